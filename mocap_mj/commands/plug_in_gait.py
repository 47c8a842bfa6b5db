"""``mocap-mj plug-in-gait``: Plug-in Gait (Conventional Gait Model 1.0) on a C3D trial."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.commands.common import into_out_folder
from mocap_mj.outputs.write_fit import frame_range

from ..clinical.subject import PigSubject
from ..errors import MocapError


def run(args: argparse.Namespace) -> int:
    from mocap_mj.outputs.plug_in_gait import write_all

    from ..clinical import pig_from_file, plug_in_gait

    whole = _read(args, args.markers)
    sl = frame_range(args.frames, whole.n_frames, args.markers)
    if sl.stop - sl.start < 1:
        raise MocapError(f"{args.markers}: --frames {args.frames} selects no frame")
    trial = whole.slice(sl.start, sl.stop)
    subject = _file_subject(args.markers)
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
        trial_type=args.trial_type,
    )

    kinetics, kinetic_notes = _kinetics(args, trial, result, rotation.T, (sl, whole.n_frames))

    def work(out: Path) -> tuple[Mapping[str, Any], str]:
        write_all(out, result, trial.rate, str(args.markers), kinetics, kinetic_notes)
        summary = {"markers": str(args.markers), "static": args.static, "out": str(args.out)}
        summary |= result.summary()
        summary["kinetics"] = sorted(kinetics) if kinetics else []
        summary["kinetics_notes"] = kinetic_notes
        text = (
            f"plug-in-gait: {len(result.angles)} angles, {len(result.points)} bone points, "
            f"{len(kinetics or {})} kinetic outputs, {trial.n_frames} frames "
            f"({'static' if result.static else 'dynamic'} trial) -> {args.out}"
        )
        return summary, text

    return into_out_folder(args, work)


def _counted(text: str) -> set[int] | None:
    """--plates: None for all, the empty set for none, else the plate numbers."""
    if text == "all":
        return None
    if text == "none":
        return set()
    try:
        numbers = {int(v) for v in text.split(",")}
    except ValueError:
        numbers = {0}
    if min(numbers) < 1:
        raise MocapError(f"--plates {text!r}: expected all, none or plate numbers such as 1,4")
    return numbers


def _read(args: argparse.Namespace, path: str) -> Any:
    """The markers of ``path`` read with the command's input flags (a static as the trial)."""
    from ..io.load import load_markers

    return load_markers(
        path, subject=args.subject, marker_map=args.marker_map, up=args.up, units=args.units
    )


def _kinetics(
    args: argparse.Namespace,
    trial: Any,
    result: Any,
    to_lab: np.ndarray,
    frames: tuple[slice, int],
) -> tuple[dict[str, np.ndarray] | None, list[str]]:
    """The kinetic outputs when the trial is a C3D with plates and the subject a mass;
    ``frames``: the rows of the recording's ``n_frames`` that ``--frames`` keeps."""
    rows, n_frames = frames
    from ..clinical.kinetics import trial_kinetics
    from ..io.plates import read_plates

    counted = _counted(args.plates)
    if counted == set() or Path(args.markers).suffix.lower() != ".c3d":
        return None, []
    plates = read_plates(
        args.markers, marker_rate=trial.rate, window="centred", offsets="none", up=args.up
    )
    if not plates:
        return None, ["no kinetics: the trial has no force plates"]
    mass = result.subject.measured("mass")
    if mass is None:
        return None, ["no kinetics: no body mass (PROCESSING:Bodymass, or mass in --subject-file)"]
    if len(plates[0].force) != n_frames:
        raise MocapError(
            f"{args.markers}: the plates hold {len(plates[0].force)} frames, the markers "
            f"{n_frames}; expected the same frames"
        )
    plates = [
        replace(p, force=p.force[rows], cop=p.cop[rows], free_moment=p.free_moment[rows])
        for p in plates
    ]
    return trial_kinetics(
        result.segments,
        result.centres,
        plates,
        trial,
        body_mass=mass,
        progression=result.progression @ to_lab,
        to_lab=to_lab,
        counted=counted,
    )


def _file_subject(path: str) -> PigSubject:
    """The subject values a C3D file stores (none for other formats)."""
    from ..clinical import pig_from_c3d

    return pig_from_c3d(path) if Path(path).suffix.lower() == ".c3d" else PigSubject()
