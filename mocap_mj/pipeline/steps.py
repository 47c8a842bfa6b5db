"""The solve of an identification: initial model, anatomical priors and ranges, the trials'
weights, the refinement on every frame of a long recording (:func:`solve_trials`, which
:func:`mocap_mj.pipeline.api.identify` runs)."""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np

from mocap_mj.anatomy.anatomy import ASYMMETRY_SIGMA
from mocap_mj.anatomy.axes import (
    angle_to_pig,
    axis_decisions,
    axis_rmse,
    widths,
)
from mocap_mj.anatomy.ball_centres import row_spreads
from mocap_mj.anatomy.constructed import constructed_theta
from mocap_mj.anatomy.initial import place_markers, scaled_theta, segment_scales, with_stature
from mocap_mj.anatomy.joint_checks import HOLD_RMSE_RATIO, held_joints, joint_checks
from mocap_mj.anatomy.partial import Unmeasured, freeze_unmeasured
from mocap_mj.anatomy.ranges import NOMINAL_HEIGHT, kappa_ranges, theta_bounds
from mocap_mj.anatomy.tissue import SLIDES, Slide, SlidingModel, sliding_weights
from mocap_mj.anatomy.trunk import T10Placement, t10_placement
from mocap_mj.capture.checks import check_determined, recorded_floor
from mocap_mj.capture.subject import Subject
from mocap_mj.long.chunks import FrameWeights, Robust, Weigh, robust_loss, scratch_array
from mocap_mj.long.long import result_at
from mocap_mj.long.refine import Objective, refine
from mocap_mj.pipeline.anatomical import AnatomyPriors, Weighing, anatomical_priors
from mocap_mj.pipeline.prepare import Prepared
from mocap_mj.pipeline.results import (
    HeldAtConstruction,
    Refined,
    Weighting,
    joint_axes,
    prior_noise,
    sliding_base,
)
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import pooled_correlation_time, trial_residuals
from mocap_mj.solve.lm import InitialPoses, LMSettings, identify_lm
from mocap_mj.solve.noise import (
    SOFT_TISSUE_SIGMA,
    artefact_noise,
    residual_correlation_time,
    trial_weights,
)
from mocap_mj.solve.priors import LinearGaussianPrior, Prior
from mocap_mj.solve.problem import Bounds, TrialData
from mocap_mj.solve.solver_result import IdentificationResult, ProgressCallback

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class Solved:
    """The solve of :func:`solve_trials`: the parameter set solved with, the result, the
    prior weighting (:func:`solve_anatomical`), the refinement on every frame
    (:func:`refine_on_every_frame`; None without), the sliding model weighed with, the
    subject (stature estimated when not measured) and what the report says of the solve:
    prior scale ``size`` [1], left/right prior ``symmetric`` [m], T10's placement, the
    kinematic ranges (K,) [m] (with anatomy), the initial model used, the segment scales,
    the unmeasured parameters, the solve's wall time [s], its log lines, the set's landmarks
    and, with ``init: constructed``, the construction of each initial joint centre (joint ->
    in words, :func:`~mocap_mj.anatomy.constructed.constructed_theta`); with the recipe's
    anatomy, what its priors were built from (the joints held at their construction are the
    weighting's ``held_joints``)."""

    pset: ParameterSet
    result: IdentificationResult
    weighting: Weighting | None
    refined: Refined | None
    sliding: SlidingModel | None
    slides: dict[str, Slide] | None
    subject: Subject
    size: float
    symmetric: float | None
    t10: T10Placement | None
    ranges: tuple[np.ndarray, np.ndarray] | None
    init_used: str
    scales: dict[str, float]
    missing: Unmeasured
    seconds: float
    log: list[str]
    landmarks: Mapping[str, str] | None = None
    construction: Mapping[str, str] | None = None
    anatomy: AnatomyPriors | None = None

    @property
    def t10_prior(self) -> T10Placement | None:
        """T10's placement when found misplaced (it widens the priors), else None."""
        return self.t10 if self.t10 is not None and self.t10.finding is not None else None


def solve_trials(
    prepared: Prepared,
    trials: Sequence[TrialData],
    settings: LMSettings,
    *,
    theta0: np.ndarray | None = None,
    progress: ProgressCallback | None = None,
    selected: bool = False,
) -> Solved:
    """The joint LM on ``trials`` (``prepared``'s, or frames selected from them) as
    ``prepared.recipe`` says: the parameters the data do not measure frozen
    (:func:`~mocap_mj.anatomy.partial.freeze_unmeasured`), trials with fewer marker
    coordinates than unknowns refused (:func:`mocap_mj.capture.checks.check_determined`), the
    initial model (``theta0`` (P,) [m], else ``recipe.init``: :func:`_initial_theta`), the
    subject's stature estimated when not measured, and with ``recipe.anatomy`` the anatomical
    ranges as bounds, the landmark priors (T10's placement checked against the stature), the
    left/right prior and the sliding landmarks (:func:`solve_anatomical`). With ``selected``
    (``trials``' frames were selected from ``prepared.trials``) and ``recipe.refine`` the
    model is then refined on every frame (:func:`refine_on_every_frame`)."""
    t0 = time.perf_counter()
    recipe, landmarks = prepared.recipe, prepared.landmarks or None
    pset, missing = freeze_unmeasured(prepared.pset, trials)
    _check_inputs(trials, pset)
    init_used = "given" if theta0 is not None else recipe.init
    subject = with_stature(prepared.subject, pset, [t.markers for t in trials])
    construction = partial(constructed_theta, subject=subject, hip_centre=recipe.hip_centre,
                           landmarks=landmarks)  # fmt: skip
    theta0, scales, pset, sources = _initial_theta(trials, pset, theta0, recipe.init, construction)
    stature = subject.stature()
    t10 = t10_placement(pset, trials, subject) if recipe.anatomy else None  # stature estimated
    weighing = Weighing(SLIDES if recipe.sliding_landmarks else None, recipe.trial_weights,
                        recipe.silent_axis_sd)  # fmt: skip
    symmetric = recipe.symmetric
    anatomy = AnatomyPriors(
        subject,
        size=stature[0] / NOMINAL_HEIGHT if stature else scales.get("overall", 1.0),
        symmetric=ASYMMETRY_SIGMA if symmetric is None and recipe.asymmetry_prior else symmetric,
        t10=t10 if t10 is not None and t10.finding is not None else None,
        hip_centre=recipe.hip_centre,
        landmarks=landmarks,
    )
    anatomical = anatomy if recipe.anatomy else None  # None: the plain joint LM
    solve: dict[str, Any] = {"pset": pset, "theta0": theta0, "settings": settings,
                             "weighing": weighing, "progress": progress}  # fmt: skip
    with captured_log() as log:
        result, weighting = _solve(trials, anatomy=anatomical, **solve)
        if anatomical is not None:
            result, weighting = _held_at_construction(trials, result, weighting, anatomical, solve)
    refined = None
    if recipe.refine and selected:
        result, refined = refine_on_every_frame(
            result, trials, prepared.trials, pset=pset, settings=settings, weighting=weighting,
            anatomy=anatomical, slides=weighing.slides,
        )  # fmt: skip
    for d in joint_axes(weighting).values():  # at the final model
        d["angle_to_pig_deg"] = angle_to_pig(pset, result.theta, d)
    sliding, base = None, sliding_base(weighting)
    if weighing.slides and base is not None:
        # The fit (and the refinement on every frame, and the motion's IK) weighed with it.
        sliding = SlidingModel(dict(weighing.slides), base)
    ranges = kappa_ranges(pset, subject) if recipe.anatomy else None
    return Solved(
        pset=pset, result=result, weighting=weighting, refined=refined, sliding=sliding,
        slides=weighing.slides, subject=subject, size=anatomy.size, symmetric=anatomy.symmetric,
        t10=t10, ranges=ranges, init_used=init_used, scales=scales, missing=missing,
        seconds=time.perf_counter() - t0, log=log, landmarks=landmarks, construction=sources,
        anatomy=anatomical,
    )  # fmt: skip


def _held_at_construction(
    trials: Sequence[TrialData],
    result: IdentificationResult,
    weighting: Weighting | None,
    anatomy: AnatomyPriors,
    solve: Mapping[str, Any],
) -> tuple[IdentificationResult, Weighting | None]:
    """``result`` checked against the body (:func:`~mocap_mj.anatomy.joint_checks.joint_checks`);
    a joint outside it re-solved once (:func:`solve_anatomical` with ``anatomy`` and ``solve``'s
    arguments)
    with its construction rows narrowed (:func:`~mocap_mj.anatomy.joint_checks.hold`). The
    re-solve is kept when the joints' checks then pass and the marker RMSE grows by at most
    :data:`~mocap_mj.anatomy.joint_checks.HOLD_RMSE_RATIO` (the markers were silent on where
    the joint lies), its weighting recording ``held_joints``; otherwise the first result
    stands, and its checks report what persists. Either way the weighting records
    ``held_at_construction`` (:class:`HeldAtConstruction`)."""
    subject, landmarks, pset = anatomy.subject, anatomy.landmarks, solve["pset"]
    checks = joint_checks(pset, result.theta, subject, landmarks, joint_axes(weighting) or None)
    joints = held_joints(checks)
    if not joints or weighting is None:
        return result, weighting
    held, held_weighting = solve_anatomical(trials, anatomy=replace(anatomy, held=joints), **solve)
    after = joint_checks(pset, held.theta, subject, landmarks, held_weighting.joint_axes or None)
    fixed = not any(set(held_joints([c])) & set(joints) for c in after if c.violated)
    kept = fixed and held.marker_rmse <= HOLD_RMSE_RATIO * result.marker_rmse
    record = HeldAtConstruction(joints, (result.marker_rmse, held.marker_rmse), bool(kept))
    logger.info(
        "%s held at the construction: marker RMSE %.2f -> %.2f mm, %s", ", ".join(joints),
        result.marker_rmse * 1e3, held.marker_rmse * 1e3,
        "kept" if kept else "not kept (the markers place the joint there)",
    )  # fmt: skip
    if kept:
        return held, replace(held_weighting, held_joints=joints, held_at_construction=record)
    return result, replace(weighting, held_at_construction=record)


def refine_on_every_frame(
    result: IdentificationResult,
    trials: Sequence[TrialData],
    motion_trials: Sequence[TrialData],
    *,
    pset: ParameterSet,
    settings: LMSettings,
    weighting: Weighting | None,
    anatomy: AnatomyPriors | None,
    slides: dict[str, Slide] | None = None,
) -> tuple[IdentificationResult, Refined]:
    """The identification on ``trials`` (frames selected from ``motion_trials``) refined on
    every frame of ``motion_trials`` (:func:`mocap_mj.long.refine.refine`) with the priors
    and bounds of its solve: with ``anatomy`` the landmark priors (and the left/right
    prior of width ``anatomy.symmetric`` [m]) weighed against the noise of ``weighting``, the
    anatomical ranges as bounds; always the weak prior, toward the subset's estimate (the
    directions the subset barely determined keep its value unless every frame determines
    them). The result is described at the refined model (:func:`~mocap_mj.long.long.result_at`);
    :class:`Refined` holds the refinement's steps, time, the subset's own estimate and every
    frame's pose under it, the start of the motion's IK. When the solve weighed the sliding
    landmarks (``slides``, and ``weighting`` has their ``slide_base``), the refinement
    weighs them alike, by each frame's pose (:func:`~mocap_mj.long.refine.refine`'s
    ``weigh``): it minimises the cost the subset's solve minimised, over every frame. With a
    robust ``settings.loss`` it minimises that loss, its threshold first the subset's solve's
    last (:func:`robust_for`), then the sample's (in the dict as ``robust``, for the motion's
    IK, :attr:`Refined.robust`)."""
    noise = prior_noise(weighting, settings.prior_noise)
    priors: list[Prior] = [settings.weak_prior(result.theta)]
    box = None
    if anatomy is not None:
        held = () if weighting is None else weighting.held_joints
        priors += anatomical_priors(
            pset, replace(anatomy, held=held), noise=noise,
            axes=widths(pset, joint_axes(weighting) or None),
            centres=None if weighting is None else weighting.centre_widths,
        )  # fmt: skip
        box = theta_bounds(pset, anatomy.subject)
    qpos = [scratch_array((len(t.markers), pset.model.nq)) for t in motion_trials]
    robust = robust_for(pset, result, trials, settings)
    ref = refine(
        [t.markers for t in motion_trials],
        pset,
        result.theta,
        qpos,
        result.sigma,
        settings=settings,
        objective=Objective(
            priors, box, FrameWeights(sliding_weigh(pset, weighting, slides), robust)
        ),
    )
    refined = result_at(result, trials, pset, ref.theta, settings, box, robust)
    info = Refined(
        steps_std=ref.steps,
        seconds=ref.seconds,
        subset_kappa=np.array(result.theta[: pset.n_kappa], dtype=float),
        qpos=qpos,
        robust=ref.robust,
    )
    return refined, info


def robust_for(
    pset: ParameterSet,
    result: IdentificationResult,
    trials: Sequence[TrialData],
    settings: LMSettings,
) -> Robust | None:
    """The robust loss of ``settings`` with the threshold of the fit's last iterations (the
    median distance of ``trials`` at ``result``'s poses and model,
    :func:`~mocap_mj.long.chunks.robust_loss`), None for the l2 loss."""
    if settings.loss == "l2":
        return None
    kin = Kinematics(pset)
    kin.set_theta(result.theta)
    markers = [t.markers for t in trials]
    return robust_loss(settings.loss, kin, markers, result.qpos, settings.loss_scale)


def sliding_weigh(
    pset: ParameterSet, weighting: Weighting | None, slides: dict[str, Slide] | None
) -> Weigh | None:
    """The sliding landmarks' weights by pose (:meth:`SlidingModel.weights`) that the solve
    weighed with (``weighting`` has ``slide_base``), else None."""
    base = sliding_base(weighting)
    if not slides or base is None:
        return None
    return partial(SlidingModel(dict(slides), base).weights, pset)


def _check_inputs(trials: Sequence[TrialData], pset: ParameterSet) -> None:
    """Refuse trials with fewer marker coordinates than unknowns."""
    check_determined(
        [t.name for t in trials],
        [t.markers for t in trials],
        min(recorded_floor(t.markers) for t in trials),
        pset.model,
        int(np.sum(~pset.frozen)),
    )


def _initial_theta(
    trials: Sequence[TrialData],
    pset: ParameterSet,
    theta0: np.ndarray | None,
    init: str,
    construction: Callable[..., tuple[np.ndarray, tuple[str, ...], dict[str, str]]] | None = None,
) -> tuple[np.ndarray | None, dict[str, float], ParameterSet, dict[str, str]]:
    """The initial model (P,) of :func:`solve_trials`, the segment scale estimates
    behind it (name -> factor; empty unless ``init`` scaled the nominal model), the
    parameter set to solve with (``pset`` with its knee rolling scaled to the initial model,
    :meth:`ParameterSet.with_rolling_scaled`, fixed for the solve) and each constructed
    joint centre's construction (joint -> in words; empty unless constructed).

    A given ``theta0`` is kept with the model file's rolling (an exported model.xml holds its
    subject's), as is the nominal model; otherwise ``init="nominal"`` leaves it None (the
    solver starts from the nominal model), ``"scaled"`` scales the
    nominal model to the trials' marker distances, ``"placed"`` also places the marker
    offsets by IK (with the scaled rolling) and ``"constructed"`` (with ``construction``,
    :func:`~mocap_mj.anatomy.constructed.constructed_theta` given the subject) first puts the
    joint centres and the offsets of the constructed segments' markers where the anatomical
    constructions put them, then places the other markers by IK."""
    scales: dict[str, float] = {}
    sources: dict[str, str] = {}
    if theta0 is None and init != "nominal":
        markers = [t.markers for t in trials]
        estimates = segment_scales(pset, markers)
        theta0 = scaled_theta(pset, markers, scales=estimates)
        scales = {n: e.value for n, e in estimates.items()}
        kept: tuple[str, ...] = ()
        if init == "constructed" and construction is not None:
            theta0, kept, sources = construction(pset, theta0, markers)
        pset = pset.with_rolling_scaled(theta0)
        if init in ("placed", "constructed"):
            theta0 = place_markers(pset, theta0, markers, kept=kept)
    return theta0, scales, pset, sources


def _solve(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet,
    theta0: np.ndarray | None,
    settings: LMSettings,
    anatomy: AnatomyPriors | None,
    weighing: Weighing,
    progress: ProgressCallback | None,
) -> tuple[IdentificationResult, Weighting | None]:
    """The joint LM of :func:`solve_trials`: with ``anatomy`` through :func:`solve_anatomical`
    (ranges and landmark priors, the data weighed as ``weighing`` says), else the plain
    :func:`identify_lm`; return the result and the prior weighting (None without
    ``anatomy``)."""
    if anatomy is not None:
        return solve_anatomical(
            trials, pset=pset, theta0=theta0, settings=settings, anatomy=anatomy,
            weighing=weighing, progress=progress,
        )  # fmt: skip
    result = identify_lm(trials, pset=pset, theta0=theta0, settings=settings, progress=progress)
    return result, None


class _ListHandler(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


@contextlib.contextmanager
def captured_log() -> Iterator[list[str]]:
    """The INFO messages of the ``mocap_mj`` logger while the block runs, as a list."""
    handler = _ListHandler()
    root = logging.getLogger("mocap_mj")
    level = root.level
    root.addHandler(handler)
    if root.getEffectiveLevel() > logging.INFO:
        root.setLevel(logging.INFO)
    try:
        yield handler.lines
    finally:
        root.removeHandler(handler)
        root.setLevel(level)


#: Effective noise [m] below which one solve with the nominal prior noise is kept.
REWEIGHT_RATIO = 1.5
#: Solves with per-trial weights at most (:func:`solve_anatomical`): each re-estimates the
#: trials' correlation times at the last solve's model, since a trial's residuals also carry
#: the bias another, overweighted trial pulled into the model.
TRIAL_WEIGHT_ROUNDS = 4
#: The rounds stop when no trial's weight changes by more than this factor.
TRIAL_WEIGHT_SETTLED = 1.25


def solve_anatomical(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet,
    theta0: np.ndarray | None,
    settings: LMSettings,
    anatomy: AnatomyPriors,
    weighing: Weighing | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[IdentificationResult, Weighting]:
    """The joint LM with anatomical ranges as bounds and the anatomical priors of ``anatomy``
    (:func:`anatomical_priors`), the data weighed as ``weighing`` says (default
    :class:`Weighing`'s: ``trial_weights`` False weighs every trial 1; ``silent_axis_sd``;
    ``slides``).

    The priors are weighed against the markers' effective noise: a first solve uses the
    nominal marker noise (``settings.prior_noise``, 1 mm); when the artefact's noise of one
    independent observation (:func:`artefact_noise`: the per-axis noise sigma, at least
    ``SOFT_TISSUE_SIGMA`` when the residuals are correlated, times the square root of the
    residuals' correlation time tau [frames]) exceeds that by ``REWEIGHT_RATIO``, a second
    solve starts from the first one's result with the priors' noise set to it (residuals
    correlated over tau frames hold about 1 / tau of white noise's information). On white
    noise one solve is kept. The flexion axes' rows are decided after the first solve.

    Several trials are weighed in the second solve by the independent observations each
    holds (:func:`_reweighed`); with ``weighing.slides`` (e.g.
    :data:`~mocap_mj.anatomy.tissue.SLIDES`; default None: off) it also weighs the landmark
    markers that slide with their joint's angle (:func:`_slid`), only where the residuals
    show soft tissue, never on white noise.
    Returns the result and the weighting used (:class:`Weighting`: noise, sigma, tau, each
    trial's tau and weight; with the sliding weights their smallest and their base, see
    :func:`_slid`).
    """
    lower, upper = theta_bounds(pset, anatomy.subject)
    priors = anatomical_priors(pset, anatomy, noise=settings.prior_noise)
    start = pset.nominal if theta0 is None else theta0
    result = identify_lm(
        trials, pset=pset, theta0=theta0, settings=settings, progress=progress,
        priors=[settings.weak_prior(start), *priors], bounds=Bounds(lower, upper),
    )  # fmt: skip
    weighing = weighing or Weighing()
    trial_weights, slides = weighing.trial_weights, weighing.slides
    weighting = _weighting(pset, result, trials, trial_weights)
    noise, tau = weighting.noise, weighting.tau_frames
    taus, per_trial = weighting.trial_tau_frames, weighting.trial_weights
    soft = noise > REWEIGHT_RATIO * settings.prior_noise
    weak, axis_noise = settings.weak_prior(start), noise if soft else settings.prior_noise
    axes = axis_decisions(pset, result.reduced_information, result.theta, priors, weak, axis_noise,
                          settings.prior_noise, weighing.silent_axis_sd)  # fmt: skip
    priors, weighting = _decided(pset, anatomy, result, priors, axes, weighting, soft, settings)
    if not soft:
        noise = settings.prior_noise
        weighting = replace(weighting, noise=noise)
    if not soft and all(w == 1.0 for w in per_trial) and not axes:
        return result, weighting
    _log_weighting(soft, noise, tau, per_trial, taus)
    weighted = list(trials)
    if slides and soft:
        weighted, weighting = _slid(trials, result, pset, slides, weighting)
    solve = partial(
        identify_lm,
        pset=pset,
        settings=settings,
        progress=progress,
        priors=[settings.weak_prior(result.theta), *(p.with_noise(noise) for p in priors)],
        bounds=Bounds(lower, upper),
    )
    return _reweighed(solve, result, trials, weighted, weighting, pset, trial_weights)


def _decided(
    pset: ParameterSet,
    anatomy: AnatomyPriors,
    first: IdentificationResult,
    priors: list[LinearGaussianPrior],
    axes: dict[str, Any],
    weighting: Weighting,
    soft: bool,
    settings: LMSettings,
) -> tuple[list[LinearGaussianPrior], Weighting]:
    """The priors of :func:`solve_anatomical`'s weighted solves: the flexion axes' rows as
    decided (``axes``, :mod:`~mocap_mj.anatomy.axes`) and, where the residuals show soft
    tissue (``soft``), the ball-joint centres' regression rows weighed against the data
    honestly counted (:func:`_centre_factors` at the ``first`` solve); both recorded in
    the weighting returned (``joint_axes``, ``centre_widths``)."""
    if axes:
        weighting = replace(weighting, joint_axes=axes)
    if soft:
        weak = settings.weak_prior(first.theta)
        noise = prior_noise(weighting, settings.prior_noise)
        factors = _centre_factors(pset, first, priors, weak, noise)
        weighting = replace(weighting, centre_widths=factors)
    if not axes and not soft:
        return priors, weighting
    return anatomical_priors(pset, anatomy, noise=settings.prior_noise, axes=widths(pset, axes),
                             centres=weighting.centre_widths), weighting  # fmt: skip


def _centre_factors(
    pset: ParameterSet,
    result: IdentificationResult,
    priors: Sequence[LinearGaussianPrior],
    weak: LinearGaussianPrior,
    noise: float,
) -> dict[str, float]:
    """The width factor of every ball-joint centre's regression row (label -> factor,
    :func:`~mocap_mj.anatomy.ball_centres.row_spreads`) for a solve that weighs the
    priors against ``noise`` [m]: the data of the first solve ``result`` (its reduced
    information and poses) with the soft-tissue artefact's floor, ``max(sigma,
    SOFT_TISSUE_SIGMA)`` per axis."""
    landmark, *others = (p.with_noise(noise) for p in priors)
    sta = max(result.sigma, SOFT_TISSUE_SIGMA)
    spreads = row_spreads(pset, result.reduced_information, result.free, result.qpos,
                          landmark, [weak, *others], noise, sta)  # fmt: skip
    for label, s in spreads.items():
        logger.info("%s: data %.1f mm, artefact floor %.1f mm: width x %.3f",
                    label, s.data_m * 1e3, s.floor_m * 1e3, s.factor)  # fmt: skip
    return {label: s.factor for label, s in spreads.items()}


def _log_weighting(
    soft: bool, noise: float, tau: float, per_trial: Sequence[float], taus: Sequence[float]
) -> None:
    """Log how the second solve weighs the priors (noise [m], correlation time tau [frames])
    and the trials (their weights and correlation times)."""
    if soft:
        logger.info("priors reweighted: noise %.2f mm (sigma x sqrt(tau %.1f))", noise * 1e3, tau)
    if any(w != 1.0 for w in per_trial):
        logger.info(
            "trials weighed by their independent frames: %s",
            ", ".join(f"{w:.2f} (tau {t:.0f})" for w, t in zip(per_trial, taus, strict=True)),
        )


def _weighting(
    pset: ParameterSet,
    result: IdentificationResult,
    trials: Sequence[TrialData],
    trial_weights: bool,
) -> Weighting:
    """The prior weighting after the first solve ``result``: its per-axis noise sigma, the
    residuals' pooled correlation time tau [frames], the artefact's noise of one
    independent observation [m] (:func:`artefact_noise`), each trial's tau and weight."""
    residuals = trial_residuals(pset, result, trials)
    tau = pooled_correlation_time(residuals)
    noise = artefact_noise(result.sigma, tau)
    taus, per_trial = _trial_weighting(residuals, trial_weights)
    return Weighting(sigma=result.sigma, tau_frames=tau, noise=noise, trial_tau_frames=taus,
                     trial_weights=per_trial)  # fmt: skip


def _slid(
    trials: Sequence[TrialData],
    first: IdentificationResult,
    pset: ParameterSet,
    slides: dict[str, Slide],
    weighting: Weighting,
) -> tuple[list[TrialData], Weighting]:
    """The trials with the weights of the landmark markers that slide with their joint's
    angle (:mod:`mocap_mj.anatomy.tissue`) by the ``first`` solve's poses, against a
    per-axis artefact of ``max(sigma, SOFT_TISSUE_SIGMA)``, and ``weighting`` recording
    them (``slide_weight_min``, the smallest weight, and ``slide_base``, the artefact [m]).
    ``mocap-mj identify`` slides :data:`~mocap_mj.anatomy.tissue.SLIDES` unless the
    recipe's ``sliding_landmarks`` is false
    (docs/method.md#weighing-priors-trials-and-sliding-markers)."""
    base = max(first.sigma, SOFT_TISSUE_SIGMA)
    weights = [sliding_weights(pset, q, base, slides) for q in first.qpos]
    weighting = replace(weighting, slide_weight_min=float(min(w.min() for w in weights)),
                        slide_base=base)  # fmt: skip
    return [t._replace(weights=w) for t, w in zip(trials, weights, strict=True)], weighting


def _reweighed(
    solve: Callable[..., IdentificationResult],
    first: IdentificationResult,
    trials: Sequence[TrialData],
    weighted: Sequence[TrialData],
    weighting: Weighting,
    pset: ParameterSet,
    trial_weights: bool,
) -> tuple[IdentificationResult, Weighting]:
    """:func:`solve_anatomical`'s weighted solves from the ``first`` one: ``weighted`` (the
    trials with their sliding weights) weighed by ``weighting``'s ``trial_weights``: the
    independent observations each trial holds (:func:`~mocap_mj.solve.noise.trial_weights`,
    from each trial's residual correlation time about zero), re-estimated at each weighted
    solve's model (recorded in the weighting returned), at most ``TRIAL_WEIGHT_ROUNDS``
    solves, until no weight changes by more than ``TRIAL_WEIGHT_SETTLED``: a static trial's
    soft tissue is one offset over all its frames and would otherwise outvote a movement.
    Residuals of white noise keep every weight 1; one trial always weighs 1. The result
    carries the first solve's initial model and the solves' summed iterations and time; the
    weighting returned holds the last trial weights; a functional flexion axis of
    ``weighting`` gets its marker RMSE with each solve (:func:`axes.axis_rmse`)."""
    per_trial = weighting.trial_weights
    result = solve(_trials_weighed(weighted, per_trial), theta0=first.theta,
                   initial=InitialPoses(first.qpos))  # fmt: skip
    seconds, iterations = first.seconds + result.seconds, first.iterations + result.iterations
    for _ in range(TRIAL_WEIGHT_ROUNDS - 1):
        if all(w == 1.0 for w in per_trial):
            break
        taus, update = _trial_weighting(trial_residuals(pset, result, trials), trial_weights)
        if max(abs(np.log(u / w)) for u, w in zip(update, per_trial, strict=True)) < np.log(
            TRIAL_WEIGHT_SETTLED
        ):
            break
        per_trial = update
        weighting = replace(weighting, trial_tau_frames=taus, trial_weights=per_trial)
        logger.info("trials reweighed: %s", ", ".join(f"{w:.2f}" for w in per_trial))
        result = solve(_trials_weighed(weighted, per_trial), theta0=result.theta,
                       initial=InitialPoses(result.qpos))  # fmt: skip
        seconds, iterations = seconds + result.seconds, iterations + result.iterations
    result.theta0 = first.theta0
    result.seconds = seconds
    result.init_seconds = first.init_seconds
    result.iterations = iterations
    fits = {
        "plug_in_gait_row": (first.theta, first.qpos),
        "functional": (result.theta, result.qpos),
    }
    axis_rmse(pset, fits, [t.markers for t in trials], weighting.joint_axes)
    return result, weighting


def _trial_weighting(
    residuals: Sequence[np.ndarray], weigh: bool = True
) -> tuple[list[float], list[float]]:
    """Each trial's residual correlation time about zero [frames] and its weight [1]
    (:func:`~mocap_mj.solve.noise.trial_weights`; every weight 1 without ``weigh``) from
    the trials' residuals (T_i, M, 3) [m]."""
    taus = [residual_correlation_time(r, about_mean=False) for r in residuals]
    if not weigh:
        return taus, [1.0] * len(taus)
    return taus, trial_weights(taus, [len(r) for r in residuals])


def _trials_weighed(trials: Sequence[TrialData], weights: Sequence[float]) -> list[TrialData]:
    """``trials`` with every sample's weight (their own, default 1) times the trial's
    weight [1] from ``weights``; a trial of weight 1 is returned as it is."""
    out = []
    for t, w in zip(trials, weights, strict=True):
        if w != 1.0:
            own = np.ones(t.markers.shape[:2]) if t.weights is None else t.weights
            t = t._replace(weights=w * own)
        out.append(t)
    return out
