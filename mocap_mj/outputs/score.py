"""Scoring an identification against the synthetic truth it was made from.

Errors are reported in millimetres (and degrees for joint angles) and set beside their
Cramer-Rao bounds.

Theta has directions the markers cannot determine (identifiability.json), and they are not
straight lines: turning the four head markers about the neck is a rotation, so a truth that
differs from the estimate by a finite turn also differs to second order in the "observable"
directions. The truth is therefore first moved within its class of equivalent models to the
member nearest the estimate (``align_truth``: the joint LM fitted to the truth's noise-free
markers, starting from the estimate, so it moves only in informed directions). The headline
errors are estimate minus aligned truth, projected on the observable subspace; how far the
aligned truth is from the nominal truth (the unobservable part) is reported separately.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.capture.marker_set import marked_bodies
from mocap_mj.errors import InputFileError, excerpt
from mocap_mj.io.strict_json import read_object
from mocap_mj.kernels._threads import single_blas_thread
from mocap_mj.pipeline.motion import Motion, load_motion, read_summary
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.centres import joint_centre_bound
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.ik import IKSolver

if TYPE_CHECKING:
    from mocap_mj.solve.lm import LMResult


#: Median distance [m] between a result's fitted markers and the truth's noise-free markers
#: above which the result was not fitted to this truth (another subject or trial): the
#: synthetic noise, soft-tissue artefact and outliers stay well below it.
SAME_TRIAL_MEDIAN = 0.02


def fitted_start(truth: Motion, result: Motion) -> int:
    """The truth's frame at which ``result``'s first frame lies: the one nearest in time (the
    synth folder's marker files carry the truth's times, whatever their frame numbering)."""
    if not len(result.times) or not len(truth.times):
        return 0
    return int(np.argmin(np.abs(np.asarray(truth.times) - float(result.times[0]))))


def check_same_trial(
    truth_dir: Path, result_dir: Path, truth: Motion, result: Motion, a: int, b: int
) -> None:
    """Raise :class:`InputFileError` unless ``result`` was fitted to frames [a, b) of ``truth``.

    The frame counts must match, and the markers the result was fitted to must lie within
    :data:`SAME_TRIAL_MEDIAN` (median over present samples) of the truth's noise-free markers.
    """
    n_truth, n_res = len(truth.qpos), len(result.qpos)
    if not 0 <= a <= b <= n_truth or b - a != n_res:
        raise InputFileError(
            f"{result_dir}: the result has {n_res} frames (fitted range {a}:{b}) but the truth "
            f"{truth_dir} has {n_truth}: score a result against the synth folder it was fitted to"
        )
    d = np.linalg.norm(result.markers - truth.markers[a:b], axis=2)
    present = np.isfinite(d)
    median = float(np.median(d[present])) if present.any() else float("inf")
    if median > SAME_TRIAL_MEDIAN:
        raise InputFileError(
            f"{result_dir}: its markers are {median * 1e3:.0f} mm (median) from the truth's in "
            f"{truth_dir}: a different subject or trial; score a result against the synth "
            "folder it was fitted to"
        )


def joint_centres(kin: Kinematics, qpos: np.ndarray) -> np.ndarray:
    """World positions (T, nbody - 2, 3) [m] of every body origin but the world and root."""
    return kin.forward(qpos).xpos[:, 2:]


@single_blas_thread
def score(
    truth_dir: str | Path,
    result_dir: str | Path,
    *,
    pset: ParameterSet | None = None,
    plot: bool = True,
) -> dict[str, Any]:
    """Compare an identification folder with the synthetic truth folder it was made from."""
    truth_dir, result_dir = Path(truth_dir), Path(result_dir)
    pset = pset or ParameterSet()
    theta_true = pset.load_json(truth_dir / "truth.json")
    truth_info = read_object(truth_dir / "truth.json", "the synthetic truth (a JSON object)")
    sigma_true = truth_info.get("sigma_m")
    if sigma_true is not None and (
        isinstance(sigma_true, bool)
        or not isinstance(sigma_true, int | float)
        or not 0 <= sigma_true <= 1
    ):
        raise InputFileError(
            f"{truth_dir / 'truth.json'}: sigma_m: expected the marker noise in m within 0..1, "
            f"got {excerpt(sigma_true)}"
        )
    truth_motion = load_motion(truth_dir / "truth_motion.npz", pset.model)
    theta_hat = pset.load_json(result_dir / "theta.json")
    # a result folder is whole only with its summary (a damaged one is named, not scored)
    read_summary(result_dir / "summary.json")
    motion = load_motion(result_dir / "motion.npz", pset.model)
    idf_path = result_dir / "identifiability.json"
    idf = Identifiability.from_json(
        pset, read_object(idf_path, "the identifiability (a JSON object)"), str(idf_path)
    )

    a = fitted_start(truth_motion, motion)
    b = a + len(motion.qpos)
    check_same_trial(truth_dir, result_dir, truth_motion, motion, a, b)
    # The hand's and the forearms' zeros are free (align_gauge_free): an estimate whose zeros
    # differ from the truth's is the same model, and the alignment must not be stopped by the
    # wrist or pronation limits.
    aligned = align_gauge_free(pset, theta_hat, truth_motion.markers[a:b], truth_motion.times[a:b])
    err = theta_hat - aligned
    e_obs, _ = idf.project(err)
    out = _parameter_errors(pset, idf, err, aligned, theta_true)
    out["sigma_true_mm"] = float(truth_info.get("sigma_m", float("nan"))) * 1e3
    kin_hat = Kinematics(pset)
    kin_hat.set_theta(theta_hat)
    out.update(_motion_errors(pset, idf, kin_hat, theta_true, truth_motion.qpos[a:b], motion))
    # Held-out frames: the truth trial's frames outside the fitted range, by IK.
    held = np.r_[0:a, b : len(truth_motion.qpos)]
    out["frames_held_out"] = int(held.size)
    if plot:
        from mocap_mj.io.plots import plot_parameter_errors

        k = pset.n_kappa
        plot_parameter_errors(
            result_dir / "parameter_errors.png",
            pset.kappa_names,
            e_obs[:k],
            idf.param_std[:k],
            title="Kinematic parameters: error vs Cramer-Rao bound",
        )
    if held.size:
        sig = float(truth_info.get("sigma_m", np.nan))
        out.update(_held_out(truth_dir, pset, kin_hat, held, sig))
    return out


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _parameter_errors(
    pset: ParameterSet,
    idf: Identifiability,
    err: np.ndarray,
    aligned: np.ndarray,
    theta_true: np.ndarray,
) -> dict[str, Any]:
    """The parameter part of :func:`score`: the error ``err`` (P,) [m] of the estimate against
    the aligned truth ``aligned`` (P,) [m], projected on the observable directions and beside
    its Cramer-Rao bounds, and the gauge displacement from the nominal truth ``theta_true``."""
    k = pset.n_kappa
    e_obs, e_rest = idf.project(err)
    bk, bo = idf.bound_rms()
    off_err = err[k:].reshape(-1, 3)
    return {
        "kappa_rmse_mm": _rms(e_obs[:k]) * 1e3,
        "offset_rmse_mm": _rms(e_obs[k:]) * 1e3,
        "kappa_crlb_mm": bk * 1e3,
        "offset_crlb_mm": bo * 1e3,
        "kappa_crlb_ratio": _rms(e_obs[:k]) / bk,
        "offset_crlb_ratio": _rms(e_obs[k:]) / bo,
        "theta_observable_rmse_mm": _rms(e_obs) * 1e3,
        "theta_crlb_rms_mm": float(np.sqrt(np.mean(np.diag(idf.crlb)))) * 1e3,
        "kappa_rmse_all_mm": _rms(err[:k]) * 1e3,
        "offset_rmse_all_mm": _rms(err[k:]) * 1e3,
        "unobservable_error_norm_mm": float(np.linalg.norm(e_rest)) * 1e3,
        "gauge_displacement_mm": float(np.linalg.norm(aligned - theta_true)) * 1e3,
        "observable_directions": idf.rank,
        "excluded_directions": int(pset.size - idf.rank),
        "exclusion": (
            f"headline kappa/offset RMS errors are the parts of the error in the {idf.rank} "
            f"observable directions (std <= {idf.observable_std * 1e3:.0f} mm), against the "
            f"truth aligned along the other {pset.size - idf.rank} (see identifiability.json), "
            "which are excluded"
        ),
        "kappa_errors_mm": {
            n: float(e) * 1e3 for n, e in zip(pset.kappa_names, err[:k], strict=True)
        },
        "kappa_std_mm": {
            n: float(s) * 1e3 for n, s in zip(pset.kappa_names, idf.param_std[:k], strict=True)
        },
        "offset_errors_mm": {
            n: float(np.linalg.norm(e)) * 1e3
            for n, e in zip(pset.marker_names, off_err, strict=True)
        },
    }


def _motion_errors(
    pset: ParameterSet,
    idf: Identifiability,
    kin_hat: Kinematics,
    theta_true: np.ndarray,
    q_true: np.ndarray,
    motion: Motion,
) -> dict[str, Any]:
    """The motion part of :func:`score` over the frames the result fitted: joint centre errors
    beside their Cramer-Rao bound, joint angle errors and the marker fit. ``q_true`` (T, nq)
    is the truth's motion over the result's fitted range."""
    out: dict[str, Any] = {}
    ok = np.all(np.isfinite(motion.qpos), axis=1)
    kin_true = Kinematics(pset)
    kin_true.set_theta(theta_true)
    jc = np.linalg.norm(
        joint_centres(kin_hat, motion.qpos[ok]) - joint_centres(kin_true, q_true[ok]), axis=2
    )
    # The headline is over the centres some marker follows; the others (the toes: no marker)
    # are placed by their prior rows alone and have no data bound (listed per body below).
    seen = marked_bodies(kin_hat.model)[2:]
    out["joint_centre_rmse_mm"] = _rms(jc[:, seen]) * 1e3
    out["joint_centre_max_mm"] = float(jc[:, seen].max()) * 1e3
    # Its Cramer-Rao bound: the pose's and the model's uncertainty (solve/centres.py).
    cb = joint_centre_bound(kin_hat, motion.markers[ok], motion.qpos[ok], idf)
    bound = float(np.sqrt(np.mean(cb.total[seen] ** 2)))
    out["joint_centre_crlb_mm"] = bound * 1e3
    out["joint_centre_crlb_ratio"] = _rms(jc[:, seen]) / bound
    out["joint_centre_pose_crlb_mm"] = float(np.sqrt(np.mean(cb.pose[seen] ** 2))) * 1e3
    out["joint_centres_prior_only"] = [n for n, v in zip(cb.names, seen, strict=True) if not v]
    out["joint_centre_errors_mm"] = {
        n: float(np.sqrt(np.mean(e**2))) * 1e3 for n, e in zip(cb.names, jc.T, strict=True)
    }
    out["joint_centre_crlb_by_body_mm"] = {
        n: float(b) * 1e3 for n, b in zip(cb.names, cb.total, strict=True)
    }
    # Joint angles of the joints some marker sees (not the MTP: no marker on the toes).
    dof_seen = marked_bodies(kin_hat.model)[kin_hat.model.dof_bodyid]
    dq = kin_true.difference(q_true[ok], motion.qpos[ok])[:, 6:][:, dof_seen[6:]]
    out["joint_rmse_deg"] = float(np.degrees(_rms(dq)))
    fitted = kin_hat.marker_positions(motion.qpos[ok])
    d = np.linalg.norm(motion.markers[ok] - fitted, axis=2)
    present = np.isfinite(d)
    out["marker_rmse_mm"] = float(np.sqrt(np.mean(d[present] ** 2))) * 1e3
    out["frames_fitted"] = int(ok.sum())
    return out


def _held_out(
    truth_dir: Path, pset: ParameterSet, kin_hat: Kinematics, held: np.ndarray, sig: float
) -> dict[str, float]:
    """The identified model's IK marker RMSE on the truth trial's held-out frames ``held``,
    beside what noise of ``sig`` [m] per coordinate alone would give."""
    measured = _measured(truth_dir, pset)
    ik = IKSolver(kin_hat).solve_trial(measured[held])
    return {
        "heldout_marker_rmse_mm": ik.rmse() * 1e3,
        "heldout_expected_rmse_mm": float(
            np.sqrt(3) * sig * np.sqrt(1 - kin_hat.nv / (3 * pset.n_markers)) * 1e3
        ),
    }


def align_truth(
    pset: ParameterSet, theta_hat: np.ndarray, clean: np.ndarray, times: np.ndarray
) -> np.ndarray:
    """The model equivalent to the truth that is nearest the estimate (P,) [m].

    Fits theta to the truth's noise-free markers (T, M, 3) [m] with the joint LM started at
    (and with its weak prior centred on) the estimate; the fit is exact, and the directions
    the markers cannot determine keep the estimate's values.
    """
    return _align(pset, theta_hat, clean, times).theta


def _align(
    pset: ParameterSet, theta_hat: np.ndarray, clean: np.ndarray, times: np.ndarray
) -> LMResult:
    """The LM of :func:`align_truth`: its theta (P,) [m] and its fit (``marker_rmse`` [m])."""
    from mocap_mj.solve.lm import LMSettings, Tolerances, TrialData, identify_lm

    # From the estimate, near the truth's class: no coarse approach (Tolerances.coarse_frames).
    settings = LMSettings(max_iterations=40, tolerances=Tolerances(tol_noise=1e-3, coarse_frames=0))
    return identify_lm(
        [TrialData("truth", clean, times)], pset=pset, theta0=theta_hat, settings=settings
    )


#: Hinges whose zero angles the markers do not determine: the hand carries one marker (FIN),
#: so turning its zero about the wrist and FIN's offset back fits every frame alike.
GAUGE_HINGES = ("wrist_flex_l", "wrist_dev_l", "wrist_flex_r", "wrist_dev_r")
#: How far :func:`gauge_free` widens them each way [rad].
GAUGE_MARGIN = np.radians(10.0)


def gauge_free(pset: ParameterSet, margin: float = GAUGE_MARGIN) -> ParameterSet:
    """A copy of pset whose ``GAUGE_HINGES`` are ``margin`` [rad] (default ``GAUGE_MARGIN``)
    wider each way, to align the truth with (:func:`align_truth`); the parameters are the same.

    An estimate's hand zero may differ from the truth's by degrees (nothing in the markers
    fixes it), and the truth's poses expressed in the estimate's zero may then cross a wrist
    limit. Aligning within the limits turns the zero until they do not, and the curved part
    of that turn (FIN 8 cm from the wrist, turned 3 degrees: 0.1 mm along its lever) counts
    as an error in the observable directions that the estimate does not have
    (docs/method.md#scoring-against-a-synthetic-truth)."""
    out = ParameterSet(pset.path)
    for j in _gauge_joints(out.model):
        out.model.jnt_range[j] += (-margin, margin)
    return out


def _gauge_joints(model: mujoco.MjModel) -> list[int]:
    """The ids of the model's ``GAUGE_HINGES`` (those it has)."""
    names = {model.joint(j).name for j in range(model.njnt)}
    return [model.joint(n).id for n in GAUGE_HINGES if n in names]


#: The widenings [rad] :func:`align_gauge_free` tries.
GAUGE_MARGINS = tuple(np.radians([10.0, 20.0, 30.0]))
#: The fit [m] of the truth's noise-free markers below which an alignment is exact.
EXACT_FIT = 1e-6


def align_gauge_free(
    pset: ParameterSet, theta_hat: np.ndarray, clean: np.ndarray, times: np.ndarray
) -> np.ndarray:
    """The model equivalent to the truth nearest the estimate theta_hat (P,) [m], the hand's
    zero free: :func:`align_truth` with :func:`gauge_free` widened by each of
    ``GAUGE_MARGINS`` in turn; of the alignments that fit the noise-free markers clean
    (T, M, 3) [m] exactly (RMSE below ``EXACT_FIT``) the one nearest theta_hat (Euclidean),
    else the best fit. The widening stops at the first exact alignment whose poses keep
    ``LIMIT_CLEARANCE`` from the widened limits: there the limits do not act, and the
    solution is one for every wider margin (the common case: one alignment, not three).

    One margin is not enough for every estimate: where the estimate's hand zero lies
    further from the truth's than the margin allows, the alignment has to turn the zero
    (and may stall before it fits), and the turn reads as an error of the estimate (the
    zero's path is curved: its direction at the estimate is not the truth's). A wider margin
    is no cure either: the LM may then walk further along that path before it settles. The
    nearest exact alignment is the definition of :func:`align_truth`'s
    (docs/method.md#scoring-against-a-synthetic-truth). The forearms' zeros and FIN's direction
    are then moved to the members nearest theta_hat in closed form
    (:func:`nearest_forearm_gauge`)."""
    fits = []
    for margin in GAUGE_MARGINS:
        wide = gauge_free(pset, margin)
        fits.append(_align(wide, theta_hat, clean, times))
        if fits[-1].marker_rmse < EXACT_FIT and not _gauge_limit_reached(wide, fits[-1].qpos):
            break  # no pose reached the widened limits: a wider margin aligns the same
    exact = [r for r in fits if r.marker_rmse < EXACT_FIT] or [
        min(fits, key=lambda r: r.marker_rmse)
    ]
    turned = [nearest_forearm_gauge(pset, r.theta, theta_hat) for r in exact]
    return min(turned, key=lambda t: float(np.linalg.norm(t - theta_hat)))


#: The forearms' exact gauges, as (pronation hinge, hand body). The hand carries one marker
#: (FIN) and its hinges meet on the pronation axis, so two turns fit every frame alike: the
#: radius's zero about the pronation axis (its markers turned back, every pronation angle
#: shifted; the wrist's angles re-solved for FIN) and FIN's offset about the wrist (the hand's
#: zero). Only the radius markers' places relative to the axis and FIN's distance from the
#: wrist are determined by the markers (docs/method.md#scoring-against-a-synthetic-truth).
FOREARM_GAUGES = (("pronation_l", "hand_l"), ("pronation_r", "hand_r"))


def nearest_forearm_gauge(
    pset: ParameterSet, theta: np.ndarray, theta_hat: np.ndarray
) -> np.ndarray:
    """theta (P,) [m] moved along the :data:`FOREARM_GAUGES` to the equivalent model nearest
    theta_hat (P,) [m]: each radius's markers turned about the pronation axis by the angle
    that brings them nearest theta_hat's (least squares, closed form), FIN's offset turned
    about the wrist onto theta_hat's direction, its distance kept.

    The turns ignore the joint limits: nothing in the markers fixes either zero, and an
    alignment by the LM (:func:`align_truth`) stops where the truth's poses, in the turned
    zero, reach a limit, and reads the curved rest of the turn as an error of the estimate.
    A side whose model lacks the geometry (the joints absent, the hand with other than one
    marker or with a child body, its hinges not meeting on the pronation axis) is left as
    it is."""
    out = np.array(theta, dtype=float)
    k = pset.n_kappa
    offsets, target = out[k:].reshape(-1, 3), np.asarray(theta_hat, dtype=float)[k:].reshape(-1, 3)
    body_pos = pset.body_pos(out)
    for hinge, hand in FOREARM_GAUGES:
        g = _forearm_geometry(pset.model, body_pos, hinge, hand)
        if g is None:
            continue
        u = _across(offsets[g.radius_markers] - g.pivot, g.axis)
        v = _across(target[g.radius_markers] - g.pivot, g.axis)
        angle = np.arctan2(np.sum(np.cross(u, v) @ g.axis), np.sum(u * v))
        turn = Rotation.from_rotvec(angle * g.axis)
        offsets[g.radius_markers] = g.pivot + turn.apply(offsets[g.radius_markers] - g.pivot)
        lever = offsets[g.fin] - g.wrist
        aim = target[g.fin] - g.wrist
        if np.linalg.norm(aim) > 0:
            offsets[g.fin] = g.wrist + np.linalg.norm(lever) * aim / np.linalg.norm(aim)
    return out


class _Forearm(NamedTuple):
    """A forearm gauge's geometry: the radius's markers (indices), the pronation axis (3,)
    [1] through pivot (3,) [m] in the radius's frame, the hand's marker FIN (index) and the
    wrist's centre (3,) [m] in the hand's frame."""

    radius_markers: np.ndarray
    axis: np.ndarray
    pivot: np.ndarray
    fin: int
    wrist: np.ndarray


def _forearm_geometry(
    model: mujoco.MjModel, body_pos: np.ndarray, hinge: str, hand: str
) -> _Forearm | None:
    """The geometry of one of :data:`FOREARM_GAUGES` in model with body_pos (nbody, 3) [m],
    or None where the gauge does not hold (:func:`nearest_forearm_gauge`)."""
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, hinge)
    h = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, hand)
    if j < 0 or h < 0 or model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
        return None
    radius = int(model.jnt_bodyid[j])
    wrist = [i for i in range(model.njnt) if model.jnt_bodyid[i] == h]
    sites = np.asarray(model.site_bodyid)
    children = [b for b in range(1, model.nbody) if model.body_parentid[b] in (radius, h)]
    if (
        model.body_parentid[h] != radius
        or children != [h]
        or np.count_nonzero(sites == h) != 1
        or len(wrist) < 2
        or any(model.jnt_type[i] != mujoco.mjtJoint.mjJNT_HINGE for i in wrist)
        or np.ptp(model.jnt_pos[wrist], axis=0).max() > 1e-12
    ):
        return None
    axis = np.array(model.jnt_axis[j]) / np.linalg.norm(model.jnt_axis[j])
    pivot = np.array(model.jnt_pos[j], dtype=float)
    quat_xyzw = np.roll(model.body_quat[h], -1)
    centre = body_pos[h] + Rotation.from_quat(quat_xyzw).apply(model.jnt_pos[wrist[0]])
    if np.linalg.norm(_across(centre - pivot, axis)) > 1e-9:
        return None  # the wrist is off the pronation axis: turning its zero moves the hand
    return _Forearm(
        np.flatnonzero(sites == radius),
        axis,
        pivot,
        int(np.flatnonzero(sites == h)[0]),
        np.array(model.jnt_pos[wrist[0]], dtype=float),
    )


def _across(x: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The parts (..., 3) of x (..., 3) across the unit axis (3,)."""
    return x - np.multiply.outer(x @ axis, axis)


#: How near [rad] a pose may come to a widened ``GAUGE_HINGES`` limit for the alignment to
#: count as free of it (:func:`align_gauge_free`).
LIMIT_CLEARANCE = np.radians(1.0)


def _gauge_limit_reached(pset: ParameterSet, qpos: list[np.ndarray]) -> bool:
    """Whether any pose in qpos (list of (T_i, nq) [m, rad]) has a ``GAUGE_HINGES`` angle
    within ``LIMIT_CLEARANCE`` of pset's range."""
    model = pset.model
    for j in _gauge_joints(model):
        lo, hi = model.jnt_range[j]
        for q in qpos:
            angle = q[:, model.jnt_qposadr[j]]
            angle = angle[np.isfinite(angle)]
            if np.any(angle < lo + LIMIT_CLEARANCE) or np.any(angle > hi - LIMIT_CLEARANCE):
                return True
    return False


def _measured(truth_dir: Path, pset: ParameterSet) -> np.ndarray:
    from mocap_mj.io import load_markers

    traj = load_markers(truth_dir / "markers.csv")
    return traj.select(pset.marker_names)


def score_text(s: dict[str, Any]) -> str:
    lines = [
        f"{'quantity':<28}{'error':>10}{'CRLB':>10}{'ratio':>8}",
        f"{'kinematic params (mm RMS)':<28}{s['kappa_rmse_mm']:>10.3f}{s['kappa_crlb_mm']:>10.3f}"
        f"{s['kappa_crlb_ratio']:>8.2f}",
        f"{'marker offsets (mm RMS)':<28}{s['offset_rmse_mm']:>10.3f}{s['offset_crlb_mm']:>10.3f}"
        f"{s['offset_crlb_ratio']:>8.2f}",
        f"{'joint centres (mm RMS)':<28}{s['joint_centre_rmse_mm']:>10.3f}"
        f"{s['joint_centre_crlb_mm']:>10.3f}{s['joint_centre_crlb_ratio']:>8.2f}",
        f"{'joint angles (deg RMS)':<28}{s['joint_rmse_deg']:>10.3f}",
        f"{'marker RMSE fitted (mm)':<28}{s['marker_rmse_mm']:>10.3f}",
    ]
    if "heldout_marker_rmse_mm" in s:
        lines.append(
            f"{'marker RMSE held out (mm)':<28}{s['heldout_marker_rmse_mm']:>10.3f}"
            f"   (noise floor {s['heldout_expected_rmse_mm']:.3f})"
        )
    lines.append(s["exclusion"])
    return "\n".join(lines)


__all__ = ["joint_centres", "score", "score_text"]
