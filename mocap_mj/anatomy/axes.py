"""Knee, ankle, elbow and wrist flexion axes: the motion's where it determines them, Plug-in
Gait's elsewhere.

A flexion axis's turn about its segment's long axis is what a recording determines least: a
static trial or a joint that barely moves leaves it to the priors. Plug-in Gait places it
with the chord construction (:func:`mocap_mj.clinical.geometry.chord`): the joint centre in
the plane of the proximal joint centre, the wand (THI, TIB) and the lateral marker (KNE,
ANK). The landmark prior holds that plane as a row of width
:data:`~mocap_mj.anatomy.axis_rows.SIGMA_WAND_ANGLE` (8 degrees of the axis's turn,
:func:`~mocap_mj.anatomy.axis_rows.pig_axis_row`) in the first solve.

After the first solve, :func:`axis_decisions` measures what the data hold about each row's
direction: the standard deviation of ``a_r . theta`` from the reduced information of the
markers and every other prior (the row's own information taken out), with the markers
weighed at the artefact's noise as the priors are (:mod:`mocap_mj.pipeline.steps`). Where
it exceeds the row's width the recording cannot determine the axis: the axis is Plug-in
Gait's, the row kept at :data:`SIGMA_PIG_AXIS` (and a Plug-in Gait knee's centre at KNE's
level, :func:`mocap_mj.anatomy.anatomy.landmark_prior`); otherwise the axis is functional
and the row is left out, so the motion alone places it. Where the markers' own estimate
contradicts the chord plane (beyond :data:`CONFLICT_K` standard deviations of both) the
conflict is reported; it does not overrule the rule above, since data that place the axis
less well than the wand cannot tell a misplaced wand from their own artefact. Each decision
is reported (summary.json ``joint_axes``, report.md) with both standard deviations in degrees
and, for a functional axis, its angle to Plug-in Gait's chord-plane axis in the identified
model (:func:`pig_angle`). The elbow's row (its axis through ELB) and the wrist's (along
the wrist bar) are decided the same way (:mod:`mocap_mj.anatomy.arm_axes`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mocap_mj.anatomy.arm_axes import ARM_AXES, arm_angle, has_axis, lever
from mocap_mj.anatomy.axis_rows import PIG_AXIS_WANDS, wand_width
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.priors import LinearGaussianPrior

from ..clinical.compare import crosstalk
from ..clinical.geometry import cardan_yxz, chord, frame_zy, relative, unit

#: Width [deg] of the chord-plane row where Plug-in Gait's construction places the axis (the
#: data place it less well than the wand's
#: :data:`~mocap_mj.anatomy.axis_rows.SIGMA_WAND_ANGLE`):
#: tight enough that the identified axis is Plug-in Gait's to a degree or two on the shared
#: Static_trial (``python benchmarks/vicon_pig.py``), loose enough to leave the joints inside
#: their ranges, since the foot turns about the ankle axis
#: (:data:`~mocap_mj.anatomy.foot.SIGMA_FOOT_TURN`) and the tibia about the knee's.
SIGMA_PIG_AXIS = 4.0
#: The data are silent on a knee or ankle axis when their standard deviation exceeds this
#: many widths of the chord-plane row: 17-26 degrees on the shared Static_trial, 10-13 on the
#: ankles of its jump (Movement_trial), where the row keeps the wand's own width.
SILENT = 2.0
#: The recipe's default ``silent_axis_sd`` [rad]: a knee or ankle axis whose direction the
#: markers determine to a standard deviation above it (their Cramer-Rao bound, the row taken
#: out) stays at the construction, its row at :data:`SIGMA_PIG_AXIS`: the joint checks'
#: :data:`~mocap_mj.anatomy.joint_checks.AXIS_DETERMINED_DEG`, 10 degrees. In a static trial
#: the markers leave such an axis in a flat valley, where the solve ends wherever its
#: path stops (Static_trial's left knee 6 degrees off the chord, 9 mm from Nexus' centre,
#: from one start and 2 degrees, 5 mm, from another; held, 2 degrees from both).
SILENT_AXIS_SD = float(np.radians(10.0))
#: The markers and the chord plane conflict when the markers' own estimate of the row's
#: residual lies beyond this many standard deviations of the two combined: reported as
#: ``conflict`` (a wand possibly misplaced). Where the data place the axis better than the
#: wand it is functional anyway; where they place it less well the row stays.
CONFLICT_K = 2.0
#: Wand prefix -> the joint its chord plane places, and that joint's child body.
JOINT_OF = {"THI": ("knee", "shank"), "TIB": ("ankle", "foot")}


def wands(pset: ParameterSet) -> list[tuple[str, str, str, str]]:
    """(wand, lateral marker, joint, side) of every chord plane ``pset`` has markers for."""
    out = []
    for side, p in (("l", "L"), ("r", "R")):
        for wand, marker in PIG_AXIS_WANDS.items():
            if p + wand in pset.marker_names and p + marker in pset.marker_names:
                out.append((p + wand, p + marker, f"{JOINT_OF[wand][0]}_{side}", side))
    return out


def _row(priors: Sequence[LinearGaussianPrior], start: str) -> tuple[np.ndarray, float] | None:
    """The row whose label starts with ``start`` (its ``a`` (P,) and width [m]), None when
    absent."""
    for p in priors:
        for r, label in enumerate(p.labels):
            if label.startswith(start):
                return np.asarray(p.a[r], dtype=float), float(p.sigma[r])
    return None


def axis_rows(pset: ParameterSet) -> list[tuple[str, str, str, str, float]]:
    """Every decidable axis row ``pset`` has markers for: (joint, row key, the label's
    start, the lateral marker, the lever [m] that turns a width into degrees): the knee's
    and ankle's chord planes (:func:`wands`), the elbow's ELB and the wrist bar
    (:mod:`mocap_mj.anatomy.arm_axes`)."""
    out = []
    for wand, marker, joint, _ in wands(pset):
        out.append((joint, wand, f"{wand} in the plane", marker,
                    wand_width(pset, wand, marker, 45.0)))  # fmt: skip
    for side, p in (("l", "L"), ("r", "R")):
        for name, (key, start) in ARM_AXES.items():
            if has_axis(pset, name, p):
                out.append((f"{name}_{side}", p + key, p + start, p + key, lever(pset, name, p)))
    return out


def axis_decisions(
    pset: ParameterSet,
    information: np.ndarray,
    theta: np.ndarray,
    priors: Sequence[LinearGaussianPrior],
    weak: LinearGaussianPrior,
    noise: float,
    solved_noise: float | None = None,
    silent_sd: float = SILENT_AXIS_SD,
) -> dict[str, dict[str, Any]]:
    """Per joint (``knee_l``, ``elbow_r``...): where its flexion axis comes from (module
    docstring).

    ``information`` (P, P): the markers' reduced information (unit weights) at ``theta``
    (P,) [m]; ``priors``: the landmark priors with their axis rows, ``weak`` the weak
    prior toward the initial model; ``noise`` [m]: the marker noise the priors are weighed
    against; ``solved_noise`` [m]: the one they were weighed against in the solve that gave
    ``theta`` (default ``noise``), which sets how far that solve pulled the markers'
    estimate toward the row; ``silent_sd`` [rad]: an axis whose markers' standard deviation
    exceeds it stays Plug-in Gait's whatever the row's width, and a knee or ankle axis is
    then ``silent`` (as beyond :data:`SILENT` row widths: held at the construction,
    :func:`widths`). Returns ``source`` ("plug-in-gait" or "functional"), ``silent``,
    ``conflict`` (the markers contradict the row, :data:`CONFLICT_K`), ``data_sd_deg`` (the
    direction's standard deviation without the row), ``row_sd_deg``, ``row_sigma_m`` and
    ``angle_to_pig_deg`` (:func:`angle_to_pig` at ``theta``); ``wand`` is the row's key
    (:func:`widths`).
    """
    free = ~np.asarray(pset.frozen, dtype=bool)
    solved = noise if solved_noise is None else solved_noise

    def hessian(at: float) -> np.ndarray:
        hess = np.asarray(information, dtype=float) + weak.hessian()
        for p in priors:
            hess = hess + p.with_noise(at).hessian()
        return hess

    def sd_without(hess: np.ndarray, a: np.ndarray, sigma: float, at: float) -> float:
        """The standard deviation [m] of ``a . theta`` without the row (width ``sigma``)."""
        sub = (hess - (at / sigma) ** 2 * np.outer(a, a))[np.ix_(free, free)]
        var = float(a[free] @ np.linalg.lstsq(sub, a[free], rcond=None)[0]) * at**2
        return float(np.sqrt(max(var, 0.0)))

    hess = hessian(noise)
    hess_solved = hess if solved == noise else hessian(solved)
    out: dict[str, dict[str, Any]] = {}
    for joint, key, start, marker, arm in axis_rows(pset):
        row = _row(priors, start)
        if row is None:
            continue
        a, sigma = row
        sd = sd_without(hess, a, sigma, noise)
        # The markers' own estimate of the row's residual, from the solve with the row: a
        # precision-weighted mean of it and the row's 0, at that solve's weighting.
        data = float(a @ theta) * (1.0 + (sd_without(hess_solved, a, sigma, solved) / sigma) ** 2)
        conflict = abs(data) > CONFLICT_K * float(np.hypot(sd, sigma))
        data_sd, row_sd = (float(np.degrees(np.arctan(x / arm))) for x in (sd, sigma))
        beyond = data_sd > np.degrees(silent_sd)  # the recording cannot place it
        d: dict[str, Any] = {
            "joint": joint,
            "wand": key,
            "marker": marker,
            "source": "plug-in-gait" if sd > sigma or beyond else "functional",
            "conflict": conflict,
            "data_sd_deg": data_sd,
            "row_sd_deg": row_sd,
            "row_sigma_m": sigma,
            "silent": bool(joint.startswith(("knee", "ankle"))
                           and (beyond or (sd > sigma and data_sd > SILENT * row_sd))),
        }  # fmt: skip
        d["angle_to_pig_deg"] = angle_to_pig(pset, theta, d)
        out[joint] = d
    return out


def angle_to_pig(pset: ParameterSet, theta: np.ndarray, d: Mapping[str, Any]) -> float:
    """The angle [deg] between the model's axis of decision ``d``'s joint and Plug-in
    Gait's: :func:`pig_angle` for the knee and ankle,
    :func:`~mocap_mj.anatomy.arm_axes.arm_angle` for the elbow and wrist."""
    if d["joint"].startswith(("knee", "ankle")):
        return pig_angle(pset, theta, d["wand"], d["marker"], d["joint"])
    return arm_angle(pset, theta, d["joint"])


def widths(
    pset: ParameterSet, decisions: Mapping[str, Mapping[str, Any]] | None
) -> dict[str, float | None]:
    """The axis rows' widths [m] (keyed by ``wand``) after ``decisions``
    (:func:`axis_decisions`): a Plug-in Gait knee or ankle axis's row at
    :data:`SIGMA_PIG_AXIS` where the data are silent (the decision's ``silent``:
    their standard deviation beyond :data:`SILENT` row widths or the recipe's
    ``silent_axis_sd``), else at its own width (the data about as precise as the
    wand: their weighted mean); the elbow's and wrist's at their own width; a functional
    axis's left out."""
    out: dict[str, float | None] = {}
    for d in (decisions or {}).values():
        if d["source"] != "plug-in-gait":
            out[d["wand"]] = None
        elif d["joint"].startswith(("knee", "ankle")):
            silent = d.get("silent", d["data_sd_deg"] > SILENT * d["row_sd_deg"])
            angle = SIGMA_PIG_AXIS if silent else d["row_sd_deg"]
            out[d["wand"]] = wand_width(pset, d["wand"], d["marker"], angle)
        else:
            out[d["wand"]] = float(d["row_sigma_m"])
    return out


def pig_angle(pset: ParameterSet, theta: np.ndarray, wand: str, marker: str, joint: str) -> float:
    """Angle [deg] between the identified model's flexion axis of ``joint`` and Plug-in
    Gait's chord-plane axis built from the same model: in the parent segment's frame, the
    chord construction (:func:`~mocap_mj.clinical.geometry.chord`) from the wand's and the
    lateral marker's offsets and the proximal joint centre (the frame's origin), at the
    marker's distance from the identified joint centre; both axes taken normal to the
    segment's long axis (origin to joint centre)."""
    side = joint[-2:]
    body = {"knee": "shank", "ankle": "foot"}[joint[:-2]] + side
    centre = pset.body_pos(theta)[pset.model.body(body).id]
    offsets = pset.split(theta)[1]
    w, m = (offsets[pset.marker_index(n)] for n in (wand, marker))
    delta = float(np.linalg.norm(m - centre))
    origin = np.zeros(3)
    pig = chord(w[None], origin[None], m[None], delta)[0]
    long_axis = unit(centre - origin)
    ours_dir, pig_dir = (unit(v - np.dot(v, long_axis) * long_axis) for v in (m - centre, m - pig))
    cos = float(np.clip(np.dot(ours_dir, pig_dir), -1.0, 1.0))
    sign = np.sign(np.dot(np.cross(pig_dir, ours_dir), long_axis)) or 1.0
    return float(sign * np.degrees(np.arccos(cos)))


#: Joint -> the bodies whose markers its flexion axis moves (the side appended).
AXIS_BODIES = {"knee": ("thigh", "shank"), "ankle": ("shank", "foot"),
               "elbow": ("upperarm", "radius"), "wrist": ("radius", "hand")}  # fmt: skip


def axis_rmse(
    pset: ParameterSet,
    fits: Mapping[str, tuple[np.ndarray, Sequence[np.ndarray]]],
    markers: Sequence[np.ndarray],
    decisions: Mapping[str, dict[str, Any]],
) -> None:
    """Add each functional axis's marker RMSE [m] to ``decisions`` (in place):
    ``rmse_m`` = {fit name: RMSE of the markers on the joint's two bodies
    (:data:`AXIS_BODIES`)}, for each of ``fits`` (name -> (theta (P,) [m], qpos per trial
    (T_i, nq), NaN rows for frames not solved)); markers (T_i, M, 3) [m] per trial. Called
    with the first solve (Plug-in Gait's row held) and the final one (the row left out)."""
    functional = {j: d for j, d in decisions.items() if d["source"] == "functional"}
    if not functional:
        return
    kin = Kinematics(pset)
    errors = {}
    for name, (theta, qpos) in fits.items():
        kin.set_theta(theta)
        parts = []
        for q, m in zip(qpos, markers, strict=True):
            ok = np.all(np.isfinite(q), axis=1)
            if ok.any():
                parts.append(np.linalg.norm(kin.marker_positions(q[ok]) - m[ok], axis=-1))
        errors[name] = np.concatenate(parts) if parts else np.zeros((0, pset.n_markers))
    for joint, d in functional.items():
        bodies = [pset.model.body(b + joint[-2:]).id for b in AXIS_BODIES[joint[:-2]]]
        on = np.isin(pset.site_body, bodies)
        d["rmse_m"] = {}
        for name, e in errors.items():
            sub = e[:, on]
            sub = sub[np.isfinite(sub)]
            d["rmse_m"][name] = float(np.sqrt(np.mean(sub**2))) if sub.size else None


def knee_crosstalk(
    pset: ParameterSet,
    theta: np.ndarray,
    qpos: Sequence[np.ndarray],
    markers: Sequence[np.ndarray],
    decisions: Mapping[str, dict[str, Any]],
) -> None:
    """Add each knee's varus-valgus / flexion crosstalk to ``decisions`` (in place): the
    Pearson correlation and the regression slope [deg/deg] of varus-valgus on flexion over
    the frames (qpos (T_i, nq) and markers (T_i, M, 3) [m] per trial, pooled), for the
    identified axis (``crosstalk_model``) and for Plug-in Gait's (``crosstalk_pig``: the
    chord construction in every frame from the measured wand and knee markers and the
    identified hip centre), the femur's frame from that axis and the hip and knee centres,
    the tibia's from the identified knee and ankle centres and shank (Plug-in Gait's Cardan
    sequence, :func:`~mocap_mj.clinical.geometry.cardan_yxz`). A well-placed flexion axis
    shows little. Knees that flex less than
    :data:`~mocap_mj.clinical.compare.CROSSTALK_MIN_RANGE` get None."""
    knees = {j: d for j, d in decisions.items() if j.startswith("knee")}
    if not knees:
        return
    model = pset.model_for(theta)
    q = np.concatenate([np.asarray(x, dtype=float) for x in qpos])
    mk = np.concatenate([np.asarray(x, dtype=float) for x in markers])
    xpos = np.full((len(q), model.nbody, 3), np.nan)
    xmat = np.full((len(q), model.nbody, 3, 3), np.nan)
    for t, data in rolling.posed(model, q):
        xpos[t], xmat[t] = data.xpos, data.xmat.reshape(-1, 3, 3)
    offsets = pset.split(theta)[1]
    for joint, d in knees.items():
        side = joint[-2:]
        thigh, shank, foot = (model.body(b + side).id for b in ("thigh", "shank", "foot"))
        hip, knee, ankle = xpos[:, thigh], xpos[:, shank], xpos[:, foot]
        centre = pset.body_pos(theta)[shank]
        delta = float(np.linalg.norm(offsets[pset.marker_index(d["marker"])] - centre))
        wand, kne = (mk[:, pset.marker_index(n)] for n in (d["wand"], d["marker"]))
        lat = 1.0 if side == "_l" else -1.0
        pig_y = lat * unit(kne - chord(wand, hip, kne, delta))
        tibia = frame_zy(knee - ankle, xmat[:, shank, :, 1])
        for key, y in (("crosstalk_model", xmat[:, thigh, :, 1]), ("crosstalk_pig", pig_y)):
            angles = np.degrees(cardan_yxz(relative(frame_zy(hip - knee, y), tibia)))
            d[key] = _slope(angles[:, 0], angles[:, 1])


def _slope(flexion: np.ndarray, varus: np.ndarray) -> dict[str, float] | None:
    """:func:`~mocap_mj.clinical.compare.crosstalk` as summary.json records it."""
    talk = crosstalk(flexion, varus)
    return None if talk is None else {"corr": talk[0], "slope": talk[1]}
