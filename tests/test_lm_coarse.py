"""Coarse to fine (:mod:`mocap_mj.solve.coarse`): the LM's approach on a subset of the
frames ends at the same minimum as the LM on every frame alone."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.solve.coarse import coarse_rows
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMSettings, Tolerances, identify_lm
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.selection import PELVIS
from mocap_synth import SynthConfig, synthesize

FRAMES, SUBSET = 300, 60


@pytest.mark.slow
def test_coarse_phase_reaches_the_plain_lms_minimum() -> None:
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=FRAMES, seed=1), pset)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    plain = identify_lm(
        [trial], pset=pset, settings=LMSettings(tolerances=Tolerances(coarse_frames=0))
    )
    coarse = identify_lm(
        [trial], pset=pset, settings=LMSettings(tolerances=Tolerances(coarse_frames=SUBSET))
    )
    # The coarse phase ran on the subset, the fine phase on every frame, numbered on.
    frames = [log.frames for log in coarse.trace]
    k = frames.count(SUBSET)
    assert k >= 2 and frames == [SUBSET] * k + [FRAMES] * (len(frames) - k)
    assert [log.iteration for log in coarse.trace] == list(range(1, coarse.iterations + 1))
    assert all(log.frames == FRAMES for log in plain.trace)
    # The same minimum: both stop once a step lowers F by less than sigma^2; their final F
    # differ by a small fraction of it (the 500-frame seeds 0-9: at most 0.11 sigma^2).
    sigma2 = plain.sigma**2
    assert abs(coarse.trace[-1].cost - plain.trace[-1].cost) < 0.5 * sigma2
    # ... and the same estimate in every direction the data determine, to within what the
    # stopping rule resolves (a last step lowering F by sigma^2 moves theta by up to 1.4
    # standard deviations along one direction; here 0.5, stopped one LM iteration early 0.75
    # and F 5.6 sigma^2 above): standard deviations of the plain LM's reduced information.
    idf = Identifiability(pset, plain.reduced_information, plain.sigma, theta=plain.theta)
    std = idf.direction_std[idf.observable]
    white = idf.basis.T @ (coarse.theta - plain.theta) / std
    assert np.max(np.abs(white)) < 1.0, np.max(np.abs(white))
    assert abs(coarse.marker_rmse - plain.marker_rmse) < 1e-3 * plain.marker_rmse


def test_coarse_rows_only_for_long_enough_trials() -> None:
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=120, seed=2), pset)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    assert coarse_rows([trial], pset, 60) is None  # 120 frames: not more than twice 60
    assert coarse_rows([trial], pset, 0) is None
    rows = coarse_rows([trial, trial], pset, 50)
    assert rows is not None and [len(r) for r in rows] == [25, 25]
    assert all(np.all(np.diff(r) > 0) and r[-1] < 120 for r in rows)
    # Without the pelvis markers the pose features need: evenly spaced frames.
    blind = np.asarray(exp.markers).copy()
    blind[:, [pset.marker_index(n) for n in PELVIS]] = np.nan
    rows = coarse_rows([TrialData("blind", blind, trial.times)], pset, 50)
    assert rows is not None and np.array_equal(rows[0], np.linspace(0, 119, 50).round())
