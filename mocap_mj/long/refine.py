"""The refinement of a model on every frame of a long recording (:func:`refine`): Gauss-Newton
steps on an evenly spaced sample, damped, then the one-step estimator on every frame (step 3
of :mod:`mocap_mj.long.long`)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.long.chunks import (
    CHUNK,
    FrameWeights,
    Heads,
    Parts,
    Robust,
    Weigh,
    _fill,
    _ik_pass,
    _parts,
    robust_loss,
    sample_weights,
)
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.lm import (
    LMSettings,
    bounded_step,
    solver_joint_range,
)
from mocap_mj.solve.priors import Prior
from mocap_mj.solve.problem import IdentificationProblem, ProblemOptions

#: The refinement's sample [frames], its steps at most, and the step (in standard
#: deviations) below which they stop.
SAMPLE = 20_000


INFO_FRAMES = 5_000


STEPS = 8


TOL_STD = 0.1


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


def _information(
    kin: Kinematics,
    markers: np.ndarray,
    qpos: np.ndarray,
    weigh: Weigh | None = None,
    robust: Robust | None = None,
) -> np.ndarray:
    """Reduced information (P, P) [1] of frames markers (n, M, 3) [m] at poses qpos (n, nq)
    (NaN rows skipped), joint limits not held, each sample weighted by its IRLS weight
    (:func:`~mocap_mj.long.chunks.sample_weights`: ``weigh`` and ``robust``; default 1)."""
    ok = np.isfinite(qpos[:, 0])
    if not ok.any():
        return np.zeros((kin.pset.size,) * 2)
    free = np.flatnonzero(~kin.pset.frozen)
    prob = IdentificationProblem(
        kin, markers[ok], qpos[ok], free, options=ProblemOptions(theta0=kin.theta.copy())
    )
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


@dataclass(frozen=True)
class RefineOptions:
    """The options of :func:`refine`.

    Fields
    ------
    steps : Gauss-Newton steps on the sample at most (default 8)
    tol_std : the sample's steps stop once one's largest component is below this fraction
        of its parameter's standard deviation (default 0.1): the step on every frame follows
        from the last accepted point, and a start 0.1 standard deviations closer to the
        sample's optimum changes that step's outcome by about the square of it (Gauss-Newton
        converges quadratically there)
    chunk : frames per IK chunk: the markers are read ``chunk`` frames at a time
    sample : every k-th frame of each trial, k = ceil(T / sample) with T the frames of all
        trials, is the sample (default 20,000 frames)
    info_frames : the information is summed over at most this many evenly spaced frames of
        the sample and scaled to all (default 5,000)
    """

    steps: int = STEPS
    tol_std: float = TOL_STD
    chunk: int = CHUNK
    sample: int = SAMPLE
    info_frames: int = INFO_FRAMES


@dataclass(frozen=True)
class Objective:
    """What the identification's cost holds besides its markers: its priors, its box and
    the weighing of its samples; :func:`refine` minimises that cost over every frame.

    Fields
    ------
    priors : the priors of the identification, the weak prior among them (default None: the
        weak prior toward theta0 alone, ``settings.weak_prior``): their gradient and
        information are added to the data's
    bounds : (lower, upper), each (P,) [m], the identification's box (default None: none): a
        parameter at a bound that a step pushes outward is held there
    weighing : the samples' weights (default: all 1, least squares), e.g. the soft-tissue
        sliding of the landmarks that the identification weighed with
        (:mod:`mocap_mj.anatomy.tissue`) and its robust loss: the cost, gradient and
        information are then the weighted ones. The weights follow each frame's pose under
        the model of the step (the identification's come from its first solve's poses)
    """

    priors: Sequence[Prior] | None = None
    bounds: tuple[np.ndarray, np.ndarray] | None = None
    weighing: FrameWeights = field(default_factory=FrameWeights)


@single_blas_thread
def refine(
    markers: Parts,
    pset: ParameterSet,
    theta0: np.ndarray,
    qpos: Parts,
    sigma: float,
    *,
    settings: LMSettings | None = None,
    objective: Objective = Objective(),
    options: RefineOptions = RefineOptions(),
) -> Refinement:
    """The model refined on every frame (module docstring, step 3).

    Parameters
    ----------
    markers : (T, M, 3) float [m], NaN where missing, or one such array per trial; read
        ``options.chunk`` frames at a time
    theta0 : (P,) [m], a consistent start (the identification on a subset)
    qpos : (T, nq) float (one per trial of ``markers``), written: every frame's IK pose under
        the sample's estimate, with the joint LM's limits (:func:`solver_joint_range`; NaN
        rows: too few markers); finite rows are warm starts
    sigma : [m], per-axis marker noise (the start's estimate), for ``options.tol_std``
    settings : LM settings for the weak prior and the informed directions (``prior_ratio``:
        directions with less information keep their value, as in every LM step)
    objective : the identification's priors, box and weighing (default: the weak prior
        alone, no box, least squares), so that the refinement minimises the identification's
        cost over every frame
    options : the steps, their stop, the IK chunk and the sample (:class:`RefineOptions`)
    """
    st = settings or LMSettings()
    t0 = time.perf_counter()
    parts = _parts(markers)
    n = sum(len(m) for m in parts)
    problem = _steps_of(pset, theta0, st, objective, sigma, options.chunk)
    kin, box = problem.kin, problem.box
    stride = max(1, -(-n // max(options.sample, 1)))
    sample_set = _sample_of(parts, stride, n, kin.nq, options.info_frames)
    theta = np.clip(np.array(theta0, dtype=float), *box)
    theta, best, sizes, mu, robust = _sample_steps(
        problem, sample_set, theta, options, objective.weighing.robust
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
    objective: Objective,
    sigma: float,
    chunk: int,
) -> _Steps:
    """:func:`refine`'s kinematics (at ``theta0``), priors (default: the weak prior toward
    theta0) and box (default: none) for its arguments."""
    kin = Kinematics(pset)
    # The IK with the joint LM's limits (ball cones widened), as the identification and the
    # written model solve it: the motion then starts from poses under the same limits.
    kin.model.jnt_range[:] = solver_joint_range(kin.model, st)
    kin.set_theta(theta0)
    free = np.flatnonzero(~pset.frozen)
    priors = objective.priors
    prior_list: list[Prior] = list(priors) if priors is not None else [st.weak_prior(theta0)]
    bounds = objective.bounds
    box = (
        (np.full(pset.size, -np.inf), np.full(pset.size, np.inf))
        if bounds is None
        else (np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float))
    )
    return _Steps(kin, prior_list, box, free, sigma, st, chunk, objective.weighing.weigh)


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
    options: RefineOptions,
    robust: Robust | None,
) -> tuple[np.ndarray, _Point | None, list[float], float, Robust | None]:
    """:func:`refine`'s damped Gauss-Newton steps on the sample (at most ``options.steps``,
    until one is below ``options.tol_std``) with the robust loss ``robust``, from ``theta``
    (P,) [m]:
    the last theta, the last accepted point (None: no step), the steps' sizes (in standard
    deviations), the damping and the robust loss at the last accepted point."""
    kin, prior_list, st, weigh = problem.kin, problem.priors, problem.settings, problem.weigh
    m_s, q_s, weight, info_rows = sample.markers, sample.qpos, sample.weight, sample.info_rows
    sizes: list[float] = []
    best: _Point | None = None
    mu = 0.0
    for _ in range(options.steps):
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
        if sizes[-1] < options.tol_std:
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
