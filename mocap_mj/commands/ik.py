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
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.plausibility import AT_LIMIT_PRINT, joints_at_limit, limits_text
from mocap_mj.anatomy.tissue import recorded_sliding_model
from mocap_mj.capture.checks import check_markers, recorded_floor
from mocap_mj.commands.common import into_out_folder
from mocap_mj.outputs.ik_out import fit_fields, write_motion_csv
from mocap_mj.outputs.write_fit import frame_range
from mocap_mj.pipeline.motion import save_motion
from mocap_mj.pipeline.quality import Checked
from mocap_mj.pipeline.robust_ik import solve_motion
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.joint_centre_table import write_joint_centres_csv
from mocap_mj.skeleton.mjcf import load_written
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSettings, Status
from mocap_mj.solve.losses import LossName
from mocap_mj.solve.problem import TrialData

from ..errors import MocapError
from ..export.tables import write_angles_csv
from ._kinetics import (
    Prepared,
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
    check_trials,
    drop_excluded,
    notices_to_stderr,
    parse_marker_list,
    policy_of,
    quality_text,
    without_ghosts,
)
from ._subject import subject_from_args


def run(args: argparse.Namespace) -> int:
    args.marker_set_record = choose_marker_set(args, [args.markers])
    pset = ParameterSet(model_for(args))
    trial = load_trial(args.markers, pset.marker_names, args)
    sl = frame_range(args.frames, len(trial.markers), trial.path)
    if sl.stop - sl.start < 1:
        raise MocapError(f"{trial.path}: --frames {args.frames} selects no frame")
    excluded = parse_marker_list(args.exclude_markers, pset.marker_names)
    trial = trial._replace(markers=drop_excluded(trial.markers, pset, excluded))
    if args.min_markers is None:
        args.min_markers = recorded_floor(trial.markers[sl])
    check_markers(trial.path, pset.marker_names, trial.markers[sl], args.min_markers)
    # frames in the recording's own numbering (tables, messages, summary)
    first = trial.first_frame + sl.start
    with notices_to_stderr(args.command):
        found, quality = check_trials(
            pset, [Checked(trial.path, trial.markers[sl], trial.rate, first)], excluded,
            policy_of(args),
        )  # fmt: skip
    trial = trial._replace(
        markers=without_ghosts(trial.markers, pset, found, trial.path, trial.first_frame)
    )
    # the C3D's PROCESSING Bodymass, else the model's own (identify's, with a mass)
    given = subject_from_args(args, [args.markers])
    mass = given.get("mass") or model_mass(args.model)
    sex = given.sex[0] if given.sex else model_sex(args.model) or "male"
    kinetics = prepare(args, [str(trial.path)], mass, sex)  # the plates' bad input first
    return into_out_folder(
        args, lambda out: _solve_and_write(args, pset, trial, sl, out, quality, kinetics)
    )


def _write_files(pset: ParameterSet, motion: Any, qpos: np.ndarray, out: Path, first: int) -> None:
    """model.xml, motion.npz, motion.csv, joint_centres.csv and angles.csv of the IK's qpos
    (T, nq) [internal layout] into ``out``, frames numbered from ``first``."""
    model, times = pset.model, motion.times
    pset.export_mjcf(out / "model.xml", pset.nominal)
    written = Layout.of(model).written(qpos)
    save_motion(out / "motion.npz", replace(motion, qpos=written, first_frame=first))
    write_motion_csv(out / "motion.csv", load_written(out / "model.xml"), times, written, first)
    write_joint_centres_csv(out / "joint_centres.csv", model, times, qpos, first_frame=first)
    write_angles_csv(out / "angles.csv", model, times, qpos, first_frame=first)


def _kinetics_of(
    args: argparse.Namespace, kinetics: Prepared | None, out: Path, sl: slice
) -> tuple[dict[str, Any] | None, list[str]]:
    """summary.json's ``kinetics`` of the trial (:mod:`._kinetics`) and the files written."""
    if kinetics is None:
        return None, []
    entry, files = write_trial(args, kinetics, 0, out, "", sl)
    return summary_of(kinetics, [entry]), files


def _solve_and_write(
    args: argparse.Namespace,
    pset: ParameterSet,
    trial: Any,
    sl: slice,
    out: Path,
    quality: dict[str, Any] | None = None,
    kinetics: Prepared | None = None,
) -> tuple[dict[str, Any], str]:
    markers, times = trial.markers[sl], trial.times[sl]
    first = trial.first_frame + sl.start
    t0 = time.perf_counter()
    from .progress import frames_bar

    loss: LossName = args.loss
    settings = IKSettings(
        damping=args.damping, max_iterations=args.max_iterations, min_markers=args.min_markers
    )
    with frames_bar("IK", len(markers), enabled=not args.json) as progress:
        motion = solve_motion(
            pset, TrialData(str(trial.path), markers, times), loss=loss, settings=settings,
            sliding=not args.no_sliding_landmarks, progress=progress,
        )  # fmt: skip
    seconds = time.perf_counter() - t0
    print_marker_set(args)  # after the solve: a refusal stays one line
    result, model = motion.ik, pset.model
    assert result is not None  # solve_motion's motion carries its IK
    sliding = None if args.no_sliding_landmarks else recorded_sliding_model(model)
    _write_files(pset, motion, result.qpos, out, first)
    section, kinetic_files = _kinetics_of(args, kinetics, out, sl)
    n = len(markers)
    skipped = np.flatnonzero(result.status == Status.TOO_FEW_MARKERS)
    seen = np.any(np.all(np.isfinite(markers), axis=2), axis=0)
    never = [n for n, ok in zip(pset.marker_names, seen, strict=True) if not ok]
    rmse = result.rmse()
    summary = {
        "markers_file": str(trial.path),
        "model": str(pset.path),
        "marker_set": getattr(args, "marker_set_record", None),
        "frames": n,
        "frames_range": [first, first + n],
        "frames_solved": int(n - skipped.size),
        "frames_skipped": [first + int(i) for i in skipped],
        **fit_fields(rmse, float(np.nanmax(result.marker_rmse))),
        "iterations_mean": float(result.iterations.mean()),
        "converged_fraction": float(np.mean(result.status == Status.CONVERGED)),
        "seconds": seconds,
        "frames_per_second": n / seconds,
        "damping": args.damping,
        "loss": loss,
        "sliding_landmarks": None if sliding is None else sorted(sliding.slides),
        "markers_missing": list(trial.report.missing),
        "markers_without_data": never,
        "marker_quality": quality,
        "joints_at_limit": joints_at_limit(model, model.jnt_range, [result.qpos]),
        "kinetics": section,
    }
    held = limits_text(summary["joints_at_limit"], AT_LIMIT_PRINT)
    text = (
        f"{trial.report}\n"
        f"IK ({args.damping}): {n} frames in {seconds:.2f} s ({n / seconds:,.0f} frames/s), "
        f"marker RMSE {rmse * 1e3:.3f} mm, "
        f"{summary['converged_fraction']:.0%} converged"
        + (f", {skipped.size} frames skipped (too few markers)" if skipped.size else "")
        + (
            f"\n{', '.join(sorted(sliding.slides))} weighed down with their joint's angle, "
            "as the model's identification did (--no-sliding-landmarks: off)"
            if sliding is not None
            else ""
        )
        + _without_samples(never, trial.report.found)
        + ("" if quality is None else f"\n{quality_text(quality)}")
        + (f"\njoints held at a limit of their range: {held}" if held else "")
        + (f"\n{kin_text}" if section is not None and (kin_text := text_of(section)) else "")
        + f"\nwrote {args.out}/motion.csv, joint_centres.csv, angles.csv, motion.npz, "
        + "".join(f"{f}, " for f in kinetic_files)
        + "model.xml, summary.json"
    )
    return summary, text


def _without_samples(never: list[str], found: tuple[str, ...]) -> str:
    """The output's line on the file's markers without a valid sample (``never``: every
    model marker without one; only those the file has, ``found``, are the file's)."""
    empty = [n for n in never if n in found]
    return f"\nmarkers in the file without a valid sample: {', '.join(empty)}" if empty else ""
