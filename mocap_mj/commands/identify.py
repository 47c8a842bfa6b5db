"""``mocap-mj identify``: the subject's model (segment lengths, marker offsets) and motion.

Identify the subject's model from one or more marker trials: the segment lengths and joint
positions (kinematic parameters) and every marker's offset on its segment, together with the
joint motion of every frame, by one Levenberg-Marquardt fit over all frames; the choices of
the identification come from a YAML --recipe, the subject's measurements from the C3D files,
a --subject-file, --height and --mass (docs/cli.md). Writes OUT/model.xml (the identified MJCF),
theta.json, per trial its motion.npz, angles.csv (the model's angles in Plug-in Gait's
conventions; report.md compares them with the Nexus angles a C3D holds), joint_centres.csv
and marker_error.png (the first trial's at the top of OUT, each further trial's in
OUT/trials/<its file's stem>/; export and render --trial choose one), identifiability.json,
report.md (a section per trial), plots and summary.json; docs/outputs.md explains
them. The folder appears
only when the fit is complete; a fit that cannot be determined by the data is refused.
Before the fit the marker data are checked for markers that do not move with their segment
(mislabels, label swaps, re-stuck markers, impossible distances): each finding is a warning
on stderr and in summary.json and report.md (--quality refuse: refused); --exclude-markers
drops markers' data. The anatomical fit also checks T10's placement against the stature (a
``placement`` finding, a warning like the others; --quality refuse refuses it too, before
the fit).
With force plates (a C3D's own, or --forces, one file per marker file) and a body mass, every
such trial's joint moments (dynamics.csv, grf.csv, root_residuals.csv, in the trial's
folder) and model.xml with the segments' masses and inertias (docs/dynamics.md: de Leva's, or
with the recipe's ``inertia: fit`` the masses fitted to the plates); every trial's gait events
go to events.csv.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mocap_mj.anatomy.inertia import BodyInertia, segment_inertia, with_inertials
from mocap_mj.anatomy.plausibility import plausibility_text
from mocap_mj.commands.common import into_out_folder
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.ownership import scratch_folder
from mocap_mj.outputs.inertia_out import fit_inertia, inertia_text, without_fit
from mocap_mj.outputs.inertia_out import report_section as inertia_report
from mocap_mj.outputs.write_fit import frame_range, result_text, write_result
from mocap_mj.pipeline.api import Hooks, identify_prepared, select_count
from mocap_mj.pipeline.fit import Fit
from mocap_mj.pipeline.prepare import ModelChoice, Prepared, Recording, checked, selected
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.trials import trial_folders
from mocap_mj.skeleton import prewarm
from mocap_mj.skeleton.mjcf import load_model
from mocap_mj.skeleton.parameters import ParameterSet

from ._kinetics import Prepared as KineticsPrepared
from ._kinetics import (
    prepare,
    report_section,
    stance_trials,
    summary_of,
    text_of,
    write_trial,
)
from ._markers import (
    choose_marker_set,
    load_trial,
    model_for,
    print_marker_set,
    set_file,
)
from ._quality import notices_to_stderr, quality_text
from ._subject import subject_from_args


def run(args: argparse.Namespace) -> int:
    # Long C3D recordings are read chunk by chunk into memory maps in a scratch folder that
    # lives as long as the command (load_trial).
    with scratch_folder(prefix="mocap-mj-identify-") as scratch:
        return _run(args, Path(scratch))


def _run(args: argparse.Namespace, scratch: Path) -> int:
    inputs = checked_inputs(args, recipe_from_args(args), scratch)
    return into_out_folder(args, lambda out: identified(args, inputs, out)[1:])


class Inputs(NamedTuple):
    """What :func:`checked_inputs` gives :func:`identified`: the fit's trials, the loaded
    files, the frames to select (None: all), the reading time [s] and the plates."""

    prepared: Prepared
    loaded: list[Any]
    frames_selected: int | None
    read_seconds: float
    kinetics: KineticsPrepared


def checked_inputs(args: argparse.Namespace, recipe: Recipe, scratch: Path | None) -> Inputs:
    """The marker files of ``args.markers`` read as the reading flags say (long ones chunk by
    chunk into ``scratch``) and prepared for the fit as ``recipe`` says
    (:mod:`mocap_mj.pipeline.prepare`), the subject's measurements and the plates read; every
    bad input refused before the quality check's notices (on stderr)."""
    t0 = time.perf_counter()
    # the recipe's choices where the command reads them (the model, the frames of kinetics)
    args.model, args.marker_set, args.frames = recipe.model, recipe.marker_set, recipe.frames
    args.marker_set_record = choose_marker_set(args, list(args.markers))
    model = ModelChoice(ParameterSet(model_for(args)), set_file(args))
    pset = model.pset
    loaded = [load_trial(path, pset.marker_names, args, scratch) for path in args.markers]
    read_seconds = time.perf_counter() - t0
    recordings = [
        Recording(t.path, t.markers, t.times, t.rate, t.first_frame, own=True) for t in loaded
    ]  # the command's own copies: labels are corrected, ghosts dropped in them
    chosen = selected(recordings, recipe, pset)  # frames, exclusions, usable frames
    subject = subject_from_args(args, [t.path for t in loaded])  # bad input before any output
    kinetics = prepare(args, [str(t.path) for t in loaded], subject.get("mass"), subject.table)
    with notices_to_stderr(args.command):  # after every bad-input error but the library's
        prepared = checked(chosen, recipe, subject, model)
    count = select_count(recipe.select, sum(len(t.markers) for t in prepared.trials),
                         len(prepared.trials))  # fmt: skip
    return Inputs(prepared, loaded, count, read_seconds, kinetics)


def recipe_from_args(args: argparse.Namespace) -> Recipe:
    """The recipe of ``--recipe`` (default: :class:`Recipe`'s defaults), each of its fields
    that a flag sets replaced by the flag's value when given (``--loss``, ``--model``,
    ``--marker-set``, ``--exclude-markers``, ``--frames``; ``--quality`` warn or refuse,
    ``--no-sliding-landmarks`` when given)."""
    recipe = Recipe.load(args.recipe) if args.recipe else Recipe()
    given: dict[str, Any] = {
        "loss": args.loss,
        "model": getattr(args, "model", None),
        "marker_set": getattr(args, "marker_set", None),
        "frames": args.frames,
        "exclude_markers": None
        if args.exclude_markers is None
        else tuple(n.strip() for n in args.exclude_markers.split(",") if n.strip()),
        "relabel": False if args.no_relabel else None,
        "strict": True if args.strict else None,
        "sliding_landmarks": False if getattr(args, "no_sliding_landmarks", None) else None,
    }
    return replace(recipe, **{k: v for k, v in given.items() if v is not None})


def _inputs(args: argparse.Namespace, loaded: list[Any], seconds: float | None) -> dict[str, Any]:
    """summary.json's record of the inputs: marker files, reading time, the marker set."""
    return {
        "markers_files": [t.path for t in loaded],
        "read_seconds": seconds,
        "marker_set": getattr(args, "marker_set_record", None),
    }


def _measured_text(summary: dict[str, Any]) -> str:
    """The output's line of the subject measurements (mm and kg) with their sources."""
    measured = "; ".join(
        f"{n} {m['value'] * (1 if m['unit'] == 'kg' else 1e3):g} "
        f"{'kg' if m['unit'] == 'kg' else 'mm'} ({m['source']})"
        for n, m in summary["measurements"].items()
    )
    return f"measurements: {measured or 'none (regressions from the markers)'}\n"


def _kinetics_into(
    args: argparse.Namespace,
    kinetics: KineticsPrepared,
    loaded: list[Any],
    out: Path,
    summary: dict[str, Any],
    choice: str,
) -> str:
    """:func:`_write_kinetics` into ``out`` and ``summary`` (the recipe's ``inertia``
    ``choice``); the output's kinetics lines."""
    section, fit = _write_kinetics(args, kinetics, loaded, out, choice)
    summary["kinetics"] = section
    lines = text_of(section)
    if fit is not None:
        summary["inertia"] = fit
        lines = "\n".join([lines, *inertia_text(fit)]).lstrip("\n")
    return f"{lines}\nwrote {Path(args.out)}/{', '.join(section['files'])}\n".lstrip("\n")


def _write_kinetics(
    args: argparse.Namespace,
    kinetics: KineticsPrepared,
    loaded: list[Any],
    out: Path,
    choice: str,
) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Every trial's events and kinetics (:mod:`._kinetics`) into ``out``, model.xml's
    inertial parameters (:func:`_segment_inertia`); summary.json's ``kinetics`` and its
    ``inertia`` (None: the recipe's ``inertia`` is the regression)."""
    folders = trial_folders([t.path for t in loaded])
    rows = [frame_range(args.frames, len(t.markers), t.path) for t in loaded]
    fitted, fit = _segment_inertia(args, kinetics, out, (folders, rows), choice)
    entries, files = [], []
    for i, (folder, sl) in enumerate(zip(folders, rows, strict=True)):
        entry, written = write_trial(args, kinetics, i, out, folder, sl, fitted)
        entries.append(entry)
        files += written
    section = summary_of(kinetics, entries)
    section["files"] = files
    section["inertials_in_model"] = kinetics.mass is not None
    report = out / "report.md"
    if report.is_file():
        extra = "" if fit is None else inertia_report(fit)
        atomic_write_text(report, report.read_text() + report_section(section) + extra)
    return section, fit


def _segment_inertia(
    args: argparse.Namespace,
    kinetics: KineticsPrepared,
    out: Path,
    trials: tuple[list[str], list[slice]],
    choice: str,
) -> tuple[BodyInertia | None, dict[str, Any] | None]:
    """With a known body mass, model.xml's ``<inertial>`` elements (a dynamic MuJoCo model;
    the kinematics are unchanged): de Leva's parameters, or with ``choice`` "fit" the masses
    fitted over the stance frames of the trials (``trials``: each one's folder and rows;
    :mod:`mocap_mj.outputs.inertia_out`). The fitted parameters (None: de Leva's) and
    summary.json's ``inertia`` (None when ``choice`` is the regression)."""
    model_xml = out / "model.xml"
    fitted, fit = None, None
    if choice == "fit":
        with notices_to_stderr(args.command):
            if kinetics.mass is None or not any(t is not None for t in kinetics.loads):
                fit = without_fit(kinetics.refused or "no force plates")
            else:
                found = stance_trials(kinetics, out, *trials)
                inertia, fit = fit_inertia(model_xml, found, kinetics.mass, sex=kinetics.sex)
                fitted = inertia if fit["source"] == "fit" else None
    if kinetics.mass is not None:
        inertia = fitted or segment_inertia(load_model(model_xml), kinetics.mass, sex=kinetics.sex)
        atomic_write_text(model_xml, with_inertials(model_xml.read_text(), inertia))
    return fitted, fit


def identified(
    args: argparse.Namespace, inputs: Inputs, out: Path
) -> tuple[Fit, dict[str, Any], str]:
    """The library's fit of ``inputs`` (:func:`~mocap_mj.pipeline.api.identify_prepared`)
    written into ``out`` (:func:`~mocap_mj.outputs.write_fit.write_result`, the kinetics);
    the fit, the summary and the output's text."""
    prepared, loaded, count, read_seconds, kinetics = inputs
    prewarm.start()  # the identification kernels compile on the other core meanwhile
    from .progress import frames_bar, progress_bar

    pset = prepared.pset
    total = sum(len(t.markers) for t in prepared.trials) if count is not None else 0
    # Every frame's motion of a long recording is written chunk by chunk into a folder beside
    # the output (one file system: write_result moves the files in).
    with (
        scratch_folder(out.parent, prefix=".mocap-mj-motion-") as sink,
        progress_bar("identify (LM)", enabled=not args.json) as progress,
        frames_bar(
            "IK of every frame", total, enabled=count is not None and not args.json
        ) as motion_progress,
    ):
        hooks = Hooks(progress, motion_progress, Path(sink))
        fit = identify_prepared(prepared, None, prepared.recipe.settings(), hooks)
        summary = write_result(fit, out, inputs=_inputs(args, loaded, read_seconds), force=True)
    kinetic_text = (
        ""
        if kinetics is None
        else _kinetics_into(args, kinetics, loaded, out, summary, prepared.recipe.inertia)
    )
    print_marker_set(args)  # after the fit: a refusal stays one line
    for f in fit.findings:
        if f.kind == "placement":  # found in the identification, after the stature
            print(f"mocap-mj {args.command}: warning: {f.message}", file=sys.stderr)
    for note in [summary.get("shoulder_note"), *(summary.get("standing_notes") or [])]:
        if note:
            print(f"mocap-mj {args.command}: warning: {note}", file=sys.stderr)
    per_marker = np.array(list(fit.report.checks.marker_rmse_by_marker.values()))
    outside = fit.kappa_outside_bounds()
    reports = "\n".join(str(t.report) for t in loaded)
    text = f"{reports}\n{result_text(summary, pset, Path(args.out))}\n"
    if count is not None:
        text += (
            f"identified on {sum(map(len, summary['frames_selected']))} of {total} frames "
            "chosen for pose diversity (--select); motion.npz and joint_centres.csv: every "
            f"frame by IK with the identified model, marker RMSE "
            f"{summary['motion_marker_rmse_mm']:.3f} mm\n"
        )
    text += _measured_text(summary)
    est = summary.get("stature_estimate")
    if est:
        text += (
            f"stature {est['value']:.2f} +- {est['sd']:.2f} m estimated from {est['source']} "
            "(no measured height)\n"
        )
    text += quality_text(fit.report.quality) + "\n"
    text += kinetic_text
    plaus = plausibility_text(
        pset,
        per_marker,
        outside,
        at_bound=summary["kappa_at_bound"],
        at_limit=summary["joints_at_limit"],
    )
    return fit, summary, text + plaus
