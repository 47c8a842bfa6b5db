"""Plug-in Gait joint centres from the markers and the subject values.

Each function takes marker positions (T, 3) [m] (NaN where missing) and returns centres
(T, 3) [m]; NaN propagates, so a frame missing a marker gives NaN in what depends on it.
"""

from __future__ import annotations

import numpy as np

from .geometry import chord, unit

#: Davis et al. (1991): the angles of the hip-centre construction [rad].
DAVIS_THETA = 0.5
DAVIS_BETA = 0.314


def davis_hip(
    pelvis: np.ndarray,
    origin: np.ndarray,
    *,
    leg_length: float,
    asis_trochanter: float,
    inter_asis: float,
    marker_radius: float,
    side: str,
) -> np.ndarray:
    """Hip joint centre (T, 3) [m] of Davis et al. (1991) in the pelvis frame.

    ``pelvis`` (T, 3, 3): the pelvis axes (x anterior, y left, z up), ``origin`` (T, 3) the
    mid-point of the ASIS markers. ``leg_length`` is the mean of the two legs [m], C =
    0.115 leg length - 15.3 mm; the centre lies C cos(theta) sin(beta) - (ASIS-trochanter +
    marker radius) cos(beta) anterior, -(C cos(theta) cos(beta) + (ASIS-trochanter + marker
    radius) sin(beta)) superior and inter-ASIS / 2 - C sin(theta) lateral of the origin.
    """
    c = 0.115 * leg_length - 0.0153
    d = asis_trochanter + marker_radius
    x = c * np.cos(DAVIS_THETA) * np.sin(DAVIS_BETA) - d * np.cos(DAVIS_BETA)
    y = (0.5 * inter_asis - c * np.sin(DAVIS_THETA)) * (1.0 if side == "l" else -1.0)
    z = -c * np.cos(DAVIS_THETA) * np.cos(DAVIS_BETA) - d * np.sin(DAVIS_BETA)
    return origin + pelvis @ np.array([x, y, z])


def wand_direction(
    thorax: np.ndarray, origin: np.ndarray, sho: np.ndarray, side: str
) -> np.ndarray:
    """The virtual shoulder wand (T, 3), a unit direction from the thorax origin: normal to
    the plane of the thorax's anterior axis and the shoulder marker, pointing up (Plug-in
    Gait's construction that stands in for a marker above the acromion)."""
    to_sho = unit(sho - origin)
    x = thorax[..., 0]
    return unit(np.cross(to_sho, x) if side == "r" else np.cross(x, to_sho))


def shoulder(
    thorax: np.ndarray, origin: np.ndarray, sho: np.ndarray, offset: float, radius: float, side: str
) -> np.ndarray:
    """Shoulder joint centre (T, 3) [m]: the chord construction from the wand, the thorax
    origin and the shoulder marker, ``offset`` + marker radius from the marker."""
    wand = origin + wand_direction(thorax, origin, sho, side)
    return chord(wand, origin, sho, offset + radius)


def elbow(
    sjc: np.ndarray,
    elb: np.ndarray,
    wrist_mid: np.ndarray,
    width: float,
    radius: float,
    side: str,
) -> np.ndarray:
    """Elbow joint centre (T, 3) [m]: the chord construction in the plane through the elbow
    marker normal to the arm's plane (shoulder centre, elbow marker, wrist mid-point),
    elbow width / 2 + marker radius from the marker, medial of it."""
    n = unit(np.cross(unit(sjc - elb), unit(wrist_mid - elb)))
    sign = 1.0 if side == "l" else -1.0
    return chord(elb + sign * n, sjc, elb, 0.5 * width + radius)


def wrist(
    wrist_mid: np.ndarray, radius_y: np.ndarray, width: float, radius: float, side: str
) -> np.ndarray:
    """Wrist joint centre (T, 3) [m]: the wrist-bar mid-point moved by wrist width / 2 +
    marker radius along the forearm's y axis ``radius_y`` (T, 3) (against it on the left)."""
    sign = 1.0 if side == "r" else -1.0
    return wrist_mid + sign * (0.5 * width + radius) * radius_y


def hand(
    wrist_mid: np.ndarray, wjc: np.ndarray, fin: np.ndarray, thickness: float, radius: float
) -> np.ndarray:
    """Hand centre (T, 3) [m]: the chord construction from the wrist-bar mid-point, the
    wrist centre and the finger marker, hand thickness / 2 + marker radius from FIN."""
    return chord(wrist_mid, wjc, fin, 0.5 * thickness + radius)
