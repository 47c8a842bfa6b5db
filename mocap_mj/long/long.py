"""Long recordings: identify on a pose-diverse subset, refine on every frame, IK in chunks.

Identification on all frames of an hour at 100 Hz (360,000 frames) by the joint LM costs
many minutes. A subset of about a thousand pose-diverse frames
(:mod:`mocap_mj.solve.selection`) gives a consistent estimate cheaply, but its error is
that of a thousand frames, not of the hour. :func:`identify_long` therefore

1. selects ``count`` frames by pose diversity,
2. identifies the model on them (the joint LM, initial model scaled and its markers placed
   from the selected frames, as ``mocap-mj identify`` does by default),
3. refines the model on every frame (:func:`refine`): the one-step estimator (Le Cam),
   with its start brought closer first. One Gauss-Newton step on the reduced system of
   *every* frame, ``theta_1 = theta_0 + S^-1 g``, is asymptotically efficient from a
   root-n-consistent start theta_0; g, the reduced gradient
   (:func:`mocap_mj.kernels._schur.reduced_gradient`), is summed over every frame at its IK pose
   under theta_0 in one streamed pass, and S, the reduced information, only has to be a
   consistent estimate, so it comes from an evenly spaced sample, scaled. From the subset's
   estimate the step was not enough: directions the subset barely determined start
   millimetres away, where the curvature changes over the step. So theta_0 is first
   brought to the sample's own optimum by Gauss-Newton steps on the sample (``sample``
   frames, default 20,000; the information recomputed at every step: kept fixed, the steps
   diverged), which costs a fraction of a pass over every frame; the last step is the
   one on every frame. Joint limits are not held in these steps (g and S of the problem
   without limits, like the Cramer-Rao bound): held, the set of frames at a limit changed
   with theta and the steps oscillated or diverged. The sample's gradient, information and
   cost are scaled to every frame, so that priors (``identify``'s landmark rows, its box)
   weigh against the whole recording; a sample step that raises that cost is taken back and
   the next one damped (Levenberg-Marquardt): on a real trial with its priors the undamped
   steps did not converge (docs/method.md#long-recordings). The pass over every frame solves
   each frame's IK as a chain from the nearest earlier frame of the sample, whose pose
   under the same model the sample's last step has
   (:meth:`~mocap_mj.solve.ik.IKSolver.solve_from_heads`): no chain starts cold,
4. solves the IK of every frame with the refined model, warm-started from the poses of
   the pass of step 3 (theta moved by a fraction of a millimetre: about two iterations per
   frame).

Steps 3 and 4 stream ``chunk`` frames at a time through ``qpos_out`` (an array or a
memory-mapped ``.npy``): no more than one chunk's poses and per-frame work arrays are in
memory at once, never all Jacobians.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from typing import NamedTuple, TypeAlias

import numpy as np
from numpy.typing import NDArray

from mocap_mj.anatomy.initial import place_markers, scaled_theta, segment_scales
from mocap_mj.kernels import _schur
from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKResult, IKSolver
from mocap_mj.solve.lm import (
    LMResult,
    LMSettings,
    TrialData,
    bounded_step,
    identify_lm,
    solver_joint_range,
)
from mocap_mj.solve.losses import L2, Loss, Weighted, loss_named
from mocap_mj.solve.priors import Prior
from mocap_mj.solve.problem import IdentificationProblem, loss_threshold, reduced_information
from mocap_mj.solve.selection import Selection, select_frames
from mocap_mj.solve.solver_result import IdentificationResult

from ..errors import MocapError, check_shape

#: IK chunk [frames]: 20,000 frames' poses are 9 MB, their IK working set a few tens of MB.
CHUNK = 20_000
#: The refinement's sample [frames], its steps at most, and the step (in standard
#: deviations) below which they stop.
SAMPLE = 20_000
INFO_FRAMES = 5_000
STEPS = 8
TOL_STD = 0.1

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


class LongResult(NamedTuple):
    """Outcome of :func:`identify_long`.

    Fields
    ------
    selection : the kept frames
    lm : the identification on them (its theta is the start of the refinement)
    theta : (P,) [m], the model: ``lm.theta`` refined on every frame (itself unrefined)
    information : (P, P) [1], the refinement's last matrix: the reduced information of
        every frame, estimated from the sample (:class:`Refinement`; unrefined:
        ``lm.reduced_information``), frozen rows and columns zero
    steps : list of float, the refinement steps' sizes (:class:`Refinement`)
    marker_rmse : [m] over all present samples of every solved frame under ``theta``
    frames_solved : int
    seconds : per stage (``select``, ``identify``, ``refine``: its sample steps and its pass
        over every frame, also apart as ``refine_sample`` and ``refine_pass``; ``ik``: the
        last IK, under theta)
    """

    selection: Selection
    lm: LMResult
    theta: np.ndarray
    information: np.ndarray
    steps: list[float]
    marker_rmse: float
    frames_solved: int
    seconds: dict[str, float]


class Refinement(NamedTuple):
    """The refinement on every frame (:func:`refine`).

    Fields
    ------
    theta : (P,) [m], the refined model
    information : (P, P) [1], the last step's matrix: reduced information (joint limits not
        held) of the sample at the sample's estimate, scaled to every frame; frozen rows and
        columns zero
    gradient : (P,) [m], the reduced gradient of every solved frame at the sample's estimate
    steps : list of float, each step's largest component in units of that parameter's
        standard deviation (the sample's steps, then the step on every frame)
    seconds : dict, wall time [s] of the ``sample`` steps and of the ``pass`` over every
        frame (its IK and reduced gradient)
    robust : the robust loss and the threshold of the last accepted sample point (the pass
        over every frame's), None for least squares
    """

    theta: np.ndarray
    information: np.ndarray
    gradient: np.ndarray
    steps: list[float]
    seconds: dict[str, float]
    robust: Robust | None = None


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
    (:func:`mocap_mj.kernels._schur.reduced_gradient`, joint limits not held, see :func:`refine`;
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
    :func:`refine`'s sample holds them; NaN rows: not solved."""

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


def _information(
    kin: Kinematics,
    markers: np.ndarray,
    qpos: np.ndarray,
    weigh: Weigh | None = None,
    robust: Robust | None = None,
) -> np.ndarray:
    """Reduced information (P, P) [1] of frames markers (n, M, 3) [m] at poses qpos (n, nq)
    (NaN rows skipped), joint limits not held, each sample weighted by its IRLS weight
    (:func:`sample_weights`: ``weigh`` and ``robust``; default 1)."""
    ok = np.isfinite(qpos[:, 0])
    if not ok.any():
        return np.zeros((kin.pset.size,) * 2)
    free = np.flatnonzero(~kin.pset.frozen)
    prob = IdentificationProblem(kin, markers[ok], qpos[ok], free, theta0=kin.theta.copy())
    w = prob.present.astype(float)
    if weigh is not None or robust is not None:
        w = sample_weights(kin, markers[ok], qpos[ok], weigh, robust)[0]
    return prob.information(w)


class _Solver:
    """Gauss-Newton steps for a fixed reduced information (P, P) [1] with the priors (the
    weak prior toward the start and any others, as in the LM) and the box lower..upper (P,)
    [m] (a parameter at a bound that the step pushes outward is held there, as in every LM
    step: :func:`mocap_mj.solve.lm.bounded_step`), within the informed directions; step
    sizes in standard deviations for the noise sigma [m]."""

    def __init__(
        self,
        info: np.ndarray,
        priors: Sequence[Prior],
        box: tuple[np.ndarray, np.ndarray],
        free: np.ndarray,
        sigma: float,
        st: LMSettings,
        mu: float = 0.0,
    ) -> None:
        self.free, self.priors, self.box = free, priors, box
        self.floor = st.tolerances.prior_ratio * st.prior_weight
        hess = sum((p.hessian() for p in priors), np.zeros_like(info))
        self.s_mat = info[np.ix_(free, free)] + hess[np.ix_(free, free)]
        lam, vec = np.linalg.eigh(0.5 * (self.s_mat + self.s_mat.T))
        basis, lam = vec[:, lam > self.floor], lam[lam > self.floor]
        self.std = sigma * np.sqrt(np.einsum("ij,j,ij->i", basis, 1.0 / lam, basis))
        self.damped = self.s_mat + mu * np.diag(np.diag(self.s_mat))

    def step(self, theta: np.ndarray, grad: np.ndarray) -> float:
        """theta (P,) [m] advanced in place by the step for the data gradient grad (P,) [m];
        returns the step's largest component in standard deviations."""
        f = self.free
        g_prior = sum((p.gradient(theta) for p in self.priors), np.zeros_like(theta))
        lower, upper = (b[f] for b in self.box)
        dth, _ = bounded_step(
            self.s_mat, grad[f] - g_prior[f], self.damped, theta[f], lower, upper, self.floor
        )
        theta[f] += dth
        theta[f] = np.clip(theta[f], lower, upper)  # exactly inside, as the LM's iterates
        return float(np.max(np.abs(dth) / np.maximum(self.std, 1e-300), initial=0.0))


@single_blas_thread
def refine(
    markers: Parts,
    pset: ParameterSet,
    theta0: np.ndarray,
    qpos: Parts,
    sigma: float,
    *,
    settings: LMSettings | None = None,
    priors: Sequence[Prior] | None = None,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    steps: int = STEPS,
    tol_std: float = TOL_STD,
    chunk: int = CHUNK,
    sample: int = SAMPLE,
    info_frames: int = INFO_FRAMES,
    weigh: Weigh | None = None,
    robust: Robust | None = None,
) -> Refinement:
    """The model refined on every frame (module docstring, step 3).

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing, or one such array per trial; read
        ``chunk`` frames at a time
    theta0 : (P,) [m], a consistent start (the identification on a subset)
    qpos : (T, nq) float (one per trial of ``markers``), written: every frame's IK pose under
        the sample's estimate, with the joint LM's limits (:func:`solver_joint_range`; NaN
        rows: too few markers); finite rows are warm starts
    sigma : [m], per-axis marker noise (the start's estimate), for ``tol_std``
    settings : LM settings for the weak prior and the informed directions (``prior_ratio``:
        directions with less information keep their value, as in every LM step)
    priors : the priors of the identification, the weak prior among them (default: the weak
        prior toward theta0 alone, ``settings.weak_prior``): their gradient and information
        are added to the data's, so that the refinement minimises the identification's cost
        over every frame
    lower, upper : (P,) [m], the identification's box (default: none): a parameter at a
        bound that a step pushes outward is held there
    steps : Gauss-Newton steps on the sample at most (default 8)
    tol_std : the sample's steps stop once one's largest component is below this fraction
        of its parameter's standard deviation (default 0.1): the step on every frame follows
        from the last accepted point, and a start 0.1 standard deviations closer to the
        sample's optimum changes that step's outcome by about the square of it (Gauss-Newton
        converges quadratically there)
    sample : every k-th frame of each trial, k = ceil(T / sample) with T the frames of all
        trials, is the sample (default 20,000 frames)
    info_frames : the information is summed over at most this many evenly spaced frames of
        the sample and scaled to all (default 5,000)
    weigh : per-sample weights of a frame's markers at its pose (default None: all 1), e.g.
        the soft-tissue sliding of the landmarks that the identification weighed with
        (:mod:`mocap_mj.anatomy.tissue`): the cost, gradient and information are then the
        weighted ones, so that the refinement minimises the same weighted cost as the
        identification, over every frame. The weights follow each frame's pose under the
        model of the step (the identification's come from its first solve's poses)
    """
    st = settings or LMSettings()
    t0 = time.perf_counter()
    parts = _parts(markers)
    n = sum(len(m) for m in parts)
    problem = _steps_of(pset, theta0, st, priors, (lower, upper), sigma, chunk, weigh)
    kin, box = problem.kin, problem.box
    stride = max(1, -(-n // max(sample, 1)))
    sample_set = _sample_of(parts, stride, n, kin.nq, info_frames)
    theta = np.clip(np.array(theta0, dtype=float), *box)
    theta, best, sizes, mu, robust = _sample_steps(
        problem, sample_set, theta, steps, tol_std, robust
    )
    t1 = time.perf_counter()
    if best is None:  # no step asked for
        return Refinement(theta, np.zeros((pset.size,) * 2), np.zeros(pset.size), sizes, {}, robust)
    theta, grad = best.theta, best.grad
    if stride == 1:
        # The sample is every frame: its last accepted point is the refined model, with its
        # poses (not those of a step taken back after it).
        _fill(qpos, best.qpos)
    else:
        grad = _step_on_every_frame(problem, parts, qpos, stride, best, mu, sizes, robust)
    seconds = {"sample": t1 - t0, "pass": time.perf_counter() - t1}
    return Refinement(theta, best.info, grad, sizes, seconds, robust)


class _Sample(NamedTuple):
    """The sample of :func:`refine`: markers (n, M, 3) [m], poses (n, nq) (written), the
    weight of one of its frames (the frames it stands for), the rows its information is
    summed over and that information's scale."""

    markers: np.ndarray
    qpos: np.ndarray
    weight: float
    info_rows: slice
    scale: float


class _Steps(NamedTuple):
    """What every step of :func:`refine` solves with: the kinematics, priors, box (lower,
    upper) [m], free parameters, noise sigma [m], settings, IK chunk and weighing."""

    kin: Kinematics
    priors: list[Prior]
    box: tuple[np.ndarray, np.ndarray]
    free: np.ndarray
    sigma: float
    settings: LMSettings
    chunk: int
    weigh: Weigh | None


def _steps_of(
    pset: ParameterSet,
    theta0: np.ndarray,
    st: LMSettings,
    priors: Sequence[Prior] | None,
    bounds: tuple[np.ndarray | None, np.ndarray | None],
    sigma: float,
    chunk: int,
    weigh: Weigh | None,
) -> _Steps:
    """:func:`refine`'s kinematics (at ``theta0``), priors (default: the weak prior toward
    theta0) and box (default: none) for its arguments."""
    kin = Kinematics(pset)
    # The IK with the joint LM's limits (ball cones widened), as the identification and the
    # written model solve it: the motion then starts from poses under the same limits.
    kin.model.jnt_range[:] = solver_joint_range(kin.model, st)
    kin.set_theta(theta0)
    free = np.flatnonzero(~pset.frozen)
    prior_list: list[Prior] = list(priors) if priors is not None else [st.weak_prior(theta0)]
    lower, upper = bounds
    box = (
        np.full(pset.size, -np.inf) if lower is None else np.asarray(lower, dtype=float),
        np.full(pset.size, np.inf) if upper is None else np.asarray(upper, dtype=float),
    )
    return _Steps(kin, prior_list, box, free, sigma, st, chunk, weigh)


def _sample_of(parts: list[np.ndarray], stride: int, n: int, nq: int, info_frames: int) -> _Sample:
    """Every ``stride``-th frame of each trial of ``parts`` ((T, M, 3) [m] each, ``n`` in all),
    its poses (n', nq) to be written, the rows (<= ``info_frames``) its information sums."""
    m_s = np.concatenate([np.asarray(m[::stride], dtype=float) for m in parts])
    q_s = np.full((len(m_s), nq), np.nan)
    weight = n / len(m_s)  # the sample's gradient, information and cost stand for every frame
    info_rows = slice(None, None, max(1, -(-len(m_s) // max(info_frames, 1))))
    scale = weight * len(m_s) / len(m_s[info_rows])
    return _Sample(m_s, q_s, weight, info_rows, scale)


def _step_on_every_frame(
    problem: _Steps,
    parts: list[np.ndarray],
    qpos: Parts,
    stride: int,
    best: _Point,
    mu: float,
    sizes: list[float],
    robust: Robust | None,
) -> np.ndarray:
    """The one step on every frame from the sample's estimate ``best`` (its information
    scaled), the frames' IK (into ``qpos``) chained from the sample's poses at it; the step's
    size appended to ``sizes``; returns the gradient (P,) on every frame."""
    kin, theta = problem.kin, best.theta
    kin.set_theta(theta)
    offsets = np.cumsum([0] + [len(range(0, len(m), stride)) for m in parts[:-1]])
    heads = Heads(best.qpos, stride, tuple(int(o) for o in offsets))
    _, grad = _ik_pass(parts, kin, qpos, problem.chunk, gradient=True, heads=heads,
                       weigh=problem.weigh, robust=robust)  # fmt: skip
    _, priors, box, free, sigma, st, _, _ = problem
    sizes.append(_Solver(best.info, priors, box, free, sigma, st, mu).step(theta, grad))
    return grad


def _sample_steps(
    problem: _Steps,
    sample: _Sample,
    theta: np.ndarray,
    steps: int,
    tol_std: float,
    robust: Robust | None,
) -> tuple[np.ndarray, _Point | None, list[float], float, Robust | None]:
    """:func:`refine`'s damped Gauss-Newton steps on the sample, from ``theta`` (P,) [m]:
    the last theta, the last accepted point (None: no step), the steps' sizes (in standard
    deviations), the damping and the robust loss at the last accepted point."""
    kin, prior_list, st, weigh = problem.kin, problem.priors, problem.settings, problem.weigh
    m_s, q_s, weight, info_rows = sample.markers, sample.qpos, sample.weight, sample.info_rows
    sizes: list[float] = []
    best: _Point | None = None
    mu = 0.0
    for _ in range(steps):
        kin.set_theta(theta)
        fit, grad = _ik_pass(
            m_s, kin, q_s, problem.chunk, gradient=True, weigh=weigh, robust=robust
        )
        cost = weight * 0.5 * fit.sq + sum(p.cost(theta) for p in prior_list)
        if best is not None and cost > best.cost:
            # The step raised the cost (real data: frames at joint limits, soft tissue): back
            # to the last point, with more damping (Levenberg-Marquardt, as the LM's steps).
            theta, mu = best.theta.copy(), max(10.0 * mu, 1e-3)
        else:
            # The information at every accepted point: kept from the start, the steps diverged.
            info = sample.scale * _information(kin, m_s[info_rows], q_s[info_rows], weigh, robust)
            if robust is not None:
                # The threshold from the sample's distances at every accepted point, as the
                # LM's from its frames' at every iterate; the next step's cost is compared
                # with this point's under it.
                robust = robust_loss(robust.loss.name, kin, m_s, q_s, st.loss_scale)
                data = sample_weights(kin, m_s, q_s, weigh, robust)[1]
                cost = weight * data + sum(p.cost(theta) for p in prior_list)
            best = _Point(theta.copy(), cost, weight * grad, info, q_s.copy())
            mu /= 10.0
        solver = _Solver(best.info, prior_list, problem.box, problem.free, problem.sigma, st, mu)
        sizes.append(solver.step(theta, best.grad))
        if sizes[-1] < tol_std:
            break
    return theta, best, sizes, mu, robust


class _Point(NamedTuple):
    """An accepted point of the sample's steps: theta (P,) [m], the cost [m^2] (data and
    priors), the reduced gradient (P,) [m] and information (P, P) [1], all for every frame,
    and the sample's poses (n, nq) under theta."""

    theta: np.ndarray
    cost: float
    grad: np.ndarray
    info: np.ndarray
    qpos: np.ndarray


def _fill(qpos: Parts, rows: np.ndarray) -> None:
    """Copy rows (T, nq), every trial's frames one after the other, into qpos (per trial)."""
    k = 0
    for q in _parts(qpos):
        q[:] = rows[k : k + len(q)]
        k += len(q)


def refit_all(
    markers: Parts,
    pset: ParameterSet,
    theta: np.ndarray,
    qpos: Parts,
    *,
    chunk: int = CHUNK,
) -> tuple[float, int]:
    """IK of every frame under theta (P,) [m], ``chunk`` frames at a time, in place in qpos
    (T, nq) (one per trial of ``markers``): warm from its finite rows, chained in chunks of
    NaN rows.

    Returns the marker RMSE [m] over the present samples of the solved frames, and their
    number."""
    kin = Kinematics(pset)
    kin.set_theta(theta)
    fit, _ = _ik_pass(markers, kin, qpos, chunk, gradient=False)
    return fit.rmse, fit.solved


def identify_long(
    markers: NDArray[np.floating],
    times: NDArray[np.floating],
    pset: ParameterSet,
    qpos_out: NDArray[np.floating],
    *,
    count: int = 1000,
    settings: LMSettings | None = None,
    chunk: int = CHUNK,
    refine_on_all: bool = True,
    sample: int = SAMPLE,
) -> LongResult:
    """Identify a long recording on ``count`` selected frames, IK every frame, refine the
    model on every frame (:func:`refine`), then IK every frame again (warm) with it.

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing; a memory map is read chunk by chunk
    times : (T,) float [s]
    pset : the model's parameter set
    qpos_out : (T, nq) float, written: every frame's pose (NaN rows where too few markers)
    count : frames identified on (default 1000: see docs/method.md#long-recordings)
    settings : LM settings (default ``LMSettings()``)
    chunk : frames per IK chunk
    refine_on_all : refine the model on every frame (:func:`refine`; default on: without,
        the model's error is that of ``count`` frames, many times the bound of the whole
        recording)
    sample : frames of the refinement's sample (:func:`refine`)
    """
    n = len(markers)
    st = settings or LMSettings()
    check_shape("markers", markers, (None, pset.n_markers, 3))
    check_shape("times", times, (n,))
    check_shape("qpos_out", qpos_out, (n, pset.model.nq))
    t0 = time.perf_counter()
    sel = select_frames(markers, pset.marker_names, count)
    t1 = time.perf_counter()
    sub = np.asarray(markers[sel.frames], dtype=float)
    scales = segment_scales(pset, [sub])
    theta0 = place_markers(pset, scaled_theta(pset, [sub], scales=scales), [sub])
    trial = TrialData("selection", sub, np.asarray(times[sel.frames], dtype=float))
    lm = identify_lm([trial], pset=pset, theta0=theta0, settings=st)
    t2 = time.perf_counter()
    qpos_out[:] = np.nan
    theta, info, sizes = lm.theta, lm.reduced_information, []
    extra: dict[str, float] = {}
    t3 = time.perf_counter()
    if refine_on_all:
        ref = refine(
            markers, pset, lm.theta, qpos_out, lm.sigma, settings=st, chunk=chunk, sample=sample
        )
        theta, info, sizes = ref.theta, ref.information, ref.steps
        extra = {f"refine_{k}": v for k, v in ref.seconds.items()}
        t3 = time.perf_counter()
    rmse, solved = refit_all(markers, pset, theta, qpos_out, chunk=chunk)
    t4 = time.perf_counter()
    stages = {"select": t1 - t0, "identify": t2 - t1, "refine": t3 - t2, "ik": t4 - t3, **extra}
    return LongResult(sel, lm, theta, info, sizes, rmse, solved, stages)


def result_at(
    result: IdentificationResult,
    trials: Sequence[TrialData],
    pset: ParameterSet,
    theta: np.ndarray,
    settings: LMSettings,
    box: tuple[np.ndarray, np.ndarray] | None = None,
    robust: Robust | None = None,
) -> IdentificationResult:
    """The identification's ``result`` on ``trials`` described at another model theta (P,)
    [m] (the refined one): the trials' poses solved again under theta (warm from the
    result's, with the solver's joint limits; with ``robust``, weighted by the result's
    final IRLS weights, as the robust fit's poses were), their fit (RMSE, sigma), the reduced
    information at them and the parameters on a bound of ``box`` (lower, upper) (P,) [m];
    the initial model, iterations and trace stay the identification's."""
    kin = Kinematics(pset)
    kin.model.jnt_range[:] = solver_joint_range(kin.model, settings)
    kin.set_theta(theta)
    solver = IKSolver(kin)
    qpos, frame_rmse = [], []
    for i, (t, q0) in enumerate(zip(trials, result.qpos, strict=True)):
        q, f = np.array(q0, dtype=float), np.full(len(q0), np.nan)
        ok = np.isfinite(q[:, 0])
        if ok.any():
            w = None if robust is None else np.asarray(result.weights[i])[ok]
            r = solver.solve_frames(np.asarray(t.markers, dtype=float)[ok], q[ok], w)
            q[ok], f[ok] = r.qpos, r.marker_rmse
        qpos.append(q)
        frame_rmse.append(f)
    info, sigma, n_res, n_unk = reduced_information(pset, theta, trials, qpos)
    used = [np.isfinite(q[:, 0]) for q in qpos]
    n_markers = [
        np.all(np.isfinite(np.asarray(t.markers, dtype=float)), axis=2).sum(axis=1) for t in trials
    ]
    sq = sum(
        float(np.sum(f[u] ** 2 * k[u])) for f, u, k in zip(frame_rmse, used, n_markers, strict=True)
    )
    present = sum(int(k[u].sum()) for u, k in zip(used, n_markers, strict=True))
    lower, upper = (
        box if box is not None else (np.full(pset.size, -np.inf), np.full(pset.size, np.inf))
    )
    eps = 1e-12 * np.maximum(1.0, np.abs(theta))
    at_bound = result.free & ((theta <= lower + eps) | (theta >= upper - eps))
    return dataclasses.replace(
        result,
        theta=np.array(theta, dtype=float),
        qpos=qpos,
        used=used,
        marker_rmse=float(np.sqrt(sq / present)) if present else float("nan"),
        frame_rmse=frame_rmse,
        reduced_information=info,
        sigma=sigma,
        n_residuals=n_res,
        n_unknowns=n_unk,
        at_bound=at_bound,
    )


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
