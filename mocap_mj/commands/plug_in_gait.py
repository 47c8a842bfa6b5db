"""``mocap-mj plug-in-gait``: Plug-in Gait (Conventional Gait Model 1.0) on a C3D trial."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.commands.common import into_out_folder
from mocap_mj.outputs.write_fit import frame_range

from ..capture.subject import Subject
from ..clinical.subject import pig_dict
from ..errors import MocapError


@dataclass(frozen=True)
class PigRun:
    """One trial through Plug-in Gait: the file, its trajectory, the result, its kinetic
    outputs (None without plates or mass), the kinetics' notes and the whole-body centre of
    mass (``CentreOfMass``, ``CentreOfMassFloor`` (T, 3) [m, the lab frame]; empty for a
    static trial, without a mass or without the trunk and arms)."""

    path: str
    trial: Any
    result: Any
    kinetics: dict[str, np.ndarray] | None
    notes: list[str]
    centre_of_mass: dict[str, np.ndarray] = field(default_factory=dict)

    def outputs(self) -> dict[str, np.ndarray] | None:
        """What kinetics.csv holds: the kinetic outputs and the centre of mass (None: no
        file)."""
        return {**(self.kinetics or {}), **self.centre_of_mass} or None


def pig_run(args: argparse.Namespace, path: str) -> PigRun:
    """Plug-in Gait on the trial ``path`` with the command's --static, --subject-file,
    --trial-type and --plates, its markers read with the input flags the command has
    (--subject, --marker-map, --up, --units) and cut to its --frames."""
    from ..clinical import pig_from_file, plug_in_gait

    whole = _read(args, path)
    rows = frame_range(getattr(args, "frames", None), whole.n_frames, path)
    if rows.stop - rows.start < 1:
        raise MocapError(f"{path}: --frames {args.frames} selects no frame")
    trial = whole.slice(rows.start, rows.stop)
    subject = _file_subject(path)
    static = None
    if args.static:
        static = _read(args, args.static)
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
    up = getattr(args, "up", None)
    kinetics, notes = _kinetics(path, (args.plates, up), trial, result, rotation.T, (rows, whole))
    com, com_notes = _centre_of_mass(trial, result, rotation.T)
    return PigRun(path, trial, result, kinetics, notes + com_notes, com)


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
    result, kinetics, kinetic_notes, trial = pig.result, pig.outputs(), pig.notes, pig.trial

    def work(out: Path) -> tuple[Mapping[str, Any], str]:
        write_all(out, result, trial.rate, str(args.markers), kinetics, kinetic_notes)
        summary = {"markers": str(args.markers), "static": args.static, "out": str(args.out)}
        summary |= result.summary()
        summary["kinetics"] = sorted(kinetics) if kinetics else []
        summary["kinetics_notes"] = kinetic_notes
        if report:
            subject = pig_dict(result.subject)
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


def _read(args: argparse.Namespace, path: str) -> Any:
    """The markers of ``path`` read with the command's input flags (a static as the trial)."""
    from ..io.load import load_markers

    return load_markers(
        path,
        subject=getattr(args, "subject", None),
        marker_map=getattr(args, "marker_map", None),
        up=getattr(args, "up", None),
        units=getattr(args, "units", None),
    )


def _kinetics(
    path: str,
    plates: tuple[str, str | None],
    trial: Any,
    result: Any,
    to_lab: np.ndarray,
    frames: tuple[slice, Any],
) -> tuple[dict[str, np.ndarray] | None, list[str]]:
    """The kinetic outputs when the trial is a C3D with plates and the subject a mass:
    ``plates`` (--plates, --up: the plates rotated as the markers); ``frames`` (the rows of
    the ``whole`` recording that --frames keeps, ``trial``'s)."""
    from ..clinical.centre_of_mass import with_trunk
    from ..clinical.kinetics import PlateChoice, trial_kinetics
    from ..io.plates import read_plates, recorded_ground_reactions

    (plates_text, up), (rows, whole) = plates, frames
    counted = _counted(plates_text)
    if counted == set() or Path(path).suffix.lower() != ".c3d":
        return None, []
    records = read_plates(path, marker_rate=trial.rate, window="centred", offsets="none", up=up)
    if not records:
        return None, ["no kinetics: the trial has no force plates"]
    mass = result.subject.get("mass")
    if mass is None:
        return None, ["no kinetics: no body mass (PROCESSING:Bodymass, or mass in --subject-file)"]
    if len(records[0].force) != whole.n_frames:
        raise MocapError(
            f"{path}: the plates hold {len(records[0].force)} frames, the markers "
            f"{whole.n_frames}; expected the same frames"
        )
    records = [
        replace(p, force=p.force[rows], cop=p.cop[rows], free_moment=p.free_moment[rows])
        for p in records
    ]
    recorded = recorded_ground_reactions(path) if plates_text == "auto" else None
    markers = {n: trial.positions[:, i] for i, n in enumerate(trial.names)}
    return trial_kinetics(
        result.segments,
        with_trunk(result.segments, result.centres, markers, result.subject.marker_radius),
        records,
        trial,
        body_mass=mass,
        progression=result.progression @ to_lab,
        to_lab=to_lab,
        choice=PlateChoice(
            counted, None if recorded is None else {k: v[rows] for k, v in recorded.items()}
        ),
    )


def _centre_of_mass(
    trial: Any, result: Any, to_lab: np.ndarray
) -> tuple[dict[str, np.ndarray], list[str]]:
    """Nexus' ``CentreOfMass`` and ``CentreOfMassFloor`` of a dynamic trial with a body mass
    (:func:`~mocap_mj.clinical.centre_of_mass.pig_centre_of_mass`; no plates needed), and a
    note when a dynamic trial has none."""
    from ..clinical.centre_of_mass import pig_centre_of_mass

    if result.static:
        return {}, []
    if result.subject.get("mass") is None:
        return {}, ["no CentreOfMass: no body mass (PROCESSING:Bodymass, or mass in "
                    "--subject-file)"]  # fmt: skip
    if "thorax" not in result.segments:
        return {}, ["no CentreOfMass: it needs the trunk, head and arms"]
    markers = {n: trial.positions[:, i] for i, n in enumerate(trial.names)}
    com = pig_centre_of_mass(result.segments, result.centres, markers,
                             marker_radius=result.subject.marker_radius, to_lab=to_lab)  # fmt: skip
    return com, []


def _file_subject(path: str) -> Subject:
    """The subject values a C3D file stores (none for other formats)."""
    from ..clinical import pig_from_c3d

    return pig_from_c3d(path) if Path(path).suffix.lower() == ".c3d" else Subject()
