"""Which way is up in a marker file, and the rotation that makes it the model's +Z.

Every rotation here is proper (det = +1, right-handed axes stay right-handed) and maps the
file's vertical axis onto +Z:

====  =========================  ==============================
up    rotation                   (x, y, z) in the file becomes
====  =========================  ==============================
z     identity                   (x, y, z)
-z    180 deg about x            (x, -y, -z)
y     +90 deg about x            (x, -z, y)
-y    -90 deg about x            (x, z, -y)
x     -90 deg about y            (-z, y, x)
-x    +90 deg about y            (z, y, -x)
====  =========================  ==============================
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mocap_mj.errors import UnknownNameError

UP_AXES = ("x", "y", "z", "-x", "-y", "-z")

_ROTATIONS = {
    "z": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-z": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),
    "y": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    "-y": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
    "x": ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
    "-x": ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
}

HEAD_MARKERS = ("LFHD", "RFHD", "LBHD", "RBHD")
TRUNK_MARKERS = ("C7", "CLAV")
FOOT_MARKERS = ("LANK", "RANK", "LHEE", "RHEE", "LTOE", "RTOE")
#: Head-over-feet height [m] below which detection is not trusted (standing adults: ~1.5 m).
MIN_HEIGHT = 0.5
#: The chosen axis must beat the next one by this factor.
MIN_RATIO = 2.0


def normalize_up(up: str) -> str:
    """``up`` in canonical form ("+Z" -> "z"); :class:`UnknownNameError` if not an axis."""
    text = up.strip().lower() if isinstance(up, str) else ""
    text = text[1:] if text.startswith("+") else text
    if text not in UP_AXES:
        raise UnknownNameError("up axis", str(up), UP_AXES)
    return text


def rotation_to_z_up(up: str) -> np.ndarray:
    """The proper rotation (3, 3) taking the ``up`` axis of a file onto +Z.

    Apply it as ``positions @ R.T`` to positions (..., 3).
    """
    return np.array(_ROTATIONS[normalize_up(up)], dtype=np.float64)


def detect_up(positions: np.ndarray, names: Sequence[str]) -> tuple[str | None, str]:
    """Guess the vertical axis from where head markers sit relative to foot markers.

    Parameters
    ----------
    positions : (T, M, 3) float [m]
        Marker positions in the file's axes; NaN where missing.
    names : sequence of M str
        Model marker names of ``positions``' columns.

    Returns
    -------
    up : str or None
        One of :data:`UP_AXES`, or None when the markers cannot tell.
    how : str
        Which markers decided, or why detection was not possible.
    """
    index = {n: i for i, n in enumerate(names)}

    def median_of(group: Sequence[str]) -> np.ndarray | None:
        cols = [index[n] for n in group if n in index]
        if not cols:
            return None
        pts = positions[:, cols].reshape(-1, 3)
        pts = pts[~np.isnan(pts).any(axis=1)]
        return np.median(pts, axis=0) if len(pts) else None

    feet = median_of(FOOT_MARKERS)
    top_names: tuple[str, ...] = HEAD_MARKERS
    top = median_of(top_names)
    if top is None:
        top, top_names = median_of(TRUNK_MARKERS), TRUNK_MARKERS
    if feet is None or top is None:
        return None, "no head (or C7/CLAV) and foot markers with data"
    rise = top - feet
    order = np.argsort(-np.abs(rise))
    best, second = float(abs(rise[order[0]])), float(abs(rise[order[1]]))
    if best < MIN_HEIGHT or best < MIN_RATIO * second:
        return None, (
            f"head-over-feet offset {np.round(rise, 3).tolist()} m has no clear vertical axis"
        )
    axis = "xyz"[int(order[0])]
    up = axis if rise[order[0]] > 0 else "-" + axis
    used = "/".join(n for n in top_names if n in index)
    return up, f"{used} above the foot markers by {best:.2f} m along {up}"
