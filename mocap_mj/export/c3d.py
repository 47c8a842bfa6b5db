"""C3D write-back (ezc3d): measured markers, model markers, joint centres and the angles.

Points, in this order, all in the MJCF world frame (z up, as the lab of the input file):

- the measured markers, under their names (``LASI`` ...), in millimetres;
- the model's markers, ``<name>_model`` (``LASI_model``), in millimetres;
- the joint centres of :mod:`mocap_mj.skeleton.joint_centres` (``hip_l`` ...), in millimetres;
- Plug-in Gait's angles of the model (:mod:`mocap_mj.export.clinical`) under Vicon's names
  and components (``LHipAngles``: x flexion, y adduction, z internal rotation), in degrees.

Parameters a reader expects: ``POINT:RATE``, ``POINT:UNITS`` = mm, ``POINT:ANGLES`` with
``POINT:ANGLE_UNITS`` = deg, ``POINT:MODELED_MARKERS`` (model markers and joint centres),
``POINT:TYPE_GROUPS``, ``POINT:DESCRIPTIONS``; the EVENT group holds the gait events the
caller passes (:func:`mocap_mj.capture.events.add_events`), none by default. Missing
samples (a marker not seen, a frame not solved) are written as invalid points (residual -1),
which readers return as NaN.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.capture.events import GaitEvent, add_events
from mocap_mj.export.read_result import ExportSource
from mocap_mj.skeleton.joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories

from ..io.atomic import atomic_write_bytes
from .clinical import clinical_angles
from .tables import marker_residuals


@dataclass(frozen=True)
class C3DPoints:
    """The points of a C3D file: ``values`` (T, N, 3) in the file's units (mm; degrees for
    the angles), NaN where missing, under ``labels`` (N,) with their ``descriptions`` (N,),
    at ``rate`` [Hz]; ``first_frame``: the recording's number of frame 0 as a C3D header
    numbers frames (from 1; below 1, the file's frames are numbered from 1)."""

    labels: list[str]
    descriptions: list[str]
    values: np.ndarray
    rate: float
    first_frame: int = 1


def c3d_points(src: ExportSource) -> tuple[list[str], list[str], np.ndarray]:
    """(labels, descriptions, values (T, N, 3) in file units: mm and degrees) of the file."""
    model, motion = src.model, src.motion
    names = list(motion.marker_names)
    fitted, _ = marker_residuals(model, motion.qpos, motion.markers)
    centres = joint_centre_trajectories(model, motion.qpos)
    by_name = clinical_angles(model, motion.qpos)
    angles = np.degrees(np.stack(list(by_name.values()), axis=1))
    labels = [
        *names,
        *(f"{n}_model" for n in names),
        *JOINT_CENTRE_NAMES,
        *by_name,
    ]
    desc = [
        *("measured marker" for _ in names),
        *("model marker (fitted)" for _ in names),
        *("joint centre" for _ in JOINT_CENTRE_NAMES),
        *("Plug-in Gait angle of the model" for _ in by_name),
    ]
    values = np.concatenate([motion.markers * 1e3, fitted * 1e3, centres * 1e3, angles], axis=1)
    return labels, desc, values


def write_c3d(path: str | Path, src: ExportSource, *, events: Sequence[GaitEvent] = ()) -> None:
    """Write the C3D of ``src`` (see the module doc), atomically, with ``events`` (gait
    events, :mod:`mocap_mj.capture.events`) in its EVENT group when given."""
    labels, desc, values = c3d_points(src)
    n_markers = len(src.motion.marker_names)
    write_points_c3d(
        path,
        C3DPoints(labels, desc, values, src.rate, src.motion.first_frame),
        angle_labels=labels[n_markers * 2 + len(JOINT_CENTRE_NAMES) :],
        modeled=labels[n_markers : n_markers * 2 + len(JOINT_CENTRE_NAMES)],
        events=events,
    )


def write_points_c3d(
    path: str | Path,
    points: C3DPoints,
    *,
    angle_labels: list[str],
    modeled: list[str],
    events: Sequence[GaitEvent] = (),
    kinetic: Mapping[str, tuple[list[str], str]] | None = None,
) -> None:
    """Write ``points`` as a C3D, atomically; NaN samples are written as invalid points,
    ``points.first_frame`` above 1 also as ``TRIAL:ACTUAL_START_FIELD``. ``angle_labels``:
    the labels of the angles (in degrees), ``modeled`` those of the modelled markers.
    ``events``: gait events written into the EVENT group (none by default). ``kinetic``:
    Vicon's kinetic point groups, e.g. ``{"MOMENTS": (labels, "Nmm/kg")}`` (FORCES,
    MOMENTS, POWERS), written as ``POINT:MOMENTS`` and ``POINT:MOMENT_UNITS``."""
    labels, values, first_frame = points.labels, points.values, points.first_frame
    c3d = ezc3d.c3d()
    point = c3d["parameters"]["POINT"]
    point["RATE"]["value"] = np.array([points.rate])
    point["LABELS"]["value"] = labels
    point["DESCRIPTIONS"]["value"] = points.descriptions
    point["UNITS"]["value"] = ["mm"]
    c3d.add_parameter("POINT", "ANGLES", angle_labels)
    c3d.add_parameter("POINT", "ANGLE_UNITS", ["deg"])
    c3d.add_parameter("POINT", "MODELED_MARKERS", modeled)
    groups = ["ANGLES", "ANGLE", "MODELED_MARKERS", "MODELED"]
    for group, (names, unit) in (kinetic or {}).items():
        c3d.add_parameter("POINT", group, names)
        c3d.add_parameter("POINT", f"{group[:-1]}_UNITS", [unit])
        groups += [group, group[:-1]]
    c3d.add_parameter("POINT", "TYPE_GROUPS", groups)
    data = np.ones((4, len(labels), len(values)))
    data[:3] = np.transpose(values, (2, 1, 0))
    c3d["data"]["points"] = data
    if first_frame > 1:
        c3d.add_parameter("TRIAL", "ACTUAL_START_FIELD", [int(first_frame), 0])
        c3d["header"]["points"]["first_frame"] = int(first_frame) - 1  # ezc3d counts from 0
    missing = ~np.all(np.isfinite(values), axis=2).T  # (N, T)
    residuals = np.where(missing, -1.0, 0.0)[np.newaxis]
    c3d["data"]["meta_points"]["residuals"] = residuals
    c3d["data"]["meta_points"]["camera_masks"] = np.zeros((7, *missing.shape), dtype=bool)
    add_events(c3d, events)
    target = Path(path)
    tmp = target.with_name(f".{target.stem}.tmp.c3d")  # ezc3d wants the suffix
    try:
        c3d.write(str(tmp))
        atomic_write_bytes(target, tmp.read_bytes())
    finally:
        tmp.unlink(missing_ok=True)
