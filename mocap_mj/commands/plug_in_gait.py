"""``mocap-mj plug-in-gait``: Plug-in Gait (Conventional Gait Model 1.0) on a C3D trial."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.commands.common import add_force_flag, add_json_flag, into_out_folder

from ..clinical.subject import PigSubject


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
        "names), OUT/summary.json and OUT/report.md; frames keep the recording's numbers.",
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
        "tibial_torsion_l, head_offset with a unit), or Vicon's .vsk or .mp subject file "
        "(Plug-in Gait's names and the C3D PROCESSING group's units: mm, kg, rad) "
        "(default: none)",
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
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mocap_mj.outputs.plug_in_gait import write_all

    from ..clinical import pig_from_file, plug_in_gait
    from ..io.load import load_markers

    trial = load_markers(args.markers)
    subject = _file_subject(args.markers)
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
        trial_type=args.trial_type,
    )

    def work(out: Path) -> tuple[Mapping[str, Any], str]:
        write_all(out, result, trial.rate, str(args.markers))
        summary = {"markers": str(args.markers), "static": args.static, "out": str(args.out)}
        summary |= result.summary()
        text = (
            f"plug-in-gait: {len(result.angles)} angles, {len(result.points)} bone points, "
            f"{trial.n_frames} frames ({'static' if result.static else 'dynamic'} trial) "
            f"-> {args.out}"
        )
        return summary, text

    return into_out_folder(args, work)


def _file_subject(path: str) -> PigSubject:
    """The subject values a C3D file stores (none for other formats)."""
    from ..clinical import pig_from_c3d

    return pig_from_c3d(path) if Path(path).suffix.lower() == ".c3d" else PigSubject()
