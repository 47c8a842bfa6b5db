"""Plug-in Gait's marker roles, filled by any marker set's landmarks.

The anatomical rows (:mod:`mocap_mj.anatomy.anatomy`) are written for the markers of
Plug-in Gait (``LKNE.y = knee centre + knee_width/2 + r``, Harrington's hip centres from
``LASI``, ``RASI``, ``LPSI``, ``RPSI``, ...). What such a row needs is the landmark, not the
name: the lateral femoral epicondyle of the left thigh is ``LKNE`` in Plug-in Gait,
``L_FLE`` in the ISB / CAST set, ``l knee 1`` in the Davis set. :func:`roles` maps each
role of :data:`ROLES` to the marker of a set that sits on its landmark (the side from the
marker's body, ``_l`` / ``_r``, or on an unsided body such as the pelvis or head from its
offset: +y is left), so that every row applies to every set whose markers say where they
sit. A marker that carries a role's own name keeps it (Plug-in Gait maps onto itself). A
sacrum marker stands in for both posterior superior iliac spines when a set has none:
every pelvis row uses only their midpoint, which the sacrum marks (Davis et al. 1991).
Technical markers (wands, clusters) take no role: no chord-plane axis without Plug-in
Gait's wands (:mod:`mocap_mj.anatomy.axes`), the motion places those axes.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from mocap_mj.skeleton.parameters import ParameterSet

#: Landmark -> Plug-in Gait role (side prefix "L" / "R" added for a sided role).
ROLES: dict[str, tuple[str, bool]] = {
    "asis": ("ASI", True),
    "psis": ("PSI", True),
    "lateral_femoral_epicondyle": ("KNE", True),
    "lateral_malleolus": ("ANK", True),
    "calcaneus": ("HEE", True),
    "second_metatarsal_head": ("TOE", True),
    "acromion": ("SHO", True),
    "lateral_humeral_epicondyle": ("ELB", True),
    "radial_styloid": ("WRA", True),
    "ulnar_styloid": ("WRB", True),
    "second_metacarpal_head": ("FIN", True),
    "head_front": ("FHD", True),
    "head_back": ("BHD", True),
    "c7": ("C7", False),
    "t10": ("T10", False),
    "jugular_notch": ("CLAV", False),
    "xiphoid": ("STRN", False),
}


def marker_sides(pset: ParameterSet) -> dict[str, str]:
    """Marker -> "L", "R" or "" (on the midline): from its body's ``_l`` / ``_r`` suffix,
    else from the sign of its nominal offset's y (+y left; within 5 mm: midline)."""
    model = pset.model
    offsets = pset.split(pset.nominal)[1]
    out = {}
    for i, name in enumerate(pset.marker_names):
        body = model.body(int(model.site_bodyid[model.site(name).id])).name
        if body.endswith(("_l", "_r")):
            out[name] = body[-1].upper()
        else:
            y = float(offsets[i][1])
            out[name] = "L" if y > 0.005 else "R" if y < -0.005 else ""
    return out


def roles(pset: ParameterSet, landmarks: Mapping[str, str] | None) -> dict[str, str]:
    """Role (``LKNE``, ``C7``, ...) -> the marker of ``pset`` that fills it, for the
    markers ``landmarks`` (marker -> landmark) names; roles whose name is a marker of
    ``pset`` map onto themselves, and are left out. The first marker of a landmark and side
    (in set order) takes the role."""
    names = set(pset.marker_names)
    sides = marker_sides(pset)
    out: dict[str, str] = {}
    for marker in pset.marker_names:
        landmark = (landmarks or {}).get(marker)
        if landmark not in ROLES:
            continue
        role, sided = ROLES[landmark]
        if sided and not sides[marker]:
            continue
        name = sides[marker] + role if sided else role
        if name not in names and name not in out:
            out[name] = marker
    sacrum = [m for m in pset.marker_names if (landmarks or {}).get(m) == "sacrum"]
    if sacrum and not ({"LPSI", "RPSI"} & (names | set(out))):
        out.update({"LPSI": sacrum[0], "RPSI": sacrum[0]})
    return out


def medial_markers(
    pset: ParameterSet, landmarks: Mapping[str, str] | None, landmark: str, side: str
) -> list[str]:
    """The markers of ``pset`` that ``landmarks`` puts on ``landmark``, on ``side`` ("L"
    or "R", :func:`marker_sides`), in set order."""
    sides = marker_sides(pset)
    return [
        m for m in pset.marker_names if (landmarks or {}).get(m) == landmark and sides[m] == side
    ]


def renamed(text: str, alias: Mapping[str, str]) -> str:
    """``text`` with every whole-word role of ``alias`` replaced by its marker's name."""
    if not alias:
        return text
    pattern = r"\b(" + "|".join(re.escape(r) for r in sorted(alias, key=len, reverse=True)) + r")\b"
    return re.sub(pattern, lambda m: alias[m.group(1)], text)
