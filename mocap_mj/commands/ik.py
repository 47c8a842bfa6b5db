"""``mocap-mj ik``: joint motion of a given model from a marker file.

Inverse kinematics of one marker file with a given model (the bundled humanoid unless
--model): each frame's joint angles minimise the distance between the model's marker sites and
the measured markers (Levenberg-Marquardt, frames solved in chains warm-started from their
neighbours). Writes OUT/motion.csv (joint angles, mm and degrees), angles.csv (the model's
angles in Plug-in Gait's conventions, the table `mocap-mj plug-in-gait` writes), motion.npz
(qpos, times, markers; opened by `mocap-mj view`), model.xml and summary.json. Frames with
fewer than --min-markers present markers are left unsolved (empty in motion.csv). A model written by
identify with the landmarks' soft-tissue sliding model (recorded in its model.xml) weighs
them as identify did, so that its RMSE reproduces the fit (--no-sliding-landmarks: every
marker alike). The marker data are checked first, as by identify (warnings; --quality,
--exclude-markers). With force plates (a C3D's own, or --forces) and a body mass (the C3D's
PROCESSING Bodymass, else a --model identify wrote with a mass), the joint moments:
dynamics.csv, grf.csv (each foot's load) and root_residuals.csv (docs/dynamics.md); the gait
events go to events.csv.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, NamedTuple

from mocap_mj.anatomy.plausibility import AT_LIMIT_PRINT, limits_text
from mocap_mj.commands.common import into_out_folder
from mocap_mj.outputs.ik_folder import ik_summary, write_ik_files
from mocap_mj.outputs.write_fit import frame_range
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.pipeline.track import CheckedTrial, Tracked, TrackOptions, checked_trial, track
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSettings
from mocap_mj.solve.problem import TrialData

from ..errors import MocapError
from ._kinetics import Prepared as Loads
from ._kinetics import (
    model_mass,
    model_sex,
    prepare,
    summary_of,
    text_of,
    write_trial,
)
from ._markers import (
    choose_marker_set,
    load_trial,
    model_for,
    print_marker_set,
)
from ._quality import (
    notices_to_stderr,
    parse_marker_list,
    policy_of,
    quality_text,
)
from ._subject import subject_from_args


class Prepared(NamedTuple):
    """What ``ik`` has read and checked before it writes anything: the model's parameter
    set, the trial as loaded, the checked trial ready to solve, the IK's options and the
    plates' kinetics (:func:`~._kinetics.prepare`)."""

    pset: ParameterSet
    trial: Any
    checked: CheckedTrial
    options: TrackOptions
    kinetics: Loads


def run(args: argparse.Namespace) -> int:
    ready = prepared(args)
    return into_out_folder(args, lambda out: written(args, ready, out)[:2])


def prepared(args: argparse.Namespace) -> Prepared:
    """The model, the trial and its plates read and checked from ``args`` (``ik``'s options):
    bad input refused here, before any output."""
    args.marker_set_record = choose_marker_set(args, [args.markers])
    pset = ParameterSet(model_for(args))
    trial = load_trial(args.markers, pset.marker_names, args)
    sl = frame_range(args.frames, len(trial.markers), trial.path)
    if sl.stop - sl.start < 1:
        raise MocapError(f"{trial.path}: --frames {args.frames} selects no frame")
    options = TrackOptions(
        rows=sl,
        excluded=tuple(parse_marker_list(args.exclude_markers, pset.marker_names)),
        settings=IKSettings(
            damping=args.damping, max_iterations=args.max_iterations, min_markers=args.min_markers
        ),
        loss=args.loss,
        sliding=not args.no_sliding_landmarks,
        policy=policy_of(args),
    )
    recording = TrialData(str(trial.path), trial.markers, trial.times)
    with notices_to_stderr(args.command):
        checked = checked_trial(
            pset, str(trial.path), recording, trial.first_frame, trial.rate, options
        )
    # the C3D's PROCESSING Bodymass, else the model's own (identify's, with a mass)
    given = subject_from_args(args, [args.markers])
    mass = given.get("mass") or model_mass(args.model)
    sex = given.sex[0] if given.sex else model_sex(args.model) or "male"
    kinetics = prepare(args, [str(trial.path)], mass, sex)  # the plates' bad input first
    return Prepared(pset, trial, checked, options, kinetics)


def _kinetics_of(
    args: argparse.Namespace, kinetics: Loads | None, out: Path, sl: slice
) -> tuple[dict[str, Any] | None, list[str]]:
    """summary.json's ``kinetics`` of the trial (:mod:`._kinetics`) and the files written."""
    if kinetics is None:
        return None, []
    entry, files = write_trial(args, kinetics, 0, out, "", sl)
    return summary_of(kinetics, [entry]), files


def written(
    args: argparse.Namespace, ready: Prepared, out: Path
) -> tuple[dict[str, Any], str, Tracked]:
    """The trial's motion solved and ``ik``'s files written into ``out``: summary.json's
    content (not yet written), the stdout text and the motion."""
    from .progress import frames_bar

    pset, trial, checked, options, kinetics = ready

    n = len(checked.trial.markers)
    with frames_bar("IK", n, enabled=not args.json) as progress:
        tracked = track(pset, checked, options, progress)
    print_marker_set(args)  # after the solve: a refusal stays one line
    write_ik_files(pset, tracked, out)
    section, kinetic_files = _kinetics_of(args, kinetics, out, options.rows)
    head = {
        "markers_file": str(trial.path),
        "model": str(pset.path),
        "marker_set": getattr(args, "marker_set_record", None),
        "markers_missing": list(trial.report.missing),
    }
    summary = ik_summary(pset, tracked, options, head, section)
    text = _text(args, summary, trial, section, kinetic_files, tracked.quality)
    return summary, text, tracked


def _text(
    args: argparse.Namespace,
    summary: dict[str, Any],
    trial: Any,
    section: dict[str, Any] | None,
    kinetic_files: list[str],
    quality: MarkerQuality,
) -> str:
    """The command's stdout lines on the IK ``summary`` (summary.json's content) and the
    trial's marker-data ``quality``."""
    n, seconds = summary["frames"], summary["seconds"]
    skipped = len(summary["frames_skipped"])
    slides = summary["sliding_landmarks"]
    never = summary["markers_without_data"]
    held = limits_text(summary["joints_at_limit"], AT_LIMIT_PRINT)
    return (
        f"{trial.report}\n"
        f"IK ({args.damping}): {n} frames in {seconds:.2f} s ({n / seconds:,.0f} frames/s), "
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm, "
        f"{summary['converged_fraction']:.0%} converged"
        + (f", {skipped} frames skipped (too few markers)" if skipped else "")
        + (
            f"\n{', '.join(slides)} weighed down with their joint's angle, "
            "as the model's identification did (--no-sliding-landmarks: off)"
            if slides is not None
            else ""
        )
        + _without_samples(never, trial.report.found)
        + f"\n{quality_text(quality)}"
        + (f"\njoints held at a limit of their range: {held}" if held else "")
        + (f"\n{kin_text}" if section is not None and (kin_text := text_of(section)) else "")
        + f"\nwrote {args.out}/motion.csv, joint_centres.csv, angles.csv, motion.npz, "
        + "".join(f"{f}, " for f in kinetic_files)
        + "model.xml, summary.json"
    )


def _without_samples(never: list[str], found: tuple[str, ...]) -> str:
    """The output's line on the file's markers without a valid sample (``never``: every
    model marker without one; only those the file has, ``found``, are the file's)."""
    empty = [n for n in never if n in found]
    return f"\nmarkers in the file without a valid sample: {', '.join(empty)}" if empty else ""
