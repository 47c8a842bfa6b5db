"""Truth-motion presets: joint limits, smoothness, range of motion, reproducibility."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_synth import motion
from mocap_synth.motion import JointInfo, ball_angle, quat_to_rotvec, rotvec_to_quat

PRESETS = ("rom", "walk", "static")


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return ParameterSet().model


def _joint(model: mujoco.MjModel, kind: str) -> list[JointInfo]:
    return [j for j in motion.joints(model) if j.kind == kind]


def check_limits(model: mujoco.MjModel, qpos: np.ndarray) -> None:
    """Every hinge inside its range and every ball within its angle, by the margin or more."""
    assert qpos.shape[1] == model.nq and np.all(np.isfinite(qpos))
    for j in _joint(model, "hinge"):
        x = qpos[:, j.qadr]
        margin = 0.99 * j.margin
        assert x.min() >= j.lo + margin and x.max() <= j.hi - margin, j.name
    for j in _joint(model, "ball") + _joint(model, "free"):
        a = j.qadr + (3 if j.kind == "free" else 0)
        quat = qpos[:, a : a + 4]
        np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
        if j.kind == "ball":
            assert ball_angle(quat).max() <= j.hi - 0.99 * j.margin, j.name


def max_accelerations(model: mujoco.MjModel, qpos: np.ndarray, rate: float) -> np.ndarray:
    """Largest finite-difference acceleration: hinges and ball rotation vectors [rad/s^2], root
    position [m/s^2], as (3,)."""
    hinge = [j.qadr for j in _joint(model, "hinge")]
    rv = np.concatenate(
        [quat_to_rotvec(qpos[:, j.qadr : j.qadr + 4]) for j in _joint(model, "ball")], axis=1
    )
    free = _joint(model, "free")[0].qadr

    def acc(x: np.ndarray) -> float:
        return float(np.abs(np.diff(x, 2, axis=0)).max() * rate**2)

    return np.array([acc(qpos[:, hinge]), acc(rv), acc(qpos[:, free : free + 3])])


@pytest.mark.parametrize("name", PRESETS)
def test_preset_within_limits_and_smooth(model: mujoco.MjModel, name: str) -> None:
    qpos = motion.generate(name, model, 500, 100.0, np.random.default_rng(1))
    check_limits(model, qpos)
    acc = max_accelerations(model, qpos, 100.0)
    assert acc[0] < 200.0 and acc[1] < 200.0 and acc[2] < 10.0, acc
    # C2: the same motion sampled ten times faster has the same accelerations (a kink in the
    # velocity would grow them with the rate).
    fine = motion.generate(name, model, 4991, 1000.0, np.random.default_rng(1))
    check_limits(model, fine)
    np.testing.assert_allclose(fine[::10], qpos, atol=0.02)
    assert np.all(max_accelerations(model, fine, 1000.0) < 1.2 * acc + 1.0)


@pytest.mark.parametrize("name", PRESETS)
@pytest.mark.parametrize(("frames", "rate"), [(1, 100.0), (7, 30.0), (1200, 240.0)])
def test_any_rate_and_length(model: mujoco.MjModel, name: str, frames: int, rate: float) -> None:
    qpos = motion.generate(name, model, frames, rate, np.random.default_rng(2))
    assert qpos.shape == (frames, model.nq)
    check_limits(model, qpos)
    again = motion.generate(name, model, frames, rate, np.random.default_rng(2))
    np.testing.assert_array_equal(qpos, again)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rom_moves_every_joint(model: mujoco.MjModel, seed: int) -> None:
    qpos = motion.rom(model, 500, 100.0, np.random.default_rng(seed))
    for j in _joint(model, "hinge"):
        x = qpos[:, j.qadr]
        assert x.max() - x.min() >= 0.5 * (j.hi - j.lo), j.name
    for j in _joint(model, "ball"):
        quat = qpos[:, j.qadr : j.qadr + 4]
        assert ball_angle(quat).max() >= 0.5 * j.hi, j.name
        rv = quat_to_rotvec(quat)
        # about all three axes, not along one fixed axis
        assert np.all(rv.max(axis=0) - rv.min(axis=0) >= 0.3 * j.hi), j.name
        spread = np.linalg.svd(rv - rv.mean(axis=0), compute_uv=False) / np.sqrt(len(rv))
        assert spread.min() > 0.03 * j.hi, j.name  # RMS along the least-moved direction
    root = qpos[:, :3]
    assert np.all(root.max(axis=0) - root.min(axis=0) > 0.04)
    yaw = quat_to_rotvec(qpos[:, 3:7])[:, 2]
    assert yaw.max() - yaw.min() > np.radians(60)
    # Several joints at once, each with its own timing: no two hinges move in lockstep.
    hinges = qpos[:, [j.qadr for j in _joint(model, "hinge")]]
    corr = np.corrcoef(hinges.T) - np.eye(hinges.shape[1])
    assert np.abs(corr).max() < 0.99
    # Eases in from and out to the standing pose.
    np.testing.assert_allclose(qpos[0], model.qpos0, atol=1e-9)
    np.testing.assert_allclose(qpos[-1], model.qpos0, atol=1e-3)


def test_walk_goes_forward(model: mujoco.MjModel) -> None:
    qpos = motion.walk(model, 500, 100.0, np.random.default_rng(0))
    speed = (qpos[-1, 0] - qpos[0, 0]) / 4.99
    assert 1.0 < speed < 1.6
    assert np.ptp(qpos[:, 1]) < 0.1  # straight line
    names = {j.name: j for j in motion.joints(model)}
    knee = qpos[:, names["knee_flex_l"].qadr]
    assert np.radians(50) < knee.max() < np.radians(75) and knee.min() < np.radians(10)
    # left and right legs half a cycle apart
    right = qpos[:, names["knee_flex_r"].qadr]
    assert np.corrcoef(knee, right)[0, 1] < 0.0


def test_static_is_nearly_still(model: mujoco.MjModel) -> None:
    qpos = motion.static(model, 1000, 100.0, np.random.default_rng(0))
    assert np.ptp(qpos[:, :3], axis=0).max() < 0.03
    hinge = qpos[:, [j.qadr for j in _joint(model, "hinge")]]
    assert np.ptp(hinge, axis=0).max() < np.radians(3)
    assert np.ptp(qpos[:, :3], axis=0).max() > 0.001  # sways


def test_rotation_helpers() -> None:
    rng = np.random.default_rng(0)
    rv = rng.normal(0, 1, (50, 3))
    rv *= (np.minimum(np.linalg.norm(rv, axis=1), 3.0) / np.linalg.norm(rv, axis=1))[:, None]
    quat = rotvec_to_quat(rv)
    np.testing.assert_allclose(quat_to_rotvec(quat), rv, atol=1e-12)
    np.testing.assert_allclose(ball_angle(quat), np.linalg.norm(rv, axis=1), atol=1e-12)
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, quat[0])
    axis = rv[0] / np.linalg.norm(rv[0])
    np.testing.assert_allclose(mat.reshape(3, 3) @ axis, axis, atol=1e-12)
    np.testing.assert_allclose(rotvec_to_quat(np.zeros(3)), [1, 0, 0, 0])


def test_soft_clip() -> None:
    x = np.linspace(-5.0, 5.0, 2001)
    y = motion.soft_clip(x, -1.0, 2.0, 0.3)
    assert np.all(y > -1.0) and np.all(y < 2.0) and np.all(np.diff(y) > 0)
    inner = (x >= -0.7) & (x <= 1.7)
    np.testing.assert_array_equal(y[inner], x[inner])
    r = np.array([[0.1, 0.0, 0.0], [3.0, 4.0, 0.0]])
    out = motion.soft_clip_norm(r, 2.0, 0.2)
    np.testing.assert_array_equal(out[0], r[0])
    assert 1.8 < np.linalg.norm(out[1]) < 2.0
    np.testing.assert_allclose(out[1] / np.linalg.norm(out[1]), [0.6, 0.8, 0.0])
