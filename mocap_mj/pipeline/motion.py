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
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from mocap_mj import arguments
from mocap_mj.errors import ArgumentTypeError, InputFileError, ShapeError, check_shape, excerpt
from mocap_mj.io.atomic import atomic_write_bytes
from mocap_mj.io.strict_json import read_object
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
        motion_fields(self)
        n = len(self.qpos)
        check_shape("qpos", self.qpos, (n, None))
        check_shape("times", self.times, (n,))
        check_shape("markers", self.markers, (n, len(self.marker_names), 3))


def motion_fields(motion: Motion) -> None:
    """Check a :class:`Motion`'s fields (:mod:`mocap_mj.arguments`) and convert array-likes:
    qpos (T, nq) and markers (T, M, 3) numbers (NaN where not solved or not seen), times
    (T,) finite and increasing [s], marker_names texts (a list becomes a tuple), first_frame a whole
    number >= 0. A numeric array keeps its dtype (a file's)."""
    for name, axes in (("qpos", (None, None)), ("times", (None,)), ("markers", (None, None, 3))):
        value = arguments.array(
            f"Motion {name}", getattr(motion, name), axes, missing=name != "times",
            keep=True,
        )  # fmt: skip
        object.__setattr__(motion, name, value)
    arguments.increasing("Motion times", motion.times)
    names = arguments.sequence("Motion marker_names", motion.marker_names, "marker names")
    if not all(isinstance(n, str) for n in names):
        raise ArgumentTypeError(f"Motion marker_names: expected texts, got {excerpt(names)}")
    object.__setattr__(motion, "marker_names", tuple(names))
    if motion.markers.shape[1] != len(names):
        raise ShapeError(
            f"Motion markers: expected one column per marker_names entry ({len(names)}), "
            f"got shape {motion.markers.shape}"
        )
    first = arguments.whole("Motion first_frame", motion.first_frame, low=0)
    object.__setattr__(motion, "first_frame", first)


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


#: Largest magnitude of a motion file's qpos and markers [m or rad]: a pose or marker 1 km
#: from the origin (or a joint turned by 160 turns) is no recording's, a value such as 1e30 a
#: corrupt file's.
MOTION_LIMIT = 1e3
#: How far a free or ball joint's quaternion may be from unit norm in a motion file.
QUAT_TOLERANCE = 1e-3


def load_motion(
    path: str | Path, model: mujoco.MjModel | None = None, model_path: str | Path | None = None
) -> Motion:
    """Read a :class:`Motion` written by :func:`save_motion`. With ``model`` (the tool's
    model, :func:`mocap_mj.skeleton.mjcf.load_model`), qpos is converted to its layout
    (:meth:`mocap_mj.skeleton.exported.Layout.read`: the written slide columns dropped; a motion
    written before them read as it is) and its quaternions checked; without, it is the file's.

    Every array is checked before it is used (:func:`check_motion_arrays`): a truncated file,
    another dtype or shape, values beyond :data:`MOTION_LIMIT`, times that do not increase
    or no frame raise :class:`~mocap_mj.errors.InputFileError`, one line naming the file and
    what was expected; ``model_path`` (the file of ``model``) is named too when the motion's
    columns are not of that model."""
    path = Path(path)
    try:
        with np.load(path) as data:
            arrays = {k: np.asarray(data[k]) for k in data.files}
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        # A truncated or damaged .npz: BadZipFile (no zip directory), EOFError (a member cut
        # short), ValueError (not a zip: NumPy declines to unpickle it).
        raise InputFileError(
            f"{path}: not a complete motion file (an .npz with qpos, times, markers): "
            f"{' '.join(str(exc).split())[:120]}"
        ) from None
    motion = check_motion_arrays(arrays, str(path))
    if model is None:
        return motion
    try:
        qpos = Layout.of(model).read(motion.qpos, str(path))
    except InputFileError as exc:
        if model_path is None:
            raise
        raise InputFileError(f"{exc}: {model_path} is not this motion's model") from None
    _check_quaternions(model, qpos, str(path))
    return Motion(qpos, motion.times, motion.markers, motion.marker_names, None, motion.first_frame)


def check_motion_arrays(arrays: dict[str, np.ndarray], source: str) -> Motion:
    """The :class:`Motion` of a motion file's arrays (``qpos``, ``times``, ``markers``,
    ``marker_names``, optional ``first_frame``), each checked for presence, dtype, shape and
    values; :class:`~mocap_mj.errors.InputFileError` naming ``source`` otherwise.

    The rules: qpos (T, C) and markers (T, M, 3) real numbers within ``MOTION_LIMIT``, a qpos
    row either every value or NaN only (a frame not solved), at least one solved frame; times
    (T,) finite and strictly increasing, T >= 1; marker_names (M,) text; first_frame an
    integer >= 0."""
    missing = [k for k in ("qpos", "times", "markers", "marker_names") if k not in arrays]
    if missing:
        raise InputFileError(f"{source}: a motion file without {', '.join(missing)}")
    qpos, times, markers = arrays["qpos"], arrays["times"], arrays["markers"]
    for name, value in (("qpos", qpos), ("times", times), ("markers", markers)):
        if value.dtype.kind not in "fiu":
            raise InputFileError(
                f"{source}: {name}: expected real numbers, got dtype {value.dtype}"
            )
    n = len(times) if times.ndim == 1 else -1
    if n < 1:
        what = "no frames" if n == 0 else f"shape {times.shape}"
        raise InputFileError(f"{source}: times: expected (T,) with T >= 1 frames, got {what}")
    names = arrays["marker_names"]
    if names.ndim != 1 or names.dtype.kind not in "US":
        raise InputFileError(
            f"{source}: marker_names: expected (M,) text, got {names.dtype} {names.shape}"
        )
    for name, value, shape in (
        ("qpos", qpos, (n, None)),
        ("markers", markers, (n, len(names), 3)),
    ):
        if value.ndim != len(shape) or any(
            s is not None and s != v for s, v in zip(shape, value.shape, strict=True)
        ):
            want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            raise InputFileError(f"{source}: {name}: expected shape {want}, got {value.shape}")
    times = times.astype(float)
    qpos, markers = qpos.astype(float), markers.astype(float)
    if not np.all(np.isfinite(times)):
        raise InputFileError(f"{source}: times: expected finite seconds, got NaN or inf")
    if n > 1 and not np.all(np.diff(times) > 0):
        k = int(np.argmin(np.diff(times) > 0))
        raise InputFileError(
            f"{source}: times: expected strictly increasing seconds, got {times[k]:.6g} then "
            f"{times[k + 1]:.6g} in rows {k}, {k + 1}"
        )
    rows = np.isfinite(qpos)
    partial = np.flatnonzero(rows.any(axis=1) & ~rows.all(axis=1))
    if len(partial) or np.isinf(qpos).any():
        k = int(partial[0]) if len(partial) else int(np.flatnonzero(np.isinf(qpos).any(axis=1))[0])
        raise InputFileError(
            f"{source}: qpos: row {k}: expected every value finite (or NaN only: not solved)"
        )
    if not rows.all(axis=1).any():
        raise InputFileError(f"{source}: qpos: expected at least one solved frame, got none")
    for name, value in (("qpos", qpos), ("markers", markers)):
        if np.isinf(value).any() or np.nanmax(np.abs(value), initial=0.0) > MOTION_LIMIT:
            raise InputFileError(
                f"{source}: {name}: expected values within +-{MOTION_LIMIT:g} m or rad (NaN "
                f"where missing), got {np.nanmax(np.abs(value)):.3g}"
            )
    first = arrays.get("first_frame", np.array(0))
    if first.shape != () or first.dtype.kind not in "iu" or int(first) < 0:
        raise InputFileError(
            f"{source}: first_frame: expected an integer >= 0, got {excerpt(first.tolist())}"
        )
    return Motion(qpos, times, markers, tuple(str(s) for s in names), None, int(first))


def _check_quaternions(model: mujoco.MjModel, qpos: np.ndarray, source: str) -> None:
    """Refuse a free or ball joint's quaternion that is not of unit norm in a solved frame."""
    solved = qpos[np.isfinite(qpos).all(axis=1)]
    free, ball = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        if kind not in (free, ball):
            continue
        start = int(model.jnt_qposadr[j]) + (3 if kind == free else 0)
        norm = np.linalg.norm(solved[:, start : start + 4], axis=1)
        if np.any(np.abs(norm - 1.0) > QUAT_TOLERANCE):
            raise InputFileError(
                f"{source}: qpos: joint {model.joint(j).name!r}: expected a unit quaternion, "
                f"got norm {norm[np.argmax(np.abs(norm - 1.0))]:.6g}"
            )


def read_summary(path: str | Path) -> dict[str, Any]:
    """A result's ``summary.json``, with the fields a reader uses checked:
    ``measurements`` a mapping of name to ``{"value": number, "unit": text, ...}`` and
    ``exit_status`` an integer, when present; :class:`InputFileError` naming the file and the
    field otherwise."""
    summary = read_object(path, "the result's summary (a JSON object)")
    measurements = summary.get("measurements", {})
    if not isinstance(measurements, dict):
        raise InputFileError(
            f"{path}: measurements: expected a mapping of measurement names to values, "
            f"got {excerpt(measurements)}"
        )
    for name, entry in measurements.items():
        ok = isinstance(entry, dict) and isinstance(entry.get("unit", ""), str)
        value = entry.get("value") if isinstance(entry, dict) else None
        if not ok or isinstance(value, bool) or not isinstance(value, int | float):
            raise InputFileError(
                f"{path}: measurements: {excerpt(name)}: expected {{value: number, unit: "
                f"text}}, got {excerpt(entry)}"
            )
    status = summary.get("exit_status", 0)
    if isinstance(status, bool) or not isinstance(status, int):
        raise InputFileError(f"{path}: exit_status: expected an integer, got {excerpt(status)}")
    return summary


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
