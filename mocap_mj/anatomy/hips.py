"""Plug-in Gait's hip centres (Davis et al. 1991) as prior rows on theta.

A recipe's ``hip_centre: davis`` places the hip centres as Plug-in Gait does
(:func:`mocap_mj.clinical.centres.davis_hip`), in place of Harrington et al. (2007)
(:mod:`mocap_mj.anatomy.anatomy`): from the mean leg length, the ASIS-trochanter distance
(measured, else Plug-in Gait's regression on the leg length) and the ASIS markers' distance.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mocap_mj.capture.subject import Subject

from ..clinical.centres import DAVIS_BETA, DAVIS_THETA
from ..errors import MocapError

Row = tuple[dict[str, float], float, str]


def davis_rows(subject: Subject, side: str, nominal: Mapping[str, float]) -> list[Row]:
    """The rows ``(terms, b, label)`` (``terms . theta = b`` [m]) of one hip centre.

    Davis's offsets are in Plug-in Gait's pelvis frame, whose x axis runs from mid-PSIS to
    mid-ASIS: written relative to those markers (their heights over the ``nominal`` (name
    -> value) ASIS-PSIS depth give the frame's tilt), so that the rows hold however the
    pelvis frame tilts against its markers. The lateral offset is half the ASIS
    markers' distance (linear in theta) less ``C sin(theta)``. Raises
    :class:`~mocap_mj.errors.MocapError` without both leg lengths.
    """
    legs = [subject.get(f"leg_length_{x}") for x in ("l", "r")]
    if legs[0] is None or legs[1] is None:
        raise MocapError(
            "hip_centre davis: Davis's hip centre needs both leg lengths (LegLength in the "
            "C3D file, or leg_length_l and leg_length_r in --subject-file)"
        )
    leg = 0.5 * (legs[0] + legs[1])
    atd = subject.asis_trochanter(side)  # both leg lengths given: never None
    assert atd is not None
    c, d = 0.115 * leg - 0.0153, atd + subject.marker_radius
    x = c * np.cos(DAVIS_THETA) * np.sin(DAVIS_BETA) - d * np.cos(DAVIS_BETA)
    z = -c * np.cos(DAVIS_THETA) * np.cos(DAVIS_BETA) - d * np.sin(DAVIS_BETA)
    depth = 0.5 * sum(nominal.get(f"{m}ASI.x", 0.0) - nominal.get(f"{m}PSI.x", 0.0) for m in "LR")
    if depth <= 0:
        raise MocapError("hip_centre davis: the model has no ASIS and PSIS markers")
    # Plug-in Gait's x axis, mid-PSIS to mid-ASIS, is this frame's x turned down by t,
    # sin t = (mid-PSIS.z - mid-ASIS.z) / depth: linear in the offsets at the nominal depth,
    # so the rows follow the markers whatever the frame's own tilt (cos t ~ 1).
    tilt = {f"{m}PSI.z": 0.5 / depth for m in "LR"} | {f"{m}ASI.z": -0.5 / depth for m in "LR"}
    sign = 1.0 if side == "l" else -1.0
    # hip = mid-ASIS + x ex + z ez, ex = (1, 0, -sin t), ez = (sin t, 0, 1); hip_depth and
    # hip_height point back and down.
    depth_terms = {f"hip_depth_{side}": 1.0, "LASI.x": 0.5, "RASI.x": 0.5}
    height_terms = {f"hip_height_{side}": 1.0, "LASI.z": 0.5, "RASI.z": 0.5}
    for name, k in tilt.items():
        depth_terms[name] = depth_terms.get(name, 0.0) + z * k
        height_terms[name] = height_terms.get(name, 0.0) - x * k
    return [
        (depth_terms, float(-x), f"hip_depth_{side} (Davis 1991)"),
        (height_terms, float(-z), f"hip_height_{side} (Davis 1991)"),
        ({f"hip_width_{side}": 1.0, "LASI.y": -0.5 * sign - 0.5, "RASI.y": -0.5 * sign + 0.5},
         float(-c * np.sin(DAVIS_THETA)), f"hip_width_{side} (Davis 1991)"),
    ]  # fmt: skip
