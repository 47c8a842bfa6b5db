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

from ..clinical.centre_causes import entry, explanation, report_lines
from ..clinical.nexus_centres import (
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
