"""Joint-centre lengths, their standard deviations and the residuals' correlation time."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.solve.consistency import (
    correlation_time,
    excited_lengths,
    joint_centre_lengths,
    length_std,
)
from mocap_mj.solve.lm import identify_lm
from mocap_mj.solve.noise import residual_correlation_time
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize


def test_correlation_time_of_white_and_repeated_residuals() -> None:
    rng = np.random.default_rng(0)
    assert residual_correlation_time(rng.normal(size=(400, 39, 3))) == pytest.approx(1.0, abs=0.3)
    repeated = np.repeat(rng.normal(size=(40, 39, 3)), 10, axis=0)  # each value for 10 frames
    assert 7.0 < residual_correlation_time(repeated) < 13.0
    gaps = rng.normal(size=(400, 39, 3))
    gaps[::7, 3] = np.nan  # missing samples are left out
    assert residual_correlation_time(gaps) == pytest.approx(1.0, abs=0.3)


def test_joint_centre_lengths_of_the_nominal_model() -> None:
    pset = ParameterSet()
    lengths = joint_centre_lengths(pset, pset.nominal)
    pos = pset.body_pos_nominal
    names = [pset.model.body(b).name for b in range(pset.model.nbody)]
    shank, foot = names.index("shank_r"), names.index("foot_r")
    assert lengths["thigh_r:shank_r"] == pytest.approx(np.linalg.norm(pos[shank]))
    assert lengths["shank_r:foot_r"] == pytest.approx(np.linalg.norm(pos[foot]))
    hips = pos[names.index("thigh_l")] - pos[names.index("thigh_r")]
    assert lengths["thigh_l:thigh_r"] == pytest.approx(np.linalg.norm(hips))
    assert "ulna_l:radius_l" not in lengths  # coincident centres have no length
    assert all(v > 0 for v in lengths.values())
    # Lengths move with the segment-length parameters, not with the marker offsets.
    theta = pset.nominal.copy()
    theta[pset.index("thigh_length_r")] += 0.01
    theta[pset.n_kappa :] += 0.02
    moved = joint_centre_lengths(pset, theta)
    assert moved["thigh_r:shank_r"] == pytest.approx(lengths["thigh_r:shank_r"] + 0.01)
    assert moved["thigh_l:shank_l"] == pytest.approx(lengths["thigh_l:shank_l"])


def test_white_noise_fit_excites_the_legs() -> None:
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=150, seed=3), pset)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    result = identify_lm([trial], pset=pset)
    tau = correlation_time(pset, result, [trial])
    assert tau < 2.0  # white synthetic noise: about one independent observation per frame
    white = length_std(pset, result)
    slow = length_std(pset, result, tau=4.0)
    assert all(slow[n] >= white[n] for n in white)
    excited = excited_lengths([white, white])
    assert {"thigh_r:shank_r", "thigh_l:shank_l"} <= set(excited)
    assert excited_lengths([white, {n: 1.0 for n in white}]) == []
