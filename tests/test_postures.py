"""Synthetic postures and headings: each posture is what it says, the heading turns every marker
about the vertical, the same seed gives the same capture; and ``identify`` recovers the truth
in each posture within its bound, with no joint on the wrong side of its marker."""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import mujoco
import numpy as np
import pytest
from test_synth_motion import check_limits, max_accelerations

from mocap_mj import ParameterSet
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_synth import POSES, ConfigError, SynthConfig, synthesize
from mocap_synth import postures as pz
from mocap_synth.motion import generate
from mocap_synth.truth_checks import (
    AXIS_DEG,
    Z_MAX,
    Z_RMS,
    axis_errors,
    flipped_joints,
    identify_and_check,
)

DOWN = np.array([0.0, 0.0, -1.0])


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return ParameterSet().model


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angles [deg] between vectors (..., 3)."""
    cos = np.sum(u * v, -1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _bodies(model: mujoco.MjModel, qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Body origins (T, 3) [m] by name, and the sites' heights (T, nsite) [m] as ``"site z"``."""
    data = mujoco.MjData(model)
    xpos, sz = [], []
    for q in np.atleast_2d(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        xpos.append(data.xpos.copy())
        sz.append(data.site_xpos[:, 2].copy())
    x = np.array(xpos)
    out = {model.body(i).name: x[:, i] for i in range(model.nbody)}
    out["site z"] = np.array(sz)
    return out


def _figures(model: mujoco.MjModel, qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Per frame [deg]: arm elevation from hanging (upper arm against the downward vertical),
    knee flexion (the angle between thigh and shank), thigh from vertical; the lowest site's
    height [m]."""
    b = _bodies(model, qpos)
    out = {"lowest": b["site z"].min(axis=1)}
    for s in "lr":
        out[f"arm_{s}"] = _angle(b[f"ulna_{s}"] - b[f"upperarm_{s}"], DOWN)
        thigh = b[f"shank_{s}"] - b[f"thigh_{s}"]
        out[f"knee_{s}"] = _angle(thigh, b[f"foot_{s}"] - b[f"shank_{s}"])
        out[f"thigh_{s}"] = _angle(thigh, DOWN)
    return out


#: (posture, figure, value [deg], tolerance of the posture itself, of a static's mean [deg]).
EXPECTED = [
    ("neutral", "arm", 0.0, 1.0, 15.0),
    ("neutral", "knee", 0.0, 1.0, 15.0),
    ("t-pose", "arm", 90.0, 1.0, 15.0),
    ("t-pose", "knee", 0.0, 1.0, 15.0),
    ("arms-up", "arm", 155.0, 1.0, 15.0),
    ("seated", "knee", 90.0, 1.0, 15.0),
    ("seated", "thigh", 90.0, 1.0, 15.0),
    ("crouched", "knee", 90.0, 1.0, 15.0),
    ("crouched", "thigh", 65.0, 1.0, 15.0),
]


@pytest.mark.parametrize(("pose", "figure", "value", "tol", "tol_static"), EXPECTED)
def test_posture_is_what_it_says(
    model: mujoco.MjModel, pose: str, figure: str, value: float, tol: float, tol_static: float
) -> None:
    """The posture's own joint angles give the figure; a static trial in it (a perturbed pose
    and its sway, seed 3) keeps it on average, on the truth model."""
    fig = _figures(model, pz.pose_qpos(model, pose))
    for s in "lr":
        assert abs(fig[f"{figure}_{s}"][0] - value) < tol, (pose, figure, s, fig)
    exp = synthesize(SynthConfig(frames=60, motion="static", pose=pose, seed=3))
    kin_model = _truth_model(exp)
    fig = _figures(kin_model, exp.qpos)
    for s in "lr":
        mean = float(np.mean(fig[f"{figure}_{s}"]))
        assert abs(mean - value) < tol_static, (pose, figure, s, mean)


def _truth_model(exp: object) -> mujoco.MjModel:
    kin = Kinematics(exp.pset)  # type: ignore[attr-defined]
    kin.set_theta(exp.theta_true)  # type: ignore[attr-defined]
    return kin.model


@pytest.mark.parametrize("pose", POSES)
def test_feet_stay_on_the_floor(model: mujoco.MjModel, pose: str) -> None:
    """Every posture's lowest site is as high as standing's; a seated or crouched pelvis is
    lowered accordingly (some 0.4 and 0.3 m)."""
    fig = _figures(model, pz.pose_qpos(model, pose))
    neutral = _figures(model, model.qpos0)
    assert abs(fig["lowest"][0] - neutral["lowest"][0]) < 1e-9
    drop = model.qpos0[2] - pz.pose_qpos(model, pose)[2]
    expected = {"seated": (0.35, 0.5), "crouched": (0.2, 0.4)}.get(pose, (-1e-9, 1e-9))
    assert expected[0] <= drop <= expected[1], (pose, drop)


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize(
    ("pose", "movement", "heading"),
    [("neutral", "static", 90.0), ("seated", "static", 180.0), ("t-pose", "walk", 270.0),
     ("crouched", "rom", -37.5)],
)  # fmt: skip
def test_heading_turns_every_marker_about_the_vertical(
    pose: str, movement: str, heading: float
) -> None:
    """The same capture turned: every clean marker (and soft-tissue displacement) of frame t is
    R_z(heading) times the one facing +x; the noise draws are the same."""
    cfg = SynthConfig(frames=80, motion=movement, pose=pose, seed=4, sta_mm=3.0)
    a = synthesize(cfg)
    b = synthesize(dataclasses.replace(cfg, heading_deg=heading))
    r = _rz(heading)
    np.testing.assert_allclose(b.markers_clean, a.markers_clean @ r.T, rtol=0, atol=1e-9)
    assert b.sta is not None and a.sta is not None
    np.testing.assert_allclose(b.sta, a.sta @ r.T, rtol=0, atol=1e-9)
    white_a = a.markers - a.markers_clean - a.sta
    white_b = b.markers - b.markers_clean - b.sta
    np.testing.assert_allclose(white_a, white_b, rtol=0, atol=1e-12)


@pytest.mark.parametrize("pose", POSES[1:])
@pytest.mark.parametrize("movement", ["rom", "walk"])
def test_dynamics_start_at_rest_in_the_posture(
    model: mujoco.MjModel, pose: str, movement: str
) -> None:
    """A rom or walk in a posture: its first frame is the posture (the root where the motion
    starts horizontally), its first frames at rest; then the motion itself; within the limits
    and as smooth as the presets."""
    rate = 100.0
    rng = np.random.default_rng(2)
    plain = generate(movement, model, 300, rate, rng)
    q = pz.apply(model, plain, movement, pose, 0.0, rate)
    check_limits(model, q)
    acc = max_accelerations(model, q, rate)
    assert acc[0] < 200.0 and acc[1] < 200.0 and acc[2] < 10.0, acc
    pose_q = pz.pose_qpos(model, pose)
    np.testing.assert_allclose(q[0, 7:], pose_q[7:], rtol=0, atol=1e-9)
    np.testing.assert_allclose(q[0, 2:7], pose_q[2:7], rtol=0, atol=1e-9)
    np.testing.assert_allclose(q[0, :2], plain[0, :2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(q[1], q[0], rtol=0, atol=1e-4)  # at rest: smoothstep
    after = int(pz.BLEND_S * rate) + 1
    np.testing.assert_allclose(q[after:, 7:], plain[after:, 7:], rtol=0, atol=2e-3)


@pytest.mark.parametrize("pose", POSES)
def test_static_in_a_posture_within_limits(model: mujoco.MjModel, pose: str) -> None:
    static = generate("static", model, 200, 100.0, np.random.default_rng(5))
    q = pz.apply(model, static, "static", pose, 0.0, 100.0)
    check_limits(model, q)
    fig = _figures(model, q)
    neutral = _figures(model, model.qpos0)
    # the sway (joints about a degree, the root -/+ 2 mm vertically) moves the feet little
    assert np.all(np.abs(fig["lowest"] - neutral["lowest"][0]) < 0.06), pose


def test_same_seed_same_capture_other_seed_another() -> None:
    cfg = SynthConfig(frames=50, motion="static", pose="crouched", heading_deg=90.0, seed=7)
    a, b = synthesize(cfg), synthesize(cfg)
    np.testing.assert_array_equal(a.markers, b.markers)
    np.testing.assert_array_equal(a.qpos, b.qpos)
    np.testing.assert_array_equal(a.theta_true, b.theta_true)
    c = synthesize(dataclasses.replace(cfg, seed=8))
    assert np.abs(c.markers - a.markers).max() > 1e-3


def test_defaults_are_the_preset_itself() -> None:
    """Neutral facing +x is the preset unchanged, and its settings are not written (the files
    are those of a capture without these settings)."""
    cfg = SynthConfig(frames=40, motion="walk", seed=2)
    same = synthesize(dataclasses.replace(cfg, pose="neutral", heading_deg=0.0))
    np.testing.assert_array_equal(synthesize(cfg).markers, same.markers)
    assert "pose" not in cfg.to_dict() and "heading_deg" not in cfg.to_dict()
    other = dataclasses.replace(cfg, pose="seated", heading_deg=90)
    assert other.to_dict()["pose"] == "seated" and other.to_dict()["heading_deg"] == 90.0
    assert SynthConfig(**other.to_dict()) == other


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"pose": "sitting"}, "pose: unknown posture 'sitting'; expected one of neutral, t-pose"),
     ({"heading_deg": float("nan")}, "heading_deg: expected a finite number"),
     ({"heading_deg": "90"}, "heading_deg: expected a number")],
)  # fmt: skip
def test_bad_posture_or_heading_is_one_line(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("(", r"\(")):
        SynthConfig(**kwargs)  # type: ignore[arg-type]


def test_postures_table_names_the_poses() -> None:
    assert tuple(pz.POSTURES) == POSES


# ------------------------------------------------------------------ the checks themselves
def _truth_pair(
    offset_shift: dict[str, np.ndarray], turn_deg: float = 0.0
) -> tuple[tuple[Kinematics, Kinematics], tuple[np.ndarray, np.ndarray], ParameterSet]:
    """A truth (seed 6, 30 static frames) and an 'estimate': the truth with markers moved by
    ``offset_shift`` (marker -> (3,) [m] in its segment) and its poses turned by ``turn_deg``
    about the vertical."""
    exp = synthesize(SynthConfig(frames=30, motion="static", pose="seated", seed=6))
    pset = exp.pset
    theta = np.array(exp.theta_true)
    for name, shift in offset_shift.items():
        i = pset.n_kappa + 3 * pset.marker_index(name)
        theta[i : i + 3] += shift
    kins = []
    for th in (exp.theta_true, theta):
        kin = Kinematics(pset)
        kin.set_theta(np.asarray(th))
        kins.append(kin)
    q_hat = pz.turn(pset.model, np.asarray(exp.qpos), turn_deg)
    return (kins[0], kins[1]), (np.asarray(exp.qpos), q_hat), pset


def test_the_truth_has_no_flip_and_no_axis_error() -> None:
    kins, qs, pset = _truth_pair({})
    assert flipped_joints(pset, kins, qs) == []
    assert max(axis_errors(kins, qs).values()) < 1e-3


def test_a_marker_moved_past_its_centre_is_a_flip() -> None:
    """RKNE moved 100 mm medially (+y on the right): the knee centre now lies lateral of it,
    and only that joint is named."""
    kins, qs, pset = _truth_pair({"RKNE": np.array([0.0, 0.10, 0.0])})
    flips = flipped_joints(pset, kins, qs)
    assert len(flips) == 1 and flips[0].startswith("knee_r: centre"), flips
    assert "lateral of RKNE (truth:" in flips[0] and "medial)" in flips[0], flips
    # LELB moved 80 mm medially (-y on the left): the elbow centre lateral of it
    kins, qs, pset = _truth_pair({"LELB": np.array([0.0, -0.08, 0.0])})
    flips = flipped_joints(pset, kins, qs)
    assert len(flips) == 1 and flips[0].startswith("elbow_l: centre 4"), flips
    assert "mm lateral of LELB (truth: 3" in flips[0], flips


def test_a_flexion_axis_is_not_turned_by_the_joints_after_it() -> None:
    """The estimate's left subtalar and ankle angles and right knee rotation and flexion 20
    degrees off the truth's leave the left ankle's and the right knee's flexion axes where
    they are (MuJoCo's joint axis, not the body's final frame), and turn the right ankle's
    (the shank turned about its long axis) by the 20 degrees."""
    kins, (q, _), _ = _truth_pair({})
    q_hat = np.array(q, dtype=float)
    model = kins[0].model
    for name in ("subtalar_l", "ankle_l", "knee_rot_r", "knee_flex_r"):
        q_hat[:, model.joint(name).qposadr[0]] += np.radians(20.0)
    errors = axis_errors(kins, (q, q_hat))
    assert max(errors[n] for n in ("ankle_l", "knee_flex_l", "knee_flex_r")) < 1e-6, errors
    assert abs(errors["ankle_r"] - 20.0) < 1.0, errors


def test_a_turned_pose_is_an_axis_error_of_that_angle() -> None:
    kins, qs, _ = _truth_pair({}, turn_deg=15.0)
    errors = axis_errors(kins, qs)
    # every flexion axis is horizontal-ish in a seated pose: turned about the vertical by 15 deg
    assert all(5.0 < e <= 15.0 + 1e-6 for e in errors.values()), errors


# -------------------------------------------------------------- identify in each posture
#: (posture, heading [deg], movement, frames): a static and a rom starting in each posture,
#: the headings spread over 0/90/180/270; the cases of benchmarks/skeleton_postures.py
#: (seed 3), which prints their figures.
CASES = [
    ("neutral", 0.0, "static", 200),
    ("neutral", 90.0, "rom", 300),
    ("t-pose", 90.0, "static", 200),
    ("t-pose", 180.0, "rom", 300),
    ("arms-up", 180.0, "static", 200),
    ("arms-up", 270.0, "rom", 300),
    ("seated", 270.0, "static", 200),
    ("seated", 0.0, "rom", 300),
    ("crouched", 0.0, "static", 200),
    ("crouched", 90.0, "rom", 300),
]
#: Cases that miss a target today, with the figure: (case, which test) -> reason. A static
#: determines no flexion axis (the thigh, shank and upper arm turn about their long axes with
#: the wand markers' offsets): the priors hold it near the construction, which the synthetic
#: truth's wands, placed 20 mm off their chord planes at random, turn from the truth's.
_STATIC_AXIS = "a static's {} axis ends {} deg from the truth's (target 10)"
FAILING: dict[tuple[tuple[str, float, str, int], str], str] = {
    # The right knee's construction lies 12 deg from the truth's axis (the thigh wand drawn
    # off its chord plane); the fit, which the static does not hold, ends 25 deg off.
    (("neutral", 0.0, "static", 200), "axes"): _STATIC_AXIS.format("right knee", 24.9),
    # Arms raised or folded with the elbows nearly straight: the fit's right elbow lies 13 mm
    # nearer ELB and 21 mm more proximal than the truth's (a static does not fix the width),
    # its axis turned with it.
    (("arms-up", 180.0, "static", 200), "axes"): _STATIC_AXIS.format("right elbow", 28.3),
    (("crouched", 0.0, "static", 200), "axes"): _STATIC_AXIS.format("left elbow", 15.3),
}


@functools.cache
def _identified(pose: str, heading: float, movement: str, frames: int) -> dict[str, Any]:
    cfg = SynthConfig(frames=frames, motion=movement, pose=pose, heading_deg=heading, seed=3)
    return identify_and_check(cfg)


def _cases(test: str) -> list[Any]:
    out = []
    for case in CASES:
        reason = FAILING.get((case, test))
        marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
        out.append(pytest.param(*case, marks=marks, id="-".join(str(c) for c in case[:3])))
    return out


@pytest.mark.slow
@pytest.mark.parametrize(("pose", "heading", "movement", "frames"), _cases("centres"))
def test_identify_finds_the_joint_centres_in_every_posture(
    pose: str, heading: float, movement: str, frames: int
) -> None:
    """Joint centres within their Cramer-Rao bound (z RMS over bodies <= 1.3, none beyond 4)
    and no joint centre on the wrong side of its landmark marker."""
    r = _identified(pose, heading, movement, frames)
    assert r["z_rms"] <= Z_RMS and r["z_max"] <= Z_MAX, (r["z_rms"], r["z_max"], r["z_worst"])
    assert r["flips"] == [], r["flips"]


@pytest.mark.slow
@pytest.mark.parametrize(("pose", "heading", "movement", "frames"), _cases("axes"))
def test_identify_finds_the_flexion_axes_in_every_posture(
    pose: str, heading: float, movement: str, frames: int
) -> None:
    """Every flexion axis (knees, ankles, elbows) within 10 degrees of the truth's."""
    r = _identified(pose, heading, movement, frames)
    assert r["axis_max_deg"] <= AXIS_DEG, (r["axis_max_deg"], r["axis_worst"], r["axis_deg"])


def test_a_walk_from_a_posture_has_its_truth_events_after_the_blend() -> None:
    from mocap_synth.gait_truth import truth_events

    cfg = SynthConfig(frames=400, motion="walk", seed=1)
    seated = truth_events(synthesize(dataclasses.replace(cfg, pose="seated")))
    plain = truth_events(synthesize(cfg))
    assert seated and min(e.time for e in seated) >= pz.BLEND_S
    assert [e for e in plain if e.time >= pz.BLEND_S] == seated
