"""The per-frame IK solver on the compiled joint tree (:mod:`mocap_mj.kernels._tree`) and its entry
points for many frames.

- :func:`blocked_dofs` / :func:`hold_blocked`: the joint limits (hinge box, ball cone) as an
  active set, shared with the joint LM's blocks (:mod:`mocap_mj.kernels._schur`);
- :func:`solve_frame`: one frame's damped Levenberg-Marquardt (adaptive or Sugihara's
  damping) from its start pose;
- :func:`solve_batch`, :func:`solve_chains`, :func:`walk`: independent frames, chains of
  consecutive frames warm-started by constant velocity, and re-solves walked from a seed, all
  through the one entry kernel :func:`_ik_range`, the items spread over threads in contiguous
  blocks (:func:`mocap_mj.kernels._tree.run_blocks`; each frame's arithmetic is sequential, so
  results
  do not depend on the thread count).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

from mocap_mj.kernels._jit import _jit, _kernel
from mocap_mj.kernels._tree import (
    ADAPTIVE,
    BALL,
    CONVERGED,
    HINGE,
    MAX_ITERATIONS,
    PARALLEL_MIN,
    TOO_FEW_MARKERS,
    Tree,
    _copy,
    _count_present,
    _floats,
    blocks,
    cost,
    difference,
    factor,
    fk,
    integrate,
    lower_copy,
    normal_equations,
    project,
    run_blocks,
    solve,
    work_arrays,
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


#: Every frame's fit as :func:`solve_chains` returns it: qpos (T, nq) [m, quaternion, rad],
#: rmse (T,) [m], iterations (T,) and status (T,).
Fits = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def walk(
    tr: Tree,
    target: np.ndarray,
    wts: np.ndarray,
    out: Fits,
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
    overlap. target (T, M, 3) [m], wts (T, M); ``out`` = (qpos, rmse, iters, status)
    (:data:`Fits`), updated in place; settings as :func:`solve_batch`.
    """
    qpos, rmse, iters, status = out
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


# ------------------------------------------------------------------ first-run notice
#: What the first run of an install spends compiling the kernels on an idle 2-core machine
#: (``benchmarks/cold_start.py``: the first demo's wall time less the second's, 26 s against
#: 9 s), said once when the on-disk cache is empty; scaled by :func:`compile_estimate` when
#: other work already keeps the cores busy.
COMPILE_SECONDS = 17
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
    on-disk cache (:mod:`mocap_mj.kernels._kernel_cache`) does not hold them yet."""
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
