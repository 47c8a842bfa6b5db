"""Joint Levenberg-Marquardt identification of theta and every frame's pose.

Minimises over theta (P,) and q_t (T frames x nv)::

    F = sum_t sum_m rho(|p_tm - x_m(q_t; theta)|)  +  sum_k prior_k(theta),
    lower <= theta <= upper

the problem of :mod:`mocap_mj.solve.problem`: rho(d) = d^2 / 2 (``loss="l2"``) or a robust
loss (``"huber"``, ``"cauchy"``, applied as iteratively reweighted least squares with a scale
re-estimated from the residuals each iteration); missing samples have weight 0. By default the
priors are one weak prior toward the initial model and there is no box.

Each step solves the damped Gauss-Newton system, which has the block-arrow structure of bundle
adjustment: one nv x nv block A_t per frame, coupled to the shared parameters by B_t (nv x P).
Every frame's block is eliminated (Schur complement)::

    S = C + H_prior - sum_t B_t^T A_t^-1 B_t
    S dtheta = g_theta - g_prior - sum_t B_t^T A_t^-1 g_t
    dq_t = A_t^-1 (g_t - B_t dtheta)

accumulated chunk by chunk over frames (memory does not grow with T beyond the trajectories
and, for up to ``cache_frames`` frames, the per-frame A_t^-1 [B_t, g_t] kept for the back
substitution; longer trials recompute them in a second pass).

Damping: Marquardt-scaled (``mu * diag``) on both blocks, mu0 = 1e-2, divided by 3 after an
accepted step and raised after a rejected one (``Tolerances.mu_decrease``). After each step
every frame finishes its own pose by per-frame LM under the new theta (``refine_iterations``).
Bounds: a parameter at a bound whose step points outward is held for that step (the reduced
system is solved without it), and the step is then projected onto the box.
Coarse to fine (:mod:`mocap_mj.solve.coarse`, ``coarse_frames``): on more than twice
``coarse_frames`` frames, :func:`identify_lm` first converges on a pose-diverse subset (the
approach from the initial model, at a fraction of the cost per iteration), solves every
frame's IK under the subset's model and continues on every frame from there; only this last
phase decides the answer, by the stopping rules below.
Stopping: an accepted step that lowers F by less than ``tol_noise * sigma^2`` or
``tol_cost * F``, or a step whose largest
theta component is below ``tol_theta`` [m] and pose component below ``tol_q``, or ``mu`` beyond
1e12 (no descent possible), or ``max_iterations``.

The weak prior (:func:`mocap_mj.solve.priors.weak_prior`; ``prior_sigma``, default 50 mm,
relative to a 1 mm marker noise: lambda_p = (1 mm / 50 mm)^2) pins the directions of theta
that the markers cannot determine (a lone marker turning about its joint, the pelvis frame
against its markers) to the initial model, and is negligible (< 1e-4 relative) in every
direction the data determine to better than 5 mm. The identifiability report
(:mod:`mocap_mj.solve.identifiability`) names them.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import mujoco
import numpy as np
import scipy.linalg

from mocap_mj.kernels import _tree
from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.coarse import (
    COARSE_REFITS,
    coarse_rows,
    joined_trace,
    shifted,
    subset_heads,
    subset_trials,
)
from mocap_mj.solve.heuristics import RefitSchedule, StallMonitor, frame_rmse, refit_frames
from mocap_mj.solve.ik import IKResult, IKSettings, IKSolver
from mocap_mj.solve.ik import Status as IKStatus
from mocap_mj.solve.losses import loss_named
from mocap_mj.solve.priors import Prior
from mocap_mj.solve.problem import (
    CHI3_MEDIAN,
    Bounds,
    IdentificationProblem,
    ProblemOptions,
    ReducedChunk,
    TrialData,
    build_problem,
    unpool,
)

# The settings live in .settings; imported from here too, where the solver is.
from mocap_mj.solve.settings import LMSettings as LMSettings
from mocap_mj.solve.settings import MuDecrease as MuDecrease
from mocap_mj.solve.settings import Performance as Performance
from mocap_mj.solve.settings import Tolerances as Tolerances
from mocap_mj.solve.solver_result import (
    IdentificationResult,
    IterationLog,
    ProgressCallback,
    Status,
    TraceEntry,
)

from ..errors import SolverError, check_shape

logger = logging.getLogger(__name__)

#: The joint LM's stop reasons (the name its result used; :class:`Status`).
Termination = Status
#: The joint LM's result (the name it used; :class:`IdentificationResult`).
LMResult = IdentificationResult


# ------------------------------------------------------------------ one damped step
def build_system(
    problem: IdentificationProblem, w: np.ndarray, mu: float, chunks: list[slice], cache: bool
) -> ReducedChunk:
    """The damped reduced system of all frames with weights w (n, M) and damping mu,
    accumulated chunk by chunk: s and rhs without prior and damping; its ``step`` maps dtheta
    to every frame's pose step (from the chunks' eliminations, kept when ``cache``, else
    recomputed)."""
    pf, nv = problem.free.size, problem.kin.nv
    s_mat, rhs = np.zeros((pf, pf)), np.zeros(pf)
    g_theta, diag_c = np.zeros(pf), np.zeros(pf)
    g_q, diag_a = np.empty((problem.n, nv)), np.empty((problem.n, nv))
    kept: list[ReducedChunk] = []
    for sl in chunks:
        red = problem.reduce(sl, w, mu)
        g_q[sl], diag_a[sl] = red.g_q, red.diag_a
        g_theta += red.g_theta
        s_mat += red.s
        rhs += red.rhs
        diag_c += red.diag_c
        if cache:
            kept.append(red)

    def step(dth: np.ndarray) -> np.ndarray:
        dq = np.empty((problem.n, nv))
        for i, sl in enumerate(chunks):
            dq[sl] = (kept[i] if cache else problem.reduce(sl, w, mu)).step(dth)
        return dq

    return ReducedChunk(s_mat, rhs, g_theta, diag_c, g_q, diag_a, step)


def informed_solve(
    s_mat: np.ndarray, s_damped: np.ndarray, rhs: np.ndarray, floor: float
) -> np.ndarray:
    """Solve s_damped x = rhs within the eigen-directions of s_mat with information above
    ``floor`` (the others keep their value: the data hardly constrain them).

    Only the few eigenvectors U (Pf, k) of s_mat at or below the floor are computed
    (``scipy.linalg.eigh`` by value: the step needs no other, and the decomposition is serial
    work between the parallel passes); x is the solution of the equality-constrained system
    [s_damped U; U^T 0] [x; l] = [rhs; 0] by one Cholesky factor of s_damped (positive
    definite: the damping and the priors), which is the solve in the complement's basis
    (the eigenbasis solve when s_damped has no Cholesky factor).
    """
    sym = 0.5 * (s_mat + s_mat.T)
    _, low = scipy.linalg.eigh(
        sym, subset_by_value=(-np.inf, floor), driver="evr", check_finite=False
    )
    try:
        factor = scipy.linalg.cho_factor(s_damped, check_finite=False)
    except np.linalg.LinAlgError:  # not positive definite: the eigenbasis solve
        lam, vec = np.linalg.eigh(sym)
        basis = vec[:, lam > floor]
        return basis @ np.linalg.solve(basis.T @ s_damped @ basis, basis.T @ rhs)
    z = scipy.linalg.cho_solve(factor, rhs, check_finite=False)
    if low.shape[1] == 0:
        return z
    y = scipy.linalg.cho_solve(factor, low, check_finite=False)
    return z - y @ np.linalg.solve(low.T @ y, low.T @ z)


def bounded_step(
    s_mat: np.ndarray,
    rhs: np.ndarray,
    s_damped: np.ndarray,
    theta_f: np.ndarray,
    lower_f: np.ndarray,
    upper_f: np.ndarray,
    floor: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The parameter step dtheta (Pf,) [m] within the box, and which parameters were held.

    s_mat (Pf, Pf): the information of the data and the priors (for the informed directions,
    ``floor``);
    s_damped: the damped system with the priors; rhs (Pf,); theta_f, lower_f, upper_f (Pf,) [m].

    Active set: a parameter on a bound whose step points outward is held (its row and column
    leave the reduced system) and the system is solved again, until no held parameter is
    added; the step is then projected onto the box. Without bounds: one solve.
    """
    keep = np.ones(theta_f.size, dtype=bool)
    dth = np.zeros(theta_f.size)
    for _ in range(theta_f.size):
        if keep.all():  # no parameter held (always without bounds): no copies
            dth[:] = informed_solve(s_mat, s_damped, rhs, floor)
        else:
            idx = np.flatnonzero(keep)
            dth[:] = 0.0
            sub = np.ix_(idx, idx)
            dth[idx] = informed_solve(s_mat[sub], s_damped[sub], rhs[idx], floor)
        out = keep & (((theta_f <= lower_f) & (dth < 0)) | ((theta_f >= upper_f) & (dth > 0)))
        if not np.any(out):
            break
        keep &= ~out
    return np.clip(theta_f + dth, lower_f, upper_f) - theta_f, ~keep


class Trial(NamedTuple):
    """A candidate iterate: theta (P,) [m], poses (n, nq), distances (n, M) [m], F [m^2], the
    predicted decrease [m^2], the parameter step's largest component [m] and pose step's."""

    theta: np.ndarray
    qpos: np.ndarray
    dist: np.ndarray
    cost: float
    predicted: float
    step_theta: float
    step_q: float


def propose(
    problem: IdentificationProblem,
    st: LMSettings,
    theta: np.ndarray,
    w: np.ndarray,
    mu: float,
    c_loss: float,
    chunks: list[slice],
) -> Trial:
    """One damped Gauss-Newton step from theta and the problem's poses (not yet accepted:
    the kinematics is left at the candidate theta)."""
    f, cache = problem.free, problem.n <= st.performance.cache_frames
    system = build_system(problem, w, mu, chunks, cache)
    _, g_prior, h_prior = problem.prior(theta)
    d_prior = np.diag(h_prior)
    s_damped = system.s + h_prior + np.diag(mu * (system.diag_c + d_prior)) + 1e-15 * np.eye(f.size)
    rhs = system.rhs - g_prior
    # Steps move in the directions the data or the priors inform (an anatomical prior decides
    # where the markers cannot); the others keep their value.
    dth, _ = bounded_step(
        system.s + h_prior,
        rhs,
        s_damped,
        theta[f],
        problem.lower[f],
        problem.upper[f],
        st.tolerances.prior_ratio * st.prior_weight,
    )
    dq = system.step(dth)
    theta_new = theta.copy()
    theta_new[f] = np.clip(theta[f] + dth, problem.lower[f], problem.upper[f])  # exactly inside
    q_new = finish_poses(problem, theta_new, dq, w, st.tolerances.refine_iterations)
    dist_new = problem.residuals(q_new)
    # Decrease predicted by the damped quadratic model: 1/2 h^T (mu D h + g) (Nielsen).
    h_g = float(np.einsum("ni,ni->", dq, system.g_q) + dth @ (system.g_theta - g_prior))
    h_dh = float(
        np.einsum("ni,ni,ni->", dq, system.diag_a, dq) + dth @ ((system.diag_c + d_prior) * dth)
    )
    return Trial(
        theta_new,
        q_new,
        dist_new,
        problem.cost(dist_new, theta_new, c_loss),
        max(0.5 * (h_g + mu * h_dh), 1e-300),
        float(np.abs(dth).max(initial=0.0)),
        float(np.abs(dq).max(initial=0.0)),
    )


def finish_poses(
    problem: IdentificationProblem,
    theta: np.ndarray,
    dq: np.ndarray,
    w: np.ndarray,
    iterations: int,
) -> np.ndarray:
    """Poses (n, nq) after the joint step dq (n, nv) under theta (P,) [m], projected onto the
    joint limits and finished by ``iterations`` per-frame IK iterations (own damping,
    box-constrained at the limits) with the loss's weights w (n, M) (0 where a marker is
    missing, as :class:`~mocap_mj.solve.losses.Loss` gives them): given theta the frames
    are independent."""
    problem.kin.set_theta(theta)
    limits = problem.limits
    q = np.array(problem.qpos, dtype=float)
    _tree.integrate_rows(problem.kin.tree(), q, np.ascontiguousarray(dq, dtype=float))
    q = limits.project(q)
    if iterations > 0:
        q = limits.solve_frames(
            problem.markers, q, w, max_iterations=iterations, prepared=(problem.target, w)
        ).qpos
    return q


def next_damping(
    mu: float, nu: float, accepted: bool, rho: float, rule: MuDecrease
) -> tuple[float, float]:
    """(mu, nu) after a step with gain ratio rho: decreased after an accepted step
    (``rule``), multiplied by nu (which doubles) after a rejected one."""
    if accepted:
        return mu * (max(1 / 3, 1 - (2 * rho - 1) ** 3) if rule == "nielsen" else 1 / 3), 2.0
    return mu * nu, nu * 2


def stop_reason(
    st: LMSettings,
    it: int,
    accepted: bool,
    gain: float,
    cost: float,
    sigma: float,
    step: Trial,
    mu: float,
) -> Status | None:
    """The convergence test after iteration ``it`` (gain: F decrease [m^2], sigma [m])."""
    if accepted and it > 1 and gain <= st.tolerances.tol_noise * sigma**2:
        return Status.NOISE
    if accepted and gain <= st.tolerances.tol_cost * cost:
        return Status.COST
    if accepted and step.step_theta < st.tolerances.tol_theta and step.step_q < st.tolerances.tol_q:
        return Status.STEP
    if mu > 1e12:
        return Status.NO_DESCENT
    return None


# ------------------------------------------------------------------ the solver
class _State:
    """The iterate: theta (P,) [m], distances (n, M) [m] at the problem's poses, damping."""

    def __init__(self, problem: IdentificationProblem, theta: np.ndarray, mu: float) -> None:
        self.theta = theta
        self.dist = problem.residuals(problem.qpos)
        self.mu, self.nu = mu, 2.0

    def rmse(self, problem: IdentificationProblem) -> float:
        return problem.statistics(self.dist).rmse


def solve_lm(
    problem: IdentificationProblem,
    settings: LMSettings | None = None,
    *,
    progress: ProgressCallback | None = None,
    continued: float | None = None,
    information: bool = True,
) -> IdentificationResult:
    """Minimise the problem's F by joint LM from its kinematics' theta and its poses.

    ``continued``: the damping mu of an LM that converged on a subset of these frames (the
    coarse phase, :mod:`mocap_mj.solve.coarse`), whose model the poses were just solved
    under by a fresh IK. The LM starts with that damping instead of ``mu0``, and the refits
    are those of an LM that has settled (the fresh IK stands in for the approach's).
    ``information``: compute the reduced information at the solution (False: zeros; the
    coarse phase's result needs only theta and the damping).

    Returns the common :class:`IdentificationResult` (per-trial poses, the reduced
    information at the solution, the status and the trace of :class:`IterationLog`).
    """
    st = settings or LMSettings()
    t_start = time.perf_counter()
    theta = np.clip(problem.kin.theta.copy(), problem.lower, problem.upper)
    problem.kin.set_theta(theta)
    state = _State(problem, theta, st.tolerances.mu0 if continued is None else continued)
    chunks = [
        slice(s, min(s + st.performance.chunk, problem.n))
        for s in range(0, problem.n, st.performance.chunk)
    ]
    schedule = RefitSchedule(
        st.tolerances.refit_factor,
        st.tolerances.settle_gain,
        st.tolerances.max_refits,
        state.rmse(problem),
    )
    if continued is not None:
        schedule.settled, schedule.last_iteration = True, 0
    stall = StallMonitor(st.tolerances.stall_window, st.tolerances.stall_rel)
    trace: list[IterationLog] = []
    status, it = Status.MAX_ITERATIONS, 0
    while it < st.max_iterations:
        it += 1
        stop = _iterate(problem, st, state, it, chunks, schedule, stall, trace)
        if progress is not None:
            progress(trace[-1])
        if isinstance(stop, Status) and not _repair(problem, state, schedule, it, st):
            status = stop
            break
    problem.kin.set_theta(state.theta)
    result = _result(problem, st, state, it, status, trace, information)
    result.seconds = time.perf_counter() - t_start
    return result


def _iterate(
    problem: IdentificationProblem,
    st: LMSettings,
    state: _State,
    it: int,
    chunks: list[slice],
    schedule: RefitSchedule,
    stall: StallMonitor,
    trace: list[IterationLog],
) -> Status | bool | None:
    """One LM iteration with its refits; the stop reason, None to go on, or False when a
    refit changed frames (the convergence test is then skipped)."""
    t_it = time.perf_counter()
    c_loss = problem.loss_scale(state.dist, st.loss_scale)
    w = problem.loss.weights(state.dist, problem.present, c_loss)
    cost = problem.cost(state.dist, state.theta, c_loss)
    step = propose(problem, st, state.theta, w, state.mu, c_loss, chunks)
    accepted = step.cost < cost
    if accepted:
        state.theta, problem.qpos, state.dist = step.theta, step.qpos, step.dist
    else:
        problem.kin.set_theta(state.theta)
    rho = (cost - step.cost) / step.predicted
    state.mu, state.nu = next_damping(state.mu, state.nu, accepted, rho, st.tolerances.mu_decrease)
    stats = problem.statistics(state.dist)
    trace.append(
        IterationLog(
            it,
            step.cost if accepted else cost,
            stats.rmse,
            state.mu,
            accepted,
            step.step_theta,
            time.perf_counter() - t_it,
            state.theta.copy(),
            problem.n,
        )
    )
    logger.info(
        "iter %3d  F %.6e  rmse %.4f mm  mu %.1e  %s  max|dtheta| %.4f mm",
        it,
        trace[-1].cost,
        stats.rmse * 1e3,
        state.mu,
        "accepted" if accepted else "rejected",
        step.step_theta * 1e3,
    )
    gain = cost - step.cost
    stalled = schedule.settling(accepted, gain, cost)
    if (schedule.improved(accepted, stats.rmse) or stalled) and schedule.take(it):
        fixed = refit_frames(
            problem.limits, problem.markers, problem.qpos, problem.segments, problem.sample_weights
        )
        if len(fixed):
            state.dist = problem.residuals(problem.qpos)
            schedule.last_rmse = state.rmse(problem)
            logger.info("refit: %d frames had a better pose by a fresh IK", len(fixed))
            return False
        schedule.last_rmse = stats.rmse
    schedule.settled |= stalled
    sigma = stats.sigma if problem.sample_weights is None else problem.weighted_sigma(state.dist)
    stop = stop_reason(st, it, accepted, gain, cost, sigma, step, state.mu)
    # The stall is judged on the objective (its square root, in RMSE's units): with sample
    # weights or priors the unweighted marker RMSE may rise while F still falls.
    level = float(np.sqrt(trace[-1].cost))
    if accepted:
        stall.accepted(level)
    if stop is None and schedule.settled and stall.stalled(level):
        stop = Status.STALL
    return stop


def _repair(
    problem: IdentificationProblem,
    state: _State,
    schedule: RefitSchedule,
    it: int,
    st: LMSettings,
) -> bool:
    """At a stop: frames caught in a local minimum of their pose show up as outliers of the
    fit; re-solve every trial's IK with the current model and go on (damping reset) if any
    frame improved. False: nothing changed, the stop stands."""
    if not schedule.take_at_stop(it):
        return False
    fixed = refit_frames(
        problem.limits, problem.markers, problem.qpos, problem.segments, problem.sample_weights
    )
    if len(fixed) == 0:
        return False
    state.dist = problem.residuals(problem.qpos)
    state.mu, state.nu = st.tolerances.mu0, 2.0
    schedule.settled = False
    logger.info("repaired %d frames caught in local minima; continuing", len(fixed))
    return True


def _result(
    problem: IdentificationProblem,
    st: LMSettings,
    state: _State,
    it: int,
    status: Status,
    trace: list[IterationLog],
    information: bool = True,
) -> IdentificationResult:
    """The per-trial result at the final iterate, with the reduced information (no damping,
    no prior; the final IRLS weights)."""
    c_loss = problem.loss_scale(state.dist, st.loss_scale)
    w_final = problem.loss.weights(state.dist, problem.present, c_loss)
    stats = problem.statistics(state.dist)
    free = np.zeros(problem.kin.pset.size, dtype=bool)
    free[problem.free] = True
    eps = 1e-12 * np.maximum(1.0, np.abs(state.theta))
    at_bound = free & ((state.theta <= problem.lower + eps) | (state.theta >= problem.upper - eps))
    return IdentificationResult(
        theta=state.theta,
        theta0=problem.theta0,
        qpos=unpool(problem.qpos, problem.used),
        used=problem.used,
        marker_rmse=stats.rmse,
        frame_rmse=unpool(frame_rmse(state.dist, problem.present), problem.used),
        reduced_information=(
            problem.information(w_final, st.performance.chunk)
            if information
            else np.zeros((problem.kin.pset.size,) * 2)
        ),
        free=free,
        sigma=stats.sigma,
        n_residuals=stats.n_residuals,
        n_unknowns=stats.n_unknowns,
        iterations=it,
        status=status,
        trace=trace,
        weights=unpool(w_final, problem.used, fill=0.0),
        at_bound=at_bound,
        method="lm",
    )


# ------------------------------------------------------------------ the public entry
def solver_joint_range(model: mujoco.MjModel, settings: LMSettings) -> np.ndarray:
    """The joint limits (njnt, 2) [rad or m] the joint LM solves with, as ``jnt_range``:
    the model's, with the cone of every limited ball joint widened by
    ``settings.tolerances.ball_limit_scale`` (at most pi). ``identify`` writes these into
    model.xml so that an IK with the written model reproduces the fit."""
    rng = np.array(model.jnt_range, dtype=float)
    ball = (model.jnt_type == mujoco.mjtJoint.mjJNT_BALL) & (model.jnt_limited > 0)
    rng[ball, 1] = np.minimum(rng[ball, 1] * settings.tolerances.ball_limit_scale, np.pi)
    return rng


def initial_ik(
    kin: Kinematics, trials: Sequence[TrialData], ik_settings: IKSettings | None = None
) -> list[IKResult]:
    """IK of every trial with the kinematics' current theta."""
    solver = IKSolver(kin, ik_settings)
    return [solver.solve_trial(t.markers) for t in trials]


@dataclass(frozen=True, eq=False)
class InitialPoses:
    """Where :func:`identify_lm`'s poses start: given per trial, or solved by an IK.

    Attributes
    ----------
    qpos : sequence of (T_i, nq) [m, quaternion, rad] or None
        The starting poses per trial (NaN rows: frames not used). None (default): every
        frame's IK with the initial model (after the coarse phase, when it applies).
    ik : IKSettings or None
        The settings of that IK (default None: ``IKSettings()``); unused with ``qpos``.
    """

    qpos: Sequence[np.ndarray] | None = None
    ik: IKSettings | None = None


@single_blas_thread
def identify_lm(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet | None = None,
    theta0: np.ndarray | None = None,
    settings: LMSettings | None = None,
    initial: InitialPoses | None = None,
    priors: Sequence[Prior] | None = None,
    bounds: Bounds | None = None,
    progress: ProgressCallback | None = None,
) -> IdentificationResult:
    """Identify theta and the motion of every trial by joint Levenberg-Marquardt.

    Builds the :class:`~mocap_mj.solve.problem.IdentificationProblem` and runs
    :func:`solve_lm` on it.

    Parameters
    ----------
    trials : sequence of TrialData
        One or more trials of one subject; theta is shared.
    pset : ParameterSet, optional
        The parameterisation (bundled humanoid by default); its ``frozen`` flags are honoured.
    theta0 : (P,) [m], optional
        Initial model and mean of the default prior (default ``pset.nominal``).
    settings : LMSettings, optional
        The LM's settings (default ``LMSettings()``).
    initial : InitialPoses, optional
        The starting poses per trial, or the settings of the IK that solves them (default:
        every frame's IK with theta0 and ``IKSettings()``, after the coarse phase).
    priors : sequence of Prior, optional
        Default: the weak prior toward theta0 (``settings.prior_sigma``); pass it in the
        sequence to keep it beside others.
    bounds : Bounds, optional
        Box on theta (default: none).
    progress : callable, optional
        Called with each iteration's :class:`IterationLog`.
    """
    st = settings or LMSettings()
    pset = pset or ParameterSet()
    theta = pset.check(pset.nominal if theta0 is None else theta0).copy()
    free = np.flatnonzero(~pset.frozen)
    if free.size == 0:
        raise SolverError("every parameter is frozen: nothing to identify")
    if not trials:
        raise SolverError("no trials given")
    for t in trials:
        check_shape(f"{t.name}: markers", t.markers, (None, pset.n_markers, 3))
    kin = Kinematics(pset)
    kin.model.jnt_range[:] = solver_joint_range(kin.model, st)
    kin.set_theta(theta)
    t_start = time.perf_counter()
    if priors is None:
        priors = [st.weak_prior(theta)]
    options = ProblemOptions(theta0=theta, priors=priors, bounds=bounds, loss=loss_named(st.loss))
    result = _solve_levels(
        kin, trials, free, options, st, initial or InitialPoses(), progress, information=True
    )
    result.seconds = time.perf_counter() - t_start
    return result


def _solve_levels(
    kin: Kinematics,
    trials: Sequence[TrialData],
    free: np.ndarray,
    options: ProblemOptions,
    st: LMSettings,
    initial: InitialPoses,
    progress: ProgressCallback | None,
    *,
    information: bool,
) -> IdentificationResult:
    """:func:`identify_lm` from the kinematics' theta: the coarse phase first when it applies
    (itself solved this way, so a long trial is approached through subsets growing tenfold:
    :func:`~mocap_mj.solve.coarse.coarse_rows`), then the IK of every frame and the LM on
    all of them."""
    coarse: IdentificationResult | None = None
    rows = (
        None
        if initial.qpos is not None
        else coarse_rows(trials, kin.pset, st.tolerances.coarse_frames)
    )
    if rows is not None:  # no poses given: ``initial`` holds only the IK's settings
        start, sub = kin.theta.copy(), subset_trials(trials, rows)
        sub_st = replace(
            st,
            tolerances=replace(
                st.tolerances, max_refits=min(st.tolerances.max_refits, COARSE_REFITS)
            ),
        )
        try:
            coarse = _solve_levels(
                kin, sub, free, options, sub_st, initial, progress, information=False
            )
        except SolverError:  # no frame of the subset solvable: every frame decides
            coarse = None
        if coarse and 2 * sum(int(u.sum()) for u in coarse.used) < sum(len(r) for r in rows):
            coarse = None  # most of the subset unsolvable: no approach worth continuing
        kin.set_theta(start if coarse is None else coarse.theta)
    t_ik = time.perf_counter()
    if initial.qpos is None:
        if coarse is not None and rows is not None:
            solver = IKSolver(kin, initial.ik)
            heads = subset_heads(trials, rows, coarse.qpos)
            iks = [
                solver.solve_from_heads(t.markers, h) for t, h in zip(trials, heads, strict=True)
            ]
        else:
            iks = initial_ik(kin, trials, initial.ik)
        init_q = [r.qpos for r in iks]
        used = [r.status != IKStatus.TOO_FEW_MARKERS for r in iks]
    else:
        init_q = [np.asarray(q, dtype=float) for q in initial.qpos]
        used = [np.all(np.isfinite(q), axis=1) for q in init_q]
    init_seconds = time.perf_counter() - t_ik
    problem = build_problem(kin, trials, init_q, used, free, options)
    if coarse is None:
        result = solve_lm(problem, st, progress=progress, information=information)
    else:
        k = coarse.iterations
        fine_st = replace(st, max_iterations=max(1, st.max_iterations - k))
        renumbered = None if progress is None else _shifted(progress, k)
        last = coarse.trace[-1]
        mu = last.mu if isinstance(last, IterationLog) else st.tolerances.mu0
        result = solve_lm(
            problem, fine_st, progress=renumbered, continued=mu, information=information
        )
        result.trace = joined_trace(coarse.trace, result.trace)
        result.iterations += k
    result.init_seconds = init_seconds
    return result


def _shifted(progress: ProgressCallback, k: int) -> ProgressCallback:
    """``progress`` with iteration numbers shifted by k (the coarse phase's iterations)."""

    def call(log: TraceEntry) -> None:
        progress(shifted(log, k))

    return call


__all__ = [
    "CHI3_MEDIAN",
    "Bounds",
    "InitialPoses",
    "LMResult",
    "LMSettings",
    "Termination",
    "TrialData",
    "identify_lm",
    "initial_ik",
    "solve_lm",
    "solver_joint_range",
]
