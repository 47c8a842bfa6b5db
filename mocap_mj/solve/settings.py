"""Settings of the joint LM (:mod:`mocap_mj.solve.lm`): the problem's choices that a
recipe states, the solver's :class:`Tolerances` and the :class:`Performance` knobs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from mocap_mj.solve.losses import LossName, loss_named
from mocap_mj.solve.priors import LinearGaussianPrior, weak_prior

from ..errors import MocapError

MuDecrease = Literal["nielsen", "third"]


@dataclass(frozen=True)
class Tolerances:
    """The joint LM's stopping rules and safeguards: how the solver reaches the minimum of the
    problem the recipe states (the reasons for the defaults:
    ``docs/method.md#the-joint-levenbergmarquardt-solver``).

    Attributes
    ----------
    tol_noise : float
        An accepted step that lowers F by less than ``tol_noise * sigma^2`` ends the solve
        (sigma: per-axis noise estimated from the fit, each sample weighed by its weight when
        the trials carry sample weights, :meth:`IdentificationProblem.weighted_sigma`). Near
        the minimum a step that lowers F by delta moves theta by sqrt(2 delta) / sigma
        standard deviations (Mahalanobis, in the reduced information): with 1.0, at most 1.4
        standard deviations along a single direction.
    tol_cost : float
        Relative decrease of F below which an accepted step ends the solve.
    tol_theta : float [m]
    tol_q : float [rad or m]
    mu0 : float
        Initial Marquardt damping (dimensionless).
    settle_gain : float
        Once an accepted step lowers F by less than this fraction, progress has stalled: a
        refit is tried (``refit_factor``) before the iterations go on.
    prior_ratio : float
        Every step is restricted to the eigen-directions of the reduced information (at the
        current iterate) whose information exceeds ``prior_ratio`` times the weak prior's
        weight lambda_p. In the others the data hardly constrain theta and Gauss-Newton would
        wander or crawl: they keep their value.
    refit_factor : float
        Every trial's IK is solved afresh with the current model
        (:func:`~mocap_mj.solve.heuristics.refit_frames`) each time the marker RMSE has
        fallen by this factor since the last such refit, when progress stalls
        (``settle_gain``) and at convergence; at most ``max_refits`` times.
    refine_iterations : int
        Per-frame IK iterations applied to every frame after each step, from ``q + dq`` with
        the new theta (0 disables). Given theta the frames are independent, and the joint
        step's dq is a poor guess for frames at or near their joint limits; each frame's own
        damped iterations finish its step.
    stall_window, stall_rel : int, float
        Once settled, stop when sqrt(F) (the objective in the marker RMSE's units: with sample
        weights or priors the unweighted RMSE may rise while F falls) fell by less than
        ``stall_rel`` (relative) over the last ``stall_window`` accepted steps.
    max_refits : int
    mu_decrease : "nielsen" or "third"
        Damping after an accepted step: Nielsen's ``mu *= max(1/3, 1 - (2 rho - 1)^3)``, or
        ``mu /= 3`` whatever the gain ratio ("delayed gratification", Transtrum & Sethna
        2012). With ``mu0 = 1e-2`` and "third" (the default) the first steps are damped, so
        that a weakly observable direction is not carried into a neighbouring minimum.
    ball_limit_scale : float
        During identification the cone limit of every ball joint is widened by this factor
        (at most pi). A joint limit is not a measurement, and at a ball's cone the null
        directions of theta become "determined" by the inequality: a kinked valley in which
        the LM converges linearly. Hinge limits are kept (they keep the IK out of flipped
        configurations). The identified poses may turn a ball beyond the model's cone (by up
        to the factor), so the written model.xml carries the widened cones
        (:func:`solver_joint_range`): an IK with it reproduces the fit. 1.0 keeps the model's
        limits.
    coarse_frames : int
        Coarse to fine (:mod:`mocap_mj.solve.coarse`): with more than twice this many
        frames, the LM first converges on a pose-diverse subset of this many frames (or a
        tenth of all, whichever is more; itself approached the same way), then continues on
        every frame from there (default 100: at 500 frames the approach then costs about a
        fifth per iteration, and every frame's IK is solved once, under a model near the
        answer; 0 disables). Only when :func:`identify_lm` solves the initial IK itself (no
        ``InitialPoses.qpos``).
    """

    tol_noise: float = 1.0
    tol_cost: float = 1e-10
    tol_theta: float = 1e-9
    tol_q: float = 1e-8
    mu0: float = 1e-2
    settle_gain: float = 1e-2
    prior_ratio: float = 100.0
    max_refits: int = 6
    stall_window: int = 5
    stall_rel: float = 1e-4
    refit_factor: float = 1.5
    refine_iterations: int = 30
    mu_decrease: MuDecrease = "third"
    ball_limit_scale: float = 1.5
    coarse_frames: int = 100

    def __post_init__(self) -> None:
        if self.mu_decrease not in ("nielsen", "third"):
            raise MocapError(f"mu_decrease must be 'nielsen' or 'third', got {self.mu_decrease!r}")
        if self.ball_limit_scale < 1.0:
            raise MocapError(f"ball_limit_scale must be >= 1, got {self.ball_limit_scale}")
        if self.coarse_frames < 0:
            raise MocapError(f"coarse_frames must be >= 0, got {self.coarse_frames}")


@dataclass(frozen=True)
class Performance:
    """How the joint LM uses memory: knobs that change its speed and footprint, not the
    problem it solves or its stopping rules.

    Attributes
    ----------
    chunk : int
        Frames per chunk when accumulating the reduced system. The chunks' partial sums are
        added in another order with another size, so theta may differ in its last bits (by
        about 1e-13 m on a 300-frame synthetic trial with 64 against 1000), never more.
    cache_frames : int
        Keep per-frame back-substitution data up to this many frames (else recompute); the
        answer is the same bit for bit.
    """

    chunk: int = 1000
    cache_frames: int = 5000

    def __post_init__(self) -> None:
        if self.chunk < 1:
            raise MocapError(f"chunk must be at least 1, got {self.chunk}")


@dataclass(frozen=True)
class LMSettings:
    """Settings of the joint LM: the problem's choices that a :class:`Recipe
    <mocap_mj.pipeline.recipe.Recipe>` states (iterations, loss, weak prior, reporting
    threshold), the solver's :class:`Tolerances` and the :class:`Performance` knobs.

    Attributes
    ----------
    max_iterations : int
    prior_sigma : float [m]
        Width of the default weak prior toward the initial model, stated for a marker noise
        of ``prior_noise`` (so lambda_p = (prior_noise / prior_sigma)^2).
    prior_noise : float [m]
    loss : "l2", "huber" or "cauchy"
    loss_scale : float
        Robust threshold in units of the estimated per-axis noise sigma.
    observable_std : float [m]
        Reporting threshold: a direction of theta is observable when its standard deviation
        (reduced information and the noise estimated from the fit) is at most this.
    tolerances : Tolerances
    performance : Performance
    """

    max_iterations: int = 100
    prior_sigma: float = 0.05
    prior_noise: float = 0.001
    loss: LossName = "l2"
    loss_scale: float = 3.0
    observable_std: float = 0.005
    tolerances: Tolerances = Tolerances()
    performance: Performance = Performance()

    def __post_init__(self) -> None:
        loss_named(self.loss)  # raises for an unknown loss, listing the valid ones
        if self.prior_sigma <= 0 or self.prior_noise <= 0:
            raise MocapError("prior_sigma and prior_noise must be positive")
        if self.max_iterations < 1:
            raise MocapError("max_iterations must be at least 1")

    @property
    def prior_weight(self) -> float:
        """lambda_p = (prior_noise / prior_sigma)^2 [1], the weak prior's weight."""
        return (self.prior_noise / self.prior_sigma) ** 2

    def weak_prior(self, theta0: np.ndarray) -> LinearGaussianPrior:
        """The weak prior toward theta0 (P,) [m]: ``prior_sigma`` wide against
        ``prior_noise``. :func:`identify_lm` uses it when given no priors; callers that pass
        their own priors add it themselves."""
        return weak_prior(theta0, self.prior_sigma, self.prior_noise)
