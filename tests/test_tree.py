"""The compiled kernels (mocap_mj.kernels._tree) against MuJoCo and against the NumPy reference
path."""

from __future__ import annotations

import mujoco
import numba
import numpy as np
import pytest
from _motion import random_poses, smooth_motion
from _oracles import mj_site_jacobian, numpy_solve_frames

from mocap_mj import Kinematics
from mocap_mj.kernels import _tree as tree_kernels
from mocap_mj.kernels import _tree_ik
from mocap_mj.skeleton import rolling
from mocap_mj.solve.ik import IKSettings, IKSolver

# Helpers that only kernels call have no Python entry point: these copies have one.
fk, normal_equations, factor, solve, integrate, difference = (
    tree_kernels.python_callable(k)
    for k in (
        tree_kernels.fk,
        tree_kernels.normal_equations,
        tree_kernels.factor,
        tree_kernels.solve,
        tree_kernels.integrate,
        tree_kernels.difference,
    )
)


@pytest.fixture(scope="module")
def kin() -> Kinematics:
    k = Kinematics()
    rng = np.random.default_rng(11)
    k.set_theta(k.pset.nominal + rng.uniform(-0.01, 0.01, k.pset.size))
    return k


def poses(kin: Kinematics, n: int, seed: int) -> np.ndarray:
    return random_poses(kin, n, seed)


def test_fk_matches_mj_kinematics(kin: Kinematics) -> None:
    tr = kin.tree()
    w = tree_kernels.work(tr, kin.nq)
    data = mujoco.MjData(kin.model)
    for q in poses(kin, 20, 1):
        data.qpos[:] = q
        rolling.kinematics(kin.model, data)  # the knee rolling placed, mocap_mj.skeleton.rolling
        fk(tr, q, w)
        np.testing.assert_allclose(w.site_xpos, data.site_xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w.xpos, data.xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w.xmat.reshape(-1, 9), data.xmat, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w.xanchor, data.xanchor, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w.xaxis, data.xaxis, rtol=0, atol=1e-12)


def test_tree_follows_theta(kin: Kinematics) -> None:
    k = Kinematics(kin.pset)
    q = poses(k, 3, 2)
    before = tree_kernels.forward(k.tree(), q)
    k.set_theta(k.theta + 0.005)
    after = tree_kernels.forward(k.tree(), q)
    np.testing.assert_allclose(after, k.marker_positions(q), rtol=0, atol=1e-12)
    assert np.abs(after - before).max() > 1e-3


def test_jacobian_matches_mj_jac_site(kin: Kinematics) -> None:
    tr = kin.tree()
    w = tree_kernels.work(tr, kin.nq)
    jac = np.zeros((kin.n_markers, 3, kin.nv))
    for q in poses(kin, 5, 3):
        fk(tr, q, w)
        tree_kernels.jacobian(tr, w, jac)
        np.testing.assert_allclose(jac, mj_site_jacobian(kin, q), rtol=0, atol=1e-12)


@pytest.mark.parametrize("away", [0.0, 30.0])
def test_normal_equations_and_sparse_solve(kin: Kinematics, away: float) -> None:
    # away: the subject stands this far [m] from the lab's origin (the normal equations are
    # formed from sums about the root's origin, so the lab's origin must not matter)
    tr = kin.tree()
    w = tree_kernels.work(tr, kin.nq)
    rng = np.random.default_rng(4)
    q = poses(kin, 1, 4)[0]
    q[:3] += away * np.array([0.6, -0.8, 0.0])
    fk(tr, q, w)
    target = w.site_xpos + rng.normal(0, 0.01, w.site_xpos.shape)
    wts = rng.uniform(0.5, 2.0, kin.n_markers)
    wts[[3, 17]] = 0.0  # missing markers drop out
    normal_equations(tr, target, wts, w)
    jac = np.zeros((kin.n_markers, 3, kin.nv))
    tree_kernels.jacobian(tr, w, jac)
    jw = jac * np.sqrt(wts)[:, None, None]
    h = np.einsum("sir,sic->rc", jw, jw)
    g = np.einsum("sir,si->r", jac, (target - w.site_xpos) * wts[:, None])
    np.testing.assert_allclose(np.tril(w.h), np.tril(h), rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.g, g, rtol=0, atol=1e-14)
    # Only ancestor pairs are non-zero: the mass-matrix sparsity the factorisation relies on.
    anc = np.eye(kin.nv, dtype=bool)
    for v in range(kin.nv):
        p = kin.model.dof_parentid[v]
        while p >= 0:
            anc[v, p] = True
            p = kin.model.dof_parentid[p]
    assert np.all(h[~(anc | anc.T)] == 0.0)
    a = np.tril(w.h).copy()
    a[np.diag_indices(kin.nv)] += 1e-6
    x = w.g.copy()
    factor(tr, a)
    solve(tr, a, x)
    np.testing.assert_allclose(x, np.linalg.solve(h + 1e-6 * np.eye(kin.nv), g), rtol=1e-9)


def test_integrate_and_difference_match_mujoco(kin: Kinematics) -> None:
    tr = kin.tree()
    rng = np.random.default_rng(5)
    qa, qb = poses(kin, 2, 5)
    dv = rng.normal(0, 0.7, kin.nv)
    mine = qa.copy()
    integrate(tr, mine, dv, 0.3)
    np.testing.assert_allclose(mine, kin.integrate(qa[None], dv[None], 0.3)[0], atol=1e-14)
    d = np.zeros(kin.nv)
    difference(tr, qa, qb, d)
    np.testing.assert_allclose(d, kin.difference(qa[None], qb[None])[0], atol=1e-12)


def test_compiled_ik_agrees_with_numpy_oracle_on_every_frame(kin: Kinematics) -> None:
    # The same per-frame LM from the same starting poses (tests/_oracles.py): every frame
    # reaches the same minimum. (The motion keeps the balls inside their cones, where the
    # compiled solver's cone hold, which the oracle lacks, is inactive.)
    qpos = smooth_motion(kin, 60, seed=8)
    rng = np.random.default_rng(8)
    markers = kin.marker_positions(qpos) + rng.normal(0, 1e-3, (60, kin.n_markers, 3))
    markers[rng.random((60, kin.n_markers)) < 0.1] = np.nan
    start = qpos.copy()
    start[:, 7:] += rng.normal(0, 0.05, (60, kin.nq - 7))  # joints off by about 3 degrees
    start = IKSolver(kin).project(start)
    solver = IKSolver(kin, IKSettings(tol_rmse=1e-9))
    fast = solver.solve_frames(markers, start)
    slow = numpy_solve_frames(solver, markers, start)
    np.testing.assert_array_equal(fast.status, slow.status)
    np.testing.assert_allclose(fast.marker_rmse, slow.marker_rmse, rtol=1e-6)
    x_fast, x_slow = kin.marker_positions(fast.qpos), kin.marker_positions(slow.qpos)
    present = np.isfinite(markers)
    assert np.abs(x_fast - x_slow)[present].max() < 1e-6


def test_results_do_not_depend_on_thread_count(kin: Kinematics) -> None:
    qpos = smooth_motion(kin, 300, seed=9)
    markers = kin.marker_positions(qpos) + np.random.default_rng(9).normal(0, 1e-3, (300, 39, 3))
    solver = IKSolver(kin)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = solver.solve_trial(markers)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = solver.solve_trial(markers)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one.qpos, many.qpos)
    np.testing.assert_array_equal(one.iterations, many.iterations)


def test_ball_at_its_limit_slides_along_it(kin: Kinematics) -> None:
    """Markers of a pose with the thorax turned beyond its 45 degree cone: the solution sits on
    the cone and is optimal there (KKT): every free dof's gradient vanishes, the thorax's
    gradient points straight outward (along its rotation axis), none along the cone."""
    m = kin.model
    j = m.joint("thorax").id
    adr, dof, limit = m.jnt_qposadr[j], m.jnt_dofadr[j], m.jnt_range[j, 1]
    rng = np.random.default_rng(5)
    beyond = np.tile(m.qpos0, (8, 1))
    axes = rng.normal(size=(8, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    half = 0.5 * (limit + 0.3)  # 0.3 rad beyond the cone
    beyond[:, adr : adr + 4] = np.c_[np.full(8, np.cos(half)), np.sin(half) * axes]
    target = kin.marker_positions(beyond)
    start = beyond.copy()
    start[:, adr : adr + 4] = [1.0, 0.0, 0.0, 0.0]
    q = IKSolver(kin, IKSettings(tol_rmse=0.0, tol_cost=0.0)).solve_frames(target, start).qpos
    quat = q[:, adr : adr + 4] * np.sign(q[:, adr : adr + 1])
    s = np.linalg.norm(quat[:, 1:], axis=1)
    angle = 2 * np.arctan2(s, quat[:, 0])
    np.testing.assert_allclose(angle, limit, atol=1e-6)
    # Gradient of F = 1/2 |r|^2 in the tangent space, by central differences.
    eps = 1e-7

    def cost(qq: np.ndarray) -> np.ndarray:
        return 0.5 * np.sum((kin.marker_positions(qq) - target) ** 2, axis=(1, 2))

    grad = np.empty((8, kin.nv))
    for i in range(kin.nv):
        step = np.zeros((8, kin.nv))
        step[:, i] = eps
        grad[:, i] = (cost(kin.integrate(q, step)) - cost(kin.integrate(q, -step))) / (2 * eps)
    n = quat[:, 1:] / s[:, None]
    g_ball = grad[:, dof : dof + 3]
    radial = np.sum(g_ball * n, axis=1)  # d F / d angle: < 0, F would fall beyond the cone
    tangential = g_ball - radial[:, None] * n
    others = np.delete(grad, np.s_[dof : dof + 3], axis=1)
    scale = -radial
    assert np.all(scale > 1e-4), radial
    np.testing.assert_array_less(np.linalg.norm(tangential, axis=1), 1e-3 * scale)
    np.testing.assert_array_less(np.abs(others).max(axis=1), 1e-3 * scale)


def test_kernel_only_helper_refuses_a_python_call() -> None:
    """A helper compiled without a Python entry raises TypeError from Python, never crashes."""
    with pytest.raises(TypeError, match="python_callable"):
        _tree_ik.hold_blocked(None, None, None, None)
