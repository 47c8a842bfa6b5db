"""Vicon's Plug-in Gait bone points: per segment an origin (O) and the points one segment
length along its anterior (A, the x axis), lateral (L, the y axis) and proximal (P, the z
axis) directions, as Nexus writes them for display.

Codes: PEL pelvis (origin the mid-point of the hip centres, length the distance between
them), FE femur (knee centre; hip centre at P), TI tibia (ankle centre; its length the
knee-ankle distance less a fifth of the knee width, as Nexus draws it), FO foot and TO toe
(origin the toe marker), TRX thorax, HED head, CL clavicle (shoulder centre; thorax origin
at P), HU humerus (elbow centre; shoulder centre at P), RA radius (wrist centre), HN hand
(twice the wrist-to-hand-centre distance from the wrist centre; wrist centre at P).
"""

from __future__ import annotations

import numpy as np

from .segments import SIDES, Segment


def _points(
    code: str, origin: np.ndarray, axes: np.ndarray, length: np.ndarray
) -> dict[str, np.ndarray]:
    out = {code + "O": origin}
    for k, letter in enumerate("ALP"):
        out[code + letter] = origin + length[:, None] * axes[..., k]
    return out


def _dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a - b, axis=1)


def bone_points(
    segs: dict[str, Segment],
    jc: dict[str, np.ndarray],
    knee_width: dict[str, float],
    *,
    upper: bool,
) -> dict[str, np.ndarray]:
    """Bone points by Vicon name (T, 3) [m] in the frame of the segments."""
    out: dict[str, np.ndarray] = {}
    pel = jc["pelvis"]
    out |= _points("PEL", pel, segs["pelvis"].axes, _dist(jc["hip_l"], jc["hip_r"]))
    for s in SIDES:
        p = s.upper()
        knee, ankle = jc[f"knee_{s}"], jc[f"ankle_{s}"]
        out |= _points(p + "FE", knee, segs[f"femur_{s}"].axes, _dist(jc[f"hip_{s}"], knee))
        tib = _dist(knee, ankle) - knee_width[s] / 5.0
        out |= _points(p + "TI", ankle, segs[f"tibia_torsioned_{s}"].axes, tib)
        foot = segs[f"foot_{s}"]
        out |= _points(p + "FO", foot.origin, foot.axes, _dist(ankle, foot.origin))
    if not upper:
        return out
    tho = segs["thorax"]
    out |= _points("TRX", tho.origin, tho.axes, _dist(tho.origin, segs["head"].origin))
    head = segs["head"]
    out |= _points("HED", head.origin, head.axes, np.full(len(pel), np.nan))
    for s in SIDES:
        p = s.upper()
        sjc, ejc, wjc, hjc = (jc[f"{k}_{s}"] for k in ("shoulder", "elbow", "wrist", "hand"))
        out |= _points(p + "CL", sjc, segs[f"clavicle_{s}"].axes, _dist(tho.origin, sjc))
        out |= _points(p + "HU", ejc, segs[f"humerus_{s}"].axes, _dist(sjc, ejc))
        out |= _points(p + "RA", wjc, segs[f"radius_{s}"].axes, _dist(ejc, wjc))
        hand_o = wjc + 2.0 * (hjc - wjc)
        out |= _points(p + "HN", hand_o, segs[f"hand_{s}"].axes, _dist(hand_o, wjc))
    return out
