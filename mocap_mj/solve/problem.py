"""The identification problem: theta (P,) and the poses of every frame, given the markers.

Minimised over theta and q_t (the used frames of all trials, pooled)::

    F = sum_t sum_m rho(|p_tm - x_m(q_t; theta)|)  +  sum_k prior_k(theta),
    lower <= theta <= upper

with a robust loss rho (:mod:`mocap_mj.solve.losses`; missing samples have weight 0),
priors (:mod:`mocap_mj.solve.priors`) and an optional box. The problem owns the pooled data,
the residuals, the cost, the Gauss-Newton blocks (per-frame pose blocks eliminated by the
Schur complement, :mod:`mocap_mj.kernels._schur`) and the reduced information; solvers
(:mod:`mocap_mj.solve.lm`, :mod:`mocap_synth.paper`) own only their iterations.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from os import PathLike
from typing import NamedTuple

import numpy as np

from mocap_mj.capture.marker_set import measured_dofs
from mocap_mj.kernels import _schur
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.losses import L2, Loss, Weighted
from mocap_mj.solve.priors import LinearGaussianPrior, Prior, total_prior, weak_prior

from .. import arguments
from ..errors import ArgumentError, MocapError, SolverError, check_shape, excerpt

#: Median of the chi distribution with 3 degrees of freedom: median |e| / sigma for 3D noise.
CHI3_MEDIAN = 1.5381722


class _Trial(NamedTuple):
    """:class:`TrialData`'s fields (a NamedTuple's own ``__new__`` cannot be replaced)."""

    name: str
    markers: np.ndarray
    times: np.ndarray
    weights: np.ndarray | None = None


class TrialData(_Trial):
    """One trial's measured markers: markers (T, M, 3) [m] NaN where missing; times (T,) [s];
    weights (T, M) [1] or None: each sample's weight in the loss (its noise variance relative
    to the nominal one, inverted: :class:`~mocap_mj.solve.losses.Weighted`; default None,
    every sample 1, the white-noise model; the soft-tissue sliding of landmark markers sets
    them, :mod:`mocap_mj.anatomy.tissue`).

    Checked when built (:func:`trial_arrays`): array-likes become float arrays, a bad one
    raises :class:`~mocap_mj.errors.ArgumentError` naming the trial and the field."""

    __slots__ = ()

    def __new__(
        cls,
        name: str,
        markers: np.ndarray,
        times: np.ndarray,
        weights: np.ndarray | None = None,
    ) -> TrialData:
        return super().__new__(cls, *trial_arrays(name, markers, times, weights))


def trial_arrays(
    name: object, markers: object, times: object, weights: object = None
) -> tuple[str, np.ndarray, np.ndarray, np.ndarray | None]:
    """A trial's fields checked (:mod:`mocap_mj.arguments`): name a text (a path converts),
    markers (T, M, 3) [m] finite or NaN, times (T,) [s] finite and strictly increasing,
    weights None or (T, M) [1] finite and not negative."""
    if isinstance(name, PathLike):
        name = str(name)
    arguments.kind("TrialData name", name, str, "a text (the trial's name or file)")
    where = f"TrialData {excerpt(name)}"
    m = arguments.array(f"{where}: markers", markers, (None, None, 3), missing=True)
    t = arguments.array(f"{where}: times", times, (len(m),))
    arguments.increasing(f"{where}: times", t)
    w = None
    if weights is not None:
        w = arguments.array(f"{where}: weights", weights, m.shape[:2])
        if (w < 0).any():
            raise ArgumentError(f"{where}: weights: expected weights >= 0, got {w.min():g}")
    return str(name), m, t, w


def pool(
    trials: Sequence[TrialData], qpos: Sequence[np.ndarray], used: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """The used frames (``used[i]`` (T_i,) bool) of every trial stacked: markers (n, M, 3) [m]
    and their poses (n, nq) from qpos (T_i, nq) per trial."""
    markers = np.concatenate([t.markers[u] for t, u in zip(trials, used, strict=True)])
    q = np.concatenate([np.asarray(qq, dtype=float)[u] for qq, u in zip(qpos, used, strict=True)])
    return markers, q


def unpool(rows: np.ndarray, used: Sequence[np.ndarray], fill: float = np.nan) -> list[np.ndarray]:
    """Per-trial arrays (T_i, ...) from pooled rows (n, ...): ``fill`` where a frame was unused."""
    out, start = [], 0
    for u in used:
        k = int(u.sum())
        a = np.full((len(u), *rows.shape[1:]), fill)
        a[u] = rows[start : start + k]
        out.append(a)
        start += k
    return out


def check_bounds(
    size: int, lower: np.ndarray | None, upper: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The box (lower, upper), each (P,) [m], with -inf/+inf for a side not given."""
    lo = np.full(size, -np.inf) if lower is None else np.asarray(lower, dtype=float).copy()
    hi = np.full(size, np.inf) if upper is None else np.asarray(upper, dtype=float).copy()
    check_shape("lower", lo, (size,))
    check_shape("upper", hi, (size,))
    if np.any(lo > hi):
        i = int(np.flatnonzero(lo > hi)[0])
        raise MocapError(f"bounds: lower[{i}] = {lo[i]} exceeds upper[{i}] = {hi[i]}")
    return lo, hi


@dataclass(frozen=True, eq=False)
class Bounds:
    """A box on theta: ``lower <= theta <= upper``.

    Attributes
    ----------
    lower, upper : (P,) [m] or None
        Each side's bound per parameter (-inf or +inf: that parameter unbounded on that
        side); None: no bound on that side (the default: no box). Checked when a problem is
        built (:func:`check_bounds`). ``Bounds(*theta_bounds(pset, subject))`` is the box of
        the anatomical ranges (:func:`~mocap_mj.anatomy.ranges.theta_bounds`).
    """

    lower: np.ndarray | None = None
    upper: np.ndarray | None = None

    def arrays(self, size: int) -> tuple[np.ndarray, np.ndarray]:
        """The box (lower, upper), each (size,) [m], checked (:func:`check_bounds`)."""
        return check_bounds(size, self.lower, self.upper)


class ReducedChunk(NamedTuple):
    """A chunk of frames eliminated from the damped Gauss-Newton system.

    s (Pf, Pf) and rhs (Pf,): the chunk's ``C - B^T A_d^-1 B`` and ``g_th - B^T A_d^-1 g_q``;
    g_theta (Pf,), diag_c (Pf,); g_q (n, nv), diag_a (n, nv); ``step`` maps dtheta (Pf,) [m]
    to the frames' pose steps dq (n, nv).
    """

    s: np.ndarray
    rhs: np.ndarray
    g_theta: np.ndarray
    diag_c: np.ndarray
    g_q: np.ndarray
    diag_a: np.ndarray
    step: Callable[[np.ndarray], np.ndarray]


class FitStatistics(NamedTuple):
    """rmse [m] over present samples, sigma [m] per-axis noise RMSE / sqrt(3 (1 - p / n)),
    n_residuals (3 x present samples) and n_unknowns (per frame the joint dofs its present
    markers determine, :func:`mocap_mj.capture.marker_set.measured_dofs`, + free parameters)."""

    rmse: float
    sigma: float
    n_residuals: int
    n_unknowns: int


def loss_threshold(distances: np.ndarray, factor: float) -> float:
    """Robust threshold c [m]: ``factor`` times the per-axis noise estimated from the median
    of the present marker distances (K,) [m] (median |e| / sigma = 1.538 for 3D Gaussian
    noise); ``factor`` x 1 mm without any distance."""
    d = np.asarray(distances, dtype=float)
    return factor * (float(np.median(d)) / CHI3_MEDIAN if d.size else 1e-3)


def _per_axis_noise(rmse: float, n_res: int, n_unk: int) -> float:
    """Per-axis noise [m] from a 3D marker RMSE [m]: rmse / sqrt(3 (1 - unknowns /
    residuals)), the residuals' degrees of freedom taken out."""
    return float(rmse / np.sqrt(3 * max(1.0 - n_unk / max(n_res, 1), 1e-6)))


@dataclass(frozen=True, eq=False)
class ProblemOptions:
    """The choices of an :class:`IdentificationProblem`'s objective beyond its data.

    Attributes
    ----------
    theta0 : (P,) [m] or None
        The initial model (default None: the kinematics' theta when the problem is built).
    priors : sequence of Prior
        The priors summed into F (default: none).
    bounds : Bounds or None
        The box on theta (default None: unbounded).
    loss : Loss or None
        The marker loss rho (default None: :class:`~mocap_mj.solve.losses.L2`).
    """

    theta0: np.ndarray | None = None
    priors: Sequence[Prior] = ()
    bounds: Bounds | None = None
    loss: Loss | None = None


class IdentificationProblem:
    """Pooled frames, loss, priors and box of one identification (see the module docstring).

    Parameters
    ----------
    kin : Kinematics at the current theta (the problem sets it; its joint limits are used)
    markers : (n, M, 3) [m], NaN where missing
    qpos : (n, nq), the current poses (updated in place by solvers)
    free : (Pf,) int, indices of the parameters identified
    options : ProblemOptions or None, the initial model, priors, box and loss (default
        None: ``ProblemOptions()``, the kinematics' theta, no prior, no box, L2)
    used : list of (T_i,) bool, the frames of each trial pooled here, in order (default: one
        trial, every frame)
    weights : (n, M) [1] or None, per-sample weights of the loss (default None: all 1), see
        :class:`~mocap_mj.solve.losses.Weighted`
    """

    def __init__(
        self,
        kin: Kinematics,
        markers: np.ndarray,
        qpos: np.ndarray,
        free: np.ndarray,
        *,
        options: ProblemOptions | None = None,
        used: Sequence[np.ndarray] | None = None,
        weights: np.ndarray | None = None,
    ) -> None:
        opt = options or ProblemOptions()
        self.kin = kin
        self.limits = IKSolver(kin)
        self.markers = markers
        self.present = np.all(np.isfinite(markers), axis=2)
        # The joint dofs the data determine (those of bodies without a present marker have a
        # zero Jacobian and stay where they start): the unknowns of the noise estimate.
        self.n_dofs = int(measured_dofs(kin.pset.model, self.present).sum())
        self.target = np.where(self.present[..., None], markers, 0.0)
        self.qpos = qpos
        self.free = np.asarray(free, dtype=int)
        self.n = len(markers)
        self.theta0 = (
            kin.theta.copy() if opt.theta0 is None else np.asarray(opt.theta0, dtype=float)
        )
        self.priors = tuple(opt.priors)
        self._prior_hessian: np.ndarray | None = None
        self.lower, self.upper = (opt.bounds or Bounds()).arrays(kin.pset.size)
        self.loss: Loss = L2() if opt.loss is None else opt.loss
        # The per-sample weights (n, M) [1] or None, also what a refit's fresh IK weighs by.
        self.sample_weights: np.ndarray | None = None
        if weights is not None:
            check_shape("weights", weights, self.present.shape)
            self.sample_weights = np.asarray(weights, dtype=float)
            self.loss = Weighted(self.loss, self.sample_weights)
        self.used = [np.ones(self.n, dtype=bool)] if used is None else [np.asarray(u) for u in used]
        self.segments = self.segments_of(self.used)
        if self.segments[-1].stop != self.n:
            raise MocapError(f"used frames ({self.segments[-1].stop}) != rows ({self.n})")

    @staticmethod
    def segments_of(used: Sequence[np.ndarray]) -> list[slice]:
        """The pooled rows of each trial, from the used frames (T_i,) bool of each."""
        edges = np.cumsum([0] + [int(u.sum()) for u in used])
        return [slice(int(a), int(b)) for a, b in itertools.pairwise(edges)]

    def residuals(self, qpos: np.ndarray) -> np.ndarray:
        """Distances (n, M) [m] between measured and model markers (0 where missing)."""
        out = np.empty(self.present.shape)
        for s in range(0, self.n, 4096):
            x = self.kin.site_positions(qpos[s : s + 4096])
            out[s : s + 4096] = np.linalg.norm(self.target[s : s + 4096] - x, axis=2)
        return np.where(self.present, out, 0.0)

    def loss_scale(self, dist: np.ndarray, factor: float) -> float:
        """Robust threshold c [m] of the present distances (:func:`loss_threshold`)."""
        return loss_threshold(dist[self.present], factor)

    def prior(self, theta: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Summed prior cost [m^2], gradient (Pf,) and Hessian (Pf, Pf) over the free set
        (the Hessian, constant by :class:`Prior`'s contract, is formed once)."""
        cost, grad, self._prior_hessian = total_prior(
            self.priors, theta, self.free, self._prior_hessian
        )
        return cost, grad, self._prior_hessian

    def cost(self, dist: np.ndarray, theta: np.ndarray, c: float) -> float:
        """F [m^2] for distances dist (n, M) [m], theta (P,) [m] and loss threshold c [m]."""
        return self.loss.value(dist, self.present, c) + sum(p.cost(theta) for p in self.priors)

    def statistics(self, dist: np.ndarray) -> FitStatistics:
        """RMSE and noise estimate of distances dist (n, M) [m]."""
        n_res = int(3 * self.present.sum())
        n_unk = self.n_dofs + int(self.free.size)
        rmse = float(np.sqrt(np.sum(dist**2) / max(self.present.sum(), 1)))
        return FitStatistics(rmse, _per_axis_noise(rmse, n_res, n_unk), n_res, n_unk)

    def weighted_sigma(self, dist: np.ndarray) -> float:
        """The noise estimate [m] of :meth:`statistics` with each sample weighed by its
        ``sample_weights`` (the same without them): the noise of a unit-weight sample, in the
        units of the weighted cost F that the solver's noise test compares a gain with. A
        weighed-down sample (a sliding landmark) would otherwise inflate it, and the solver
        would stop while F still falls by more than the noise."""
        if self.sample_weights is None:
            return self.statistics(dist).sigma
        w = np.where(self.present, self.sample_weights, 0.0)
        rmse = float(np.sqrt(np.sum(w * dist**2) / max(self.present.sum(), 1)))
        return _per_axis_noise(rmse, int(3 * self.present.sum()), self.n_dofs + self.free.size)

    def reduce(self, sl: slice, w: np.ndarray, mu: float, *, limits: bool = True) -> ReducedChunk:
        """Frames ``sl`` with weights w (n, M) eliminated with damping mu (compiled blocks).

        With ``limits``, hinges at a joint limit that the gradient pushes outward are held
        (the step's active set); without, the blocks are those of the unconstrained problem.
        """
        kin, f = self.kin, self.free
        tree = kin.tree()
        fb = _schur.frame_blocks(
            tree, kin.kappa_tables(), self.target[sl], w[sl], self.qpos[sl], f, mu, limits=limits
        )
        c = fb.c[np.ix_(f, f)]
        return ReducedChunk(
            c - fb.yty,
            fb.g_theta[f] - fb.ytg,
            fb.g_theta[f],
            np.diag(c).copy(),
            fb.g_q,
            fb.diag_a,
            lambda d: _schur.back_substitute(tree, fb, d),
        )

    def information(self, w: np.ndarray, chunk: int = 1000) -> np.ndarray:
        """Reduced information (P, P) [1] of theta for weights w (n, M): the Schur complement
        of the poses without damping, prior or joint limits (a limit is not a measurement);
        frozen rows and columns zero.

        Uses (A + 1e-12 I)^-1: B has no component in A's null space (B = J_q^T W J_th), so
        this equals the pseudo-inverse's result to ~1e-8 relative.
        """
        f = self.free
        s_free = np.zeros((f.size, f.size))
        for s in range(0, self.n, chunk):
            s_free += self.reduce(slice(s, min(s + chunk, self.n)), w, 0.0, limits=False).s
        size = self.kin.pset.size
        info = np.zeros((size, size))
        info[np.ix_(f, f)] = 0.5 * (s_free + s_free.T)
        return info

    def normal_blocks(
        self, sl: slice, w: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Unconstrained normal-equation pieces of frames ``sl`` with weights w (n, M), in NumPy.

        Returns A (n, nv, nv), B (n, nv, Pf), g_q (n, nv), C (Pf, Pf), g_theta (Pf,) over the
        free parameters (the per-frame blocks that :mod:`mocap_mj.kernels._schur` eliminates).
        """
        kin = self.kin
        frames = kin.forward(self.qpos[sl])
        n, m = frames.site_xpos.shape[:2]
        sw = np.sqrt(w[sl])
        r = (self.target[sl] - frames.site_xpos) * sw[..., None]  # (n, M, 3)
        jq = kin.jac_q(frames) * sw[..., None, None]  # (n, M, 3, nv)
        jk = kin.jac_kappa(frames) * sw[..., None, None]  # (n, M, 3, K)
        rot = kin.jac_offsets(frames) * sw[..., None, None]  # (n, M, 3, 3)
        k, p = kin.pset.n_kappa, kin.pset.size
        jqf = jq.reshape(n, 3 * m, kin.nv)
        a = np.einsum("nri,nrj->nij", jqf, jqf, optimize=True)
        gq = np.einsum("nri,nr->ni", jqf, r.reshape(n, 3 * m))
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
        idx = k + np.arange(3 * m)
        c[idx, idx] = np.repeat(w[sl].sum(axis=0), 3)
        gt = np.empty(p)
        gt[:k] = jkf.T @ r.reshape(-1)
        gt[k:] = np.einsum("nmcj,nmc->mj", rot, r).reshape(-1)
        f = self.free
        return a, b[:, :, f], gq, c[np.ix_(f, f)], gt[f]


def build_problem(
    kin: Kinematics,
    trials: Sequence[TrialData],
    qpos: Sequence[np.ndarray],
    used: Sequence[np.ndarray],
    free: np.ndarray,
    options: ProblemOptions | None = None,
) -> IdentificationProblem:
    """The problem over the used frames (``used[i]`` (T_i,) bool) of the trials, from poses
    qpos (T_i, nq) per trial, with ``options`` (default: ``ProblemOptions()``); the trials'
    sample weights pooled alike (1 for a trial without)."""
    if sum(int(u.sum()) for u in used) == 0:
        raise SolverError("no frame has enough markers to be solved")
    markers, q = pool(trials, qpos, used)
    weights = None
    if any(t.weights is not None for t in trials):
        weights = np.concatenate(
            [
                np.ones(t.markers.shape[:2])[u] if t.weights is None else np.asarray(t.weights)[u]
                for t, u in zip(trials, used, strict=True)
            ]
        )
    return IdentificationProblem(kin, markers, q, free, options=options, used=used, weights=weights)


def reduced_information(
    pset: ParameterSet, theta: np.ndarray, trials: Sequence[TrialData], qpos: Sequence[np.ndarray]
) -> tuple[np.ndarray, float, int, int]:
    """Reduced information of theta (P,) [m] at a solution with poses qpos (T_i, nq) per trial
    (NaN rows: frames not used), as the joint LM reports it (unit weights, no prior).

    Returns
    -------
    information : (P, P) [1], frozen rows/columns zero
    sigma : float [m], per-axis noise estimated from the fit
    n_residuals, n_unknowns : int
    """
    kin = Kinematics(pset)
    kin.set_theta(theta)
    used = [np.all(np.isfinite(q), axis=1) for q in qpos]
    prob = build_problem(kin, trials, qpos, used, np.flatnonzero(~pset.frozen))
    stats = prob.statistics(prob.residuals(prob.qpos))
    info = prob.information(prob.present.astype(float))
    return info, stats.sigma, stats.n_residuals, stats.n_unknowns


__all__ = [
    "CHI3_MEDIAN",
    "Bounds",
    "FitStatistics",
    "IdentificationProblem",
    "LinearGaussianPrior",
    "Prior",
    "ProblemOptions",
    "ReducedChunk",
    "TrialData",
    "build_problem",
    "check_bounds",
    "loss_threshold",
    "pool",
    "reduced_information",
    "unpool",
    "weak_prior",
]
