"""The segments' masses fitted to the loads (mocap_mj/pipeline/inertial_fit.py) against a
synthetic truth.

The regression: the bundled humanoid with de Leva's parameters for 75 kg. The truth: its 16
segment bodies' masses (and first moments and inertias) scaled by 0.8-1.25. The loads: the
truth's needed root wrench on the right foot (its own inverse dynamics), so that the truth
leaves no residual. Asserted: the columns add up to the whole inverse dynamics (linearity);
every body the fit calls determined is within 10 % of the truth (the target; measured 1.4 % at
most with a 1 % body-weight noise on the force); a static pose determines at most the three
combinations gravity sees (the weight and the centre of mass's horizontal place).
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.inertia import inertial_model, segment_inertia
from mocap_mj.errors import MocapError
from mocap_mj.pipeline import dynamics as dy
from mocap_mj.pipeline.inertial_fit import Trial, fit_masses, root_columns
from mocap_mj.skeleton import exported
from mocap_mj.skeleton.mjcf import load_model

MASS, FRAMES = 75.0, 150


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory) -> dict:
    pset = ParameterSet()
    path = tmp_path_factory.mktemp("mass_fit") / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    regression = inertial_model(path, MASS)
    inertia = segment_inertia(load_model(path), MASS)
    bodies = [b for b, n in zip(inertia.bodies, inertia.length, strict=True) if n > 0]
    rng = np.random.default_rng(0)
    scale = dict(zip(bodies, rng.uniform(0.8, 1.25, len(bodies)), strict=True))
    truth = copy.deepcopy(regression)
    for b, s in scale.items():
        truth.body_mass[truth.body(b).id] *= s
        truth.body_inertia[truth.body(b).id] *= s
    layout = exported.Layout.of(pset.model)
    qpos = layout.written(smooth_motion(Kinematics(pset), FRAMES, seed=4))
    return {"pset": pset, "regression": regression, "truth": truth, "bodies": bodies,
            "scale": scale, "qpos": qpos, "layout": layout}  # fmt: skip


def _needed_load(truth: mujoco.MjModel, qpos: np.ndarray, noise: float, seed: int) -> dy.BodyLoad:
    """The truth's root wrench as a load on the right foot, at the root body's origin, its
    force with a Gaussian noise of ``noise`` [N] per axis."""
    times = np.arange(len(qpos)) / 100.0
    need = dy.inverse_dynamics(truth, qpos, times, cutoff_hz=None)
    data, root = mujoco.MjData(truth), int(truth.jnt_bodyid[0])
    point = np.zeros((len(qpos), 3))
    for t in range(len(qpos)):
        data.qpos[:] = need.qpos[t]
        mujoco.mj_kinematics(truth, data)
        point[t] = data.xpos[root]
    jitter = np.random.default_rng(seed).normal(0.0, noise, (len(qpos), 3))
    return dy.BodyLoad("foot_r", need.root_force + jitter, point, need.root_moment)


def test_the_columns_add_up_to_the_whole_inverse_dynamics(case: dict) -> None:
    model, qpos = case["regression"], case["qpos"]
    times = np.arange(FRAMES) / 100.0
    load = _needed_load(case["truth"], qpos, 0.0, 0)
    trial = Trial(qpos, times, [load], np.ones(FRAMES, bool))
    base, cols = root_columns(model, trial, case["bodies"], None)
    whole = dy.inverse_dynamics(model, qpos, times, [load], cutoff_hz=None)
    total = base + cols.sum(axis=2)
    np.testing.assert_allclose(total[:, :3], whole.root_force, atol=1e-8)
    np.testing.assert_allclose(total[:, 3:], whole.root_moment, atol=1e-8)


@pytest.mark.parametrize("noise_pct_bw", [0.0, 1.0])
def test_the_determined_masses_are_the_truth_s(case: dict, noise_pct_bw: float) -> None:
    qpos, times = case["qpos"], np.arange(FRAMES) / 100.0
    load = _needed_load(case["truth"], qpos, noise_pct_bw / 100 * MASS * 9.80665, 1)
    fit = fit_masses(case["regression"], [Trial(qpos, times, [load], np.ones(FRAMES, bool))],
                     case["bodies"], cutoff_hz=None)  # fmt: skip
    truth = np.array([case["scale"][b] for b in fit.bodies])
    assert fit.determined.sum() >= 12
    error = np.abs(fit.scale / truth - 1)[fit.determined]
    assert error.max() < 0.10, fit.scale / truth
    assert fit.residual_after[0] < 0.5 * fit.residual_before[0]
    np.testing.assert_allclose(fit.mass_after, fit.mass_before * fit.scale)


def test_a_static_pose_determines_only_what_gravity_sees(case: dict) -> None:
    """Standing still: the root wrench is the weight and its moment, three combinations of
    the masses; the fit leaves the rest at the regression and says so."""
    qpos = np.tile(case["qpos"][:1], (30, 1))
    times = np.arange(30) / 100.0
    load = _needed_load(case["truth"], qpos, 0.0, 0)
    fit = fit_masses(case["regression"], [Trial(qpos, times, [load], np.ones(30, bool))],
                     case["bodies"], cutoff_hz=None)  # fmt: skip
    sv = fit.singular_values
    assert np.sum(sv > 1e-6 * sv[0]) == 3
    assert fit.determined.sum() <= 3
    assert fit.residual_after[0] < 1e-3 * fit.residual_before[0] + 1e-6


def test_no_fitted_frame_is_one_clear_error(case: dict) -> None:
    qpos, times = case["qpos"][:20], np.arange(20) / 100.0
    with pytest.raises(MocapError, match="no frame"):
        fit_masses(case["regression"], [Trial(qpos, times, [], np.zeros(20, bool))],
                   case["bodies"][:2], cutoff_hz=None)  # fmt: skip
