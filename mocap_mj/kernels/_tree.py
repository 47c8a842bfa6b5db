"""Compiled (numba) kinematics of a joint tree: the kernels the IK and the joint LM build on.

The kernels mirror what MuJoCo does for the joint types this project supports (free, ball and
hinge) and are checked against it in ``tests/test_tree.py``:

- :func:`fk` is ``mj_kinematics`` restricted to body frames, joint anchors/axes and sites;
- :func:`normal_equations` assembles ``H = J^T W J`` (nv x nv) and ``g = J^T W r`` of the
  marker Jacobian columns ``a_v x (x_s - p_v)`` without ever forming the (3M x nv) Jacobian,
  from per-body sums of the weighted site positions over each subtree;
- :func:`factor` / :func:`solve` are MuJoCo's sparse ``L^T D L`` factorisation of a matrix with
  the sparsity of the mass matrix (``mj_factorI`` / ``mj_solveM``): ``H`` has exactly that
  sparsity (two dofs meet in ``H`` only through a site both move, so one is the other's
  ancestor), and the factorisation in reverse dof order has no fill-in;
- :func:`integrate` / :func:`difference` are ``mj_integratePos`` / ``mj_differentiatePos``.

Everything works on one frame at a time with scalars and small work arrays (no allocation in
the inner loops); frames are spread over Python threads in contiguous blocks
(:func:`run_blocks`; each frame's arithmetic is sequential, so results do not depend on the
thread count). The per-frame IK solver and the joint limits are :mod:`mocap_mj.kernels._tree_ik`,
the tables of a MuJoCo model :mod:`mocap_mj.skeleton.tree_tables`, the compile options
:mod:`mocap_mj.kernels._jit`.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, NamedTuple

import numba as nb
import numpy as np

from mocap_mj.kernels import _numba_prewarm
from mocap_mj.kernels._jit import _inline, _jit, _kernel, python_callable

FREE, BALL, HINGE = 0, 1, 3  # mjtJoint values
TRANSLATION, HINGE_AXIS, BODY_AXIS = 0, 1, 2  # dof kinds
ADAPTIVE, SUGIHARA = 0, 1
CONVERGED, MAX_ITERATIONS, TOO_FEW_MARKERS = 0, 1, 2


class Tree(NamedTuple):
    """Flat tables of a model's kinematic tree (nb bodies, nj joints, ns sites, nv dofs).

    Fields
    ------
    body_parent, body_jntadr, body_jntnum : (nb,) int
    body_pos : (nb, 3) float [m]; body_quat : (nb, 4) float (w, x, y, z)
    jnt_type, jnt_qposadr : (nj,) int
    jnt_pos : (nj, 3) float [m]; jnt_axis : (nj, 3) float; jnt_ref : (nj,) float [rad]
    jnt_ballmax : (nj,) float [rad], a limited ball joint's largest rotation (inf otherwise)
    jnt_lo, jnt_hi : (nj,) float [rad], a limited hinge's range (-inf, inf otherwise)
    site_body : (ns,) int; site_pos : (ns, 3) float [m]
    site_dofptr : (ns + 1,) int; site_dofs : (sum,) int, ascending dofs that move each site
    dof_jnt, dof_body, dof_kind, dof_col, dof_parent : (nv,) int
    body_rolladr : (nb,) int, qpos address of the hinge a body's origin rolls with (-1: none)
    body_roll : (nb, 3, 3) float [m/rad^k], row k-1: the coefficient of q^k of that rolling
        translation, parent frame (:mod:`mocap_mj.skeleton.rolling`); body_rollmax : (nb,) float
        [rad]
    """

    body_parent: np.ndarray
    body_jntadr: np.ndarray
    body_jntnum: np.ndarray
    body_pos: np.ndarray
    body_quat: np.ndarray
    jnt_type: np.ndarray
    jnt_qposadr: np.ndarray
    jnt_pos: np.ndarray
    jnt_axis: np.ndarray
    jnt_ref: np.ndarray
    jnt_ballmax: np.ndarray
    jnt_lo: np.ndarray
    jnt_hi: np.ndarray
    site_body: np.ndarray
    site_pos: np.ndarray
    site_dofptr: np.ndarray
    site_dofs: np.ndarray
    dof_jnt: np.ndarray
    dof_body: np.ndarray
    dof_kind: np.ndarray
    dof_col: np.ndarray
    dof_parent: np.ndarray
    body_rolladr: np.ndarray
    body_roll: np.ndarray
    body_rollmax: np.ndarray


class KappaTables(NamedTuple):
    """(parameter, body) pairs of the kinematic parameters and the sites each pair moves.

    Fields
    ------
    pair_k, pair_parent : (npair,) int, the parameter and the moved body's parent
    pair_dir : (npair, 3) float, direction in the parent's frame
    site_pairptr : (ns + 1,) int; site_pairs : (sum,) int, the pairs that move each site
    n_kappa : int
    pair_body : (npair,) int, the moved body (the pair moves the sites of its subtree)
    pair_dofptr : (npair + 1,) int; pair_dofs, pair_inside : (sum,) int, bool: the dofs that
        move some of a pair's sites, ascending, and whether the dof's body is inside the
        pair's body's subtree (it moves only its own body's subtree) or at or above it (it
        moves all of the pair's sites)
    pair_pairs : (k, 3) int, [p, q, body] for every two pairs (either order, each with
        itself) that move common sites: those of ``body``'s subtree, the deeper of theirs
    """

    pair_k: np.ndarray
    pair_parent: np.ndarray
    pair_dir: np.ndarray
    site_pairptr: np.ndarray
    site_pairs: np.ndarray
    n_kappa: int
    pair_body: np.ndarray
    pair_dofptr: np.ndarray
    pair_dofs: np.ndarray
    pair_inside: np.ndarray
    pair_pairs: np.ndarray


class Work(NamedTuple):
    """Per-frame scratch arrays of :func:`solve_frame` (see :func:`work`)."""

    xpos: np.ndarray
    xquat: np.ndarray
    xmat: np.ndarray
    xanchor: np.ndarray
    xaxis: np.ndarray
    site_xpos: np.ndarray
    axis: np.ndarray
    anchor: np.ndarray
    jcol: np.ndarray
    h: np.ndarray
    g: np.ndarray
    a: np.ndarray
    dv: np.ndarray
    q_new: np.ndarray
    damp: np.ndarray
    blocked: np.ndarray
    xroll: np.ndarray
    agg: np.ndarray
    mot: np.ndarray
    frc: np.ndarray


_POOL: tuple[int, int, ThreadPoolExecutor] | None = None
_POOL_LOCK = threading.Lock()


def _worker_pool(workers: int) -> ThreadPoolExecutor:
    """The process's worker threads for :func:`run_blocks`, at least ``workers`` of them.

    Kept for the process: starting threads for every call cost 0.5 ms per call on a loaded
    machine (tens of calls per identification). Made again in a forked child, whose copy of
    the pool has no threads.
    """
    global _POOL
    with _POOL_LOCK:
        if _POOL is None or _POOL[0] != os.getpid() or _POOL[1] < workers:
            pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="mocap-mj")
            _POOL = (os.getpid(), workers, pool)
        return _POOL[2]


def run_blocks(
    kernel: Callable[..., Any], bounds: np.ndarray, args: Callable[[int], tuple]
) -> None:
    """``kernel(*args(b))`` for each block b of ``bounds`` (k + 1,), one thread per block.

    The kernels release the GIL (:func:`_jit`), so the blocks run in parallel without numba's
    ``parallel=True``, whose parfor compilation cost most of the first run's compile time.
    The first block runs in the calling thread, the others in the process's worker threads
    (:func:`_worker_pool`); all have finished when this returns.
    """
    k = bounds.size - 1
    if k <= 1:
        if k == 1:
            kernel(*args(0))
        return
    pool = _worker_pool(k - 1)
    futures = [pool.submit(kernel, *args(b)) for b in range(1, k)]
    try:
        kernel(*args(0))
    finally:
        for future in futures:
            future.result()


# ------------------------------------------------------------------ quaternion helpers
@_inline
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


@_inline
def _qnormalize(q0, q1, q2, q3):
    n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    if n < 1e-15:
        return 1.0, 0.0, 0.0, 0.0
    return q0 / n, q1 / n, q2 / n, q3 / n


@_jit
def _quat2mat(q0, q1, q2, q3, out):
    """Rotation matrix of a unit quaternion into out (3, 3) (as ``mju_quat2Mat``)."""
    q00, q01, q02, q03 = q0 * q0, q0 * q1, q0 * q2, q0 * q3
    q11, q12, q13 = q1 * q1, q1 * q2, q1 * q3
    q22, q23, q33 = q2 * q2, q2 * q3, q3 * q3
    out[0, 0] = q00 + q11 - q22 - q33
    out[1, 1] = q00 - q11 + q22 - q33
    out[2, 2] = q00 - q11 - q22 + q33
    out[0, 1] = 2 * (q12 - q03)
    out[0, 2] = 2 * (q13 + q02)
    out[1, 0] = 2 * (q12 + q03)
    out[1, 2] = 2 * (q23 - q01)
    out[2, 0] = 2 * (q13 - q02)
    out[2, 1] = 2 * (q23 + q01)


@_inline
def _rot(q0, q1, q2, q3, v0, v1, v2):
    """Vector v rotated by the unit quaternion q."""
    # t = 2 q_v x v; v' = v + q0 t + q_v x t
    t0 = 2 * (q2 * v2 - q3 * v1)
    t1 = 2 * (q3 * v0 - q1 * v2)
    t2 = 2 * (q1 * v1 - q2 * v0)
    return (
        v0 + q0 * t0 + q2 * t2 - q3 * t1,
        v1 + q0 * t1 + q3 * t0 - q1 * t2,
        v2 + q0 * t2 + q1 * t1 - q2 * t0,
    )


# ------------------------------------------------------------------ array helpers
@_jit
def _copy(dst, src):
    """dst[:] = src for 1-D arrays of one size, element by element: numpy's slice assignment
    compiles a shape check with a formatted error message (string code) in every kernel that
    uses it, a large part of the first run's compile."""
    for i in range(dst.size):
        dst[i] = src[i]


@_jit
def _count_present(wts):
    """Number of markers with positive weight in wts (M,)."""
    n = 0
    for s in range(wts.size):
        if wts[s] > 0:
            n += 1
    return n


# ------------------------------------------------------------------ forward kinematics
@_inline
def _rolling(tr, b, q):
    """Body b's rolling translation t(q) and dt/dq (parent frame) [m, m/rad] at angle q
    [rad]: the cubic up to body_rollmax, continued at its slope beyond
    (:mod:`mocap_mj.skeleton.rolling`)."""
    c = tr.body_roll[b]
    u = min(q, tr.body_rollmax[b])
    u2, u3, e = u * u, u * u * u, q - u
    d0 = c[0, 0] + 2 * u * c[1, 0] + 3 * u2 * c[2, 0]
    d1 = c[0, 1] + 2 * u * c[1, 1] + 3 * u2 * c[2, 1]
    d2 = c[0, 2] + 2 * u * c[1, 2] + 3 * u2 * c[2, 2]
    t0 = u * c[0, 0] + u2 * c[1, 0] + u3 * c[2, 0] + e * d0
    t1 = u * c[0, 1] + u2 * c[1, 1] + u3 * c[2, 1] + e * d1
    t2 = u * c[0, 2] + u2 * c[1, 2] + u3 * c[2, 2] + e * d2
    return t0, t1, t2, d0, d1, d2


@_jit
def fk(tr, qpos, w):
    """Forward kinematics of one frame qpos (nq,) into the work arrays of ``w``.

    A rolling body's origin is its ``body_pos`` plus t(q) of its flexion angle (parent frame);
    ``w.xroll[b]`` receives R_parent dt/dq, the origin's velocity per rad of flexion.
    """
    xpos, xquat, xmat = w.xpos, w.xquat, w.xmat
    xpos[0, :] = 0.0
    xquat[0, 0], xquat[0, 1], xquat[0, 2], xquat[0, 3] = 1.0, 0.0, 0.0, 0.0
    _quat2mat(1.0, 0.0, 0.0, 0.0, xmat[0])
    for b in range(1, tr.body_parent.size):
        p = tr.body_parent[b]
        bp = tr.body_pos[b]
        b0, b1, b2 = bp[0], bp[1], bp[2]
        px, py, pz = xpos[p, 0], xpos[p, 1], xpos[p, 2]
        m = xmat[p]
        if tr.body_rolladr[b] >= 0:
            t0, t1, t2, d0, d1, d2 = _rolling(tr, b, qpos[tr.body_rolladr[b]])
            b0, b1, b2 = b0 + t0, b1 + t1, b2 + t2
            for i in range(3):
                w.xroll[b, i] = m[i, 0] * d0 + m[i, 1] * d1 + m[i, 2] * d2
        x0 = px + m[0, 0] * b0 + m[0, 1] * b1 + m[0, 2] * b2
        x1 = py + m[1, 0] * b0 + m[1, 1] * b1 + m[1, 2] * b2
        x2 = pz + m[2, 0] * b0 + m[2, 1] * b1 + m[2, 2] * b2
        bq = tr.body_quat[b]
        q0, q1, q2, q3 = _qmul(
            xquat[p, 0], xquat[p, 1], xquat[p, 2], xquat[p, 3], bq[0], bq[1], bq[2], bq[3]
        )
        for j in range(tr.body_jntadr[b], tr.body_jntadr[b] + tr.body_jntnum[b]):
            a = tr.jnt_qposadr[j]
            typ = tr.jnt_type[j]
            if typ == FREE:
                x0, x1, x2 = qpos[a], qpos[a + 1], qpos[a + 2]
                q0, q1, q2, q3 = _qnormalize(qpos[a + 3], qpos[a + 4], qpos[a + 5], qpos[a + 6])
                w.xanchor[j, 0], w.xanchor[j, 1], w.xanchor[j, 2] = x0, x1, x2
                ax = tr.jnt_axis[j]  # as MuJoCo: a free joint's axis is not rotated
                w.xaxis[j, 0], w.xaxis[j, 1], w.xaxis[j, 2] = ax[0], ax[1], ax[2]
                continue
            ax = tr.jnt_axis[j]
            jp = tr.jnt_pos[j]
            w.xaxis[j, 0], w.xaxis[j, 1], w.xaxis[j, 2] = _rot(q0, q1, q2, q3, ax[0], ax[1], ax[2])
            r0, r1, r2 = _rot(q0, q1, q2, q3, jp[0], jp[1], jp[2])
            an0, an1, an2 = x0 + r0, x1 + r1, x2 + r2
            w.xanchor[j, 0], w.xanchor[j, 1], w.xanchor[j, 2] = an0, an1, an2
            if typ == BALL:
                l0, l1, l2, l3 = _qnormalize(qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3])
            else:
                half = 0.5 * (qpos[a] - tr.jnt_ref[j])
                s = math.sin(half)
                l0, l1, l2, l3 = math.cos(half), ax[0] * s, ax[1] * s, ax[2] * s
            q0, q1, q2, q3 = _qmul(q0, q1, q2, q3, l0, l1, l2, l3)
            r0, r1, r2 = _rot(q0, q1, q2, q3, jp[0], jp[1], jp[2])
            x0, x1, x2 = an0 - r0, an1 - r1, an2 - r2
        q0, q1, q2, q3 = _qnormalize(q0, q1, q2, q3)
        xquat[b, 0], xquat[b, 1], xquat[b, 2], xquat[b, 3] = q0, q1, q2, q3
        _quat2mat(q0, q1, q2, q3, xmat[b])
        xpos[b, 0], xpos[b, 1], xpos[b, 2] = x0, x1, x2
    for s in range(tr.site_body.size):
        b = tr.site_body[s]
        sp = tr.site_pos[s]
        m = xmat[b]
        for i in range(3):
            w.site_xpos[s, i] = xpos[b, i] + m[i, 0] * sp[0] + m[i, 1] * sp[1] + m[i, 2] * sp[2]


@_jit
def cost(tr, target, wts, w):
    """1/2 sum_s wts_s |target_s - x_s|^2 [m^2] for the sites in ``w`` (after :func:`fk`)."""
    c = 0.0
    for s in range(tr.site_body.size):
        if wts[s] > 0:
            d0 = target[s, 0] - w.site_xpos[s, 0]
            d1 = target[s, 1] - w.site_xpos[s, 1]
            d2 = target[s, 2] - w.site_xpos[s, 2]
            c += wts[s] * (d0 * d0 + d1 * d1 + d2 * d2)
    return 0.5 * c


@_jit
def dof_axes(tr, w):
    """World axis and anchor of every dof (``w.axis``, ``w.anchor``: (nv, 3)), after :func:`fk`.

    A rolling hinge (:mod:`mocap_mj.skeleton.rolling`) turns its subtree about its axis a through
    the body origin p and moves the origin by e = ``w.xroll`` per rad, e normal to a: together a
    rotation about the instantaneous centre p + a x e (a x (x - p - a x e) = a x (x - p) + e),
    which is the anchor given here, so every column stays ``a x (x - anchor)``.
    """
    for v in range(tr.dof_jnt.size):
        j = tr.dof_jnt[v]
        kind = tr.dof_kind[v]
        c = tr.dof_col[v]
        if kind == TRANSLATION:
            w.axis[v, :] = 0.0
            w.axis[v, c] = 1.0
        elif kind == HINGE_AXIS:
            w.axis[v, 0], w.axis[v, 1], w.axis[v, 2] = w.xaxis[j, 0], w.xaxis[j, 1], w.xaxis[j, 2]
        else:
            b = tr.dof_body[v]
            w.axis[v, 0], w.axis[v, 1], w.axis[v, 2] = (
                w.xmat[b, 0, c],
                w.xmat[b, 1, c],
                w.xmat[b, 2, c],
            )
        w.anchor[v, 0], w.anchor[v, 1], w.anchor[v, 2] = (
            w.xanchor[j, 0],
            w.xanchor[j, 1],
            w.xanchor[j, 2],
        )
        b = tr.dof_body[v]
        if kind == HINGE_AXIS and tr.body_rolladr[b] == tr.jnt_qposadr[j]:
            a, e = w.axis[v], w.xroll[b]
            w.anchor[v, 0] += a[1] * e[2] - a[2] * e[1]
            w.anchor[v, 1] += a[2] * e[0] - a[0] * e[2]
            w.anchor[v, 2] += a[0] * e[1] - a[1] * e[0]


@_inline
def site_column(tr, w, v, s):
    """d x_s / d qvel_v (3,) as a tuple [m/rad or m/m]."""
    a = w.axis[v]
    if tr.dof_kind[v] == TRANSLATION:
        return a[0], a[1], a[2]
    p = w.anchor[v]
    e0 = w.site_xpos[s, 0] - p[0]
    e1 = w.site_xpos[s, 1] - p[1]
    e2 = w.site_xpos[s, 2] - p[2]
    return a[1] * e2 - a[2] * e1, a[2] * e0 - a[0] * e2, a[0] * e1 - a[1] * e0


@_jit
def _subtree_sums(tr, target, wts, w, ref0, ref1, ref2):
    """Weighted sums over the sites of every body's subtree (after :func:`fk`), sites with
    wts (M,) > 0, x a site's position relative to (ref0, ref1, ref2) [m] and r = target - x
    its residual [m]: ``w.agg`` (nbody, 16) [W, sum w x (3), sum w x x^T (xx, xy, xz, yy,
    yz, zz), sum w r (3), sum w x cross r (3)].

    Every product of a dof's or a kinematic parameter's site columns with the sites it moves
    is one with these sums (:func:`_dof_terms`, the Schur kernel's parameter blocks)
    instead of a sum over the sites. Positions are taken relative to a point on the body
    (the root's origin), not the lab's origin, so that the products' cancellation stays that
    of the body's size however far from the origin it stands."""
    agg = w.agg
    for b in range(agg.shape[0]):
        for i in range(16):
            agg[b, i] = 0.0
    for s in range(tr.site_body.size):
        ws = wts[s]
        if ws <= 0:
            continue
        x0 = w.site_xpos[s, 0] - ref0
        x1 = w.site_xpos[s, 1] - ref1
        x2 = w.site_xpos[s, 2] - ref2
        r0 = target[s, 0] - w.site_xpos[s, 0]
        r1 = target[s, 1] - w.site_xpos[s, 1]
        r2 = target[s, 2] - w.site_xpos[s, 2]
        a = agg[tr.site_body[s]]
        a[0] += ws
        a[1] += ws * x0
        a[2] += ws * x1
        a[3] += ws * x2
        a[4] += ws * x0 * x0
        a[5] += ws * x0 * x1
        a[6] += ws * x0 * x2
        a[7] += ws * x1 * x1
        a[8] += ws * x1 * x2
        a[9] += ws * x2 * x2
        a[10] += ws * r0
        a[11] += ws * r1
        a[12] += ws * r2
        a[13] += ws * (x1 * r2 - x2 * r1)
        a[14] += ws * (x2 * r0 - x0 * r2)
        a[15] += ws * (x0 * r1 - x1 * r0)
    for b in range(agg.shape[0] - 1, 0, -1):
        p = tr.body_parent[b]
        for i in range(16):
            agg[p, i] += agg[b, i]


@_jit
def _dof_terms(tr, w, ref0, ref1, ref2):
    """H = J^T W J (lower triangle of ``w.h``) and g = J^T W r (``w.g``) from the subtree
    sums ``w.agg`` (:func:`_subtree_sums`, about the same point (ref0, ref1, ref2) [m]).

    Dof v moves a site at x (relative to ref) by e_v(x) = om_v x x + nu_v per unit
    (a hinge or ball axis a through anchor p: om = a, nu = a x (ref - p); a translation:
    om = 0, nu = a): ``w.mot`` (nv, 6) [om, nu]. Over the sites of its body's subtree,
    f_v = sum w e_v = om x M1 + W nu and m_v = sum w x cross e_v = om tr(M2) - M2 om + M1 x nu:
    ``w.frc`` (nv, 6) [f, m]. An ancestor u moves all of those sites, so
    ``H[v, u] = om_u . m_v + nu_u . f_v`` and ``g_v = om_v . sum w x cross r + nu_v . sum w r``.
    """
    h, g, agg, mot, frc = w.h, w.g, w.agg, w.mot, w.frc
    for v in range(tr.dof_jnt.size):
        a = w.axis[v]
        if tr.dof_kind[v] == TRANSLATION:
            o0, o1, o2, n0, n1, n2 = 0.0, 0.0, 0.0, a[0], a[1], a[2]
        else:
            d0 = ref0 - w.anchor[v, 0]
            d1 = ref1 - w.anchor[v, 1]
            d2 = ref2 - w.anchor[v, 2]
            o0, o1, o2 = a[0], a[1], a[2]
            n0, n1, n2 = a[1] * d2 - a[2] * d1, a[2] * d0 - a[0] * d2, a[0] * d1 - a[1] * d0
        mot[v, 0], mot[v, 1], mot[v, 2], mot[v, 3], mot[v, 4], mot[v, 5] = o0, o1, o2, n0, n1, n2
        s = agg[tr.dof_body[v]]
        wt, m0, m1, m2 = s[0], s[1], s[2], s[3]
        frc[v, 0] = o1 * m2 - o2 * m1 + wt * n0
        frc[v, 1] = o2 * m0 - o0 * m2 + wt * n1
        frc[v, 2] = o0 * m1 - o1 * m0 + wt * n2
        tr2 = s[4] + s[7] + s[9]
        frc[v, 3] = o0 * tr2 - (s[4] * o0 + s[5] * o1 + s[6] * o2) + m1 * n2 - m2 * n1
        frc[v, 4] = o1 * tr2 - (s[5] * o0 + s[7] * o1 + s[8] * o2) + m2 * n0 - m0 * n2
        frc[v, 5] = o2 * tr2 - (s[6] * o0 + s[8] * o1 + s[9] * o2) + m0 * n1 - m1 * n0
        g[v] = o0 * s[13] + o1 * s[14] + o2 * s[15] + n0 * s[10] + n1 * s[11] + n2 * s[12]
        f = frc[v]
        u = v
        while u >= 0:
            m = mot[u]
            h[v, u] = (
                m[0] * f[3] + m[1] * f[4] + m[2] * f[5] + m[3] * f[0] + m[4] * f[1] + m[5] * f[2]
            )
            u = tr.dof_parent[u]


@_jit
def normal_equations(tr, target, wts, w):
    """H = J^T W J (lower triangle of ``w.h``, (nv, nv)) and g = J^T W r (``w.g``, (nv,)) of
    the sites with wts (M,) > 0 at their targets target (M, 3) [m], after :func:`fk`.

    Formed from the subtree sums of the weighted site positions (:func:`_subtree_sums`,
    :func:`_dof_terms`): a dof's products with another's columns are sums over the sites
    both move, which are the sites below the deeper one, so each entry is a product with
    that subtree's sums instead of a loop over its sites (on the bundled model, about a
    quarter of the operations of summing site by site). Only the (dof, ancestor or itself)
    entries of H are written: the others are zero and never read (:func:`factor`).
    """
    dof_axes(tr, w)
    r = min(1, tr.body_parent.size - 1)  # the root's origin
    ref0, ref1, ref2 = w.xpos[r, 0], w.xpos[r, 1], w.xpos[r, 2]
    _subtree_sums(tr, target, wts, w, ref0, ref1, ref2)
    _dof_terms(tr, w, ref0, ref1, ref2)


@_kernel
def jacobian(tr, w, out):
    """Dense d(site position)/d(qvel) (ns, 3, nv) into out (zeros where a dof does not act)."""
    dof_axes(tr, w)
    out[:, :, :] = 0.0
    for s in range(tr.site_body.size):
        for k in range(tr.site_dofptr[s], tr.site_dofptr[s + 1]):
            v = tr.site_dofs[k]
            out[s, 0, v], out[s, 1, v], out[s, 2, v] = site_column(tr, w, v, s)


# ------------------------------------------------------------------ sparse LDL
@_jit
def factor(tr, a):
    """In-place L^T D L factorisation of the lower triangle of a (nv, nv) (``mj_factorI``).

    Only entries (k, i) with i an ancestor dof of k (or i = k) are read or written; the
    factor's unit-lower entries replace them, D the diagonal.
    """
    parent = tr.dof_parent
    for k in range(a.shape[0] - 1, -1, -1):
        inv_d = 1.0 / a[k, k]
        i = parent[k]
        while i >= 0:
            tmp = a[k, i] * inv_d
            j = i
            while j >= 0:
                a[i, j] -= tmp * a[k, j]
                j = parent[j]
            a[k, i] = tmp
            i = parent[i]


@_inline
def lower_copy(tr, h, a):
    """a <- h at the entries :func:`factor` reads (each dof's row at itself and its
    ancestors); the rest of a is left as it was."""
    parent = tr.dof_parent
    for i in range(h.shape[0]):
        k = i
        while k >= 0:
            a[i, k] = h[i, k]
            k = parent[k]


@_jit
def solve(tr, a, x):
    """x <- (L^T D L)^-1 x in place, for a factored by :func:`factor` (``mj_solveM``)."""
    parent = tr.dof_parent
    n = a.shape[0]
    for k in range(n - 1, -1, -1):
        xk = x[k]
        if xk != 0.0:
            i = parent[k]
            while i >= 0:
                x[i] -= a[k, i] * xk
                i = parent[i]
    for k in range(n):
        x[k] /= a[k, k]
    for k in range(n):
        i = parent[k]
        while i >= 0:
            x[k] -= a[k, i] * x[i]
            i = parent[i]


# ------------------------------------------------------------------ configuration space
@_jit
def integrate(tr, qpos, dv, scale):
    """qpos (nq,) advanced in place by scale * dv (nv,) (``mj_integratePos``)."""
    v = 0
    for j in range(tr.jnt_type.size):
        a = tr.jnt_qposadr[j]
        typ = tr.jnt_type[j]
        if typ == HINGE:
            qpos[a] += scale * dv[v]
            v += 1
            continue
        if typ == FREE:
            for i in range(3):
                qpos[a + i] += scale * dv[v + i]
            a += 3
            v += 3
        w0, w1, w2 = dv[v], dv[v + 1], dv[v + 2]
        n = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        q0, q1, q2, q3 = _qnormalize(qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3])
        if n >= 1e-15:
            half = 0.5 * scale * n
            s = math.sin(half) / n
            q0, q1, q2, q3 = _qmul(q0, q1, q2, q3, math.cos(half), w0 * s, w1 * s, w2 * s)
        q0, q1, q2, q3 = _qnormalize(q0, q1, q2, q3)
        qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3] = q0, q1, q2, q3
        v += 3


@_inline
def _quat_log(q0, q1, q2, q3):
    """Rotation vector of a unit quaternion (``mju_quat2Vel`` with dt = 1)."""
    s = math.sqrt(q1 * q1 + q2 * q2 + q3 * q3)
    if s < 1e-15:
        return 0.0, 0.0, 0.0
    angle = 2 * math.atan2(s, q0)
    if angle > math.pi:
        angle -= 2 * math.pi
    f = angle / s
    return q1 * f, q2 * f, q3 * f


@_jit
def difference(tr, qa, qb, dv):
    """dv (nv,) with integrate(qa, dv, 1) = qb (``mj_differentiatePos``)."""
    v = 0
    for j in range(tr.jnt_type.size):
        a = tr.jnt_qposadr[j]
        typ = tr.jnt_type[j]
        if typ == HINGE:
            dv[v] = qb[a] - qa[a]
            v += 1
            continue
        if typ == FREE:
            for i in range(3):
                dv[v + i] = qb[a + i] - qa[a + i]
            a += 3
            v += 3
        a0, a1, a2, a3 = _qnormalize(qa[a], qa[a + 1], qa[a + 2], qa[a + 3])
        b0, b1, b2, b3 = _qnormalize(qb[a], qb[a + 1], qb[a + 2], qb[a + 3])
        d = _qmul(a0, -a1, -a2, -a3, b0, b1, b2, b3)
        dv[v], dv[v + 1], dv[v + 2] = _quat_log(d[0], d[1], d[2], d[3])
        v += 3


@_jit
def project(tr, qpos):
    """Joint limits applied in place to qpos (nq,): hinges clipped, balls shortened."""
    for j in range(tr.jnt_type.size):
        a = tr.jnt_qposadr[j]
        typ = tr.jnt_type[j]
        if typ == HINGE:
            if qpos[a] < tr.jnt_lo[j]:
                qpos[a] = tr.jnt_lo[j]
            elif qpos[a] > tr.jnt_hi[j]:
                qpos[a] = tr.jnt_hi[j]
        elif typ == BALL and tr.jnt_ballmax[j] < np.inf:
            q0, q1, q2, q3 = qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3]
            if q0 < 0:
                q0, q1, q2, q3 = -q0, -q1, -q2, -q3
            s = math.sqrt(q1 * q1 + q2 * q2 + q3 * q3)
            if 2 * math.atan2(s, q0) > tr.jnt_ballmax[j]:
                half = 0.5 * tr.jnt_ballmax[j]
                f = math.sin(half) / s
                q0, q1, q2, q3 = math.cos(half), q1 * f, q2 * f, q3 * f
            qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3] = q0, q1, q2, q3


@_kernel
def project_rows(tr, qpos):
    """:func:`project` applied in place to every row of qpos (B, nq)."""
    for t in range(qpos.shape[0]):
        project(tr, qpos[t])


@_kernel
def integrate_rows(tr, qpos, dv):
    """:func:`integrate` (scale 1) applied in place to every row of qpos (B, nq) with the
    row's dv (B, nv): the joint LM's step of every frame, one call instead of B calls of
    ``mj_integratePos``."""
    for t in range(qpos.shape[0]):
        integrate(tr, qpos[t], dv[t], 1.0)


# ------------------------------------------------------------------ one frame's LM
def work(tr: Tree, nq: int) -> Work:
    """Scratch arrays for one frame (see :class:`Work`)."""
    nbody, njnt, ns, nv = tr.body_parent.size, tr.jnt_type.size, tr.site_body.size, tr.dof_jnt.size
    return python_callable(work_arrays)(nbody, njnt, ns, nv, nq)


@_jit
def work_arrays(nbody, njnt, ns, nv, nq):
    return Work(
        np.zeros((nbody, 3)),
        np.zeros((nbody, 4)),
        np.zeros((nbody, 3, 3)),
        np.zeros((njnt, 3)),
        np.zeros((njnt, 3)),
        np.zeros((ns, 3)),
        np.zeros((nv, 3)),
        np.zeros((nv, 3)),
        np.zeros((nv, 3)),
        np.zeros((nv, nv)),
        np.zeros(nv),
        np.zeros((nv, nv)),
        np.zeros(nv),
        np.zeros(nq),
        np.zeros(nv),
        np.zeros(nv, dtype=np.bool_),
        np.zeros((nbody, 3)),
        np.zeros((nbody, 16)),
        np.zeros((nv, 6)),
        np.zeros((nv, 6)),
    )


# ------------------------------------------------------------------ many frames
#: Batches smaller than this run in the calling thread: a thread costs its start-up, and on a
#: busy machine a descheduled worker stalls the whole call.
PARALLEL_MIN = 32


def blocks(items: int, frames: int, min_block: int = PARALLEL_MIN) -> np.ndarray:
    """Bounds (k + 1,) of k contiguous blocks of range(items), one per thread (numba's thread
    count: ``NUMBA_NUM_THREADS``, ``numba.set_num_threads``), with at least ``min_block``
    (default PARALLEL_MIN) of the work's ``frames`` per block (k = 1: run in the caller, see
    :func:`run_blocks`)."""
    k = max(1, min(nb.get_num_threads(), items, frames // max(min_block, 1)))
    # np.linspace(0, items, k + 1).round() without its overhead (hundreds of calls a run):
    # the same i * (items / k), rounded half to even, and the end exact.
    step = items / k
    return np.array([round(i * step) for i in range(k)] + [items], dtype=np.int64)


def _floats(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """The arrays as C-contiguous, writeable float64 (copied only where needed).

    Numba compiles a kernel once per argument type, and a strided or read-only array is
    another type: one call with such an array would compile the whole entry kernel again
    (for :func:`_ik_range`, most of the first run's compile).
    """
    out = [np.ascontiguousarray(a, dtype=float) for a in arrays]
    return tuple(a if a.flags.writeable else a.copy() for a in out)


@_kernel
def _forward_range(tr, qpos, site_xpos):
    w = work_arrays(
        tr.body_parent.size, tr.jnt_type.size, tr.site_body.size, tr.dof_jnt.size, qpos.shape[1]
    )
    for t in range(qpos.shape[0]):
        fk(tr, qpos[t], w)
        for s in range(site_xpos.shape[1]):
            for i in range(3):
                site_xpos[t, s, i] = w.site_xpos[s, i]


def forward(tr: Tree, qpos: np.ndarray) -> np.ndarray:
    """Site positions (T, ns, 3) [m] of qpos (T, nq), the frames spread over threads."""
    _numba_prewarm.wait()
    out = np.empty((len(qpos), tr.site_body.size, 3))
    (q,) = _floats(qpos)
    bounds = blocks(len(q), len(q))
    run_blocks(
        _forward_range,
        bounds,
        lambda b: (tr, q[bounds[b] : bounds[b + 1]], out[bounds[b] : bounds[b + 1]]),
    )
    return out
