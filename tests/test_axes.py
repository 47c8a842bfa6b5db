"""Knee flexion axes: Plug-in Gait's chord plane where a trial cannot place them, the
motion's where it can (mocap_mj.anatomy.axes), on synthetic subjects whose axes are known."""

from __future__ import annotations

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, MocapError, ParameterSet
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.axes import knee_crosstalk, pig_angle
from mocap_mj.anatomy.axis_rows import wand_width
from mocap_mj.capture.subject import Measurement, Subject
from mocap_mj.pipeline.anatomical import AnatomyPriors
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData

KNEES = (("LTHI", "LKNE", "knee_l"), ("RTHI", "RKNE", "knee_r"))


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def _wand_turned(pset: ParameterSet, theta: np.ndarray, degrees: float) -> np.ndarray:
    """``theta`` with each thigh wand turned by ``degrees`` about the thigh's long axis
    (out of Plug-in Gait's chord plane; 0: in it)."""
    out = theta.copy()
    for wand, _, _ in KNEES:
        i = pset.n_kappa + 3 * pset.marker_index(wand)
        x, y = out[i], out[i + 1]
        a = np.radians(degrees) * np.sign(y)
        out[i], out[i + 1] = x * np.cos(a) - y * np.sin(a), x * np.sin(a) + y * np.cos(a)
    return out


def _solve(pset: ParameterSet, truth: np.ndarray, qpos: np.ndarray, seed: int) -> tuple:
    kin = Kinematics(pset)
    kin.set_theta(truth)
    rng = np.random.default_rng(seed)
    markers = kin.marker_positions(qpos) + rng.normal(0.0, 1e-3, (len(qpos), pset.n_markers, 3))
    trial = TrialData("axes", markers, np.arange(len(qpos)) / 100.0)
    subject = Subject()
    subject.set("height", 1.75, "test")  # the nominal model's: every prior centred on it
    for side in "lr":  # the nominal model's widths (KNE 50 mm, ANK 40 mm lateral, r 7 mm)
        subject.set(f"knee_width_{side}", 0.086, "test")
        subject.set(f"ankle_width_{side}", 0.066, "test")
    return solve_anatomical([trial], pset=pset, theta0=None, settings=LMSettings(),
                            anatomy=AnatomyPriors(subject))  # fmt: skip


def test_pig_angle_follows_the_chord_plane(pset: ParameterSet) -> None:
    """The angle between the model's axis and the chord plane's: zero with the wand in the
    plane; a wand moved by dx turns it by wand_width's gain (within 10 % for 5 degrees)."""
    for wand, marker, joint in KNEES:
        assert abs(pig_angle(pset, pset.nominal, wand, marker, joint)) < 1e-6
        theta = pset.nominal.copy()
        dx = wand_width(pset, wand, marker, 5.0)
        theta[pset.n_kappa + 3 * pset.marker_index(wand)] += dx
        got = abs(pig_angle(pset, theta, wand, marker, joint))
        assert abs(got - 5.0) < 0.5, (joint, got)


def test_static_trial_takes_plug_in_gaits_axis(pset: ParameterSet) -> None:
    """A static trial (one pose, knees flexed 10 degrees) of a subject whose wands sit in
    the chord plane: the data cannot place the knee axes, so the chord-plane row does
    (within its width of the truth's axis), and the report says so."""
    kin = Kinematics(pset)
    q = smooth_motion(kin, 1, seed=2)[0]
    for j in ("knee_flex_l", "knee_flex_r"):
        q[pset.model.joint(j).qposadr[0]] = np.radians(10.0)
    qpos = np.tile(q, (80, 1))
    result, weighting = _solve(pset, pset.nominal.copy(), qpos, seed=3)
    for wand, marker, joint in KNEES:
        d = weighting.joint_axes[joint]
        assert d["source"] == "plug-in-gait", d
        assert d["data_sd_deg"] > d["row_sd_deg"]
        assert abs(pig_angle(pset, result.theta, wand, marker, joint)) < d["row_sd_deg"]


def test_moving_trial_keeps_its_functional_axis(pset: ParameterSet) -> None:
    """A trial with wide knee flexion of a subject whose thigh wands are turned 15 degrees
    out of the chord plane (the axis 20-25 degrees from the plane's): the motion places the
    axes, which stay the subject's (the angle to Plug-in Gait's recovered within 2 degrees)."""
    truth = _wand_turned(pset, pset.nominal, 15.0)
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 300, seed=4)
    _, weighting = _solve(pset, truth, qpos, seed=5)
    for wand, marker, joint in KNEES:
        d = weighting.joint_axes[joint]
        assert d["source"] == "functional", d
        want = pig_angle(pset, truth, wand, marker, joint)
        assert abs(want) > 15.0
        assert abs(d["angle_to_pig_deg"] - want) < 2.0, (joint, d, want)


def test_davis_hip_rows(pset: ParameterSet) -> None:
    """--hip-centre davis: rows from the leg lengths, in the recipe; refused without them."""
    legs = {f"leg_length_{s}": Measurement(0.9, "test") for s in "lr"}
    prior = landmark_prior(pset, Subject(legs), hip_centre="davis")
    assert sum("Davis" in lab for lab in prior.labels) == 6
    assert not any("Harrington" in lab for lab in prior.labels)
    with pytest.raises(MocapError, match="leg lengths"):
        landmark_prior(pset, Subject(), hip_centre="davis")
    assert "hip_centre: davis" in Recipe(hip_centre="davis").to_yaml()
    with pytest.raises(MocapError):
        Recipe(hip_centre="pelvis")  # type: ignore[arg-type]


def test_crosstalk_shows_a_turned_wand(pset: ParameterSet) -> None:
    """Knee varus-valgus on flexion over a moving trial of a subject whose thigh wands are
    turned 15 degrees: the chord plane's axis (Plug-in Gait's) produces a slope of at
    least 0.08 degree per degree of flexion (correlation above 0.7), the subject's own axis
    less than 0.01; with the wands in the plane both show less than 0.01."""
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 300, seed=4)
    for turn, pig_min, pig_max in ((15.0, 0.08, np.inf), (0.0, 0.0, 0.01)):
        truth = _wand_turned(pset, pset.nominal, turn)
        kin.set_theta(truth)
        decisions = {j: {"wand": w, "marker": m} for w, m, j in KNEES}
        knee_crosstalk(pset, truth, [qpos], [kin.marker_positions(qpos)], decisions)
        for joint, d in decisions.items():
            assert abs(d["crosstalk_model"]["slope"]) < 0.01, (turn, joint, d)
            assert pig_min <= abs(d["crosstalk_pig"]["slope"]) < pig_max, (turn, joint, d)
            assert turn == 0.0 or abs(d["crosstalk_pig"]["corr"]) > 0.7


def test_foot_turns_about_a_placed_ankle_axis(pset: ParameterSet) -> None:
    """With Plug-in Gait's TIB chord (the ankle width measured) the heel-toe line may turn
    about the foot's z by SIGMA_FOOT_TURN (its mid-point held on the x axis); without it
    HEE.y = TOE.y = 0 set the ankle axis normal to the heel-toe line."""
    from mocap_mj.anatomy.anatomy import SIGMA_LANDMARK
    from mocap_mj.anatomy.foot import HEEL_TO_TOE, SIGMA_FOOT_TURN

    subject = Subject()
    subject.set("height", 1.75, "test")
    bare = landmark_prior(pset, subject)
    assert sum(lab in ("LHEE.y = 0", "RHEE.y = 0") for lab in bare.labels) == 2
    for side in "lr":
        subject.set(f"ankle_width_{side}", 0.066, "test")
    placed = landmark_prior(pset, subject)
    assert not any(lab.endswith("HEE.y = 0") for lab in placed.labels)
    for p in "LR":
        (r,) = [i for i, lab in enumerate(placed.labels) if lab.startswith(f"{p}TOE.y = {p}HEE.y")]
        assert placed.sigma[r] == pytest.approx(np.tan(np.radians(SIGMA_FOOT_TURN)) * HEEL_TO_TOE)
        (m,) = [i for i, lab in enumerate(placed.labels) if lab == f"{p}HEE-TOE midpoint y = 0"]
        assert placed.sigma[m] == SIGMA_LANDMARK


def test_knee_level_row_is_plug_in_gaits_perpendicular(pset: ParameterSet) -> None:
    """KNE's level row states Plug-in Gait's chord: KNE's offset from the knee centre normal
    to the hip-knee line, so a knee centre moved medially raises KNE's level by
    (w/2 + r) / thigh length per metre."""
    subject = Subject()
    subject.set("height", 1.75, "test")
    subject.set("knee_width_l", 0.086, "test")
    prior = landmark_prior(pset, subject)
    (r,) = [i for i, lab in enumerate(prior.labels) if lab == "LKNE.z = -thigh_length"]
    a = prior.a[r]
    half = 0.086 / 2 + subject.marker_radius
    thigh = pset.nominal[pset.index("thigh_length_l")]
    assert a[pset.index("knee_lateral_l")] == pytest.approx(-half / thigh)
    assert a[pset.index("thigh_length_l")] == 1.0
