"""An identified skeleton against the synthetic truth it was fitted to: joint centres in standard
deviations, flexion axes in degrees, and joints on the wrong side of their marker.

:func:`skeleton_errors` scores a result folder against its synth folder with
:func:`mocap_mj.outputs.score.score` (what ``mocap-mj score`` prints) and adds, over the frames
the result fitted:

* each joint centre's error over its Cramer-Rao bound, ``z_b = e_b / s_b`` (the score's RMS
  error over frames [m] over its RMS bound [m], the bodies some marker follows); an efficient
  fit has an RMS ``z`` near 1;
* each flexion axis (:data:`FLEXION`: knees, ankles, elbows) against the truth's: the angle
  [deg] between the two world-frame axes, RMS over frames;
* each joint centre against the landmark marker beside it (:data:`LANDMARKS`), in that
  marker's segment frame (x forward, y left, z up in the reference pose), along the directions
  in which the anatomy separates them: medial-lateral for a knee, ankle or elbow (the marker on
  the lateral epicondyle or malleolus, the centre some width/2 medial of it), all three for a
  hip (posterior, medial and below its ASIS marker). A component of the truth's
  marker-to-centre vector of at least :data:`FLIP_MIN` whose estimate has the opposite sign by
  more than :data:`FLIP_TOL` is a flipped joint (a knee centre lateral of its knee marker, a
  hip lateral of its ASIS), medians over frames. Other components are placement errors of a
  few millimetres in the truth, whose sign an estimate may differ in without being on the
  wrong side of anything (the joint-centre ``z`` covers them).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mocap_mj.outputs.score import fitted_start, score
from mocap_mj.outputs.write_fit import write_result
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData

from .experiment import synthesize, write_experiment

if TYPE_CHECKING:
    from .config import SynthConfig

__all__ = [
    "AXIS_DEG",
    "FLEXION",
    "FLIP_MIN",
    "FLIP_TOL",
    "LANDMARKS",
    "Z_MAX",
    "Z_RMS",
    "axis_errors",
    "flipped_joints",
    "identify_and_check",
    "skeleton_errors",
]

#: The flexion hinges compared, by base name (``_l``/``_r`` added).
FLEXION: tuple[str, ...] = ("knee_flex", "ankle", "elbow")
#: (joint, body whose origin is its centre, landmark marker without its side letter, the axes
#: of the marker's segment frame along which the anatomy separates them).
LANDMARKS: tuple[tuple[str, str, str, tuple[int, ...]], ...] = (
    ("hip", "thigh", "ASI", (0, 1, 2)),
    ("knee", "shank", "KNE", (1,)),
    ("ankle", "foot", "ANK", (1,)),
    ("elbow", "ulna", "ELB", (1,)),
)
#: A component of the truth's marker-to-centre vector counts from this size [m] ...
FLIP_MIN = 0.010
#: ... and is flipped when the estimate's lies beyond this [m] on the other side.
FLIP_TOL = 0.005
_AXES = {0: ("posterior", "anterior"), 2: ("below", "above")}
#: The targets of an identification on a synthetic truth: joint-centre z RMS over bodies and
#: largest z, largest flexion-axis angle [deg]; and no flipped joint.
Z_RMS, Z_MAX, AXIS_DEG = 1.3, 4.0, 10.0


def _kin(pset: ParameterSet, theta: np.ndarray) -> Kinematics:
    kin = Kinematics(pset)
    kin.set_theta(theta)
    return kin


def axis_errors(
    kins: tuple[Kinematics, Kinematics], qs: tuple[np.ndarray, np.ndarray]
) -> dict[str, float]:
    """RMS over frames of the angle [deg] between the truth's and the estimate's world-frame
    flexion axes, by joint, for the models ``kins`` (truth, estimate) in poses ``qs`` (T, nq).
    The axis is MuJoCo's ``xaxis``: the hinge's in its body's frame before the body's later
    joints (the knee's rotation, the subtalar hinge) turn that frame about other axes."""
    frames = [k.forward(q) for k, q in zip(kins, qs, strict=True)]
    out: dict[str, float] = {}
    for base in FLEXION:
        for side in "lr":
            name = f"{base}_{side}"
            axes = [f.xaxis[:, k.model.joint(name).id] for k, f in zip(kins, frames, strict=True)]
            cos = np.clip(np.sum(axes[0] * axes[1], axis=1), -1.0, 1.0)
            ok = np.isfinite(cos)
            out[name] = float(np.degrees(np.sqrt(np.mean(np.arccos(cos[ok]) ** 2))))
    return out


def _side_words(side: str, axis: int, sign: float) -> str:
    if axis == 1:  # y: left in the reference pose
        lateral = (sign > 0) == (side == "l")
        return "lateral" if lateral else "medial"
    return _AXES[axis][int(sign > 0)]


def flipped_joints(
    pset: ParameterSet, kins: tuple[Kinematics, Kinematics], qs: tuple[np.ndarray, np.ndarray]
) -> list[str]:
    """One line per joint centre on the wrong side of its landmark marker (module docstring)."""
    frames = [k.forward(q) for k, q in zip(kins, qs, strict=True)]
    model = kins[0].model
    out = []
    for joint, body_base, marker_base, along in LANDMARKS:
        for side in "lr":
            marker = f"{side.upper()}{marker_base}"
            if marker not in pset.marker_names:
                continue
            m = pset.marker_index(marker)
            body = model.body(f"{body_base}_{side}").id
            parent = int(model.site_bodyid[m])
            d = [
                np.nanmedian(
                    np.einsum("tji,tj->ti", f.xmat[:, parent], f.xpos[:, body] - f.site_xpos[:, m]),
                    axis=0,
                )
                for f in frames
            ]
            for axis in along:
                truth, est = d[0][axis], d[1][axis]
                if abs(truth) >= FLIP_MIN and est * np.sign(truth) < -FLIP_TOL:
                    out.append(
                        f"{joint}_{side}: centre {abs(est) * 1e3:.0f} mm "
                        f"{_side_words(side, axis, est)} of {marker} (truth: "
                        f"{abs(truth) * 1e3:.0f} mm {_side_words(side, axis, truth)})"
                    )
    return out


def skeleton_errors(
    truth_dir: str | Path, result_dir: str | Path, pset: ParameterSet | None = None
) -> dict[str, Any]:
    """The result folder ``result_dir`` against the synth folder ``truth_dir``.

    Returns
    -------
    dict
        ``score`` (:func:`mocap_mj.outputs.score.score`), ``z`` (body -> joint-centre error
        over its bound), ``z_rms``, ``z_max``, ``z_worst`` (its body), ``axis_deg`` (joint ->
        RMS angle [deg]), ``axis_max_deg``, ``axis_worst``, ``flips`` (lines, empty when none).
    """
    pset = pset or ParameterSet()
    truth_dir, result_dir = Path(truth_dir), Path(result_dir)
    s = score(truth_dir, result_dir, pset=pset, plot=False)
    prior_only = set(s["joint_centres_prior_only"])
    err, bound = s["joint_centre_errors_mm"], s["joint_centre_crlb_by_body_mm"]
    z = {n: err[n] / bound[n] for n in err if n not in prior_only}
    truth = load_motion(truth_dir / "truth_motion.npz", pset.model)
    result = load_motion(result_dir / "motion.npz", pset.model)
    a = fitted_start(truth, result)
    ok = np.all(np.isfinite(result.qpos), axis=1)
    qs = (truth.qpos[a : a + len(result.qpos)][ok], result.qpos[ok])
    kins = (
        _kin(pset, pset.load_json(truth_dir / "truth.json")),
        _kin(pset, pset.load_json(result_dir / "theta.json")),
    )
    axes = axis_errors(kins, qs)
    worst_z = max(z, key=lambda n: z[n])
    worst_axis = max(axes, key=lambda n: axes[n])
    return {
        "score": s,
        "z": z,
        "z_rms": float(np.sqrt(np.mean(np.square(list(z.values()))))),
        "z_max": z[worst_z],
        "z_worst": worst_z,
        "axis_deg": axes,
        "axis_max_deg": axes[worst_axis],
        "axis_worst": worst_axis,
        "flips": flipped_joints(pset, kins, qs),
    }


def identify_and_check(
    cfg: SynthConfig, pset: ParameterSet | None = None, recipe: Recipe | None = None
) -> dict[str, Any]:
    """Synthesize ``cfg``, identify its trial alone with ``mocap_mj.identify`` (``recipe``,
    default: ``identify``'s own), write the result folder and check it against the truth:
    :func:`skeleton_errors` plus ``seconds`` (the identification's), ``marker_rmse_mm``,
    ``implausible`` (the fit's own reasons, those that exit 3) and ``ok`` (the targets
    :data:`Z_RMS`, :data:`Z_MAX`, :data:`AXIS_DEG` met, no flipped joint)."""
    pset = pset or ParameterSet()
    exp = synthesize(cfg, pset)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_experiment(exp, d / "synth")
        t0 = time.perf_counter()
        trial = TrialData(cfg.motion, np.asarray(exp.markers), np.asarray(exp.times))
        fit = identify([trial], recipe or Recipe(), pset=pset)
        seconds = time.perf_counter() - t0
        summary = write_result(fit, d / "result", force=True)
        out = skeleton_errors(d / "synth", d / "result", pset)
    out["seconds"] = seconds
    out["marker_rmse_mm"] = summary["marker_rmse_mm"]
    out["implausible"] = list(summary.get("implausible") or [])
    out["ok"] = (
        out["z_rms"] <= Z_RMS
        and out["z_max"] <= Z_MAX
        and out["axis_max_deg"] <= AXIS_DEG
        and not out["flips"]
    )
    return out
