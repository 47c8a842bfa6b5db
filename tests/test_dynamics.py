"""Inverse dynamics (mocap_mj/pipeline/dynamics.py) against ground truth computed another way.

(a) Without external loads the root residual is the wrench the motion needs: Newton's
    m c'' - m g from the centre-of-mass trajectory, and Euler's dH_c/dt from the bodies'
    positions and orientations alone (finite differences, not MuJoCo's velocities).
(b) That wrench put on a foot as a BodyLoad leaves no residual, and changes each joint's
    moment by exactly the load's moment about that joint, only on the path to that foot.
(c) Standing still on one foot, the ankle's, subtalar's and knee's moments are the
    gravitational moment of the body above them about their axes.
(d) A pendulum's torque is (I + m l^2) theta'' + m g l sin(theta).
And the smoothing: a sinusoid's derivative through the filter, a ball joint's spin.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _motion import smooth_motion

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.errors import MocapError, ShapeError, UnknownNameError
from mocap_mj.pipeline import dynamics as dy
from mocap_mj.skeleton import exported
from mocap_mj.skeleton.mjcf import load_model

MASS = 75.0  # [kg]
RATE = 100.0  # [Hz]
FRAMES = 300
EDGE = 3  # frames left out at each end, where the finite differences are one-sided


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


@pytest.fixture(scope="module")
def model(pset: ParameterSet, tmp_path_factory: pytest.TempPathFactory) -> mujoco.MjModel:
    """The bundled humanoid as the tool writes it (the knees' slides), de Leva's figures."""
    path = tmp_path_factory.mktemp("dyn") / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    return inertial_model(path, MASS)


@pytest.fixture(scope="module")
def motion(pset: ParameterSet) -> tuple[np.ndarray, np.ndarray]:
    """(qpos (T, 59) in the written layout, times (T,) [s]): a smooth motion of every joint
    and the root, the knees flexing and rolling."""
    q = smooth_motion(Kinematics(pset), FRAMES, seed=4)
    return exported.Layout.of(pset.model).written(q), np.arange(FRAMES) / RATE


@pytest.fixture(scope="module")
def free(model: mujoco.MjModel, motion: tuple[np.ndarray, np.ndarray]) -> dy.Dynamics:
    return dy.inverse_dynamics(model, *motion, cutoff_hz=None)


def _second_difference(x: np.ndarray) -> np.ndarray:
    out = np.full_like(x, np.nan)
    out[1:-1] = (x[2:] - 2 * x[1:-1] + x[:-2]) * RATE**2
    return out


def _vee_log(r: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) of the rotation matrix r (3, 3)."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, r.ravel())
    vec = np.zeros(3)
    mujoco.mju_quat2Vel(vec, quat, 1.0)
    return vec


def _needed_wrench(
    model: mujoco.MjModel, qpos: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton and Euler from positions alone: the external force (T, 3) [N] and moment about
    the root body's origin (T, 3) [N m] the motion qpos needs, and that origin (T, 3) [m]."""
    data = mujoco.MjData(model)
    frames, nb = len(qpos), model.nbody
    x, rot, root = np.zeros((frames, nb, 3)), np.zeros((frames, nb, 3, 3)), np.zeros((frames, 3))
    for t, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        x[t], rot[t] = data.xipos, data.ximat.reshape(nb, 3, 3)
        root[t] = data.xpos[1]
    m = model.body_mass
    total = m.sum()
    com = np.einsum("b,tbi->ti", m, x) / total
    force = total * (_second_difference(com) - model.opt.gravity)
    # angular momentum about the centre of mass, from finite differences of the body frames
    vel = np.full_like(x, np.nan)
    vel[1:-1] = (x[2:] - x[:-2]) * RATE / 2
    omega = np.zeros_like(x)
    omega[[0, -1]] = np.nan
    for t in range(1, frames - 1):
        for b in range(1, nb):
            step = rot[t + 1, b] @ rot[t - 1, b].T
            omega[t, b] = _vee_log(step) * RATE / 2
    inertia_world = np.einsum("tbij,bj,tbkj->tbik", rot, model.body_inertia, rot)
    spin = np.einsum("tbij,tbj->tbi", inertia_world, omega)
    orbit = np.cross(x - com[:, None], vel) * m[None, :, None]
    h = (spin + orbit).sum(axis=1)
    dh = np.full_like(h, np.nan)
    dh[1:-1] = (h[2:] - h[:-2]) * RATE / 2
    moment = dh + np.cross(com - root, force)
    return force, moment, root


@pytest.mark.parametrize("cutoff", [None, dy.CUTOFF_HZ])
def test_root_residual_is_the_wrench_the_motion_needs(
    model: mujoco.MjModel, motion: tuple[np.ndarray, np.ndarray], cutoff: float | None
) -> None:
    """Newton within 0.1 % of body weight and Euler within 0.5 N m (the finite differences'
    O(dt^2) over position data, 100 Hz), unfiltered and on the filtered motion (its rebuilt
    qpos and its derivatives agree away from the filter's start-up, 10 frames at each end)."""
    free = dy.inverse_dynamics(model, *motion, cutoff_hz=cutoff)
    force, moment, _ = _needed_wrench(model, free.qpos)
    weight = model.body_mass.sum() * 9.81
    edge = EDGE if cutoff is None else 10
    inner = slice(edge, -edge)
    assert np.abs(force[inner]).max() > 0.2 * weight  # the motion needs more than gravity
    np.testing.assert_array_less(np.abs(free.root_force - force)[inner], 1e-3 * weight)
    assert np.abs(moment[inner]).max() > 5.0
    np.testing.assert_array_less(np.abs(free.root_moment - moment)[inner], 0.5)


def test_fast_path_equals_mj_inverse(model: mujoco.MjModel, free: dy.Dynamics) -> None:
    """mj_rne with the acceleration (the loop's) against a plain mj_inverse loop."""
    dyn = dy.dynamics_model(model)
    data = mujoco.MjData(dyn)
    for t in range(0, len(free.times), 7):
        data.qpos[:], data.qvel[:], data.qacc[:] = free.qpos[t], free.qvel[t], free.qacc[t]
        mujoco.mj_inverse(dyn, data)
        scale = np.abs(data.qfrc_inverse).max()
        np.testing.assert_allclose(free.tau[t], data.qfrc_inverse, rtol=0, atol=1e-12 * scale)


def _chain(model: mujoco.MjModel, body: int) -> set[int]:
    """The degrees of freedom between the root and ``body`` (the root's included)."""
    dofs: set[int] = set()
    while body > 0:
        start, count = model.body_dofadr[body], model.body_dofnum[body]
        dofs.update(range(start, start + count))
        body = model.body_parentid[body]
    return dofs


def test_the_needed_wrench_on_a_foot_leaves_no_residual(
    model: mujoco.MjModel, motion: tuple[np.ndarray, np.ndarray], free: dy.Dynamics
) -> None:
    data = mujoco.MjData(model)
    foot = model.body("foot_r").id
    frames = len(free.times)
    point, root = np.zeros((frames, 3)), np.zeros((frames, 3))
    for t, q in enumerate(free.qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        point[t] = data.xpos[foot] * (1, 1, 0) + (0.05, 0.0, 0.0)  # on the floor, ahead
        root[t] = data.xpos[1]
    force = free.root_force
    moment = free.root_moment + np.cross(root - point, force)  # about the point of application
    load = dy.BodyLoad("foot_r", force, point, moment)
    loaded = dy.inverse_dynamics(model, *motion, [load], cutoff_hz=None)

    weight = MASS * 9.81
    assert np.abs(loaded.root_force).max() < 1e-6 * weight  # well below 0.5 % of it
    assert np.abs(loaded.root_moment).max() < 1e-6 * weight  # [N m], a 1 m lever
    on_path = _chain(model, foot)
    off = [d for d in range(model.nv) if d not in on_path]
    np.testing.assert_allclose(loaded.tau[:, off], free.tau[:, off], rtol=0, atol=1e-9)
    # on the path, each joint's moment drops by the load's moment about it: J^T f
    for t in range(0, frames, 37):
        data.qpos[:] = free.qpos[t]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        for j in range(model.njnt):
            dof = model.jnt_dofadr[j]
            if dof not in on_path or model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
                continue
            b = model.jnt_bodyid[j]
            about = np.cross(point[t] - data.xanchor[j], force[t]) + moment[t]
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
                expected = -data.xmat[b].reshape(3, 3).T @ about
                np.testing.assert_allclose(
                    loaded.tau[t, dof : dof + 3] - free.tau[t, dof : dof + 3], expected, atol=1e-8
                )
            elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
                delta = loaded.tau[t, dof] - free.tau[t, dof]
                assert delta == pytest.approx(-data.xaxis[j] @ force[t], abs=1e-8)
            else:
                delta = loaded.tau[t, dof] - free.tau[t, dof]
                assert delta == pytest.approx(-data.xaxis[j] @ about, abs=1e-8)


def _subtree(model: mujoco.MjModel, body: int) -> set[int]:
    out = {body}
    for b in range(body + 1, model.nbody):
        if model.body_parentid[b] in out:
            out.add(b)
    return out


def test_standing_on_one_foot_the_ankle_holds_the_body_above(
    pset: ParameterSet, model: mujoco.MjModel
) -> None:
    """A still pose on the left foot, the whole weight under the centre of mass: no residual,
    and every joint of the left leg holds the gravitational moment of the bodies above it."""
    q = pset.model.qpos0.copy()
    for name, angle in [("knee_flex_l", 0.35), ("ankle_l", 0.2), ("subtalar_l", 0.1),
                        ("hip_r", None), ("elbow_r", 0.6)]:  # fmt: skip
        j = pset.model.joint(name)
        if angle is None:  # the right hip flexed by 0.5 rad about its y axis
            q[j.qposadr[0] : j.qposadr[0] + 4] = [np.cos(0.25), 0, np.sin(0.25), 0]
        else:
            q[j.qposadr[0]] = angle
    qpos = np.tile(exported.Layout.of(pset.model).written(q[None])[0], (12, 1))
    data = mujoco.MjData(model)
    data.qpos[:] = qpos[0]
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    weight = -model.body_mass.sum() * model.opt.gravity  # upward [N]
    under = data.subtree_com[1] * (1, 1, 0)
    frames = len(qpos)
    load = dy.BodyLoad(
        "foot_l", np.tile(weight, (frames, 1)), np.tile(under, (frames, 1)), np.zeros((frames, 3))
    )
    dyn = dy.inverse_dynamics(model, qpos, np.arange(frames) / RATE, [load], cutoff_hz=None)
    assert np.abs(dyn.root_force).max() < 1e-9 * weight[2]
    assert np.abs(dyn.root_moment).max() < 1e-9 * weight[2]
    for name in ("ankle_l", "subtalar_l", "knee_flex_l", "knee_rot_l"):
        j = model.joint(name).id
        below = _subtree(model, model.jnt_bodyid[j])
        above = [b for b in range(1, model.nbody) if b not in below]
        gravity = sum(
            np.cross(data.xipos[b] - data.xanchor[j], model.body_mass[b] * model.opt.gravity)
            for b in above
        )
        expected = float(data.xaxis[j] @ gravity)
        got = dyn.tau[:, model.jnt_dofadr[j]]
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)
    assert abs(dyn.tau[0, model.joint("ankle_l").dofadr[0]]) > 1.0  # a real moment


def test_pendulum_torque_is_analytic() -> None:
    """A rod on a hinge about y: tau = (I + m l^2) theta'' + m g l sin(theta), within 1e-5 of
    the inertial term's amplitude (the central difference's O(dt^2) at 1000 Hz: 2e-6)."""
    m, length, inertia, g = 2.0, 0.4, 0.03, 9.81
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, -g]
    body = spec.worldbody.add_body(name="rod", pos=[0, 0, 1])
    body.add_joint(name="swing", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
    body.mass, body.ipos = m, [0, 0, -length]
    body.inertia = [inertia, inertia, inertia]
    pendulum = spec.compile()
    rate, amp, omega = 1000.0, 0.8, 2 * np.pi * 0.7
    t = np.arange(2000) / rate
    theta = amp * np.sin(omega * t)
    dyn = dy.inverse_dynamics(pendulum, theta[:, None], t, cutoff_hz=None)
    expected = (inertia + m * length**2) * (-(omega**2) * theta) + m * g * length * np.sin(theta)
    inner = slice(EDGE, -EDGE)
    scale = (inertia + m * length**2) * amp * omega**2  # the inertial term's amplitude
    np.testing.assert_allclose(dyn.tau[inner, 0], expected[inner], rtol=0, atol=1e-5 * scale)
    assert dyn.dof_names == ("swing",)
    assert np.all(np.isnan(dyn.root_force))
    np.testing.assert_allclose(dyn.power[:, 0], dyn.tau[:, 0] * dyn.qvel[:, 0])


def test_filter_gives_a_sinusoids_derivative() -> None:
    """A 1 Hz wave at 100 Hz through the 6 Hz filter: the wave and its two derivatives within
    0.3 % of their amplitudes away from the first and last 20 frames; a 20 Hz ripple falls
    below 1 % of its amplitude (the filter's gain there: 1 / (1 + (20 / 6)^4) = 0.8 %)."""
    t = np.arange(400) / RATE
    w = 2 * np.pi
    wave = np.sin(w * t)
    smooth = dy.lowpass(wave[:, None], RATE, dy.CUTOFF_HZ)[:, 0]
    vel, acc = dy.derivatives(smooth[:, None], 1 / RATE)
    inner = slice(20, -20)
    np.testing.assert_allclose(smooth[inner], wave[inner], atol=3e-3)
    np.testing.assert_allclose(vel[inner, 0], w * np.cos(w * t)[inner], atol=3e-3 * w)
    np.testing.assert_allclose(acc[inner, 0], -(w**2) * wave[inner], atol=3e-3 * w**2)
    ripple = np.sin(2 * np.pi * 20 * t)
    left = dy.lowpass(ripple[:, None], RATE, dy.CUTOFF_HZ)[inner, 0]
    assert 0.002 < np.abs(left).max() < 0.01


def test_quaternion_velocities_are_the_body_angular_velocity() -> None:
    """A ball joint spinning at a constant body-frame rate omega: qvel = omega, qacc = 0,
    though the quaternion's own components swing through +-1."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="top")
    body.add_joint(name="spin", type=mujoco.mjtJoint.mjJNT_BALL)
    body.mass, body.inertia = 1.0, [0.1, 0.2, 0.3]
    top = spec.compile()
    omega = np.array([3.0, -1.0, 2.0])  # [rad/s], body frame
    frames = 200
    qpos = np.zeros((frames, 4))
    q = np.array([1.0, 0, 0, 0])
    for t in range(frames):
        qpos[t] = q
        mujoco.mju_quatIntegrate(q, omega, 1 / RATE)
    raw = dy.inverse_dynamics(top, qpos, np.arange(frames) / RATE, cutoff_hz=None)
    np.testing.assert_allclose(raw.qvel, np.tile(omega, (frames, 1)), atol=1e-9)
    np.testing.assert_allclose(raw.qacc, 0.0, atol=1e-6)
    dyn = dy.inverse_dynamics(top, qpos, np.arange(frames) / RATE)
    inner = slice(30, -30)  # past the filter's start-up at the ends
    np.testing.assert_allclose(dyn.qvel[inner], np.tile(omega, (frames - 60, 1)), atol=1e-4)
    np.testing.assert_allclose(dyn.qacc[inner], 0.0, atol=1e-2)
    # Euler's equations for a body spinning freely: tau = I omega' + omega x (I omega)
    inertia = np.array([0.1, 0.2, 0.3])
    expected = np.cross(omega, inertia * omega)
    np.testing.assert_allclose(dyn.tau[inner], np.tile(expected, (frames - 60, 1)), atol=1e-4)
    assert dyn.dof_names == ("spin_x", "spin_y", "spin_z")


def test_nan_frames_and_short_runs_are_left_out(
    model: mujoco.MjModel, motion: tuple[np.ndarray, np.ndarray]
) -> None:
    qpos, times = motion[0].copy(), motion[1]
    qpos[100] = np.nan  # one unsolved frame
    qpos[200:205] = np.nan
    qpos[195:200] = np.nan  # frames 205.. are a long run; 101..194 too
    dyn = dy.inverse_dynamics(model, qpos, times)
    assert np.all(np.isnan(dyn.tau[[100, 197, 204]]))
    assert np.all(np.isfinite(dyn.tau[[0, 99, 101, 194, 205, FRAMES - 1]]))


def test_bad_input_is_one_clear_error(
    pset: ParameterSet, model: mujoco.MjModel, motion: tuple[np.ndarray, np.ndarray]
) -> None:
    qpos, times = motion
    with pytest.raises(MocapError, match="pass the model as written"):
        dy.inverse_dynamics(load_model(), exported.Layout.of(pset.model).internal(qpos), times)
    uneven = times.copy()
    uneven[50:] += 0.003
    with pytest.raises(ShapeError, match="row 50 steps"):
        dy.inverse_dynamics(model, qpos, uneven)
    with pytest.raises(MocapError, match="half the frame rate"):
        dy.inverse_dynamics(model, qpos, times, cutoff_hz=60.0)
    with pytest.raises(ShapeError, match=r"qpos: expected shape \(\*, 59\)"):
        dy.inverse_dynamics(model, qpos[:, :55], times)
    zeros = np.zeros((FRAMES, 3))
    with pytest.raises(UnknownNameError, match="unknown body 'foot'"):
        dy.inverse_dynamics(model, qpos, times, [dy.BodyLoad("foot", zeros, zeros, zeros)])
    with pytest.raises(ShapeError, match="load on foot_l: point"):
        dy.inverse_dynamics(model, qpos, times, [dy.BodyLoad("foot_l", zeros, zeros[:5], zeros)])
