"""Ball-joint centres against their regression: a walk's soft-tissue artefact does not move
the hips off a regression that is right, a functional trial moves them to a truth off it,
and summary.json's ``joint_centres_vs_regression`` agrees with theta
(mocap_mj/anatomy/ball_centres.py, docs/model.md#hip-centres-regression-and-data)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import mocap_mj
from mocap_mj.anatomy.anatomy import landmark_prior
from mocap_mj.anatomy.ball_centres import RowSpread, centre_rows, rotation_spread
from mocap_synth import SynthConfig, synthesize
from mocap_synth.centres import at_regression

HIPS = ("hip_l", "hip_r")


def _fit(motion: str, sta_mm: float, seed: int, shift: float = 0.0) -> tuple[Any, Any]:
    exp = synthesize(SynthConfig(frames=500, motion=motion, noise_mm=1.0, sta_mm=sta_mm,
                                 seed=seed))  # fmt: skip
    names = ("hip_width_l", "hip_width_r")
    exp = at_regression(exp, {n: shift for n in names})
    trial = mocap_mj.TrialData("synth", np.array(exp.markers), np.array(exp.times))
    at_100_hz = mocap_mj.Recording(trial.name, trial.markers, trial.times, 100.0)
    return exp, mocap_mj.identify([at_100_hz], mocap_mj.Recipe(), None)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_walk_with_soft_tissue_keeps_hips_at_a_true_regression(seed: int) -> None:
    """Truth at the regression, a walk with 10 mm/rad of soft-tissue artefact: each hip
    within 4 mm of it (without the artefact floor the same trials put them 8-11 mm off)."""
    _, fit = _fit("walk", 10.0, seed)
    report = fit.report.centres_vs_regression
    for hip in HIPS:
        assert report[hip].distance < 0.004, (hip, report[hip])
        assert not report[hip].moved_by_data
        spreads = [r.spread for r in report[hip].rows.values() if r.spread is not None]
        lateral = next(s for s in spreads if s.floor_m > 0.030)  # the walk's 5 deg
        assert lateral.factor < 0.3


def test_functional_trial_moves_hips_to_a_truth_off_the_regression() -> None:
    """A range-of-motion trial (hip 40-100 degrees every way, white noise) whose truth hips
    sit 15 mm lateral of the regression: the identified centres move there, within 2.5 of
    their reported standard deviations, and are flagged as moved by the data."""
    _, fit = _fit("rom", 0.0, 0, shift=0.015)
    pset = fit.pset
    assert "centre_widths" not in fit.summary()["prior_weighting"]  # white noise: rows as they are
    report = fit.report.centres_vs_regression
    ident = pset.body_pos(fit.theta)
    for hip, body in zip(HIPS, ("thigh_l", "thigh_r"), strict=True):
        entry = report[hip]
        assert entry.moved_by_data
        assert 0.010 < entry.distance < 0.020
        b = pset.model.body(body).id
        # The centre relative to its pelvis markers (the regression moves with them).
        offset = np.array([0.0, 0.015 if hip == "hip_l" else -0.015, 0.0])
        err = (ident[b] - entry.regression_centre) - offset
        assert np.linalg.norm(err) < 2.5 * entry.distance_sd + 0.001, (hip, err)


@pytest.mark.slow
def test_report_fields_agree_with_theta() -> None:
    """summary.json's identified_mm is the thigh's position in theta; regression_mm + the
    rows' distances give it back; distance_mm is their norm and the typed report's distance
    in mm; report.md lists both hips."""
    _, fit = _fit("walk", 10.0, 2)
    pset = fit.pset
    report = fit.summary()["joint_centres_vs_regression"]
    for joint, centre in fit.report.centres_vs_regression.items():
        assert report[joint]["distance_mm"] == pytest.approx(centre.distance * 1e3, abs=1e-9)
    assert set(HIPS) <= set(report)
    for entry in report.values():
        b = pset.model.body(entry["body"]).id
        np.testing.assert_allclose(entry["identified_mm"], pset.body_pos(fit.theta)[b] * 1e3)
        d = [r["from_regression_mm"] for r in entry["rows"].values()]
        assert entry["distance_mm"] == pytest.approx(float(np.linalg.norm(d)))
        diff = np.asarray(entry["identified_mm"]) - np.asarray(entry["regression_mm"])
        assert np.linalg.norm(diff) == pytest.approx(entry["distance_mm"], abs=1e-6)
        assert entry["distance_sd_mm"] > 0 and "davis_mm" in entry
    from mocap_mj.outputs.write_fit import centre_lines

    lines = centre_lines(report)
    assert sum(line.startswith("| hip_") for line in lines) == 2


def test_centre_rows_are_the_hip_regressions() -> None:
    """The Harrington rows of both hips, one per pelvis-frame axis."""
    pset = mocap_mj.ParameterSet()
    rows = centre_rows(pset, landmark_prior(pset))
    assert sorted({c.joint for c in rows}) == ["hip_l", "hip_r"]
    for joint in HIPS:
        axes = np.array([np.abs(c.axis) for c in rows if c.joint == joint])
        np.testing.assert_allclose(axes[np.argsort(np.argmax(axes, axis=1))], np.eye(3))


def test_rotation_spread_of_a_turn_about_one_axis() -> None:
    """A hip turning +-0.3 rad about the pelvis x axis: K = 0.045 (I - x x^T) rad^2 (the
    mean square angle 0.3^2 / 2), so a centre shift along x moves no marker; the floor
    sigma^2 u^T K^-1 u is 5 mm / 0.21 rad = 24 mm along y."""
    pset = mocap_mj.ParameterSet()
    t = np.linspace(0.0, 2 * np.pi, 401)[:-1]
    angle = 0.3 * np.sin(t)
    q = np.tile(pset.model.qpos0, (len(t), 1))
    adr = int(pset.model.jnt_qposadr[pset.model.joint("hip_l").id])
    q[:, adr : adr + 4] = np.stack([np.cos(angle / 2), np.sin(angle / 2), 0 * t, 0 * t], 1)
    k = rotation_spread(pset, [q], "hip_l")
    np.testing.assert_allclose(k, 0.045 * np.diag([0.0, 1.0, 1.0]), atol=1e-5)
    floor = 0.005 * np.sqrt(np.linalg.solve(k, np.array([0.0, 1.0, 0.0]))[1])
    assert floor == pytest.approx(0.005 / np.sqrt(0.045), rel=1e-4)
    s = RowSpread(data_m=0.004, floor_m=floor, prior_m=0.008)
    assert s.factor == pytest.approx(np.sqrt(0.004**2 / (0.004**2 + floor**2)))
    assert s.posterior_m == pytest.approx((1 / 0.008**2 + 1 / (0.004**2 + floor**2)) ** -0.5)
