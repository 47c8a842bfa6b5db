"""Reference implementations in plain NumPy that the compiled code is checked against."""

from __future__ import annotations

import numpy as np

from mocap_mj.identify.problem import IdentificationProblem


def normal_equations(
    prob: IdentificationProblem, sl: slice, w: np.ndarray, *, limits: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A (n, nv, nv), B (n, nv, Pf), g_q (n, nv), C, g_theta of frames ``sl``; with
    ``limits``, hinges at a limit that the gradient pushes outward are held (their rows and
    columns leave the frame's block), as the compiled blocks do."""
    a, b, gq, c, gt = prob.normal_blocks(sl, w)
    blocked = prob.limits.blocked(prob.qpos[sl], gq) if limits else None
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
