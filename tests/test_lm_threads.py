"""The speed paths of issue 18m give the answers of the paths they replace, to the last bit:
cold starts batched over the threads (:meth:`IKSolver._best_start`, ``min_block``)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.solve.ik import IKSolver
from mocap_synth import SynthConfig, synthesize


@pytest.fixture(scope="module")
def frames() -> tuple[IKSolver, np.ndarray]:
    """A solver under the nominal model and 40 frames of a synthetic ROM trial (every
    fifth: poses far apart, as a coarse subset's)."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=200, seed=2), pset)
    return IKSolver(Kinematics(pset)), np.asarray(exp.markers)[::5]


def test_frames_do_not_depend_on_the_blocks(frames: tuple[IKSolver, np.ndarray]) -> None:
    solver, markers = frames
    cold = solver.root_from_pelvis(markers)
    if numba.get_num_threads() < 2:
        pytest.skip("one numba thread: every batch runs in one block")
    one = solver.solve_frames(markers, cold)  # 40 frames: one block (PARALLEL_MIN 32)
    many = solver.solve_frames(markers, cold, min_block=4)  # spread over the threads
    assert np.array_equal(one.qpos, many.qpos, equal_nan=True)
    assert np.array_equal(one.marker_rmse, many.marker_rmse, equal_nan=True)


def test_best_start_is_the_best_of_each_start_solved_alone(
    frames: tuple[IKSolver, np.ndarray],
) -> None:
    solver, markers = frames
    _, w = solver._prepare(markers, None)
    cold = solver.root_from_pelvis(markers)
    # The rule as it was written per start: the solution from the rigid fit, replaced by an
    # arm configuration's where that fits 10 % better (here on 11-13 of the 40 frames).
    first = solver.solve_frames(markers, cold, w)
    fit = np.nan_to_num(first.marker_rmse, nan=np.inf)
    expected = np.where(np.isfinite(fit)[:, None], first.qpos, cold)
    for q0 in solver._arm_starts(cold):
        r = solver.solve_frames(markers, q0, w)
        rmse = np.nan_to_num(r.marker_rmse, nan=np.inf)
        better = rmse < 0.9 * fit
        expected[better] = r.qpos[better]
        fit = np.where(better, rmse, fit)
    assert np.array_equal(solver._best_start(markers, w, cold), expected)
