"""Compiled (numba) per-frame blocks of the joint Levenberg-Marquardt (bundle-adjustment form).

For frame t with marker weights w (M,), joint Jacobian J_q (3M x nv) and model Jacobian J_th
(3M x P) the Gauss-Newton system has the blocks

    A = J_q^T W J_q (nv x nv),  B = J_q^T W J_th (nv x P),  C = J_th^T W J_th (P x P),
    g_q = J_q^T W r,  g_th = J_th^T W r.

Eliminating the frame's joint step leaves ``S = sum_t C - B^T A_d^-1 B`` for the shared
parameters, A_d the damped A. With MuJoCo's tree factorisation ``A_d = L^T D L``
(:func:`mocap_mj.kernels._tree.factor`, no fill-in) ``B^T A_d^-1 B = Y^T Y`` for
``Y = D^-1/2 L^-T B``: the kernels return Y (and ``y_g = D^-1/2 L^-T g_q``) per frame, and
the sum over frames is one matrix product of the stacked Y (BLAS), the only dense step. The
frames' steps follow as ``dq = L^-1 D^-1/2 (y_g - Y dtheta)`` (:func:`back_substitute`).

Model-parameter Jacobians: kinematic parameter k moves body b's origin by ``R_parent(b) d_kb``
per metre (``ParameterSet.direction``), which translates every site in b's subtree; a marker
offset moves its own site by the rotation of its body. So a kinematic parameter's products
with the dofs' columns and with the other parameters' are products with the subtree sums of
the weighted site positions that :func:`mocap_mj.kernels._tree.normal_equations` forms, not sums
over the sites; only the marker offsets' blocks are formed site by site.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from mocap_mj.kernels import _numba_prewarm
from mocap_mj.kernels._jit import _jit, _kernel
from mocap_mj.kernels._tree import (
    HINGE,
    KappaTables,
    Tree,
    _floats,
    blocks,
    factor,
    fk,
    lower_copy,
    normal_equations,
    run_blocks,
    site_column,
    solve,
    work_arrays,
)
from mocap_mj.kernels._tree_ik import blocked_dofs, hold_blocked


@_jit
def _rows_lt_solve(tr, a, y, runs, runptr):
    """y (nv, c) <- L^-T y, rows at once, for a factored by ``factor``, over each row's
    structural non-zeros only: row k's runs of columns ``runs[runptr[k]:runptr[k + 1]]``
    ([first, last + 1) each; within every ancestor's, :func:`gram_groups`) and the last
    column (the gradient's). Entries outside a row's runs are neither read nor written.

    The runs' bounds are taken as unsigned: numba checks a signed index for a negative
    value (Python's wraparound) at every access, which kept the inner loop from
    vectorising (13 against 9 us a frame on the bundled model)."""
    parent = tr.dof_parent
    last = y.shape[1] - 1
    for k in range(a.shape[0] - 1, -1, -1):
        yk = y[k]
        i = parent[k]
        while i >= 0:
            f = a[k, i]
            if f != 0.0:
                yi = y[i]
                for r in range(runptr[k], runptr[k + 1]):
                    for c in range(np.uint64(runs[r, 0]), np.uint64(runs[r, 1])):
                        yi[c] -= f * yk[c]
                yi[last] -= f * yk[last]
            i = parent[i]


@_jit
def _pair_directions(kt, w, vp):
    """vp (pairs, 3): the world direction R_parent d of every (kappa, body) pair."""
    for p in range(kt.pair_k.size):
        m = w.xmat[kt.pair_parent[p]]
        d = kt.pair_dir[p]
        for i in range(3):
            vp[p, i] = m[i, 0] * d[0] + m[i, 1] * d[1] + m[i, 2] * d[2]


@_jit
def _hold_limits(tr, q, w, bmat):
    """Hinges at a joint limit that the gradient ``w.g`` pushes outward are held: their rows
    leave A (``w.h``), B (bmat: a row per dof) and g."""
    h, g = w.h, w.g
    if blocked_dofs(tr, q, g, w.blocked, g):
        hold_blocked(tr, q, w.blocked, h)
        for v in range(h.shape[0]):
            if w.blocked[v] and tr.jnt_type[tr.dof_jnt[v]] == HINGE:
                bmat[v, :] = 0.0
                g[v] = 0.0


@_kernel
def _schur_range(
    tr, kt, target, wts, qpos, free, lo, hi, use_limits, mu, y_out, y_base, y_row, y_colptr,
    y_exact, y_exactptr, y_runs, y_runptr, yg_out, ld_out, gq_out, diag_out, c_acc, gt_acc,
):  # fmt: skip
    nbody, njnt, ns, nv = tr.body_parent.size, tr.jnt_type.size, tr.site_body.size, tr.dof_jnt.size
    w = work_arrays(nbody, njnt, ns, nv, qpos.shape[1])
    kn = kt.n_kappa
    n_par = kn + 3 * ns
    vp = np.zeros((kt.pair_k.size, 3))
    agg, mot, frc = w.agg, w.mot, w.frc  # the subtree sums of normal_equations
    pd_ptr, pd_dofs, pd_inside, pp = kt.pair_dofptr, kt.pair_dofs, kt.pair_inside, kt.pair_pairs
    # B's free columns and g_q, [B_free, g] (nv, Pf + 1), are formed in place in yb (col:
    # each parameter's column there, -1 when frozen), written only at their structural
    # non-zeros (each dof's runs) and cleared there once read, so that no frame clears or
    # copies the whole array (58 KB a frame on the bundled model).
    col = np.full(n_par, -1, dtype=np.int64)
    for c in range(free.size):
        col[free[c]] = c
    yb = np.zeros((nv, free.size + 1))
    for t in range(lo, hi):
        fk(tr, qpos[t], w)
        normal_equations(tr, target[t], wts[t], w)
        _pair_directions(kt, w, vp)
        # the kinematic parameters' blocks from the subtree sums
        for p in range(kt.pair_k.size):
            kk = kt.pair_k[p]
            sb = agg[kt.pair_body[p]]
            v0, v1, v2 = vp[p, 0], vp[p, 1], vp[p, 2]
            gt_acc[kk] += v0 * sb[10] + v1 * sb[11] + v2 * sb[12]
            ck = col[kk]
            if ck < 0:
                continue
            # a dof at or above the pair's body: vp . sum over b's subtree of w e_v
            # = om . (M1_b x vp) + nu . (W_b vp)
            a0, a1, a2 = sb[2] * v2 - sb[3] * v1, sb[3] * v0 - sb[1] * v2, sb[1] * v1 - sb[2] * v0
            b0, b1, b2 = sb[0] * v0, sb[0] * v1, sb[0] * v2
            for e in range(pd_ptr[p], pd_ptr[p + 1]):
                v = pd_dofs[e]
                if pd_inside[e]:  # a dof inside b's subtree: vp . f_v
                    f = frc[v]
                    yb[v, ck] += v0 * f[0] + v1 * f[1] + v2 * f[2]
                else:
                    m = mot[v]
                    yb[v, ck] += (
                        m[0] * a0 + m[1] * a1 + m[2] * a2 + (m[3] * b0 + m[4] * b1 + m[5] * b2)
                    )
        for e in range(pp.shape[0]):
            p, q = pp[e, 0], pp[e, 1]
            c_acc[kt.pair_k[p], kt.pair_k[q]] += agg[pp[e, 2], 0] * (
                vp[p, 0] * vp[q, 0] + vp[p, 1] * vp[q, 1] + vp[p, 2] * vp[q, 2]
            )
        # the marker offsets' blocks, site by site (an offset moves its own site only)
        for s in range(ns):
            ws = wts[t, s]
            if ws <= 0:
                continue
            r0 = target[t, s, 0] - w.site_xpos[s, 0]
            r1 = target[t, s, 1] - w.site_xpos[s, 1]
            r2 = target[t, s, 2] - w.site_xpos[s, 2]
            d_lo, d_hi = tr.site_dofptr[s], tr.site_dofptr[s + 1]
            for k in range(d_hi - d_lo):
                v = tr.site_dofs[d_lo + k]
                w.jcol[k, 0], w.jcol[k, 1], w.jcol[k, 2] = site_column(tr, w, v, s)
            rot = w.xmat[tr.site_body[s]]
            off = kn + 3 * s
            for pi in range(kt.site_pairptr[s], kt.site_pairptr[s + 1]):
                p = kt.site_pairs[pi]
                kk = kt.pair_k[p]
                v0, v1, v2 = ws * vp[p, 0], ws * vp[p, 1], ws * vp[p, 2]
                for j in range(3):
                    # C's (offset, kappa) block is the transpose of this one, mirrored by
                    # the caller (the same sums in the same order)
                    c_acc[kk, off + j] += v0 * rot[0, j] + v1 * rot[1, j] + v2 * rot[2, j]
            for j in range(3):
                e0, e1, e2 = ws * rot[0, j], ws * rot[1, j], ws * rot[2, j]
                ck = col[off + j]
                if ck >= 0:
                    for k in range(d_hi - d_lo):
                        yb[tr.site_dofs[d_lo + k], ck] += (
                            w.jcol[k, 0] * e0 + w.jcol[k, 1] * e1 + w.jcol[k, 2] * e2
                        )
                gt_acc[off + j] += e0 * r0 + e1 * r1 + e2 * r2
                c_acc[off + j, off + j] += ws
        h, g = w.h, w.g
        if use_limits:
            _hold_limits(tr, qpos[t], w, yb)
        a = w.a
        lower_copy(tr, h, a)
        for i in range(nv):
            gq_out[t, i] = g[i]
            diag_out[t, i] = h[i, i]
            a[i, i] += mu * h[i, i] + 1e-12
        factor(tr, a)
        pos = 0
        for i in range(nv):
            ld_out[t, pos] = a[i, i]
            pos += 1
            j = tr.dof_parent[i]
            while j >= 0:
                ld_out[t, pos] = a[i, j]
                pos += 1
                j = tr.dof_parent[j]
            yb[i, free.size] = g[i]
        _rows_lt_solve(tr, a, yb, y_runs, y_runptr)
        for i in range(nv):
            sd = 1.0 / np.sqrt(a[i, i])
            yi = yb[i]
            at = np.uint64(
                y_base[i] + (t * y_row[i, 1] + y_row[i, 0]) * (y_colptr[i + 1] - y_colptr[i])
            )
            for r in range(y_exactptr[i], y_exactptr[i + 1]):  # the row's columns, run by run
                c_lo, c_hi = np.uint64(y_exact[r, 0]), np.uint64(y_exact[r, 1])
                for c in range(c_lo, c_hi):
                    y_out[at + (c - c_lo)] = yi[c] * sd
                at += c_hi - c_lo
            for r in range(y_runptr[i], y_runptr[i + 1]):  # cleared where the solve wrote
                for c in range(np.uint64(y_runs[r, 0]), np.uint64(y_runs[r, 1])):
                    yi[c] = 0.0
            yg_out[t, i] = yi[free.size] * sd


def gram_groups(tr: Tree, kt: KappaTables, free: np.ndarray) -> list[tuple[slice, np.ndarray]]:
    """The structural sparsity of Y (nv x Pf per frame): groups of consecutive dofs whose
    rows of Y can be non-zero in the same free columns, as (dofs, columns (k,) int).

    ``Y[i, p]`` can be non-zero only when dof i moves a site that parameter p moves (B is
    ``J_q^T W J_th``, and ``L^-T`` carries a row only to the dof's ancestors, which move the
    same sites). A hinge's row covers its limb below it, the root's every column: about a
    sixth of the dense product's work on the bundled model. Dofs without a column are left
    out.
    """
    ns, nv = tr.site_body.size, tr.dof_jnt.size
    moves = np.zeros((ns, nv), dtype=bool)  # moves[s, v]: dof v moves site s
    moves[np.repeat(np.arange(ns), np.diff(tr.site_dofptr)), tr.site_dofs] = True
    touches = np.zeros((kt.n_kappa + 3 * ns, ns), dtype=bool)  # parameter moves site
    for site in range(ns):
        pairs = kt.site_pairs[kt.site_pairptr[site] : kt.site_pairptr[site + 1]]
        touches[kt.pair_k[pairs], site] = True
        touches[kt.n_kappa + 3 * site : kt.n_kappa + 3 * site + 3, site] = True
    pattern = (moves.T.astype(np.int64) @ touches[free].T.astype(np.int64)) > 0  # (nv, Pf)
    groups: list[tuple[slice, np.ndarray]] = []
    start = 0
    for v in range(1, nv + 1):
        if v == nv or not np.array_equal(pattern[v], pattern[start]):
            cols = np.flatnonzero(pattern[start])
            if cols.size:
                groups.append((slice(start, v), cols))
            start = v
    return groups


_GROUPS: dict[bytes, list[tuple[slice, np.ndarray]]] = {}


def cached_gram_groups(
    tr: Tree, kt: KappaTables, free: np.ndarray
) -> list[tuple[slice, np.ndarray]]:
    """:func:`gram_groups`, kept per structure (the tree's tables change with theta, their
    structure does not: an identification asks for the same groups at every iteration)."""
    sizes = np.array([tr.dof_jnt.size, kt.n_kappa, free.size], dtype=np.int64)
    parts = (sizes, tr.site_dofptr, tr.site_dofs, kt.site_pairptr, kt.site_pairs, kt.pair_k, free)
    key = b"".join(np.ascontiguousarray(a, dtype=np.int64).tobytes() for a in parts)
    if key not in _GROUPS:
        if len(_GROUPS) > 64:
            _GROUPS.clear()
        _GROUPS[key] = gram_groups(tr, kt, free)
    return _GROUPS[key]


#: Columns between two runs of a row that :func:`_runs` closes over (default 8): the L^-T
#: solve then carries the zeros between them, cheaper than starting another loop (a limb
#: dof's kinematic parameters alternate with the other side's, runs of 1-3 columns).
RUN_GAP = 8


def _runs(cols: np.ndarray, gap: int = RUN_GAP) -> np.ndarray:
    """Sorted column indices cols (k,) int as runs (r, 2) [first, last + 1) that cover them,
    two runs joined where at most ``gap`` columns lie between them (default RUN_GAP; columns
    outside a row's structure are zero in it; 0: runs of consecutive columns only)."""
    if cols.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    breaks = np.flatnonzero(np.diff(cols) > gap + 1) + 1
    first = cols[np.concatenate([[0], breaks])]
    last = cols[np.concatenate([breaks - 1, [cols.size - 1]])] + 1
    return np.stack([first, last], axis=1).astype(np.int64)


class _Layout(NamedTuple):
    """Where :class:`PackedY` keeps each dof's row, per frame of the call (times n frames):
    offsets (groups + 1,) of the group blocks and base (nv,) of each dof's block; row (nv, 2)
    the dof's row in its group and the group's rows; the number of the dof's columns
    ``colptr[i + 1] - colptr[i]``, the same columns as runs of consecutive ones
    ``exact[exactptr[i]:exactptr[i + 1]]`` and as runs ``runs[runptr[i]:runptr[i + 1]]``
    that cover them, gaps of up to ``RUN_GAP`` columns included (a limb's dof has 2-3; each
    [first, last + 1)); square:
    each group's ``np.ix_(c, c)``, made once (an ``np.ix_`` costs about 10 us, 17 groups a
    thread a pass)."""

    offsets: np.ndarray
    base: np.ndarray
    row: np.ndarray
    colptr: np.ndarray
    exact: np.ndarray
    exactptr: np.ndarray
    runs: np.ndarray
    runptr: np.ndarray
    square: tuple[tuple[np.ndarray, ...], ...]


_LAYOUTS: dict[int, tuple[list[tuple[slice, np.ndarray]], _Layout]] = {}


def _layout(groups: list[tuple[slice, np.ndarray]], nv: int) -> _Layout:
    """The :class:`_Layout` of ``groups`` (kept per groups object: :func:`cached_gram_groups`
    returns the same list for the same structure)."""
    hit = _LAYOUTS.get(id(groups))
    if hit is not None and hit[0] is groups:
        return hit[1]
    sizes = [(d.stop - d.start) * c.size for d, c in groups]
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    base = np.zeros(nv, dtype=np.int64)
    row = np.zeros((nv, 2), dtype=np.int64)
    counts = np.zeros(nv, dtype=np.int64)
    cols: list[np.ndarray] = [np.zeros(0, dtype=np.int64)] * nv
    for g, (d, c) in enumerate(groups):
        for i in range(d.start, d.stop):
            base[i] = offsets[g]
            row[i] = (i - d.start, d.stop - d.start)
            counts[i], cols[i] = c.size, c.astype(np.int64)

    def flat(runs: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        ptr = np.concatenate([[0], np.cumsum([len(r) for r in runs])]).astype(np.int64)
        return np.concatenate([*runs, np.zeros((0, 2))]).astype(np.int64), ptr

    lay = _Layout(
        offsets,
        base,
        row,
        np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
        *flat([_runs(c, 0) for c in cols]),
        *flat([_runs(c) for c in cols]),
        tuple(np.ix_(c, c) for _, c in groups),
    )
    if len(_LAYOUTS) > 64:
        _LAYOUTS.clear()
    _LAYOUTS[id(groups)] = (groups, lay)
    return lay


class PackedY:
    """Y (n, nv, Pf) of n frames stored as its structural non-zeros only: group g of
    :func:`gram_groups` (dofs d, columns c) is a C-contiguous (n, |d|, |c|) block of one flat
    buffer, so that its rows over any range of frames are one (k |d|, |c|) matrix for BLAS,
    without the copies that gathering the columns from a dense Y took (and at about 30 % of
    its memory on the bundled model). Dofs in no group have zero rows.
    """

    def __init__(self, n: int, nv: int, pf: int, groups: list[tuple[slice, np.ndarray]]) -> None:
        self.n, self.nv, self.pf, self.groups = n, nv, pf, groups
        lay = _layout(groups, nv)
        offsets = lay.offsets * n
        self.buffer = np.empty(int(offsets[-1]))
        self.blocks = [
            self.buffer[offsets[g] : offsets[g + 1]].reshape(n, d.stop - d.start, c.size)
            for g, (d, c) in enumerate(groups)
        ]
        self.base = lay.base * n
        self.layout = lay

    def kernel_args(self) -> tuple[np.ndarray, ...]:
        """The buffer and its tables, as :func:`_schur_range` takes them."""
        lay = self.layout
        return (self.buffer, self.base, lay.row, lay.colptr, lay.exact, lay.exactptr, lay.runs,
                lay.runptr)  # fmt: skip

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """Y x (n, nv) for x (Pf,)."""
        out = np.zeros((self.n, self.nv))
        for (d, c), blk in zip(self.groups, self.blocks, strict=True):
            out[:, d] = (blk.reshape(-1, c.size) @ x[c]).reshape(self.n, -1)
        return out

    def gram(self, lo: int, hi: int) -> np.ndarray:
        """``sum_t Y_t^T Y_t`` (Pf, Pf) over frames lo..hi, one BLAS product per group."""
        out = np.zeros((self.pf, self.pf))
        for (_, c), blk, square in zip(self.groups, self.blocks, self.layout.square, strict=True):
            g = blk[lo:hi].reshape(-1, c.size)
            out[square] += g.T @ g
        return out

    def rmatvec(self, lo: int, hi: int, u: np.ndarray) -> np.ndarray:
        """``sum_t Y_t^T u_t`` (Pf,) over frames lo..hi, u (n, nv)."""
        out = np.zeros(self.pf)
        for (d, c), blk in zip(self.groups, self.blocks, strict=True):
            out[c] += blk[lo:hi].reshape(-1, c.size).T @ u[lo:hi, d].reshape(-1)
        return out

    def dense(self) -> np.ndarray:
        """Y (n, nv, Pf), zeros outside the groups."""
        y = np.zeros((self.n, self.nv, self.pf))
        for (d, c), blk in zip(self.groups, self.blocks, strict=True):
            y[:, d.start : d.stop][:, :, c] = blk
        return y


def factor_size(tr: Tree) -> int:
    """Entries of one frame's factor as :class:`FrameBlocks` keeps them: per dof in order, its
    diagonal, then its row's entries at its ancestors, nearest first (MuJoCo's factorisation
    has no fill-in, so these are all of L and D)."""
    parent = tr.dof_parent
    size = parent.size
    for k in range(parent.size):
        i = parent[k]
        while i >= 0:
            size += 1
            i = parent[i]
    return int(size)


class FrameBlocks(NamedTuple):
    """Eliminated per-frame blocks of n frames (Pf free parameters).

    Fields
    ------
    y : PackedY, D^-1/2 L^-T B (n, nv, Pf) over the free parameters (its non-zeros)
    y_g : (n, nv) float, D^-1/2 L^-T g_q
    ld : (n, :func:`factor_size`) float, the factors of the damped A (their non-zeros)
    g_q : (n, nv) float, J_q^T W r [m^2 per rad or m]
    diag_a : (n, nv) float, diag(A) (undamped)
    c : (P, P) float, sum over the frames of J_th^T W J_th
    g_theta : (P,) float, sum of J_th^T W r
    yty : (Pf, Pf) float, sum of B^T A_d^-1 B = Y^T Y over the frames
    ytg : (Pf,) float, sum of B^T A_d^-1 g_q = Y^T y_g
    """

    y: PackedY
    y_g: np.ndarray
    ld: np.ndarray
    g_q: np.ndarray
    diag_a: np.ndarray
    c: np.ndarray
    g_theta: np.ndarray
    yty: np.ndarray
    ytg: np.ndarray


def frame_blocks(
    tr: Tree,
    kt: KappaTables,
    target: np.ndarray,
    wts: np.ndarray,
    qpos: np.ndarray,
    free: np.ndarray,
    mu: float,
    *,
    limits: bool = True,
) -> FrameBlocks:
    """Blocks of frames target (n, M, 3) [m], weights wts (n, M), poses qpos (n, nq).

    ``A`` is damped as ``A + mu diag(A) + 1e-12 I``. With ``limits``, hinges at a joint limit
    that the gradient pushes outward are held (their rows leave A, B and g_q). Each thread
    forms its frames' Y^T Y (:meth:`PackedY.gram`, over Y's structural non-zeros) and Y^T y_g
    (BLAS, the only dense step) right after its kernel, so that both cores share the
    products too.
    """
    _numba_prewarm.wait()
    n = len(qpos)
    nv = tr.dof_jnt.size
    n_par = kt.n_kappa + 3 * tr.site_body.size
    free = np.ascontiguousarray(free, dtype=np.int64)
    pf = free.size
    groups = cached_gram_groups(tr, kt, free)
    y = PackedY(n, nv, pf, groups)
    y_g = np.empty((n, nv))
    ld = np.empty((n, factor_size(tr)))
    g_q = np.empty((n, nv))
    diag_a = np.empty((n, nv))
    bounds = blocks(n, n)
    k = bounds.size - 1
    c = np.zeros((k, n_par, n_par))
    g_theta = np.zeros((k, n_par))
    yty = np.zeros((k, pf, pf))
    ytg = np.zeros((k, pf))
    args = (tr, kt, *_floats(target, wts, qpos), free)
    outs = (bool(limits), float(mu), *y.kernel_args(), y_g, ld, g_q, diag_a)

    def block(b: int) -> None:
        lo, hi = bounds[b], bounds[b + 1]
        _schur_range(*args, lo, hi, *outs, c[b], g_theta[b])
        yty[b] = y.gram(lo, hi)
        ytg[b] = y.rmatvec(lo, hi, y_g)

    run_blocks(block, bounds, lambda b: (b,))
    c_sum = c.sum(axis=0)
    kn = kt.n_kappa
    c_sum[kn:, :kn] = c_sum[:kn, kn:].T  # the kernel forms the (kappa, offset) block only
    return FrameBlocks(
        y, y_g, ld, g_q, diag_a, c_sum, g_theta.sum(axis=0), yty.sum(axis=0), ytg.sum(axis=0)
    )


@_kernel
def _gradient_range(tr, kt, target, wts, qpos, lo, hi, use_limits, gt_acc):
    nbody, njnt, ns, nv = tr.body_parent.size, tr.jnt_type.size, tr.site_body.size, tr.dof_jnt.size
    w = work_arrays(nbody, njnt, ns, nv, qpos.shape[1])
    vp = np.zeros((kt.pair_k.size, 3))
    x = np.zeros(nv)
    no_b = np.zeros((nv, 0))
    kn = kt.n_kappa
    for t in range(lo, hi):
        if np.isnan(qpos[t, 0]):
            continue
        fk(tr, qpos[t], w)
        normal_equations(tr, target[t], wts[t], w)
        if use_limits:
            _hold_limits(tr, qpos[t], w, no_b)
        h, g, a = w.h, w.g, w.a
        lower_copy(tr, h, a)
        for i in range(nv):
            x[i] = g[i]
            a[i, i] += 1e-12
        factor(tr, a)
        solve(tr, a, x)
        _pair_directions(kt, w, vp)
        for s in range(ns):
            ws = wts[t, s]
            if ws <= 0:
                continue
            # r - J_q x: the residual left after the frame's own Gauss-Newton pose step
            r0 = target[t, s, 0] - w.site_xpos[s, 0]
            r1 = target[t, s, 1] - w.site_xpos[s, 1]
            r2 = target[t, s, 2] - w.site_xpos[s, 2]
            for k in range(tr.site_dofptr[s], tr.site_dofptr[s + 1]):
                v = tr.site_dofs[k]
                c0, c1, c2 = site_column(tr, w, v, s)
                r0 -= c0 * x[v]
                r1 -= c1 * x[v]
                r2 -= c2 * x[v]
            r0, r1, r2 = ws * r0, ws * r1, ws * r2
            for pi in range(kt.site_pairptr[s], kt.site_pairptr[s + 1]):
                p = kt.site_pairs[pi]
                gt_acc[kt.pair_k[p]] += vp[p, 0] * r0 + vp[p, 1] * r1 + vp[p, 2] * r2
            rot = w.xmat[tr.site_body[s]]
            for j in range(3):
                gt_acc[kn + 3 * s + j] += rot[0, j] * r0 + rot[1, j] * r1 + rot[2, j] * r2


def reduced_gradient(
    tr: Tree,
    kt: KappaTables,
    target: np.ndarray,
    wts: np.ndarray,
    qpos: np.ndarray,
    *,
    limits: bool = True,
) -> np.ndarray:
    """The reduced gradient ``sum_t g_th - B^T A^-1 g_q`` (P,) [m^2 per m] of frames target
    (n, M, 3) [m], weights wts (n, M), at poses qpos (n, nq) (NaN rows skipped).

    The right-hand side of the undamped reduced system (:func:`frame_blocks` with mu = 0)
    without its matrix: ``B^T A^-1 g_q = J_th^T W J_q x`` for the frame's own Gauss-Newton
    pose step ``x = A^-1 g_q``, so the gradient is ``J_th^T W (r - J_q x)``: one solve per
    frame instead of Pf, no B formed and nothing stored per frame, so it can be summed over
    every frame of a long recording. With ``limits``, hinges at a
    joint limit that the gradient pushes outward are held, as in :func:`frame_blocks`.
    """
    n = len(qpos)
    n_par = kt.n_kappa + 3 * tr.site_body.size
    bounds = blocks(n, n)
    k = bounds.size - 1
    gt = np.zeros((k, n_par))
    args = (tr, kt, *_floats(target, wts, qpos))
    run_blocks(
        _gradient_range,
        bounds,
        lambda b: (*args, bounds[b], bounds[b + 1], bool(limits), gt[b]),
    )
    return gt.sum(axis=0)


@_kernel
def _back_range(tr, ld, u, out):
    parent = tr.dof_parent
    for t in range(ld.shape[0]):
        a = ld[t]
        x = out[t]
        pos = 0
        for k in range(u.shape[1]):
            x[k] = u[t, k] / np.sqrt(a[pos])
            pos += 1
            i = parent[k]
            while i >= 0:
                x[k] -= a[pos] * x[i]
                pos += 1
                i = parent[i]


def back_substitute(tr: Tree, blocks: FrameBlocks, dtheta: np.ndarray) -> np.ndarray:
    """The frames' joint steps dq (n, nv) for the free-parameter step dtheta (Pf,)."""
    _numba_prewarm.wait()
    u = blocks.y_g - blocks.y.matvec(dtheta)
    out = np.empty_like(u)
    _back_range(tr, blocks.ld, u, out)
    return out
