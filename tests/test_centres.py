"""The joint-centre Cramer-Rao bound (mocap_mj/solve/centres.py).

Its Jacobians are checked against MuJoCo's, and its pose part against a Monte-Carlo
experiment: with the model known, the joint centres of IK solutions of noisy markers scatter
about the truth as the bound says.
"""

from __future__ import annotations

import numpy as np
import pytest
from _motion import smooth_motion
from _oracles import mj_jacobians

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.solve.centres import centre_jacobians, joint_centre_bound
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.ik import IKSolver


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    return Kinematics(ParameterSet())


def test_jacobians_match_mujoco(kin: Kinematics) -> None:
    qpos = smooth_motion(kin, 3, seed=4)
    k, h = centre_jacobians(kin, qpos)
    for t in range(len(qpos)):  # MuJoCo's, with the knee rolling's term (tests/_oracles.py)
        np.testing.assert_allclose(k[t], mj_jacobians(kin, qpos[t], "body")[2:], atol=1e-7)
    # d c / d kappa against central differences of the body origins (step 1e-6 m)
    theta, eps = kin.theta.copy(), 1e-6
    try:
        for j in range(kin.pset.n_kappa):
            d = np.zeros_like(theta)
            d[j] = eps
            kin.set_theta(theta + d)
            hi = kin.forward(qpos).xpos[:, 2:]
            kin.set_theta(theta - d)
            lo = kin.forward(qpos).xpos[:, 2:]
            np.testing.assert_allclose(h[..., j], (hi - lo) / (2 * eps), atol=1e-8)
    finally:
        kin.set_theta(theta)
    assert np.abs(h).max() > 0.5  # a parameter moves the bodies below it one for one


def test_pose_part_matches_monte_carlo(kin: Kinematics) -> None:
    """Model known (no model part): RMS joint-centre error of IK over noise draws vs bound."""
    pset = kin.pset
    qpos = smooth_motion(kin, 60, seed=2)
    clean = kin.marker_positions(qpos)
    sigma = 1e-3
    idf = Identifiability(pset, np.zeros((pset.size, pset.size)), sigma)  # theta known
    bound = joint_centre_bound(kin, clean, qpos, idf)
    assert np.all(bound.model == 0.0)
    truth = kin.forward(qpos).xpos[:, 2:]
    rng = np.random.default_rng(0)
    solver = IKSolver(kin)
    sq = []
    for _ in range(6):
        noisy = clean + rng.normal(0.0, sigma, clean.shape)
        q = solver.solve_frames(noisy, qpos).qpos
        sq.append(np.sum((kin.forward(q).xpos[:, 2:] - truth) ** 2, axis=2))
    measured = np.sqrt(np.mean(sq))
    # 6 x 60 frame draws: the RMS has a relative spread of about 2 % (per body about 5 %).
    assert measured == pytest.approx(bound.rms(), rel=0.05)
    per_body = np.sqrt(np.mean(np.concatenate(sq), axis=0))
    np.testing.assert_allclose(per_body, bound.total, rtol=0.12)
