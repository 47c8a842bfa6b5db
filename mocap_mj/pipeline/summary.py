"""The summary of a fit (summary.json): what :func:`mocap_mj.pipeline.api.identify` reports
beside its arrays, in the summary's units (millimetres, seconds; names ending ``_mm``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from mocap_mj.anatomy.anatomy import ASYMMETRY_SIGMA
from mocap_mj.anatomy.axes import widths
from mocap_mj.anatomy.ball_centres import BallCentre, CentreRowReport, centre_report, row_spreads
from mocap_mj.anatomy.hinge_centres import HingeCentre
from mocap_mj.anatomy.initial import marker_stature, segment_scales
from mocap_mj.anatomy.joint_checks import (
    Check,
    checks_summary,
    half_width,
    joint_checks,
    violations,
)
from mocap_mj.anatomy.partial import Unmeasured
from mocap_mj.anatomy.plausibility import (
    implausible_reasons,
    joints_at_limit,
    kappa_outside_bounds,
    marker_rmse_by_marker,
)
from mocap_mj.anatomy.segments import SegmentRow, Uncertainty, uncertainty_summary
from mocap_mj.anatomy.standing import standing_knee_axes, standing_note
from mocap_mj.anatomy.tissue import arm_elevation, raised_arms_note
from mocap_mj.anatomy.trunk import T10Placement
from mocap_mj.capture.marker_quality import Finding
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.anatomical import anatomical_priors
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.relabel import Relabel
from mocap_mj.pipeline.report import Checks, MarkerQuality
from mocap_mj.pipeline.results import Refined, Weighting, joint_axes, prior_noise
from mocap_mj.pipeline.steps import REWEIGHT_RATIO, Solved
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMSettings, solver_joint_range
from mocap_mj.solve.noise import SOFT_TISSUE_SIGMA
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.solver_result import IdentificationResult

from ..errors import MocapError


class Judged(NamedTuple):
    """What :func:`judge` finds of a solve: the kinematic parameters left at a bound (name ->
    ``lower`` or ``upper``), the reasons to call it implausible (one sentence each) and the
    anatomical checks of its joints."""

    kappa_at_bound: dict[str, str]
    implausible: list[str]
    joints: list[Check]


def judge(solved: Solved, trials: Sequence[TrialData]) -> Judged:
    """The plausibility of the solve ``solved`` on ``trials`` (the frames identified on): the
    bounds it reached, the marker fit and stature, and each joint inside the body (a joint
    the markers hold away from its construction said so)."""
    pset, result = solved.pset, solved.result
    at_bound = _kappa_at_bound(pset, result)
    reasons = implausible_reasons(
        result.marker_rmse,
        len(at_bound),
        int(np.sum(~pset.frozen[: pset.n_kappa])),
        marker_stature(segment_scales(pset, [t.markers for t in trials])),
    )
    joints = joint_checks(pset, result.theta, solved.subject, solved.landmarks,
                          joint_axes(solved.weighting) or None)  # fmt: skip
    held = None if solved.weighting is None else solved.weighting.held_at_construction
    note = ""
    if held and not held.kept:
        first, holding = (v * 1e3 for v in held.marker_rmse)
        note = (f"; held at its construction the markers fit at {holding:.2f} mm RMSE "
                f"({first:.2f} as fitted): they place it there, a marker misplaced?")  # fmt: skip
    return Judged(at_bound, reasons + violations(joints, note), joints)


def fit_report(
    solved: Solved,
    trials: Sequence[TrialData],
    settings: LMSettings,
    recipe: Recipe,
    idf: Identifiability,
    judged: Judged,
) -> dict[str, Any]:
    """The summary of the solve ``solved`` on ``trials`` (the frames identified on) judged
    ``judged``: solver, frames, timing, fit and observability, priors, measured parameters,
    bounds and limits reached, plausibility, the arms' elevation and T10's placement."""
    pset, result = solved.pset, solved.result
    summary = _summary_fields(trials, solved, settings, idf)
    summary.update(
        _prior_fields(recipe.anatomy, solved.weighting, recipe.symmetric,
                      recipe.asymmetry_prior, solved.subject)
    )  # fmt: skip
    summary["hip_centre"] = recipe.hip_centre if recipe.anatomy else None
    summary["init_centres"] = dict(solved.construction or {})
    summary.update(_measured_fields(pset, solved.missing))
    summary["sliding_landmarks"] = None if solved.sliding is None else sorted(solved.sliding.slides)
    summary["kappa_at_bound"] = dict(judged.kappa_at_bound)
    summary["implausible"] = list(judged.implausible)
    summary["anatomy_checks"] = checks_summary(judged.joints)
    held = None if solved.weighting is None else solved.weighting.held_at_construction
    summary["held_at_construction"] = None if held is None else {
        "joints": held.joints, "marker_rmse_mm": [v * 1e3 for v in held.marker_rmse],
        "kept": held.kept,
    }  # fmt: skip
    fitted = [q[used] for q, used in zip(result.qpos, result.used, strict=True)]
    summary["joints_at_limit"] = joints_at_limit(
        pset.model, solver_joint_range(pset.model, settings), fitted
    )
    elevation = arm_elevation(pset, fitted)
    summary["arm_elevation_deg"] = {
        s: [float(np.degrees(a)) for a in v] for s, v in elevation.items()
    }
    summary["shoulder_note"] = raised_arms_note(elevation)
    summary.update(_standing_fields(solved, trials))
    summary["t10_placement"] = None if solved.t10 is None else _t10_fields(solved.t10)
    return summary


def _standing_fields(solved: Solved, trials: Sequence[TrialData]) -> dict[str, Any]:
    """``standing_knee_axes_deg`` (trial -> side -> the identified and the constructed knee
    axis's yaw from the pelvis's lateral axis [deg], :mod:`mocap_mj.anatomy.standing`, for
    each trial where the subject stands) and ``standing_notes`` (one line per trial whose
    axes are not a standing knee's)."""
    pset, result = solved.pset, solved.result
    names = set(pset.names)
    half = {s: half_width(pset, result.theta, solved.subject, "knee_width", s)[0]
            for s in ("l", "r") if f"thigh_length_{s}" in names}  # fmt: skip
    entries: dict[str, Any] = {}
    notes = []
    for trial, q, used in zip(trials, result.qpos, result.used, strict=True):
        axes = standing_knee_axes(pset, result.theta, q[used], trial.markers[used], half,
                                  solved.landmarks)  # fmt: skip
        if axes is None:
            continue
        entries[str(trial.name)] = {
            s: {k: None if v is None else float(np.degrees(v)) for k, v in e.items()}
            for s, e in axes.items()
        }
        note = standing_note(axes, str(trial.name))
        if note:
            notes.append(note)
    return {"standing_knee_axes_deg": entries, "standing_notes": notes}


def _measured_fields(pset: ParameterSet, missing: Unmeasured) -> dict[str, Any]:
    """The partial-marker-set part of the summary: how many parameters the data measured,
    the names of those held at the prior (:mod:`mocap_mj.anatomy.partial`), the bodies no
    present marker determines and the markers without data."""
    return {
        "parameters_measured": int(np.sum(~pset.frozen)),
        "parameters_not_measured": [n for n, f in zip(pset.names, pset.frozen, strict=True) if f],
        "unmeasured_bodies": list(missing.bodies),
        "markers_without_data": list(missing.markers),
    }


def _prior_fields(
    anatomical: bool,
    weighting: Weighting | None,
    symmetric: float | None,
    asymmetry_prior: bool,
    subject: Subject,
) -> dict[str, Any]:
    """The priors part of the summary (standard deviations in millimetres)."""
    return {
        "anatomical_priors": anatomical,
        "prior_weighting": _weighting_fields(weighting),
        "joint_axes": {j: _axis_fields(d) for j, d in joint_axes(weighting).items()},
        "symmetric_mm": None if symmetric is None else symmetric * 1e3,
        "asymmetry_prior_mm": (
            ASYMMETRY_SIGMA * 1e3 if anatomical and asymmetry_prior and symmetric is None else None
        ),
        "measurements": subject.to_dict(),
        "sex": None if subject.sex is None else {"value": subject.sex[0], "source": subject.sex[1]},
        "stature_estimate": (
            None if subject.stature_estimate is None else subject.stature_estimate.to_dict()
        ),
    }


def _weighting_fields(w: Weighting | None) -> dict[str, Any]:
    """summary.json's ``prior_weighting`` (empty without the anatomical priors)."""
    if w is None:
        return {}
    out: dict[str, Any] = {
        "sigma_mm": w.sigma * 1e3,
        "tau_frames": w.tau_frames,
        "noise_mm": w.noise * 1e3,
        "trial_tau_frames": w.trial_tau_frames,
        "trial_weights": w.trial_weights,
    }
    if w.centre_widths is not None:
        out["centre_widths"] = w.centre_widths
    if w.slide_base is not None:
        out["slide_weight_min"] = w.slide_weight_min
        out["slide_base_mm"] = w.slide_base * 1e3
    return out


def _axis_fields(decision: dict[str, Any]) -> dict[str, Any]:
    """summary.json's ``joint_axes`` entry of one flexion axis: its decision with the marker
    RMSE of each fit in mm (``rmse_mm``)."""
    out: dict[str, Any] = {}
    for k, v in decision.items():
        if k == "rmse_m":
            out["rmse_mm"] = {n: None if r is None else r * 1e3 for n, r in v.items()}
        else:
            out[k] = v
    return out


def _t10_fields(t10: T10Placement) -> dict[str, Any]:
    """summary.json's ``t10_placement``: the C7-T10 distance against the stature [mm]."""
    return {
        "c7_t10_mm": t10.measured * 1e3,
        "expected_mm": t10.expected * 1e3,
        "spread_mm": t10.spread * 1e3,
        "shift_mm": t10.shift * 1e3,
        "misplaced": t10.finding is not None,
    }


def finding_fields(finding: Finding) -> dict[str, Any]:
    """One finding of summary.json's ``marker_quality`` (its figure ``value_mm`` in mm, to
    0.1 mm)."""
    f = finding
    return {
        "file": f.file,
        "kind": f.kind,
        "markers": list(f.markers),
        "frames": None if f.frames is None else list(f.frames),
        "value_mm": round(f.value * 1e3, 1),
        "expected": f.expected,
        "message": f.message,
    }


def relabel_fields(relabel: Relabel) -> dict[str, Any]:
    """One correction of summary.json's ``marker_quality.relabelled`` (its residuals
    ``before_mm``, ``after_mm`` in mm, to 0.1 mm)."""
    r = relabel
    return {
        "file": r.file,
        "kind": r.kind,
        "markers": list(r.markers),
        "sources": list(r.sources),
        "frames": list(r.frames),
        "before_mm": round(r.before * 1e3, 1),
        "after_mm": round(r.after * 1e3, 1),
        "applied": r.applied,
        "message": r.message,
    }


def quality_fields(quality: MarkerQuality) -> dict[str, Any]:
    """summary.json's ``marker_quality`` entry: the corrections of the labels, the findings,
    the markers they name (:func:`~mocap_mj.capture.marker_quality.suspects`), the excluded
    markers and the samples the findings drop."""
    return {
        "relabelled": [relabel_fields(r) for r in quality.relabelled],
        "findings": [finding_fields(f) for f in quality.findings],
        "suspects": quality.suspects,
        "excluded": list(quality.excluded),
        "samples_dropped": quality.samples_dropped,
    }


def _summary_fields(
    trials: Sequence[TrialData], solved: Solved, settings: LMSettings, idf: Identifiability
) -> dict[str, Any]:
    """The solver part of the summary of ``solved`` on ``trials``: initial model, frames,
    timing, fit (millimetres) and observability."""
    pset, result = solved.pset, solved.result
    n_frames = sum(len(t.markers) for t in trials)
    n_used = sum(int(u.sum()) for u in result.used)
    bk, bo = idf.bound_rms()
    return {
        "solver": "lm",
        "loss": settings.loss,
        "init": solved.init_used,
        "init_scales": solved.scales,
        "frames": n_frames,
        "frames_used": n_used,
        "frames_skipped": n_frames - n_used,
        "seconds": solved.seconds,
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
        "log": solved.log,
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


class Checked(NamedTuple):
    """:func:`check_fit`'s checks and segment table
    (:class:`~mocap_mj.anatomy.segments.Uncertainty`)."""

    checks: Checks
    table: Uncertainty


def check_fit(
    solved: Solved,
    trials: Sequence[TrialData],
    settings: LMSettings,
    judged: Judged,
    prior_info: np.ndarray | None = None,
) -> Checked:
    """The real-data checks of ``solved`` on ``trials`` judged ``judged``: each marker's RMSE,
    the parameters outside their range (``solved.ranges``, default ``pset``'s), the segment
    table with inflated standard deviations, with the priors of ``prior_info`` (P, P)
    [1/m^2] in ``std_priors``."""
    pset, result, ranges = solved.pset, solved.result, solved.ranges
    per_marker = marker_rmse_by_marker(pset, result, trials)
    lower, upper = ranges if ranges is not None else (None, None)
    table = uncertainty_summary(
        pset, result, trials, per_marker, settings, ranges=ranges, prior_information=prior_info
    )
    checks = Checks(
        marker_rmse_by_marker={
            n: float(v) for n, v in zip(pset.marker_names, per_marker, strict=True)
        },
        worst_markers=dict(table.worst),
        kappa_outside_bounds=kappa_outside_bounds(pset, result.theta, lower, upper),
        kappa_at_bound=dict(judged.kappa_at_bound),
        parameters_flagged=dict(table.flagged),
        implausible=tuple(judged.implausible),
    )
    return Checked(checks, table)


def checks_fields(checked: Checked) -> dict[str, Any]:
    """summary.json's checks [mm]: each marker's RMSE, the parameters outside their range,
    the residuals' correlation time, the segment table, the flagged parameters and the worst
    markers."""
    checks, table = checked
    return {
        "marker_rmse_by_marker_mm": {n: v * 1e3 for n, v in checks.marker_rmse_by_marker.items()},
        "kappa_outside_bounds_mm": {
            n: [v * 1e3 for v in b] for n, b in checks.kappa_outside_bounds.items()
        },
        "correlation_time_frames": table.tau_frames,
        "segments": {r.name: segment_fields(r) for r in table.rows},
        "parameters_flagged": dict(checks.parameters_flagged),
        "worst_markers_mm": {n: v * 1e3 for n, v in checks.worst_markers.items()},
    }


def segment_fields(row: SegmentRow) -> dict[str, Any]:
    """One row of the segment table as summary.json's ``segments`` holds it: millimetres,
    null where not applicable."""

    def mm(v: float) -> float | None:
        return float(v) * 1e3 if math.isfinite(v) else None

    return {
        "kind": row.kind,
        "value_mm": mm(row.value),
        "std_white_mm": mm(row.std_white),
        "std_mm": mm(row.std),
        "std_priors_mm": mm(row.std_priors),
        "nominal_mm": mm(row.nominal),
        "lower_mm": mm(row.lower),
        "upper_mm": mm(row.upper),
        "flag": row.flag,
    }


def regression_centres(
    solved: Solved, settings: LMSettings, recipe: Recipe
) -> dict[str, BallCentre]:
    """:func:`~mocap_mj.anatomy.ball_centres.centre_report` at the solve's model: each
    regression-placed ball joint's centre against its regression, with the data counted as
    the solve counted them (the weighting's noise; with correlated residuals the soft-tissue
    floor of ``max(sigma, SOFT_TISSUE_SIGMA)``); for the hips also the other regression's
    centre (in ``others``: Davis beside Harrington, Harrington beside Davis; Davis's needs
    both leg lengths). Empty without the anatomical priors."""
    if not recipe.anatomy:
        return {}
    pset, result, w = solved.pset, solved.result, solved.weighting
    if solved.anatomy is None:
        return {}
    anatomy = replace(solved.anatomy, held=() if w is None else w.held_joints)
    axes = widths(pset, joint_axes(w) or None)
    noise = prior_noise(w, settings.prior_noise)
    priors = [p.with_noise(noise) for p in anatomical_priors(pset, anatomy, axes=axes)]
    soft = noise > REWEIGHT_RATIO * settings.prior_noise  # as solve_anatomical decides
    sta = max(result.sigma, SOFT_TISSUE_SIGMA) if soft else 0.0
    spreads = row_spreads(pset, result.reduced_information, result.free, result.qpos,
                          priors[0], [settings.weak_prior(result.theta), *priors[1:]], noise,
                          sta)  # fmt: skip
    other = "davis" if recipe.hip_centre == "harrington" else "harrington"
    try:
        alt = anatomical_priors(pset, replace(anatomy, hip_centre=other), axes=axes)[0]
    except MocapError:  # Davis's rows need both leg lengths
        alt = None
    return dict(centre_report(pset, result.theta, priors[0], spreads, {other: alt}))


def centre_fields(centres: Mapping[str, BallCentre]) -> dict[str, Any]:
    """summary.json's ``joint_centres_vs_regression`` [mm] of :func:`regression_centres`."""
    return {joint: _ball_centre_fields(c) for joint, c in centres.items()}


def _ball_centre_fields(c: BallCentre) -> dict[str, Any]:
    """One joint's entry of summary.json's ``joint_centres_vs_regression`` [mm]."""
    out: dict[str, Any] = {
        "body": c.body,
        "identified_mm": (c.identified * 1e3).tolist(),
        "regression": c.regression,
        "regression_mm": (c.regression_centre * 1e3).tolist(),
        "distance_mm": c.distance * 1e3,
        "distance_sd_mm": c.distance_sd * 1e3,
        "moved_by_data": c.moved_by_data,
        "rows": {label: _centre_row_fields(r) for label, r in c.rows.items()},
    }
    for name, centre in c.others.items():
        out[f"{name}_mm"] = None if centre is None else (centre * 1e3).tolist()
    return out


def _centre_row_fields(r: CentreRowReport) -> dict[str, float | None]:
    """One regression row's report [mm]: its value's distance from the regression, the
    regression's width, the data's and the floor's standard deviations and the width factor."""
    spread = r.spread
    return {
        "from_regression_mm": r.distance * 1e3,
        "regression_sd_mm": r.regression_sd * 1e3,
        "data_sd_mm": None if spread is None else spread.data_m * 1e3,
        "artefact_floor_mm": None if spread is None else spread.floor_m * 1e3,
        "width_factor": None if spread is None else spread.factor,
    }


def refinement_fields(pset: ParameterSet, refined: Refined) -> dict[str, Any]:
    """summary.json's ``refinement``: its steps [sd], seconds and the subset's own kinematic
    parameters (``subset_kappa_mm``, mm)."""
    return {
        "steps_std": refined.steps_std,
        "seconds": refined.seconds,
        "subset_kappa_mm": {
            n: float(v) * 1e3 for n, v in zip(pset.kappa_names, refined.subset_kappa, strict=True)
        },
    }


def hinge_fields(centres: Mapping[str, HingeCentre]) -> dict[str, dict[str, Any]]:
    """summary.json's ``joint_centres_vs_construction``
    (:func:`~mocap_mj.anatomy.hinge_centres.hinge_report`): per hinge centre its
    construction, ``construction_mm`` and ``identified_mm`` (x y z in the markers' frame),
    ``distance_mm``, ``distance_sd_mm`` and ``moved_by_data``."""
    return {
        joint: {
            "construction": c.construction,
            "construction_mm": (c.constructed * 1e3).tolist(),
            "identified_mm": (c.identified * 1e3).tolist(),
            "distance_mm": c.distance * 1e3,
            "distance_sd_mm": c.distance_sd * 1e3,
            "moved_by_data": c.moved_by_data,
        }
        for joint, c in centres.items()
    }


def motion_fields(rmse: float, ik_seconds: float, seconds: float) -> dict[str, Any]:
    """summary.json's figures of every frame's motion: its marker RMSE ``rmse`` [m] in mm and
    the wall times [s] of its IK and of the whole."""
    return {
        "motion_marker_rmse_mm": rmse * 1e3,
        "motion_seconds": {"ik": ik_seconds, "all": seconds},
    }


def written_marker_rmse(summary: Mapping[str, Any]) -> float | None:
    """The marker RMSE [m] a written summary.json (its content, millimetres) records, for a
    command that reads another's result folder (None: it records none)."""
    rmse = summary.get("marker_rmse_mm")
    return rmse / 1e3 if isinstance(rmse, float) else None
