"""Every frame's motion written chunk by chunk: motion.npz and joint_centres.csv of a long trial.

``identify`` with a selection (the recipe's ``select``) solves the IK of every frame of a
recording that may hold an hour (360,000 frames): its poses, markers and joint-centre table
would take about a gigabyte in memory at once. Here the IK runs ``chunk`` frames at a time and
each chunk goes straight into the files: motion.npz is a zip of ``.npy`` members (as
:func:`mocap_mj.pipeline.motion.save_motion` writes it, byte for byte: uncompressed, fixed
timestamps),
each member's header written by numpy's ``.npy`` header writer and its rows appended as they
come; joint_centres.csv is appended chunk by chunk
(:func:`mocap_mj.skeleton.joint_centre_table.joint_centre_text`,
the whole table's formatting), angles.csv from the written motion
(:mod:`mocap_mj.long.angles_out`). All are written under a temporary name and renamed
when complete (:func:`mocap_mj.io.atomic.atomic_path`)."""

from __future__ import annotations

import contextlib
import time
import zipfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, NamedTuple

import mujoco
import numpy as np
from numpy.typing import NDArray

from mocap_mj.long.angles_out import write_angle_chunks
from mocap_mj.long.chunks import CHUNK, ChunkFit, FrameWeights, solve_chunk
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.joint_centre_table import joint_centre_columns, joint_centre_text
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, solver_joint_range
from mocap_mj.solve.problem import TrialData

from ..io.atomic import atomic_path
from ..io.ownership import scratch_folder

#: LM iterations of each frame started from the refinement's poses (``start``): those are
#: the converged IK under a model a fraction of a millimetre from the written one, and one
#: Gauss-Newton step from there lands where the converged solve would stop, within its own
#: tolerance (docs/method.md#long-recordings), at a fraction of its time.
WARM_ITERATIONS = 1


class MotionFit(NamedTuple):
    """Sums over the solved frames of the motion: squared marker distances [m^2], present
    samples, solved frames, all frames; wall time [s] in the IK and in all."""

    sq: float
    present: int
    solved: int
    frames: int
    ik_seconds: float = 0.0
    seconds: float = 0.0

    @property
    def rmse(self) -> float:
        """Marker RMSE [m] over every present sample of the solved frames."""
        return float(np.sqrt(self.sq / self.present)) if self.present else float("nan")


@contextlib.contextmanager
def npy_member(
    zf: zipfile.ZipFile, name: str, shape: tuple[int, ...], dtype: np.dtype
) -> Iterator[Callable[[np.ndarray], None]]:
    """Write the zip member ``name`` (``.npy``) of an array of ``shape`` and ``dtype`` whose
    C-order rows are appended by the yielded function; refuse a member whose rows do not add
    up to ``shape``."""
    info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
    expected = int(np.prod(shape)) * dtype.itemsize
    written = 0
    with zf.open(info, "w", force_zip64=True) as handle:
        header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False}
        np.lib.format.write_array_header_1_0(handle, {**header, "shape": shape})

        def append(rows: np.ndarray) -> None:
            nonlocal written
            data = np.ascontiguousarray(rows, dtype=dtype).tobytes()
            written += len(data)
            handle.write(data)

        yield append
    if written != expected:
        raise ValueError(f"{name}.npy: expected {expected} bytes of rows, got {written}")


def _zip(path: Path) -> zipfile.ZipFile:
    return zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True)


def write_motion_chunks(
    path: Path,
    trial: TrialData,
    names: Sequence[str],
    nq: int,
    poses: Iterator[np.ndarray],
    chunk: int = CHUNK,
    first_frame: int = 0,
) -> None:
    """motion.npz of ``trial`` (its times (T,) [s] and markers (T, M, 3) [m], read ``chunk``
    frames at a time) with the poses (T, nq) that ``poses`` yields chunk by chunk, in the
    member order of :func:`mocap_mj.pipeline.motion.save_motion`; ``first_frame``: the recording's
    number of frame 0."""
    n = len(trial.markers)
    with atomic_path(path) as tmp, _zip(tmp) as zf:
        with npy_member(zf, "qpos", (n, nq), np.dtype(float)) as append:
            for q in poses:
                append(q)
        with npy_member(zf, "times", (n,), np.dtype(float)) as append:
            append(np.asarray(trial.times, dtype=float))
        m_shape = (n, *trial.markers.shape[1:])
        with npy_member(zf, "markers", m_shape, np.dtype(float)) as append:
            for s in range(0, n, chunk):
                append(np.asarray(trial.markers[s : s + chunk], dtype=float))
        labels = np.array(list(names))
        with npy_member(zf, "marker_names", labels.shape, labels.dtype) as append:
            append(labels)
        with npy_member(zf, "first_frame", (), np.dtype(np.int64)) as append:
            append(np.array(first_frame, dtype=np.int64))


class _CentresTable:
    """joint_centres.csv appended chunk by chunk (header first)."""

    def __init__(self, handle: IO[bytes], model: mujoco.MjModel, first_frame: int) -> None:
        self.handle, self.model, self.next = handle, model, first_frame
        handle.write((",".join(joint_centre_columns()) + "\n").encode())

    def append(self, times: np.ndarray, qpos: np.ndarray) -> None:
        text, _ = joint_centre_text(self.model, times, qpos, first_frame=self.next)
        self.handle.write(text)
        self.next += len(qpos)


@dataclass(frozen=True)
class MotionOptions:
    """How :func:`write_every_frame_motion` and :func:`every_frame_motion` solve every frame.

    Fields
    ------
    start : per trial (T_i, nq), poses the chunk's frames start from (finite rows, e.g. the
        refinement's: warm, ``WARM_ITERATIONS`` LM iterations each); default None and NaN
        chunks: solved afresh, chained through each chunk (:meth:`IKSolver.solve_trial`, as
        ``mocap-mj ik`` solves a trial)
    weighing : the warm frames' weights at their start poses
        (:func:`mocap_mj.long.chunks.solve_chunk`), as the identification weighed its fit
        (its soft-tissue sliding model, its robust loss and threshold); default: all 1,
        least squares
    chunk : frames per IK chunk
    progress : called with the frames done over all trials (default None)
    """

    start: Sequence[NDArray[np.floating]] | None = None
    weighing: FrameWeights = field(default_factory=FrameWeights)
    chunk: int = CHUNK
    progress: Callable[[int], None] | None = None


def write_every_frame_motion(
    out: Path,
    pset: ParameterSet,
    theta: np.ndarray,
    settings: LMSettings,
    trials: Sequence[TrialData],
    *,
    first_frames: Sequence[int] | None = None,
    options: MotionOptions = MotionOptions(),
) -> MotionFit:
    """IK of every frame of ``trials`` with the model as ``identify`` writes it (parameters
    theta (P,) [m], the joint limits the solver used), written chunk by chunk into
    ``out``/motion.npz (in model.xml's layout, :class:`mocap_mj.skeleton.exported.Layout`) and
    joint_centres.csv (``motion_<i>.npz``, ``joint_centres_<i>.csv`` for the other trials),
    and the first trial's angles.csv (:mod:`mocap_mj.long.angles_out`); returns the fit
    over every frame.

    ``first_frames``: each trial's first frame in its file (the CSV's frame column; default
    0). ``options``: the start poses, weighing, chunk and progress callback
    (:class:`MotionOptions`)."""
    solver = _written_solver(pset, theta, settings)
    layout = Layout.of(solver.kin.model)
    model = pset.model_for(theta)
    t0 = time.perf_counter()
    firsts = list(first_frames) if first_frames is not None else [0] * len(trials)
    tally = _Tally(options.progress)
    for i, (trial, first) in enumerate(zip(trials, firsts, strict=True)):
        suffix = "" if i == 0 else f"_{i}"
        q0 = options.start[i] if options.start is not None else None
        with (
            atomic_path(out / f"joint_centres{suffix}.csv") as tmp_csv,
            open(tmp_csv, "wb") as handle,
        ):
            table = _CentresTable(handle, model, first)
            poses = _solved(solver, trial, q0, table, tally, options)
            write_motion_chunks(
                out / f"motion{suffix}.npz",
                trial,
                pset.marker_names,
                layout.nq_written,
                (layout.written(q) for q in poses),
                options.chunk,
                first,
            )
        if i == 0:  # the first trial's angles, as write_result writes them
            write_angle_chunks(out / "angles.csv", model, out / "motion.npz", first, options.chunk)
    return tally.fit._replace(seconds=time.perf_counter() - t0)


def every_frame_motion(
    pset: ParameterSet,
    theta: np.ndarray,
    settings: LMSettings,
    trials: Sequence[TrialData],
    *,
    options: MotionOptions = MotionOptions(),
) -> tuple[list[np.ndarray], MotionFit]:
    """:func:`write_every_frame_motion` held in memory: every frame's pose (T_i, nq) per
    trial (the same poses, solved chunk by chunk alike) and the fit over every frame."""
    solver = _written_solver(pset, theta, settings)
    t0 = time.perf_counter()
    tally = _Tally(options.progress)
    poses = []
    for i, trial in enumerate(trials):
        q0 = options.start[i] if options.start is not None else None
        chunks = _solved(solver, trial, q0, None, tally, options)
        poses.append(np.concatenate([np.zeros((0, solver.kin.nq)), *chunks]))
    return poses, tally.fit._replace(seconds=time.perf_counter() - t0)


def _written_solver(pset: ParameterSet, theta: np.ndarray, settings: LMSettings) -> IKSolver:
    """The IK of the model as ``identify`` writes it: parameters theta (P,) [m], the joint
    limits the solver used (:func:`solver_joint_range`), read back from its MJCF."""
    with scratch_folder() as tmp:
        path = Path(tmp) / "model.xml"
        pset.export_mjcf(path, theta, joint_range=solver_joint_range(pset.model, settings))
        written = ParameterSet(path)
    return IKSolver(Kinematics(written))


class _Tally:
    """The motion's fit so far, and the progress callback (frames done)."""

    def __init__(self, progress: Callable[[int], None] | None) -> None:
        self.fit, self.progress = MotionFit(0.0, 0, 0, 0), progress

    def add(self, f: ChunkFit, frames: int, seconds: float) -> None:
        self.fit = MotionFit(
            self.fit.sq + f.sq,
            self.fit.present + f.present,
            self.fit.solved + f.solved,
            self.fit.frames + frames,
            self.fit.ik_seconds + seconds,
        )
        if self.progress is not None:
            self.progress(self.fit.frames)


def _solved(
    solver: IKSolver,
    trial: TrialData,
    q0: NDArray[np.floating] | None,
    table: _CentresTable | None,
    tally: _Tally,
    options: MotionOptions,
) -> Iterator[np.ndarray]:
    """The trial's poses (n, nq) chunk by chunk (:func:`mocap_mj.long.chunks.solve_chunk`:
    warm from q0's finite rows (T, nq), else chained; weighed and chunked by ``options``),
    each also appended to the centres table (when given)."""
    nq, chunk = solver.kin.nq, options.chunk
    weigh, robust = options.weighing.weigh, options.weighing.robust
    for s in range(0, len(trial.markers), chunk):
        m = np.asarray(trial.markers[s : s + chunk], dtype=float)
        q = np.array(q0[s : s + chunk], dtype=float) if q0 is not None else None
        q = q if q is not None else np.full((len(m), nq), np.nan)
        t0 = time.perf_counter()
        f = solve_chunk(solver, m, q, WARM_ITERATIONS, weigh, robust)
        tally.add(f, len(m), time.perf_counter() - t0)
        if table is not None:
            table.append(np.asarray(trial.times[s : s + chunk], dtype=float), q)
        yield q
