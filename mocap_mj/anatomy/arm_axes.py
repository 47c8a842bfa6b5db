"""Elbow and wrist flexion axes: Plug-in Gait's construction as prior rows, and the angle
between it and the identified model's axis.

Plug-in Gait's elbow axis passes through the elbow marker: the elbow centre is the ELB
marker moved medially, normal to the arm's plane, by half the elbow width plus the marker
radius (:func:`mocap_mj.clinical.centres.elbow`). In the model's upper arm (origin the
shoulder centre, the elbow centre on its z axis, the elbow's hinge along its y) that is
``ELB.x = 0``: the row :func:`mocap_mj.anatomy.anatomy.landmark_prior` holds at
:data:`~mocap_mj.anatomy.anatomy.SIGMA_CONVENTION`, the lateral marker that defines a
convention joint. Plug-in Gait's wrist flexion axis is the wrist bar: the hand's y runs
from WRA to WRB, and the wrist centre lies off the bar's mid-point normal to the bar and to
the forearm (:func:`mocap_mj.clinical.centres.wrist`). In the model's radius (the wrist's
flexion hinge along its y) that is ``WRA.x = WRB.x`` (:func:`bar_row`), width
:data:`~mocap_mj.anatomy.axis_rows.SIGMA_WAND_ANGLE` of the bar's turn about the forearm.
Without that row nothing but the motion holds the bar's turn, and a static trial (the
wrist still, FIN the hand's only marker) leaves it to chance: the wrist centre then moves
round the bar's mid-point.

As for the knee and ankle (:mod:`mocap_mj.anatomy.axes`), each row is a decision: where
the recording determines the axis better than the row, the motion places it (the row left
out); elsewhere Plug-in Gait's construction does. Neither row needs a measured width (the
width places the centre along the axis, not the axis's direction), so both hold whether the
elbow and wrist widths are measured or regressed.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mocap_mj.anatomy.axis_rows import SIGMA_WAND_ANGLE, Row, nominal_offset
from mocap_mj.skeleton.parameters import ParameterSet

#: Joint -> (the marker whose name keys its row, the start of the row's label).
ARM_AXES: dict[str, tuple[str, str]] = {
    "elbow": ("ELB", "ELB.x = 0 (Plug-in Gait's"),
    "wrist": ("WRA", "WRA-WRB bar along"),
}


def has_axis(pset: ParameterSet, joint: str, p: str) -> bool:
    """Whether ``pset`` has the markers of ``joint``'s row on side prefix ``p``."""
    need = ("ELB",) if joint == "elbow" else ("WRA", "WRB")
    return all(p + m in pset.marker_names for m in need)


def lever(pset: ParameterSet, joint: str, p: str) -> float:
    """The lever [m] that turns a row residual into the axis's turn: ``atan(residual /
    lever)``; the nominal ELB's distance from the elbow's axis line, the nominal bar's
    length."""
    if joint == "elbow":
        return float(abs(nominal_offset(pset, p + "ELB")[1]))
    a, b = (nominal_offset(pset, p + m) for m in ("WRA", "WRB"))
    return float(abs(a[1] - b[1]))


def bar_width(pset: ParameterSet, p: str, angle: float = SIGMA_WAND_ANGLE) -> float:
    """The width [m] of :func:`bar_row` for a turn of the bar by ``angle`` [deg]."""
    return float(np.tan(np.radians(angle)) * lever(pset, "wrist", p))


def bar_row(p: str, sigma: float) -> Row:
    """Plug-in Gait's wrist flexion axis along the wrist bar: ``WRA.x - WRB.x = 0`` in the
    radius frame (the bar parallel to the wrist's flexion hinge), width ``sigma`` [m]."""
    label = f"{p}WRA-WRB bar along the wrist's flexion axis (Plug-in Gait's wrist)"
    return {f"{p}WRA.x": 1.0, f"{p}WRB.x": -1.0}, 0.0, sigma, label


def arm_rows(pset: ParameterSet, p: str, widths: Mapping[str, float | None]) -> list[Row]:
    """The wrist bar's row of side prefix ``p`` (:func:`bar_row`) unless ``widths`` (row key
    -> width [m], None for a functional axis, :func:`mocap_mj.anatomy.axes.widths`) leaves
    it out: the bar's direction needs no measured width, only the bar."""
    if not has_axis(pset, "wrist", p):
        return []
    sigma = widths.get(p + "WRA", bar_width(pset, p))
    return [] if sigma is None else [bar_row(p, sigma)]


def arm_angle(pset: ParameterSet, theta: np.ndarray, joint: str) -> float:
    """Angle [deg] between the identified model's flexion axis of ``joint`` (``elbow_l``,
    ``wrist_r``...) and Plug-in Gait's, about the segment's long axis: for the elbow the
    direction from the elbow centre to ELB (Plug-in Gait's axis passes through the marker),
    for the wrist the bar WRA-WRB, both in the segment's frame normal to its z. Positive:
    Plug-in Gait's axis turned anterior of the model's on the lateral side."""
    p = joint[-1].upper()
    offsets = pset.split(theta)[1]
    if joint.startswith("elbow"):
        v = offsets[pset.marker_index(p + "ELB")]
    else:
        v = offsets[pset.marker_index(p + "WRA")] - offsets[pset.marker_index(p + "WRB")]
    lateral = v[1] if p == "L" else -v[1]
    return float(np.degrees(np.arctan2(v[0], lateral)))
