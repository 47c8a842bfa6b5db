"""The Vicon Plug-in Gait full-body marker set, in the order the bundled model defines its sites.

The order is the model's site order (a depth-first walk of the body tree: pelvis, thorax, head,
left arm, right arm, left leg, right leg), so a (T, 39, 3) marker array indexes like the model.
"""

from __future__ import annotations

MARKER_NAMES: tuple[str, ...] = (
    # pelvis
    "LASI", "RASI", "LPSI", "RPSI",
    # thorax
    "C7", "T10", "CLAV", "STRN", "RBAK",
    # head
    "LFHD", "RFHD", "LBHD", "RBHD",
    # left arm: clavicle, upper arm, radius, hand
    "LSHO", "LUPA", "LELB", "LFRM", "LWRA", "LWRB", "LFIN",
    # right arm
    "RSHO", "RUPA", "RELB", "RFRM", "RWRA", "RWRB", "RFIN",
    # left leg: thigh, shank, foot, toes
    "LTHI", "LKNE", "LTIB", "LANK", "LHEE", "LTOE",
    # right leg
    "RTHI", "RKNE", "RTIB", "RANK", "RHEE", "RTOE",
)  # fmt: skip

#: Left/right partner of every bilateral marker (used for symmetry checks and label-swap tests).
MIRROR: dict[str, str] = {
    name: ("R" + name[1:] if name[0] == "L" else "L" + name[1:])
    for name in MARKER_NAMES
    if name[0] in "LR" and ("R" + name[1:] if name[0] == "L" else "L" + name[1:]) in MARKER_NAMES
}
