"""Prior rows of the foot: the heel and toe markers, and the MTP joint placed from the toe.

Each function returns rows ``(terms, b, sigma, label)`` (``terms . theta = b`` [m], width
``sigma`` [m]) that :func:`mocap_mj.anatomy.anatomy.landmark_prior` adds.
"""

from __future__ import annotations

import numpy as np

from mocap_mj.anatomy.axis_rows import Row
from mocap_mj.skeleton.parameters import ParameterSet

#: TOE above the MTP joint centre [m] on a 1.75 m adult: half the metatarsal head's height,
#: the dorsal skin and the marker radius.
TOE_ABOVE_MTP = 0.02

#: Standard deviations [m] of the MTP joint centre's position from the ankle centre between
#: adults of one stature, on a 1.75 m adult: ``foot_length`` (the ankle centre to the
#: second metatarsal head, half the foot's length: foot length 0.152 H, Winter 2009, with a
#: 4 % coefficient of variation at a given stature; the ball of the foot at 73 % of it from
#: the heel, ANSUR II) and ``foot_height`` (the ankle centre 0.039 H above the sole, the
#: metatarsal head's centre 20-25 mm above it: the head's radius and the plantar pad).
SIGMA_FOOT_LENGTH, SIGMA_FOOT_HEIGHT = 0.007, 0.008
#: Standard deviation [deg] of the foot's turn about the vertical against the ankle's
#: flexion axis: the heel-to-toe line's angle to the normal of the transmalleolar axis,
#: the difference of the thigh-foot angle and the transmalleolar angle, which spread by
#: 10-20 degrees among healthy adults (Staheli et al., "Lower-extremity rotational
#: problems in children", J Bone Joint Surg Am 67 (1985) 39-47). Where a landmark places
#: the ankle axis (Plug-in Gait's TIB chord plane, a malleolus pair) the heel-toe line may
#: turn by this much in the foot frame, so the axis follows the landmark and the foot turns
#: about it (Plug-in Gait's static ankle rotation: 23 and 9 degrees on the shared
#: Static_trial); elsewhere HEE.y = TOE.y = 0 at the landmark width set the axis normal to
#: the heel-toe line.
SIGMA_FOOT_TURN = 15.0
#: Heel marker to toe marker [m] on the nominal 1.75 m adult (70 mm behind the ankle
#: centre, the MTP joint 140 mm ahead): the lever that turns :data:`SIGMA_FOOT_TURN` into
#: the heel-toe row's width.
HEEL_TO_TOE = 0.21


def foot_rows(
    pset: ParameterSet, side: str, p: str, s: float, turn: bool, lm: float, soft: float
) -> list[Row]:
    """The rows of one side's heel and toe markers, and the MTP joint from the toe marker.

    Plug-in Gait's foot runs rigidly from the ankle centre to TOE, on the second metatarsal
    head: TOE is on the foot body, over the MTP joint, which no marker sees (the toes carry
    none). So the MTP joint (``foot_length``, ``foot_height``) is placed from TOE, below it
    by the dorsal thickness of the forefoot (bone, skin, marker radius), and from the
    stature (the nominal proportions scaled by ``s``, :data:`SIGMA_FOOT_LENGTH`,
    :data:`SIGMA_FOOT_HEIGHT`): TOE's placement varies (over the metatarsal head, on the
    shoe's toe) and the foot frame's pitch is left to the heel rows, so that a joint seen by
    no marker is not placed by one marker's placement alone. With ``turn`` (a landmark
    places the ankle axis) the heel-toe line turns about the foot's z by
    :data:`SIGMA_FOOT_TURN` (one standard deviation), its mid-point held on the foot's x
    axis. ``lm`` and ``soft`` [m]: the widths of a landmark's and of a soft row.
    """
    out: list[Row] = []
    kappa0 = dict(zip(pset.names, pset.nominal, strict=False))
    for name, sigma in (("foot_length", SIGMA_FOOT_LENGTH), ("foot_height", SIGMA_FOOT_HEIGHT)):
        base = kappa0.get(f"{name}_{side}")
        if base is not None:
            out.append(({f"{name}_{side}": 1.0}, base * s, sigma * s,
                        f"{name}_{side} = {base * 1e3:.0f} mm x stature / 1.75 m"))  # fmt: skip
    out.append(({f"{p}HEE.x": 1}, -0.07 * s, soft, f"{p}HEE.x = 70 mm behind the ankle"))
    if turn:
        width = float(np.tan(np.radians(SIGMA_FOOT_TURN))) * HEEL_TO_TOE * s
        label = f"{p}TOE.y = {p}HEE.y (the foot +- {SIGMA_FOOT_TURN:.0f} deg about the z axis)"
        out.append(({f"{p}HEE.y": 0.5, f"{p}TOE.y": 0.5}, 0.0, lm, f"{p}HEE-TOE midpoint y = 0"))
        out.append(({f"{p}TOE.y": 1, f"{p}HEE.y": -1}, 0.0, width, label))
    else:
        out.append(({f"{p}HEE.y": 1}, 0.0, lm, f"{p}HEE.y = 0"))
        out.append(({f"{p}TOE.y": 1}, 0.0, lm, f"{p}TOE.y = 0"))
    out.append(({f"{p}HEE.z": 1}, -0.035 * s, soft, f"{p}HEE.z = 35 mm below the ankle"))
    out.append(({f"{p}TOE.x": 1, f"foot_length_{side}": -1}, 0.0, lm,
                f"{p}TOE.x = foot_length_{side} (over the MTP joint)"))  # fmt: skip
    out.append(({f"{p}TOE.z": 1, f"foot_height_{side}": 1}, TOE_ABOVE_MTP * s, lm,
                f"{p}TOE.z = {TOE_ABOVE_MTP * 1e3:.0f} mm above the MTP joint"))  # fmt: skip
    # Plug-in Gait's foot axis runs from HEE to TOE: the two markers are (nearly: 10 mm on
    # the nominal model) level in the foot frame.
    out.append(({f"{p}HEE.z": 1, f"{p}TOE.z": -1}, -0.01 * s, lm,
                f"{p}HEE level with {p}TOE in the foot frame"))  # fmt: skip
    return out
