"""Vicon's Plug-in Gait bone points: per segment an origin (O) and the points one segment
length along its anterior (A, the x axis), lateral (L, the y axis) and proximal (P, the z
axis) directions, as Nexus writes them to place its display meshes.

Codes and lengths: PEL pelvis (origin the mid-point of the hip centres, length the distance
between them), FE femur (knee centre; the hip centre at P), TI tibia (ankle centre; length
the knee-ankle distance less a fifth of the knee width), FO foot (length the trial's mean
heel-toe marker distance less a marker radius, placed so that the ankle centre sits at
(11, -+11, 120) / 169 foot lengths in its frame, the mesh's ankle), TO toe (a third of the
foot's length, distal of the foot's origin, the foot's axes), TRX thorax (the thorax origin;
length the mean of its distances from the two shoulder centres, each frame), HED head
(length the head size, twice the trial's mean LFHD-RFHD distance less a marker diameter; the
origin 0.84 head sizes behind and 0.3 below the mid-point of the front head markers, in the
head's frame), CL clavicle (shoulder centre; the thorax origin at P), HU humerus (elbow
centre; the shoulder centre at P), RA radius (wrist centre; length 0.93 of the elbow-wrist
distance), HN hand (twice the wrist-to-hand-centre distance beyond the wrist centre; the
wrist centre at P).
"""

from __future__ import annotations

import numpy as np

from .segments import SIDES, Segment

#: The head mesh's origin in the head's frame, in head sizes from the front head markers'
#: mid-point (Nexus's placement, reproduced on the shared trials to 1e-5 mm).
HEAD_ORIGIN = np.array([-0.84, 0.0, -0.3])


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
    foot_length: dict[str, float],
    *,
    upper: bool,
    head_size: float = float("nan"),
) -> dict[str, np.ndarray]:
    """Bone points by Vicon name (T, 3) [m] in the frame of the segments; ``knee_width``
    and ``foot_length`` [m] by side (NaN foot length: no foot or toe points); ``head_size``
    [m] the head's length (NaN: head points NaN)."""
    out: dict[str, np.ndarray] = {}
    pel = jc["pelvis"]
    out |= _points("PEL", pel, segs["pelvis"].axes, _dist(jc["hip_l"], jc["hip_r"]))
    for s in SIDES:
        p = s.upper()
        knee, ankle = jc[f"knee_{s}"], jc[f"ankle_{s}"]
        out |= _points(p + "FE", knee, segs[f"femur_{s}"].axes, _dist(jc[f"hip_{s}"], knee))
        tib = _dist(knee, ankle) - knee_width[s] / 5.0
        out |= _points(p + "TI", ankle, segs[f"tibia_torsioned_{s}"].axes, tib)
        foot = segs[f"foot_{s}"].axes
        length = np.full(len(pel), foot_length[s])
        lat = 1.0 if s == "l" else -1.0
        ankle_in_mesh = np.array([11.0, -11.0 * lat, 120.0]) / 169.0
        origin = ankle - foot_length[s] * (foot @ ankle_in_mesh)
        out |= _points(p + "FO", origin, foot, length)
        out |= _points(p + "TO", origin - (foot_length[s] / 3.0) * foot[..., 2], foot, length / 3)
    if not upper:
        return out
    tho, head = segs["thorax"], segs["head"]
    sho = 0.5 * (_dist(tho.origin, jc["shoulder_l"]) + _dist(tho.origin, jc["shoulder_r"]))
    out |= _points("TRX", tho.origin, tho.axes, sho)
    size = np.full(len(pel), head_size)
    origin = head.origin + head_size * (head.axes @ HEAD_ORIGIN)
    out |= _points("HED", origin, head.axes, size)
    for s in SIDES:
        p = s.upper()
        sjc, ejc, wjc, hjc = (jc[f"{k}_{s}"] for k in ("shoulder", "elbow", "wrist", "hand"))
        out |= _points(p + "CL", sjc, segs[f"clavicle_{s}"].axes, _dist(tho.origin, sjc))
        out |= _points(p + "HU", ejc, segs[f"humerus_{s}"].axes, _dist(sjc, ejc))
        out |= _points(p + "RA", wjc, segs[f"radius_{s}"].axes, 0.93 * _dist(ejc, wjc))
        hand_o = wjc + 2.0 * (hjc - wjc)
        out |= _points(p + "HN", hand_o, segs[f"hand_{s}"].axes, _dist(hand_o, wjc))
    return out
