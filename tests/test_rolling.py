"""The knee's rolling (mocap_mj.skeleton.rolling): kernels, MuJoCo and NumPy paths agree with it."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _motion import random_poses

from mocap_mj import Kinematics
from mocap_mj.errors import MocapError
from mocap_mj.kernels import _tree as tree_kernels
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton import tree_tables as _tree_tables
from mocap_mj.skeleton.mjcf import model_path

fk = tree_kernels.python_callable(tree_kernels.fk)

#: OpenSim gait2392's knee_r translation splines (gait2392_simbody.osim, knee_angle_r [rad],
#: negative in flexion; translation1 anterior, translation2 superior [m]).
GAIT2392_TX = (
    [-2.0944, -1.74533, -1.39626, -1.0472, -0.698132, -0.349066, -0.174533, 0.197344],
    [-0.0032, 0.00179, 0.00411, 0.0041, 0.00212, -0.001, -0.0031, -0.005227],
)
GAIT2392_TY = (
    [-2.0944, -1.22173, -0.523599, -0.349066, -0.174533, 0.159149],
    [-0.4226, -0.4082, -0.399, -0.3976, -0.3966, -0.395264],
)


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    """A subject away from the nominal model (kappa and offsets +-1 cm)."""
    k = Kinematics()
    k.set_theta(k.pset.nominal + np.random.default_rng(21).uniform(-0.01, 0.01, k.pset.size))
    return k


def flexed_poses(kin: Kinematics, n: int, seed: int) -> np.ndarray:
    """Random poses with both knees flexed over -5..145 degrees (beyond q_max too)."""
    q = random_poses(kin, n, seed, scale=0.4)
    knees = np.random.default_rng(seed + 1).uniform(-5, 145, (n, kin.rolling.qposadr.size))
    q[:, kin.rolling.qposadr] = np.radians(knees)
    return q


def test_bundled_knee_follows_gait2392() -> None:
    """The cubic in models/humanoid.xml is within 1 mm of gait2392's knots over 10-120 deg,
    per its femur length (0.3958 m) scaled to the nominal thigh (docs/model.md)."""
    roll = rolling.read(mujoco.MjModel.from_xml_path(str(model_path())))
    assert roll is not None and roll.bodies.size == 2
    scale = roll.length[0] / rolling.GAIT2392_FEMUR_LENGTH
    for (knots, values), axis in ((GAIT2392_TX, 0), (GAIT2392_TY, 2)):
        ext = np.interp(0.0, knots, values)  # full extension, between the two nearest knots
        flexion = -np.array(knots)
        keep = (flexion >= 0.17) & (flexion <= 2.1)
        t, _ = roll.translation(np.tile(flexion[keep, None], (1, 2)))
        want = (np.array(values)[keep] - ext) * scale
        np.testing.assert_allclose(t[:, 0, axis], want, atol=0.001)
        np.testing.assert_allclose(t[:, 1, axis], want, atol=0.001)
    t, _ = roll.translation(np.radians([[120.0, 120.0]]))
    assert -0.033 < t[0, 0, 2] < -0.027  # ~30 mm distal at 120 deg for a 0.43 m thigh


def test_fk_matches_mujoco_with_the_bodies_placed(kin: Kinematics) -> None:
    tr = kin.tree()
    w = tree_kernels.work(tr, kin.nq)
    data = mujoco.MjData(kin.model)
    before = np.array(kin.model.body_pos)
    for q in flexed_poses(kin, 20, 1):
        data.qpos[:] = q
        rolling.kinematics(kin.model, data)
        fk(tr, q, w)
        np.testing.assert_allclose(w.site_xpos, data.site_xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w.xpos, data.xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w.xanchor, data.xanchor, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(kin.model.body_pos, before)  # restored after each call


def test_kernel_jacobian_matches_finite_differences_of_fk(kin: Kinematics) -> None:
    tr = kin.tree()
    w = tree_kernels.work(tr, kin.nq)
    jac = np.zeros((kin.n_markers, 3, kin.nv))
    eps = 1e-6
    for q in flexed_poses(kin, 4, 2):
        fk(tr, q, w)
        tree_kernels.jacobian(tr, w, jac)
        fd = np.empty_like(jac)
        for v in range(kin.nv):
            step = np.zeros((1, kin.nv))
            step[0, v] = eps
            hi, lo = kin.integrate(q[None], step)[0], kin.integrate(q[None], -step)[0]
            fk(tr, hi, w)
            x_hi = w.site_xpos.copy()
            fk(tr, lo, w)
            fd[:, :, v] = (x_hi - w.site_xpos) / (2 * eps)
        np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-8)
        # the coupling does act: the knee column differs from the fixed hinge's
        fk(tr, q, w)
        data = mujoco.MjData(kin.model)
        data.qpos[:] = q
        rolling.kinematics(kin.model, data)
        mujoco.mj_comPos(kin.model, data)
        knee = kin.model.jnt_dofadr[kin.rolling.joints[1]]
        ank = kin.pset.marker_index("RANK")
        jp = np.zeros((3, kin.nv))
        mujoco.mj_jacSite(kin.model, data, jp, None, ank)
        np.testing.assert_allclose(jac[ank][:, knee] - jp[:, knee], w.xroll[kin.rolling.bodies[1]])
        assert np.linalg.norm(w.xroll[kin.rolling.bodies[1]]) > 0.005


def test_numpy_jacobian_matches_the_kernel(kin: Kinematics) -> None:
    tr = kin.tree()
    w = tree_kernels.work(tr, kin.nq)
    q = flexed_poses(kin, 3, 3)
    jq = kin.jac_q(kin.forward(q))
    jac = np.zeros((kin.n_markers, 3, kin.nv))
    for t in range(3):
        fk(tr, q[t], w)
        tree_kernels.jacobian(tr, w, jac)
        np.testing.assert_allclose(jq[t], jac, rtol=0, atol=1e-12)
    np.testing.assert_allclose(kin.site_positions(q), kin.marker_positions(q), atol=1e-12)


def test_kappa_jacobian_stays_parent_direction(kin: Kinematics) -> None:
    """The thigh length moves the knee through R_parent d at any flexion: the coupling is a
    constant of the solve (scaled before it), not a function of theta."""
    q = flexed_poses(kin, 3, 4)
    k = Kinematics(kin.pset)
    k.set_theta(kin.theta)
    jk = k.jac_kappa(k.forward(q))
    eps = 1e-6
    i = k.pset.index("thigh_length_r")
    th = kin.theta.copy()
    th[i] += eps
    k.set_theta(th)
    hi = k.marker_positions(q)
    th[i] -= 2 * eps
    k.set_theta(th)
    lo = k.marker_positions(q)
    np.testing.assert_allclose(jk[..., i], (hi - lo) / (2 * eps), atol=1e-8)


def test_model_without_the_entries_is_a_fixed_hinge(tmp_path) -> None:  # type: ignore[no-untyped-def]
    plain = tmp_path / "plain.xml"
    plain.write_text(rolling.without(model_path().read_text()))
    model = mujoco.MjModel.from_xml_path(str(plain))
    assert rolling.read(model) is None
    tr = _tree_tables.build_tree(model)
    assert np.all(tr.body_rolladr == -1)
    k = Kinematics()
    from mocap_mj.skeleton.parameters import ParameterSet

    fixed = Kinematics(ParameterSet(plain))
    q = flexed_poses(k, 2, 5)
    data = mujoco.MjData(model)
    for t in range(2):
        data.qpos[:] = q[t]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(fixed.site_positions(q[t : t + 1])[0], data.site_xpos)
    assert np.abs(fixed.site_positions(q) - k.site_positions(q)).max() > 0.005


def test_bad_entry_names_the_entry(tmp_path) -> None:  # type: ignore[no-untyped-def]
    text = model_path().read_text().replace(":shank_r:knee_flex_r", ":shank_r:knee_rot_r")
    bad = tmp_path / "bad.xml"
    bad.write_text(text)
    with pytest.raises(MocapError, match="mocap_mj_roll:shank_r:knee_rot_r"):
        rolling.read(mujoco.MjModel.from_xml_path(str(bad)))


def test_scaled_rolling_is_written_and_read_back(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """with_rolling_scaled: L = hip-to-knee distance of theta, in a copy; model.xml carries it,
    and a ParameterSet of that file has the same kinematics (what `ik --model` solves)."""
    from mocap_mj.skeleton.parameters import ParameterSet

    pset = ParameterSet()
    theta = pset.nominal.copy()
    theta[pset.index("thigh_length_l")] = 0.47
    theta[pset.index("thigh_length_r")] = 0.40
    scaled = pset.with_rolling_scaled(theta)
    assert rolling.read(pset.model).length.tolist() == [0.43, 0.43]  # the original untouched
    np.testing.assert_allclose(rolling.read(scaled.model).length, [0.47, 0.40], atol=1e-12)
    scaled.export_mjcf(tmp_path / "model.xml", theta)
    back = ParameterSet(tmp_path / "model.xml")
    np.testing.assert_array_equal(rolling.read(back.model).length, [0.47, 0.40])
    k1, k2 = Kinematics(scaled), Kinematics(back)
    k1.set_theta(theta)
    k2.set_theta(back.read(back.model))
    q = flexed_poses(k1, 4, 6)
    np.testing.assert_allclose(k2.site_positions(q), k1.site_positions(q), rtol=0, atol=1e-12)
    # Scaling does act: the 0.47 m thigh's knee moves 0.47/0.43 as far.
    t1, _ = rolling.read(scaled.model).translation(np.radians([[100.0, 100.0]]))
    t0, _ = rolling.read(pset.model).translation(np.radians([[100.0, 100.0]]))
    np.testing.assert_allclose(t1[0, 0], t0[0, 0] * 0.47 / 0.43, atol=1e-12)


def test_viewer_and_joint_centres_show_the_rolling(kin: Kinematics) -> None:
    from mocap_mj.skeleton.joint_centres import JOINT_CENTRES, joint_centre_trajectories
    from mocap_viewer.playback import marker_positions

    q = flexed_poses(kin, 3, 7)
    np.testing.assert_allclose(marker_positions(kin.model, q), kin.site_positions(q), atol=1e-12)
    knee = [i for i, c in enumerate(JOINT_CENTRES) if c[1] == "shank_r"]
    got = joint_centre_trajectories(kin.model, q)[:, knee[0]]
    np.testing.assert_allclose(got, kin.forward(q).xpos[:, kin.model.body("shank_r").id])


def test_posed_frames_match_the_per_frame_pass(kin: Kinematics) -> None:
    """rolling.posed (translations computed once for the whole trial) places every body as
    rolling.kinematics does frame by frame, skips unsolved frames and restores body_pos."""
    m = kin.model
    qpos = flexed_poses(kin, 12, 3)
    qpos[4] = np.nan
    before = np.array(m.body_pos)
    posed = {t: np.array(d.xpos) for t, d in rolling.posed(m, qpos)}
    np.testing.assert_array_equal(m.body_pos, before)
    assert sorted(posed) == [t for t in range(12) if t != 4]
    data = mujoco.MjData(m)
    for t, xpos in posed.items():
        data.qpos[:] = qpos[t]
        rolling.kinematics(m, data)
        np.testing.assert_allclose(xpos, data.xpos, rtol=0, atol=1e-12)
