"""The gait report of ``gait-report`` and ``plug-in-gait --report``: the inputs read before
any output (the normative file, the events files), each trial's gait events and cycles, and
the report's files (:mod:`mocap_mj.outputs.gait_html`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mocap_mj.capture.events import GaitEvent, gait_events, read_events_csv
from mocap_mj.clinical.gait_scores import Normative, read_normative
from mocap_mj.errors import MocapError


def add_events_option(p: Any) -> None:
    """``--events``."""
    p.add_argument(
        "--events",
        nargs="+",
        metavar="FILE",
        help="gait events, one events.csv per marker file in order (side, kind, frame, "
        "time_s, source: what ik, identify and synth write) (default: the C3D's EVENT "
        "group, else its force plates, else the kinematics; docs/clinical.md)",
    )


def read_inputs(
    args: argparse.Namespace, markers: Sequence[str]
) -> tuple[Normative | None, list[list[GaitEvent]] | None]:
    """--normative and --events, read (bad input raises here, before any output)."""
    normative = read_normative(args.normative) if args.normative else None
    if args.events is None:
        return normative, None
    if len(args.events) != len(markers):
        raise MocapError(
            f"--events: expected one events.csv per marker file ({len(markers)}), got "
            f"{len(args.events)}"
        )
    return normative, [read_events_csv(p) for p in args.events]


def trial_events(path: str, trial: Any) -> list[GaitEvent]:
    """The trial's gait events: the C3D's EVENT group, else its plates' (the feet that alone
    stand on them), else the kinematics (:func:`~mocap_mj.capture.events.gait_events`)."""
    from mocap_mj.capture.contacts import assign_feet
    from mocap_mj.io.plates import read_plates

    loads = None
    if Path(path).suffix.lower() == ".c3d":
        try:
            plates = read_plates(path, marker_rate=trial.rate)
            loads = assign_feet(plates, trial) if plates else None
        except MocapError:
            loads = None  # the plates cannot tell: the kinematics do
    try:
        return gait_events(path, trial, loads=loads)
    except MocapError as exc:
        raise MocapError(f"{path}: gait events: {exc}") from None


def gait_report_files(
    out: Path,
    runs: Sequence[Any],
    normative: Normative | None,
    events: Sequence[Sequence[GaitEvent]] | None,
) -> dict[str, Any]:
    """The report's files of the Plug-in Gait ``runs`` (:class:`~mocap_mj.commands.
    plug_in_gait.PigRun`) into ``out``; summary.json's ``gait_report`` entry."""
    from mocap_mj.outputs.gait_html import write_gait_report
    from mocap_mj.outputs.gait_report import trial_cycles

    trials = []
    notes = []
    names = _names([r.path for r in runs])
    for i, run in enumerate(runs):
        found = list(events[i]) if events is not None else trial_events(run.path, run.trial)
        trials.append(trial_cycles(names[i], found, run.trial, run.result.angles, run.kinetics))
        notes += [f"{names[i]}: {n}" for n in run.notes]
    subject = runs[0].result.subject.to_dict() if runs else {}
    entry = write_gait_report(out, trials, normative, subject, notes)
    if not any(t.cycles for t in trials):
        entry["note"] = "no complete gait cycle in the trials' events"
    return entry


def _names(paths: Sequence[str]) -> list[str]:
    """The trials' names in the tables: the file stems, numbered when two are alike."""
    stems = [Path(p).stem for p in paths]
    return [s if stems.count(s) == 1 else f"{s}_{i + 1}" for i, s in enumerate(stems)]
