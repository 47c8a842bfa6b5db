"""report.md's "Joint centres against Plug-in Gait" and summary.json's
``joint_centres_vs_plug_in_gait``: the identified model's joint centres against the bone
points Vicon Nexus stored in each trial's C3D (:mod:`mocap_mj.clinical.nexus_centres`,
:mod:`mocap_mj.clinical.centre_causes`). A file without them gives neither."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.pipeline.fit import Fit
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.joint_centres import JOINT_CENTRE_NAMES, centre_bodies

from ..clinical.centre_causes import explanation
from ..clinical.nexus_centres import (
    COMPONENTS,
    EXPLAIN_ABOVE,
    CentreGap,
    centre_gaps,
    has_bone_points,
    lab_from_ours,
    nexus_crosstalk,
    read_nexus,
    rows_for,
)
from ..errors import MocapError

#: report.md's words for our source of each joint's centre (the hips' and the flexion axes'
#: come from summary.json).
SOURCES = {"shoulder": "SHO and the shoulder offset rows", "wrist": "wrist bar rows"}


def centres_vs_nexus(
    fit: Fit, summary: Mapping[str, Any], trial: int = 0
) -> tuple[list[str], dict[str, Any] | None]:
    """(report lines, summary entry) of trial ``trial``'s joint centres (default the first)
    against Nexus's in its C3D; ([], None) when the file is no C3D or holds no bone points."""
    path = Path(str(fit.trials[trial].name)) if trial < len(fit.trials) else None
    if path is None or path.suffix.lower() != ".c3d" or not path.is_file():
        return [], None
    title = ["## Joint centres against Plug-in Gait", ""]
    try:
        if not has_bone_points(path):
            return [], None
        if fit.motion is None:
            return [*title, "Not compared: the motion was written in chunks (a long "
                    "recording).", ""], None  # fmt: skip
        nexus = read_nexus(path)
    except MocapError as exc:
        return [*title, f"Not compared: {exc}", ""], None
    if nexus is None:
        return [], None
    m = fit.motion[trial]
    model = fit.pset.model_for(fit.theta)
    centres = np.full((len(m.qpos), len(JOINT_CENTRE_NAMES), 3), np.nan)
    pelvis = np.full((len(m.qpos), 3, 3), np.nan)
    bodies, pel = centre_bodies(model), model.body("pelvis").id
    for t, data in rolling.posed(model, m.qpos):
        centres[t], pelvis[t] = data.xpos[bodies], data.xmat[pel].reshape(3, 3)
    rows = rows_for(fit.first_frames[trial] + np.arange(len(m.qpos)), nexus)
    try:
        rot, shift = lab_from_ours(nexus, rows, fit.pset.marker_names, m.markers)
    except MocapError as exc:
        return [*title, f"Not compared: {exc}", ""], None
    ours = {n: centres[:, j] @ rot.T + shift for j, n in enumerate(JOINT_CENTRE_NAMES)}
    regression = summary.get("joint_centres_vs_regression") or {}
    alternatives = _other_hips(regression, ours, pelvis, rot)
    axes = summary.get("joint_axes") or {}
    entries = {}
    for gap in centre_gaps(nexus, rows, ours, alternatives):
        joint, side = gap.joint.rsplit("_", 1)
        talk = nexus_crosstalk(nexus, rows, side) if joint == "knee" else None
        text = explanation(gap, axes.get(gap.joint), talk)
        entries[gap.joint] = entry(gap, _source(gap.joint, regression, axes), text)
    if not entries:
        return [], None
    frames = int(np.sum(rows >= 0))
    record = {"reference": nexus.source, "frames": frames, "centres": entries}
    return report_lines(nexus.source, frames, entries), record


def _other_hips(
    regression: Mapping[str, Any],
    ours: Mapping[str, np.ndarray],
    pelvis: np.ndarray,
    rot: np.ndarray,
) -> dict[str, tuple[str, np.ndarray]]:
    """Per hip, the other regression's centre (Davis's beside Harrington's, or the reverse)
    on our pelvis in every frame (T, 3) [m] in the file's frame: ours moved by the two
    centres' difference in the pelvis frame (summary.json's ``joint_centres_vs_regression``)."""
    out = {}
    for joint in ("hip_l", "hip_r"):
        r = regression.get(joint) or {}
        key = next((k for k in ("davis_mm", "harrington_mm") if r.get(k) is not None), None)
        if key is None or joint not in ours:
            continue
        delta = (np.asarray(r[key]) - np.asarray(r["identified_mm"])) * 1e-3
        name = f"{key[:-3].capitalize()}'s regression"
        out[joint] = (name, ours[joint] + np.einsum("ij,tjk,k->ti", rot, pelvis, delta))
    return out


def _source(joint: str, regression: Mapping[str, Any], axes: Mapping[str, Any]) -> str:
    """report.md's "our source" of ``joint``'s centre."""
    if joint in regression:
        moved = " moved by the data" if regression[joint].get("moved_by_data") else ""
        return f"{regression[joint]['regression']} regression{moved}"
    if joint in axes:
        return ("flexion axis from the markers" if axes[joint].get("source") != "plug-in-gait"
                else "Plug-in Gait's axis row")  # fmt: skip
    return SOURCES.get(joint.split("_")[0], "the fit")


def _named(v: np.ndarray) -> dict[str, float]:
    return {k: float(x) * 1e3 for k, x in zip(COMPONENTS, v, strict=True)}


def entry(gap: CentreGap, source: str, text: str | None) -> dict[str, Any]:
    """summary.json's record of one centre [mm, deg]."""
    out: dict[str, Any] = {
        "nexus_point": gap.point,
        "frames": gap.frames,
        "distance_mm": gap.distance * 1e3,
        "components_mm": _named(gap.components),
        "components_sd_mm": _named(gap.components_sd),
        "our_source": source,
        "explanation": text,
    }  # fmt: skip
    if gap.from_marker is not None and gap.marker_angle is not None:
        out["seen_from_marker"] = {"marker": gap.marker, "ours_mm": gap.from_marker[0] * 1e3,
                                   "nexus_mm": gap.from_marker[1] * 1e3,
                                   "angle_deg": float(np.degrees(gap.marker_angle))}  # fmt: skip
    if gap.bend is not None:
        out["bend_deg"] = [float(np.degrees(b)) for b in gap.bend]
        if gap.bend_corr is not None and gap.bend_slope is not None:
            out["bend_corr"] = gap.bend_corr
            out["bend_slope_mm_per_deg"] = gap.bend_slope * 1e3 * np.pi / 180
    if gap.construction is not None:
        out["plug_in_gait_on_our_proximal"] = {"proximal": gap.proximal,
                                               "to_nexus_mm": gap.construction[0] * 1e3,
                                               "to_ours_mm": gap.construction[1] * 1e3}  # fmt: skip
    if gap.arm_plane is not None:
        out["arm_plane_tilt_deg"] = float(np.degrees(gap.arm_plane[0]))
        out["arm_plane_tilt_flexion_corr"] = gap.arm_plane[1]
    if gap.alternative is not None:
        out["alternative"] = {"name": gap.alternative[0], "to_nexus_mm": gap.alternative[1] * 1e3,
                              "to_ours_mm": gap.alternative[2] * 1e3}  # fmt: skip
    return out


def report_lines(source: str, frames: int, entries: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """report.md's section "Joint centres against Plug-in Gait" of summary entries."""
    lines = [
        "## Joint centres against Plug-in Gait",
        "",
        f"Our joint centres (joint_centres.csv) against the Plug-in Gait bone points Vicon Nexus "
        f"stored in {source}, {frames} frames in common: the median distance and its "
        "components (ours minus Nexus's, in Nexus's segment frame), and for every centre more "
        f"than {EXPLAIN_ABOVE * 1e3:.0f} mm away the figures that say why "
        '(docs/clinical.md, "Joint centres against Nexus\'s").',
        "",
        "| joint | Nexus point | distance (mm) | anterior / lateral / proximal (mm) | our source "
        "| explanation |",
        "|---|---|---|---|---|---|",
    ]
    within = f"within {EXPLAIN_ABOVE * 1e3:.0f} mm"
    for joint, e in entries.items():
        c = e["components_mm"]
        parts = " / ".join("n/a" if not np.isfinite(c[k]) else f"{c[k]:+.0f}" for k in COMPONENTS)
        lines.append(f"| {joint} | {e['nexus_point']} | {e['distance_mm']:.1f} | {parts} | "
                     f"{e['our_source']} | {e['explanation'] or within} |")  # fmt: skip
    return [*lines, ""]
