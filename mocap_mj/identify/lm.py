"""Joint Levenberg-Marquardt identification of theta and every frame's pose.

Minimises over theta (P,) and q_t (T frames x nv)::

    F = sum_t sum_m rho(|p_tm - x_m(q_t; theta)|)  +  1/2 lambda_p |theta - theta_0|^2

with rho(d) = d^2 / 2 (``loss="l2"``) or a robust loss (``"huber"``, ``"cauchy"``, applied as
iteratively reweighted least squares with a scale re-estimated from the residuals each
iteration). Missing samples have weight 0.

Each step solves the damped Gauss-Newton system, which has the block-arrow structure of bundle
adjustment: one nv x nv block A_t per frame, coupled to the shared parameters by B_t (nv x P).
Every frame's block is eliminated (Schur complement)::

    S = C + lambda_p I - sum_t B_t^T A_t^-1 B_t,   S dtheta = g_theta - sum_t B_t^T A_t^-1 g_t
    dq_t = A_t^-1 (g_t - B_t dtheta)

accumulated chunk by chunk over frames (memory does not grow with T beyond the trajectories
and, for up to ``cache_frames`` frames, the per-frame A_t^-1 [B_t, g_t] kept for the back
substitution; longer trials recompute them in a second pass).

Damping: Marquardt-scaled (``mu * diag``) on both blocks, mu0 = 1e-2, divided by 3 after an
accepted step and raised after a rejected one (``LMSettings.mu_decrease``). After each step
every frame finishes its own pose by per-frame LM under the new theta (``refine_iterations``).
Stopping: an accepted step that lowers F by less than ``tol_noise * sigma^2`` or
``tol_cost * F``, or a step whose largest
theta component is below ``tol_theta`` [m] and pose component below ``tol_q``, or ``mu`` beyond
1e12 (no descent possible), or ``max_iterations``.

The weak prior (``prior_sigma``, default 50 mm, relative to a 1 mm marker noise:
lambda_p = (1 mm / 50 mm)^2) pins the directions of theta that the markers cannot determine
(a lone marker turning about its joint, the pelvis frame against its markers) to the initial
model, and is negligible (< 1e-4 relative) in every direction the data determine to better
than 5 mm. The identifiability report (:mod:`mocap_mj.identify.identifiability`) names them.
"""

from __future__ import annotations

import enum
import itertools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import mujoco
import numpy as np

from .. import _schur
from .._threads import single_blas_thread
from ..errors import MocapError, SolverError, check_shape
from ..ik import IKResult, IKSettings, IKSolver, Status
from ..kinematics import Kinematics
from ..parameters import ParameterSet
from .priors import LinearGaussianPrior

#: Median of the chi distribution with 3 degrees of freedom: median |e| / sigma for 3D noise.
CHI3_MEDIAN = 1.5381722


class Termination(enum.Enum):
    NOISE = "cost change below tol_noise * sigma^2"
    STALL = "marker RMSE changed by less than stall_rel over stall_window accepted steps"
    COST = "relative cost change below tol_cost"
    STEP = "step below tol_theta and tol_q"
    NO_DESCENT = "no descent direction found (damping exhausted)"
    MAX_ITERATIONS = "iteration limit reached"


@dataclass(frozen=True)
class LMSettings:
    """Settings of the joint LM.

    Attributes
    ----------
    max_iterations : int
    tol_noise : float
        An accepted step that lowers F by less than ``tol_noise * sigma^2`` ends the solve
        (sigma: per-axis noise estimated from the fit). Near the minimum a step that lowers F
        by delta moves theta by sqrt(2 delta) / sigma standard deviations (Mahalanobis, in
        the reduced information): with 1.0, at most 1.4 standard deviations along a single
        direction, about 0.12 RMS over the ~130 observable ones. With noisy markers the last
        iterations converge linearly (the residual curvature of weakly determined joints, MTP
        and subtalar, is not in J^T J). Measured on seeds 0-9 of the demo's experiment:
        the same errors against the bound as with 0.1 (within 0.05x), 1-9 fewer iterations.
    tol_cost : float
        Relative decrease of F below which an accepted step ends the solve.
    tol_theta : float [m]
    tol_q : float [rad or m]
    mu0 : float
        Initial Marquardt damping (dimensionless).
    prior_sigma : float [m]
        Standard deviation of the weak Gaussian prior toward the initial model, stated for a
        marker noise of ``prior_noise`` (so lambda_p = (prior_noise / prior_sigma)^2).
    prior_noise : float [m]
    loss : {"l2", "huber", "cauchy"}
    loss_scale : float
        Robust threshold in units of the estimated per-axis noise sigma.
    observable_std : float [m]
        Reporting threshold: a direction of theta is observable when its standard deviation
        (reduced information and the noise estimated from the fit) is at most this.
    settle_gain : float
        Once an accepted step lowers F by less than this fraction, progress has stalled: a
        refit is tried (``refit_factor``) before the iterations go on.
    prior_ratio : float
        Every step is restricted to the eigen-directions of the reduced information (at the
        current iterate) whose information exceeds ``prior_ratio`` times the prior's. In the
        others the prior is not negligible, the data hardly constrain them, and Gauss-Newton
        would wander or crawl there: they keep their value (the initial model's).
    chunk : int
        Frames per chunk when accumulating the reduced system.
    cache_frames : int
        Keep per-frame back-substitution data up to this many frames (else recompute).
    refit_factor : float
        Every trial's IK is solved afresh with the current model (``_refit_frames``) each
        time the marker RMSE has fallen by this factor since the last such refit, when
        progress stalls (``settle_gain``) and at convergence; at most ``max_refits`` times.
    refine_iterations : int
        Per-frame IK iterations (``IKSolver.solve_frames``, each frame stops on its own
        convergence test) applied to every frame after each step, from ``q + dq`` with the
        new theta. Given theta the frames are independent, and the joint step's dq is a
        poor guess for some frames (joints at or near their limits, weakly determined toes
        and wrists): measured on seed 0, a dozen frames raised F by 40-150 sigma^2 each after
        a step the model predicted to lower it, so steps were rejected and the LM crawled.
        With 2 such iterations a frame whose first undamped steps fail never moves (its
        damping needs 4-5 rejections to grow); 30 let every frame finish. 0 disables it.
    stall_window, stall_rel : int, float
        Once settled, stop when the marker RMSE fell by less than ``stall_rel`` (relative)
        over the last ``stall_window`` accepted steps: heavily damped crawling along a
        curved valley of weakly informed directions, which changes nothing measurable.
    max_refits : int
    mu_decrease : {"nielsen", "third"}
        Damping after an accepted step: Nielsen's ``mu *= max(1/3, 1 - (2 rho - 1)^3)``, or
        ``mu /= 3`` whatever the gain ratio ("delayed gratification", Transtrum & Sethna 2012).
        With ``mu0 = 1e-2`` and "third" (the default) the first steps are damped: nearly
        undamped first steps (``mu0 = 1e-6``, Nielsen) carried a weakly observable direction
        (a toes origin, seen through its single marker) into a neighbouring minimum of higher
        cost on 6 of the seeds 0-9 (``docs/identification.md``).
    ball_limit_scale : float
        During identification the cone limit of every ball joint is widened by this factor
        (at most pi; thorax 45 -> 67.5 degrees, neck 80 -> 120, shoulders and hips to 180).
        A joint limit is not a measurement, and at a ball's cone the exact null directions of
        theta (the pelvis frame against its markers, traded against the trunk geometry)
        become "determined" by the inequality: a kinked, curved valley in which the LM
        converges linearly (measured on seed 0 of the demo's experiment, whose synthetic
        truth has the thorax at its 45 degree cone in many frames: 17 iterations and 1.3-1.6 s
        with 1.0, 10 iterations and 0.8-0.9 s with 1.5, the same final cost to 1e-8). Hinge
        limits are kept: they keep the IK out of flipped configurations. The identified poses
        may therefore turn a ball beyond the model's cone (by up to the factor); the written
        model keeps its own limits. 1.0 keeps the model's limits.
    """

    max_iterations: int = 100
    tol_noise: float = 1.0
    tol_cost: float = 1e-10
    tol_theta: float = 1e-9
    tol_q: float = 1e-8
    mu0: float = 1e-2
    prior_sigma: float = 0.05
    prior_noise: float = 0.001
    loss: str = "l2"
    loss_scale: float = 3.0
    observable_std: float = 0.005
    settle_gain: float = 1e-2
    prior_ratio: float = 100.0
    chunk: int = 1000
    cache_frames: int = 5000
    max_refits: int = 6
    stall_window: int = 5
    stall_rel: float = 1e-4
    refit_factor: float = 1.5
    refine_iterations: int = 30
    mu_decrease: str = "third"
    ball_limit_scale: float = 1.5

    def __post_init__(self) -> None:
        if self.mu_decrease not in ("nielsen", "third"):
            raise MocapError(f"mu_decrease must be 'nielsen' or 'third', got {self.mu_decrease!r}")
        if self.loss not in ("l2", "huber", "cauchy"):
            raise MocapError(f"loss must be one of l2, huber, cauchy; got {self.loss!r}")
        if self.prior_sigma <= 0 or self.prior_noise <= 0:
            raise MocapError("prior_sigma and prior_noise must be positive")
        if self.ball_limit_scale < 1.0:
            raise MocapError(f"ball_limit_scale must be >= 1, got {self.ball_limit_scale}")
        if self.max_iterations < 1 or self.chunk < 1:
            raise MocapError("max_iterations and chunk must be at least 1")

    @property
    def prior_weight(self) -> float:
        return (self.prior_noise / self.prior_sigma) ** 2


class TrialData(NamedTuple):
    """One trial's measured markers: markers (T, M, 3) [m] NaN where missing; times (T,) [s]."""

    name: str
    markers: np.ndarray
    times: np.ndarray


class IterationLog(NamedTuple):
    """One LM iteration: theta after it (P,) [m], F, marker RMSE [m], damping, timing [s]."""

    iteration: int
    cost: float  # F [m^2]
    rmse: float  # marker RMSE [m]
    mu: float
    accepted: bool
    step_theta: float  # max |dtheta| [m]
    seconds: float
    theta: np.ndarray


@dataclass
class LMResult:
    """Outcome of :func:`identify_lm`.

    Attributes
    ----------
    theta : (P,) [m]
    theta0 : (P,) [m], the initial (prior) model
    qpos : list of (T_i, nq) per trial; NaN rows for frames not used
    used : list of (T_i,) bool per trial: frames in the problem (enough markers)
    marker_rmse : float [m], over present samples of used frames (weights ignored)
    frame_rmse : list of (T_i,) [m]
    reduced_information : (P, P) [1], S without damping and prior at the solution (free
        parameters only; rows/cols of frozen ones are zero)
    sigma : float [m], per-axis noise estimated from the fit: RMSE / sqrt(3 (1 - p / n))
    n_residuals, n_unknowns : int
    iterations : int
    termination : Termination
    trace : list of IterationLog
    seconds : float
    init_seconds : float, IK before the first LM iteration
    at_bound : (P,) int, -1 / +1 for a parameter that ended at its lower / upper bound, else 0
    """

    theta: np.ndarray
    theta0: np.ndarray
    qpos: list[np.ndarray]
    used: list[np.ndarray]
    marker_rmse: float
    frame_rmse: list[np.ndarray]
    reduced_information: np.ndarray
    free: np.ndarray
    sigma: float
    n_residuals: int
    n_unknowns: int
    iterations: int
    termination: Termination
    trace: list[IterationLog] = field(default_factory=list)
    seconds: float = 0.0
    init_seconds: float = 0.0
    weights: list[np.ndarray] = field(default_factory=list)
    at_bound: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


def _robust_weights(dist: np.ndarray, present: np.ndarray, loss: str, c: float) -> np.ndarray:
    """IRLS weights (T, M) of the 3D distances for the loss with threshold c [m]."""
    if loss == "l2":
        return present.astype(float)
    if loss == "huber":
        w = np.minimum(1.0, c / np.maximum(dist, 1e-300))
    else:
        w = 1.0 / (1.0 + (dist / c) ** 2)
    return np.where(present, w, 0.0)


def _robust_cost(dist: np.ndarray, present: np.ndarray, loss: str, c: float) -> float:
    d = dist[present]
    if loss == "l2":
        return float(0.5 * np.sum(d**2))
    if loss == "huber":
        return float(np.sum(np.where(d <= c, 0.5 * d**2, c * d - 0.5 * c**2)))
    return float(np.sum(0.5 * c**2 * np.log1p((d / c) ** 2)))


class _Reduced:
    """A chunk's contribution to the damped reduced system and its back-substitution.

    Fields: s (Pf, Pf) and rhs (Pf,), the chunk's ``sum C - B^T A_d^-1 B`` and
    ``sum g_th - B^T A_d^-1 g_q``; g_theta (Pf,), diag_c (Pf,); g_q (n, nv), diag_a (n, nv).
    """

    def __init__(
        self,
        s: np.ndarray,
        rhs: np.ndarray,
        g_theta: np.ndarray,
        diag_c: np.ndarray,
        g_q: np.ndarray,
        diag_a: np.ndarray,
        step: Callable[[np.ndarray], np.ndarray],
    ) -> None:
        self.s, self.rhs, self.g_theta, self.diag_c = s, rhs, g_theta, diag_c
        self.g_q, self.diag_a = g_q, diag_a
        self.step = step  # dtheta (Pf,) -> the frames' joint steps dq (n, nv)


class _Problem:
    """Frames of all trials stacked, with the per-chunk normal-equation kernel."""

    def __init__(
        self, kin: Kinematics, markers: np.ndarray, qpos: np.ndarray, free: np.ndarray
    ) -> None:
        self.kin = kin
        self.limits = IKSolver(kin)
        self.present = np.all(np.isfinite(markers), axis=2)
        self.target = np.where(self.present[..., None], markers, 0.0)
        self.qpos = qpos
        self.free = free
        self.n = len(markers)

    def residuals(self, qpos: np.ndarray) -> np.ndarray:
        """Distances (T, M) [m] between measured and model markers (0 where missing)."""
        out = np.empty(self.present.shape)
        for s in range(0, self.n, 4096):
            x = self.kin.site_positions(qpos[s : s + 4096])
            d = self.target[s : s + 4096] - x
            out[s : s + 4096] = np.linalg.norm(d, axis=2)
        return np.where(self.present, out, 0.0)

    def reduce(self, sl: slice, w: np.ndarray, mu: float, *, limits: bool = True) -> _Reduced:
        """Frames ``sl`` eliminated with damping mu: the compiled blocks
        (:mod:`mocap_mj._schur`) or, for kinematics they do not reproduce, NumPy."""
        kin, f = self.kin, self.free
        pf = f.size
        if kin.compiled:
            tree = kin.tree()
            fb = _schur.frame_blocks(
                tree, kin.kappa_tables(), self.target[sl], w[sl], self.qpos[sl], f, mu,
                limits=limits,
            )  # fmt: skip
            yf = fb.y.reshape(-1, pf)
            c = fb.c[np.ix_(f, f)]
            s_part = c - yf.T @ yf
            rhs = fb.g_theta[f] - yf.T @ fb.y_g.reshape(-1)
            return _Reduced(
                s_part, rhs, fb.g_theta[f], np.diag(c).copy(), fb.g_q, fb.diag_a,
                lambda d: _schur.back_substitute(tree, fb, d),
            )  # fmt: skip
        a, b, gq, c, gt = self.chunk_system(sl, w, limits=limits)
        z = np.matmul(_damped_inverse(a, mu), np.concatenate([b, gq[..., None]], axis=2))
        bf = b.reshape(-1, pf)
        zf = z.reshape(-1, pf + 1)
        return _Reduced(
            c - bf.T @ zf[:, :pf], gt - bf.T @ zf[:, pf], gt, np.diag(c).copy(), gq,
            np.einsum("nii->ni", a), lambda d: z[..., pf] - z[..., :pf] @ d,
        )  # fmt: skip

    def information(self, w: np.ndarray, size: int, chunk: int = 1000) -> np.ndarray:
        """Reduced information (size, size) of theta for weights w (T, M): the Schur
        complement of the poses without damping or joint limits (a limit is not a
        measurement); frozen rows and columns zero."""
        f = self.free
        s_free = np.zeros((f.size, f.size))
        for s in range(0, self.n, chunk):
            sl = slice(s, min(s + chunk, self.n))
            if self.kin.compiled:
                # (A + 1e-12 I)^-1: B has no component in A's null space (B = J_q^T W J_th),
                # so this equals the pseudo-inverse's result to ~1e-8 relative.
                s_free += self.reduce(sl, w, 0.0, limits=False).s
                continue
            a, b, _, c, _ = self.chunk_system(sl, w, limits=False)
            ainv = np.linalg.pinv(a, hermitian=True)
            bf = b.reshape(-1, f.size)
            s_free += c - bf.T @ np.matmul(ainv, b).reshape(-1, f.size)
        info = np.zeros((size, size))
        info[np.ix_(f, f)] = 0.5 * (s_free + s_free.T)
        return info

    def chunk_system(
        self, sl: slice, w: np.ndarray, *, limits: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Normal-equation pieces of frames ``sl`` with weights w (T, M).

        With ``limits``, hinges at a joint limit that the gradient pushes outward are held
        (the step's active set); without, the blocks are those of the unconstrained problem
        (the information matrix: a limit is not a measurement).

        Returns A (n, nv, nv), B (n, nv, Pf), g_q (n, nv), C (Pf, Pf), g_theta (Pf,) over the
        free parameters.
        """
        kin = self.kin
        frames = kin.forward(self.qpos[sl])
        n, m = frames.site_xpos.shape[:2]
        sw = np.sqrt(w[sl])
        r = (self.target[sl] - frames.site_xpos) * sw[..., None]  # (n, M, 3)
        jq = kin.jac_q(frames) * sw[..., None, None]  # (n, M, 3, nv)
        jk = kin.jac_kappa(frames) * sw[..., None, None]  # (n, M, 3, K)
        rot = kin.jac_offsets(frames) * sw[..., None, None]  # (n, M, 3, 3)
        k = kin.pset.n_kappa
        p = kin.pset.size
        jqf = jq.reshape(n, 3 * m, kin.nv)
        rf = r.reshape(n, 3 * m)
        a = np.einsum("nri,nrj->nij", jqf, jqf, optimize=True)
        gq = np.einsum("nri,nr->ni", jqf, rf)
        b = np.empty((n, kin.nv, p))
        b[:, :, :k] = np.einsum("nri,nrk->nik", jqf, jk.reshape(n, 3 * m, k), optimize=True)
        b[:, :, k:] = np.einsum("nmci,nmcj->nimj", jq, rot, optimize=True).reshape(n, kin.nv, -1)
        c = np.zeros((p, p))
        jkf = jk.reshape(n * 3 * m, k)
        c[:k, :k] = jkf.T @ jkf
        ko = np.einsum("nmck,nmcj->kmj", jk, rot, optimize=True).reshape(k, -1)
        c[:k, k:] = ko
        c[k:, :k] = ko.T
        # Offsets of one marker: sum_t R^T w R = (sum_t w) I (R orthonormal).
        wsum = w[sl].sum(axis=0)
        idx = k + np.arange(3 * m)
        c[idx, idx] = np.repeat(wsum, 3)
        gt = np.empty(p)
        gt[:k] = jkf.T @ rf.reshape(-1)
        gt[k:] = np.einsum("nmcj,nmc->mj", rot, r).reshape(-1)
        # Hinges at a limit that the gradient pushes outward are held for this step (active
        # set of the box constraints): their rows and columns leave the frame's block.
        blocked = self.limits.blocked(self.qpos[sl], gq) if limits else None
        if blocked is not None and np.any(blocked):
            rows, dofs = np.nonzero(blocked)
            a[rows, dofs, :] = 0.0
            a[rows, :, dofs] = 0.0
            a[rows, dofs, dofs] = 1.0
            b[rows, dofs, :] = 0.0
            gq[rows, dofs] = 0.0
        f = self.free
        return a, b[:, :, f], gq, c[np.ix_(f, f)], gt[f]


def _damped_inverse(a: np.ndarray, mu: float) -> np.ndarray:
    diag = np.einsum("nii->ni", a)
    ad = a.copy()
    idx = np.arange(a.shape[1])
    ad[:, idx, idx] += mu * diag + 1e-12
    return np.linalg.inv(ad)


def _informed_basis(s_mat: np.ndarray, min_information: float) -> np.ndarray:
    """Orthonormal basis (Pf, r) of the eigen-directions of S with information above a floor."""
    lam, vec = np.linalg.eigh(0.5 * (s_mat + s_mat.T))
    return vec[:, lam > min_information]


def _bounded_step(
    s_info: np.ndarray,
    s_damped: np.ndarray,
    rhs: np.ndarray,
    min_information: float,
    theta: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> np.ndarray:
    """#14: the damped step dtheta (Pf,) [m] in the informed directions, with an active set.

    A parameter at a bound whose step points outward is held (its row and column leave the
    system) and the step re-solved, up to 5 times; the step is then clipped so that
    ``theta + dtheta`` stays within [lo, hi].
    """
    move = np.ones(theta.size, dtype=bool)
    at_lo = theta <= lo
    at_hi = theta >= hi
    dth = np.zeros(theta.size)
    for _ in range(5):
        idx = np.flatnonzero(move)
        if idx.size == 0:
            break
        sub = np.ix_(idx, idx)
        basis = _informed_basis(s_info[sub], min_information)
        y = np.linalg.solve(basis.T @ s_damped[sub] @ basis, basis.T @ rhs[idx])
        dth = np.zeros(theta.size)
        dth[idx] = basis @ y
        held = move & ((at_lo & (dth < 0)) | (at_hi & (dth > 0)))
        if not held.any():
            break
        move &= ~held
    dth[~move] = 0.0
    return np.clip(theta + dth, lo, hi) - theta


def _refit_frames(
    solver: IKSolver, markers: np.ndarray, prob: _Problem, segments: list[slice]
) -> np.ndarray:
    """Solve every trial's IK afresh with the current theta; keep each frame's better pose.

    The initial IK ran with a model far from the subject, where whole stretches of frames can
    settle in a wrong configuration (an arm twisted about itself, a foot flipped) that the
    joint iterations cannot leave. With the model improved, a fresh IK (new chain starts,
    repair from neighbours) finds the right one. Returns the indices of frames replaced.
    """
    before = prob.residuals(prob.qpos)
    pres = np.maximum(prob.present.sum(axis=1), 1)
    rmse_before = np.sqrt(np.sum(before**2, axis=1) / pres)
    changed = []
    for seg in segments:
        r = solver.solve_trial(markers[seg])
        rows = np.arange(seg.start, seg.stop)
        better = np.nan_to_num(r.marker_rmse, nan=np.inf) < 0.98 * rmse_before[rows]
        prob.qpos[rows[better]] = r.qpos[better]
        changed.append(rows[better])
    return np.concatenate(changed) if changed else np.zeros(0, dtype=int)


def _widen_ball_limits(kin: Kinematics, scale: float) -> None:
    """Widen the cone limit of every limited ball joint of kin's own model copy by ``scale``
    (at most pi): see ``LMSettings.ball_limit_scale``."""
    m = kin.model
    ball = (m.jnt_type == mujoco.mjtJoint.mjJNT_BALL) & (m.jnt_limited > 0)
    m.jnt_range[ball, 1] = np.minimum(m.jnt_range[ball, 1] * scale, np.pi)


def initial_ik(
    kin: Kinematics, trials: Sequence[TrialData], ik_settings: IKSettings | None = None
) -> list[IKResult]:
    """IK of every trial with the kinematics' current theta."""
    solver = IKSolver(kin, ik_settings)
    return [solver.solve_trial(t.markers) for t in trials]


@single_blas_thread
def identify_lm(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet | None = None,
    theta0: np.ndarray | None = None,
    settings: LMSettings | None = None,
    ik_settings: IKSettings | None = None,
    initial_qpos: Sequence[np.ndarray] | None = None,
    progress: bool = False,
    log: list[str] | None = None,
    priors: Sequence[LinearGaussianPrior] = (),
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> LMResult:
    """Identify theta and the motion of every trial by joint Levenberg-Marquardt.

    Parameters
    ----------
    trials : sequence of TrialData
        One or more trials of one subject; theta is shared.
    pset : ParameterSet, optional
        The parameterisation (bundled humanoid by default); its ``frozen`` flags are honoured.
    theta0 : (P,) [m], optional
        Initial model and prior mean (default ``pset.nominal``).
    initial_qpos : sequence of (T_i, nq), optional
        Starting poses per trial (default: IK with theta0).
    progress : bool
        Show a progress bar over the iterations.
    log : list of str, optional
        Receives one line per iteration.
    priors : sequence of LinearGaussianPrior
        Added to F, its gradient and the reduced system (:mod:`mocap_mj.identify.priors`).
    lower, upper : (P,) [m], optional
        Bounds of theta (-inf / inf: none), kept by an active set: a parameter at a bound whose
        step points outward is held for that step, and every step is clipped to the box.
        theta0's free entries are clipped into the box first. ``LMResult.at_bound`` says
        which ended at a bound.
    """
    st = settings or LMSettings()
    pset = pset or ParameterSet()
    theta = pset.check(pset.nominal if theta0 is None else theta0).copy()
    # ---- #14: priors and bounds (the same semantics as #13's solver layer; keep one) ----
    lo = np.full(pset.size, -np.inf) if lower is None else np.asarray(lower, dtype=float)
    hi = np.full(pset.size, np.inf) if upper is None else np.asarray(upper, dtype=float)
    check_shape("lower", lo, (pset.size,))
    check_shape("upper", hi, (pset.size,))
    if np.any(lo > hi):
        raise MocapError("lower bound above upper bound for " + ", ".join(
            pset.names[i] for i in np.flatnonzero(lo > hi)))  # fmt: skip
    free = np.flatnonzero(~pset.frozen)
    theta[free] = np.clip(theta[free], lo[free], hi[free])  # frozen ones keep their value
    h_prior = sum((p.hessian() for p in priors), np.zeros((pset.size, pset.size)))
    h_prior_f = h_prior[np.ix_(free, free)]

    def prior_cost(th: np.ndarray) -> float:
        return float(sum(p.cost(th) for p in priors))

    def prior_gradient(th: np.ndarray) -> np.ndarray:
        return sum((p.gradient(th) for p in priors), np.zeros(pset.size))[free]

    # ---- end #14 ----
    theta_init = theta.copy()
    if free.size == 0:
        raise SolverError("every parameter is frozen: nothing to identify")
    if not trials:
        raise SolverError("no trials given")
    for t in trials:
        check_shape(f"{t.name}: markers", t.markers, (None, pset.n_markers, 3))
    kin = Kinematics(pset)
    _widen_ball_limits(kin, st.ball_limit_scale)
    kin.set_theta(theta)
    t_start = time.perf_counter()
    if initial_qpos is None:
        iks = initial_ik(kin, trials, ik_settings)
        init_q = [r.qpos for r in iks]
        used = [r.status != Status.TOO_FEW_MARKERS for r in iks]
    else:
        init_q = [np.asarray(q, dtype=float) for q in initial_qpos]
        used = [np.all(np.isfinite(q), axis=1) for q in init_q]
    init_seconds = time.perf_counter() - t_start
    if sum(int(u.sum()) for u in used) == 0:
        raise SolverError("no frame has enough markers to be solved")
    markers = np.concatenate([t.markers[u] for t, u in zip(trials, used, strict=True)])
    bounds = np.cumsum([0] + [int(u.sum()) for u in used])
    segments = [slice(a, b) for a, b in itertools.pairwise(bounds)]
    qpos = np.concatenate([q[u] for q, u in zip(init_q, used, strict=True)])
    prob = _Problem(kin, markers, qpos, free)
    n = prob.n
    nv = kin.nv
    pf = free.size
    lam = st.prior_weight
    chunks = [slice(s, min(s + st.chunk, n)) for s in range(0, n, st.chunk)]
    cache = n <= st.cache_frames

    def scale_of(dist: np.ndarray) -> float:
        d = dist[prob.present]
        return float(np.median(d) / CHI3_MEDIAN) if d.size else 1e-3

    def total_cost(dist: np.ndarray, th: np.ndarray, c: float) -> float:
        dth = th - theta_init
        weak = 0.5 * lam * float(dth @ dth)
        return _robust_cost(dist, prob.present, st.loss, c) + weak + prior_cost(th)

    dist = prob.residuals(qpos)
    mu = st.mu0
    nu = 2.0
    trace: list[IterationLog] = []
    termination = Termination.MAX_ITERATIONS
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=st.max_iterations, desc="identify (LM)", unit="it", leave=False, delay=2)
    limits = prob.limits
    refits = 0
    last_refit_it = -10
    last_refit_rmse = float(np.sqrt(np.sum(dist**2) / prob.present.sum()))
    it = 0
    settled = False
    accepted_rmse: list[float] = []
    n_res_now = int(3 * prob.present.sum())
    while it < st.max_iterations:
        it += 1
        t_it = time.perf_counter()
        c_loss = st.loss_scale * scale_of(dist)
        w = _robust_weights(dist, prob.present, st.loss, c_loss)
        cost = total_cost(dist, theta, c_loss)
        # Build and solve the damped reduced system (retrying with more damping if needed).
        s_mat = np.zeros((pf, pf))
        rhs = np.zeros(pf)
        g_theta = np.zeros(pf)
        diag_c = np.zeros(pf)
        g_q = np.empty((n, nv))
        diag_a = np.empty((n, nv))
        z_cache: list[_Reduced] = []
        for sl in chunks:
            red = prob.reduce(sl, w, mu)
            g_q[sl] = red.g_q
            diag_a[sl] = red.diag_a
            g_theta += red.g_theta
            s_mat += red.s
            rhs += red.rhs
            diag_c += red.diag_c
            if cache:
                z_cache.append(red)
        gprior = lam * (theta - theta_init)[free] + prior_gradient(theta)
        # Steps stay in the directions the data (or the anatomical priors) inform.
        diag_p = np.diag(h_prior_f)
        s_damped = (
            s_mat + h_prior_f + np.diag(lam + mu * (diag_c + lam + diag_p)) + 1e-15 * np.eye(pf)
        )
        dth_f = _bounded_step(
            s_mat + h_prior_f, s_damped, rhs - gprior, st.prior_ratio * lam,
            theta[free], lo[free], hi[free],
        )  # fmt: skip
        dq = np.empty((n, nv))
        for i, sl in enumerate(chunks):
            red = z_cache[i] if cache else prob.reduce(sl, w, mu)
            dq[sl] = red.step(dth_f)
        theta_new = theta.copy()
        theta_new[free] += dth_f
        kin.set_theta(theta_new)
        q_new = limits.project(kin.integrate(prob.qpos, dq))
        if st.refine_iterations > 0:
            # Given theta_new the frames are independent: a few per-frame IK iterations (own
            # damping, box-constrained at the joint limits) from q + dq finish their step.
            q_new = limits.solve_frames(markers, q_new, w, max_iterations=st.refine_iterations).qpos
        dist_new = prob.residuals(q_new)
        cost_new = total_cost(dist_new, theta_new, c_loss)
        # Decrease predicted by the damped quadratic model: 1/2 h^T (mu D h + g) (Nielsen).
        h_g = float(np.einsum("ni,ni->", dq, g_q) + dth_f @ (g_theta - gprior))
        h_dh = float(
            np.einsum("ni,ni,ni->", dq, diag_a, dq) + dth_f @ ((diag_c + lam + diag_p) * dth_f)
        )
        predicted = max(0.5 * (h_g + mu * h_dh), 1e-300)
        rho = (cost - cost_new) / predicted
        accepted = cost_new < cost
        if accepted:
            theta, prob.qpos, dist = theta_new, q_new, dist_new
            mu *= max(1 / 3, 1 - (2 * rho - 1) ** 3) if st.mu_decrease == "nielsen" else 1 / 3
            nu = 2.0
        else:
            kin.set_theta(theta)
            mu *= nu
            nu *= 2
        rmse = float(np.sqrt(np.sum(dist**2) / prob.present.sum()))
        step = float(np.abs(dth_f).max())
        trace.append(
            IterationLog(it, cost_new if accepted else cost, rmse, mu, accepted, step,
                         time.perf_counter() - t_it, theta.copy())
        )  # fmt: skip
        if log is not None:
            log.append(
                f"iter {it:3d}  F {trace[-1].cost:.6e}  rmse {rmse * 1e3:.4f} mm  mu {mu:.1e}  "
                f"{'accepted' if accepted else 'rejected'}  max|dtheta| {step * 1e3:.4f} mm"
            )
        if bar is not None:
            bar.update(1)
        # A fresh IK of every trial with the current model (``_refit_frames``) whenever the
        # model has improved markedly since the last one, and when progress stalls.
        improved = accepted and rmse < last_refit_rmse / st.refit_factor
        stalled = accepted and cost - cost_new < st.settle_gain * cost and not settled
        if (improved or stalled) and refits < st.max_refits:
            fixed = _refit_frames(limits, markers, prob, segments)
            refits += 1
            last_refit_it = it
            if len(fixed):
                dist = prob.residuals(prob.qpos)
                last_refit_rmse = float(np.sqrt(np.sum(dist**2) / prob.present.sum()))
                if log is not None:
                    log.append(f"refit: {len(fixed)} frames had a better pose by a fresh IK")
                continue
            last_refit_rmse = rmse
        if stalled:
            settled = True
        sigma_now = rmse / np.sqrt(3 * max(1.0 - (n * nv + pf) / n_res_now, 1e-6))
        stop = None
        if accepted and it > 1 and cost - cost_new <= st.tol_noise * sigma_now**2:
            stop = Termination.NOISE
        elif accepted and cost - cost_new <= st.tol_cost * cost:
            stop = Termination.COST
        elif accepted and step < st.tol_theta and np.abs(dq).max() < st.tol_q:
            stop = Termination.STEP
        elif mu > 1e12:
            stop = Termination.NO_DESCENT
        if accepted:
            accepted_rmse.append(rmse)
        if (
            stop is None
            and settled
            and len(accepted_rmse) > st.stall_window
            and accepted_rmse[-st.stall_window - 1] - rmse < st.stall_rel * rmse
        ):
            stop = Termination.STALL
        if stop is not None:
            # Frames caught in a local minimum of their pose (typically from the initial IK
            # with a model far from the subject) show up now as outliers of the fit: re-solve
            # them from their neighbours with the current model and go on if any improved.
            # (Not again if a refit a few iterations ago found nothing better.)
            fresh = refits < st.max_refits and it - last_refit_it > 3
            fixed = (
                _refit_frames(limits, markers, prob, segments) if fresh else np.zeros(0, dtype=int)
            )
            refits += int(fresh)
            last_refit_it = it if fresh else last_refit_it
            if len(fixed) == 0:
                termination = stop
                break
            dist = prob.residuals(prob.qpos)
            mu, nu = st.mu0, 2.0
            settled = False
            if log is not None:
                log.append(f"repaired {len(fixed)} frames caught in local minima; continuing")
    if bar is not None:
        bar.close()
    kin.set_theta(theta)
    # Reduced information (no damping, no prior, unit weights) at the solution.
    c_loss = st.loss_scale * scale_of(dist)
    w_final = _robust_weights(dist, prob.present, st.loss, c_loss)
    info = prob.information(w_final, pset.size, st.chunk)
    n_res = int(3 * prob.present.sum())
    n_unk = int(nv * n + pf)
    rmse = float(np.sqrt(np.sum(dist**2) / prob.present.sum()))
    dof = max(1.0 - n_unk / n_res, 1e-6)
    sigma = rmse / np.sqrt(3 * dof)
    # Back to per-trial arrays.
    qpos_out, frame_rmse, weights_out = [], [], []
    start = 0
    for t, u in zip(trials, used, strict=True):
        k = int(u.sum())
        q = np.full((len(t.markers), kin.nq), np.nan)
        q[u] = prob.qpos[start : start + k]
        fr = np.full(len(t.markers), np.nan)
        pres = prob.present[start : start + k]
        d = dist[start : start + k]
        fr[u] = np.sqrt(np.sum(d**2, axis=1) / np.maximum(pres.sum(axis=1), 1))
        wt = np.zeros((len(t.markers), pset.n_markers))
        wt[u] = w_final[start : start + k]
        qpos_out.append(q)
        frame_rmse.append(fr)
        weights_out.append(wt)
        start += k
    return LMResult(
        theta=theta,
        theta0=theta_init,
        qpos=qpos_out,
        used=used,
        marker_rmse=rmse,
        frame_rmse=frame_rmse,
        reduced_information=info,
        free=~pset.frozen.copy(),
        sigma=float(sigma),
        n_residuals=n_res,
        n_unknowns=n_unk,
        iterations=it,
        termination=termination,
        trace=trace,
        seconds=time.perf_counter() - t_start,
        init_seconds=init_seconds,
        weights=weights_out,
        at_bound=np.where(theta <= lo, -1, np.where(theta >= hi, 1, 0)),
    )
