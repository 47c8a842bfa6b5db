"""The compiled joint-LM blocks (mocap_mj.kernels._schur) against the NumPy normal equations
(tests/_oracles.py)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _oracles import damped_inverse, information, normal_equations

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.kernels import _schur
from mocap_mj.solve.problem import IdentificationProblem
from mocap_synth import SynthConfig, synthesize


@pytest.fixture(scope="module")
def problem() -> tuple[Kinematics, IdentificationProblem, np.ndarray]:
    exp = synthesize(SynthConfig(frames=60, seed=4, gaps=0.1), ParameterSet())
    kin = Kinematics(exp.pset)
    kin.set_theta(exp.pset.nominal)  # away from the truth: non-zero residuals
    free = np.flatnonzero(~exp.pset.frozen)
    free = free[free != 5]  # a frozen parameter
    prob = IdentificationProblem(kin, np.asarray(exp.markers), np.asarray(exp.qpos).copy(), free)
    rng = np.random.default_rng(0)
    w = prob.present * rng.uniform(0.5, 1.5, prob.present.shape)
    return kin, prob, w


@pytest.mark.parametrize("limits", [True, False])
def test_blocks_match_numpy_normal_equations(problem, limits: bool) -> None:  # type: ignore[no-untyped-def]
    kin, prob, w = problem
    free, pf, mu = prob.free, prob.free.size, 1e-3
    sl = slice(0, prob.n)
    # Put four hinges on their lower limits so that the active set is exercised.
    q = prob.qpos.copy()
    hinges = np.flatnonzero(kin.model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)[:4]
    q[:, kin.model.jnt_qposadr[hinges]] = kin.model.jnt_range[hinges, 0]
    prob_q = IdentificationProblem(
        kin, np.where(prob.present[..., None], prob.target, np.nan), q, free
    )
    a, b, gq, c, gt = normal_equations(prob_q, sl, w, limits=limits)
    z = damped_inverse(a, mu) @ np.concatenate([b, gq[..., None]], axis=2)
    bf, zf = b.reshape(-1, pf), z.reshape(-1, pf + 1)
    s_ref, rhs_ref = c - bf.T @ zf[:, :pf], gt - bf.T @ zf[:, pf]
    fb = _schur.frame_blocks(
        kin.tree(), kin.kappa_tables(), prob_q.target, w, q, free, mu, limits=limits
    )
    yf = fb.y.dense().reshape(-1, pf)
    s = fb.c[np.ix_(free, free)] - yf.T @ yf
    rhs = fb.g_theta[free] - yf.T @ fb.y_g.reshape(-1)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=1e-10 * np.abs(s_ref).max())
    np.testing.assert_allclose(rhs, rhs_ref, rtol=0, atol=1e-10 * np.abs(rhs_ref).max())
    # The products the threads form beside the kernel are the same sums.
    s_fb = fb.c[np.ix_(free, free)] - fb.yty
    np.testing.assert_allclose(s_fb, s_ref, rtol=0, atol=1e-10 * np.abs(s_ref).max())
    rhs_fb = fb.g_theta[free] - fb.ytg
    np.testing.assert_allclose(rhs_fb, rhs_ref, rtol=0, atol=1e-10 * np.abs(rhs_ref).max())
    np.testing.assert_allclose(fb.g_q, gq, rtol=0, atol=1e-12)
    held = np.count_nonzero(gq[:, kin.model.jnt_dofadr[hinges]] == 0.0)
    assert held > 0 if limits else held == 0
    np.testing.assert_allclose(fb.diag_a, np.einsum("nii->ni", a), rtol=0, atol=1e-12)
    # The reduced gradient alone (no damping): g_th - B^T A^-1 g_q over the free parameters.
    z0 = damped_inverse(a, 0.0) @ gq[..., None]
    grad_ref = gt - np.einsum("nip,ni->p", b, z0[..., 0])
    target, q_nan = prob_q.target, q.copy()
    q_nan[0] = np.nan  # a frame without a pose is skipped
    grad = _schur.reduced_gradient(kin.tree(), kin.kappa_tables(), target, w, q, limits=limits)
    np.testing.assert_allclose(grad[free], grad_ref, rtol=0, atol=1e-9 * np.abs(grad_ref).max())
    skipped = _schur.reduced_gradient(
        kin.tree(), kin.kappa_tables(), target, w, q_nan, limits=limits
    )
    one = _schur.reduced_gradient(
        kin.tree(), kin.kappa_tables(), target[:1], w[:1], q[:1], limits=limits
    )
    np.testing.assert_allclose(skipped, grad - one, rtol=0, atol=1e-9 * np.abs(grad).max())
    dth = np.random.default_rng(1).normal(0, 1e-3, pf)
    dq_ref = z[..., pf] - z[..., :pf] @ dth
    dq = _schur.back_substitute(kin.tree(), fb, dth)
    np.testing.assert_allclose(dq, dq_ref, rtol=0, atol=1e-10 * np.abs(dq_ref).max())


@pytest.mark.slow
def test_information_matches_pseudo_inverse(problem) -> None:  # type: ignore[no-untyped-def]
    _, prob, w = problem
    fast = prob.information(w)
    slow = information(prob, w)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-4 * np.abs(slow).max())


def test_gram_groups_cover_y_and_skip_its_zeros(problem) -> None:  # type: ignore[no-untyped-def]
    """Y's non-zeros lie inside the structural groups (the product above matches the oracle
    only then), and the groups leave out most of the dense product's work."""
    kin, prob, w = problem
    free, pf = prob.free, prob.free.size
    tree, kt = kin.tree(), kin.kappa_tables()
    groups = _schur.gram_groups(tree, kt, free)
    covered = np.zeros((kin.nv, pf), dtype=bool)
    for dofs, cols in groups:
        covered[dofs][:, cols] = True
    # Y = D^-1/2 L^-T B: L^-T carries a row of B to the dof's ancestors only
    _, b, _, _, _ = prob.normal_blocks(slice(0, prob.n), w)
    reach = (b != 0).any(axis=0)
    for k in range(kin.nv - 1, -1, -1):
        i = int(kin.model.dof_parentid[k])
        while i >= 0:
            reach[i] |= reach[k]
            i = int(kin.model.dof_parentid[i])
    assert reach.any() and not np.any(reach & ~covered)
    work = sum((d.stop - d.start) * c.size**2 for d, c in groups)
    assert work < 0.3 * kin.nv * pf**2
