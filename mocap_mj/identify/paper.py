"""Algorithm 1 of Zou & Sugihara: theta by finite-difference gradient descent through IK.

The paper identifies theta (P = 147: 30 kinematic parameters and 39 x 3 marker offsets [m]) by
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
IK re-solves, with :class:`mocap_mj.ik.IKSolver` (the project's LM IK, without its relative
RMSE stop: :data:`IK_SETTINGS`) as the solver. What is made fast is only how the IK problems
are laid out:

- every frame's unperturbed IK is warm-started from that frame's previous solution, and every
  perturbed IK from the unperturbed solution of the same frame under the current theta;
- all (P + 1) x N_F problems of an iteration go through one vectorised
  :meth:`IKSolver.solve_frames` call (in chunks of ``chunk_rows`` rows to bound memory): the
  kinematics used there (:class:`TaggedKinematics`) carries, per row, which parameter is
  perturbed, as one extra column of the configuration. Perturbing a parameter with the pose
  fixed is an exact rigid translation of a kinematic subtree (a kinematic parameter moves a
  body's position in its parent's frame) or of one marker site (an offset), so each row's
  forward kinematics is the unperturbed one plus that translation;
- the unperturbed E_j(theta) of each difference is a row of the same call, started at the same
  pose and run for the same iterations as the perturbed rows, so that what the IK still had
  to converge cancels in the difference;
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

import argparse
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from .._threads import single_blas_thread
from ..errors import MocapError, SolverError, check_shape
from ..ik import IKSettings, IKSolver, Status
from ..kinematics import Frames, Kinematics
from ..parameters import ParameterSet
from .lm import IterationLog, LMResult, Termination, TrialData

SAMPLINGS: tuple[str, ...] = ("batch", "even", "random", "stochastic")

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
    chunk_rows : int
        Perturbed IK problems per :meth:`IKSolver.solve_frames` call (memory: about 70 kB
        per row).
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

    sampling: str = "batch"
    iterations: int = 100
    step: float = DEFAULT_STEP
    delta: float = DEFAULT_DELTA
    fraction: float = 0.1
    seed: int = 0
    perturbed_iterations: int = 2
    ik_iterations: int = 100
    chunk_rows: int = 1024
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
        if min(self.perturbed_iterations, self.ik_iterations, self.chunk_rows) < 1:
            raise MocapError("perturbed_iterations, ik_iterations and chunk_rows must be >= 1")


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


@dataclass
class PaperResult:
    """Outcome of :func:`identify_paper`.

    Attributes
    ----------
    theta, theta0 : (P,) [m]
    qpos : list of (T_i, nq) per trial: every frame's IK under the final theta (NaN rows for
        frames with too few markers)
    used : list of (T_i,) bool
    frame_rmse : list of (T_i,) [m], marker RMSE of each frame under the final theta
    marker_rmse : float [m], over all present samples of the used frames
    energy : float [m^2], E over all used frames at the final theta
    trace : list of PaperIteration
    settings : PaperSettings
    seconds : float, the algorithm (initial IK and iterations; not the final IK)
    init_seconds : float, initial IK of all frames
    final_seconds : float, final IK of all frames
    ik_problems : int, IK problems solved in the iterations (unperturbed and perturbed)
    clipped : int, iterations in which a bound was active
    repaired : int, frame poses improved by fresh IK (local minima) in the iterations
    refits : list of int, iterations at which every frame's IK was solved afresh
    """

    theta: np.ndarray
    theta0: np.ndarray
    qpos: list[np.ndarray]
    used: list[np.ndarray]
    frame_rmse: list[np.ndarray]
    marker_rmse: float
    energy: float
    trace: list[PaperIteration]
    settings: PaperSettings
    seconds: float
    init_seconds: float
    final_seconds: float
    ik_problems: int
    clipped: int = 0
    repaired: int = 0
    refits: list[int] = field(default_factory=list)


# ------------------------------------------------------------------ tagged kinematics
class TaggedKinematics(Kinematics):
    """Kinematics of many perturbed models at once, one per row.

    The configuration has one column more than the model's: ``qpos[:, -1]`` is the index i of
    the parameter perturbed by ``delta`` in that row (-1: none), so that one
    :class:`IKSolver` call can solve frames of P different models. With the pose fixed,
    ``theta + delta e_i`` moves, exactly,

    - for a kinematic parameter: each target body (and its subtree: bodies, joint anchors and
      sites) by ``delta * R_parent D[i, b]``;
    - for a marker offset (marker m, axis c): site m by ``delta * R_body[:, c]``.

    Orientations (and so joint axes) do not change.

    Parameters
    ----------
    pset : ParameterSet
    delta : float [m]
    """

    compiled = False  # rows carry their own perturbed model: NumPy path only

    def __init__(self, pset: ParameterSet, delta: float) -> None:
        super().__init__(pset)
        self.delta = float(delta)
        self.model_nq = self.nq
        self.nq = self.model_nq + 1
        m = self.model
        site_body = np.array(m.site_bodyid)
        jnt_body = np.array(m.jnt_bodyid)
        k = self.pset.n_kappa
        # Per kinematic parameter: (parent body, direction, body mask, joint mask, site mask).
        self._moves: list[list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]]
        self._moves = [[] for _ in range(k)]
        for i, b in self.kappa_pairs:
            sub = self.ancestor[:, b]  # bodies in b's subtree
            self._moves[i].append(
                (
                    int(m.body_parentid[b]),
                    self.pset.direction[i, b].copy(),
                    np.flatnonzero(sub),
                    np.flatnonzero(sub[jnt_body]),
                    np.flatnonzero(sub[site_body]),
                )
            )
        self._site_body = site_body

    def tagged(self, qpos: np.ndarray, params: np.ndarray) -> np.ndarray:
        """Configuration (B, nq + 1) from qpos (B, nq) and perturbed parameter (B,) (-1: none)."""
        return np.concatenate([qpos, np.asarray(params, dtype=float)[:, None]], axis=1)

    def forward(self, qpos: np.ndarray) -> Frames:
        """Forward kinematics of tagged configurations (B, nq + 1), each row's model its own."""
        qpos = self._check_qpos(qpos)
        nq = self.model_nq
        site_xpos, xpos, xmat, xanchor, xaxis = self._kinematics_rows(qpos[:, :nq])
        tag = np.rint(qpos[:, nq]).astype(int)
        k = self.pset.n_kappa
        for i in np.unique(tag[tag >= 0]):
            rows = np.flatnonzero(tag == i)
            if i < k:
                for parent, direction, bodies, joints, sites in self._moves[i]:
                    shift = self.delta * (xmat[rows, parent] @ direction)  # (r, 3)
                    xpos[np.ix_(rows, bodies)] += shift[:, None]
                    xanchor[np.ix_(rows, joints)] += shift[:, None]
                    site_xpos[np.ix_(rows, sites)] += shift[:, None]
            else:
                s, c = divmod(int(i) - k, 3)
                site_xpos[rows, s] += self.delta * xmat[rows, self._site_body[s], :, c]
        return Frames(site_xpos, xpos, xmat, xanchor, xaxis)

    def marker_positions(self, qpos: np.ndarray) -> np.ndarray:
        return self.forward(qpos).site_xpos

    def integrate(self, qpos: np.ndarray, dv: np.ndarray, scale: float = 1.0) -> np.ndarray:
        qpos = self._check_qpos(qpos)
        check_shape("dv", dv, (len(qpos), self.nv))
        out = qpos.copy()
        nq = self.model_nq
        for t in range(len(out)):
            q = out[t, :nq].copy()
            mujoco.mj_integratePos(self.model, q, dv[t], scale)
            out[t, :nq] = q
        return out


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
    chunk_rows : int
    """

    def __init__(
        self,
        pset: ParameterSet,
        delta: float,
        *,
        perturbed_iterations: int = 3,
        ik_iterations: int = 100,
        ik_settings: IKSettings | None = None,
        chunk_rows: int = 1024,
    ) -> None:
        self.pset = pset
        self.kin = Kinematics(pset)
        self.tagged = TaggedKinematics(pset, delta)
        ik_settings = ik_settings or IK_SETTINGS
        self.ik = IKSolver(self.kin, ik_settings)
        self.ik_tagged = IKSolver(self.tagged, ik_settings)
        self.delta = float(delta)
        self.perturbed_iterations = perturbed_iterations
        self.ik_iterations = ik_iterations
        self.chunk_rows = chunk_rows
        self.params = np.flatnonzero(~pset.frozen)
        self.problems = 0

    def set_theta(self, theta: np.ndarray) -> None:
        self.kin.set_theta(theta)
        self.tagged.set_theta(theta)

    def solve(self, markers: np.ndarray, qpos0: np.ndarray) -> np.ndarray:
        """Unperturbed IK (B, nq) of frames (B, M, 3) from qpos0 (B, nq)."""
        return self.solve_rmse(markers, qpos0)[0]

    def solve_rmse(self, markers: np.ndarray, qpos0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unperturbed IK of frames (B, M, 3) from qpos0: qpos (B, nq), marker RMSE (B,) [m]."""
        r = self.ik.solve_frames(markers, qpos0, max_iterations=self.ik_iterations)
        self.problems += len(markers)
        return r.qpos, r.marker_rmse

    def perturbed_energy(
        self, markers: np.ndarray, qpos: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """E_j(theta) (B,) and E_j(theta + Delta e_i) (B, P_free) [m^2] of frames (B, M, 3).

        Every problem (the unperturbed one and each perturbed one) starts at qpos (B, nq) and
        runs the same ``perturbed_iterations`` LM iterations, so that what the IK still had to
        converge cancels in the difference.
        """
        b = len(markers)
        pf = self.params.size
        cols = np.concatenate([[-1], self.params])
        frame = np.repeat(np.arange(b), pf + 1)
        param = np.tile(cols, b)
        out = np.empty(b * (pf + 1))
        for s in range(0, out.size, self.chunk_rows):
            sl = slice(s, min(s + self.chunk_rows, out.size))
            q0 = self.tagged.tagged(qpos[frame[sl]], param[sl])
            r = self.ik_tagged.solve_frames(
                markers[frame[sl]], q0, max_iterations=self.perturbed_iterations
            )
            out[sl] = r.marker_rmse**2 * r.n_markers
        self.problems += out.size
        e = out.reshape(b, pf + 1)
        return e[:, 0], e[:, 1:]

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
    progress: bool = False,
    log: list[str] | None = None,
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
    progress : bool
        Progress bar over the iterations.
    log : list of str, optional
        Receives one line per iteration.

    Returns
    -------
    PaperResult
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
        chunk_rows=st.chunk_rows,
    )
    est.set_theta(theta)
    iks = [est.ik.solve_trial(t.markers) for t in trials]
    used = [r.status != Status.TOO_FEW_MARKERS for r in iks]
    markers = np.concatenate([t.markers[u] for t, u in zip(trials, used, strict=True)])
    qpos = np.concatenate([r.qpos[u] for r, u in zip(iks, used, strict=True)])
    present = np.all(np.isfinite(markers), axis=2).sum(axis=1)
    init_seconds = time.perf_counter() - t_start
    sampler = FrameSampler(len(markers), st.sampling, st.fraction, st.seed)
    est.problems = 0
    trace: list[PaperIteration] = []
    clipped = 0
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=st.iterations, desc=f"identify (paper, {st.sampling})", unit="it",
            leave=False, delay=2,
        )  # fmt: skip
    init_rmse = np.concatenate([r.marker_rmse[u] for r, u in zip(iks, used, strict=True)])
    recent = deque(np.nan_to_num(init_rmse).tolist(), maxlen=100)
    bounds = np.cumsum([0] + [int(u.sum()) for u in used])
    segments = [slice(int(a), int(b)) for a, b in pairwise(bounds)]
    repaired = 0
    refits: list[int] = []
    last_refit = -st.refit_interval
    for it in range(1, st.iterations + 1):
        frames = sampler.draw()
        est.set_theta(theta)
        q_new, rmse_s = est.solve_rmse(markers[frames], qpos[frames])
        qpos[frames] = q_new
        limit = st.refit_factor * float(np.median(recent)) + st.refit_margin
        if np.any(rmse_s > limit) and it - last_refit >= st.refit_interval:
            # A sampled frame fits far worse than the frames solved recently: its pose is
            # caught in a local minimum (typically since the initial IK, under a model far
            # from the subject). Every frame's IK afresh under theta; keep the better poses.
            fixed = _refit(est.ik, markers, qpos, segments)
            repaired += fixed
            refits.append(it)
            last_refit = it
            if log is not None:
                log.append(f"iter {it:4d}  IK of all frames afresh: {fixed} poses improved")
            q_new, rmse_s = est.solve_rmse(markers[frames], qpos[frames])
            qpos[frames] = q_new
        recent.extend(rmse_s.tolist())
        grad, _, e0 = est.gradient_at(markers[frames], q_new)
        step = st.step * grad / len(frames)
        theta = theta - step
        if st.clip_to_bounds:
            clipped_theta = np.clip(theta, pset.lower, pset.upper)
            clipped += int(np.any(clipped_theta != theta))
            theta = clipped_theta
        energy = float(e0.sum())
        rmse = float(np.sqrt(energy / max(int(present[frames].sum()), 1)))
        gnorm = float(np.linalg.norm(grad) / len(frames))
        trace.append(
            PaperIteration(it, frames, energy, rmse, gnorm, time.perf_counter() - t_start,
                           theta.copy())
        )  # fmt: skip
        if log is not None:
            log.append(
                f"iter {it:4d}  frames {len(frames):4d}  E {energy:.6e} m^2  rmse "
                f"{rmse * 1e3:.4f} mm  |g|/N {gnorm:.3e}  max|dtheta| "
                f"{np.abs(step).max() * 1e3:.4f} mm"
            )
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    seconds = time.perf_counter() - t_start
    problems = est.problems
    # Every frame's IK under the final theta (for the result, not part of the algorithm).
    t_final = time.perf_counter()
    est.set_theta(theta)
    qpos_out, frame_rmse = [], []
    start = 0
    sq, npres = 0.0, 0
    for t, u in zip(trials, used, strict=True):
        k = int(u.sum())
        q = np.full((len(t.markers), est.kin.nq), np.nan)
        fr = np.full(len(t.markers), np.nan)
        if k:
            # Warm from the last poses, and afresh (chains, repair): each frame's better fit.
            warm = est.ik.solve_trial(t.markers[u], qpos_init=qpos[start : start + k])
            fresh = est.ik.solve_trial(t.markers[u])
            better = np.nan_to_num(fresh.marker_rmse, nan=np.inf) < np.nan_to_num(
                warm.marker_rmse, nan=np.inf
            )
            qq = np.where(better[:, None], fresh.qpos, warm.qpos)
            rr = np.where(better, fresh.marker_rmse, warm.marker_rmse)
            q[u], fr[u] = qq, rr
            ok = np.isfinite(rr)
            sq += float(np.sum(rr[ok] ** 2 * warm.n_markers[ok]))
            npres += int(warm.n_markers[ok].sum())
        qpos_out.append(q)
        frame_rmse.append(fr)
        start += k
    final_seconds = time.perf_counter() - t_final
    return PaperResult(
        theta=theta,
        theta0=theta_init,
        qpos=qpos_out,
        used=used,
        frame_rmse=frame_rmse,
        marker_rmse=float(np.sqrt(sq / max(npres, 1))),
        energy=sq,
        trace=trace,
        settings=st,
        seconds=seconds,
        init_seconds=init_seconds,
        final_seconds=final_seconds,
        ik_problems=problems,
        clipped=clipped,
        repaired=repaired,
        refits=refits,
    )


def _refit(solver: IKSolver, markers: np.ndarray, qpos: np.ndarray, segments: list[slice]) -> int:
    """Fresh IK (chains, repair) of every trial in place where it fits better; count."""
    x = solver.kin.marker_positions(qpos)
    present = np.all(np.isfinite(markers), axis=2)
    d2 = np.where(present, np.sum((np.nan_to_num(markers) - x) ** 2, axis=2), 0.0)
    before = np.sqrt(d2.sum(axis=1) / np.maximum(present.sum(axis=1), 1))
    changed = 0
    for seg in segments:
        r = solver.solve_trial(markers[seg])
        better = np.nan_to_num(r.marker_rmse, nan=np.inf) < 0.98 * before[seg]
        rows = np.arange(seg.start, seg.stop)[better]
        qpos[rows] = r.qpos[better]
        changed += int(better.sum())
    return changed


# ------------------------------------------------------------------ result folder
def reduced_information(
    pset: ParameterSet, theta: np.ndarray, trials: Sequence[TrialData], qpos: Sequence[np.ndarray]
) -> tuple[np.ndarray, float, int, int]:
    """Reduced information of theta at a solution, as the joint LM reports it.

    Same quantity as ``LMResult.reduced_information`` (Schur complement of the poses, unit
    weights, no prior; built with the LM's own normal-equation kernel).

    Returns
    -------
    information : (P, P) [1], frozen rows/columns zero
    sigma : float [m], per-axis noise estimated from the fit
    n_residuals, n_unknowns : int
    """
    from .lm import _Problem

    kin = Kinematics(pset)
    kin.set_theta(theta)
    ok = [np.all(np.isfinite(q), axis=1) for q in qpos]
    markers = np.concatenate([t.markers[u] for t, u in zip(trials, ok, strict=True)])
    q = np.concatenate([qq[u] for qq, u in zip(qpos, ok, strict=True)])
    free = np.flatnonzero(~pset.frozen)
    prob = _Problem(kin, markers, q, free)
    w = prob.present.astype(float)
    pf = free.size
    info = prob.information(w, pset.size)
    dist = prob.residuals(q)
    n_res = int(3 * prob.present.sum())
    n_unk = int(kin.nv * prob.n + pf)
    rmse = float(np.sqrt(np.sum(dist**2) / max(prob.present.sum(), 1)))
    sigma = rmse / np.sqrt(3 * max(1.0 - n_unk / max(n_res, 1), 1e-6))
    return info, float(sigma), n_res, n_unk


def as_lm_result(
    result: PaperResult, information: np.ndarray, sigma: float, n_residuals: int, n_unknowns: int
) -> LMResult:
    """The fields of :class:`LMResult` that the result folder needs, from a paper result."""
    trace = [
        IterationLog(p.iteration, p.energy, p.rmse, float("nan"), True, 0.0, p.seconds, p.theta)
        for p in result.trace
    ]
    return LMResult(
        theta=result.theta,
        theta0=result.theta0,
        qpos=result.qpos,
        used=result.used,
        marker_rmse=result.marker_rmse,
        frame_rmse=result.frame_rmse,
        reduced_information=information,
        free=np.ones(len(result.theta), dtype=bool),
        sigma=sigma,
        n_residuals=n_residuals,
        n_unknowns=n_unknowns,
        iterations=len(result.trace),
        termination=Termination.MAX_ITERATIONS,
        trace=trace,
        seconds=result.seconds,
        init_seconds=result.init_seconds,
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


def run_paper_cli(
    args: argparse.Namespace,
    pset: ParameterSet,
    trials: list[TrialData],
    ranges: list[list[int]],
    out: Path,
) -> int:
    """``mocap-mj identify --solver paper``: Algorithm 1, then the same folder as the LM path."""
    from ..cli import finish
    from ..io.atomic import atomic_write_text
    from .identifiability import Identifiability
    from .output import expected_rmse, report_lines, write_result

    if args.sampling is None:
        raise MocapError("--solver paper needs --sampling batch, even, random or stochastic")
    settings = PaperSettings(
        sampling=args.sampling,
        iterations=args.iterations,
        step=DEFAULT_STEP if args.step is None else args.step,
        delta=DEFAULT_DELTA if args.delta is None else args.delta,
        fraction=args.fraction,
        seed=args.seed,
    )
    log: list[str] = []
    result = identify_paper(trials, pset=pset, settings=settings, progress=not args.json, log=log)
    info, sigma, n_res, n_unk = reduced_information(pset, result.theta, trials, result.qpos)
    observable_std = args.observable_mm * 1e-3
    idf = Identifiability(pset, info, sigma, observable_std=observable_std, theta=result.theta)
    lm_like = as_lm_result(result, info, sigma, n_res, n_unk)
    n_frames = sum(len(t.markers) for t in trials)
    n_used = sum(int(u.sum()) for u in result.used)
    summary: dict[str, Any] = {
        "markers_files": [t.name for t in trials],
        "frames_fitted_range": ranges,
        "solver": "paper",
        "sampling": settings.sampling,
        "step": settings.step,
        "delta_m": settings.delta,
        "fraction": settings.fraction,
        "seed": settings.seed,
        "perturbed_iterations": settings.perturbed_iterations,
        "loss": "l2",
        "frames": n_frames,
        "frames_used": n_used,
        "frames_skipped": n_frames - n_used,
        "frames_per_iteration": len(result.trace[0].frames),
        "seconds": result.seconds,
        "init_seconds": result.init_seconds,
        "final_ik_seconds": result.final_seconds,
        "iterations": len(result.trace),
        "ik_problems": result.ik_problems,
        "frames_repaired": result.repaired,
        "fresh_ik_iterations": result.refits,
        "termination": Termination.MAX_ITERATIONS.value,
        "marker_rmse_mm": result.marker_rmse * 1e3,
        "energy_m2": result.energy,
        "expected_rmse_mm": expected_rmse(sigma, n_unk, n_res) * 1e3,
        "sigma_mm": sigma * 1e3,
        "observable_directions": idf.rank,
        "unobservable_directions": int(np.sum(~idf.observable)),
        "kappa_crlb_rms_mm": idf.bound_rms()[0] * 1e3,
        "offset_crlb_rms_mm": idf.bound_rms()[1] * 1e3,
        "kappa_mm": {
            n: float(v) * 1e3 for n, v in zip(pset.kappa_names, result.theta, strict=False)
        },
    }
    write_result(out, pset, lm_like, idf, trials, summary)
    lines = report_lines(pset, lm_like, idf, summary)
    cut = lines.index("## Iterations")
    lines = [
        *lines[:cut],
        "## Iterations (Algorithm 1 of Zou & Sugihara)",
        "",
        f"sampling {settings.sampling}, alpha {settings.step:g}, Delta {settings.delta:g} m, "
        f"{result.ik_problems} IK problems",
        "",
        *trace_lines(result),
        "",
    ]
    atomic_write_text(out / "report.md", "\n".join(lines))
    text = (
        f"identified {pset.size} parameters from {n_used} frames in {result.seconds:.2f} s "
        f"(Algorithm 1, {settings.sampling} sampling, {len(result.trace)} iterations, "
        f"{result.ik_problems} IK problems)\n"
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm (noise floor "
        f"{summary['expected_rmse_mm']:.3f} mm); {idf.rank} of {pset.size} directions observable\n"
        f"wrote {args.out}/model.xml, theta.json, motion.npz, identifiability.json, report.md"
    )
    return finish(args, summary, text, out)
