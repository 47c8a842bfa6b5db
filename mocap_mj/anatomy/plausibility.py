"""Checks of an identified model that real data need: residual per marker, implausible values.

On real recordings the marker RMSE alone says little: 151 parameters and a pose per frame can
absorb soft-tissue artefact into parameters the motion hardly excites (a foot length of a few
millimetres, a forearm of 40 cm). These checks name the markers that fit worst, the
kinematic parameters outside a range (the anatomical ranges of
:mod:`mocap_mj.anatomy.ranges`, which the solver enforces, so none unless the solve ran
without them) and those that ended at a bound of the range; and :func:`implausible_reasons`
says when the fit as a whole cannot describe a person (the command line then exits with a
status of its own, the result written for inspection).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence

import mujoco
import numpy as np

from mocap_mj.capture.landmarks import WIDTH_PAIRS
from mocap_mj.capture.roles import marker_sides
from mocap_mj.capture.subject import HUMAN_RANGES, Subject
from mocap_mj.skeleton.joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.lm import LMResult, TrialData


def marker_rmse_by_marker(
    pset: ParameterSet, result: LMResult, trials: Sequence[TrialData]
) -> np.ndarray:
    """RMS distance [m] (M,) of every marker to its model site over the used frames of all
    trials (NaN for a marker never seen)."""
    kin = Kinematics(pset)
    kin.set_theta(result.theta)
    sq = np.zeros(pset.n_markers)
    count = np.zeros(pset.n_markers)
    for trial, qpos, used in zip(trials, result.qpos, result.used, strict=True):
        if not np.any(used):
            continue
        x = kin.marker_positions(qpos[used])
        d2 = np.sum((np.asarray(trial.markers)[used] - x) ** 2, axis=2)
        ok = np.isfinite(d2)
        sq += np.where(ok, d2, 0.0).sum(axis=0)
        count += ok.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.sqrt(sq / np.maximum(count, 1)), np.nan)


def kappa_outside_bounds(
    pset: ParameterSet,
    theta: np.ndarray,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> dict[str, list[float]]:
    """Kinematic parameters outside [lower, upper] (K,) [m] (default: ``pset``'s bounds):
    ``{name: [value, lower, upper]}`` [m]."""
    kappa, _ = pset.split(theta)
    lower = pset.lower[: pset.n_kappa] if lower is None else lower
    upper = pset.upper[: pset.n_kappa] if upper is None else upper
    out = {}
    for i, name in enumerate(pset.kappa_names):
        lo, hi = float(lower[i]), float(upper[i])
        if not lo <= kappa[i] <= hi:
            out[name] = [float(kappa[i]), lo, hi]
    return out


#: A joint is at a limit within this distance [rad] of it (the solver holds a joint that the
#: markers push past its limit exactly at it).
AT_LIMIT_TOL = np.radians(0.5)
#: Share of the frames at a limit from which a joint is reported (report.md, summary.json).
AT_LIMIT_SHARE = 0.01
#: Share of the frames at a limit from which the command's output names the joint.
AT_LIMIT_PRINT = 0.10


def joints_at_limit(
    model: mujoco.MjModel,
    joint_range: np.ndarray,
    qpos: Sequence[np.ndarray],
) -> dict[str, dict[str, float | str]]:
    """The joints held at a limit in at least :data:`AT_LIMIT_SHARE` of the frames.

    joint_range (njnt, 2) [rad]: the limits the poses were solved with; qpos: each trial's
    poses (T_k, nq) (rows of NaN skipped). A hinge is at its lower or upper limit within
    :data:`AT_LIMIT_TOL`, a ball at its cone (the rotation angle from the reference pose).
    Returns ``{joint: {"share": fraction of frames, "limit": "lower" | "upper" | "cone",
    "limit_deg": the limit [deg]}}`` (the side more often hit), the most held first. A pose
    held at a limit is one the markers asked to go past it: the model's range, a marker's
    placement or the frames' conventions (a pelvis frame tilted by high PSIS markers) are
    then what the lengths nearby absorb.
    """
    q = np.concatenate([np.asarray(x, dtype=float) for x in qpos], axis=0)
    q = q[np.all(np.isfinite(q), axis=1)]
    out: dict[str, dict[str, float | str]] = {}
    if len(q) == 0:
        return out
    for j in range(model.njnt):
        lo, hi = (float(v) for v in joint_range[j])
        if not model.jnt_limited[j] or hi <= lo:
            continue
        adr = int(model.jnt_qposadr[j])
        kind = int(model.jnt_type[j])
        if kind == int(mujoco.mjtJoint.mjJNT_HINGE):
            a = q[:, adr]
            hits = {"lower": (a <= lo + AT_LIMIT_TOL, lo), "upper": (a >= hi - AT_LIMIT_TOL, hi)}
        elif kind == int(mujoco.mjtJoint.mjJNT_BALL):
            w = np.clip(np.abs(q[:, adr]), 0.0, 1.0)
            hits = {"cone": (2.0 * np.arccos(w) >= hi - AT_LIMIT_TOL, hi)}
        else:
            continue
        side, (mask, limit) = max(hits.items(), key=lambda kv: int(kv[1][0].sum()))
        share = float(mask.mean())
        if share >= AT_LIMIT_SHARE:
            out[model.joint(j).name] = {
                "share": share,
                "limit": side,
                "limit_deg": float(np.degrees(limit)),
            }
    return dict(sorted(out.items(), key=lambda kv: -float(kv[1]["share"])))


def plausibility_text(
    pset: ParameterSet,
    per_marker: np.ndarray,
    outside: dict[str, list[float]],
    worst: int = 5,
    at_bound: dict[str, str] | None = None,
    at_limit: dict[str, dict[str, float | str]] | None = None,
) -> str:
    """Readable lines: the worst-fitting markers, the parameters outside their range, those
    held at a bound of it (``{name: "lower" | "upper"}``) and the joints held at a limit in
    at least :data:`AT_LIMIT_PRINT` of the frames (:func:`joints_at_limit`)."""
    order = [int(i) for i in np.argsort(-np.nan_to_num(per_marker, nan=-1.0))[:worst]]
    lines = [
        "worst markers (RMS mm): "
        + ", ".join(f"{pset.marker_names[i]} {per_marker[i] * 1e3:.1f}" for i in order)
    ]
    if outside:
        lines.append(
            "kinematic parameters outside the anatomical range: "
            + ", ".join(
                f"{n} {v * 1e3:.0f} mm [{lo * 1e3:.0f}, {hi * 1e3:.0f}]"
                for n, (v, lo, hi) in outside.items()
            )
        )
    if at_bound:
        lines.append(
            "kinematic parameters held at a bound of their anatomical range (the markers pull "
            "them beyond it; weakly excited or a marker misplaced?): "
            + ", ".join(f"{n} ({b})" for n, b in at_bound.items())
        )
    held = limits_text(at_limit or {}, AT_LIMIT_PRINT)
    if held:
        lines.append(
            "joints held at a limit of their range (share of frames; the markers ask for "
            "more, and the lengths nearby absorb it): " + held
        )
    return "\n".join(lines)


def limits_text(at_limit: dict[str, dict[str, float | str]], least: float = 0.0) -> str:
    """``lumbar_flex lower -30 deg 100 %, ...`` for :func:`joints_at_limit`'s entries held in
    at least ``least`` of the frames (default 0: every entry); "" when none is."""
    return ", ".join(
        f"{n} {v['limit']} {float(v['limit_deg']):.0f} deg {float(v['share']):.0%}"
        for n, v in at_limit.items()
        if float(v["share"]) >= least
    )


#: Paired segment lengths compared left to right (``<name>_length_l/_r``).
PAIRED_LENGTHS = ("thigh", "shank", "upperarm", "forearm", "clavicle", "foot")
#: (joint centre, lateral marker, width measurement): Plug-in Gait puts each centre
#: width/2 + marker radius medial of its marker (the wrist: anterior of the WRA-WRB midpoint).
WIDTH_CHECKS = (("knee", "KNE", "knee_width"), ("ankle", "ANK", "ankle_width"),
                ("elbow", "ELB", "elbow_width"), ("wrist", "WRA", "wrist_width"))  # fmt: skip


def left_right_differences(pset: ParameterSet, theta: np.ndarray) -> dict[str, float]:
    """|left - right| [m] of the paired segment lengths of :data:`PAIRED_LENGTHS`."""
    return {
        seg: abs(float(theta[pset.index(f"{seg}_length_l")] - theta[pset.index(f"{seg}_length_r")]))
        for seg in PAIRED_LENGTHS
    }


def width_errors(
    pset: ParameterSet, theta: np.ndarray, qpos: np.ndarray, markers: np.ndarray, subject: Subject
) -> dict[str, float]:
    """Per measured width: median over frames of |centre - lateral marker| minus (width/2 +
    marker radius) [m], centres of the model theta in poses qpos (T, nq), markers (T, M, 3)
    [m] measured (model order). Keys ``knee_l``, ...; widths not measured, and joints whose
    Plug-in Gait markers the set does not name, are left out."""
    jc = joint_centre_trajectories(pset.model_for(theta), qpos)
    out = {}
    for side, p in (("l", "L"), ("r", "R")):
        for joint, marker, width in WIDTH_CHECKS:
            w = subject.get(f"{width}_{side}")
            needed = [p + marker] + ([p + "WRB"] if marker == "WRA" else [])
            if w is None or not set(needed) <= set(pset.marker_names):
                continue
            m = markers[:, pset.marker_index(p + marker)]
            if marker == "WRA":
                m = 0.5 * (m + markers[:, pset.marker_index(p + "WRB")])
            j = JOINT_CENTRE_NAMES.index(f"{joint}_{side}")
            d = np.nanmedian(np.linalg.norm(jc[:, j] - m, axis=1))
            out[f"{joint}_{side}"] = float(d - (w / 2 + subject.marker_radius))
    return out


#: Marker RMSE [m] above which a fit is implausible. Real recordings fit to 0.5-5 mm (camera
#: noise about 1 mm, soft-tissue artefact of some 5-15 mm on the worst markers); a marker
#: placed or labelled wrong in every frame raises the RMSE over 39 markers by some 15 mm.
#: Beyond 30 mm the model is not the subject: wrong units or measurements, or not a person.
IMPLAUSIBLE_RMSE = 0.030
#: Share of the free kinematic parameters held at a bound of their anatomical range above
#: which a fit is implausible: the markers then pull most of the skeleton outside any
#: person's proportions (real recordings leave none or a few at a bound).
IMPLAUSIBLE_AT_BOUND = 0.5


def implausible_reasons(
    rmse: float, at_bound: int, free_kappa: int, stature: float | None
) -> list[str]:
    """Why a fit cannot describe a person, one line each (empty: plausible).

    rmse [m]: the fit's marker RMSE (non-finite: implausible); ``at_bound`` of the
    ``free_kappa`` free kinematic parameters ended at a bound of their range; stature [m]:
    the stature the markers' long-bone distances imply
    (:func:`mocap_mj.anatomy.initial.marker_stature`; None: unknown), which must lie within
    the human height range (:data:`mocap_mj.capture.subject.HUMAN_RANGES`): a person of a few
    decimetres is a recording in centimetres or inches read as millimetres.
    """
    out = []
    if not np.isfinite(rmse) or rmse > IMPLAUSIBLE_RMSE:
        out.append(
            f"marker RMSE {rmse * 1e3:.4g} mm, above the {IMPLAUSIBLE_RMSE * 1e3:.0f} mm any "
            "person fits to (units, measurements or marker names wrong?)"
        )
    if free_kappa and at_bound > IMPLAUSIBLE_AT_BOUND * free_kappa:
        out.append(
            f"{at_bound} of {free_kappa} kinematic parameters held at a bound of their "
            "anatomical range (measurements or units wrong?)"
        )
    low, high = HUMAN_RANGES["height"]
    if stature is not None and not low <= stature <= high:
        out.append(
            f"stature {stature:.3g} m from the markers, outside any person's "
            f"{low:g}..{high:g} m (the file's length unit wrong? --units)"
        )
    return out


#: Joint (side removed) -> the width whose landmark pair marks it and the joint's child body.
PAIR_JOINTS: dict[str, tuple[str, str]] = {
    "knee": ("knee_width", "shank"),
    "ankle": ("ankle_width", "foot"),
    "elbow": ("elbow_width", "ulna"),
}


def pair_centre_gaps(
    pset: ParameterSet, theta: np.ndarray, landmarks: Mapping[str, str], present: Collection[str]
) -> dict[str, float]:
    """Per joint and side (``knee_l``...) whose lateral and medial landmarks
    (:data:`mocap_mj.capture.landmarks.WIDTH_PAIRS`) two markers of ``present`` mark (``landmarks``:
    marker -> landmark): the distance [m] from the joint centre of the model ``theta`` (P,)
    to the midpoint of the two markers' offsets, in the parent segment's frame in the
    reference pose (the knee extended, where the knee's rolling is zero). Both markers sit
    on the parent segment, so this is the gap in every frame at the ankle and elbow."""
    offsets, centres = pset.split(theta)[1], pset.body_pos(theta)
    sides = marker_sides(pset)
    out = {}
    for joint, (width, child) in PAIR_JOINTS.items():
        for side in "lr":
            on = [
                [m for m in pset.marker_names
                 if m in present and landmarks.get(m) == lm and sides[m] == side.upper()]
                for lm in WIDTH_PAIRS[width]
            ]  # fmt: skip
            if not (on[0] and on[1]):
                continue
            pair = (on[0][0], on[1][0])
            mid = 0.5 * (offsets[pset.marker_index(pair[0])] + offsets[pset.marker_index(pair[1])])
            body = pset.model.body(f"{child}_{side}").id
            out[f"{joint}_{side}"] = float(np.linalg.norm(centres[body] - mid))
    return out
