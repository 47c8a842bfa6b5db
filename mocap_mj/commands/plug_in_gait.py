"""``mocap-mj plug-in-gait``: Plug-in Gait (Conventional Gait Model 1.0) on a C3D trial."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.commands._gait import add_events_option
from mocap_mj.commands.common import add_force_flag, add_json_flag, into_out_folder

from ..clinical.subject import PigSubject
from ..errors import MocapError


def register(sub: Any) -> None:
    p = sub.add_parser(
        "plug-in-gait",
        help="Plug-in Gait angles and joint centres, as Vicon Nexus computes them",
        description="Plug-in Gait (the Conventional Gait Model 1.0) from its published "
        "definitions: Davis hip centres, chord knee, ankle, shoulder, elbow and hand "
        "centres, the foot with the static offsets, Vicon's Cardan sequences and signs, "
        "pelvis, foot, thorax and head angles in the direction of progression. Subject "
        "values come from the C3D's PROCESSING group, then --static (offsets, inter-ASIS "
        "distance, leg lengths from the markers), then --subject-file. Writes OUT/angles.csv "
        "[deg], OUT/joint_centres.csv [mm, lab frame], OUT/result.c3d (Vicon's point "
        "names), OUT/summary.json and OUT/report.md; frames keep the recording's numbers. "
        "A C3D trial with force plates and a body mass also gives OUT/kinetics.csv: Plug-in "
        "Gait's joint moments, powers and forces and the ground reactions per kg (also in "
        "result.c3d under Vicon's names and units).",
    )
    p.add_argument("--markers", required=True, metavar="TRIAL", help="the trial (C3D, TRC...)")
    p.add_argument(
        "--static",
        metavar="STATIC",
        help="static trial: its foot offsets replace the trial's; refused when its pelvis "
        "and leg markers move (--trial-type auto's rule), as a walk given for the static "
        "or the two files swapped (default: the trial's PROCESSING values; a trial that is "
        "itself static gives its own)",
    )
    p.add_argument(
        "--subject-file",
        metavar="FILE",
        help="subject values overriding the file's: a YAML file (measurements as in "
        "summary.json, and static_plantar_flex_l, static_rot_off_l, asis_trochanter_l, "
        "tibial_torsion_l, sole_delta_l, head_offset with a unit; Nexus' static options "
        "flat_foot_l, head_level: true or false), or Vicon's .vsk or .mp subject file "
        "(Plug-in Gait's names and the C3D PROCESSING group's units: mm, kg, rad) "
        "(default: none; a static's flat foot is told by its given offsets)",
    )
    p.add_argument(
        "--trial-type",
        choices=("auto", "static", "dynamic"),
        default="auto",
        help="static: the trial gives its own foot offsets and the static model's foot (as "
        "Nexus' static pipeline); dynamic: the offsets of the PROCESSING group, --static or "
        "--subject-file; auto (default): static when no --static is given and the pelvis "
        "and leg markers stay within 0.1 m of their median positions",
    )
    p.add_argument(
        "--plates",
        default="auto",
        metavar="LIST",
        help="the force plates whose contacts count for the kinetics: auto (default: the "
        "contacts the recording's own ground reactions count, as Nexus' "
        "LGroundReactionForce, its manual choices included; without them as all), all "
        "(each plate while one foot alone stands on it), none (no kinetics), or plate "
        "numbers from 1, e.g. 1,4 (a lab's choice of valid strikes)",
    )
    p.add_argument(
        "--report",
        action="store_true",
        help="also the gait report: OUT/cycles.csv, spatiotemporal.csv, scores.csv (with "
        "--normative) and report.html, as gait-report writes them (default: off)",
    )
    add_report_options(p)
    add_events_option(p)
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=run)


def add_report_options(p: Any) -> None:
    """``--normative`` (and the report it belongs to)."""
    p.add_argument(
        "--normative",
        metavar="FILE",
        help="normative set (CSV: variable,percent,mean,sd; docs/clinical.md): its band in "
        "every plot, and the Gait Variable Scores and Gait Profile Score in scores.csv "
        "(default: none; the plots show the two sides only and the scores are omitted)",
    )


@dataclass(frozen=True)
class PigRun:
    """One trial through Plug-in Gait: the file, its trajectory, the result, its kinetic
    outputs (None without plates or mass) and the kinetics' notes."""

    path: str
    trial: Any
    result: Any
    kinetics: dict[str, np.ndarray] | None
    notes: list[str]


def pig_run(args: argparse.Namespace, path: str) -> PigRun:
    """Plug-in Gait on the trial ``path`` with the command's --static, --subject-file,
    --trial-type and --plates."""
    from ..clinical import pig_from_file, plug_in_gait
    from ..io.load import load_markers

    trial = load_markers(path)
    subject = _file_subject(path)
    static = None
    if args.static:
        static = load_markers(args.static)
        subject = _file_subject(args.static).update(subject)
    extra = pig_from_file(args.subject_file) if args.subject_file else None
    rotation = np.asarray(trial.source.get("rotation", np.eye(3)), dtype=float)
    frames = trial.first_frame + np.arange(trial.n_frames)
    result = plug_in_gait(
        trial,
        subject,
        static,
        frames=frames,
        to_lab=rotation.T,
        override=extra,
        trial_type=getattr(args, "trial_type", "auto"),
    )
    kinetics, notes = _kinetics(path, args.plates, trial, result, rotation.T)
    return PigRun(path, trial, result, kinetics, notes)


def gait_trial(run: PigRun) -> Any:
    """The run as a trial of the gait report (:class:`~mocap_mj.commands._gait.GaitTrial`)."""
    from ._gait import GaitTrial

    return GaitTrial(run.path, run.trial, run.result.angles, run.kinetics, tuple(run.notes))


def run(args: argparse.Namespace) -> int:
    from mocap_mj.outputs.plug_in_gait import write_all

    from ._gait import gait_report_files, read_inputs

    report = args.report or args.normative is not None or args.events is not None
    normative, events = read_inputs(args, [args.markers]) if report else (None, None)
    pig = pig_run(args, args.markers)
    result, kinetics, kinetic_notes, trial = pig.result, pig.kinetics, pig.notes, pig.trial

    def work(out: Path) -> tuple[Mapping[str, Any], str]:
        write_all(out, result, trial.rate, str(args.markers), kinetics, kinetic_notes)
        summary = {"markers": str(args.markers), "static": args.static, "out": str(args.out)}
        summary |= result.summary()
        summary["kinetics"] = sorted(kinetics) if kinetics else []
        summary["kinetics_notes"] = kinetic_notes
        if report:
            subject = result.subject.to_dict()
            entry = gait_report_files(out, [gait_trial(pig)], normative, events, subject)
            summary["gait_report"] = entry
            summary["implausible"] = entry["implausible"]
        text = (
            f"plug-in-gait: {len(result.angles)} angles, {len(result.points)} bone points, "
            f"{len(kinetics or {})} kinetic outputs, {trial.n_frames} frames "
            f"({'static' if result.static else 'dynamic'} trial) -> {args.out}"
        )
        return summary, text

    return into_out_folder(args, work)


def _counted(text: str) -> set[int] | None:
    """--plates: None for auto and all, the empty set for none, else the plate numbers."""
    if text in ("auto", "all"):
        return None
    if text == "none":
        return set()
    try:
        numbers = {int(v) for v in text.split(",")}
    except ValueError:
        numbers = {0}
    if min(numbers) < 1:
        raise MocapError(
            f"--plates {text!r}: expected auto, all, none or plate numbers such as 1,4"
        )
    return numbers


def _kinetics(
    path: str, plates_text: str, trial: Any, result: Any, to_lab: np.ndarray
) -> tuple[dict[str, np.ndarray] | None, list[str]]:
    """The kinetic outputs when the trial is a C3D with plates and the subject a mass."""
    from ..clinical.kinetics import trial_kinetics
    from ..io.plates import read_plates, recorded_ground_reactions

    counted = _counted(plates_text)
    if counted == set() or Path(path).suffix.lower() != ".c3d":
        return None, []
    plates = read_plates(path, marker_rate=trial.rate, window="centred", offsets="none")
    if not plates:
        return None, ["no kinetics: the trial has no force plates"]
    mass = result.subject.measured("mass")
    if mass is None:
        return None, ["no kinetics: no body mass (PROCESSING:Bodymass, or mass in --subject-file)"]
    if len(plates[0].force) != trial.n_frames:
        raise MocapError(
            f"{path}: the plates hold {len(plates[0].force)} frames, the markers "
            f"{trial.n_frames}; expected the same frames"
        )
    return trial_kinetics(
        result.segments,
        result.centres,
        plates,
        trial,
        body_mass=mass,
        progression=result.progression @ to_lab,
        to_lab=to_lab,
        counted=counted,
        recorded=recorded_ground_reactions(path) if plates_text == "auto" else None,
    )


def _file_subject(path: str) -> PigSubject:
    """The subject values a C3D file stores (none for other formats)."""
    from ..clinical import pig_from_c3d

    return pig_from_c3d(path) if Path(path).suffix.lower() == ".c3d" else PigSubject()
