"""The gait report of ``gait-report`` and ``plug-in-gait --report``: the inputs read before
any output (the normative file, the events files), each trial's gait events and cycles, and
the report's files (:mod:`mocap_mj.outputs.gait_html`)."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.capture.events import GaitEvent, gait_events, read_events_csv
from mocap_mj.clinical.gait_scores import Normative, read_normative
from mocap_mj.errors import MocapError
from mocap_mj.outputs.gait_report import AnglesSource


@dataclass(frozen=True)
class GaitTrial:
    """One trial of the report: its file, trajectory (Z up), Plug-in Gait angles by Vicon
    name ((T, 3) [rad] at the trajectory's frames), kinetic outputs (None without) and the
    notes on them."""

    path: str
    trial: Any
    angles: dict[str, np.ndarray]
    kinetics: dict[str, np.ndarray] | None = None
    notes: tuple[str, ...] = ()


def is_plug_in_gait(trial: Any) -> bool:
    """Whether the trajectory holds Plug-in Gait's lower-body markers (its angles come from
    the markers; otherwise from an identified model)."""
    from mocap_mj.clinical.model import LOWER_MARKERS

    names = set(trial.names)
    return set(LOWER_MARKERS) <= names and ("SACR" in names or {"LPSI", "RPSI"} <= names)


def identified_trials(
    args: argparse.Namespace, paths: Sequence[str], scratch: Path
) -> tuple[list[GaitTrial], AnglesSource]:
    """The trials' angles in Plug-in Gait's conventions from a model ``mocap-mj identify``
    identifies on them (its folder in ``scratch``; ``--marker-set`` passed on), and where
    they come from: that model and its marker RMSE (summary.json's, read back)."""
    from mocap_mj.clinical.from_model import model_angles
    from mocap_mj.commands.registry import build_parser
    from mocap_mj.io.load import load_markers
    from mocap_mj.pipeline.motion import load_motion
    from mocap_mj.pipeline.summary import written_marker_rmse
    from mocap_mj.pipeline.trials import open_trial
    from mocap_mj.skeleton.mjcf import load_model

    fit = scratch / "identified"
    argv = ["identify", "--markers", *paths, "--out", str(fit), "--json"]
    if getattr(args, "marker_set", None):
        argv += ["--marker-set", args.marker_set]
    ident = build_parser().parse_args(argv)
    with contextlib.redirect_stdout(io.StringIO()):
        status = ident.func(ident)
    if status != 0:
        raise MocapError(f"the identification of {', '.join(paths)} failed (exit {status})")
    model = load_model(fit / "model.xml")
    out = []
    for i, path in enumerate(paths):
        motion = load_motion(open_trial(fit, str(i)).motion, model)  # trial i's folder
        trial = load_markers(path)
        if len(motion.times) != trial.n_frames:
            raise MocapError(
                f"{path}: the identified motion has {len(motion.times)} frames, the file "
                f"{trial.n_frames}; expected the same"
            )
        out.append(GaitTrial(path, trial, model_angles(model, motion.qpos)))
    rmse = written_marker_rmse(json.loads((fit / "summary.json").read_text()))
    source = AnglesSource(
        "the identified model's, in Plug-in Gait's conventions", str(fit / "model.xml"), rmse
    )
    return out, source


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
    runs: Sequence[GaitTrial],
    normative: Normative | None,
    events: Sequence[Sequence[GaitEvent]] | None,
    subject: dict[str, Any],
    notes: Sequence[str] = (),
) -> dict[str, Any]:
    """The report's files of the trials ``runs`` into ``out`` (``subject``: name -> {value,
    unit, source}; ``notes``: lines for the page); summary.json's ``gait_report`` entry."""
    from mocap_mj.outputs.gait_html import write_gait_report
    from mocap_mj.outputs.gait_report import trial_cycles

    trials = []
    lines = list(notes)
    names = _names([r.path for r in runs])
    for i, run in enumerate(runs):
        found = list(events[i]) if events is not None else trial_events(run.path, run.trial)
        trials.append(trial_cycles(names[i], found, run.trial, run.angles, run.kinetics))
        lines += [f"{names[i]}: {n}" for n in run.notes]
    entry = write_gait_report(out, trials, normative, subject, lines)
    if not any(t.cycles for t in trials):
        entry["note"] = "no complete gait cycle in the trials' events"
    return entry


def _names(paths: Sequence[str]) -> list[str]:
    """The trials' names in the tables: the file stems, numbered when two are alike."""
    stems = [Path(p).stem for p in paths]
    return [s if stems.count(s) == 1 else f"{s}_{i + 1}" for i, s in enumerate(stems)]
