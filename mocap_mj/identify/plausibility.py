"""Checks of an identified model that real data need: residual per marker, implausible values.

On real recordings the marker RMSE alone says little: 151 parameters and a pose per frame can
absorb soft-tissue artefact into parameters the motion hardly excites (a foot length of a few
millimetres, a forearm of 40 cm). These checks name the markers that fit worst, the
kinematic parameters outside a range (the anatomical ranges of
:mod:`mocap_mj.identify.ranges`, which the solver enforces, so none unless the solve ran
without them) and those that ended at a bound of the range.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories
from ..kinematics import Kinematics
from ..parameters import ParameterSet
from ..subject import Subject
from .lm import LMResult, TrialData


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


def plausibility_text(
    pset: ParameterSet,
    per_marker: np.ndarray,
    outside: dict[str, list[float]],
    worst: int = 5,
    at_bound: dict[str, str] | None = None,
) -> str:
    """Readable lines: the worst-fitting markers, the parameters outside their range and
    those held at a bound of it (``{name: "lower" | "upper"}``)."""
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
    return "\n".join(lines)


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
    [m] measured (model order). Keys ``knee_l``, ...; widths not measured are left out."""
    jc = joint_centre_trajectories(pset.model_for(theta), qpos)
    out = {}
    for side, p in (("l", "L"), ("r", "R")):
        for joint, marker, width in WIDTH_CHECKS:
            w = subject.get(f"{width}_{side}")
            if w is None:
                continue
            m = markers[:, pset.marker_index(p + marker)]
            if marker == "WRA":
                m = 0.5 * (m + markers[:, pset.marker_index(p + "WRB")])
            j = JOINT_CENTRE_NAMES.index(f"{joint}_{side}")
            d = np.nanmedian(np.linalg.norm(jc[:, j] - m, axis=1))
            out[f"{joint}_{side}"] = float(d - (w / 2 + subject.marker_radius))
    return out
