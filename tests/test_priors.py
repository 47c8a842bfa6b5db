"""Anatomical priors, subject measurements and the anatomical ranges enforced by the LM."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.anatomy import (
    MEDIAL_MALLEOLUS_ABOVE,
    SIGMA_CONVENTION,
    SIGMA_LANDMARK,
    SIGMA_MEASURED,
    SIGMA_REGRESSED,
    SIGMA_T10_LEVEL,
    WIDTH_RATIO,
    landmark_prior,
    marker_prior_table,
    symmetric_prior,
)
from mocap_mj.anatomy.foot import SIGMA_FOOT_HEIGHT, SIGMA_FOOT_LENGTH
from mocap_mj.anatomy.ranges import ALIGNMENT_RANGES, SIGNED, base_name, kappa_ranges, theta_bounds
from mocap_mj.capture.marker_set import marker_class
from mocap_mj.capture.subject import Subject, from_c3d, from_values, from_yaml
from mocap_mj.errors import MocapError
from mocap_mj.solve.lm import LMSettings, Tolerances, TrialData, identify_lm
from mocap_mj.solve.noise import SOFT_TISSUE_SIGMA, artefact_noise
from mocap_mj.solve.priors import LinearGaussianPrior
from mocap_mj.solve.problem import Bounds


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def test_marker_classes() -> None:
    assert marker_class("LKNE") == "landmark"
    assert marker_class("RASI") == "landmark"
    assert marker_class("C7") == "landmark"
    assert marker_class("CLAV") == "landmark"
    assert marker_class("LTHI") == "cluster"
    assert marker_class("RBAK") == "cluster"
    with pytest.raises(MocapError):  # not a Plug-in Gait marker: no class, no prior
        marker_class("LKNEM")


def test_prior_mean_and_width_per_class(pset: ParameterSet) -> None:
    """A landmark's mean follows the skeleton (KNE at the knee's level, on its axis); its
    lateral width is the regression's without a measurement, the caliper's with one; ANK's
    and ELB's level and depth are a convention joint's; a free marker has no anatomical
    row."""
    theta = pset.nominal.copy()
    theta[pset.index("thigh_length_l")] = 0.40
    table = marker_prior_table(pset, landmark_prior(pset), theta)
    mean, width = table["LKNE"]
    r = 0.007  # default 14 mm marker
    ratio = WIDTH_RATIO["knee_width"][1]  # 100 mm at the nominal 430 mm
    np.testing.assert_allclose(mean, [0.0, ratio * 0.40 / 2 + r, -0.40], atol=1e-12)
    np.testing.assert_allclose(width, [SIGMA_LANDMARK, SIGMA_REGRESSED, SIGMA_LANDMARK])
    # ANK defines the ankle centre (a convention joint): its level and depth at 3 mm.
    theta_shank = theta[pset.index("shank_length_l")]
    mean, width = table["LANK"]
    np.testing.assert_allclose(mean[[0, 2]], [0.0, -theta_shank], atol=1e-12)
    np.testing.assert_allclose(width, [SIGMA_CONVENTION, SIGMA_REGRESSED, SIGMA_CONVENTION])
    # ELB defines the elbow centre likewise (a convention joint), KNE does not (10 mm above).
    mean, width = table["LELB"]
    np.testing.assert_allclose(
        mean[[0, 2]], [0.0, -theta[pset.index("upperarm_length_l")]], atol=1e-12
    )
    np.testing.assert_allclose(width, [SIGMA_CONVENTION, SIGMA_REGRESSED, SIGMA_CONVENTION])
    mean_r, _ = table["RKNE"]
    assert mean_r[1] == pytest.approx(-(ratio * pset.nominal[pset.index("thigh_length_r")] / 2 + r))
    assert np.all(np.isinf(table["LTHI"][1])) and np.all(np.isnan(table["LTHI"][0]))
    measured = from_values([("knee_width_l", 0.120), ("marker_diameter", 0.016)], "test")
    mean, width = marker_prior_table(pset, landmark_prior(pset, measured), theta)["LKNE"]
    assert mean[1] == pytest.approx(0.060 + 0.008)
    assert width[1] == pytest.approx(SIGMA_MEASURED)


def test_nominal_model_satisfies_its_regressed_priors(pset: ParameterSet) -> None:
    """Without measurements the priors are centred on the nominal model's geometry (so the
    synthetic demo, whose truth is the nominal model perturbed, is not pulled elsewhere)."""
    prior = landmark_prior(pset)
    z = prior.residuals(pset.nominal)
    big = {lab: float(v) for lab, v in zip(prior.labels, z, strict=True) if abs(v) > 0.5}
    # The known differences: the nominal hip centre is Bell et al.'s (1989), 11 mm higher
    # than Harrington et al.'s (2007) for a 250 mm pelvis; the nominal C7/T1 joint is 25 mm
    # behind and 22 mm above where Dumas et al. (2007) put it from the C7 and CLAV markers.
    for side in "lr":
        assert big.pop(f"hip_height_{side} = 0.30 PW + 10.9 mm (Harrington 2007)") == (
            pytest.approx((0.075 - 0.30 * 0.25 - 0.0109) / 0.008)
        )
    cjc = "C7/T1.{} = C7 + 0.55 (CLAV - C7) turned 8 deg up (Dumas 2007)"
    assert big.pop(cjc.format("x")) == pytest.approx(-0.0245 / SIGMA_CONVENTION, abs=0.05)
    assert big.pop(cjc.format("z")) == pytest.approx(0.0216 / SIGMA_CONVENTION, abs=0.05)
    # The nominal L5/S1 is Reed et al.'s (1999): 0.264 and 0.126 ASIS widths (250 mm)
    # behind and above mid-ASIS, so its rows hold exactly (Winter's 100 / 50 mm did not:
    # 11 and 6 sd, and the synthetic landmark placement bent the ASIS offsets to meet them).
    for c in "xz":
        i = next(i for i, lab in enumerate(prior.labels) if lab.startswith(f"L5/S1.{c} = "))
        assert z[i] == pytest.approx(0.0, abs=1e-9), prior.labels[i]
    assert not big, big


def test_leg_length_row_is_the_tape_from_asis_to_medial_malleolus(pset: ParameterSet) -> None:
    """Plug-in Gait's LegLength is a tape from the ASIS to the medial malleolus over the
    straight leg: on random skeletons standing at qpos0 (forward kinematics, the ASIS bone a
    marker radius behind LASI, the medial malleolus half the ankle width medial of and 10 mm
    above the ankle centre) the row given that distance holds within 1.5 mm (its
    linearisation), where hip height + thigh + shank is 5-15 mm off."""
    import mujoco

    rng = np.random.default_rng(3)
    r, aw = 0.007, 0.07
    names = ["hip_depth_l", "hip_width_l", "hip_height_l", "thigh_length_l", "shank_length_l"]
    for _ in range(5):
        theta = pset.nominal.copy()
        for n in names:
            theta[pset.index(n)] *= rng.uniform(0.85, 1.15)
        for c in "xy":
            theta[pset.index(f"LASI.{c}")] += rng.uniform(-0.01, 0.01)
        model = pset.model_for(theta)
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        asis = data.site_xpos[model.site("LASI").id] - np.array([r, 0.0, 0.0])
        ankle = data.xpos[model.body("foot_l").id]
        malleolus = ankle + np.array([0.0, -aw / 2, MEDIAL_MALLEOLUS_ABOVE])
        tape = float(np.linalg.norm(asis - malleolus))
        subject = from_values([("leg_length_l", tape), ("ankle_width_l", aw)], "test")
        prior = landmark_prior(pset, subject)
        i = prior.labels.index("ASIS to medial malleolus = leg_length_l")
        assert abs(prior.a[i] @ theta - prior.b[i]) < 0.0015
        chain = sum(theta[pset.index(n)] for n in names[2:])
        assert 0.005 < chain - tape < 0.015


def test_toe_marker_places_the_mtp_joint(pset: ParameterSet) -> None:
    """TOE is on the foot over the MTP joint (Plug-in Gait): its prior mean follows the foot
    length and height, 20 mm above the joint."""
    theta = pset.nominal.copy()
    theta[pset.index("foot_length_l")] = 0.16
    theta[pset.index("foot_height_l")] = 0.06
    assert pset.model.body(int(pset.site_body[pset.marker_index("LTOE")])).name == "foot_l"
    mean, width = marker_prior_table(pset, landmark_prior(pset), theta)["LTOE"]
    np.testing.assert_allclose(mean, [0.16, 0.0, -0.04], atol=1e-12)
    np.testing.assert_allclose(width, [SIGMA_LANDMARK] * 3)


def test_mtp_joint_has_a_stature_row(pset: ParameterSet) -> None:
    """No marker sees the MTP joint: foot length and height also get the nominal proportions
    at the subject's stature, their widths scaled with it."""
    prior = landmark_prior(pset, from_values([("height", 1.40)], "test"))
    s = 1.40 / 1.75
    for name, nominal, sigma in (("foot_length_r", 0.14, SIGMA_FOOT_LENGTH),
                                 ("foot_height_r", 0.045, SIGMA_FOOT_HEIGHT)):  # fmt: skip
        col = pset.index(name)
        (r,) = [r for r in range(len(prior.b)) if np.flatnonzero(prior.a[r]).tolist() == [col]]
        assert prior.b[r] == pytest.approx(nominal * s)
        assert prior.sigma[r] == pytest.approx(sigma * s)


def _turned(pset: ParameterSet, theta: np.ndarray, markers: list[str], joints: list[tuple[str,
            str]], angle: float) -> np.ndarray:  # fmt: skip
    """theta with the markers' offsets and the joint positions (x, z kappa pairs, frame
    coordinates) turned by ``angle`` [rad] about the frame's y axis: the frame tilted against
    its markers, which the data cannot see."""
    c, s = np.cos(angle), np.sin(angle)
    out = theta.copy()
    k = pset.n_kappa
    for m in markers:
        i = k + 3 * pset.marker_index(m)
        x, z = theta[i], theta[i + 2]
        out[i], out[i + 2] = c * x + s * z, -s * x + c * z
    for jx, jz in joints:
        ix, iz = pset.index(jx[1:]), pset.index(jz[1:])
        x = theta[ix] * (-1.0 if jx[0] == "-" else 1.0)
        z = theta[iz] * (-1.0 if jz[0] == "-" else 1.0)
        out[ix] = (c * x + s * z) * (-1.0 if jx[0] == "-" else 1.0)
        out[iz] = (-s * x + c * z) * (-1.0 if jz[0] == "-" else 1.0)
    return out


def test_convention_joints_follow_their_markers_not_the_frame(pset: ParameterSet) -> None:
    """C7/T1 and T12/L1 are placed from the thorax markers in a form that a tilt of the
    frame against its markers (with the joints turned along) leaves unchanged; the
    frame-tilt rows themselves do see the tilt (they fix it). (L5/S1 is Reed's, in the pelvis
    frame that the pelvis-tilt row fixes: ``test_l5s1_row_is_reeds_and_ignores_the_psis``.)"""
    prior = landmark_prior(pset)
    rng = np.random.default_rng(3)
    theta = pset.nominal + rng.normal(0, 0.01, pset.size)
    labels = np.array(prior.labels)
    for markers, joints, names, tilt in (
        (["C7", "T10", "CLAV", "STRN"], [("+neck_depth", "+thorax_length")],
         ("C7/T1", "T12/L1"), "thorax axis"),
    ):  # fmt: skip
        turned = _turned(pset, theta, markers, joints, np.radians(15))
        # Misfits in metres (T12/L1's z row is wider than its x row: SIGMA_T10_LEVEL).
        r0, r1 = prior.a @ theta - prior.b, prior.a @ turned - prior.b
        for name in names:
            sel = np.array([lab.startswith(name + ".") for lab in labels])
            assert sel.sum() == 2
            # The residual (x, z) turns with the frame: its length is unchanged.
            assert np.linalg.norm(r1[sel]) == pytest.approx(np.linalg.norm(r0[sel]), rel=1e-9)
        sel = np.array([lab.startswith(tilt) for lab in labels])
        assert sel.sum() == 1 and abs(r1[sel][0] - r0[sel][0]) > 0.005
    widths = {lab: sd for lab, sd in zip(prior.labels, prior.sigma, strict=True)}
    for lab, sd in widths.items():
        if lab.startswith("T12/L1.z"):
            assert sd == SIGMA_T10_LEVEL, lab
        elif lab.startswith(("C7/T1", "T12/L1", "L5/S1", "sc_width", "CLAV.z", "CLAV.x")):
            assert sd == SIGMA_CONVENTION, lab


def test_l5s1_row_is_reeds_and_ignores_the_psis(pset: ParameterSet) -> None:
    """L5/S1 is 0.264 and 0.126 ASIS widths behind and above mid-ASIS in the pelvis frame
    (Reed et al. 1999): a skeleton built so holds the rows exactly whatever its ASIS width,
    and moving the PSIS markers (placed higher or deeper) does not move the rows, where
    the nominal-proportion rows along the ASIS-PSIS line followed them."""
    prior = landmark_prior(pset)
    sel = np.array([lab.startswith("L5/S1.") for lab in prior.labels])
    assert sel.sum() == 2
    rng = np.random.default_rng(5)
    for _ in range(3):
        theta = pset.nominal + rng.normal(0, 0.005, pset.size)
        pw = theta[pset.index("LASI.y")] - theta[pset.index("RASI.y")]
        mid_x = 0.5 * (theta[pset.index("LASI.x")] + theta[pset.index("RASI.x")])
        mid_z = 0.5 * (theta[pset.index("LASI.z")] + theta[pset.index("RASI.z")])
        theta[pset.index("lumbar_depth")] = 0.264 * pw - mid_x
        theta[pset.index("lumbar_height")] = mid_z + 0.126 * pw
        np.testing.assert_allclose(prior.a[sel] @ theta - prior.b[sel], 0.0, atol=1e-12)
        moved = theta.copy()
        for m in ("LPSI", "RPSI"):
            moved[pset.index(f"{m}.z")] += 0.08
            moved[pset.index(f"{m}.x")] -= 0.03
        np.testing.assert_allclose(prior.a[sel] @ moved - prior.b[sel], 0.0, atol=1e-12)


def test_artefact_noise_floor_only_for_correlated_residuals() -> None:
    """White residuals (tau about 1: synthetic noise) keep their own size; correlated ones
    (soft-tissue artefact) are taken at least SOFT_TISSUE_SIGMA per axis."""
    assert artefact_noise(0.001, 1.0) == pytest.approx(0.001)
    assert artefact_noise(0.001, 9.0) == pytest.approx(SOFT_TISSUE_SIGMA * 3)
    assert artefact_noise(0.008, 4.0) == pytest.approx(0.016)


def test_prior_gradient_and_hessian_match_the_cost(pset: ParameterSet) -> None:
    rng = np.random.default_rng(1)
    prior = landmark_prior(pset, noise=0.004)
    theta = pset.nominal + rng.normal(0, 0.01, pset.size)
    g = prior.gradient(theta)
    h = prior.hessian()
    d = rng.normal(0, 1e-3, pset.size)
    # The cost is quadratic: the second-order expansion is exact.
    expected = prior.cost(theta) + g @ d + 0.5 * d @ h @ d
    assert prior.cost(theta + d) == pytest.approx(expected, rel=1e-10)
    sym = symmetric_prior(pset, 0.002)
    th = pset.nominal.copy()
    th[pset.index("thigh_length_l")] += 0.004
    assert sym.cost(th) == pytest.approx(0.5 * (0.001 / 0.002) ** 2 * 0.004**2)


def _write_c3d(path: Path, processing: dict[str, float]) -> None:
    import ezc3d

    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ("LKNE",)
    c3d["data"]["points"] = np.ones((4, 1, 3))
    for name, value in processing.items():
        c3d.add_parameter("PROCESSING", name, [value])
    c3d.write(str(path))


def test_c3d_processing_measurement_reaches_the_prior(tmp_path: Path, pset: ParameterSet) -> None:
    path = tmp_path / "subject.c3d"
    _write_c3d(path, {"LKneeWidth": 110.0, "Height": 1600.0, "RKneeWidth": 0.0, "Bodymass": 61.0})
    subject = from_c3d(path)
    assert subject.get("knee_width_l") == pytest.approx(0.110)
    assert subject.get("height") == pytest.approx(1.6)
    assert subject.get("mass") == pytest.approx(61.0)
    assert subject.get("knee_width_r") is None  # Nexus' 0 = not entered
    assert "PROCESSING:LKneeWidth" in subject.values["knee_width_l"].source
    mean, width = marker_prior_table(pset, landmark_prior(pset, subject), pset.nominal)["LKNE"]
    assert mean[1] == pytest.approx(0.055 + 0.007)
    assert width[1] == pytest.approx(SIGMA_MEASURED)
    # Height scales the ranges.
    lo, hi = kappa_ranges(pset, subject)
    k = pset.index("thigh_length_l")
    assert lo[k] == pytest.approx(0.8 * 0.43 * 1.6 / 1.75)
    assert hi[k] == pytest.approx(1.2 * 0.43 * 1.6 / 1.75)


def test_yaml_and_flags_override_and_reject_bad_values(tmp_path: Path) -> None:
    f = tmp_path / "s.yaml"
    f.write_text("height: 1.72\nknee_width_l: 105 mm\n")
    s = Subject().update(from_yaml(f))
    assert s.get("knee_width_l") == pytest.approx(0.105)
    s = s.update(from_values([("knee_width_l", 0.1)], "command line"))
    assert s.values["knee_width_l"].source == "command line"
    assert s.to_dict()["height"]["source"].endswith("height")
    f.write_text("knee_wdth_l: 0.1\n")
    with pytest.raises(MocapError, match="unknown measurement 'knee_wdth_l'"):
        from_yaml(f)
    f.write_text("height: tall\n")
    with pytest.raises(MocapError, match="height"):
        from_yaml(f)
    with pytest.raises(MocapError, match=r"^command line: expected a body mass within 2..650 kg"):
        from_values([("mass", -3.0)], "command line")


def test_ranges_have_positive_lengths(pset: ParameterSet) -> None:
    lo, hi = kappa_ranges(pset)
    assert np.all(lo < pset.nominal[: pset.n_kappa]) and np.all(hi > pset.nominal[: pset.n_kappa])
    signed = SIGNED | ALIGNMENT_RANGES.keys()
    lengths = [i for i, n in enumerate(pset.kappa_names) if base_name(n) not in signed]
    assert np.all(lo[lengths] > 0)
    # The alignment offsets: -/+ tan(12 deg) x the segment, at the tallest adult height.
    i, seg = pset.index("knee_lateral_r"), pset.index("thigh_length_r")
    half = np.tan(np.radians(12.0)) * pset.nominal[seg] * 2.10 / 1.75
    assert (lo[i], hi[i]) == pytest.approx((-half, half))


def test_bounds_are_never_crossed(pset: ParameterSet) -> None:
    """Random starts, some far outside the ranges, and bounds that cut through the truth:
    every solver output stays inside and the parameters pushed outward end at a bound."""
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, 40, seed=3)
    rng = np.random.default_rng(5)
    lower, upper = theta_bounds(pset)
    k = pset.n_kappa
    truth = pset.nominal.copy()
    truth[:k] *= rng.uniform(0.9, 1.1, k)
    kin.set_theta(truth)
    markers = kin.marker_positions(qpos) + rng.normal(0, 1e-3, (40, pset.n_markers, 3))
    # Tight bounds below the truth on two lengths: the data push them outward.
    upper = upper.copy()
    for name in ("thigh_length_l", "shank_length_r"):
        upper[pset.index(name)] = truth[pset.index(name)] - 0.02
    settings = LMSettings(max_iterations=10, tolerances=Tolerances(refine_iterations=5))
    for seed in range(3):
        theta0 = pset.nominal.copy()
        if seed:
            theta0[:k] *= np.random.default_rng(seed).uniform(0.3, 2.0, k)  # many outside
        res = identify_lm(
            [TrialData("t", markers, np.arange(40) / 100.0)],
            pset=pset, theta0=theta0, settings=settings, bounds=Bounds(lower, upper),
            priors=[landmark_prior(pset)],
        )  # fmt: skip
        assert np.all(res.theta >= lower) and np.all(res.theta <= upper)
        # at_bound: within 1e-12 (relative) of a bound, as IdentificationResult documents it.
        tol = 1e-12 * np.maximum(1.0, np.abs(res.theta))
        on_bound = (res.theta <= lower + tol) | (res.theta >= upper - tol)
        assert np.array_equal(res.at_bound, on_bound)
        if seed == 0:  # from the nominal model the fit reaches the cut bounds
            for name in ("thigh_length_l", "shank_length_r"):
                assert res.at_bound[pset.index(name)], name


def test_prior_interface_shapes(pset: ParameterSet) -> None:
    prior = LinearGaussianPrior(np.zeros((2, pset.size)), np.zeros(2), np.ones(2))
    assert prior.hessian().shape == (pset.size, pset.size)
    assert prior.gradient(pset.nominal).shape == (pset.size,)
