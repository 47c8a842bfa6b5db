"""The compiled tree's tables of a MuJoCo model: :func:`build_tree` (the flat arrays of
:class:`~mocap_mj.kernels._tree.Tree` the kernels take), :func:`moved` (a new theta's positions) and
:func:`kappa_tables` (which sites each kinematic parameter moves, for the joint LM's
parameter columns)."""

from __future__ import annotations

import mujoco
import numpy as np

from mocap_mj.kernels._tree import (
    BALL,
    BODY_AXIS,
    FREE,
    HINGE,
    HINGE_AXIS,
    TRANSLATION,
    KappaTables,
    Tree,
)
from mocap_mj.kernels._tree_ik import compile_notice


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
    :meth:`~mocap_mj.skeleton.parameters.ParameterSet.apply`); the rest is kept, so a change of
    theta (every step of the joint LM) costs two copies instead of :func:`build_tree`."""
    return tree._replace(
        body_pos=np.array(model.body_pos, dtype=float),
        site_pos=np.array(model.site_pos, dtype=float),
    )


def _rolling_tables(m: mujoco.MjModel) -> dict[str, np.ndarray]:
    """:class:`Tree`'s rolling fields of the couplings recorded in m
    (:mod:`mocap_mj.skeleton.rolling`)."""
    from mocap_mj.skeleton import rolling

    adr = np.full(m.nbody, -1, dtype=np.int64)
    coef = np.zeros((m.nbody, 3, 3))
    qmax = np.full(m.nbody, np.inf)
    roll = rolling.read(m)
    if roll is not None:
        adr[roll.bodies] = roll.qposadr
        coef[roll.bodies] = roll.coef * roll.length[:, None, None]
        qmax[roll.bodies] = roll.qmax
    return {"body_rolladr": adr, "body_roll": coef, "body_rollmax": qmax}
