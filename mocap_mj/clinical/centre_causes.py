"""Why our joint centres differ from Vicon Nexus's: sentences built from the figures of
:mod:`.nexus_centres` (report.md's table and summary.json's ``joint_centres_vs_plug_in_gait``
hold them: :mod:`mocap_mj.outputs.nexus_out`).

Every centre more than :data:`~.nexus_centres.EXPLAIN_ABOVE` from Nexus's gets a sentence
of measured figures. The figures name a cause only where they show one: Plug-in Gait's
construction hung from our proximal centre lying near Nexus's and far from ours puts the
gap on our own placement, the reverse on the proximal centre; for a hip, Davis's regression
(Plug-in Gait's) on our pelvis lying near Nexus's puts it on the regression; for a flexion
axis, its angle to Plug-in Gait's and the varus-valgus / flexion crosstalk each axis
produces; two centres at the same distance from the joint's marker but apart seen from it
differ by the direction from the marker; a distance that follows the joint's bend, by a
construction that changes with the pose. Where no figure shows a cause the sentence says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .nexus_centres import EXPLAIN_ABOVE, CentreGap

#: One figure explains a gap when it is at most this share of the other (the construction
#: on our proximal centre against Nexus's and against ours).
DOMINANT = 0.5
#: A gap "follows the bend" when the correlation's size reaches this.
BEND_CORR = 0.7
#: A gap is "constant" when every component's standard deviation over the frames is below
#: this [m].
CONSTANT_SD = 0.002
#: A flexion axis this far [deg] from Plug-in Gait's, or two centres this far apart seen
#: from the joint's marker, place the centre in another direction from the marker.
AXIS_ANGLE = 10.0
#: Two centres whose distances from the joint's marker differ by less than this [m] sit at
#: the same depth under it.
SAME_DEPTH = 0.005


def _mm(x: float) -> str:
    return f"{x * 1e3:.0f} mm"


def _sentences(gap: CentreGap, axis: Mapping[str, Any] | None,
               crosstalk: tuple[float, float] | None) -> tuple[list[str], bool]:  # fmt: skip
    """The measured figures of ``gap`` as sentences, the conclusions they support first,
    and whether any of them shows a cause."""
    out: list[str] = []
    shows = False
    if gap.construction is not None:
        to_them, to_us = gap.construction
        text = (f"Plug-in Gait's construction hung from our {gap.proximal} centre lies "
                f"{_mm(to_them)} from Nexus's and {_mm(to_us)} from ours")  # fmt: skip
        if to_them <= DOMINANT * to_us:
            text += f": its placement about the marker moves it, not the {gap.proximal} centre"
        elif to_us <= DOMINANT * to_them:
            text += f": the {gap.proximal} centre it hangs from moves it"
        shows |= ":" in text
        out.append(text)
    if gap.alternative is not None:
        name, to_them, to_us = gap.alternative
        text = f"{name} on our pelvis lies {_mm(to_them)} from Nexus's and {_mm(to_us)} from ours"
        if to_them <= DOMINANT * gap.distance:
            text += f": the regressions differ (Nexus's is {name})"
            shows = True
        out.append(text)
    if gap.arm_plane is not None:
        tilt, corr = gap.arm_plane
        out.append(f"Plug-in Gait's arm plane (through {gap.point[0]}ELB, not the elbow centre) "
                   f"lies {np.degrees(tilt):.0f} deg from the plane of Nexus's own shoulder, "
                   f"elbow and wrist centres (r {corr:+.2f} with its flexion)")  # fmt: skip
    if axis:
        out.append(_axis_text(axis, crosstalk))
        shows |= abs(float(axis["angle_to_pig_deg"])) >= AXIS_ANGLE
    if gap.from_marker is not None and gap.marker_angle is not None:
        ours, theirs = gap.from_marker
        out.append(f"ours lies {_mm(ours)}, Nexus's {_mm(theirs)} from {gap.marker}, "
                   f"{np.degrees(gap.marker_angle):.0f} deg apart seen from it")  # fmt: skip
        # the same depth under the marker, another direction: a convention of direction
        shows |= abs(ours - theirs) < SAME_DEPTH and gap.marker_angle >= np.radians(AXIS_ANGLE)
    if gap.marker_anterior is not None:
        a, b = (f"{v * 1e3:+.0f}" for v in gap.marker_anterior)
        out.append(f"anterior of {gap.marker}: ours {a} mm, Nexus's {b} mm")
    bends = gap.bend_corr is not None and abs(gap.bend_corr) >= BEND_CORR
    if np.all(gap.components_sd < CONSTANT_SD) and not bends:
        out.append(f"the offset is constant (sd under {_mm(CONSTANT_SD)} over the frames)")
    if bends and gap.bend is not None and gap.bend_corr is not None:
        lo, hi = np.degrees(gap.bend)
        slope = (gap.bend_slope or 0.0) * 1e3 * np.pi / 180
        out.append(f"the distance follows our joint's bend ({lo:.0f}-{hi:.0f} deg): "
                   f"r {gap.bend_corr:+.2f}, {slope:+.2f} mm/deg")  # fmt: skip
        shows = True
    return out, shows


def _axis_text(axis: Mapping[str, Any], crosstalk: tuple[float, float] | None) -> str:
    """Our flexion axis's source and angle to Plug-in Gait's, with the crosstalk figures."""
    src = "the markers" if axis.get("source") != "plug-in-gait" else "Plug-in Gait's chord"
    text = f"our flexion axis from {src}, {axis['angle_to_pig_deg']:+.0f} deg to Plug-in Gait's"
    parts = []
    for key, who in (("crosstalk_model", "ours"), ("crosstalk_pig", "Plug-in Gait's axis")):
        c = axis.get(key)
        if c:
            parts.append(f"{who} r {c['corr']:+.2f} slope {c['slope']:+.2f}")
    if crosstalk is not None:
        parts.append(f"Nexus's own r {crosstalk[0]:+.2f} slope {crosstalk[1]:+.2f}")
    if parts:
        text += f"; varus-valgus on flexion (deg/deg): {', '.join(parts)}"
    return text


def explanation(
    gap: CentreGap,
    axis: Mapping[str, Any] | None = None,
    crosstalk: tuple[float, float] | None = None,
) -> str | None:
    """The sentence for ``gap`` (None within :data:`EXPLAIN_ABOVE`): its measured figures;
    ``axis``: summary.json's ``joint_axes`` entry of the joint, ``crosstalk``: Nexus's own
    knee crosstalk (correlation, slope). Says plainly when no figure shows a cause."""
    if gap.distance <= EXPLAIN_ABOVE:
        return None
    found, shows = _sentences(gap, axis, crosstalk)
    if not shows:
        found.append("the tool measures no cause for this joint")
    text = "; ".join(found)
    return text[:1].upper() + text[1:] + "."
