"""``mocap-mj gait-report``: the gait report of walking trials (cycles, spatiotemporal
parameters, curves against a normative band, the Gait Profile Score)."""

from __future__ import annotations

import argparse
import shutil
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from mocap_mj.clinical.subject import pig_dict
from mocap_mj.commands.common import into_out_folder
from mocap_mj.errors import MocapError
from mocap_mj.outputs.gait_report import AnglesSource, source_fields


def run(args: argparse.Namespace) -> int:
    from ..io.load import load_markers
    from ..io.ownership import scratch_folder
    from ._gait import identified_trials, is_plug_in_gait, read_inputs

    normative, events = read_inputs(args, args.markers)
    kinds = [is_plug_in_gait(load_markers(p)) for p in args.markers]
    if any(kinds) and not all(kinds):
        raise MocapError(
            "--markers: expected trials of one marker set, got Plug-in Gait's in "
            f"{', '.join(p for p, k in zip(args.markers, kinds, strict=True) if k)} only"
        )
    with scratch_folder(prefix="mocap-mj-gait-") as scratch:
        if all(kinds):
            trials, subject, source = _pig_trials(args)
        else:  # another set: the angles of the model identified on the trials
            trials, source = identified_trials(args, args.markers, scratch)
            subject = {}
        return into_out_folder(
            args, lambda out: _work(args, out, trials, subject, source, normative, events)
        )


def _pig_trials(args: argparse.Namespace) -> tuple[list[Any], dict[str, Any], AnglesSource]:
    from .plug_in_gait import gait_trial, pig_run

    runs = [pig_run(args, path) for path in args.markers]
    source = AnglesSource("Plug-in Gait's, from the markers")
    return [gait_trial(r) for r in runs], pig_dict(runs[0].result.subject), source


def _work(
    args: argparse.Namespace,
    out: Path,
    trials: list[Any],
    subject: dict[str, Any],
    source: AnglesSource,
    normative: Any,
    events: Any,
) -> tuple[Mapping[str, Any], str]:
    from ._gait import gait_report_files

    notes = [f"angles: {source.angles}"]
    if source.model is not None:  # the identified model, kept beside the report
        shutil.copyfile(source.model, out / "model.xml")
        source = replace(source, model="model.xml")
        rmse = source.marker_rmse
        shown = "unknown" if rmse is None else f"{rmse * 1e3:.2f} mm"
        notes.append(f"the model identified on the trials (model.xml): marker RMSE {shown}")
    entry = gait_report_files(out, trials, normative, events, subject, notes)
    summary = {
        "command": "gait-report",
        "markers": list(args.markers),
        "static": args.static,
        "out": str(args.out),
        **source_fields(source),
        "subject": subject,
        "gait_report": entry,
        "implausible": entry["implausible"],
    }
    counts = [n for t in entry["cycles"].values() for n in t.values()]
    scores = entry["scores_omitted"] or f"GPS {entry['gps_deg']['overall']:.2f} deg overall"
    text = (
        f"gait-report: {sum(counts)} cycles of {len(trials)} trials "
        f"({len(entry['dropped'])} dropped or without kinetics); {scores} -> {args.out}"
    )
    return summary, text
