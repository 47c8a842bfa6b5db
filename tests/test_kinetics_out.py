"""The feet's plate loads on the model (mocap_mj/outputs/kinetics_out.py) against ground truth.

The truth: a smooth motion of the bundled humanoid (written, the knees' slides) whose whole
wrench (the root residual without loads, :mod:`tests.test_dynamics` checks it is Newton's
and Euler's) stands on the right foot as a force plate measures it: force, centre of pressure
on the floor and free moment about the vertical. Through ``body_loads`` the inverse dynamics
then leave no residual, and the joint moments equal those under the same wrench given as a
general load at another point; grf.csv holds the loads as given.
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.capture.contacts import FootLoads
from mocap_mj.outputs.dynamics_out import STANDARD_GRAVITY
from mocap_mj.outputs.kinetics_out import body_loads, grf_table, residual_figures, stance_frames
from mocap_mj.pipeline import dynamics as dy
from mocap_mj.skeleton import exported

MASS = 75.0  # [kg]
RATE = 100.0  # [Hz]
FRAMES = 200


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    pset = ParameterSet()
    path = tmp_path_factory.mktemp("kin") / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    model = inertial_model(path, MASS)
    q = exported.Layout.of(pset.model).written(smooth_motion(Kinematics(pset), FRAMES, seed=7))
    times = np.arange(FRAMES) / RATE
    free = dy.inverse_dynamics(model, q, times, cutoff_hz=None)
    root = np.array(free.qpos[:, :3])  # the pelvis origin (the free joint's position)
    force = free.root_force
    moment_o = free.root_moment + np.cross(root, force)  # about the world origin
    # as a floor plate measures it (z = 0, normal +z): cop = z x M / Fz, free moment about z
    up = np.array([0.0, 0.0, 1.0])
    fz = force[:, 2]
    on = fz > 0.2 * MASS * STANDARD_GRAVITY  # the plate sees a load (a threshold, as read)
    cop = np.full((FRAMES, 3), np.nan)
    cop[on] = np.cross(up, moment_o[on]) / fz[on, None]
    free_moment = np.zeros((FRAMES, 3))
    free_moment[on, 2] = (moment_o[on] - np.cross(cop[on], force[on]))[:, 2]
    right = FootLoads("right", np.where(on[:, None], force, 0.0), cop, free_moment, on, ())
    n = np.zeros((FRAMES, 3))
    left = FootLoads("left", n, np.full((FRAMES, 3), np.nan), n, np.zeros(FRAMES, bool), ())
    return {"model": model, "q": q, "times": times, "free": free, "feet": (left, right), "on": on}


def test_the_plate_form_of_the_needed_wrench_leaves_no_residual(case: dict) -> None:
    on = case["on"]
    assert on.sum() > FRAMES // 2  # the motion's wrench points up on most frames
    loaded = dy.inverse_dynamics(
        case["model"], case["q"], case["times"], body_loads(case["feet"]), cutoff_hz=None
    )
    weight = MASS * STANDARD_GRAVITY
    assert np.abs(loaded.root_force[on]).max() < 1e-6 * weight
    assert np.abs(loaded.root_moment[on]).max() < 1e-6 * weight  # [N m], a 1 m lever
    # off the plate nothing is applied: the free residual
    np.testing.assert_allclose(loaded.tau[~on], case["free"].tau[~on], rtol=0, atol=1e-9)
    # the same wrench as a general load at the foot's origin moves the joints alike
    free, right = case["free"], case["feet"][1]
    point = np.array(free.qpos[:, :3]) * (1, 1, 0)  # below the pelvis, on the floor
    point[~on] = np.nan
    moment = right.free_moment + np.cross(np.nan_to_num(right.cop) - point, right.force)
    general = dy.BodyLoad("foot_r", right.force, point, np.nan_to_num(moment))
    other = dy.inverse_dynamics(case["model"], case["q"], case["times"], [general], cutoff_hz=None)
    peak = np.abs(free.tau).max()
    np.testing.assert_allclose(loaded.tau[on], other.tau[on], rtol=0, atol=1e-9 * peak)

    fig = residual_figures(loaded, case["feet"], MASS, stance_frames(case["feet"]))
    assert fig.frames == on.sum()
    assert fig.force_rms_pct_bw < 1e-4 and fig.moment_rms_nm < 1e-4
    assert fig.peak_grf_n == pytest.approx(np.linalg.norm(right.force, axis=1).max())


def test_grf_csv_holds_the_loads_as_given(case: dict) -> None:
    right = case["feet"][1]
    text = grf_table(case["times"], case["feet"])
    table = np.genfromtxt(io.StringIO(text), delimiter=",", names=True)
    assert table.dtype.names[:2] == ("time_s", "left_force_X_N")
    for a, k in zip("XYZ", range(3), strict=True):
        np.testing.assert_allclose(table[f"right_force_{a}_N"], right.force[:, k], rtol=1e-5)
    on = case["on"]
    np.testing.assert_allclose(table["right_cop_X_m"][on], right.cop[on, 0], rtol=1e-5, atol=1e-9)
    assert np.isnan(table["right_cop_X_m"][~on]).all()  # empty cells off the plate
    np.testing.assert_allclose(
        table["right_free_moment_Z_Nm"], right.free_moment[:, 2], rtol=1e-5, atol=1e-9
    )
    assert (table["right_on_plate"] == on).all() and (table["left_on_plate"] == 0).all()
