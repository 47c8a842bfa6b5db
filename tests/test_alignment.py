"""The knee's frontal-plane alignment as subject parameters: prior rows, ranges, recovery.

The knee is a flexion hinge plus tibial rotation, so without these parameters the hip,
knee and ankle centres lie in one plane normal to the knee axis; ``knee_lateral`` and
``ankle_lateral`` move the knee centre (in the thigh frame) and the ankle centre (in the
shank frame) along that axis: a subject's static valgus or varus (docs/model.md).
"""

from __future__ import annotations

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, MocapError, ParameterSet
from mocap_mj.anatomy.anatomy import ALIGNMENT, SIGMA_REGRESSED, landmark_prior, marker_prior_table
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.anatomical import AnatomyPriors, anatomical_priors, prior_information
from mocap_mj.pipeline.steps import solve_anatomical
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData, reduced_information
from mocap_synth.perturb import perturb_theta, place_landmarks

ALIGNED = ("knee_lateral_l", "knee_lateral_r", "ankle_lateral_l", "ankle_lateral_r")


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def test_alignment_rows_and_the_landmarks_that_follow(pset: ParameterSet) -> None:
    """Each alignment parameter has a prior row 0 +- tan(3 deg) x its segment's nominal
    length; KNE's and ANK's lateral prior means follow the joint centre they mark."""
    prior = landmark_prior(pset)
    for name, seg in (("knee_lateral_l", "thigh_length_l"), ("ankle_lateral_r", "shank_length_r")):
        rows = [r for r in range(len(prior.b)) if np.flatnonzero(prior.a[r]).tolist()
                == [pset.index(name)]]  # fmt: skip
        assert len(rows) == 1
        r = rows[0]
        assert prior.b[r] == 0.0 and prior.a[r, pset.index(name)] == 1.0
        sd = ALIGNMENT[name[:-2]][2]
        expected = np.tan(np.radians(sd)) * pset.nominal[pset.index(seg)]
        assert prior.sigma[r] == pytest.approx(expected)
    theta = pset.nominal.copy()
    theta[pset.index("knee_lateral_l")] = -0.02
    theta[pset.index("ankle_lateral_r")] = 0.015
    table = marker_prior_table(pset, prior, theta)
    base = marker_prior_table(pset, prior, pset.nominal)
    assert table["LKNE"][0][1] - base["LKNE"][0][1] == pytest.approx(-0.02)
    assert table["RANK"][0][1] - base["RANK"][0][1] == pytest.approx(-0.015)  # right: -y lateral
    assert table["LKNE"][1][1] == pytest.approx(SIGMA_REGRESSED)
    # The knee centre moves along the knee axis, the ankle centre with it.
    kin = Kinematics(pset)
    kin.set_theta(theta)
    xpos = kin.forward(pset.model.qpos0[None]).xpos[0]
    kin.set_theta(pset.nominal)
    xpos0 = kin.forward(pset.model.qpos0[None]).xpos[0]
    shank, foot = pset.model.body("shank_l").id, pset.model.body("foot_l").id
    np.testing.assert_allclose(xpos[shank] - xpos0[shank], [0.0, -0.02, 0.0], atol=1e-12)
    np.testing.assert_allclose(xpos[foot] - xpos0[foot], [0.0, -0.02, 0.0], atol=1e-12)


def test_valgus_subject_is_recovered_within_its_bound(pset: ParameterSet) -> None:
    """A synthetic subject with 3-4 degrees of femoral valgus and a varus or valgus tibia,
    landmarks placed on its skeleton (KNE half the regressed knee width lateral of the
    displaced knee centre): the identified alignment parameters are within 4 standard
    deviations of the Bayesian bound (data and prior information) of the truth, while the
    truth's knee values lie beyond 4 of them from the neutral 0 (the test would fail for a
    solver that ignored them)."""
    rng = np.random.default_rng(11)
    truth = perturb_theta(pset, rng, placement="uniform")
    for name, value in zip(ALIGNED, (-0.028, -0.024, 0.012, -0.010), strict=True):
        truth[pset.index(name)] = value
    truth = place_landmarks(pset, truth, rng)
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 300, seed=4)
    kin.set_theta(truth)
    sigma = 1e-3
    markers = kin.marker_positions(qpos) + rng.normal(0.0, sigma, (300, pset.n_markers, 3))
    trial = TrialData("valgus", markers, np.arange(300) / 100.0)
    settings = LMSettings()
    result, _ = solve_anatomical([trial], pset=pset, theta0=None, settings=settings,
                                 anatomy=AnatomyPriors(Subject()))  # fmt: skip
    info = result.reduced_information / result.sigma**2 + prior_information(
        anatomical_priors(pset, AnatomyPriors(Subject()), noise=settings.prior_noise),
        settings,
        pset.size,
    )
    std = np.sqrt(np.diag(np.linalg.inv(info)))
    for name in ALIGNED:
        i = pset.index(name)
        err = result.theta[i] - truth[i]
        assert abs(err) < 4 * std[i], (name, err, std[i])
        if name.startswith("knee"):
            assert abs(truth[i]) > 4 * std[i], (name, truth[i], std[i])


def test_parameters_file_without_alignment_reads_neutral(pset: ParameterSet, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A theta.json written before the alignment parameters existed reads with them at 0;
    any other missing name is still an error."""
    data = pset.to_dict(pset.nominal)
    for name in ALIGNED:
        del data["kappa"][name]
    np.testing.assert_array_equal(pset.from_dict(data), pset.nominal)
    del data["kappa"]["thigh_length_l"]
    with pytest.raises(MocapError, match=r"missing names.*thigh_length_l"):
        pset.from_dict(data)


def test_alignment_seen_only_through_tibial_and_subtalar_rotation(pset: ParameterSet) -> None:
    """The gauge: with the tibia and the subtalar joint still, sliding the knee (ankle) centre
    along the knee axis with the markers below it moved back changes no marker, so each
    alignment parameter leads an unobservable direction, named as such; with those joints
    moving, none of them is unobservable (each is determined to better than 50 mm)."""
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 100, seed=2)
    rng = np.random.default_rng(0)
    for still in (True, False):
        q = qpos.copy()
        if still:
            for joint in ("knee_rot_l", "knee_rot_r", "subtalar_l", "subtalar_r"):
                q[:, pset.model.jnt_qposadr[pset.model.joint(joint).id]] = 0.0
        kin.set_theta(pset.nominal)
        markers = kin.marker_positions(q) + rng.normal(0.0, 1e-3, (100, pset.n_markers, 3))
        trial = TrialData("t", markers, np.arange(100) / 100.0)
        info, *_ = reduced_information(pset, pset.nominal, [trial], [q])
        idf = Identifiability(pset, info, 1e-3)
        led = {
            d.description.split(":")[0]
            for d in idf.directions()
            if d.kind == "unobservable" and "sliding along the knee" in d.description
        }
        assert led == (set(ALIGNED) if still else set()), led
