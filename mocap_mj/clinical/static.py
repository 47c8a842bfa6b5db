"""What a static trial gives Plug-in Gait: whether a trial is static, the static
plantar-flexion and rotation offsets, the head offset of a level head, and the inter-ASIS
distance, leg lengths, foot length and head size measured from the markers.
"""

from __future__ import annotations

import numpy as np

from .geometry import cardan_yxz, frame, relative
from .segments import Markers

#: Markers whose stillness makes a trial static (pelvis and legs).
STILL_MARKERS = ("LASI", "RASI", "LKNE", "RKNE", "LANK", "RANK", "LTOE", "RTOE")
#: A trial is static when these markers stay within this distance [m] of their median
#: positions in 99 % of the frames.
STILL_RADIUS = 0.1


def is_static(m: Markers) -> bool:
    """True when the pelvis and leg markers barely move (a standing calibration trial)."""
    return trial_kind(m) == "static"


def trial_kind(m: Markers) -> str | None:
    """ "static" when every one of :data:`STILL_MARKERS` stays within :data:`STILL_RADIUS` of
    its median position in 99 % of the frames that show it, "dynamic" when one moves farther,
    None when one has no sample (or is absent): then the markers cannot tell."""
    spread = []
    for name in STILL_MARKERS:
        if name not in m:
            return None
        p = m[name]
        ok = np.all(np.isfinite(p), axis=1)
        if ok.sum() < 1:
            return None
        d = np.linalg.norm(p[ok] - np.median(p[ok], axis=0), axis=1)
        spread.append(np.percentile(d, 99))
    return "static" if max(spread) < STILL_RADIUS else "dynamic"


def foot_offsets(raw: np.ndarray, static: np.ndarray, side: str) -> tuple[float, float]:
    """(static plantar flexion, static rotation offset) [rad]: the mean over frames of the
    static foot in the uncorrected foot (``raw``, z from the toe to the ankle centre), as
    Plug-in Gait stores them (plantar flexion about the foot's y, then rotation about its
    x; the rotation offset's sign mirrored on the right)."""
    ang = cardan_yxz(relative(raw, static))
    mean = np.nanmean(ang, axis=0)
    if not np.all(np.isfinite(mean[:2])):
        raise ValueError(f"no frame shows the {side} foot's TOE, HEE and ankle")
    rot = -mean[1] if side == "l" else mean[1]
    return float(-mean[0]), float(rot)


def inter_asis(m: Markers) -> float:
    """Median LASI-RASI distance [m] over the frames that show both."""
    d = np.linalg.norm(m["LASI"] - m["RASI"], axis=1)
    return float(np.nanmedian(d))


def leg_length(m: Markers, side: str) -> float:
    """Leg length estimate [m]: median over frames of ASIS-KNE plus KNE-ANK (the path from
    the ASIS to the malleolus through the knee that the tape measure follows)."""
    p = side.upper()
    d = np.linalg.norm(m[p + "ASI"] - m[p + "KNE"], axis=1) + np.linalg.norm(
        m[p + "KNE"] - m[p + "ANK"], axis=1
    )
    return float(np.nanmedian(d))


def foot_length(m: Markers, side: str, radius: float) -> float:
    """The foot bone's length [m]: the mean heel-toe marker distance over the trial less a
    marker radius (NaN without HEE or TOE)."""
    p = side.upper()
    d = np.linalg.norm(m[p + "HEE"] - m[p + "TOE"], axis=1)
    return float(np.nanmean(d)) - radius if np.any(np.isfinite(d)) else float("nan")


def head_offset(head: np.ndarray) -> float:
    """The head offset [rad] of a level head (Nexus's static "head level"): the mean over the
    frames of the pitch about the head's y (``head`` (T, 3, 3), the head markers' frame) that
    turns its x horizontal, the first angle of the YXZ decomposition of the level head (same
    y, x horizontal) in the head; the head turned by it about its y reads no tilt."""
    up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), head[..., 1].shape)
    level = frame(1, head[..., 1], 0, np.cross(head[..., 1], up))
    pitch = cardan_yxz(relative(head, level))[:, 0]
    if not np.any(np.isfinite(pitch)):
        raise ValueError("no frame shows the four head markers")
    return float(np.nanmean(pitch))


def head_size(m: Markers, radius: float) -> float:
    """The head bone's length [m] (Nexus's head mesh): twice the mean LFHD-RFHD distance over
    the trial less a marker diameter (NaN without them)."""
    d = np.linalg.norm(m["LFHD"] - m["RFHD"], axis=1)
    return 2.0 * (float(np.nanmean(d)) - 2.0 * radius) if np.any(np.isfinite(d)) else float("nan")
