"""A long trial's IK in chunks: every frame solved ``chunk`` frames at a time under one model,
with a robust loss and per-sample weights held fixed over the pass, the poses streamed through
an array or a memory-mapped ``.npy`` (no more than one chunk's work arrays in memory)."""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import NamedTuple, TypeAlias

import numpy as np
from numpy.typing import NDArray

from mocap_mj.kernels import _schur
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve.ik import IKResult, IKSolver
from mocap_mj.solve.losses import L2, Loss, Weighted, loss_named
from mocap_mj.solve.problem import loss_threshold

from ..errors import MocapError, check_shape

#: IK chunk [frames]: 20,000 frames' poses are 9 MB, their IK working set a few tens of MB.
CHUNK = 20_000


#: Markers (T, M, 3) or poses (T, nq) of one trial, or one array per trial.
Parts: TypeAlias = NDArray[np.floating] | Sequence[NDArray[np.floating]]


#: Per-sample weights (n, M) [1] of the poses (n, nq) they are given (1 for NaN rows), e.g.
#: the landmarks' soft-tissue sliding (:meth:`mocap_mj.anatomy.tissue.SlidingModel.weights`).
Weigh: TypeAlias = Callable[[np.ndarray], np.ndarray]


class Robust(NamedTuple):
    """A robust loss (:mod:`mocap_mj.solve.losses`) and its threshold c [m]
    (:func:`robust_loss`), held fixed over an IK pass and its cost, so that the cost and the
    IRLS weights are those of one problem."""

    loss: Loss
    c: float


@dataclass(frozen=True)
class FrameWeights:
    """How the samples of a pass are weighed (:func:`sample_weights`): the same as the
    identification's fit, so that a pass minimises its cost.

    Fields
    ------
    weigh : per-sample weights by pose (default None: all 1), e.g. the landmarks'
        soft-tissue sliding
    robust : a robust loss and its threshold (default None: least squares)
    """

    weigh: Weigh | None = None
    robust: Robust | None = None


def robust_loss(
    name: str, kin: Kinematics, markers: Parts, qpos: Parts, scale: float
) -> Robust | None:
    """The loss called ``name`` with the threshold the LM's last iterations used: ``scale``
    times the per-axis noise from the median marker distance of markers (T, M, 3) [m] at
    poses qpos (T, nq) (one of each per trial; NaN rows skipped) under kin's model
    (:meth:`~mocap_mj.solve.problem.IdentificationProblem.loss_scale`); None for "l2"."""
    if name == "l2":
        return None
    dist = [
        _distances(kin, np.asarray(m, dtype=float), np.asarray(q, dtype=float))
        for m, q in zip(_parts(markers), _parts(qpos), strict=True)
    ]
    return Robust(loss_named(name), loss_threshold(np.concatenate([x[p] for x, p in dist]), scale))


def _distances(kin: Kinematics, m: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distances (n, M) [m] of the markers m (n, M, 3) [m] from the model's at the poses
    q (n, nq) under kin's model, 0 where a sample is missing or its frame has no pose (NaN
    row), and where they are present (n, M) bool."""
    ok = np.isfinite(q[:, 0])
    present = np.all(np.isfinite(m), axis=2) & ok[:, None]
    d = np.zeros(present.shape)
    d[ok] = np.linalg.norm(
        kin.site_positions(q[ok]) - np.where(present[ok, :, None], m[ok], 0), axis=2
    )
    return np.where(present, d, 0.0), present


def sample_weights(
    kin: Kinematics,
    m: np.ndarray,
    q: np.ndarray,
    weigh: Weigh | None = None,
    robust: Robust | None = None,
) -> tuple[np.ndarray, float]:
    """The IRLS weights (n, M) [1] of the samples m (n, M, 3) [m] at poses q (n, nq) under
    kin's model (0 where missing or without a pose) and their cost [m^2]: the loss of
    ``robust`` (default least squares) of each distance scaled by the square root of the
    ``weigh`` weight (:class:`~mocap_mj.solve.losses.Weighted`, as the identification
    weighs a robust loss with the sliding landmarks)."""
    d, present = _distances(kin, m, q)
    base = np.ones(present.shape) if weigh is None else weigh(q)
    loss = Weighted(L2() if robust is None else robust.loss, base)
    c = np.inf if robust is None else robust.c
    return loss.weights(d, present, c), loss.value(d, present, c)


class ChunkFit(NamedTuple):
    """Sums over the solved frames of an IK pass: squared marker distances [m^2] (weighted:
    twice the cost, :func:`sample_weights`), present samples, frames."""

    sq: float
    present: int
    solved: int

    @property
    def rmse(self) -> float:
        return float(np.sqrt(self.sq / self.present)) if self.present else float("nan")


def solve_chunk(
    solver: IKSolver,
    m: np.ndarray,
    q: np.ndarray,
    warm_iterations: int | None = None,
    weigh: Weigh | None = None,
    robust: Robust | None = None,
) -> ChunkFit:
    """IK of one chunk's markers m (n, M, 3) [m] in place in q (n, nq): frames with a pose
    (finite rows) start there (warm, at most ``warm_iterations`` iterations, default the
    solver's limit; with ``weigh`` or ``robust``, weighted by the IRLS weights of their
    start poses, :func:`sample_weights`; NaN rows had too few markers and stay NaN); a chunk
    of NaN rows is solved afresh (chained, unweighted, :meth:`IKSolver.solve_trial`)."""
    warm = np.isfinite(q[:, 0])
    r: IKResult
    if warm.any():
        w = None
        if weigh is not None or robust is not None:
            w = sample_weights(solver.kin, m[warm], q[warm], weigh, robust)[0]
        r = solver.solve_frames(m[warm], q[warm], w, max_iterations=warm_iterations)
        q[warm] = r.qpos
    else:
        r = solver.solve_trial(m)
        q[:] = r.qpos
    return _fit(r)


def _fit(r: IKResult) -> ChunkFit:
    """The sums of :class:`ChunkFit` over r's solved frames."""
    ok = r.solved
    return ChunkFit(
        float(np.sum(r.marker_rmse[ok] ** 2 * r.n_markers[ok])),
        int(r.n_markers[ok].sum()),
        int(ok.sum()),
    )


def _ik_pass(
    markers: Parts,
    kin: Kinematics,
    qpos: Parts,
    chunk: int,
    gradient: bool,
    heads: Heads | None = None,
    weigh: Weigh | None = None,
    robust: Robust | None = None,
) -> tuple[ChunkFit, np.ndarray]:
    """IK of every frame under kin's theta, chunk by chunk, in place in qpos (T, nq) (or one
    such array per trial of ``markers``; :func:`solve_chunk`); with ``heads``, chunks
    without a pose are solved as chains from the heads' poses
    (:meth:`~mocap_mj.solve.ik.IKSolver.solve_from_heads`); with ``gradient``, the sum (P,) [m] of
    each chunk's reduced gradient at its new poses
    (:func:`mocap_mj.kernels._schur.reduced_gradient`, joint limits not held, see
    :func:`~mocap_mj.long.refine.refine`;
    zeros otherwise). With ``weigh`` (and ``gradient``) the gradient and the fit's squared
    distances are weighted by the samples' weights at the new poses: the reduced gradient's
    own pose step (``- J_q A^-1 g_q``) is then the weighted problem's, so the gradient is
    that problem's to first order even where the IK (heads, cold chunks) ran unweighted.
    With ``robust``, the weights are its IRLS weights and the fit's squared distances twice
    its cost (:func:`sample_weights`), alike, and the heads' chains are solved again,
    weighted, from their poses."""
    solver = IKSolver(kin)
    tree, kt = kin.tree(), kin.kappa_tables()
    grad = np.zeros(kin.pset.size)
    fit = ChunkFit(0.0, 0, 0)
    if heads is not None:
        chunk = max(heads.stride, chunk - chunk % heads.stride)  # chunks start at a head
    for span, m, q in _chunks(markers, qpos, chunk):
        if heads is not None and not np.isfinite(q[:, 0]).any():
            r = solver.solve_from_heads(m, heads.rows(span, len(m)))
            q[:] = r.qpos
            f = _fit(r)
            if robust is not None:
                # The chains ran unweighted: an outlier pulls its frame's pose by millimetres,
                # too far for the gradient's first-order pose step, and the motion's IK
                # starts here. Solved again from there under the loss's weights.
                f = solve_chunk(solver, m, q, weigh=weigh, robust=robust)
        else:
            f = solve_chunk(solver, m, q, weigh=weigh, robust=robust)
        span.qpos[span.start : span.stop] = q
        if gradient:
            present = np.all(np.isfinite(m), axis=2)
            target = np.where(present[..., None], m, 0.0)
            w = present.astype(float)
            if weigh is not None or robust is not None:
                w, cost = sample_weights(kin, m, q, weigh, robust)
                f = f._replace(sq=2.0 * cost)
            grad += _schur.reduced_gradient(tree, kt, target, w, q, limits=False)
        fit = ChunkFit(fit.sq + f.sq, fit.present + f.present, fit.solved + f.solved)
    return fit, grad


class Heads(NamedTuple):
    """Poses of every ``stride``-th frame of each trial: ``qpos`` (n, nq), the trials'
    sampled frames one trial after the other (frames 0, stride, 2 stride, ... of each), as
    :func:`~mocap_mj.long.refine.refine`'s sample holds them; NaN rows: not solved."""

    qpos: np.ndarray
    stride: int
    offsets: tuple[int, ...]  # each trial's first row in qpos

    def rows(self, span: _Span, n: int) -> np.ndarray:
        """Start poses (n, nq) of the span's frames [span.start, span.start + n): the head
        poses at the sampled frames, NaN elsewhere (span.start a multiple of stride)."""
        out = np.full((n, self.qpos.shape[1]), np.nan)
        first = self.offsets[span.trial] + span.start // self.stride
        k = len(range(0, n, self.stride))
        out[:: self.stride] = self.qpos[first : first + k]
        return out


class _Span(NamedTuple):
    """Frames [start, stop) of one trial's poses ``qpos`` (T_i, nq)."""

    trial: int
    start: int
    stop: int
    qpos: NDArray[np.floating]


def _chunks(
    markers: Parts, qpos: Parts, chunk: int
) -> Iterator[tuple[_Span, np.ndarray, np.ndarray]]:
    """Every trial's frames ``chunk`` at a time: the span, its markers (n, M, 3) [m] and a
    copy of its poses (n, nq), both in memory."""
    ms, qs = _parts(markers), _parts(qpos)
    if len(ms) != len(qs):
        raise MocapError(f"qpos: expected one array per trial ({len(ms)}), got {len(qs)}")
    for i, (mt, qt) in enumerate(zip(ms, qs, strict=True)):
        check_shape(f"qpos[{i}]", qt, (len(mt), None))
        for s in range(0, len(mt), chunk):
            e = min(s + chunk, len(mt))
            m = np.asarray(mt[s:e], dtype=float)
            yield _Span(i, s, e, qt), m, np.array(qt[s:e], dtype=float)


def _parts(x: Parts) -> list[NDArray[np.floating]]:
    """One array, or one per trial, as a list."""
    return [x] if isinstance(x, np.ndarray) else list(x)


def _fill(qpos: Parts, rows: np.ndarray) -> None:
    """Copy rows (T, nq), every trial's frames one after the other, into qpos (per trial)."""
    k = 0
    for q in _parts(qpos):
        q[:] = rows[k : k + len(q)]
        k += len(q)


def scratch_array(shape: tuple[int, int]) -> NDArray[np.floating]:
    """A float array of ``shape`` filled with NaN: in memory up to ``CHUNK`` rows, else a
    memory map on an anonymous temporary file (the poses of an hour, 160 MB, are paged by
    the system rather than held; the file disappears with the array)."""
    if shape[0] <= CHUNK:
        return np.full(shape, np.nan)
    arr = np.memmap(tempfile.TemporaryFile(prefix="mocap-mj-"), float, "w+", shape=shape)
    for s in range(0, shape[0], CHUNK):
        arr[s : s + CHUNK] = np.nan
    return arr
