"""C3D files, read through ezc3d after a structural check of our own.

Every 3D point of POINT:LABELS (+ LABELS2, LABELS3... past 255 points) is read; the points
the file itself lists as model outputs (POINT:ANGLES, FORCES, MOMENTS, POWERS, SCALARS,
REACTIONS, MODELED_MARKERS and any group POINT:TYPE_GROUPS names) are reported in
``non_markers`` for the loader to drop. A sample whose residual is negative, or whose three
coordinates are exactly zero, is missing (NaN).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import ezc3d
import numpy as np

from mocap_mj.errors import InputFileError
from mocap_mj.io.formats._common import RawMarkers
from mocap_mj.io.formats.c3d_check import check_c3d

#: POINT parameters that list non-marker points (model outputs), as Vicon writes them.
NON_MARKER_GROUPS = (
    "ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS", "MODELED_MARKERS",
)  # fmt: skip


def looks_like(head: bytes) -> bool:
    """True if a file starting with ``head`` has the C3D key byte."""
    return len(head) >= 2 and head[1] == 0x50 and head[0] >= 1


def _values(params: dict[str, Any], group: str, name: str) -> list[Any]:
    entry = params.get(group, {}).get(name)
    if not isinstance(entry, dict):
        return []
    value = entry.get("value")
    if value is None:
        return []
    return list(np.ravel(value)) if not isinstance(value, list) else value


def _point_labels(point: dict[str, Any]) -> list[str]:
    labels = [str(v) for v in _values({"POINT": point}, "POINT", "LABELS")]
    k = 2
    while f"LABELS{k}" in point:
        labels += [str(v) for v in _values({"POINT": point}, "POINT", f"LABELS{k}")]
        k += 1
    return [label.strip() for label in labels]


def _non_marker_names(point: dict[str, Any]) -> set[str]:
    groups = list(NON_MARKER_GROUPS)
    listed = _values({"POINT": point}, "POINT", "TYPE_GROUPS")
    type_groups = [str(v).strip().upper() for v in listed]
    groups += type_groups[::2]  # (group, singular) pairs
    names: set[str] = set()
    for group in groups:
        if group in ("LABELS", "DESCRIPTIONS", "UNITS") or group.startswith("LABELS"):
            continue
        names.update(str(v).strip() for v in _values({"POINT": point}, "POINT", group))
    names.discard("")
    return names


def _up_hint(point: dict[str, Any]) -> str | None:
    screen = [str(v).strip().upper() for v in _values({"POINT": point}, "POINT", "Y_SCREEN")]
    if screen and len(screen[0]) == 2 and screen[0][0] in "+-" and screen[0][1] in "XYZ":
        return ("-" if screen[0][0] == "-" else "") + screen[0][1].lower()
    return None


def read(path: Path) -> RawMarkers:
    """Read the marker points of a C3D file."""
    layout = check_c3d(path)
    try:
        c3d = ezc3d.c3d(str(path))
        params = c3d["parameters"]
        points = np.asarray(c3d["data"]["points"], dtype=np.float64)
        residuals = np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=np.float64)
    except Exception as exc:  # ezc3d raises RuntimeError, OSError, ValueError...
        message = " ".join(str(exc).split())[:200]
        raise InputFileError(f"{path}: ezc3d could not read it: {message}") from exc
    point = params.get("POINT", {})
    if points.shape != (4, layout.n_points, layout.n_frames):
        raise InputFileError(
            f"{path}: data section: expected {layout.n_points} points x {layout.n_frames} frames "
            f"(POINT:USED x POINT:FRAMES), got {points.shape[1]} x {points.shape[2]} from ezc3d"
        )
    labels = _point_labels(point)[: layout.n_points]
    positions = points[:3].transpose(2, 1, 0).copy()  # (T, M, 3)
    missing = (residuals[0].T < 0) | np.all(positions == 0.0, axis=2)
    positions[missing] = np.nan
    positions[np.isnan(positions).any(axis=2)] = np.nan
    bad = np.argwhere(np.isinf(positions))
    if len(bad):
        frame, point = int(bad[0][0]), int(bad[0][1])
        raise InputFileError(
            f"{path}: data section: expected finite coordinates, got infinity in frame "
            f"{frame + 1} for point {labels[point]!r}"
        )

    rate = float(layout.params[("POINT", "RATE")].values[0])
    units = [str(v).strip() for v in _values(params, "POINT", "UNITS")]
    subjects = [str(v).strip() for v in _values(params, "SUBJECTS", "NAMES") if str(v).strip()]
    header = c3d["header"]["points"]
    return RawMarkers(
        format="c3d",
        labels=labels,
        positions=positions,
        times=np.arange(layout.n_frames) / rate,
        rate=rate,
        units=units[0] if units and units[0] else None,
        units_where="group POINT:UNITS",
        labels_where="group POINT:LABELS",
        up_hint=_up_hint(point),
        non_markers=_non_marker_names(point),
        subjects=subjects,
        info={"first_frame": int(header["first_frame"])},
    )
