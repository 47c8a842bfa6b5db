"""The Cramer-Rao bound of the joint centres: world positions of the body origins over a trial.

A joint centre c_b(q_t; theta) (the origin of body b in frame t) is estimated through both the
frame's pose and the model. With the frame's information blocks A_t = J_q^T J_q (nv, nv) and
B_t = J_q^T J_theta (nv, P) (unit weights on the present markers) and the reduced information
S of theta (:mod:`mocap_mj.solve.identifiability`), the joint covariance of (q_t, theta) is
the inverse of the block-arrow information, so (first order, sigma the per-axis noise)::

    Cov c_t = sigma^2 [ K_t A_t^-1 K_t^T  +  G_t S^+ G_t^T ],   G_t = H_t - K_t A_t^-1 B_t

with K_t = d c / d q_t (3, nv) and H_t = d c / d theta (3, P): the first term is the pose's
own uncertainty (theta known), the second the model's, seen through a pose that re-fits the
markers. S^+ is taken over the directions of theta determined to at most ``weak_std``: the
exact null directions (a lone marker turning about its joint, the pelvis frame against its
markers) leave every marker, and to first order every joint centre, where they are.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from mocap_mj.kernels._threads import one_blas_thread
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.problem import IdentificationProblem

from ..errors import check_shape


class CentreBound(NamedTuple):
    """Joint-centre bound over a trial's frames, per body (world and root excluded).

    Fields
    ------
    names : list of str, the bodies
    total : (B,) float [m], RMS over frames of sqrt(trace Cov c_t)
    pose : (B,) float [m], the pose's part alone (theta known)
    model : (B,) float [m], the model's part alone
    """

    names: list[str]
    total: np.ndarray
    pose: np.ndarray
    model: np.ndarray

    def rms(self) -> float:
        """RMS over bodies [m] (comparable with the RMS error over bodies and frames)."""
        return float(np.sqrt(np.mean(self.total**2)))


def centre_jacobians(kin: Kinematics, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of the body origins, in closed form (as :meth:`Kinematics.jac_q` and
    :meth:`Kinematics.jac_kappa` give the markers').

    Column v of body b is ``a_v x (c_b - p_v)`` for a rotational dof with world axis ``a_v``
    through ``p_v`` (the rolling knee's instantaneous centre included, see
    :meth:`Kinematics.dof_axes`), ``a_v`` for a translation, zero where the dof is not at or
    above b; a kinematic parameter moving body a's position along direction d (parent frame)
    moves the origin of every body of a's subtree by R_parent d.

    Parameters
    ----------
    kin : Kinematics at the model theta
    qpos : (T, nq) [m, rad] poses

    Returns
    -------
    k : (T, B, 3, nv) [m / rad or m / m], d c / d q (in MuJoCo's tangent space)
    h : (T, B, 3, K) [m / m], d c / d kappa (marker offsets do not move body origins)
    """
    frames = kin.forward(qpos)
    axis, anchor = kin.dof_axes(frames)  # (T, nv, 3) each
    centres = frames.xpos[:, 2:]  # (T, B, 3)
    k = np.cross(axis[:, None], centres[:, :, None] - anchor[:, None])  # (T, B, nv, 3)
    trans = kin.dof_translation
    k[:, :, trans] = axis[:, None, trans]
    k *= kin.ancestor[2:][:, kin.dof_body][None, :, :, None]
    h = np.zeros((*centres.shape, kin.pset.n_kappa))
    moves = np.einsum("tpij,pj->tpi", frames.xmat[:, kin.kappa_parent], kin.kappa_dir)
    for p, (j, body) in enumerate(kin.kappa_pairs):
        column = h[..., j]  # (T, B, 3) view
        column[:, kin.ancestor[2:, body]] += moves[:, p, None, :]
    return k.transpose(0, 1, 3, 2), h


def joint_centre_bound(
    kin: Kinematics,
    markers: np.ndarray,
    qpos: np.ndarray,
    idf: Identifiability,
    *,
    chunk: int = 500,
) -> CentreBound:
    """Cramer-Rao bound of the joint centres over the frames of a trial.

    Parameters
    ----------
    kin : Kinematics at the estimated theta
    markers : (T, M, 3) [m], NaN where missing (only which samples are present matters)
    qpos : (T, nq), the estimated poses; frames with NaN are skipped
    idf : the identifiability analysis of the same fit (its S, sigma and weak_std)
    """
    check_shape("markers", markers, (None, kin.pset.n_markers, 3))
    ok = np.all(np.isfinite(qpos), axis=1)
    markers, qpos = markers[ok], qpos[ok]
    p, n_k = kin.pset.size, kin.pset.n_kappa
    sel = idf.direction_std <= idf.weak_std
    vec, lam = idf.eigenvectors[:, sel], idf.eigenvalues[sel]
    cov_theta = (vec / lam) @ vec.T  # (P, P) [1 / information], times sigma^2 below
    free = np.arange(p)
    prob = IdentificationProblem(kin, markers, qpos.copy(), free)
    w = prob.present.astype(float)
    nb = kin.model.nbody - 2
    pose_ss = np.zeros(nb)
    model_ss = np.zeros(nb)
    with one_blas_thread():
        for s in range(0, len(qpos), chunk):
            sl = slice(s, min(s + chunk, len(qpos)))
            a, b, _, _, _ = prob.normal_blocks(sl, w)
            k, h_k = centre_jacobians(kin, qpos[sl])
            n = len(a)
            ainv = np.linalg.pinv(a, hermitian=True)  # (n, nv, nv)
            kf = k.reshape(n, 3 * nb, kin.nv)
            x = kf @ ainv  # (n, 3B, nv)
            pose_var = np.einsum("nri,nri->nr", x, kf).reshape(n, nb, 3).sum(axis=2)
            g = -(x @ b)  # (n, 3B, P)
            g[:, :, :n_k] += h_k.reshape(n, 3 * nb, n_k)
            model_var = np.einsum("nrp,pq,nrq->nr", g, cov_theta, g, optimize=True)
            pose_ss += pose_var.sum(axis=0)
            model_ss += model_var.reshape(n, nb, 3).sum(axis=2).sum(axis=0)
    t = max(len(qpos), 1)
    sig2 = idf.sigma**2
    pose = np.sqrt(sig2 * pose_ss / t)
    model = np.sqrt(sig2 * model_ss / t)
    names = [kin.model.body(i).name for i in range(2, kin.model.nbody)]
    return CentreBound(names, np.sqrt(pose**2 + model**2), pose, model)


__all__ = ["CentreBound", "centre_jacobians", "joint_centre_bound"]
