"""Ball-joint centres against their regression: a walk's soft-tissue artefact does not move
the hips off a regression that is right, a functional trial moves them to a truth off it,
and summary.json's ``joint_centres_vs_regression`` agrees with theta
(mocap_mj/identify/ball_centres.py, docs/model.md#hip-centres-regression-and-data)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import mocap_mj
from mocap_synth import SynthConfig, synthesize
from mocap_synth.centres import at_regression

HIPS = ("hip_l", "hip_r")


def _fit(motion: str, sta_mm: float, seed: int, shift: float = 0.0) -> tuple[Any, Any]:
    exp = synthesize(SynthConfig(frames=500, motion=motion, noise_mm=1.0, sta_mm=sta_mm,
                                 seed=seed))  # fmt: skip
    names = ("hip_width_l", "hip_width_r")
    exp = at_regression(exp, {n: shift for n in names})
    trial = mocap_mj.TrialData("synth", np.array(exp.markers), np.array(exp.times))
    return exp, mocap_mj.identify([trial], mocap_mj.Recipe(), None, rates=[100.0])


@pytest.mark.parametrize("seed", [0, 1])
def test_walk_with_soft_tissue_keeps_hips_at_a_true_regression(seed: int) -> None:
    """Truth at the regression, a walk with 10 mm/rad of soft-tissue artefact: each hip
    within 4 mm of it (without the artefact floor the same trials put them 8-11 mm off)."""
    _, fit = _fit("walk", 10.0, seed)
    report = fit.report["joint_centres_vs_regression"]
    for hip in HIPS:
        assert report[hip]["distance_mm"] < 4.0, (hip, report[hip])
        assert not report[hip]["moved_by_data"]
        rows = report[hip]["rows"].values()
        lateral = next(r for r in rows if r["artefact_floor_mm"] > 30.0)  # the walk's 5 deg
        assert lateral["width_factor"] < 0.3


def test_functional_trial_moves_hips_to_a_truth_off_the_regression() -> None:
    """A range-of-motion trial (hip 40-100 degrees every way, white noise) whose truth hips
    sit 15 mm lateral of the regression: the identified centres move there, within 2.5 of
    their reported standard deviations, and are flagged as moved by the data."""
    _, fit = _fit("rom", 0.0, 0, shift=0.015)
    pset = fit.pset
    report = fit.report["joint_centres_vs_regression"]
    ident = pset.body_pos(fit.theta)
    for hip, body in zip(HIPS, ("thigh_l", "thigh_r"), strict=True):
        entry = report[hip]
        assert entry["moved_by_data"]
        assert 10.0 < entry["distance_mm"] < 20.0
        b = pset.model.body(body).id
        # The centre relative to its pelvis markers (the regression moves with them).
        reg = np.asarray(entry["regression_mm"]) * 1e-3
        offset = np.array([0.0, 0.015 if hip == "hip_l" else -0.015, 0.0])
        err = (ident[b] - reg) - offset
        assert np.linalg.norm(err) * 1e3 < 2.5 * entry["distance_sd_mm"] + 1.0, (hip, err)


def test_report_fields_agree_with_theta() -> None:
    """identified_mm is the thigh's position in theta; regression_mm + the rows'
    distances give it back; distance_mm is their norm; report.md lists both hips."""
    _, fit = _fit("walk", 10.0, 2)
    pset = fit.pset
    report = fit.report["joint_centres_vs_regression"]
    assert set(HIPS) <= set(report)
    for entry in report.values():
        b = pset.model.body(entry["body"]).id
        np.testing.assert_allclose(entry["identified_mm"], pset.body_pos(fit.theta)[b] * 1e3)
        d = [r["from_regression_mm"] for r in entry["rows"].values()]
        assert entry["distance_mm"] == pytest.approx(float(np.linalg.norm(d)))
        diff = np.asarray(entry["identified_mm"]) - np.asarray(entry["regression_mm"])
        assert np.linalg.norm(diff) == pytest.approx(entry["distance_mm"], abs=1e-6)
        assert entry["distance_sd_mm"] > 0 and "davis_mm" in entry
    from mocap_mj.identify.output import centre_lines

    lines = centre_lines(report)
    assert sum(line.startswith("| hip_") for line in lines) == 2
