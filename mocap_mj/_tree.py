"""Compiled (numba) kinematics of a joint tree and the per-frame IK solver built on it.

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
thread count).
"""

from __future__ import annotations

import math
import os
import sys
import threading
import types
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import cache
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numba as nb
import numpy as np
from numba.core.registry import CPUDispatcher

from . import _numba_prewarm
from ._kernel_cache import share_cache

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
        translation, parent frame (:mod:`mocap_mj.rolling`); body_rollmax : (nb,) float [rad]
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


#: Options of every kernel: cached on disk (:mod:`mocap_mj._kernel_cache`), releasing the GIL
#: (Python threads run kernels side by side, see :func:`run_blocks`), and numpy's error model
#: (a division by zero gives inf/nan instead of raising: no exception paths to compile).
_OPTIONS: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}
_INNER_OPTIONS: dict[str, Any] = {**_OPTIONS, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


def _kernel(fn: Callable[..., Any]) -> Any:
    """An entry kernel: compiled with the wrapper that Python calls it through."""
    return share_cache(nb.njit(**_OPTIONS)(fn))


class _KernelOnly(CPUDispatcher):  # type: ignore[misc]
    """A :func:`_jit` helper's dispatcher: a call from Python raises instead of crashing."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise TypeError(
            f"{self.py_func.__qualname__} is compiled for calls from kernels only "
            "(no Python entry point): use mocap_mj._tree.python_callable"
        )


def _jit(fn: Callable[..., Any]) -> Any:
    """A kernel called only from other kernels: compiled without the Python and C wrappers.

    Numba gives every compiled function a wrapper that unboxes its arguments from Python
    objects (for a :class:`Tree` and a :class:`Work`, 38 arrays) and a C-callable one, and
    compiles and optimises them with the function; a helper never called from Python does not
    need them, and leaving them out shortens the first run's compile
    (docs/validation.md#first-run). Without its wrapper a call from Python would crash the
    interpreter, so the dispatcher raises :class:`TypeError` instead: use
    :func:`python_callable` (tests do).
    """
    disp = share_cache(nb.njit(**_INNER_OPTIONS)(fn))
    disp.__class__ = _KernelOnly
    return disp


@cache
def python_callable(helper: Any) -> Any:
    """A :func:`_jit` helper compiled again with a Python entry point (for tests).

    A copy of the function under its own name, so the two compilations have separate entries
    in the on-disk cache (numba keys them by qualified name, not by options).
    """
    fn = helper.py_func
    copy = types.FunctionType(
        fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__
    )
    copy.__qualname__ = f"{fn.__qualname__}_from_python"
    copy.__doc__ = fn.__doc__
    return _kernel(copy)


#: Small helpers are compiled like any kernel and LLVM inlines them where it pays. Numba's
#: ``inline="always"`` would copy their IR into every caller before type inference, which
#: lengthens the first run's compile (docs/validation.md#first-run).
_inline = _jit


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
    (:mod:`mocap_mj.rolling`)."""
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

    A rolling hinge (:mod:`mocap_mj.rolling`) turns its subtree about its axis a through the
    body origin p and moves the origin by e = ``w.xroll`` per rad, e normal to a: together a
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


@_jit
def _ball_axis(q, a):
    """Rotation axis (unit; zeros for no rotation) and angle [rad] of the ball quaternion at
    qpos address a, taken with w >= 0 (angle in [0, pi])."""
    q0, q1, q2, q3 = q[a], q[a + 1], q[a + 2], q[a + 3]
    if q0 < 0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    s = math.sqrt(q1 * q1 + q2 * q2 + q3 * q3)
    angle = 2 * math.atan2(s, q0)
    if s < 1e-12:
        return 0.0, 0.0, 0.0, angle
    return q1 / s, q2 / s, q3 / s, angle


@_jit
def blocked_dofs(tr, q, dv, out, gb):
    """out (nv,) bool: dofs held for a step dv; returns any.

    A hinge at a limit whose step dv points outward is held. A ball joint at its largest
    rotation that the descent direction gb (J^T W r) turns further (its component along the
    rotation axis: for q exp(e v), d angle / d e = n . v) has its three dofs flagged:
    :func:`hold_blocked` then holds only that radial component, and the ball slides along its
    limit. (Testing the step instead of the descent direction for balls held intermediate
    iterates on the cone that would have turned back inward: 6.3 instead of 4.6 iterations
    per frame on the IK benchmark.)
    """
    any_blocked = False
    v = 0
    for j in range(tr.jnt_type.size):
        typ = tr.jnt_type[j]
        if typ == HINGE:
            a = tr.jnt_qposadr[j]
            b = (q[a] <= tr.jnt_lo[j] + 1e-12 and dv[v] < 0) or (
                q[a] >= tr.jnt_hi[j] - 1e-12 and dv[v] > 0
            )
            out[v] = b
            any_blocked |= b
            v += 1
        elif typ == BALL:
            b = False
            if tr.jnt_ballmax[j] < np.inf:
                n0, n1, n2, angle = _ball_axis(q, tr.jnt_qposadr[j])
                radial = n0 * gb[v] + n1 * gb[v + 1] + n2 * gb[v + 2]
                b = angle >= tr.jnt_ballmax[j] - 1e-9 and radial > 0
            for i in range(3):
                out[v + i] = b
            any_blocked |= b
            v += 3
        else:
            for i in range(6):
                out[v + i] = False
            v += 6
    return any_blocked


@_jit
def hold_blocked(tr, q, blocked, h):
    """Apply the holds flagged by :func:`blocked_dofs` to the lower triangle of the normal
    matrix h (nv, nv) (the part :func:`normal_equations` fills and :func:`factor` reads): a
    held hinge's row and column leave it (unit diagonal; the caller zeroes its right-hand
    side), a held ball's radial component gets a stiffness 1e6 times the ball's diagonal, so
    the step keeps its rotation angle to about 1e-6 of what it would otherwise take."""
    nv = h.shape[0]
    v = 0
    for j in range(tr.jnt_type.size):
        typ = tr.jnt_type[j]
        if typ == HINGE:
            if blocked[v]:
                for k in range(v):
                    h[v, k] = 0.0
                for k in range(v + 1, nv):
                    h[k, v] = 0.0
                h[v, v] = 1.0
            v += 1
        elif typ == BALL:
            if blocked[v]:
                n = _ball_axis(q, tr.jnt_qposadr[j])
                stiff = 1e6 * (h[v, v] + h[v + 1, v + 1] + h[v + 2, v + 2]) + 1e-6
                for i in range(3):
                    for k in range(i + 1):
                        h[v + i, v + k] += stiff * n[i] * n[k]
            v += 3
        else:
            v += 6


@_jit
def _damped_solve(tr, w, q, damp, blocked, use_blocked):
    """w.dv = (H + diag(damp))^-1 g, with the blocked dofs held (:func:`hold_blocked`) if
    use_blocked."""
    n = w.g.size
    a, dv = w.a, w.dv
    lower_copy(tr, w.h, a)
    for i in range(n):
        a[i, i] += damp[i]
        dv[i] = w.g[i]
    if use_blocked:
        hold_blocked(tr, q, blocked, a)
        for v in range(n):
            if blocked[v] and tr.jnt_type[tr.dof_jnt[v]] == HINGE:
                dv[v] = 0.0
    factor(tr, a)
    solve(tr, a, dv)


@_jit
def solve_frame(tr, target, wts, q, w, max_it, damping, tol_step, tol_cost, tol_rmse, mu0, wbar):
    """Levenberg-Marquardt on one frame; q (nq,) is the start and receives the solution.

    target (M, 3) [m] (any finite value where wts is 0), wts (M,) >= 0. Returns
    (iterations, status, marker RMSE [m] over the sites with wts > 0).
    """
    nv = w.g.size
    n_i = max(_count_present(wts), 1)
    project(tr, q)
    fk(tr, q, w)
    f = cost(tr, target, wts, w)
    mu, nu = mu0, 2.0
    need_jac = True
    fresh = True  # the work arrays hold q's forward kinematics
    status = MAX_ITERATIONS
    iterations = 0
    q_new, dv, damp = w.q_new, w.dv, w.damp
    for it in range(1, max_it + 1):
        iterations = it
        if need_jac:
            normal_equations(tr, target, wts, w)
            need_jac = False
        for i in range(nv):
            damp[i] = mu * (w.h[i, i] + 1e-9) if damping == ADAPTIVE else f + wbar
        # The step without holds; if it pushes a joint out of its limits, again with holds.
        # (``hold`` a variable, not two calls with the constants False and True: numba would
        # compile _damped_solve once for each constant.)
        hold = False
        while True:
            _damped_solve(tr, w, q, damp, w.blocked, hold)
            if hold or not blocked_dofs(tr, q, dv, w.blocked, w.g):
                break
            hold = True
        _copy(q_new, q)
        integrate(tr, q_new, dv, 1.0)
        project(tr, q_new)
        fk(tr, q_new, w)
        fresh = False
        f_new = cost(tr, target, wts, w)
        step = 0.0
        for i in range(nv):
            step = max(step, abs(dv[i]))
        if damping == ADAPTIVE:
            predicted = 0.0
            for i in range(nv):
                predicted += dv[i] * (damp[i] * dv[i] + w.g[i])
            predicted *= 0.5
            rho = (f - f_new) / max(predicted, 1e-300)
            accept = f_new < f and rho > 0
            if accept:
                mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
            else:
                mu *= nu
                nu *= 2.0
        else:
            accept = True
        done = step < tol_step or mu > 1e12
        if accept:
            rmse_new = math.sqrt(2 * max(f_new, 0.0) / n_i)
            d_rmse = math.sqrt(2 * f / n_i) - rmse_new
            done |= f - f_new <= tol_cost * f or d_rmse < tol_rmse * rmse_new
            _copy(q, q_new)
            f = f_new
            need_jac = True
            fresh = True
        if done:
            status = CONVERGED
            break
    if not fresh:  # the last step was rejected: its kinematics are in the work arrays
        fk(tr, q, w)
    sq = 0.0
    for s in range(wts.size):
        if wts[s] > 0:
            for i in range(3):
                d = target[s, i] - w.site_xpos[s, i]
                sq += d * d
    return iterations, status, math.sqrt(sq / n_i)


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


#: Jobs of :func:`_ik_range`.
FRAMES, CHAINS, WALKS = 0, 1, 2


@_kernel
def _ik_range(
    job, tr, target, wts, qpos, rmse, iters, status, starts, firsts, lasts, early, lo, hi,
    max_it, damping, tol_step, tol_cost, tol_rmse, mu0, wbar, min_markers,
):  # fmt: skip
    """The one entry kernel of the IK jobs, for items lo..hi: frames (FRAMES,
    :func:`solve_batch`), chains (CHAINS, :func:`solve_chains`) or walks (WALKS,
    :func:`walk`).

    Numba optimises every compiled function, entry or helper, with all of its callees linked
    in, so each kernel between this entry and :func:`solve_frame` (and each further entry)
    would optimise the per-frame solver once more: the three loops are in this one body.
    ``starts`` (T, nq) [m, rad] are the cold starts of CHAINS or the seeds of WALKS;
    ``firsts``, ``lasts`` (K,) the chains' bounds [first, last) or the walks' ends
    [first, last] (all three unused by FRAMES).
    """
    nbody, njnt, ns, nv = tr.body_parent.size, tr.jnt_type.size, tr.site_body.size, tr.dof_jnt.size
    nq = qpos.shape[1]
    w = work_arrays(nbody, njnt, ns, nv, nq)
    vel = np.zeros(nv)
    if job == FRAMES:
        for t in range(lo, hi):
            if _count_present(wts[t]) < min_markers:
                status[t] = TOO_FEW_MARKERS
                qpos[t, :] = np.nan
                continue
            iters[t], status[t], rmse[t] = solve_frame(
                tr, target[t], wts[t], qpos[t], w, max_it, damping, tol_step, tol_cost,
                tol_rmse, mu0, wbar,
            )  # fmt: skip
    elif job == CHAINS:
        for c in range(lo, hi):
            for t in range(firsts[c], lasts[c]):
                if _count_present(wts[t]) < min_markers:
                    status[t] = TOO_FEW_MARKERS
                    continue
                k = t - firsts[c]
                q = qpos[t]
                if k >= 1 and status[t - 1] != TOO_FEW_MARKERS:
                    _copy(q, qpos[t - 1])
                    if k >= 2 and status[t - 2] != TOO_FEW_MARKERS:
                        difference(tr, qpos[t - 2], qpos[t - 1], vel)
                        integrate(tr, q, vel, 1.0)
                else:
                    _copy(q, starts[t])
                iters[t], status[t], rmse[t] = solve_frame(
                    tr, target[t], wts[t], q, w, max_it, damping, tol_step, tol_cost,
                    tol_rmse, mu0, wbar,
                )  # fmt: skip
    else:
        prev2 = np.zeros(nq)
        prev = np.zeros(nq)
        qw = np.zeros(nq)
        for r in range(lo, hi):
            step = 1 if lasts[r] >= firsts[r] else -1
            _copy(prev, starts[r])
            have2 = False
            for t in range(firsts[r], lasts[r] + step, step):
                if status[t] == TOO_FEW_MARKERS:
                    break
                _copy(qw, prev)
                if have2:
                    difference(tr, prev2, prev, vel)
                    integrate(tr, qw, vel, 1.0)
                it, stat, err = solve_frame(
                    tr, target[t], wts[t], qw, w, max_it, damping, tol_step, tol_cost,
                    tol_rmse, mu0, wbar,
                )  # fmt: skip
                iters[t] += it
                better = err < rmse[t] * (1.0 - 1e-6)
                if better:
                    _copy(qpos[t], qw)
                    rmse[t], status[t] = err, stat
                elif early:
                    break  # same basin as the frame's own solution: the rest follows
                else:
                    _copy(qw, qpos[t])
                _copy(prev2, prev)
                _copy(prev, qw)
                have2 = True


def solve_batch(
    tr: Tree,
    target: np.ndarray,
    wts: np.ndarray,
    qpos: np.ndarray,
    *settings: float,
    min_block: int = PARALLEL_MIN,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Independent frames, solved in place from their starts qpos (B, nq) [m, rad].

    target (B, M, 3) [m], wts (B, M); settings: max_it, damping (ADAPTIVE or SUGIHARA),
    tol_step, tol_cost, tol_rmse, mu0, wbar, min_markers (see ``IKSettings``). Returns
    (rmse (B,) [m], iterations (B,), status (B,)); frames with fewer than min_markers sites of
    positive weight get status TOO_FEW_MARKERS and NaN qpos. ``min_block``: fewest frames
    per thread (:func:`blocks`; cold starts, at tens of iterations a frame, pay with fewer).
    """
    n = len(qpos)
    rmse = np.full(n, np.nan)
    iters = np.zeros(n, dtype=np.int64)
    status = np.zeros(n, dtype=np.int64)
    args = _settings(settings)
    target, wts = _floats(target, wts)
    bounds = blocks(n, n, min_block)
    none = _unused(qpos.shape[1])
    run_blocks(
        _ik_range,
        bounds,
        lambda b: (
            FRAMES, tr, target, wts, qpos, rmse, iters, status, *none, bounds[b],
            bounds[b + 1], *args,
        ),
    )  # fmt: skip
    return rmse, iters, status


def _floats(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """The arrays as C-contiguous, writeable float64 (copied only where needed).

    Numba compiles a kernel once per argument type, and a strided or read-only array is
    another type: one call with such an array would compile the whole entry kernel again
    (for :func:`_ik_range`, most of the first run's compile).
    """
    out = [np.ascontiguousarray(a, dtype=float) for a in arrays]
    return tuple(a if a.flags.writeable else a.copy() for a in out)


def _unused(nq: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Placeholders for :func:`_ik_range`'s starts, firsts, lasts and early (FRAMES)."""
    return np.empty((0, nq)), np.empty(0, np.int64), np.empty(0, np.int64), False


def _settings(settings: tuple[float, ...]) -> tuple[int | float, ...]:
    max_it, damping, tol_step, tol_cost, tol_rmse, mu0, wbar, min_markers = settings
    return (
        int(max_it), int(damping), float(tol_step), float(tol_cost), float(tol_rmse),
        float(mu0), float(wbar), int(min_markers),
    )  # fmt: skip


def solve_chains(
    tr: Tree,
    target: np.ndarray,
    wts: np.ndarray,
    cold: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    *settings: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Chains of consecutive frames [starts[c], ends[c]), the chains spread over threads.

    A frame starts from the previous frame's solution advanced by the velocity between the
    two previous frames (constant-velocity prediction, projected onto the limits), from the
    previous solution when only one exists, and from ``cold`` (T, nq) (a rigid fit of the
    root) at a chain's head or after an unsolved frame. target (T, M, 3) [m], wts (T, M),
    settings as :func:`solve_batch`. Returns (qpos (T, nq), rmse (T,) [m], iterations (T,),
    status (T,)).
    """
    n, nq = cold.shape
    target, wts, cold = _floats(target, wts, cold)
    qpos = np.full((n, nq), np.nan)
    rmse = np.full(n, np.nan)
    iters = np.zeros(n, dtype=np.int64)
    status = np.zeros(n, dtype=np.int64)
    args = _settings(settings)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    ends = np.ascontiguousarray(ends, dtype=np.int64)
    bounds = blocks(starts.size, n)
    run_blocks(
        _ik_range,
        bounds,
        lambda b: (
            CHAINS, tr, target, wts, qpos, rmse, iters, status, cold, starts, ends, False,
            bounds[b], bounds[b + 1], *args,
        ),
    )  # fmt: skip
    return qpos, rmse, iters, status


def walk(
    tr: Tree,
    target: np.ndarray,
    wts: np.ndarray,
    qpos: np.ndarray,
    rmse: np.ndarray,
    iters: np.ndarray,
    status: np.ndarray,
    seeds: np.ndarray,
    firsts: np.ndarray,
    lasts: np.ndarray,
    early: bool,
    *settings: float,
) -> None:
    """Re-solve runs of frames in place, each walked from a seed pose.

    Run r visits frames firsts[r], ..., lasts[r] (either direction, consecutive; it stops at
    an unsolved frame), starting from seeds[r] (nq,) and predicting each next start with
    constant velocity. A frame's new pose is kept when its RMSE is lower than rmse[t] and
    the walk goes on from the kept pose; with ``early`` the walk stops at the first frame
    that does not improve (it has reached the basin the frames are already in). Runs must not
    overlap. Arrays as :func:`solve_chains`' outputs, updated in place.
    """
    args = _settings(settings)
    firsts, lasts = (np.ascontiguousarray(a, dtype=np.int64) for a in (firsts, lasts))
    target, wts, seeds = _floats(target, wts, seeds)
    frames = int(np.abs(lasts - firsts).sum()) + firsts.size
    bounds = blocks(firsts.size, frames)
    run_blocks(
        _ik_range,
        bounds,
        lambda b: (
            WALKS, tr, target, wts, qpos, rmse, iters, status, seeds, firsts, lasts,
            bool(early), bounds[b], bounds[b + 1], *args,
        ),
    )  # fmt: skip


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


# ------------------------------------------------------------------ tables
#: What the first run of an install spends compiling the kernels on an idle 2-core machine
#: (``benchmarks/cold_start.py``), said once when the on-disk cache is empty; scaled by
#: :func:`compile_estimate` when other work already keeps the cores busy.
COMPILE_SECONDS = 15
_notice_given = False


def compile_estimate(base: float = COMPILE_SECONDS) -> tuple[int, str]:
    """The compile's expected wall time [s] on this machine now, and why it differs from
    ``base``: the compiler gets a share ``cores / (load + 1)`` of the cores when the 1-minute
    load average already exceeds what leaves one core idle, so the time grows by the inverse."""
    cores = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except OSError:  # not available on this platform: assume idle
        return round(base), ""
    if load < cores - 0.5:
        return round(base), ""
    return round(base * (load + 1) / cores), f", the machine is busy: load {load:.1f} on {cores}"


def compile_notice() -> None:
    """Say on stderr, once per process, that the kernels are about to be compiled, if the
    on-disk cache (:mod:`mocap_mj._kernel_cache`) does not hold them yet."""
    global _notice_given
    if _notice_given:
        return
    _notice_given = True
    try:
        index = Path(_ik_range._cache._cache_file._index_path)
    except AttributeError:  # a numba without this cache layout: say nothing
        return
    if not index.exists():
        seconds, why = compile_estimate()
        print(
            f"mocap-mj: compiling the numeric kernels (once per install, ~{seconds} s{why})",
            file=sys.stderr,
            flush=True,
        )


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


def kappa_tables(
    pairs: tuple[tuple[int, int], ...],
    parents: np.ndarray,
    directions: np.ndarray,
    sites_of_pair: list[np.ndarray],
    n_sites: int,
    n_kappa: int,
    ancestor: np.ndarray,
    dof_body: np.ndarray,
) -> KappaTables:
    """:class:`KappaTables` from :class:`mocap_mj.Kinematics`' kappa tables, its ancestor
    table (nb, nb) bool (``ancestor[b, a]``: body a is b or one of b's ancestors) and the
    dofs' bodies (nv,) int."""
    per_site: list[list[int]] = [[] for _ in range(n_sites)]
    for p, sites in enumerate(sites_of_pair):
        for s in sites:
            per_site[int(s)].append(p)
    ptr = np.concatenate([[0], np.cumsum([len(x) for x in per_site])]).astype(np.int64)
    flat = np.array([p for x in per_site for p in x], dtype=np.int64)
    body = np.array([b for _, b in pairs], dtype=np.int64)
    dof_body = np.asarray(dof_body, dtype=np.int64)
    above = ancestor[body][:, dof_body]  # (npair, nv): the dof's body is at or above the pair's
    inside = ancestor[dof_body][:, body].T & (dof_body[None, :] != body[:, None])
    moves = above | inside
    pp, qq = np.nonzero(ancestor[body][:, body] | ancestor[body][:, body].T)
    deeper = np.where(ancestor[body[qq], body[pp]], body[qq], body[pp])
    return KappaTables(
        np.array([k for k, _ in pairs], dtype=np.int64),
        np.asarray(parents, dtype=np.int64),
        np.asarray(directions, dtype=float),
        ptr,
        flat,
        int(n_kappa),
        body,
        np.concatenate([[0], np.cumsum(moves.sum(axis=1))]).astype(np.int64),
        np.nonzero(moves)[1].astype(np.int64),
        inside[moves],
        np.stack([pp, qq, deeper], axis=1).astype(np.int64),
    )


def build_tree(model: mujoco.MjModel) -> Tree:
    """:class:`Tree` of an ``mujoco.MjModel`` with free, ball and hinge joints only.

    Kernels run on trees only: this is where :func:`compile_notice` is given.
    """
    compile_notice()
    m = model
    nv = m.nv
    jnt_type = np.array(m.jnt_type, dtype=np.int64)
    if np.any((jnt_type != FREE) & (jnt_type != BALL) & (jnt_type != HINGE)):
        raise ValueError("only free, ball and hinge joints are supported")
    qadr = np.array(m.jnt_qposadr, dtype=np.int64)
    limited = np.array(m.jnt_limited, dtype=bool)
    rng = np.array(m.jnt_range, dtype=float)
    hinge_lim = limited & (jnt_type == HINGE)
    ball_lim = limited & (jnt_type == BALL)
    dof_jnt = np.array(m.dof_jntid, dtype=np.int64)
    dof_kind = np.zeros(nv, dtype=np.int64)
    dof_col = np.zeros(nv, dtype=np.int64)
    for j, typ in enumerate(jnt_type):
        adr = int(m.jnt_dofadr[j])
        if typ == FREE:
            dof_kind[adr : adr + 6] = (TRANSLATION,) * 3 + (BODY_AXIS,) * 3
            dof_col[adr : adr + 6] = (0, 1, 2, 0, 1, 2)
        elif typ == BALL:
            dof_kind[adr : adr + 3] = BODY_AXIS
            dof_col[adr : adr + 3] = (0, 1, 2)
        else:
            dof_kind[adr] = HINGE_AXIS
    parent = np.array(m.body_parentid, dtype=np.int64)
    site_body = np.array(m.site_bodyid, dtype=np.int64)
    dof_body = np.array(m.dof_bodyid, dtype=np.int64)
    # moves[s, v]: dof v's body is the site's body or one of its ancestors (the world,
    # body 0, carries no dof). Bodies are numbered after their parents (MuJoCo's order).
    chain = np.eye(parent.size, dtype=bool)
    for b in range(1, parent.size):
        chain[b] |= chain[parent[b]]
    chain[:, 0] = False
    moves = chain[site_body][:, dof_body]
    ptr = np.concatenate([[0], np.cumsum(moves.sum(axis=1))]).astype(np.int64)
    return Tree(
        body_parent=parent,
        body_jntadr=np.array(m.body_jntadr, dtype=np.int64),
        body_jntnum=np.array(m.body_jntnum, dtype=np.int64),
        body_pos=np.array(m.body_pos, dtype=float),
        body_quat=np.array(m.body_quat, dtype=float),
        jnt_type=jnt_type,
        jnt_qposadr=qadr,
        jnt_pos=np.array(m.jnt_pos, dtype=float),
        jnt_axis=np.array(m.jnt_axis, dtype=float),
        jnt_ref=np.array(m.qpos0, dtype=float)[qadr],
        jnt_ballmax=np.where(ball_lim, rng[:, 1], np.inf),
        jnt_lo=np.where(hinge_lim, rng[:, 0], -np.inf),
        jnt_hi=np.where(hinge_lim, rng[:, 1], np.inf),
        site_body=site_body,
        site_pos=np.array(m.site_pos, dtype=float),
        site_dofptr=ptr,
        site_dofs=np.nonzero(moves)[1].astype(np.int64),
        dof_jnt=dof_jnt,
        dof_body=dof_body,
        dof_kind=dof_kind,
        dof_col=dof_col,
        dof_parent=np.array(m.dof_parentid, dtype=np.int64),
        **_rolling_tables(m),
    )


def moved(tree: Tree, model: mujoco.MjModel) -> Tree:
    """``tree`` with the body and site positions of ``model`` (what a new theta changes:
    :meth:`~mocap_mj.parameters.ParameterSet.apply`); the rest is kept, so a change of theta
    (every step of the joint LM) costs two copies instead of :func:`build_tree`."""
    return tree._replace(
        body_pos=np.array(model.body_pos, dtype=float),
        site_pos=np.array(model.site_pos, dtype=float),
    )


def _rolling_tables(m: mujoco.MjModel) -> dict[str, np.ndarray]:
    """:class:`Tree`'s rolling fields of the couplings recorded in m (:mod:`mocap_mj.rolling`)."""
    from . import rolling

    adr = np.full(m.nbody, -1, dtype=np.int64)
    coef = np.zeros((m.nbody, 3, 3))
    qmax = np.full(m.nbody, np.inf)
    roll = rolling.read(m)
    if roll is not None:
        adr[roll.bodies] = roll.qposadr
        coef[roll.bodies] = roll.coef * roll.length[:, None, None]
        qmax[roll.bodies] = roll.qmax
    return {"body_rolladr": adr, "body_roll": coef, "body_rollmax": qmax}
