"""Knee flexion axes in a standing trial against the pelvis: a thigh wand turned off the knee.

Standing with the feet forward, a knee's flexion axis lies close to the pelvis's lateral axis:
the hip's rotation in quiet standing is a few degrees, and the knee points forward. Plug-in
Gait builds the knee's axis from the thigh wand (the chord plane through the hip centre, THI
and KNE), so a wand placed or bent off the knee's plane turns the axis, the femur's frame and
every hip rotation and knee angle by the same angle; in motion the turned axis shows as knee
varus-valgus that follows flexion (:func:`~mocap_mj.anatomy.axes.knee_crosstalk`). A static
trial alone cannot tell: its data are silent on the axis, and the construction places it
(:mod:`mocap_mj.anatomy.axes`).

:func:`standing_knee_axes` measures, over the frames where the subject stands still (both
knees within :data:`STANDING_FLEXION` of straight and both thighs within it of the vertical,
the pelvis within :data:`STILL_RADIUS` of its median place), the yaw of each knee axis about
the pelvis's vertical from the pelvis's lateral axis, positive turned forward (the knee
pointing inwards, an internal rotation): the identified model's flexion axis, and the
construction's on the recorded markers (the lateral minus the medial knee marker where the
set has both, else KNE minus Plug-in Gait's chord centre hung from the identified hip
centre). :func:`standing_note` reads them: beyond :data:`STANDING_YAW` an axis is not a
standing knee's. Plug-in Gait's figure is the static hip rotation its users check after a
calibration (Nexus's own on the shared Static_trial: 39 and 40 degrees, this module's 40 and
40). It is reported and never changes the fit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from mocap_mj.anatomy.axis_rows import MEDIAL_LANDMARKS
from mocap_mj.capture.roles import medial_markers, roles
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet

from ..clinical.geometry import chord, unit

#: A knee axis turned further than this [rad] from the pelvis's lateral axis in standing is
#: not a standing knee's: quiet standing holds the hip's rotation to some 10 degrees, and the
#: construction's own spread (the wand placed by eye) adds some 5-10; 25 degrees is beyond
#: both. Plug-in Gait reads the same figure as the static hip rotation.
STANDING_YAW = float(np.radians(25.0))
#: A frame is standing when both knees flex and both thighs tilt from the vertical by less
#: than this [rad].
STANDING_FLEXION = float(np.radians(20.0))
#: A standing trial's pelvis stays within this distance [m] of its median place in 99 % of
#: its standing frames (a calibration, not a walk's mid-stance).
STILL_RADIUS = 0.1
#: The share of a trial's fitted frames that must be standing for the figure.
STANDING_SHARE = 0.9


def _yaw(axis: np.ndarray, pelvis: np.ndarray, sign: float) -> np.ndarray:
    """The yaw [rad] (T,) of the axis directions (T, 3) about the pelvis's vertical (its
    frames (T, 3, 3), columns anterior, left, up) from its lateral axis on side ``sign``
    (+1 left, -1 right), positive turned forward; the axis's own sign does not count."""
    x, y, z = (pelvis[:, :, k] for k in range(3))
    flat = axis - np.sum(axis * z, axis=1)[:, None] * z
    lateral = sign * np.sum(flat * y, axis=1)
    forward = np.sum(flat * x, axis=1)
    flip = np.where(lateral < 0, -1.0, 1.0)  # the axis's own sign does not count
    return np.arctan2(flip * forward, flip * lateral)


def _standing(frames: Any, pset: ParameterSet, qpos: np.ndarray) -> np.ndarray:
    """Which of the frames (T,) bool stand: both knees and both thighs (from the vertical,
    the recording's +z) within :data:`STANDING_FLEXION` of straight."""
    model = pset.model
    ok = np.ones(len(qpos), dtype=bool)
    for side in ("l", "r"):
        knee = int(model.jnt_qposadr[model.joint(f"knee_flex_{side}").id])
        top, bottom = (frames.xpos[:, model.body(f"{b}_{side}").id] for b in ("thigh", "shank"))
        tilt = np.arccos(np.clip(unit(top - bottom)[:, 2], -1.0, 1.0))
        ok &= (np.abs(qpos[:, knee]) < STANDING_FLEXION) & (tilt < STANDING_FLEXION)
    return ok


def standing_knee_axes(
    pset: ParameterSet,
    theta: np.ndarray,
    qpos: np.ndarray,
    markers: np.ndarray,
    half_widths: Mapping[str, float],
    landmarks: Mapping[str, str] | None = None,
) -> dict[str, dict[str, float | None]] | None:
    """Per side ("l", "r") the median yaw [rad] of the knee's flexion axis from the pelvis's
    lateral axis in the standing frames of one trial (module docstring): ``identified`` (the
    model ``theta`` (P,) [m] in the poses qpos (T, nq), NaN rows unsolved) and
    ``construction`` (Plug-in Gait's on the recorded ``markers`` (T, M, 3) [m], ``pset``'s
    order, NaN where missing; None without THI and KNE or their samples), with
    ``half_widths`` [m] per side (the knee's width / 2 + marker radius). None when fewer than
    :data:`STANDING_SHARE` of the frames stand or the pelvis moves."""
    model = pset.model
    bodies = ("pelvis", "thigh_l", "thigh_r", "shank_l", "shank_r")
    joints = ("knee_flex_l", "knee_flex_r")
    if len(qpos) == 0 or any(
        mujoco.mj_name2id(model, kind, n) < 0
        for kind, names in ((mujoco.mjtObj.mjOBJ_BODY, bodies), (mujoco.mjtObj.mjOBJ_JOINT, joints))
        for n in names
    ):  # another model than the humanoid's: no figure
        return None
    kin = Kinematics(pset)
    kin.set_theta(np.asarray(theta, dtype=float))
    solved = np.all(np.isfinite(qpos), axis=1)
    if not solved.any():
        return None
    q = np.asarray(qpos, dtype=float)[solved]
    frames = kin.forward(q)
    stand = _standing(frames, pset, q)
    pelvis_pos = frames.xpos[stand, pset.model.body("pelvis").id]
    if stand.sum() < STANDING_SHARE * len(q):
        return None
    spread = np.linalg.norm(pelvis_pos - np.median(pelvis_pos, axis=0), axis=1)
    if np.percentile(spread, 99) > STILL_RADIUS:
        return None
    pelvis = frames.xmat[stand, pset.model.body("pelvis").id]
    m = np.asarray(markers, dtype=float)[solved][stand]
    out: dict[str, dict[str, float | None]] = {}
    for side, sign in (("l", 1.0), ("r", -1.0)):
        axis = frames.xaxis[stand, pset.model.joint(f"knee_flex_{side}").id]
        entry: dict[str, float | None] = {
            "identified": float(np.median(_yaw(axis, pelvis, sign))), "construction": None,
        }  # fmt: skip
        hip = frames.xpos[stand, pset.model.body(f"thigh_{side}").id]
        lateral = _constructed_axis(pset, m, hip, half_widths.get(side), landmarks, side)
        if lateral is not None:
            entry["construction"] = float(np.median(_yaw(lateral[0], pelvis[lateral[1]], sign)))
        out[side] = entry
    return out


def _constructed_axis(
    pset: ParameterSet,
    markers: np.ndarray,
    hip: np.ndarray,
    half: float | None,
    landmarks: Mapping[str, str] | None,
    side: str,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The knee axis the construction gives on the recorded ``markers`` (T, M, 3) [m]: the
    lateral marker minus the medial one where the set has both, else KNE minus Plug-in
    Gait's chord centre on THI and KNE hung from the ``hip`` centres (T, 3) [m] at ``half``
    [m] (the knee's width / 2 + marker radius). Returns the directions (S, 3) of the frames
    that show the markers and which frames (T,) bool they are; None without the markers."""
    p = side.upper()
    alias = roles(pset, landmarks)
    names = set(pset.marker_names)
    kne = alias.get(p + "KNE", p + "KNE")
    medial = medial_markers(pset, landmarks, MEDIAL_LANDMARKS["KNE"][0], p)
    thi = alias.get(p + "THI", p + "THI")
    if kne not in names or not (medial or (thi in names and half is not None)):
        return None
    other = medial[0] if medial else thi
    lateral, second = (markers[:, pset.marker_index(n)] for n in (kne, other))
    seen = np.all(np.isfinite(lateral), axis=1) & np.all(np.isfinite(second), axis=1)
    if not seen.any():
        return None
    if medial:
        return unit(lateral[seen] - second[seen]), seen
    centre = chord(second[seen], hip[seen], lateral[seen], float(half or 0.0))
    return unit(lateral[seen] - centre), seen


def standing_note(axes: Mapping[str, Mapping[str, float | None]] | None, trial: str) -> str | None:
    """One line when a knee axis of ``axes`` (:func:`standing_knee_axes` of the trial named
    ``trial``) lies beyond :data:`STANDING_YAW` from the pelvis's lateral axis; else None."""
    if not axes:
        return None

    def figures(key: str) -> list[float | None]:
        return [axes.get(s, {}).get(key) for s in ("l", "r")]

    def text(values: Sequence[float | None]) -> str:
        return " / ".join("-" if v is None else f"{np.degrees(v):+.0f}" for v in values)

    pig, ours = figures("construction"), figures("identified")
    limit = np.degrees(STANDING_YAW)
    wand = any(v is not None and abs(v) > STANDING_YAW for v in pig)
    turned = any(v is not None and abs(v) > STANDING_YAW for v in ours)
    if not (wand or turned):
        return None
    head = (f"{trial}: standing, the knee axes lie {text(ours)} deg (left / right, + turned "
            f"forward) from the pelvis's lateral axis, Plug-in Gait's construction "
            f"{text(pig)} deg; a standing knee's lies within {limit:.0f} deg")  # fmt: skip
    if wand and not turned:
        return (f"{head}: the knee markers turn the construction's axes (a thigh wand placed "
                "off the knee's plane?); the identified axes are not theirs")  # fmt: skip
    if wand:
        return (f"{head}: the knee markers turn the axes (a thigh wand placed off the knee's "
                "plane?), and this recording cannot place them; identify with a trial where "
                "the knees flex as well, or re-place the markers")  # fmt: skip
    return f"{head}: the identified axes are turned (the knees' markers misplaced?)"


def standing_lines(entries: Mapping[str, Mapping[str, Mapping[str, float | None]]],
                   notes: Sequence[str]) -> list[str]:  # fmt: skip
    """report.md's lines on summary.json's ``standing_knee_axes_deg`` (trial -> side ->
    ``identified``, ``construction`` [deg]) and ``standing_notes``; none without entries."""
    lines = []
    for trial, axes in entries.items():
        figures = [
            f"{side} {axes[side]['identified']:+.1f} (construction "
            + ("-" if axes[side].get("construction") is None
               else f"{axes[side]['construction']:+.1f}") + ")"
            for side in ("l", "r") if side in axes
        ]  # fmt: skip
        lines.append(f"- knee axes in standing, {trial}: {', '.join(figures)} deg from the "
                     "pelvis's lateral axis, + turned forward "
                     "(docs/model.md#knee-axes-in-standing)")  # fmt: skip
    lines += [f"- knee axes: {n}" for n in notes]
    return lines
