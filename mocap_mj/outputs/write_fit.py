"""Writing an identification result folder (see :mod:`mocap_mj.pipeline.motion`) and its report."""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.joint_checks import report_line
from mocap_mj.anatomy.plausibility import limits_text
from mocap_mj.anatomy.standing import standing_lines
from mocap_mj.anatomy.tissue import SlidingModel, with_sliding_model
from mocap_mj.capture.marker_quality import quality_lines
from mocap_mj.capture.marker_set import load_marker_set
from mocap_mj.errors import MocapError
from mocap_mj.io.strict_json import dumps, jsonable
from mocap_mj.outputs.fit_tables import (
    axis_lines,
    hinge_lines,
    uncertainty_lines,
    write_segments_csv,
)
from mocap_mj.outputs.trial_out import (
    save_motions,
    streamed_name,
    write_trial_plots,
    write_trial_tables,
)
from mocap_mj.pipeline.fit import Fit
from mocap_mj.pipeline.motion import Motion
from mocap_mj.pipeline.recipe import frame_range as frame_range
from mocap_mj.pipeline.trials import trial_folders
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import solver_joint_range
from mocap_mj.solve.noise import CORRELATED_TAU, SOFT_TISSUE_SIGMA, artefact_noise
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.solver_result import IdentificationResult, IterationLog

from ..arguments import instance, optional, path_like, validated
from ..io.atomic import atomic_folder, atomic_write_text


@validated(
    fit=instance(Fit, "a Fit (what mocap_mj.identify returns)"),
    folder=path_like,
    inputs=optional(instance(Mapping, "a mapping or None")),
    force=instance(bool, "True or False"),
)
def write_result(
    fit: Fit,
    folder: str | Path,
    *,
    inputs: Mapping[str, Any] | None = None,
    force: bool = False,
) -> dict[str, Any]:
    """Write ``fit`` as a result folder (:mod:`mocap_mj.pipeline.motion`): model.xml, theta.json,
    recipe.yaml (:meth:`Recipe.save`: ``mocap-mj identify --recipe`` re-runs it), per trial
    in its folder (:mod:`mocap_mj.pipeline.trials`: the first trial's at the top, each
    further one's in ``trials/<name>/``) motion.npz, joint_centres.csv, angles.csv (Plug-in
    Gait's angles of the model; compared in report.md with the Nexus angles its C3D holds)
    and marker_error.png; segments.csv, identifiability.json, report.md (a section per trial
    of several), residual_per_marker.png and summary.json (``inputs``, e.g. the marker files
    read, then :meth:`Fit.summary`, then ``trials``). The folder is replaced whole at the end
    (:func:`~mocap_mj.io.atomic.atomic_folder`; a non-empty ``folder`` only with ``force``);
    a motion streamed to files (``Fit.motion_files``) is moved into it. Returns the summary
    written."""
    summary = jsonable({**(inputs or {}), **fit.summary()})
    motion = list(fit.motion) if fit.motion is not None else []
    folders = trial_folders([str(t.name) for t in fit.trials])
    with atomic_folder(folder, force=force) as staging:
        for path in fit.motion_files:
            target = staging / streamed_name(path.name, folders)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(path, target)
        fitted_rmse = write_files(
            staging,
            fit.pset,
            fit.result,
            fit.identifiability,
            fit.trials,
            summary,
            model_xml=ModelXml(solver_joint_range(fit.pset.model, fit.settings), fit.sliding),
            motion=motion,
        )
        write_segments_csv(staging / "segments.csv", fit.segments)
        lines = write_trial_tables(staging, fit, motion, summary, fitted_rmse)
        if lines:
            report = staging / "report.md"
            atomic_write_text(report, report.read_text() + "\n" + "\n".join(lines))
        fit.recipe.save(staging / "recipe.yaml")
        atomic_write_text(staging / "summary.json", dumps(summary, indent=2) + "\n")
    return summary


@dataclass(frozen=True)
class ModelXml:
    """What model.xml records besides the parameters.

    Fields
    ------
    joint_range : (njnt, 2) [rad or m], the limits the solver used (default None: the
        model's own; see :meth:`ParameterSet.to_spec`)
    sliding : the landmarks' sliding model the fit was weighed with, recorded for ``ik``
        (:func:`~mocap_mj.anatomy.tissue.with_sliding_model`; default None: not recorded)
    """

    joint_range: np.ndarray | None = None
    sliding: SlidingModel | None = None

    def text(self, pset: ParameterSet, theta: np.ndarray) -> str:
        """model.xml of ``pset`` with the parameters theta (P,) [m] and this record."""
        xml = pset.to_xml(theta, joint_range=self.joint_range)
        return xml if self.sliding is None else with_sliding_model(xml, self.sliding)


def write_files(
    out: Path,
    pset: ParameterSet,
    result: IdentificationResult,
    idf: Identifiability,
    trials: Sequence[TrialData],
    summary: Mapping[str, Any],
    *,
    model_xml: ModelXml = ModelXml(),
    motion: Sequence[Motion] | None = None,
) -> list[float | None]:
    """model.xml, theta.json, each trial's motion.npz and marker_error.png in its folder
    (:mod:`mocap_mj.pipeline.trials`), residual_per_marker.png, identifiability.json and
    report.md (:func:`report_lines`); returns each trial's marker RMSE on its fitted frames
    [mm] (:func:`write_plots`). ``model_xml``: what model.xml records besides theta (the
    solver's joint limits, the sliding model; default: neither). ``motion``: what
    motion.npz holds (default: ``trials`` and the fit's poses; internal qpos (T_i, nq),
    written in model.xml's layout, :class:`mocap_mj.skeleton.exported.Layout`)."""
    atomic_write_text(out / "model.xml", model_xml.text(pset, result.theta))
    pset.save_json(
        out / "theta.json",
        result.theta,
        extra={
            "description": "mocap-mj identified model parameters",
            "theta0": pset.to_dict(result.theta0),
            "parameter_std_m": {
                n: float(s) for n, s in zip(pset.names, idf.param_std, strict=True)
            },
        },
    )
    if motion is None:
        motion = [
            Motion(q, t.times, t.markers, pset.marker_names)
            for t, q in zip(trials, result.qpos, strict=True)
        ]
    save_motions(out, pset, trials, motion)
    atomic_write_text(out / "identifiability.json", json.dumps(idf.to_json()) + "\n")
    fitted_rmse = write_plots(out, pset, result, trials)
    lines = report_lines(pset, result, idf, summary)
    atomic_write_text(out / "report.md", "\n".join(lines))
    return fitted_rmse


def write_plots(
    out: Path, pset: ParameterSet, result: IdentificationResult, trials: Sequence[TrialData]
) -> list[float | None]:
    """Each trial's marker_error.png in its folder and residual_per_marker.png: every
    marker's RMSE over the fitted frames of all trials, the markers never recorded left out
    (they have no residual; a zero bar would lower the mean). Returns each trial's marker
    RMSE on its fitted frames [mm] (None without data)."""
    from mocap_mj.io.plots import plot_residual_per_marker

    (sq, cnt), per_trial = write_trial_plots(out, pset, result, trials)
    seen = cnt > 0
    rmse = np.sqrt(sq[seen] / cnt[seen])
    names = [n for n, s in zip(pset.marker_names, seen, strict=True) if s]
    plot_residual_per_marker(out / "residual_per_marker.png", names, rmse)
    return per_trial


def report_lines(
    pset: ParameterSet,
    result: IdentificationResult,
    idf: Identifiability,
    summary: Mapping[str, Any],
    iterations: Sequence[str] | None = None,
) -> list[str]:
    """The Markdown report; ``iterations``: its last section (default :func:`iteration_lines`)."""
    lines = [
        "# Identification report",
        "",
        f"- trials: {', '.join(summary.get('markers_files', []))}",
        f"- frames used: {summary['frames_used']} of {summary['frames']}",
        f"- solver: {summary['solver']}, loss {summary.get('loss', 'l2')}, "
        f"{iterations_text(summary, result.iterations)} ({result.termination.value})",
        f"- time: {summary['seconds']:.2f} s (initial IK {result.init_seconds:.2f} s)",
        f"- marker RMSE: {result.marker_rmse * 1e3:.3f} mm: a per-axis noise sigma of "
        f"{result.sigma * 1e3:.3f} mm (RMSE / sqrt(3 (1 - p/n)), p = {result.n_unknowns} "
        f"unknowns, n = {result.n_residuals} residuals)",
        *_measured_lines(pset, summary),
        *_anatomy_lines(summary),
        *centre_lines(summary.get("joint_centres_vs_regression") or {}),
        *hinge_lines(summary.get("joint_centres_vs_construction") or {}),
        "",
        *(quality_lines(summary["marker_quality"]) if summary.get("marker_quality") else []),
        *kappa_lines(pset, result, idf, summary),
    ]
    lines += ["", *uncertainty_lines(summary), *idf.report_lines()]
    lines += iteration_lines(result) if iterations is None else list(iterations)
    return lines


def kappa_lines(
    pset: ParameterSet,
    result: IdentificationResult,
    idf: Identifiability,
    summary: Mapping[str, Any],
) -> list[str]:
    """report.md's table of the kinematic parameters the recording measures (those not
    measured are counted, not listed): initial, identified, change and the white standard
    deviation as segments.csv gives it (the Cramer-Rao figure with the weak prior; a
    parameter the markers do not determine says so and shows the prior's width)."""
    kappa, _ = pset.split(result.theta)
    kappa0, _ = pset.split(result.theta0)
    segments = summary.get("segments") or {}
    loose = idf.undetermined()
    lines = [
        "## Kinematic parameters",
        "",
        "| parameter | initial (mm) | identified (mm) | change (mm) | std, white (mm) |",
        "|---|---|---|---|---|",
    ]
    for i, name in enumerate(pset.kappa_names):
        if pset.frozen[i]:
            continue
        white = (segments.get(name) or {}).get("std_white_mm")
        std = f"{idf.param_std[i] * 1e3:.2f}" if white is None else f"{white:.2f}"
        if loose[i]:
            std += " (not determined by the markers: the weak prior's width)"
        lines.append(
            f"| {name} | {kappa0[i] * 1e3:.1f} | {kappa[i] * 1e3:.2f} | "
            f"{(kappa[i] - kappa0[i]) * 1e3:+.2f} | {std} |"
        )
    held = int(np.sum(pset.frozen[: pset.n_kappa]))
    if held:
        lines += ["", f"{held} kinematic parameters not measured (held at the prior) are not "
                  "listed; segments.csv gives them, flagged `not_measured`."]  # fmt: skip
    return lines


def _measured_lines(pset: ParameterSet, summary: Mapping[str, Any]) -> list[str]:
    """The report's line on a partial marker set (none when every parameter was measured):
    how many parameters the data measured and why the others are held at the prior."""
    held = summary.get("parameters_not_measured") or []
    if not held:
        return []
    bodies = ", ".join(summary.get("unmeasured_bodies") or []) or "none"
    markers = _without_data(pset, summary, ", ") or "none"
    return [
        f"- parameters measured: {pset.size - len(held)} of {pset.size}; {len(held)} held at "
        f"the prior mean (the scaled model, flagged `not_measured`, no standard deviation): "
        f"bodies without a marker: {bodies}; markers without data: {markers}"
    ]


def _without_data(pset: ParameterSet, summary: Mapping[str, Any], sep: str) -> str:
    """The markers without data in the words of the marker set: with a set that is a part of
    the model's markers (a lower-body set; summary.json's ``marker_set``), the model's
    markers outside it are counted as such, only the set's own are listed."""
    names = list(summary.get("markers_without_data") or [])
    record = summary.get("marker_set") or {}
    size = record.get("markers")
    if not isinstance(size, int) or size >= pset.n_markers or not record.get("file"):
        return sep.join(names)
    try:
        ours = set(load_marker_set(record["file"]).names)
    except MocapError:  # the set's file is gone: the names as they are
        return sep.join(names)
    outside = [n for n in names if n not in ours]
    own = [n for n in names if n in ours]
    if not outside:
        return sep.join(names)
    text = f"the model's {len(outside)} markers not of the set {record.get('name')!r}"
    return sep.join([*own, text]) if own else text


def iteration_lines(result: IdentificationResult) -> list[str]:
    """The report's iterations section: one line per trace entry (cost, RMSE; for the joint
    LM also damping, acceptance and time)."""
    lines = ["## Iterations", "", "```"]
    # The coarse phase's iterations run on subsets (their F is the subset's): say on which.
    levels = {log.frames for log in result.trace if isinstance(log, IterationLog)}
    for log in result.trace:
        text = f"{log.iteration:3d}  F {log.cost:.6e}  rmse {log.rmse * 1e3:.4f} mm"
        if isinstance(log, IterationLog):
            text += (
                f"  mu {log.mu:.1e}  {'accepted' if log.accepted else 'rejected'}  "
                f"{log.seconds:.2f} s"
            )
            if len(levels) > 1:
                text += f"  {log.frames} frames"
        lines.append(text)
    return [*lines, "```", ""]


def centre_lines(centres: Mapping[str, Any]) -> list[str]:
    """report.md's table of the ball-joint centres against their regression (summary.json's
    ``joint_centres_vs_regression``): centres in the parent body's frame [mm]."""
    if not centres:
        return []
    lines = ["", "Ball-joint centres against their regression (parent frame, x y z mm; "
             "docs/model.md#hip-centres-regression-and-data):", "",
             "| joint | regression | regression centre | identified centre | distance (mm) "
             "| sd (mm) | moved by the data | other regression |",
             "|---|---|---|---|---|---|---|---|"]  # fmt: skip

    def xyz(v: Sequence[float] | None) -> str:
        return "n/a" if v is None else " ".join(f"{x:.1f}" for x in v)

    for joint, c in centres.items():
        other = next(((k[:-3], c[k]) for k in ("davis_mm", "harrington_mm") if k in c), None)
        alt = "" if other is None else f"{other[0]}: {xyz(other[1])}"
        lines.append(
            f"| {joint} | {c['regression']} | {xyz(c['regression_mm'])} | "
            f"{xyz(c['identified_mm'])} | {c['distance_mm']:.1f} | {c['distance_sd_mm']:.1f} | "
            f"{'yes' if c['moved_by_data'] else 'no'} | {alt} |"
        )
    return lines


#: report.md's words for each hip-centre regression.
HIP_SOURCES = {"harrington": "Harrington et al. 2007 (pelvis width and depth)",
               "davis": "Davis et al. 1991 (leg length, as Plug-in Gait)"}  # fmt: skip


def _anatomy_lines(summary: Mapping[str, Any]) -> list[str]:
    """The subject measurements used (value, source), prior weighting, parameters at a
    bound of their anatomical range."""
    if not summary.get("anatomical_priors"):
        return []
    lines = ["", "## Subject measurements and anatomical priors", ""]
    meas = summary.get("measurements", {})
    for n, m in meas.items():
        value = m["value"] if m["unit"] == "kg" else m["value"] * 1e3
        lines.append(f"- {n}: {value:g} {'kg' if m['unit'] == 'kg' else 'mm'} ({m['source']})")
    if not meas:
        lines.append("- no measurements: widths and the hip centres regressed from the markers")
    sex = summary.get("sex")
    if sex:
        lines.append(f"- sex: {sex['value']} ({sex['source']}): de Leva's table of the segments")
    est = summary.get("stature_estimate")
    if est:
        lines.append(
            f"- stature {est['value']:.2f} +- {est['sd']:.2f} m estimated from {est['source']} "
            "(no measured height): the anatomical ranges and stature-scaled priors use it"
        )
    w = summary.get("prior_weighting", {})
    if w:
        lines.append(f"- {weighting_text(w)}")
    per_trial = w.get("trial_weights") or []
    if len(per_trial) > 1:
        taus = w.get("trial_tau_frames") or [float("nan")] * len(per_trial)
        files = summary.get("markers_files") or []
        names = [Path(f).name for f in files] if len(files) == len(per_trial) else [
            f"trial {i}" for i in range(len(per_trial))]  # fmt: skip
        lines.append(
            "- trials weighed by their independent frames (frames over the residuals' "
            "correlation time): "
            + ", ".join(f"{n} {v:.2f} (correlation time {t:.1f} frames)" for n, v, t in
                        zip(names, per_trial, taus, strict=True))
        )  # fmt: skip
    hip = summary.get("hip_centre")
    if hip:
        lines.append(f"- hip centres: {HIP_SOURCES.get(hip, hip)}")
    lines += init_centre_lines(summary.get("init_centres") or {})
    axes = summary.get("joint_axes") or {}
    if axes:
        lines += ["", "Flexion axes (docs/model.md#flexion-axes): Plug-in Gait's chord plane "
                  "where the data determine the axis less well than the wand does (data sd "
                  "above the row's) and do not contradict it, else the markers'; varus-valgus "
                  "on flexion over the frames as correlation and slope (deg/deg):", "",
                  *axis_lines(axes), ""]  # fmt: skip
    bound = summary.get("kappa_at_bound", {})
    lines.append(
        "- parameters at a bound of their anatomical range: "
        + (", ".join(f"{n} ({b})" for n, b in bound.items()) or "none")
    )
    if summary.get("shoulder_note"):
        lines.append(f"- shoulders: {summary['shoulder_note']}")
    lines += standing_lines(summary.get("standing_knee_axes_deg") or {},
                            summary.get("standing_notes") or [])  # fmt: skip
    held = summary.get("joints_at_limit") or {}
    lines.append(
        "- joints held at a limit of their range (share of the fitted frames): "
        + (limits_text(held) or "none")
    )
    checks = report_line(summary.get("anatomy_checks"))
    if checks:
        lines.append(checks)
    return lines


def init_centre_lines(sources: dict[str, str]) -> list[str]:
    """report.md's line on the initial model's joint centres: the joints of each
    construction (docs/model.md#the-constructions-start-and-prior); none without
    ``init: constructed``."""
    if not sources:
        return []
    by: dict[str, list[str]] = {}
    for joint, how in sources.items():
        by.setdefault(how, []).append(joint)
    text = "; ".join(f"{', '.join(joints)}: {how}" for how, joints in by.items())
    return [f"- initial joint centres from the constructions on the recording: {text}"]


def weighting_text(w: Mapping[str, Any]) -> str:
    """report.md's line on the noise the priors were weighed against (summary.json's
    ``prior_weighting``): the noise of one independent observation when the residuals show
    soft tissue (:func:`~mocap_mj.solve.noise.artefact_noise`: the first solve's sigma,
    raised to the artefact's floor when correlated, times sqrt(tau)), else the nominal."""
    noise, sigma, tau = w["noise_mm"], w["sigma_mm"], w["tau_frames"]
    effective = artefact_noise(sigma * 1e-3, tau) * 1e3
    if abs(noise - effective) > 1e-6 * max(effective, 1.0):
        return (
            f"priors weighed against the nominal marker noise of {noise:.2f} mm (the first "
            f"solve's per-axis sigma {sigma:.2f} mm, residual correlation time {tau:.1f} "
            "frames: no soft-tissue artefact to weigh them against)"
        )
    floor = (
        f", raised to the soft-tissue floor {SOFT_TISSUE_SIGMA * 1e3:.0f} mm (its residuals "
        "are correlated)"
        if tau >= CORRELATED_TAU and sigma * 1e-3 < SOFT_TISSUE_SIGMA
        else ""
    )
    return (
        f"priors weighed against the noise of one independent marker observation, "
        f"{noise:.2f} mm: the first solve's per-axis sigma {sigma:.2f} mm{floor}, times the "
        f"square root of the residuals' correlation time, {tau:.1f} frames"
    )


def iterations_text(summary: Mapping[str, Any], final: int | None = None) -> str:
    """The LM iterations in the words of every output: the final solve's (summary.json's
    ``iterations``, report.md's Iterations section) and, when the identification solved more
    than once (the priors reweighed), all of them, as the progress bar counts them
    (summary.json's ``log``). ``final``: the final solve's count when the summary has none."""
    log = [e for e in summary.get("log") or [] if isinstance(e, str) and e.startswith("iter ")]
    solves = sum(1 for e in log if e.split()[1] == "1")
    text = f"{summary.get('iterations', final)} LM iterations"
    if solves <= 1:
        return text
    return f"{text} in the final solve, {len(log)} over its {solves} solves"


def expected_rmse(sigma: float, n_unknowns: int, n_residuals: int) -> float:
    """sqrt(3) sigma sqrt(1 - p / n) [m]: the fit RMSE that noise alone leaves."""
    return float(np.sqrt(3) * sigma * np.sqrt(max(1 - n_unknowns / n_residuals, 0.0)))


def result_text(summary: dict[str, Any], pset: ParameterSet, out: Path) -> str:
    held = summary.get("parameters_not_measured") or []
    measured = (
        f"{pset.size - len(held)} of {pset.size} parameters" if held else f"{pset.size} parameters"
    )
    why = []
    if summary.get("unmeasured_bodies"):
        why.append(f"no marker on {' '.join(summary['unmeasured_bodies'])}")
    if summary.get("markers_without_data"):
        why.append(f"no data for {_without_data(pset, summary, ' ')}")
    note = f"{len(held)} held at the prior ({'; '.join(why)})\n" if held else ""
    return (
        f"identified {measured} from {summary['frames_used']} frames in "
        f"{summary['seconds']:.2f} s ({iterations_text(summary)}, "
        f"{summary['termination']})\n"
        f"{note}"
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm, i.e. a per-axis noise sigma of "
        f"{summary['sigma_mm']:.3f} mm given {summary['n_unknowns']} unknowns and "
        f"{summary['n_residuals']} residuals; {summary['observable_directions']} of {pset.size} "
        f"directions observable, CRLB {summary['kappa_crlb_rms_mm']:.3f} mm (kinematic) / "
        f"{summary['offset_crlb_rms_mm']:.3f} mm (offsets)\n"
        f"wrote {out}/model.xml, theta.json, motion.npz, joint_centres.csv, segments.csv, "
        "identifiability.json, report.md" + _trials_text(summary, out)
    )


def _trials_text(summary: Mapping[str, Any], out: Path) -> str:
    """The output's words on the further trials' folders (none for one trial)."""
    later = [t for t in summary.get("trials") or [] if t.get("folder") not in (None, ".")]
    if not later:
        return ""
    first = (summary.get("trials") or [{}])[0]
    return (
        f"\n{first.get('name')}'s motion, angles and joint centres at the top of {out}; each "
        f"further trial's in {out}/trials/NAME/ (--trial NAME in export, render and view): "
        + ", ".join(str(t.get("name")) for t in later)
    )
