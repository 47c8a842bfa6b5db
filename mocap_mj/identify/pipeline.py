"""Identify trials and write the result folder: shared by ``identify`` and ``demo``."""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Iterator, Sequence
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import check_determined
from ..errors import MocapError
from ..ik import IKSettings
from ..io.atomic import atomic_folder, atomic_write_text
from ..kinematics import Kinematics
from ..marker_quality import Finding
from ..parameters import ParameterSet
from ..strict_json import dumps, jsonable
from ..subject import Subject
from ..tables import write_joint_centres_csv
from .anatomy import ASYMMETRY_SIGMA, landmark_prior, symmetric_prior
from .consistency import pooled_correlation_time, trial_residuals
from .identifiability import Identifiability
from .initial import (
    ScaleEstimate,
    estimate_stature,
    marker_stature,
    place_markers,
    scaled_theta,
    segment_scales,
)
from .lm import LMSettings, identify_lm, solver_joint_range
from .long import Robust, Weigh, refine, result_at, robust_loss, scratch_array
from .motion_out import write_every_frame_motion
from .noise import (
    SOFT_TISSUE_SIGMA,
    artefact_noise,
    residual_correlation_time,
    trial_weights,
)
from .output import write_result
from .partial import Unmeasured, freeze_unmeasured, on_measured
from .plausibility import (
    implausible_reasons,
    joints_at_limit,
    kappa_outside_bounds,
    marker_rmse_by_marker,
)
from .priors import LinearGaussianPrior, Prior
from .problem import TrialData
from .ranges import NOMINAL_HEIGHT, kappa_ranges, theta_bounds
from .result import IdentificationResult, ProgressCallback
from .segments import SegmentRow, uncertainty_summary, write_segments_csv
from .tissue import Slide, SlidingModel, arm_elevation, raised_arms_note, sliding_weights
from .trunk import T10Placement, t10_placement

logger = logging.getLogger(__name__)

#: Initial models of :func:`identify_to_folder` (``init``).
INITS = ("placed", "scaled", "nominal")


def identify_to_folder(
    trials: Sequence[TrialData],
    out: Path,
    *,
    pset: ParameterSet,
    settings: LMSettings,
    theta0: np.ndarray | None = None,
    init: str = "nominal",
    progress: ProgressCallback | None = None,
    extra: dict[str, Any] | None = None,
    subject: Subject | None = None,
    anatomical: bool = True,
    symmetric: float | None = None,
    asymmetry_prior: bool = True,
    motion_trials: Sequence[TrialData] | None = None,
    motion_progress: Callable[[int], None] | None = None,
    refine: bool = False,
    slides: dict[str, Slide] | None = None,
) -> tuple[dict[str, Any], IdentificationResult, Identifiability]:
    """Run the joint LM on the trials and write model.xml, theta.json, motion.npz,
    identifiability.json and report.md into ``out``; return (summary, result, identifiability).

    ``motion_trials`` (one per trial, e.g. the whole recordings the trials' frames were
    selected from): motion.npz and joint_centres.csv then hold every frame of these, solved
    by IK with the identified model as written to model.xml, written chunk by chunk
    (:func:`mocap_mj.identify.motion_out.write_every_frame_motion`, ``motion_progress``
    called with the frames done); default: the fitted
    frames' poses. With ``refine`` the model identified on ``trials`` is then refined on
    every frame of ``motion_trials`` with the same priors, bounds and loss
    (:func:`refine_on_every_frame`) and everything written describes the refined model; with
    a robust loss the motion's IK weighs each sample by that loss's IRLS weight at its start
    pose, the threshold the refinement's.

    ``out`` is replaced whole at the end (:func:`mocap_mj.io.atomic.atomic_folder`): it holds
    the complete result or what it held before. Trials with fewer marker coordinates than
    unknowns are refused before the fit (:func:`mocap_mj.checks.check_determined`).

    Without ``theta0`` the initial model (and prior mean) is, for ``init="scaled"``, the
    nominal model scaled to the subject from the trials' marker distances
    (:func:`mocap_mj.identify.initial.scaled_theta`); for ``init="placed"`` that skeleton
    with the marker offsets placed by IK (:func:`mocap_mj.identify.initial.place_markers`;
    ``mocap-mj identify`` does this by default); for ``init="nominal"`` the nominal model
    (the default here: the demo's synthetic truth is the nominal model perturbed, so the
    nominal model is its best prior mean). ``progress`` is called with every LM iteration;
    the solver's log lines (logger ``mocap_mj``) are kept in the summary's ``log``.

    With ``anatomical`` (the default) the solve keeps the kinematic parameters in their
    anatomical ranges (:mod:`mocap_mj.identify.ranges`, scaled by the subject's height when
    ``subject`` has it, else by the stature estimated from the trials' markers, which the
    summary's ``stature_estimate`` records) and adds the landmark priors
    (:mod:`mocap_mj.identify.anatomy`, sharpened by ``subject``'s measurements);
    ``symmetric`` [m] adds a prior tying every left length to the right one with that
    standard deviation, in place of the population
    asymmetry prior (``ASYMMETRY_SIGMA``, on unless ``asymmetry_prior`` is False);
    ``slides``: the landmarks' soft-tissue sliding model (default None: off; ``mocap-mj
    identify`` turns it on). See :func:`solve_anatomical`. When the fit was weighed with it
    (the reweighted solve ran; a refinement on every frame and the motion's IK then weigh
    alike), model.xml records it (:func:`mocap_mj.identify.tissue.with_sliding_model`) so
    that ``mocap-mj ik --model`` weighs its poses alike and reproduces the fit; the summary's
    ``sliding_landmarks`` says whether it did.
    """
    t0 = time.perf_counter()
    pset, missing = freeze_unmeasured(pset, trials)
    _check_inputs(trials, pset, init)
    init_used = "given" if theta0 is not None else init
    theta0, scales, pset = _initial_theta(trials, pset, theta0, init)
    long_bones = segment_scales(pset, [t.markers for t in trials])
    subject = _with_stature(subject or Subject(), long_bones)
    stature = subject.stature()
    t10 = t10_placement(pset, trials, subject) if anatomical else None  # stature estimated
    prior_options: dict[str, Any] = {
        "subject": subject,
        "size": stature[0] / NOMINAL_HEIGHT if stature else scales.get("overall", 1.0),
        "anatomical": anatomical,
        "symmetric": ASYMMETRY_SIGMA if symmetric is None and asymmetry_prior else symmetric,
        "t10": t10 if t10 is not None and t10.finding is not None else None,
    }
    with captured_log() as log:
        result, weighting = _solve(
            trials,
            pset=pset,
            theta0=theta0,
            settings=settings,
            progress=progress,
            slides=slides,
            **prior_options,
        )
    refined: dict[str, Any] = {}
    if refine and motion_trials is not None:
        result, refined = refine_on_every_frame(
            result,
            trials,
            motion_trials,
            pset=pset,
            settings=settings,
            weighting=weighting,
            slides=slides,
            **prior_options,
        )
    sliding = None
    if slides and "slide_base_mm" in weighting:
        # The fit (and the refinement on every frame, and the motion's IK) weighed with it.
        sliding = SlidingModel(dict(slides), weighting["slide_base_mm"] * 1e-3)
    seconds = time.perf_counter() - t0
    idf = Identifiability(
        pset,
        result.reduced_information,
        result.sigma,
        observable_std=settings.observable_std,
        theta=result.theta,
    )
    summary: dict[str, Any] = dict(extra or {})
    summary.update(
        _summary_fields(trials, pset, settings, result, idf, init_used, scales, seconds, log)
    )
    summary.update(_prior_fields(anatomical, weighting, symmetric, asymmetry_prior, subject))
    summary.update(_measured_fields(pset, missing))
    summary["sliding_landmarks"] = None if sliding is None else sorted(sliding.slides)
    summary["kappa_at_bound"] = _kappa_at_bound(pset, result)
    summary["implausible"] = implausible_reasons(
        result.marker_rmse,
        len(summary["kappa_at_bound"]),
        int(np.sum(~pset.frozen[: pset.n_kappa])),
        marker_stature(long_bones),
    )
    fitted = [q[used] for q, used in zip(result.qpos, result.used, strict=True)]
    summary["joints_at_limit"] = joints_at_limit(
        pset.model, solver_joint_range(pset.model, settings), fitted
    )
    elevation = arm_elevation(pset, fitted)
    summary["arm_elevation_deg"] = {
        s: [float(np.degrees(a)) for a in v] for s, v in elevation.items()
    }
    summary["shoulder_note"] = raised_arms_note(elevation)
    summary["t10_placement"] = None if t10 is None else _t10_fields(t10)
    if t10 is not None and t10.finding is not None:
        _add_finding(summary, t10.finding)
    ranges = kappa_ranges(pset, subject) if anatomical else None
    priors = (
        anatomical_priors(pset, subject, size=prior_options["size"],
                          symmetric=prior_options["symmetric"],
                          t10=prior_options["t10"])
        if anatomical
        else []
    )  # fmt: skip
    info = prior_information(priors, settings, pset.size)
    rows = _add_checks(summary, pset, result, trials, settings, ranges, info)
    stream = None
    if motion_trials is not None:
        summary["motion_frames"] = [len(t.markers) for t in motion_trials]
        if refined:
            summary["refinement"] = {
                k: v for k, v in refined.items() if k not in ("qpos", "robust")
            }
        starts = summary.get("frames_fitted_range")

        def stream(staging: Path) -> dict[str, Any]:
            fit = write_every_frame_motion(
                staging,
                pset,
                result.theta,
                settings,
                list(motion_trials),
                first_frames=[int(r[0]) for r in starts] if starts else None,
                start=refined.get("qpos"),
                progress=motion_progress,
                weigh=_sliding_weigh(pset, weighting, slides),
                robust=refined.get("robust") or _robust(pset, result, trials, settings),
            )
            return {
                "motion_marker_rmse_mm": fit.rmse * 1e3,
                "motion_seconds": {"ik": fit.ik_seconds, "all": fit.seconds},
            }

    summary = jsonable(summary)
    _write_folder(
        out, pset, result, idf, trials, settings, rows, summary, stream=stream, sliding=sliding
    )
    return summary, result, idf


def refine_on_every_frame(
    result: IdentificationResult,
    trials: Sequence[TrialData],
    motion_trials: Sequence[TrialData],
    *,
    pset: ParameterSet,
    settings: LMSettings,
    weighting: dict[str, Any],
    subject: Subject,
    size: float,
    anatomical: bool,
    symmetric: float | None,
    slides: dict[str, Slide] | None = None,
    t10: T10Placement | None = None,
) -> tuple[IdentificationResult, dict[str, Any]]:
    """The identification on ``trials`` (frames selected from ``motion_trials``) refined on
    every frame of ``motion_trials`` (:func:`mocap_mj.identify.long.refine`) with the priors
    and bounds of its solve: with ``anatomical`` the landmark priors (and the left/right
    prior of width ``symmetric`` [m]) weighed against the noise of ``weighting``, the
    anatomical ranges as bounds; always the weak prior, toward the subset's estimate (the
    directions the subset barely determined keep its value unless every frame determines
    them). The result is described at the refined model (:func:`~mocap_mj.identify.long.result_at`);
    the dict holds the refinement's ``steps_std``, ``seconds``, the subset's own estimate
    (``subset_kappa_mm``) and ``qpos``: every frame's pose under the sample's estimate per
    motion trial (T_i, nq), the start of the motion's IK. When the solve weighed the sliding
    landmarks (``slides``, and ``weighting`` has their ``slide_base_mm``), the refinement
    weighs them alike, by each frame's pose (:func:`~mocap_mj.identify.long.refine`'s
    ``weigh``): it minimises the cost the subset's solve minimised, over every frame. With a
    robust ``settings.loss`` it minimises that loss, its threshold first the subset's solve's
    last (:func:`_robust`), then the sample's (in the dict as ``robust``, for the motion's
    IK)."""
    noise = weighting.get("noise_mm", settings.prior_noise * 1e3) * 1e-3
    priors: list[Prior] = [settings.weak_prior(result.theta)]
    box = None
    if anatomical:
        priors += anatomical_priors(
            pset, subject, size=size, symmetric=symmetric, noise=noise, t10=t10
        )
        box = theta_bounds(pset, subject)
    qpos = [scratch_array((len(t.markers), pset.model.nq)) for t in motion_trials]
    robust = _robust(pset, result, trials, settings)
    ref = refine(
        [t.markers for t in motion_trials],
        pset,
        result.theta,
        qpos,
        result.sigma,
        settings=settings,
        priors=priors,
        lower=None if box is None else box[0],
        upper=None if box is None else box[1],
        weigh=_sliding_weigh(pset, weighting, slides),
        robust=robust,
    )
    refined = result_at(result, trials, pset, ref.theta, settings, box, robust)
    info = {
        "steps_std": ref.steps,
        "seconds": ref.seconds,
        "subset_kappa_mm": {
            n: float(v) * 1e3 for n, v in zip(pset.kappa_names, result.theta, strict=False)
        },
        "qpos": qpos,
        "robust": ref.robust,
    }
    return refined, info


def _robust(
    pset: ParameterSet,
    result: IdentificationResult,
    trials: Sequence[TrialData],
    settings: LMSettings,
) -> Robust | None:
    """The robust loss of ``settings`` with the threshold of the fit's last iterations (the
    median distance of ``trials`` at ``result``'s poses and model,
    :func:`~mocap_mj.identify.long.robust_loss`), None for the l2 loss."""
    if settings.loss == "l2":
        return None
    kin = Kinematics(pset)
    kin.set_theta(result.theta)
    markers = [t.markers for t in trials]
    return robust_loss(settings.loss, kin, markers, result.qpos, settings.loss_scale)


def _sliding_weigh(
    pset: ParameterSet, weighting: dict[str, Any], slides: dict[str, Slide] | None
) -> Weigh | None:
    """The sliding landmarks' weights by pose (:meth:`SlidingModel.weights`) that the solve
    weighed with (``weighting`` has ``slide_base_mm``), else None."""
    if not slides or "slide_base_mm" not in weighting:
        return None
    return partial(SlidingModel(dict(slides), weighting["slide_base_mm"] * 1e-3).weights, pset)


def _check_inputs(trials: Sequence[TrialData], pset: ParameterSet, init: str) -> None:
    """Refuse an unknown ``init`` and trials with fewer marker coordinates than unknowns."""
    if init not in INITS:
        raise MocapError(f"init must be one of {', '.join(INITS)}; got {init!r}")
    check_determined(
        [t.name for t in trials],
        [t.markers for t in trials],
        IKSettings().min_markers,
        pset.model,
        int(np.sum(~pset.frozen)),
    )


def _measured_fields(pset: ParameterSet, missing: Unmeasured) -> dict[str, Any]:
    """The partial-marker-set part of the summary: how many parameters the data measured,
    the names of those held at the prior (:mod:`mocap_mj.identify.partial`), the bodies no
    present marker determines and the markers without data."""
    return {
        "parameters_measured": int(np.sum(~pset.frozen)),
        "parameters_not_measured": [n for n, f in zip(pset.names, pset.frozen, strict=True) if f],
        "unmeasured_bodies": list(missing.bodies),
        "markers_without_data": list(missing.markers),
    }


def _prior_fields(
    anatomical: bool,
    weighting: dict[str, Any],
    symmetric: float | None,
    asymmetry_prior: bool,
    subject: Subject,
) -> dict[str, Any]:
    """The priors part of the summary (standard deviations in millimetres)."""
    return {
        "anatomical_priors": anatomical,
        "prior_weighting": weighting,
        "symmetric_mm": None if symmetric is None else symmetric * 1e3,
        "asymmetry_prior_mm": (
            ASYMMETRY_SIGMA * 1e3 if anatomical and asymmetry_prior and symmetric is None else None
        ),
        "measurements": subject.to_dict(),
        "stature_estimate": (
            None if subject.stature_estimate is None else subject.stature_estimate.to_dict()
        ),
    }


def _with_stature(subject: Subject, scales: dict[str, ScaleEstimate]) -> Subject:
    """``subject`` with the stature estimated from the trials' segment ``scales``
    (:func:`~mocap_mj.identify.initial.segment_scales`,
    :func:`~mocap_mj.identify.initial.estimate_stature`) when its height is not measured:
    the anatomical ranges and the stature-scaled priors are centred on it."""
    if subject.get("height") is not None:
        return subject
    return subject.with_stature_estimate(estimate_stature(scales))


def t10_check(
    pset: ParameterSet, trials: Sequence[TrialData], subject: Subject
) -> T10Placement | None:
    """T10's placement against ``subject``'s stature, estimated from the trials' markers
    when not measured (:func:`~mocap_mj.identify.trunk.t10_placement`): what
    :func:`identify_to_folder` finds and reports (``--strict`` refuses its finding before
    the fit)."""
    scales = segment_scales(pset, [t.markers for t in trials])
    return t10_placement(pset, trials, _with_stature(subject, scales))


def _initial_theta(
    trials: Sequence[TrialData],
    pset: ParameterSet,
    theta0: np.ndarray | None,
    init: str,
) -> tuple[np.ndarray | None, dict[str, float], ParameterSet]:
    """The initial model (P,) of :func:`identify_to_folder`, the segment scale estimates
    behind it (name -> factor; empty unless ``init`` scaled the nominal model) and the
    parameter set to solve with: ``pset`` with its knee rolling scaled to the initial model
    (:meth:`ParameterSet.with_rolling_scaled`, fixed for the solve).

    A given ``theta0`` is kept with the model file's rolling (an exported model.xml holds its
    subject's), as is the nominal model; otherwise ``init="nominal"`` leaves it None (the
    solver starts from the nominal model), ``"scaled"`` scales the
    nominal model to the trials' marker distances and ``"placed"`` also places the marker
    offsets by IK (with the scaled rolling)."""
    scales: dict[str, float] = {}
    if theta0 is None and init != "nominal":
        markers = [t.markers for t in trials]
        estimates = segment_scales(pset, markers)
        theta0 = scaled_theta(pset, markers, scales=estimates)
        scales = {n: e.value for n, e in estimates.items()}
        pset = pset.with_rolling_scaled(theta0)
        if init == "placed":
            theta0 = place_markers(pset, theta0, markers)
    return theta0, scales, pset


def _solve(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet,
    theta0: np.ndarray | None,
    settings: LMSettings,
    subject: Subject,
    size: float,
    anatomical: bool,
    symmetric: float | None,
    progress: ProgressCallback | None,
    slides: dict[str, Slide] | None = None,
    t10: T10Placement | None = None,
) -> tuple[IdentificationResult, dict[str, Any]]:
    """The joint LM of :func:`identify_to_folder`: with ``anatomical`` through
    :func:`solve_anatomical` (ranges and landmark priors; ``symmetric`` [m] the left/right
    prior's standard deviation or None; ``slides`` the sliding landmarks or None), else the
    plain :func:`identify_lm`; return the result and the prior weighting (empty without
    ``anatomical``)."""
    if anatomical:
        return solve_anatomical(
            trials,
            pset=pset,
            theta0=theta0,
            settings=settings,
            subject=subject,
            size=size,
            symmetric=symmetric,
            progress=progress,
            slides=slides,
            t10=t10,
        )
    result = identify_lm(trials, pset=pset, theta0=theta0, settings=settings, progress=progress)
    return result, {}


def _t10_fields(t10: T10Placement) -> dict[str, Any]:
    """summary.json's ``t10_placement``: the C7-T10 distance against the stature [mm]."""
    return {
        "c7_t10_mm": t10.measured * 1e3,
        "expected_mm": t10.expected * 1e3,
        "spread_mm": t10.spread * 1e3,
        "shift_mm": t10.shift * 1e3,
        "misplaced": t10.finding is not None,
    }


def _add_finding(summary: dict[str, Any], finding: Finding) -> None:
    """``finding`` added to summary's ``marker_quality`` entry (created when the caller gave
    none), with the markers it names counted among the suspects."""
    entry = summary.get("marker_quality")
    if entry is None:
        entry = summary["marker_quality"] = {"findings": [], "suspects": {}, "excluded": []}
    entry["findings"].append(finding.to_json())
    named = dict(entry.get("suspects") or {})
    for n in finding.markers:
        named[n] = named.get(n, 0) + 1
    entry["suspects"] = dict(sorted(named.items(), key=lambda kv: (-kv[1], kv[0])))


def _summary_fields(
    trials: Sequence[TrialData],
    pset: ParameterSet,
    settings: LMSettings,
    result: IdentificationResult,
    idf: Identifiability,
    init_used: str,
    scales: dict[str, float],
    seconds: float,
    log: list[str],
) -> dict[str, Any]:
    """The solver part of the summary: initial model, frames, timing, fit (millimetres) and
    observability."""
    n_frames = sum(len(t.markers) for t in trials)
    n_used = sum(int(u.sum()) for u in result.used)
    bk, bo = idf.bound_rms()
    return {
        "solver": "lm",
        "loss": settings.loss,
        "init": init_used,
        "init_scales": scales,
        "frames": n_frames,
        "frames_used": n_used,
        "frames_skipped": n_frames - n_used,
        "seconds": seconds,
        "init_seconds": result.init_seconds,
        "iterations": result.iterations,
        "termination": result.termination.value,
        "marker_rmse_mm": result.marker_rmse * 1e3,
        "sigma_mm": result.sigma * 1e3,
        "n_residuals": result.n_residuals,
        "n_unknowns": result.n_unknowns,
        "observable_directions": idf.rank,
        "unobservable_directions": int(np.sum(~idf.observable)),
        "kappa_crlb_rms_mm": bk * 1e3,
        "offset_crlb_rms_mm": bo * 1e3,
        "kappa_mm": {
            n: float(v) * 1e3 for n, v in zip(pset.kappa_names, result.theta, strict=False)
        },
        "log": log,
    }


def _kappa_at_bound(pset: ParameterSet, result: IdentificationResult) -> dict[str, str]:
    """Kinematic parameters the solve left at a bound: name -> "lower" or "upper" (which side
    of the nominal value they stopped on)."""
    return {
        n: ("lower" if th < nom else "upper")
        for n, b, th, nom in zip(
            pset.kappa_names, result.at_bound, result.theta, pset.nominal, strict=False
        )
        if b
    }


def _write_folder(
    out: Path,
    pset: ParameterSet,
    result: IdentificationResult,
    idf: Identifiability,
    trials: Sequence[TrialData],
    settings: LMSettings,
    rows: list[SegmentRow],
    summary: dict[str, Any],
    stream: Callable[[Path], dict[str, Any]] | None = None,
    sliding: SlidingModel | None = None,
) -> None:
    """Write the result files, the tables and summary.json into ``out``, replaced whole;
    ``stream``: writes motion.npz and joint_centres.csv into the folder given to it itself
    (every frame of long trials, chunk by chunk) and returns what it adds to the summary
    (default: the fitted trials and their poses); ``sliding``: the sliding model the fit was
    weighed with, recorded in model.xml (default None: none)."""
    motion = ([], []) if stream is not None else (list(trials), list(result.qpos))
    with atomic_folder(out, force=True) as staging:
        if stream is not None:
            summary.update(jsonable(stream(staging)))
        write_result(
            staging,
            pset,
            result,
            idf,
            trials,
            summary,
            joint_range=solver_joint_range(pset.model, settings),
            motion=motion,
            sliding=sliding,
        )
        _write_tables(staging, pset, result.theta, motion, rows, summary.get("frames_fitted_range"))
        atomic_write_text(staging / "summary.json", dumps(summary, indent=2) + "\n")


def _add_checks(
    summary: dict[str, Any],
    pset: ParameterSet,
    result: IdentificationResult,
    trials: Sequence[TrialData],
    settings: LMSettings,
    ranges: tuple[np.ndarray, np.ndarray] | None,
    prior_info: np.ndarray | None = None,
) -> list[SegmentRow]:
    """Add the real-data checks to ``summary`` (worst markers, parameters outside their range
    ``ranges`` (K,) [m], default ``pset``'s, the segment table with inflated standard
    deviations, with the priors of ``prior_info`` (P, P) [1/m^2] in ``std_priors``); return
    the segment rows."""
    per_marker = marker_rmse_by_marker(pset, result, trials)
    lower, upper = ranges if ranges is not None else (None, None)
    outside = kappa_outside_bounds(pset, result.theta, lower, upper)
    summary["marker_rmse_by_marker_mm"] = {
        n: float(v) * 1e3 for n, v in zip(pset.marker_names, per_marker, strict=True)
    }
    summary["kappa_outside_bounds_mm"] = {n: [v * 1e3 for v in b] for n, b in outside.items()}
    entries, rows = uncertainty_summary(
        pset, result, trials, per_marker, settings, ranges=ranges, prior_information=prior_info
    )
    summary.update(entries)
    return rows


def _write_tables(
    out: Path,
    pset: ParameterSet,
    theta: np.ndarray,
    motion: tuple[list[TrialData], list[np.ndarray]],
    rows: Sequence[SegmentRow],
    ranges: Sequence[Sequence[int]] | None,
) -> None:
    """segments.csv, and joint_centres.csv per trial of ``motion`` (trials, poses;
    ``joint_centres_<i>.csv`` for the others, like motion.npz) of the model theta (P,) [m];
    ``ranges``: each trial's [first, stop) frames of its file (default: from frame 0)."""
    write_segments_csv(out / "segments.csv", rows)
    model = pset.model_for(theta)
    trials, poses = motion
    starts = [int(r[0]) for r in ranges][: len(trials)] if ranges else [0] * len(trials)
    for i, (trial, qpos, first) in enumerate(zip(trials, poses, starts, strict=True)):
        name = "joint_centres.csv" if i == 0 else f"joint_centres_{i}.csv"
        write_joint_centres_csv(out / name, model, trial.times, qpos, first_frame=first)


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


def result_text(summary: dict[str, Any], pset: ParameterSet, out: Path) -> str:
    held = summary.get("parameters_not_measured") or []
    measured = (
        f"{pset.size - len(held)} of {pset.size} parameters" if held else f"{pset.size} parameters"
    )
    why = []
    if summary.get("unmeasured_bodies"):
        why.append(f"no marker on {' '.join(summary['unmeasured_bodies'])}")
    if summary.get("markers_without_data"):
        why.append(f"no data for {' '.join(summary['markers_without_data'])}")
    note = f"{len(held)} held at the prior ({'; '.join(why)})\n" if held else ""
    return (
        f"identified {measured} from {summary['frames_used']} frames in "
        f"{summary['seconds']:.2f} s ({summary['iterations']} LM iterations, "
        f"{summary['termination']})\n"
        f"{note}"
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm, i.e. a per-axis noise sigma of "
        f"{summary['sigma_mm']:.3f} mm given {summary['n_unknowns']} unknowns and "
        f"{summary['n_residuals']} residuals; {summary['observable_directions']} of {pset.size} "
        f"directions observable, CRLB {summary['kappa_crlb_rms_mm']:.3f} mm (kinematic) / "
        f"{summary['offset_crlb_rms_mm']:.3f} mm (offsets)\n"
        f"wrote {out}/model.xml, theta.json, motion.npz, joint_centres.csv, segments.csv, "
        "identifiability.json, report.md"
    )


#: Effective noise [m] below which one solve with the nominal prior noise is kept.
REWEIGHT_RATIO = 1.5
#: Solves with per-trial weights at most (:func:`solve_anatomical`): each re-estimates the
#: trials' correlation times at the last solve's model, since a trial's residuals also carry
#: the bias another, overweighted trial pulled into the model.
TRIAL_WEIGHT_ROUNDS = 4
#: The rounds stop when no trial's weight changes by more than this factor.
TRIAL_WEIGHT_SETTLED = 1.25


def anatomical_priors(
    pset: ParameterSet,
    subject: Subject,
    *,
    size: float = 1.0,
    symmetric: float | None = None,
    noise: float = 0.001,
    t10: T10Placement | None = None,
) -> list[LinearGaussianPrior]:
    """Landmark priors and, with ``symmetric`` [m], the left/right length prior; without the
    rows on ``pset``'s frozen parameters (:func:`~mocap_mj.identify.partial.on_measured`).
    ``t10``: a T10 found misplaced (:mod:`mocap_mj.identify.trunk`; default None: trusted),
    widening the rows that hang on it."""
    priors = [landmark_prior(pset, subject, size=size, noise=noise, t10=t10)]
    if symmetric is not None:
        priors.append(symmetric_prior(pset, symmetric, noise=noise))
    return [on_measured(p, pset.frozen) for p in priors]


def prior_information(
    priors: Sequence[LinearGaussianPrior], settings: LMSettings, size: int
) -> np.ndarray:
    """The information (size, size) [1/m^2] the priors of a solve hold about theta: every
    row's ``a_r a_r^T / sigma_r^2`` plus the weak prior toward the initial model
    (``1 / settings.prior_sigma^2`` per parameter), as for a marker noise equal to the
    priors' ``noise`` (the weighting the solve used). For the Cramer-Rao bound with the
    priors (:meth:`Identifiability.bound_rms_with_prior`)."""
    info = np.zeros((size, size))
    for p in (settings.weak_prior(np.zeros(size)), *priors):
        info += (p.a.T / p.sigma**2) @ p.a
    return info


def solve_anatomical(
    trials: Sequence[TrialData],
    *,
    pset: ParameterSet,
    theta0: np.ndarray | None,
    settings: LMSettings,
    subject: Subject,
    size: float = 1.0,
    symmetric: float | None = None,
    progress: ProgressCallback | None = None,
    slides: dict[str, Slide] | None = None,
    t10: T10Placement | None = None,
) -> tuple[IdentificationResult, dict[str, Any]]:
    """The joint LM with anatomical ranges as bounds and the anatomical priors
    (``t10``: see :func:`anatomical_priors`).

    The priors are weighed against the markers' effective noise: a first solve uses the
    nominal marker noise (``settings.prior_noise``, 1 mm); when the artefact's noise of one
    independent observation (:func:`artefact_noise`: the per-axis noise sigma, at least
    ``SOFT_TISSUE_SIGMA`` when the residuals are correlated, times the square root of the
    residuals' correlation time tau [frames]) exceeds that by ``REWEIGHT_RATIO``, a second
    solve starts from the first one's result with the priors' noise set to it: soft-tissue
    residuals correlated over tau frames hold about 1 / tau of the information white noise
    would, and the prior keeps its weight against them. On synthetic white noise (tau about
    1, sigma the simulated noise) one solve is kept. The weak prior toward the initial model
    is unchanged (its mean becomes the first solve's model in the second solve).

    Several trials are weighed in the second solve by the independent observations each
    holds (:func:`~mocap_mj.identify.noise.trial_weights`, from each trial's residual
    correlation time about zero after the first solve; re-estimated at each weighted solve's
    model, at most ``TRIAL_WEIGHT_ROUNDS`` solves, until no weight changes by more than
    ``TRIAL_WEIGHT_SETTLED``): a static trial's soft tissue is one offset over all its frames
    and would otherwise outvote a movement. Residuals of white noise keep every weight 1 (no
    second solve on their account, and no sliding weights); one trial always weighs 1.

    With ``slides`` (e.g. :data:`~mocap_mj.identify.tissue.SLIDES`; default None: off) the
    second solve also weighs the landmark markers that slide with their joint's angle
    (:mod:`mocap_mj.identify.tissue`) by the first solve's poses, against a per-axis artefact
    of ``max(sigma, SOFT_TISSUE_SIGMA)``: the soft-tissue model applies only where the
    residuals show soft tissue, never on white noise. ``mocap-mj identify`` passes
    :data:`~mocap_mj.identify.tissue.SLIDES` unless ``--no-sliding-landmarks``
    (docs/real-data.md "Soft-tissue sliding"). Returns the result and the weighting used
    (``noise_mm``, ``sigma_mm``, ``tau_frames``, ``trial_tau_frames`` and ``trial_weights``
    (one per trial); when the sliding weights were applied,
    ``slide_weight_min``, the smallest of them, and ``slide_base_mm``, the per-axis artefact
    ``base``).
    """
    lower, upper = theta_bounds(pset, subject)
    priors = anatomical_priors(
        pset, subject, size=size, symmetric=symmetric, noise=settings.prior_noise,
        t10=t10,
    )  # fmt: skip
    start = pset.nominal if theta0 is None else theta0
    result = identify_lm(
        trials,
        pset=pset,
        theta0=theta0,
        settings=settings,
        progress=progress,
        priors=[settings.weak_prior(start), *priors],
        lower=lower,
        upper=upper,
    )
    residuals = trial_residuals(pset, result, trials)
    tau = pooled_correlation_time(residuals)
    noise = artefact_noise(result.sigma, tau)
    taus, per_trial = _trial_weighting(residuals)
    weighting: dict[str, Any] = {
        "sigma_mm": result.sigma * 1e3,
        "tau_frames": tau,
        "noise_mm": noise * 1e3,
        "trial_tau_frames": taus,
        "trial_weights": per_trial,
    }
    soft = noise > REWEIGHT_RATIO * settings.prior_noise
    if not soft and all(w == 1.0 for w in per_trial):
        weighting["noise_mm"] = settings.prior_noise * 1e3
        return result, weighting
    if soft:
        logger.info("priors reweighted: noise %.2f mm (sigma x sqrt(tau %.1f))", noise * 1e3, tau)
    else:
        noise = settings.prior_noise
        weighting["noise_mm"] = noise * 1e3
    if any(w != 1.0 for w in per_trial):
        logger.info(
            "trials weighed by their independent frames: %s",
            ", ".join(f"{w:.2f} (tau {t:.0f})" for w, t in zip(per_trial, taus, strict=True)),
        )
    first = result
    weighted = list(trials)
    if slides and soft:
        base = max(first.sigma, SOFT_TISSUE_SIGMA)
        weights = [sliding_weights(pset, q, base, slides) for q in first.qpos]
        weighted = [t._replace(weights=w) for t, w in zip(trials, weights, strict=True)]
        weighting["slide_weight_min"] = float(min(w.min() for w in weights))
        weighting["slide_base_mm"] = base * 1e3
    solve = partial(
        identify_lm,
        pset=pset,
        settings=settings,
        progress=progress,
        priors=[settings.weak_prior(first.theta), *(p.with_noise(noise) for p in priors)],
        lower=lower,
        upper=upper,
    )
    result = solve(_trials_weighed(weighted, per_trial), theta0=first.theta,
                   initial_qpos=first.qpos)  # fmt: skip
    seconds, iterations = first.seconds + result.seconds, first.iterations + result.iterations
    for _ in range(TRIAL_WEIGHT_ROUNDS - 1):
        if all(w == 1.0 for w in per_trial):
            break
        taus, update = _trial_weighting(trial_residuals(pset, result, trials))
        if max(abs(np.log(u / w)) for u, w in zip(update, per_trial, strict=True)) < np.log(
            TRIAL_WEIGHT_SETTLED
        ):
            break
        per_trial = update
        weighting.update(trial_tau_frames=taus, trial_weights=per_trial)
        logger.info("trials reweighed: %s", ", ".join(f"{w:.2f}" for w in per_trial))
        result = solve(_trials_weighed(weighted, per_trial), theta0=result.theta,
                       initial_qpos=result.qpos)  # fmt: skip
        seconds, iterations = seconds + result.seconds, iterations + result.iterations
    result.theta0 = first.theta0
    result.seconds = seconds
    result.init_seconds = first.init_seconds
    result.iterations = iterations
    return result, weighting


def _trial_weighting(residuals: Sequence[np.ndarray]) -> tuple[list[float], list[float]]:
    """Each trial's residual correlation time about zero [frames] and its weight [1]
    (:func:`~mocap_mj.identify.noise.trial_weights`) from the trials' residuals (T_i, M, 3)
    [m]."""
    taus = [residual_correlation_time(r, about_mean=False) for r in residuals]
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
