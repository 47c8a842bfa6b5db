"""The result folder every computing command writes, and reading it back.

A result folder (written by ``ik``, ``identify``, ``demo``; read by ``view``, ``render``,
``export``, ``score``) holds:

``model.xml``
    MJCF of the model the motion belongs to (the identified model for ``identify``).
``motion.npz``
    ``qpos`` (T, nq) [m, unit quaternions, rad] in the layout of ``model.xml`` as MuJoCo
    compiles it (the knees' slide joints included, :mod:`mocap_mj.skeleton.exported`), ``times``
    (T,)
    [s], ``markers`` (T, M, 3) [m]: the measured markers in model site order with NaN where
    missing, ``marker_names`` (M,).
``theta.json``
    The model parameters (``ParameterSet.save_json``), when identified.
``summary.json``
    The command's summary (also printed with ``--json``).

A synthetic-truth folder (``mocap-mj synth``) holds ``truth_model.xml`` and
``truth_motion.npz`` (same keys; ``markers`` are the noise-free positions) beside the measured
``markers.csv``.
"""

from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from mocap_mj.errors import InputFileError, check_shape
from mocap_mj.io.atomic import atomic_write_bytes
from mocap_mj.skeleton.exported import Layout

if TYPE_CHECKING:
    from mocap_mj.solve.ik import IKResult


@dataclass(frozen=True)
class Motion:
    """A trajectory of model poses with the markers it was fitted to.

    Attributes
    ----------
    qpos : (T, nq) float [m, quaternion, rad]
    times : (T,) float [s]
    markers : (T, M, 3) float [m], NaN where missing (model site order)
    marker_names : tuple of str, (M,)
    ik : IKResult or None
        How each frame was solved (status, iterations, marker RMSE (T,) [m]) when the motion
        was solved here (:func:`mocap_mj.pipeline.robust_ik.solve_motion`); not saved.
    first_frame : int
        The recording's own number of frame 0 (frame i is ``first_frame + i`` in every table;
        :func:`mocap_mj.io.trajectory.first_frame`); 0 when the source numbers none.
    """

    qpos: np.ndarray
    times: np.ndarray
    markers: np.ndarray
    marker_names: tuple[str, ...]
    ik: IKResult | None = None
    first_frame: int = 0

    @property
    def frames(self) -> np.ndarray:
        """The recording's frame number of each frame (T,) int."""
        return self.first_frame + np.arange(len(self.times), dtype=np.int64)

    def __post_init__(self) -> None:
        n = len(self.qpos)
        check_shape("qpos", self.qpos, (n, None))
        check_shape("times", self.times, (n,))
        check_shape("markers", self.markers, (n, len(self.marker_names), 3))


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """An uncompressed ``.npz`` with fixed zip timestamps, so equal arrays give equal bytes
    (``np.savez`` stamps the wall-clock time into the zip entries)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            with zf.open(info, "w", force_zip64=True) as handle:
                np.lib.format.write_array(handle, np.asanyarray(value), allow_pickle=False)
    return buf.getvalue()


def save_motion(path: str | Path, motion: Motion) -> None:
    """Write a :class:`Motion` as ``.npz``, atomically and byte-reproducibly."""
    arrays = {
        "qpos": motion.qpos,
        "times": motion.times,
        "markers": motion.markers,
        "marker_names": np.array(motion.marker_names),
        "first_frame": np.array(motion.first_frame, dtype=np.int64),
    }
    atomic_write_bytes(path, npz_bytes(arrays))


def load_motion(path: str | Path, model: mujoco.MjModel | None = None) -> Motion:
    """Read a :class:`Motion` written by :func:`save_motion`. With ``model`` (the tool's
    model, :func:`mocap_mj.skeleton.mjcf.load_model`), qpos is converted to its layout
    (:meth:`mocap_mj.skeleton.exported.Layout.read`: the written slide columns dropped; a motion
    written before them read as it is); without, it is the file's."""
    path = Path(path)
    try:
        with np.load(path) as data:
            qpos = np.array(data["qpos"], dtype=float)
            if model is not None:
                qpos = Layout.of(model).read(qpos, str(path))
            return Motion(
                qpos=qpos,
                times=np.array(data["times"], dtype=float),
                markers=np.array(data["markers"], dtype=float),
                marker_names=tuple(str(n) for n in data["marker_names"]),
                first_frame=int(data["first_frame"]) if "first_frame" in data else 0,
            )
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        # A truncated or damaged .npz: BadZipFile (no zip directory), EOFError (a member cut
        # short), ValueError (not a zip: NumPy declines to unpickle it).
        raise InputFileError(
            f"{path}: not a complete motion file (an .npz with qpos, times, markers): {exc}"
        ) from None


@dataclass(frozen=True)
class ResultDir:
    """Paths of a result folder (``model.xml`` + ``motion.npz``) or a synthetic-truth folder."""

    root: Path
    model: Path
    motion: Path

    @classmethod
    def open(cls, root: str | Path) -> ResultDir:
        """The folder itself, or the ``result/`` folder of a ``mocap-mj demo`` folder."""
        root = Path(root)
        for base in (root, root / "result"):
            for model, motion in (
                ("model.xml", "motion.npz"),
                ("truth_model.xml", "truth_motion.npz"),
            ):
                if (base / model).is_file() and (base / motion).is_file():
                    return cls(base, base / model, base / motion)
        raise InputFileError(
            f"{root}: not a result folder (expected model.xml and motion.npz, "
            "truth_model.xml and truth_motion.npz, or a demo folder's result/)"
        )
