"""Plug-in Gait's shoulder joint centre, as the offset of the shoulder marker from it.

Plug-in Gait puts SHO on the acromioclavicular joint and its shoulder centre by a chord
construction (:func:`mocap_mj.clinical.centres.shoulder`): ``ShoulderOffset`` + marker radius
from SHO, in the plane of the thorax origin (CLAV moved a marker radius posterior), SHO and a
virtual wand normal to the thorax's anterior axis, with SHO's offset normal to the line from
the centre to the thorax origin. On the nominal model, with a 50 mm offset, that centre lies
11 mm anterior and 10 mm lateral of the point straight below SHO: the acromioclavicular joint
is medial of the glenohumeral centre. :func:`pig_shoulder_offsets` gives that construction's
offset on the nominal model scaled to the subject's stature, for
:func:`mocap_mj.anatomy.anatomy.landmark_prior`'s shoulder rows, where the set has Plug-in
Gait's thorax markers and the subject's shoulder offset is measured.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mocap_mj.clinical.centres import shoulder
from mocap_mj.clinical.segments import Markers, trunk_frames
from mocap_mj.skeleton.parameters import ParameterSet

#: The markers Plug-in Gait's thorax frame and origin need.
THORAX = ("C7", "T10", "CLAV", "STRN")


def _nominal_world(pset: ParameterSet) -> np.ndarray:
    """Body origins (nbody, 3) [m] of the nominal model in its reference pose (every body
    frame aligned with the world)."""
    model = pset.model
    xpos = np.zeros((model.nbody, 3))
    for b in range(1, model.nbody):
        xpos[b] = xpos[model.body_parentid[b]] + pset.body_pos_nominal[b]
    return xpos


def nominal_sites(pset: ParameterSet, names: list[str]) -> dict[str, np.ndarray] | None:
    """World positions (3,) [m] of the marker sites ``names`` on the nominal model in its
    reference pose, None when one is missing."""
    xpos = _nominal_world(pset)
    offsets = pset.split(pset.nominal)[1]
    out = {}
    for n in names:
        if n not in pset.marker_names:
            return None
        out[n] = xpos[pset.model.site(n).bodyid[0]] + offsets[pset.marker_index(n)]
    return out


def pig_shoulder_offsets(
    pset: ParameterSet, name: Callable[[str], str], distance: dict[str, float], s: float,
    radius: float,
) -> dict[str, np.ndarray]:  # fmt: skip
    """Per side ("l", "r") the offset (3,) [m] of SHO from Plug-in Gait's shoulder centre in
    the thorax frame of the reference pose (the clavicle's there), on the nominal model
    scaled by ``s``, the centre ``distance[side]`` [m] (shoulder offset + marker radius)
    from SHO; ``name`` maps a Plug-in Gait role to the set's marker. The construction
    depends on SHO itself, so SHO is placed where the construction returns the nominal
    glenohumeral centre (a fixed point, to 0.01 mm in a few steps). Empty where the set
    lacks the thorax markers or a shoulder marker."""
    roles = {r: name(r) for r in (*THORAX, "LSHO", "RSHO")}
    sites = nominal_sites(pset, list(roles.values()))
    if sites is None:
        return {}
    m = {r: s * sites[n][None] for r, n in roles.items()}
    thorax = trunk_frames(Markers(m, 1), radius, 0.0)["thorax"]
    xpos = s * _nominal_world(pset)
    out = {}
    for side, p in (("l", "L"), ("r", "R")):
        if side not in distance:
            continue
        try:
            gh, sho = xpos[pset.model.body(f"upperarm_{side}").id][None], m[p + "SHO"]
        except KeyError:  # a custom model without this body
            continue
        for _ in range(8):
            offset = sho - shoulder(thorax.axes, thorax.origin, sho, distance[side] - radius,
                                   radius, side)  # fmt: skip
            sho = gh + offset
        out[side] = offset[0]
    return out
