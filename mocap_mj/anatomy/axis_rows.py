"""Prior rows on the joint axes: Plug-in Gait's chord plane (a wand and a lateral marker)
and an epicondyle or malleolus pair (a lateral and a medial marker).

Each function returns rows ``(terms, b, sigma, label)`` (``terms . theta = b`` [m], width
``sigma`` [m]) that :func:`mocap_mj.anatomy.anatomy.landmark_prior` adds;
:mod:`mocap_mj.anatomy.axes` decides where the chord plane holds.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mocap_mj.capture.roles import medial_markers
from mocap_mj.skeleton.parameters import ParameterSet

Row = tuple[dict[str, float], float, float, str]

#: Wand marker -> the lateral joint marker whose joint's flexion axis Plug-in Gait places
#: in the plane of the wand (:func:`pig_axis_row`): the thigh wand and the knee, the tibia
#: wand and the ankle. The plane needs no width (the width only places the centre in it), so
#: the row holds whether the width is measured or regressed: without it a static leaves the
#: thigh free to turn about its long axis, and the marker offsets follow.
PIG_AXIS_WANDS: dict[str, str] = {"THI": "KNE", "TIB": "ANK"}
#: Standard deviation [deg] of the flexion axis's turn about its segment's long axis where
#: the chord plane places it (:func:`pig_axis_row`): the plane turns with the wand, and a
#: wand misplaced by a few degrees turns Plug-in Gait's axis by more (knee rotation and
#: varus-valgus are the least repeatable of its angles on retest: McGinley et al.
#: 2009). On the shared Vicon trials the data placed the knee axis to 10-11 degrees in a
#: static trial and 6 in a jump (where imposing the chord plane raised the RMSE by half).
SIGMA_WAND_ANGLE = 8.0


def nominal_offset(pset: ParameterSet, marker: str) -> np.ndarray:
    """The nominal model's offset (3,) [m] of ``marker`` in its body's frame."""
    return pset.split(pset.nominal)[1][pset.marker_index(marker)]


#: Lateral joint marker (side removed) -> the medial landmark that pairs with it, the
#: joint centre's lateral parameter in the marker's frame (""for none: on the frame's
#: origin) and the segment length that places the joint below the frame's origin.
MEDIAL_LANDMARKS: dict[str, tuple[str, str, str]] = {
    "KNE": ("medial_femoral_epicondyle", "knee_lateral", "thigh_length"),
    "ANK": ("medial_malleolus", "ankle_lateral", "shank_length"),
    "ELB": ("medial_humeral_epicondyle", "", "upperarm_length"),
}


def medial_pairs(
    pset: ParameterSet, landmarks: Mapping[str, str], p: str, alias: Mapping[str, str] | None = None
) -> dict[str, str]:
    """Lateral joint marker's role (``LKNE``...) -> the marker ``landmarks`` (marker ->
    landmark) puts on its medial landmark on side ``p`` ("L" or "R",
    :func:`~mocap_mj.capture.roles.marker_sides`), where the set fills the role (the
    marker of that name, or ``alias``'s: :func:`~mocap_mj.capture.roles.roles`)."""
    out = {}
    for lateral, (landmark, _, _) in MEDIAL_LANDMARKS.items():
        found = medial_markers(pset, landmarks, landmark, p)
        if found and (p + lateral in pset.marker_names or p + lateral in (alias or {})):
            out[p + lateral] = found[0]
    return out


def medial_rows(
    side: str, lateral: str, medial: str, sigma_midpoint: float, sigma_measured: float
) -> list[Row]:
    """The joint centre at the midpoint of a lateral and a medial marker, as the ISB defines
    the knee, ankle and elbow centres from their epicondyles and malleoli (Wu et al. 2002,
    2005): its depth and level (``sigma_midpoint`` [m]: the definition, a convention row) and its
    place along the axis (``sigma_measured`` [m]: the lateral marker's width row then places
    both, the width measured from the pair)."""
    _, centre, length = MEDIAL_LANDMARKS[lateral[1:]]
    out: list[Row] = [
        ({f"{medial}.x": 0.5, f"{lateral}.x": 0.5}, 0.0, sigma_midpoint,
         f"joint centre at the {lateral}-{medial} midpoint (x)"),
        ({f"{medial}.z": 0.5, f"{lateral}.z": 0.5, f"{length}_{side}": 1.0}, 0.0, sigma_midpoint,
         f"joint centre at the {lateral}-{medial} midpoint (z)"),
    ]  # fmt: skip
    terms = {f"{medial}.y": 1.0, f"{lateral}.y": 1.0}
    if centre:  # the centre's y in the frame is +the parameter on the left, - on the right
        terms[f"{centre}_{side}"] = -2.0 if side == "l" else 2.0
    out.append((terms, 0.0, sigma_measured, f"joint centre midway between {lateral} and {medial}"))
    return out


def wand_width(
    pset: ParameterSet, wand: str, marker: str, angle: float = SIGMA_WAND_ANGLE
) -> float:
    """The width [m] of ``wand``'s chord-plane row for a turn of the flexion axis by
    ``angle`` [deg] about the segment's long axis: the plane through the origin, the marker
    ``k`` and the wand ``t`` (nominal offsets) turns its horizontal line by ``dx |k.z| /
    |k.y t.z - k.z t.y|`` [rad] for a wand moved by ``dx`` (the row's residual)."""
    k, t = nominal_offset(pset, marker), nominal_offset(pset, wand)
    return float(np.tan(np.radians(angle)) * abs(k[1] * t[2] - k[2] * t[1]) / abs(k[2]))


def pig_axis_row(pset: ParameterSet, wand: str, marker: str, sigma: float) -> Row:
    """Plug-in Gait's chord plane: the joint centre in the plane of the proximal joint
    centre, the wand and the joint's lateral marker (THI and KNE for the knee, TIB and ANK
    for the ankle), so that the flexion axis (the segment frame's y) lies in the plane of
    the wand and the marker about the segment's long axis.

    In the segment frame (origin the proximal joint centre, the joint centre on its z axis)
    the condition ``centre . (marker x wand) = 0`` is ``wand.x marker.y = marker.x
    wand.y``, linearised at the nominal offsets' y (``wand.x - (wand.y0 / marker.y0)
    marker.x = 0``), width ``sigma`` [m] (:func:`wand_width`: the wand's turn about the
    segment's axis, :data:`SIGMA_WAND_ANGLE` before :mod:`mocap_mj.anatomy.axes` decides
    whether the motion or this row places the axis).
    """
    wy, my = (nominal_offset(pset, m)[1] for m in (wand, marker))
    label = f"{wand} in the plane of the joint centre and {marker} (Plug-in Gait's chord)"
    return {f"{wand}.x": 1.0, f"{marker}.x": -wy / my}, 0.0, sigma, label
