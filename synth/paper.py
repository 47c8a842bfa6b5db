"""Algorithm 1 of Zou & Sugihara: theta by finite-difference gradient descent through IK.

The paper identifies theta (P = 151: 34 kinematic parameters and 39 x 3 marker offsets [m]) by
minimising the marker error of the motion that inverse kinematics reconstructs::

    E(theta) = sum_{j in S} sum_m |p~_jm - x_m(q_j(theta); theta)|^2,
    q_j(theta) = argmin_q sum_m |p~_jm - x_m(q; theta)|^2          (IK of frame j)

over a sample S of N_F frames. dE/dtheta is estimated by finite differences, solving IK again
for every perturbed model and every sampled frame::

    for each iteration:
        draw S (all frames / every 10th / 10 % at random / one frame at random)
        for j in S: solve IK of frame j under theta                    -> E_j(theta)
            for i in 1..P: theta_i += Delta; solve IK of frame j; E_j(theta + Delta e_i);
                           g_i += (E_j(theta + Delta e_i) - E_j(theta)) / Delta; restore
        theta := theta - alpha g / N_F

This module keeps that arithmetic: forward differences (as the paper; their error is
Delta / 2 times E's curvature, first order in Delta, see ``docs/paper.md``) of E through real
IK re-solves, with :class:`mocap_mj.solve.ik.IKSolver` (the project's LM IK, without its relative
RMSE stop: :data:`IK_SETTINGS`) as the solver. What is made fast is only how the IK problems
are laid out:

- every frame's unperturbed IK is warm-started from that frame's previous solution, and every
  perturbed IK from the unperturbed solution of the same frame under the current theta;
- the (P + 1) x N_F problems of an iteration run on the compiled IK
  (:meth:`IKSolver.solve_frames`), one call per perturbed model over the sampled frames: a
  perturbed model is the current compiled tree with its body and site positions recomputed
  for theta + Delta e_i (:meth:`GradientEstimator.perturbed_trees`), the only tables theta
  enters;
- the unperturbed E_j(theta) of each difference is solved the same way, started at the same
  pose and run for the same iterations as the perturbed problems, so that what the IK still
  had to converge cancels in the difference;
- the perturbed IK runs at most ``perturbed_iterations`` LM iterations (default 2). From the
  warm start one step lands within O(Delta^2) of the perturbed optimum (measured in
  ``docs/paper.md``: at the true model 2 iterations give the gradient of 100 to 1e-6).

One safeguard is added to the IK (not to the arithmetic of the gradient): q_j must be the
frame's IK *solution*, but a warm-started IK keeps whatever configuration the frame had. The
initial IK, under a model far from the subject, leaves about 10 % of the frames of a
range-of-motion trial in a wrong configuration (an arm twisted about itself) that warm starts
never leave; such frames fit 30-50 mm worse than the others and dominate E and its gradient.
When a sampled frame fits far worse than the recently solved ones, every frame's IK is solved
afresh under the current theta (keeping the better pose) before the gradient.

Frames with too few markers for IK are left out; missing markers do not count in E.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal, NamedTuple, get_args

import numpy as np

from mocap_mj.errors import MocapError, SolverError, check_shape
from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.kernels._tree import Tree
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.heuristics import refit_frames
from mocap_mj.solve.ik import IKSettings, IKSolver, Status
from mocap_mj.solve.problem import (
    IdentificationProblem,
    TrialData,
    pool,
    reduced_information,
    unpool,
)
from mocap_mj.solve.solver_result import IdentificationResult, ProgressCallback
from mocap_mj.solve.solver_result import Status as Stop

logger = logging.getLogger(__name__)

Sampling = Literal["batch", "even", "random", "stochastic"]
SAMPLINGS: tuple[str, ...] = get_args(Sampling)

#: IK settings of Algorithm 1: the project's defaults without the relative-RMSE stop. A finite
#: difference of E divides IK results by Delta, so every IK must be converged to far below
#: 0.1 % of the RMSE (the stop ``tol_rmse`` adds for speed); the cost and step tolerances
#: (1e-8) remain.
IK_SETTINGS = IKSettings(tol_rmse=0.0)

#: Default gradient step alpha [1] and finite-difference step Delta [m] (see docs/paper.md).
DEFAULT_STEP = 0.1
DEFAULT_DELTA = 1e-6


@dataclass(frozen=True)
class PaperSettings:
    """Settings of Algorithm 1.

    Attributes
    ----------
    sampling : {"batch", "even", "random", "stochastic"}
        Frames per iteration: all; ``fraction`` of them at even intervals (the same every
        iteration); ``fraction`` of them drawn at random every iteration; one at random.
    iterations : int
        Gradient steps.
    step : float
        alpha: theta := theta - alpha * g / N_F, with g the finite-difference gradient of
        E [m^2] summed over the N_F sampled frames. The mean per-frame Hessian of E (with the
        poses re-solved) has eigenvalues up to about 13 (the trunk lengths), so gradient
        descent diverges for alpha above about 2 / 13 = 0.15 (``docs/paper.md``).
    delta : float [m]
        Delta, the forward-difference perturbation of each parameter.
    fraction : float
        Share of the frames for ``even`` and ``random``.
    seed : int
        Seed of the random frame draws.
    perturbed_iterations : int
        LM iterations of each perturbed IK (warm-started at the unperturbed solution).
    ik_iterations : int
        LM iteration limit of each frame's unperturbed IK (warm-started at its last solution).
    clip_to_bounds : bool
        Keep theta within ``pset.lower``/``pset.upper`` (the model stays valid if a step
        overshoots; inactive in a converging run).
    refit_factor, refit_margin : float, [1] and [m]
        A sampled frame whose warm-started IK fits worse than ``refit_factor`` times the
        median RMSE of the last 100 frames solved plus ``refit_margin`` is caught in a local
        minimum of its pose: then every frame's IK is solved afresh under the current theta
        (chains and repair, :meth:`IKSolver.solve_trial`), keeping the better pose, before
        the gradient. Without it, about 10 % of the frames keep the wrong configuration the
        initial IK gave them under the nominal model and dominate E and its gradient
        (``docs/paper.md``).
    refit_interval : int
        Iterations at least between two such refits.
    """

    sampling: Sampling = "batch"
    iterations: int = 100
    step: float = DEFAULT_STEP
    delta: float = DEFAULT_DELTA
    fraction: float = 0.1
    seed: int = 0
    perturbed_iterations: int = 2
    ik_iterations: int = 100
    clip_to_bounds: bool = True
    refit_factor: float = 3.0
    refit_margin: float = 0.001
    refit_interval: int = 10

    def __post_init__(self) -> None:
        if self.sampling not in SAMPLINGS:
            raise MocapError(
                f"sampling must be one of {', '.join(SAMPLINGS)}; got {self.sampling!r}"
            )
        if self.iterations < 1:
            raise MocapError(f"iterations must be at least 1, got {self.iterations}")
        if not self.step > 0:
            raise MocapError(f"step (alpha) must be positive, got {self.step}")
        if not self.delta > 0:
            raise MocapError(f"delta must be positive [m], got {self.delta}")
        if not 0 < self.fraction <= 1:
            raise MocapError(f"fraction must be in (0, 1], got {self.fraction}")
        if self.seed < 0:
            raise MocapError(f"seed must be >= 0, got {self.seed}")
        if min(self.perturbed_iterations, self.ik_iterations) < 1:
            raise MocapError("perturbed_iterations and ik_iterations must be >= 1")


class PaperIteration(NamedTuple):
    """One iteration of Algorithm 1.

    Fields
    ------
    iteration : int (1-based)
    frames : (N_F,) int, indices of the sampled frames (into the stacked usable frames)
    energy : float [m^2], E(theta) over the sampled frames, before the step
    rmse : float [m], marker RMSE of the sampled frames, before the step
    grad_norm : float [m], |g| / N_F
    seconds : float, wall time since the start (initial IK included)
    theta : (P,) [m], after the step
    """

    iteration: int
    frames: np.ndarray
    energy: float
    rmse: float
    grad_norm: float
    seconds: float
    theta: np.ndarray

    @property
    def cost(self) -> float:
        """The objective [m^2] (E over the sampled frames), as every trace entry has it."""
        return self.energy


@dataclass
class PaperResult(IdentificationResult):
    """Outcome of :func:`identify_paper`: the common result (``method="paper"``, status
    ``MAX_ITERATIONS``, ``trace`` of :class:`PaperIteration`; ``qpos`` every frame's IK under
    the final theta) and what Algorithm 1 adds.

    Attributes
    ----------
    energy : float [m^2], E over all used frames at the final theta
    settings : PaperSettings
    final_seconds : float [s], final IK of all frames (not in ``seconds``)
    ik_problems : int, IK problems solved in the iterations (unperturbed and perturbed)
    clipped : int, iterations in which a bound was active
    repaired : int, frame poses improved by fresh IK (local minima) in the iterations
    refits : list of int, iterations at which every frame's IK was solved afresh
    """

    trace: Sequence[PaperIteration] = field(default_factory=list)
    energy: float = 0.0
    settings: PaperSettings = field(default_factory=PaperSettings)
    final_seconds: float = 0.0
    ik_problems: int = 0
    clipped: int = 0
    repaired: int = 0
    refits: list[int] = field(default_factory=list)


# ------------------------------------------------------------------ sampling
class FrameSampler:
    """The frames each iteration uses (deterministic given the seed).

    Parameters
    ----------
    n : int, usable frames
    sampling : str, one of :data:`SAMPLINGS`
    fraction : float
    seed : int
    """

    def __init__(self, n: int, sampling: str, fraction: float = 0.1, seed: int = 0) -> None:
        if n < 1:
            raise SolverError("no frame has enough markers to be solved")
        self.n = n
        self.sampling = sampling
        self.count = {
            "batch": n,
            "even": max(1, round(n * fraction)),
            "random": max(1, round(n * fraction)),
            "stochastic": 1,
        }[sampling]
        self.rng = np.random.default_rng(seed)
        # Even: count frames spread over the trial, the same every iteration.
        self._even = np.unique(np.floor(np.arange(self.count) * n / self.count).astype(int))

    def draw(self) -> np.ndarray:
        """Sorted frame indices (N_F,) for the next iteration."""
        if self.sampling == "batch":
            return np.arange(self.n)
        if self.sampling == "even":
            return self._even.copy()
        if self.sampling == "random":
            return np.sort(self.rng.choice(self.n, size=self.count, replace=False))
        return np.array([int(self.rng.integers(self.n))])


# ------------------------------------------------------------------ gradient
class GradientEstimator:
    """Finite-difference gradient of E through IK re-solves (the inner loops of Algorithm 1).

    Parameters
    ----------
    pset : ParameterSet
    delta : float [m]
    perturbed_iterations : int
    ik_settings : IKSettings, optional (default :data:`IK_SETTINGS`)
    """

    def __init__(
        self,
        pset: ParameterSet,
        delta: float,
        *,
        perturbed_iterations: int = 3,
        ik_iterations: int = 100,
        ik_settings: IKSettings | None = None,
    ) -> None:
        self.pset = pset
        self.kin = Kinematics(pset)
        self.ik = IKSolver(self.kin, ik_settings or IK_SETTINGS)
        self.delta = float(delta)
        self.perturbed_iterations = perturbed_iterations
        self.ik_iterations = ik_iterations
        self.params = np.flatnonzero(~pset.frozen)
        self.problems = 0
        self._trees: list[Tree] | None = None

    def set_theta(self, theta: np.ndarray) -> None:
        self.kin.set_theta(theta)
        self._trees = None

    def perturbed_trees(self) -> list[Tree]:
        """The compiled model at theta + Delta e_i for every free parameter i (P_free,).

        theta enters the model only through body positions (kinematic parameters) and site
        positions (marker offsets), so each perturbed model is the current tree with those
        two tables recomputed (``ParameterSet.apply``'s own formulas).
        """
        if self._trees is None:
            base, theta = self.kin.tree(), self.kin.theta
            trees = []
            for i in self.params:
                th = theta.copy()
                th[i] += self.delta
                offsets = self.pset.split(th)[1]
                body_pos = np.asarray(self.pset.body_pos(th), dtype=float)
                site_pos = np.ascontiguousarray(offsets, dtype=float)
                trees.append(base._replace(body_pos=body_pos, site_pos=site_pos))
            self._trees = trees
        return self._trees

    def solve(self, markers: np.ndarray, qpos0: np.ndarray) -> np.ndarray:
        """Unperturbed IK (B, nq) of frames (B, M, 3) from qpos0 (B, nq)."""
        return self.solve_rmse(markers, qpos0)[0]

    def solve_rmse(self, markers: np.ndarray, qpos0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unperturbed IK of frames (B, M, 3) from qpos0: qpos (B, nq), marker RMSE (B,) [m]."""
        r = self.ik.solve_frames(markers, qpos0, max_iterations=self.ik_iterations)
        self.problems += len(markers)
        return r.qpos, r.marker_rmse

    def _energy(self, tree: Tree | None, markers: np.ndarray, qpos: np.ndarray) -> np.ndarray:
        """E_j (B,) [m^2] after ``perturbed_iterations`` IK iterations from qpos (B, nq)."""
        r = self.ik.solve_frames(markers, qpos, max_iterations=self.perturbed_iterations, tree=tree)
        return np.asarray(r.marker_rmse**2 * r.n_markers)

    def perturbed_energy(
        self, markers: np.ndarray, qpos: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """E_j(theta) (B,) and E_j(theta + Delta e_i) (B, P_free) [m^2] of frames (B, M, 3).

        Every problem (the unperturbed one and each perturbed one) starts at qpos (B, nq) and
        runs the same ``perturbed_iterations`` LM iterations, so that what the IK still had to
        converge cancels in the difference.
        """
        e0 = self._energy(None, markers, qpos)
        ep = np.empty((len(markers), self.params.size))
        for j, tree in enumerate(self.perturbed_trees()):
            ep[:, j] = self._energy(tree, markers, qpos)
        self.problems += len(markers) * (self.params.size + 1)
        return e0, ep

    def gradient(
        self, markers: np.ndarray, qpos0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Forward-difference dE/dtheta summed over frames.

        Parameters
        ----------
        markers : (B, M, 3) [m]
        qpos0 : (B, nq), warm starts of the unperturbed IK

        Returns
        -------
        grad : (P,) [m], zero for frozen parameters
        qpos : (B, nq), the unperturbed IK solutions
        energy : (B,) [m^2], E_j(theta)
        """
        qpos = self.solve(markers, qpos0)
        return self.gradient_at(markers, qpos)

    def gradient_at(
        self, markers: np.ndarray, qpos: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`gradient`, with the unperturbed IK solutions qpos (B, nq) given."""
        e0, ep = self.perturbed_energy(markers, qpos)
        grad = np.zeros(self.pset.size)
        grad[self.params] = np.sum(ep - e0[:, None], axis=0) / self.delta
        return grad, qpos, e0


def analytic_gradient(kin: Kinematics, markers: np.ndarray, qpos: np.ndarray) -> np.ndarray:
    """dE/dtheta (P,) [m] at IK optima qpos (B, nq) (envelope theorem: -2 sum J_theta^T r).

    Exact when every frame's IK is at a stationary point with respect to the pose; frames at a
    joint limit hold there only to first order.
    """
    present = np.all(np.isfinite(markers), axis=2)
    frames = kin.forward(qpos)
    r = np.where(present[..., None], markers, 0.0) - frames.site_xpos
    r *= present[..., None]
    jt = kin.jac_theta(frames)  # (B, M, 3, P)
    return -2.0 * np.einsum("bmcp,bmc->p", jt, r)


# ------------------------------------------------------------------ Algorithm 1
@single_blas_thread
def identify_paper(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet | None = None,
    theta0: np.ndarray | None = None,
    settings: PaperSettings | None = None,
    ik_settings: IKSettings | None = None,
    progress: ProgressCallback | None = None,
) -> PaperResult:
    """Identify theta with Algorithm 1 of Zou & Sugihara (see the module docstring).

    Parameters
    ----------
    trials : sequence of TrialData
        Markers (T_i, M, 3) [m] of one subject; the frames of all trials are pooled.
    pset : ParameterSet, optional
        Parameterisation (bundled humanoid by default); frozen parameters are not perturbed.
    theta0 : (P,) [m], optional
        Initial model (default ``pset.nominal``).
    settings : PaperSettings, optional
    ik_settings : IKSettings, optional
        Settings of every IK (tolerances, damping); default :data:`IK_SETTINGS`.
    progress : callable, optional
        Called with each iteration's :class:`PaperIteration`.
    """
    st = settings or PaperSettings()
    pset = pset or ParameterSet()
    theta = pset.check(pset.nominal if theta0 is None else theta0).copy()
    theta_init = theta.copy()
    if not trials:
        raise SolverError("no trials given")
    for t in trials:
        check_shape(f"{t.name}: markers", t.markers, (None, pset.n_markers, 3))
    if np.all(pset.frozen):
        raise SolverError("every parameter is frozen: nothing to identify")
    t_start = time.perf_counter()
    est = GradientEstimator(
        pset,
        st.delta,
        perturbed_iterations=st.perturbed_iterations,
        ik_iterations=st.ik_iterations,
        ik_settings=ik_settings,
    )
    est.set_theta(theta)
    iks = [est.ik.solve_trial(t.markers) for t in trials]
    used = [r.status != Status.TOO_FEW_MARKERS for r in iks]
    markers, qpos = pool(trials, [r.qpos for r in iks], used)
    run = _Run(est, st, markers, qpos, used)
    init_rmse = np.concatenate([r.marker_rmse[u] for r, u in zip(iks, used, strict=True)])
    run.recent.extend(np.nan_to_num(init_rmse).tolist())
    init_seconds = time.perf_counter() - t_start
    est.problems = 0
    for it in range(1, st.iterations + 1):
        theta = run.iteration(it, theta, pset, t_start)
        if progress is not None:
            progress(run.trace[-1])
    seconds = time.perf_counter() - t_start
    t_final = time.perf_counter()
    est.set_theta(theta)
    final = _final_ik(est.ik, trials, used, run.qpos)
    return _paper_result(
        pset,
        theta,
        theta_init,
        trials,
        final,
        run,
        _Seconds(seconds, init_seconds, time.perf_counter() - t_final),
    )


class _Run:
    """The state of Algorithm 1 between iterations: poses (n, nq) of the pooled frames, the
    frame sampler, the recent per-frame RMSE [m] (for the refit test) and the trace."""

    def __init__(
        self,
        est: GradientEstimator,
        st: PaperSettings,
        markers: np.ndarray,
        qpos: np.ndarray,
        used: Sequence[np.ndarray],
    ) -> None:
        self.est, self.st, self.markers, self.qpos = est, st, markers, qpos
        self.present = np.all(np.isfinite(markers), axis=2).sum(axis=1)
        self.sampler = FrameSampler(len(markers), st.sampling, st.fraction, st.seed)
        self.segments = IdentificationProblem.segments_of(used)
        self.recent: deque[float] = deque(maxlen=100)
        self.trace: list[PaperIteration] = []
        self.clipped = self.repaired = 0
        self.refits: list[int] = []
        self.last_refit = -st.refit_interval

    def sampled_poses(self, frames: np.ndarray) -> np.ndarray:
        """Warm-started IK of the sampled frames (N_F,) under the current theta: RMSE (N_F,)."""
        q_new, rmse_s = self.est.solve_rmse(self.markers[frames], self.qpos[frames])
        self.qpos[frames] = q_new
        return rmse_s

    def iteration(
        self, it: int, theta: np.ndarray, pset: ParameterSet, t_start: float
    ) -> np.ndarray:
        """Iteration ``it`` of Algorithm 1 from theta (P,) [m]; returns the new theta."""
        st, est = self.st, self.est
        frames = self.sampler.draw()
        est.set_theta(theta)
        rmse_s = self.sampled_poses(frames)
        limit = st.refit_factor * float(np.median(self.recent)) + st.refit_margin
        if np.any(rmse_s > limit) and it - self.last_refit >= st.refit_interval:
            # A sampled frame fits far worse than the frames solved recently: its pose is
            # caught in a local minimum. Every frame's IK afresh; keep the better poses.
            fixed = len(refit_frames(est.ik, self.markers, self.qpos, self.segments))
            self.repaired += fixed
            self.refits.append(it)
            self.last_refit = it
            logger.info("iter %4d  IK of all frames afresh: %d poses improved", it, fixed)
            rmse_s = self.sampled_poses(frames)
        self.recent.extend(rmse_s.tolist())
        grad, _, e0 = est.gradient_at(self.markers[frames], self.qpos[frames])
        step = st.step * grad / len(frames)
        theta = theta - step
        if st.clip_to_bounds:
            clipped_theta = np.clip(theta, pset.lower, pset.upper)
            self.clipped += int(np.any(clipped_theta != theta))
            theta = clipped_theta
        energy = float(e0.sum())
        rmse = float(np.sqrt(energy / max(int(self.present[frames].sum()), 1)))
        gnorm = float(np.linalg.norm(grad) / len(frames))
        self.trace.append(
            PaperIteration(
                it, frames, energy, rmse, gnorm, time.perf_counter() - t_start, theta.copy()
            )
        )
        logger.info(
            "iter %4d  frames %4d  E %.6e m^2  rmse %.4f mm  |g|/N %.3e  max|dtheta| %.4f mm",
            it,
            len(frames),
            energy,
            rmse * 1e3,
            gnorm,
            np.abs(step).max() * 1e3,
        )
        return theta


class FinalFit(NamedTuple):
    """Every frame's IK under the final theta: used (T_i,) bool, qpos (T_i, nq) and RMSE
    (T_i,) [m] per trial; E [m^2] and present samples over the frames solved."""

    used: list[np.ndarray]
    qpos: list[np.ndarray]
    frame_rmse: list[np.ndarray]
    energy: float
    samples: int


def _final_ik(
    solver: IKSolver, trials: Sequence[TrialData], used: Sequence[np.ndarray], qpos: np.ndarray
) -> FinalFit:
    """Every frame's IK under the solver's theta, warm from the last poses (n, nq) and afresh
    (chains, repair), keeping each frame's better fit (for the result, not part of the
    algorithm)."""
    q_rows, r_rows, energy, samples = [], [], 0.0, 0
    for t, u, seg in zip(trials, used, IdentificationProblem.segments_of(used), strict=True):
        if not np.any(u):
            continue
        warm = solver.solve_trial(t.markers[u], qpos_init=qpos[seg])
        fresh = solver.solve_trial(t.markers[u])
        better = np.nan_to_num(fresh.marker_rmse, nan=np.inf) < np.nan_to_num(
            warm.marker_rmse, nan=np.inf
        )
        q_rows.append(np.where(better[:, None], fresh.qpos, warm.qpos))
        rr = np.where(better, fresh.marker_rmse, warm.marker_rmse)
        r_rows.append(rr)
        ok = np.isfinite(rr)
        energy += float(np.sum(rr[ok] ** 2 * warm.n_markers[ok]))
        samples += int(warm.n_markers[ok].sum())
    q_all = np.concatenate(q_rows) if q_rows else np.zeros((0, solver.kin.nq))
    r_all = np.concatenate(r_rows) if r_rows else np.zeros(0)
    return FinalFit(list(used), unpool(q_all, used), unpool(r_all, used), energy, samples)


class _Seconds(NamedTuple):
    """The wall times [s] of Algorithm 1: its iterations (from the start, the initial IK
    included), the initial IK, and the final IK of every frame."""

    run: float
    init: float
    final: float


def _paper_result(
    pset: ParameterSet,
    theta: np.ndarray,
    theta0: np.ndarray,
    trials: Sequence[TrialData],
    final: FinalFit,
    run: _Run,
    seconds: _Seconds,
) -> PaperResult:
    """The common result of Algorithm 1 from theta (P,) [m] and the initial model theta0
    (P,) [m], with the reduced information at its final poses."""
    info, sigma, n_res, n_unk = reduced_information(pset, theta, trials, final.qpos)
    free = ~pset.frozen.copy()
    at_bound = free & ((theta <= pset.lower) | (theta >= pset.upper)) & run.st.clip_to_bounds
    return PaperResult(
        theta=theta,
        theta0=theta0,
        qpos=final.qpos,
        used=final.used,
        frame_rmse=final.frame_rmse,
        marker_rmse=float(np.sqrt(final.energy / max(final.samples, 1))),
        reduced_information=info,
        free=free,
        sigma=sigma,
        n_residuals=n_res,
        n_unknowns=n_unk,
        iterations=len(run.trace),
        status=Stop.MAX_ITERATIONS,
        trace=run.trace,
        seconds=seconds.run,
        init_seconds=seconds.init,
        at_bound=at_bound,
        method="paper",
        energy=final.energy,
        settings=run.st,
        final_seconds=seconds.final,
        ik_problems=run.est.problems,
        clipped=run.clipped,
        repaired=run.repaired,
        refits=run.refits,
    )


def trace_lines(result: PaperResult) -> list[str]:
    """The per-iteration table of a paper result (Markdown)."""
    lines = [
        "| iteration | frames | E (m^2) | RMSE, sampled frames (mm) | abs(g)/N_F (m) | time (s) |",
        "|---|---|---|---|---|---|",
    ]
    for p in result.trace:
        lines.append(
            f"| {p.iteration} | {len(p.frames)} | {p.energy:.6e} | {p.rmse * 1e3:.4f} | "
            f"{p.grad_norm:.3e} | {p.seconds:.2f} |"
        )
    return lines
