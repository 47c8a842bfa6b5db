"""What the viewer shows: a model, the poses it takes, the measured markers and the residuals.

Symbols: T frames, M markers (the model's sites, in model order), nq the model's position size.
Units: metres and seconds inside; residuals are reported in millimetres only in text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import mujoco
import numpy as np

from mocap_mj.capture.marker_set import undetermined_segments
from mocap_mj.errors import InputFileError, MocapError, ShapeError
from mocap_mj.outputs.write_fit import frame_range
from mocap_mj.pipeline.motion import Motion, load_motion
from mocap_mj.pipeline.trials import open_trial
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.mjcf import load_model, model_path

__all__ = [
    "UNMEASURED_RGBA",
    "Ghost",
    "Playback",
    "frame_label",
    "load_ghost",
    "load_playback",
    "marker_positions",
    "parse_frame",
    "parse_frames",
]


#: The colour of a segment no recorded marker measures: grey and translucent.
UNMEASURED_RGBA = (0.6, 0.6, 0.6, 0.25)


def grey_unmeasured(model: mujoco.MjModel, bodies: tuple[str, ...]) -> None:
    """Draw the geoms of ``bodies`` (segments not measured) grey and translucent
    (:data:`UNMEASURED_RGBA`) in ``model``, the viewer's own copy."""
    ids = {model.body(b).id for b in bodies}
    for g in range(model.ngeom):
        if int(model.geom_bodyid[g]) in ids and int(model.geom_matid[g]) < 0:
            model.geom_rgba[g] = UNMEASURED_RGBA


def marker_positions(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Positions (T, M, 3) [m] of the model's sites for every pose of qpos (T, nq); NaN in
    a frame without a pose (NaN qpos: not solved)."""
    data = mujoco.MjData(model)
    out = np.full((len(qpos), model.nsite, 3), np.nan)
    for t, q in enumerate(qpos):
        if not np.isfinite(q).all():
            continue
        data.qpos[:] = q
        rolling.kinematics(model, data)
        out[t] = data.site_xpos
    return out


@dataclass(frozen=True, eq=False)
class Playback:
    """A model, a trajectory of its poses and the markers measured at each frame.

    Attributes
    ----------
    model : mujoco.MjModel
        The model the poses belong to (the viewer's and renderers' own copy).
    model_path : Path
        Its MJCF file.
    qpos : (T, nq) float [m, quaternion, rad]
        Pose of every frame.
    times : (T,) float [s]
        Time of every frame, increasing.
    measured : (T, M, 3) float [m]
        Measured marker positions in model site order, NaN where missing.
    marker_names : tuple of str, (M,)
        The model's site names.
    fitted : bool
        True when ``qpos`` was fitted to ``measured`` (a result folder), so that residuals and
        the marker RMSE mean something; False for markers shown on a model at rest.
    source : str
        Where the data came from, for summaries.
    first_frame : int
        The recording's number of frame 0 (labels give the recording's frame numbers).
    predicted : (T, M, 3) float [m]
        The model's marker sites at each pose (computed; NaN in a frame not solved).
    """

    model: mujoco.MjModel
    model_path: Path
    qpos: np.ndarray
    times: np.ndarray
    measured: np.ndarray
    marker_names: tuple[str, ...]
    fitted: bool = True
    source: str = ""
    first_frame: int = 0
    predicted: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        n = len(self.qpos)
        if n == 0:
            raise ShapeError("the motion has no frames")
        if self.qpos.shape != (n, self.model.nq):
            raise ShapeError(
                f"qpos: expected shape ({n}, {self.model.nq}) for {self.model_path}, "
                f"got {self.qpos.shape}"
            )
        if self.times.shape != (n,) or self.measured.shape != (n, self.model.nsite, 3):
            raise ShapeError(
                f"times/markers: expected ({n},) and ({n}, {self.model.nsite}, 3), "
                f"got {self.times.shape} and {self.measured.shape}"
            )
        if n > 1 and not np.all(np.diff(self.times) > 0):
            raise InputFileError(f"{self.source}: frame times are not increasing")
        object.__setattr__(self, "predicted", marker_positions(self.model, self.qpos))
        if self.fitted:
            grey_unmeasured(self.model, self.unmeasured_bodies)

    @cached_property
    def solved(self) -> np.ndarray:
        """(T,) bool: the frames with a pose (a frame the IK could not solve is NaN: no
        data, drawn as such)."""
        return np.asarray(np.isfinite(self.qpos).all(axis=1))

    @cached_property
    def unmeasured_bodies(self) -> tuple[str, ...]:
        """The model's bodies no recorded marker determines (:func:`undetermined_segments`
        of the markers with any sample): their pose is the prior's, not measured."""
        present = [n for n, seen in zip(self.marker_names, np.isfinite(self.measured).any(
            axis=(0, 2)), strict=True) if seen]  # fmt: skip
        return undetermined_segments(self.model, present)

    @cached_property
    def _alpha(self) -> np.ndarray:
        """(ngeom,) the geoms' alpha as shown for a solved frame (:meth:`show_body`)."""
        return np.array(self.model.geom_rgba[:, 3])

    def show_body(self, shown: bool) -> None:
        """Show, or hide (fully transparent, for a frame not solved), the body's geoms in the
        model, the viewer's own copy."""
        body, alpha = np.asarray(self.model.geom_bodyid) > 0, self._alpha
        self.model.geom_rgba[body, 3] = alpha[body] if shown else 0.0

    def first_solved(self) -> int:
        """The first frame with a pose (0 when none has)."""
        found = np.flatnonzero(self.solved)
        return int(found[0]) if len(found) else 0

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return len(self.qpos)

    @cached_property
    def residuals(self) -> np.ndarray:
        """Distance (T, M) [m] between each measured marker and its model site, NaN if missing.

        Computed once; read-only.
        """
        res = np.linalg.norm(self.measured - self.predicted, axis=2)
        res.setflags(write=False)
        return res

    @cached_property
    def frame_rmse(self) -> np.ndarray:
        """Marker RMSE (T,) [m] of each frame over its visible markers (NaN if none is).

        Computed once; read-only.
        """
        res = self.residuals
        seen = np.isfinite(res)
        count = seen.sum(axis=1)
        sq = np.where(seen, res, 0.0) ** 2
        rmse = np.full(len(res), np.nan)
        np.sqrt(sq.sum(axis=1) / np.maximum(count, 1), out=rmse, where=count > 0)
        rmse.setflags(write=False)
        return rmse

    @cached_property
    def worst_frame(self) -> int:
        """Index of the frame with the largest marker RMSE (0 if no frame has markers)."""
        rmse = self.frame_rmse
        return int(np.nanargmax(rmse)) if np.any(np.isfinite(rmse)) else 0

    @property
    def rate(self) -> float:
        """Frame rate [Hz] from the median frame interval (30 for a single frame)."""
        if self.n_frames < 2:
            return 30.0
        return float(1.0 / np.median(np.diff(self.times)))


def _markers_by_name(
    names: tuple[str, ...], positions: np.ndarray, sites: tuple[str, ...], source: str
) -> np.ndarray:
    """Reorder measured markers (T, N, 3) to the model's site order (T, M, 3), NaN if absent."""
    if names == sites:
        return positions
    common = [n for n in names if n in sites]
    if not common:
        raise InputFileError(
            f"{source}: none of its markers ({', '.join(names[:8])}...) is a site of the model"
        )
    out = np.full((len(positions), len(sites), 3), np.nan)
    index = {n: i for i, n in enumerate(names)}
    for s, name in enumerate(sites):
        if name in index:
            out[:, s] = positions[:, index[name]]
    return out


def _site_names(model: mujoco.MjModel) -> tuple[str, ...]:
    return tuple(model.site(i).name for i in range(model.nsite))


def _from_motion(
    model: mujoco.MjModel, path: Path, motion: Motion, source: str, fitted: bool
) -> Playback:
    if motion.qpos.shape[1] != model.nq:
        raise ShapeError(
            f"{source}: qpos has {motion.qpos.shape[1]} coordinates per frame, "
            f"the model {path} has nq = {model.nq}"
        )
    sites = _site_names(model)
    measured = _markers_by_name(motion.marker_names, motion.markers, sites, source)
    return Playback(
        model, path, motion.qpos, motion.times, measured, sites, fitted, source, motion.first_frame
    )


def load_playback(
    result_dir: str | Path | None = None,
    *,
    model: str | Path | None = None,
    motion: str | Path | None = None,
    markers: str | Path | None = None,
    trial: str | None = None,
) -> Playback:
    """Load what to show from a result folder, or from a model with a motion and/or markers.

    Parameters
    ----------
    result_dir : path, optional
        A result folder (``model.xml`` + ``motion.npz``) or a synthetic-truth folder.
    model : path, optional
        MJCF file (the bundled humanoid if neither this nor ``result_dir`` is given).
    motion : path, optional
        A ``motion.npz`` for ``model``: its poses and markers.
    markers : path, optional
        A marker file (any format ``mocap_mj.io.load_markers`` reads). Without ``motion`` the
        model stands at its reference pose ``qpos0`` in every frame and residuals are not
        shown; with ``motion`` it replaces the motion's markers (same number of frames).
    trial : str, optional
        Which trial of a multi-trial result: its index or name
        (:func:`mocap_mj.pipeline.trials.open_trial`; default the first).

    Returns
    -------
    Playback

    Raises
    ------
    MocapError
        On a missing or unreadable file, or data that do not fit the model.
    """
    if result_dir is not None:
        if model is not None or motion is not None or markers is not None:
            raise MocapError("give either a result folder or --model/--motion/--markers")
        res = open_trial(result_dir, trial)
        mj_model = load_model(res.model)
        motion_ = load_motion(res.motion, mj_model, res.model)
        return _from_motion(mj_model, res.model, motion_, str(res.root), True)
    if trial is not None:
        raise MocapError("--trial: only with a result folder")
    if motion is None and markers is None:
        raise MocapError("nothing to show: give a result folder, --motion or --markers")
    path = Path(model) if model is not None else model_path()
    mj_model = load_model(path)
    sites = _site_names(mj_model)
    traj_pos: np.ndarray | None = None
    traj_times: np.ndarray | None = None
    if markers is not None:
        try:
            from mocap_mj.io import load_markers
        except ImportError as exc:  # the reader package is optional for the viewer
            raise MocapError(f"cannot read marker files: {exc}") from None
        traj = load_markers(markers)
        traj_pos = _markers_by_name(
            tuple(traj.names), np.asarray(traj.positions), sites, str(markers)
        )
        traj_times = np.asarray(traj.times, dtype=float)
    if motion is not None:
        pb = _from_motion(mj_model, path, load_motion(motion, mj_model, path), str(motion), True)
        if traj_pos is None:
            return pb
        if len(traj_pos) != pb.n_frames:
            raise ShapeError(
                f"{markers}: {len(traj_pos)} frames, but the motion {motion} has {pb.n_frames}"
            )
        return Playback(
            mj_model, path, pb.qpos, pb.times, traj_pos, sites, True, str(markers), pb.first_frame
        )
    assert traj_pos is not None and traj_times is not None
    qpos = np.tile(np.array(mj_model.qpos0), (len(traj_pos), 1))
    return Playback(mj_model, path, qpos, traj_times, traj_pos, sites, False, str(markers))


@dataclass(eq=False)
class Ghost:
    """A second model drawn translucent in the pose of the main one (e.g. nominal or truth).

    Attributes
    ----------
    model : mujoco.MjModel
    data : mujoco.MjData
        Posed by :meth:`pose` (kinematics only).
    path : Path
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    path: Path

    def pose(self, qpos: np.ndarray) -> None:
        """Put the ghost in pose ``qpos`` (nq,) and compute its geom placements."""
        self.data.qpos[:] = qpos
        rolling.kinematics(self.model, self.data)


def load_ghost(spec: str, main: mujoco.MjModel, result_dir: str | Path | None = None) -> Ghost:
    """Load the ghost model named by ``spec``.

    Parameters
    ----------
    spec : str
        An MJCF path, ``"nominal"`` (the bundled humanoid) or ``"truth"`` (the
        ``truth_model.xml`` of a synthetic experiment, looked for in ``result_dir``, its
        ``synth/`` folder and the ``synth/`` beside it, as in a demo folder).
    main : mujoco.MjModel
        The model whose poses the ghost takes: the two must have the same ``nq``.
    result_dir : path, optional
        Where ``"truth"`` is looked for.
    """
    if spec == "nominal":
        path = model_path()
    elif spec == "truth":
        roots = [Path(result_dir)] if result_dir is not None else []
        candidates = [
            p
            for r in roots
            for p in (
                r / "truth_model.xml",
                r / "synth/truth_model.xml",
                r.parent / "synth/truth_model.xml",  # RESULT_DIR is a demo folder's result/
            )
        ]
        found = [p for p in candidates if p.is_file()]
        if not found:
            where = ", ".join(str(p) for p in candidates) or "(no result folder given)"
            raise InputFileError(f"--ghost truth: no truth_model.xml at {where}")
        path = found[0]
    else:
        path = Path(spec)
    model = load_model(path)
    if model.nq != main.nq:
        raise ShapeError(f"ghost {path}: nq = {model.nq}, but the shown model has nq = {main.nq}")
    return Ghost(model, mujoco.MjData(model), path)


def _index(text: str, n: int, what: str) -> int:
    try:
        k = int(text)
    except ValueError:
        raise MocapError(f"{what}: expected a frame number, got {text!r}") from None
    if not -n <= k < n:
        raise MocapError(f"{what}: frame {k} out of range (the motion has {n} frames)")
    return k % n


def parse_frame(text: str, playback: Playback) -> int:
    """A frame index from ``"K"`` (negative counts from the end) or ``"worst"``."""
    if text.strip().lower() == "worst":
        return playback.worst_frame
    return _index(text, playback.n_frames, "--frame")


def parse_frames(text: str, n: int) -> list[int]:
    """Frame indices of a ``--frames`` text ``"A:B[:S]"`` over ``n`` frames (B exclusive;
    :func:`mocap_mj.outputs.write_fit.frame_range`, the parser of every command)."""
    frames = list(range(n))[frame_range(text, n, "the result", stride=True)]
    if not frames:
        raise MocapError(f"--frames {text}: selects no frame of the {n}")
    return frames


def frame_label(playback: Playback, frame: int) -> str:
    """One line describing a frame: the recording's frame number and time and (for a fit)
    the marker RMSE in mm, or "no data" for a frame not solved."""
    number = playback.first_frame + frame
    row = f" (row {frame})" if number != frame else ""  # --frame counts rows
    text = f"frame {number}{row}  t = {playback.times[frame]:.3f} s"
    if not playback.solved[frame]:
        return f"{text}  no data (not solved)"
    if playback.fitted:
        rmse = playback.frame_rmse[frame]
        text += "  RMSE " + ("-" if math.isnan(rmse) else f"{1000 * rmse:.1f} mm")
    return text
