"""Plug-in Gait's whole-body centre of mass: Nexus' ``CentreOfMass`` and ``CentreOfMassFloor``.

The body is Plug-in Gait's 15 kinetic segments with Dempster's (1955) mass fractions as Plug-in
Gait scales them (Vicon's Plug-in Gait reference guide, "Kinetic modelling"; the fractions sum
to 1): the feet, tibiae, femora, hands, radii and humeri of :data:`~.kinetics.DEMPSTER`, each
centre of mass its fraction of the way from the distal to the proximal end of the link the
kinetics use (:func:`~.kinetics.leg_links`, :func:`~.kinetics.arm_links`), and the trunk:

========  ===========  ===============================================================
segment   mass / body  centre of mass
========  ===========  ===============================================================
pelvis    0.142        0.895 of the way from the mid-point of the hip centres to L5
thorax    0.355        0.63 of the way from C7 to L5, a fixed point of the thorax frame
head      0.081        0.52 head lengths forward of the head's origin, the mesh origin
========  ===========  ===============================================================

Their definitions are the reference guide's footnotes (quoted by biomechZoo's
``segmentCOM_data.m``; Vicon's own code for the pelvis is quoted in pyCGM2's
``bodySegmentParameters.py``) and, for the head's origin, Vicon's Nexus documentation
("Upper body kinematics", Head):

- L5, the top of the fifth lumbar vertebra, lies on the pelvis' z axis through the mid-point of
  the hip centres, 0.925 hip-centre distances above it (:data:`L5_RATIO`).
- Thorax: C7 is the C7 marker moved one marker radius along the thorax' x axis (forward), L5
  the pelvis' L5; both are taken into the thorax frame in every frame and averaged over the
  trial, and the centre of mass lies 0.63 of the way from the mean C7 to the mean L5.
- Head: 0.52 head lengths along the head's x axis (forward) from the head's origin. The
  origin is the mid-point of the front head markers moved by (-0.84, 0, -0.3) head lengths
  in the head's frame, the head length Nexus' head scale (the HED bone's length,
  :func:`~.static.head_size`): the origin of the HED bone points (:mod:`.bones`).

``CentreOfMassFloor`` is the centre of mass projected on the floor: its vertical coordinate
(the trajectory's Z up) set to 0. Both need the kinematics and the body mass only, no plates.
A frame in which a segment's centre of mass cannot be placed (a marker or joint centre
missing) gives NaN; the thorax' point is a mean over the frames that see C7, the thorax and
L5.

:func:`trunk_points` places the same points for the trunk's kinetics (:func:`~.kinetics.
trunk_kinetics`): L5, the thorax' mean C7 and L5, and the neck point (the C7 marker's mean in the
thorax frame); :func:`with_trunk` adds them to the joint centres.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .bones import HEAD_ORIGIN
from .kinetics import DEMPSTER, arm_links, leg_links
from .segments import SIDES, Markers, Segment
from .static import head_size

__all__ = [
    "COM_NAMES",
    "HEAD_COM",
    "L5_RATIO",
    "PELVIS_COM",
    "THORAX_COM",
    "TRUNK_MASS",
    "centre_of_mass",
    "head_com",
    "lumbar5",
    "pelvis_com",
    "pig_centre_of_mass",
    "segment_centres",
    "thorax_com",
    "trunk_points",
    "with_trunk",
]

#: The written points: the whole-body centre of mass and its projection on the floor.
COM_NAMES = ("CentreOfMass", "CentreOfMassFloor")
#: The trunk's mass fractions of the body (Dempster, as Plug-in Gait scales them).
TRUNK_MASS = {"pelvis": 0.142, "thorax": 0.355, "head": 0.081}
#: L5's height above the mid-point of the hip centres along the pelvis' z [hip-centre
#: distances].
L5_RATIO = 0.925
#: The pelvis' centre of mass: its fraction of the way from the hip centres' mid-point to L5.
PELVIS_COM = 0.895
#: The thorax' centre of mass: its fraction of the way from C7 to L5.
THORAX_COM = 0.63
#: The head's centre of mass forward of the head's (mesh) origin [head lengths].
HEAD_COM = 0.52


def lumbar5(pelvis: Segment, centres: Mapping[str, np.ndarray]) -> np.ndarray:
    """L5 (T, 3) [m]: :data:`L5_RATIO` hip-centre distances along the pelvis' z from the
    mid-point of the hip centres ``centres["hip_l"]``, ``["hip_r"]`` (T, 3) [m]."""
    left, right = centres["hip_l"], centres["hip_r"]
    width = np.linalg.norm(left - right, axis=1)
    return 0.5 * (left + right) + (L5_RATIO * width)[:, None] * pelvis.axes[:, :, 2]


def pelvis_com(pelvis: Segment, centres: Mapping[str, np.ndarray]) -> np.ndarray:
    """The pelvis' centre of mass (T, 3) [m]: :data:`PELVIS_COM` of the way from the hip
    centres' mid-point to :func:`lumbar5`."""
    mid = 0.5 * (centres["hip_l"] + centres["hip_r"])
    return mid + PELVIS_COM * (lumbar5(pelvis, centres) - mid)


def _local(seg: Segment, point: np.ndarray) -> np.ndarray:
    """``point`` (T, 3) [m] in ``seg``'s frame (T, 3) [m]."""
    return np.einsum("tji,tj->ti", seg.axes, point - seg.origin)


def thorax_com(thorax: Segment, c7: np.ndarray, l5: np.ndarray, marker_radius: float) -> np.ndarray:
    """The thorax' centre of mass (T, 3) [m]: the point of the thorax frame :data:`THORAX_COM`
    of the way from the trial's mean C7 to its mean L5 in that frame. ``c7`` (T, 3) [m] the
    C7 marker, moved ``marker_radius`` [m] along the thorax' x; ``l5`` (T, 3) [m]
    (:func:`lumbar5`). NaN in every frame when no frame sees both."""
    upper = _local(thorax, c7 + marker_radius * thorax.axes[:, :, 0])
    lower = _local(thorax, l5)
    seen = np.isfinite(upper).all(axis=1) & np.isfinite(lower).all(axis=1)
    if not seen.any():
        return np.full_like(thorax.origin, np.nan)
    top, bottom = upper[seen].mean(axis=0), lower[seen].mean(axis=0)
    point = top + THORAX_COM * (bottom - top)
    return thorax.origin + thorax.axes @ point


def head_com(head: Segment, length: float) -> np.ndarray:
    """The head's centre of mass (T, 3) [m]: :data:`HEAD_COM` head lengths along the head's x
    from its mesh origin, the front head markers' mid-point (``head``'s origin) moved by
    :data:`~.bones.HEAD_ORIGIN` head lengths in the head's frame; ``length`` [m] the head
    length (:func:`~.static.head_size`)."""
    return head.origin + length * (head.axes @ (HEAD_ORIGIN + np.array([HEAD_COM, 0.0, 0.0])))


def segment_centres(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    markers: Mapping[str, np.ndarray],
    marker_radius: float,
) -> dict[str, tuple[float, np.ndarray]]:
    """Each of the 15 segments' mass fraction and centre of mass (T, 3) [m], by segment name
    (``foot_l``..., ``pelvis``, ``thorax``, ``head``). ``segs``, ``centres``: Plug-in Gait's
    segments and joint centres with the trunk and arms
    (:func:`~mocap_mj.clinical.plug_in_gait`'s); ``markers``: ``C7``, ``LFHD``, ``RFHD``
    (T, 3) [m] in the same frame; ``marker_radius`` [m]."""
    out: dict[str, tuple[float, np.ndarray]] = {}
    for s in SIDES:
        for name, _, distal, proximal in (*leg_links(segs, centres, s), *arm_links(centres, s)):
            body = DEMPSTER[name]
            out[f"{name}_{s}"] = (body.mass, distal + body.com * (proximal - distal))
    l5 = lumbar5(segs["pelvis"], centres)
    length = head_size(Markers(markers, len(l5)), marker_radius)
    out["pelvis"] = (TRUNK_MASS["pelvis"], pelvis_com(segs["pelvis"], centres))
    out["thorax"] = (
        TRUNK_MASS["thorax"],
        thorax_com(segs["thorax"], markers["C7"], l5, marker_radius),
    )
    out["head"] = (TRUNK_MASS["head"], head_com(segs["head"], length))
    return out


def centre_of_mass(parts: Mapping[str, tuple[float, np.ndarray]]) -> np.ndarray:
    """The mass-weighted mean (T, 3) [m] of the segments' centres of mass (``parts``: name ->
    (mass fraction, centre of mass (T, 3) [m])); NaN in a frame where any is NaN."""
    total = sum(mass for mass, _ in parts.values())
    return sum((mass * com for mass, com in parts.values()), np.zeros(3)) / total


def pig_centre_of_mass(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    markers: Mapping[str, np.ndarray],
    *,
    marker_radius: float,
    to_lab: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """``CentreOfMass`` and ``CentreOfMassFloor`` (T, 3) [m] in the recording's lab frame.

    ``segs``, ``centres``, ``markers``, ``marker_radius``: as :func:`segment_centres`, in the
    trajectory's Z-up frame; ``to_lab`` (3, 3) the rotation from that frame back to the
    recording's lab frame (default identity). The floor point is the centre of mass with its
    Z-up coordinate 0.
    """
    rot = np.eye(3) if to_lab is None else np.asarray(to_lab, dtype=float)
    com = centre_of_mass(segment_centres(segs, centres, markers, marker_radius))
    floor = com * np.array([1.0, 1.0, 0.0])
    return {"CentreOfMass": com @ rot.T, "CentreOfMassFloor": floor @ rot.T}


def _fixed(seg: Segment, point: np.ndarray) -> np.ndarray:
    """The trial's mean of ``point`` (T, 3) [m] in ``seg``'s frame, as a point of the segment
    (T, 3) [m]; NaN in every frame when no frame sees both."""
    local = np.einsum("tji,tj->ti", seg.axes, point - seg.origin)
    seen = np.isfinite(local).all(axis=1)
    if not seen.any():
        return np.full_like(seg.origin, np.nan)
    return seg.origin + seg.axes @ local[seen].mean(axis=0)


def trunk_points(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    c7: np.ndarray,
    marker_radius: float,
) -> dict[str, np.ndarray]:
    """The trunk's kinetic points (T, 3) [m], to join the joint centres for
    :func:`~.kinetics.pig_kinetics`: ``l5`` (the pelvis' L5), ``thorax_top`` and
    ``thorax_bottom`` (the trial's mean C7, one ``marker_radius`` [m] along the thorax' x from
    the C7 marker ``c7`` (T, 3) [m], and mean L5, in the thorax frame) and ``neck`` (the C7
    marker's mean in the thorax frame). ``segs``: with ``pelvis`` and ``thorax``; ``centres``:
    ``hip_l``, ``hip_r``."""
    thorax = segs["thorax"]
    l5 = lumbar5(segs["pelvis"], centres)
    return {
        "l5": l5,
        "thorax_top": _fixed(thorax, c7 + marker_radius * thorax.axes[:, :, 0]),
        "thorax_bottom": _fixed(thorax, l5),
        "neck": _fixed(thorax, c7),
    }


def with_trunk(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    markers: Mapping[str, np.ndarray],
    marker_radius: float,
) -> dict[str, np.ndarray]:
    """``centres`` with :func:`trunk_points`' points when ``segs`` holds the trunk and arms and
    ``markers`` (name -> (T, 3) [m]) the ``C7`` marker, else a copy of ``centres``."""
    out = dict(centres)
    if {"pelvis", "thorax", "hand_l", "hand_r"} <= set(segs) and "C7" in markers:
        out |= trunk_points(segs, centres, markers["C7"], marker_radius)
    return out
