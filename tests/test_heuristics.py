"""The joint LM's safeguards (solve/heuristics.py), each on its own, and the box in the LM."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.solve.heuristics import RefitSchedule, StallMonitor, frame_rmse, refit_frames
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, Tolerances, identify_lm
from mocap_mj.solve.problem import Bounds, TrialData
from mocap_synth import SynthConfig, synthesize


@pytest.fixture(scope="module")
def exp():  # type: ignore[no-untyped-def]
    return synthesize(SynthConfig(frames=40, seed=5), ParameterSet())


def test_refit_replaces_only_frames_a_fresh_ik_fits_better(exp) -> None:  # type: ignore[no-untyped-def]
    kin = Kinematics(exp.pset)
    kin.set_theta(np.asarray(exp.theta_true))
    markers = np.asarray(exp.markers)
    qpos = np.asarray(exp.qpos).copy()
    wrong = np.array([3, 17, 30])
    rng = np.random.default_rng(0)
    qpos[wrong, 7:] += rng.normal(0, 0.6, (len(wrong), kin.nq - 7))  # joints far off
    before = qpos.copy()
    solver = IKSolver(kin)
    fixed = refit_frames(solver, markers, qpos, [slice(0, 20), slice(20, 40)])
    assert set(wrong) <= set(fixed.tolist())
    present = np.all(np.isfinite(markers), axis=2)
    dist = lambda q: np.linalg.norm(np.nan_to_num(markers) - kin.marker_positions(q), axis=2)  # noqa: E731
    assert np.all(
        frame_rmse(dist(qpos), present)[wrong] < 0.5 * frame_rmse(dist(before), present)[wrong]
    )
    untouched = np.setdiff1d(np.arange(40), fixed)
    np.testing.assert_array_equal(qpos[untouched], before[untouched])


def test_refit_judges_the_weighted_fit_by_its_own_weights(exp) -> None:  # type: ignore[no-untyped-def]
    # One marker displaced 30 mm in every frame and weighed down 100x: the weighted IK's poses
    # fit it badly on purpose. Judged unweighted (the old rule), a fresh unweighted IK "fits
    # better" and would swap the poses back at every refit; judged by the fit's own weights,
    # the weighted poses stand.
    kin = Kinematics(exp.pset)
    kin.set_theta(np.asarray(exp.theta_true))
    markers = np.asarray(exp.markers).copy()
    markers[:, 0] += 0.03
    weights = np.ones(markers.shape[:2])
    weights[:, 0] = 0.01
    solver = IKSolver(kin)
    segments = [slice(0, 20), slice(20, 40)]
    weighted = solver.solve_trial(markers, weights).qpos
    qpos = weighted.copy()
    assert len(refit_frames(solver, markers, qpos, segments, weights)) == 0
    np.testing.assert_array_equal(qpos, weighted)
    assert len(refit_frames(solver, markers, weighted.copy(), segments)) > 20


def test_refit_schedule_and_stall_monitor() -> None:
    sched = RefitSchedule(factor=1.5, settle_gain=1e-2, max_refits=2, last_rmse=0.003)
    assert sched.improved(True, 0.0019) and not sched.improved(False, 0.0019)
    assert not sched.improved(True, 0.0025)
    assert sched.settling(True, gain=0.5, cost=100.0) and not sched.settling(True, 5.0, 100.0)
    assert sched.take(4) and not sched.take_at_stop(6)  # within 3 iterations of the last
    assert sched.take_at_stop(8) and not sched.take(9)  # max_refits reached
    stall = StallMonitor(window=2, rel=1e-3)
    for r in (1.0, 0.9, 0.8999):
        stall.accepted(r)
    assert not stall.stalled(0.8999)  # 1.0 -> 0.8999 over the last 2 steps
    stall.accepted(0.89985)
    assert stall.stalled(0.89985)  # 0.9 -> 0.89985: below 1e-3 relative


def test_lm_stays_in_the_box_and_reports_the_bounds_it_ends_on(exp) -> None:  # type: ignore[no-untyped-def]
    pset = exp.pset
    rng = np.random.default_rng(1)
    theta0 = pset.nominal
    width = rng.uniform(0.0, 0.004, pset.size)  # truth: lengths +-10 %, offsets +-20 mm
    lower, upper = theta0 - width, theta0 + rng.uniform(0.0, 0.004, pset.size)
    trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
    r = identify_lm(
        [trial],
        pset=pset,
        bounds=Bounds(lower, upper),
        settings=LMSettings(max_iterations=4, tolerances=Tolerances(max_refits=0)),
    )
    assert np.all(r.theta >= lower) and np.all(r.theta <= upper)
    assert r.at_bound.any()
    on = r.at_bound
    assert np.all(
        np.isclose(r.theta[on], lower[on], atol=1e-12)
        | np.isclose(r.theta[on], upper[on], atol=1e-12)
    )
