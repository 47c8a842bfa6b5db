"""The speed paths of issue 18n give the answers of the paths they replace: the informed step
by the eigenvectors below the floor and a Cholesky KKT solve (to rounding), the compiled
tree moved with theta and the joint step integrated by a kernel (to rounding of
``mj_integratePos``)."""

from __future__ import annotations

import mujoco
import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.kernels import _tree
from mocap_mj.skeleton import tree_tables as _tree_tables
from mocap_mj.solve.lm import informed_solve


def _eigenbasis_solve(
    s_mat: np.ndarray, s_damped: np.ndarray, rhs: np.ndarray, floor: float
) -> np.ndarray:
    """The solve informed_solve replaced: in the basis of every eigenvector above the floor."""
    lam, vec = np.linalg.eigh(0.5 * (s_mat + s_mat.T))
    basis = vec[:, lam > floor]
    return basis @ np.linalg.solve(basis.T @ s_damped @ basis, basis.T @ rhs)


def _system(seed: int, uninformed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 40 x 40 information (eigenvalues 1e-4 in ``uninformed`` directions, 1 to 1e6 in the
    rest, as the reduced systems' span), its damped form and a right-hand side."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((40, 40)))
    lam = np.concatenate([np.full(uninformed, 1e-4), np.logspace(0, 6, 40 - uninformed)])
    s = (q * lam) @ q.T
    return s, s + np.diag(1e-3 * np.diag(s)), rng.standard_normal(40)


def test_informed_solve_equals_the_eigenbasis_solve() -> None:
    for seed, uninformed in ((0, 0), (1, 3), (2, 12)):
        s, s_damped, rhs = _system(seed, uninformed)
        want = _eigenbasis_solve(s, s_damped, rhs, 0.04)
        got = informed_solve(s, s_damped, rhs, 0.04)
        assert np.abs(got - want).max() <= 1e-9 * np.abs(want).max(), (seed, uninformed)


def test_informed_solve_of_an_indefinite_damped_system() -> None:
    """No Cholesky factor (a damped system that is not positive definite): the eigenbasis
    solve, as before."""
    s, _, rhs = _system(3, 4)
    s_damped = s - 1e-3 * np.eye(40)  # negative in the uninformed directions only
    want = _eigenbasis_solve(s, s_damped, rhs, 0.04)
    assert np.allclose(informed_solve(s, s_damped, rhs, 0.04), want, rtol=0, atol=1e-12)


def test_tree_moved_with_theta_equals_a_new_tree() -> None:
    pset = ParameterSet()
    kin = Kinematics(pset)
    kin.tree()  # built at the nominal theta, then moved
    theta = pset.nominal + np.random.default_rng(4).normal(0.0, 0.01, pset.size)
    kin.set_theta(theta)
    moved, built = kin.tree(), _tree_tables.build_tree(kin.model)
    for name in built._fields:
        assert np.array_equal(getattr(moved, name), getattr(built, name)), name


def test_integrate_rows_equals_mujoco() -> None:
    kin = Kinematics(ParameterSet())
    rng = np.random.default_rng(5)
    qpos = np.tile(np.array(kin.model.qpos0, dtype=float), (20, 1))
    kin_q = kin.integrate(qpos, rng.normal(0.0, 0.5, (20, kin.nv)))  # spread the poses
    dv = rng.normal(0.0, 0.3, (20, kin.nv))
    want = kin_q.copy()
    for t in range(20):
        mujoco.mj_integratePos(kin.model, want[t], dv[t], 1.0)
    got = kin_q.copy()
    _tree.integrate_rows(kin.tree(), got, dv)
    assert np.abs(got - want).max() <= 1e-12
