"""Reference implementations in plain NumPy that the compiled code is checked against."""

from __future__ import annotations

import mujoco
import numpy as np

from mocap_mj.capture.checks import frame_floor
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve.ik import IKResult, IKSolver, Status
from mocap_mj.solve.problem import IdentificationProblem


def normal_equations(
    prob: IdentificationProblem, sl: slice, w: np.ndarray, *, limits: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A (n, nv, nv), B (n, nv, Pf), g_q (n, nv), C, g_theta of frames ``sl``; with
    ``limits``, hinges at a limit that the gradient pushes outward are held (their rows and
    columns leave the frame's block), as the compiled blocks do."""
    a, b, gq, c, gt = prob.normal_blocks(sl, w)
    blocked = HingeLimits(prob.kin).blocked(prob.qpos[sl], gq) if limits else None
    if blocked is not None and np.any(blocked):
        rows, dofs = np.nonzero(blocked)
        a[rows, dofs, :] = 0.0
        a[rows, :, dofs] = 0.0
        a[rows, dofs, dofs] = 1.0
        b[rows, dofs, :] = 0.0
        gq[rows, dofs] = 0.0
    return a, b, gq, c, gt


def damped_inverse(a: np.ndarray, mu: float) -> np.ndarray:
    """(A + mu diag(A) + 1e-12 I)^-1 of every block of a (n, nv, nv)."""
    diag = np.einsum("nii->ni", a)
    ad = a.copy()
    idx = np.arange(a.shape[1])
    ad[:, idx, idx] += mu * diag + 1e-12
    return np.linalg.inv(ad)


def information(prob: IdentificationProblem, w: np.ndarray) -> np.ndarray:
    """Reduced information (P, P) by pseudo-inverses of the pose blocks."""
    f = prob.free
    a, b, _, c, _ = prob.normal_blocks(slice(0, prob.n), w)
    ainv = np.linalg.pinv(a, hermitian=True)
    bf = b.reshape(-1, f.size)
    s_free = c - bf.T @ np.matmul(ainv, b).reshape(-1, f.size)
    size = prob.kin.pset.size
    info = np.zeros((size, size))
    info[np.ix_(f, f)] = 0.5 * (s_free + s_free.T)
    return info


class HingeLimits:
    """The hinge ranges of a model: qpos addresses, dof addresses, lower and upper [rad]."""

    def __init__(self, kin: Kinematics) -> None:
        m = kin.model
        hinge = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
        self.qadr, self.dof = m.jnt_qposadr[hinge], m.jnt_dofadr[hinge]
        self.lo, self.hi = m.jnt_range[hinge, 0], m.jnt_range[hinge, 1]

    def outward(self, qpos: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """(B, nhinge) bool: hinges at a limit whose ``direction`` (B, nv) points outward."""
        qh, dh, tol = qpos[:, self.qadr], direction[:, self.dof], 1e-12
        return ((qh <= self.lo + tol) & (dh < 0)) | ((qh >= self.hi - tol) & (dh > 0))

    def blocked(self, qpos: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """(B, nv) bool: the dofs of :meth:`outward`."""
        mask = np.zeros(direction.shape, dtype=bool)
        mask[:, self.dof] = self.outward(qpos, direction)
        return mask


def box_step(
    lim: HingeLimits, q: np.ndarray, a: np.ndarray, g: np.ndarray, dv: np.ndarray
) -> np.ndarray:
    """Re-solve with hinge dofs that sit at a limit and would step outward held fixed."""
    blocked = lim.outward(q, dv)
    rows = np.flatnonzero(blocked.any(axis=1))
    if rows.size == 0:
        return dv
    a, g = a[rows].copy(), g[rows].copy()
    r_idx, j_idx = np.nonzero(blocked[rows])
    dof = lim.dof[j_idx]
    a[r_idx, dof, :] = 0.0
    a[r_idx, :, dof] = 0.0
    a[r_idx, dof, dof] = 1.0
    g[r_idx, dof] = 0.0
    dv = dv.copy()
    dv[rows] = np.linalg.solve(a, g[..., None])[..., 0]
    return dv


def numpy_solve_frames(
    solver: IKSolver, markers: np.ndarray, qpos0: np.ndarray, max_iterations: int | None = None
) -> IKResult:
    """:meth:`IKSolver.solve_frames` (unit weights) as a lock-step NumPy loop over all frames:
    batched dense 48 x 48 solves with a per-frame damping and convergence mask. Holds hinges
    at their limits (not balls at their cones)."""
    kin, st = solver.kin, solver.settings
    lim = HingeLimits(kin)
    present = np.all(np.isfinite(markers), axis=2)
    target = np.where(present[..., None], markers, 0.0)
    w = present.astype(float)
    n = len(target)
    qpos = np.array(qpos0, dtype=float, copy=True)
    limit = st.max_iterations if max_iterations is None else max_iterations
    n_present = np.count_nonzero(w > 0, axis=1)
    status = np.full(n, Status.MAX_ITERATIONS, dtype=int)
    iterations = np.zeros(n, dtype=int)
    floor = st.min_markers
    if floor is None:  # the solver's default: frame_floor of the markers recorded
        floor = frame_floor(int(np.count_nonzero(present.any(axis=0))))
    few = n_present < floor
    status[few] = Status.TOO_FEW_MARKERS
    qpos[few] = np.nan
    active = np.flatnonzero(~few)
    rmse = np.full(n, np.nan)
    q = solver.project(qpos[active].copy())
    x = kin.marker_positions(q)
    res = target[active] - x
    wa = w[active]
    cost = 0.5 * np.einsum("bm,bmi,bmi->b", wa, res, res)
    mu = np.full(active.size, st.mu0)
    nu = np.full(active.size, 2.0)
    sqrt_w = np.sqrt(wa)
    idx = np.arange(active.size)  # positions (into active) still iterating
    eye = np.eye(kin.nv)
    for it in range(1, limit + 1):
        if idx.size == 0:
            break
        jq = kin.jac_q(kin.forward(q[idx])) * sqrt_w[idx, :, None, None]
        jf = jq.reshape(idx.size, -1, kin.nv)
        rf = (res[idx] * sqrt_w[idx, :, None]).reshape(idx.size, -1)
        h = np.einsum("bri,brj->bij", jf, jf, optimize=True)
        g = np.einsum("bri,br->bi", jf, rf)
        diag = np.einsum("bii->bi", h)
        if st.damping == "adaptive":
            damp = mu[idx, None] * (diag + 1e-9)
        else:
            damp = np.broadcast_to((cost[idx] + st.wbar)[:, None], diag.shape)
        a = h + damp[:, :, None] * eye
        dv = np.linalg.solve(a, g[..., None])[..., 0]
        dv = box_step(lim, q[idx], a, g, dv)
        q_new = solver.project(kin.integrate(q[idx], dv))
        res_new = target[active[idx]] - kin.marker_positions(q_new)
        cost_new = 0.5 * np.einsum("bm,bmi,bmi->b", wa[idx], res_new, res_new)
        if st.damping == "adaptive":
            predicted = 0.5 * np.einsum("bi,bi->b", dv, damp * dv + g)
            rho = (cost[idx] - cost_new) / np.maximum(predicted, 1e-300)
            accept = (cost_new < cost[idx]) & (rho > 0)
            factor = np.maximum(1 / 3, 1 - (2 * rho - 1) ** 3)
            mu[idx] = np.where(accept, mu[idx] * factor, mu[idx] * nu[idx])
            nu[idx] = np.where(accept, 2.0, nu[idx] * 2)
        else:
            accept = np.ones(idx.size, dtype=bool)
        small_step = np.max(np.abs(dv), axis=1) < st.tol_step
        small_gain = accept & (cost[idx] - cost_new <= st.tol_cost * cost[idx])
        n_i = np.maximum(n_present[active[idx]], 1)
        rmse_new = np.sqrt(2 * np.maximum(cost_new, 0) / n_i)
        d_rmse = np.sqrt(2 * cost[idx] / n_i) - rmse_new
        small_gain |= accept & (d_rmse < st.tol_rmse * rmse_new)
        acc = idx[accept]
        q[acc] = q_new[accept]
        res[acc] = res_new[accept]
        cost[acc] = cost_new[accept]
        iterations[active[idx]] = it
        done = small_step | small_gain | (mu[idx] > 1e12)
        status[active[idx[done]]] = Status.CONVERGED
        idx = idx[~done]
    qpos[active] = q
    rmse[active] = np.sqrt(np.einsum("bm,bmi,bmi->b", (wa > 0), res, res) / n_present[active])
    return IKResult(qpos, rmse, iterations, status, n_present)


def mj_site_jacobian(kin: Kinematics, q: np.ndarray) -> np.ndarray:
    """MuJoCo's site Jacobians (M, 3, nv) at pose q (nq,), with the knee rolling placed
    (:func:`mj_jacobians`)."""
    return mj_jacobians(kin, q, "site")


def mj_jacobians(kin: Kinematics, q: np.ndarray, kind: str) -> np.ndarray:
    """MuJoCo's Jacobians of every site (``kind="site"``, (M, 3, nv)) or body origin
    (``"body"``, (nbody, 3, nv)) at pose q (nq,), with the knee rolling (mocap_mj.skeleton.rolling)
    placed and its term added: ``mj_jacSite``/``mj_jacBody`` of the placed bodies plus, for a
    point below a rolling body, the origin's velocity R_parent dt/dq in the flexion column
    (MuJoCo knows the hinge, not the coupling)."""
    from mocap_mj.skeleton import rolling

    m = kin.model
    data = mujoco.MjData(m)
    data.qpos[:] = q
    rolling.kinematics(m, data)
    mujoco.mj_comPos(m, data)
    if kind == "site":
        n, point_body, jac = m.nsite, np.array(m.site_bodyid), mujoco.mj_jacSite
    else:
        n, point_body, jac = m.nbody, np.arange(m.nbody), mujoco.mj_jacBody
    out = np.zeros((n, 3, m.nv))
    for s in range(n):
        jac(m, data, out[s], None, s)
    roll = kin.rolling
    if roll is not None:
        _, dt = roll.translation(q[roll.qposadr][None])
        for i, b in enumerate(roll.bodies):
            vel = data.xmat[m.body_parentid[b]].reshape(3, 3) @ dt[0, i]
            below = kin.ancestor[point_body, b]
            out[below, :, m.jnt_dofadr[roll.joints[i]]] += vel
    return out
