"""Forward kinematics against a plain mj_kinematics loop, Jacobians against finite differences."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _oracles import mj_site_jacobian

from mocap_mj import Kinematics, ShapeError
from mocap_mj.skeleton import rolling

EPS = 1e-6
REL_TOL = 1e-6


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    k = Kinematics()
    rng = np.random.default_rng(7)
    theta = k.pset.nominal + rng.uniform(-0.01, 0.01, k.pset.size)
    k.set_theta(theta)
    return k


def poses(kin: Kinematics, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q0 = np.tile(kin.model.qpos0, (n, 1))
    q0[:, :3] += rng.normal(0, 1.0, (n, 3))
    return kin.integrate(q0, rng.normal(0, 0.4, (n, kin.nv)))


def test_fk_equals_plain_loop(kin: Kinematics) -> None:
    qpos = poses(kin, 25, 1)
    data = mujoco.MjData(kin.model)
    expected = []
    for q in qpos:
        data.qpos[:] = q
        rolling.kinematics(kin.model, data)  # the knee rolling placed, mocap_mj.skeleton.rolling
        expected.append(data.site_xpos.copy())
    np.testing.assert_array_equal(kin.marker_positions(qpos), np.array(expected))
    np.testing.assert_array_equal(kin.forward(qpos).site_xpos, np.array(expected))


def test_jac_q_matches_mj_jacsite_and_finite_differences(kin: Kinematics) -> None:
    qpos = poses(kin, 4, 2)
    jac = kin.jac_q(kin.forward(qpos))
    assert jac.shape == (4, 39, 3, 48)
    fd = np.zeros_like(jac)
    for v in range(kin.nv):
        step = np.zeros((len(qpos), kin.nv))
        step[:, v] = EPS
        plus = kin.marker_positions(kin.integrate(qpos, step))
        minus = kin.marker_positions(kin.integrate(qpos, -step))
        fd[..., v] = (plus - minus) / (2 * EPS)
    scale = np.abs(fd).max()
    assert np.abs(jac - fd).max() <= REL_TOL * scale
    for t, q in enumerate(qpos):
        np.testing.assert_allclose(jac[t], mj_site_jacobian(kin, q), atol=1e-12)


def test_jac_theta_matches_finite_differences(kin: Kinematics) -> None:
    qpos = poses(kin, 3, 3)
    jac = kin.jac_theta(kin.forward(qpos))
    theta0 = kin.theta.copy()
    fd = np.zeros_like(jac)
    try:
        for i in range(kin.pset.size):
            theta = theta0.copy()
            theta[i] += EPS
            kin.set_theta(theta)
            plus = kin.marker_positions(qpos)
            theta[i] -= 2 * EPS
            kin.set_theta(theta)
            fd[..., i] = (plus - kin.marker_positions(qpos)) / (2 * EPS)
    finally:
        kin.set_theta(theta0)
    assert np.abs(jac - fd).max() <= REL_TOL * np.abs(fd).max()
    # The sparse pieces agree with the dense one.
    frames = kin.forward(qpos)
    k = kin.pset.n_kappa
    np.testing.assert_array_equal(jac[..., :k], kin.jac_kappa(frames))
    rot = kin.jac_offsets(frames)
    np.testing.assert_array_equal(jac[:, 5, :, k + 15 : k + 18], rot[:, 5])


def test_integrate_difference_inverse(kin: Kinematics) -> None:
    a, b = poses(kin, 5, 4), poses(kin, 5, 5)
    dv = kin.difference(a, b)
    back = kin.integrate(a, dv)
    np.testing.assert_allclose(kin.marker_positions(back), kin.marker_positions(b), atol=1e-12)


def test_bad_shapes(kin: Kinematics) -> None:
    with pytest.raises(ShapeError, match=r"qpos: expected shape \(\*, 55\), got \(3, 48\)"):
        kin.marker_positions(np.zeros((3, 48)))
    with pytest.raises(ShapeError, match="dv"):
        kin.integrate(np.tile(kin.model.qpos0, (2, 1)), np.zeros((3, 48)))
