"""``mocap-mj gait-report``: the gait report of walking trials (cycles, spatiotemporal
parameters, curves against a normative band, the Gait Profile Score)."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mocap_mj.commands._gait import add_events_option
from mocap_mj.commands.common import add_force_flag, add_json_flag, into_out_folder
from mocap_mj.commands.plug_in_gait import add_report_options


def register(sub: Any) -> None:
    p = sub.add_parser(
        "gait-report",
        help="the gait report: cycles, spatiotemporal parameters, scores, report.html",
        description="Each trial's gait events (the C3D's EVENT group, else its force plates, "
        "else the kinematics, or --events), each side's cycles from one foot strike to the "
        "next (incomplete ones dropped and said), every Plug-in Gait angle and, with force "
        "plates and a body mass, every moment and power resampled to 101 points per cycle. "
        "Writes OUT/cycles.csv (trial, side, cycle, variable, percent, value: degrees, N m/kg, "
        "W/kg), OUT/spatiotemporal.csv (per cycle, each side's mean and sd), OUT/scores.csv "
        "(with --normative: Gait Variable Scores and Gait Profile Score, Baker et al. 2009), "
        "OUT/report.html (one self-contained page) and OUT/summary.json.",
    )
    p.add_argument(
        "--markers",
        required=True,
        nargs="+",
        metavar="TRIAL",
        help="walking trials of one subject with the Plug-in Gait markers (C3D, TRC...)",
    )
    p.add_argument(
        "--static",
        metavar="STATIC",
        help="static trial for the subject values (foot offsets, leg lengths; as "
        "plug-in-gait --static) (default: each trial's PROCESSING values)",
    )
    p.add_argument(
        "--subject-file",
        metavar="FILE",
        help="subject values overriding the files' (as plug-in-gait --subject-file): YAML, "
        "Vicon's .vsk or .mp (default: none)",
    )
    p.add_argument(
        "--plates",
        default="all",
        metavar="LIST",
        help="the force plates whose contacts count for the kinetics: all (default), none, "
        "or plate numbers from 1, e.g. 1,4",
    )
    add_report_options(p)
    add_events_option(p)
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=run, trial_type="dynamic")


def run(args: argparse.Namespace) -> int:
    from ._gait import gait_report_files, read_inputs
    from .plug_in_gait import pig_run

    normative, events = read_inputs(args, args.markers)
    runs = [pig_run(args, path) for path in args.markers]

    def work(out: Path) -> tuple[Mapping[str, Any], str]:
        entry = gait_report_files(out, runs, normative, events)
        summary = {
            "command": "gait-report",
            "markers": list(args.markers),
            "static": args.static,
            "out": str(args.out),
            "angles": "Plug-in Gait's, from the markers",
            "subject": runs[0].result.subject.to_dict(),
            "gait_report": entry,
        }
        counts = [n for t in entry["cycles"].values() for n in t.values()]
        scores = entry["scores_omitted"] or (f"GPS {entry['gps_deg']['overall']:.2f} deg overall")
        text = (
            f"gait-report: {sum(counts)} cycles of {len(runs)} trials "
            f"({len(entry['dropped'])} dropped or without kinetics); {scores} -> {args.out}"
        )
        return summary, text

    return into_out_folder(args, work)
