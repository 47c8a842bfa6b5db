"""Forward kinematics of the marker sites and their analytic Jacobians, for batches of frames.

Symbols: T frames, M markers (model sites), nq/nv the model's position/velocity sizes,
K kinematic parameters, P = K + 3 M model parameters.

The Jacobian with respect to the joints is taken with respect to the *velocity* coordinates
(nv), as MuJoCo's ``mj_jacSite``: a step ``dv`` (T, nv) is applied with ``mj_integratePos``
(free and ball joints move on their manifold).
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

from mocap_mj.arguments import array, instance, optional, validated
from mocap_mj.errors import MocapError, check_shape
from mocap_mj.kernels import _tree
from mocap_mj.kernels._tree import KappaTables
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton import tree_tables as _tree_tables
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.skeleton.tree_tables import kappa_tables


class Frames(NamedTuple):
    """Kinematic state of T frames, as computed by ``mj_kinematics``.

    Fields
    ------
    site_xpos : (T, M, 3) float [m]   marker-site positions, world frame
    xpos : (T, nbody, 3) float [m]    body origins
    xmat : (T, nbody, 3, 3) float     body orientations (columns: body axes in world)
    xanchor : (T, njnt, 3) float [m]  joint anchors
    xaxis : (T, njnt, 3) float        hinge/slide joint axes, world frame
    xroll : (T, nbody, 3) float [m/rad] a rolling body's origin velocity per rad of its
                                      flexion (:mod:`mocap_mj.skeleton.rolling`; zeros elsewhere)
    """

    site_xpos: np.ndarray
    xpos: np.ndarray
    xmat: np.ndarray
    xanchor: np.ndarray
    xaxis: np.ndarray
    xroll: np.ndarray | None = None


class Kinematics:
    """Marker kinematics of a model whose parameters theta can be changed in place.

    Parameters
    ----------
    pset : ParameterSet, optional
        The parameterisation (the bundled humanoid's by default). The kinematics works on its
        own copy of the model; :meth:`set_theta` writes theta into that copy.
    """

    @validated(pset=optional(instance(ParameterSet, "a ParameterSet or None")))
    def __init__(self, pset: ParameterSet | None = None) -> None:
        self.pset = pset if pset is not None else ParameterSet()
        from copy import copy

        self.model: mujoco.MjModel = copy(self.pset.model)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.nq, self.nv, self.n_markers = m.nq, m.nv, m.nsite
        self.theta = self.pset.nominal.copy()
        self.rolling = rolling.read(self.model)
        self._tree: _tree.Tree | None = None
        self._kappa_tables: KappaTables | None = None
        self._build_tables()

    # ------------------------------------------------------------- structure
    def _build_tables(self) -> None:
        m = self.model
        nv = m.nv
        # Per dof: joint, body, kind (0 translation along a world axis, 1 hinge axis,
        # 2 body-frame axis j of a ball/free rotation) and the axis index j.
        dof_jnt = np.array(m.dof_jntid)
        kind = np.zeros(nv, dtype=int)
        col = np.zeros(nv, dtype=int)
        for j in range(m.njnt):
            adr, typ = m.jnt_dofadr[j], m.jnt_type[j]
            if typ == mujoco.mjtJoint.mjJNT_FREE:
                kind[adr : adr + 3], col[adr : adr + 3] = 0, (0, 1, 2)
                kind[adr + 3 : adr + 6], col[adr + 3 : adr + 6] = 2, (0, 1, 2)
            elif typ == mujoco.mjtJoint.mjJNT_BALL:
                kind[adr : adr + 3], col[adr : adr + 3] = 2, (0, 1, 2)
            elif typ == mujoco.mjtJoint.mjJNT_HINGE:
                kind[adr] = 1
            else:
                raise MocapError("only free, ball and hinge joints are supported")
            body = m.jnt_bodyid[j]
            if typ in (mujoco.mjtJoint.mjJNT_FREE, mujoco.mjtJoint.mjJNT_BALL) and (
                j + 1 < m.njnt and m.jnt_bodyid[j + 1] == body
            ):
                name = m.joint(j).name
                raise MocapError(f"joint {name}: a ball/free joint must be its body's last joint")
        self.dof_jnt = dof_jnt
        self.dof_body = np.array(m.dof_bodyid)
        self.dof_kind = kind
        self.dof_col = col
        self.dof_translation = kind == 0

        # ancestor[b, a]: body a is body b or one of its ancestors.
        ancestor = np.zeros((m.nbody, m.nbody), dtype=bool)
        for b in range(m.nbody):
            a = b
            while True:
                ancestor[b, a] = True
                if a == 0:
                    break
                a = m.body_parentid[a]
        self.ancestor = ancestor
        site_body = np.array(m.site_bodyid)
        # (site, dof) pairs where the dof moves the site.
        dep = ancestor[site_body][:, self.dof_body]  # (M, nv)
        self.dep = dep
        self._dep_mask = dep[:, None, :].astype(float)  # (M, 1, nv)
        self._rot = (~self.dof_translation).astype(float)
        self._trans_cols = np.zeros((3, nv))  # translation dof v moves along axis dof_col[v]
        trans = np.flatnonzero(self.dof_translation)
        self._trans_cols[self.dof_col[trans], trans] = 1.0
        # Kappa: (k, body) pairs, the parent of each body, and the sites in each body's subtree.
        ps = self.pset
        self.kappa_pairs = ps.kappa_targets
        self.kappa_parent = np.array([m.body_parentid[b] for _, b in self.kappa_pairs])
        self.kappa_dir = np.array([ps.direction[k, b] for k, b in self.kappa_pairs])
        self.kappa_sites = [np.flatnonzero(ancestor[site_body, b]) for _, b in self.kappa_pairs]

    # ------------------------------------------------------------- parameters
    def set_theta(self, theta: np.ndarray) -> None:
        """Write theta (P,) [m] into this kinematics' model (body and site positions; the
        compiled tables of :meth:`tree` follow them, other model fields are read once)."""
        self.theta = self.pset.check(theta).copy()
        self.pset.apply(self.model, self.theta)
        if self._tree is not None:  # theta moves bodies and sites only: the rest is kept
            self._tree = _tree_tables.moved(self._tree, self.model)

    def kappa_tables(self) -> KappaTables:
        """The kinematic parameters' (parameter, body) pairs for the compiled LM blocks."""
        if self._kappa_tables is None:
            self._kappa_tables = kappa_tables(
                self.kappa_pairs,
                self.kappa_parent,
                self.kappa_dir,
                self.kappa_sites,
                self.n_markers,
                self.pset.n_kappa,
                self.ancestor,
                self.dof_body,
            )
        return self._kappa_tables

    def tree(self) -> _tree.Tree:
        """Flat tables of the model at the current theta for the compiled kernels."""
        if self._tree is None:
            self._tree = _tree_tables.build_tree(self.model)
        return self._tree

    # --------------------------------------------------------------- forward
    def _check_qpos(self, qpos: np.ndarray) -> np.ndarray:
        try:
            frame = np.ndim(qpos) == 1
        except ValueError:  # a ragged list: refused below
            frame = False
        shape = (self.nq,) if frame else (None, self.nq)
        qpos = array("qpos", qpos, shape, missing=True)  # NaN: a frame not solved
        return qpos[None] if frame else qpos

    def marker_positions(self, qpos: np.ndarray) -> np.ndarray:
        """Marker positions (T, M, 3) [m] for qpos (T, nq) (or (nq,) for one frame)."""
        qpos = self._check_qpos(qpos)
        m = self.model
        out = np.full((len(qpos), m.nsite, 3), np.nan)
        for t, d in rolling.posed(m, qpos, data=self.data, roll=self.rolling):
            out[t] = d.site_xpos
        return out

    def site_positions(self, qpos: np.ndarray) -> np.ndarray:
        """:meth:`marker_positions` of validated qpos (T, nq), by the compiled kernel."""
        return _tree.forward(self.tree(), qpos)

    def forward(self, qpos: np.ndarray) -> Frames:
        """Run ``mj_kinematics`` for each frame of qpos (T, nq) and keep what Jacobians need."""
        return self._kinematics_rows(self._check_qpos(qpos))

    def _kinematics_rows(self, qpos: np.ndarray) -> Frames:
        """:meth:`forward` without the input check: qpos (T, nq), already validated."""
        m = self.model
        n = len(qpos)
        site_xpos = np.full((n, m.nsite, 3), np.nan)
        xpos = np.full((n, m.nbody, 3), np.nan)
        xmat = np.full((n, m.nbody, 9), np.nan)
        xanchor = np.full((n, m.njnt, 3), np.nan)
        xaxis = np.full((n, m.njnt, 3), np.nan)
        for t, d in rolling.posed(m, qpos, data=self.data, roll=self.rolling):
            site_xpos[t] = d.site_xpos
            xpos[t] = d.xpos
            xmat[t] = d.xmat
            xanchor[t] = d.xanchor
            xaxis[t] = d.xaxis
        xmat = xmat.reshape(n, m.nbody, 3, 3)
        xroll = np.zeros((n, m.nbody, 3))
        roll = self.rolling
        if roll is not None:
            _, dt = roll.translation(qpos[:, roll.qposadr])  # (n, k, 3), parent frame
            parents = m.body_parentid[roll.bodies]
            xroll[:, roll.bodies] = np.einsum("tkij,tkj->tki", xmat[:, parents], dt)
        return Frames(site_xpos, xpos, xmat, xanchor, xaxis, xroll)

    # ------------------------------------------------------------- Jacobians
    def dof_axes(self, frames: Frames) -> tuple[np.ndarray, np.ndarray]:
        """World axis (T, nv, 3) and anchor (T, nv, 3) [m] of every dof."""
        # Ball/free rotations: column j of the body's xmat (qvel is a body-frame angular velocity).
        axis = frames.xmat.transpose(0, 1, 3, 2)[:, self.dof_body, self.dof_col]  # (T, nv, 3)
        hinge = self.dof_kind == 1
        axis[:, hinge] = frames.xaxis[:, self.dof_jnt[hinge]]
        trans = self.dof_translation
        axis[:, trans] = np.eye(3)[self.dof_col[trans]]
        anchor = frames.xanchor[:, self.dof_jnt]
        roll = self.rolling
        if roll is not None and frames.xroll is not None:
            # a rolling hinge turns about its instantaneous centre (_tree.dof_axes)
            dofs = self.model.jnt_dofadr[roll.joints]
            anchor[:, dofs] += np.cross(axis[:, dofs], frames.xroll[:, roll.bodies])
        return axis, anchor

    def jac_q(self, frames: Frames) -> np.ndarray:
        """d(marker position)/d(qvel): (T, M, 3, nv) [m/rad or m/m].

        Column v of marker m is ``a_v x (x_m - p_v)`` for a rotational dof with world axis
        ``a_v`` through ``p_v`` (``e_i`` for a translation), zero where the dof does not move
        the marker. It is evaluated as one batched product ``[x_m, 1] @ B`` with
        ``B = [[a_v]_x ; p_v x a_v]`` (4 x 3nv per frame), then masked by the kinematic tree.
        """
        axis, anchor = self.dof_axes(frames)
        n = len(axis)
        axis = axis * self._rot[None, :, None]
        b = np.empty((n, 4, 3, self.nv))
        a0, a1, a2 = axis[..., 0], axis[..., 1], axis[..., 2]
        b[:, 0, 0], b[:, 1, 0], b[:, 2, 0] = 0.0, -a2, a1
        b[:, 0, 1], b[:, 1, 1], b[:, 2, 1] = a2, 0.0, -a0
        b[:, 0, 2], b[:, 1, 2], b[:, 2, 2] = -a1, a0, 0.0
        b[:, 3] = np.cross(anchor, axis).transpose(0, 2, 1) + self._trans_cols
        x = np.concatenate([frames.site_xpos, np.ones((n, self.n_markers, 1))], axis=2)
        jac = np.matmul(x, b.reshape(n, 4, 3 * self.nv)).reshape(n, self.n_markers, 3, self.nv)
        jac *= self._dep_mask
        return jac

    def jac_kappa(self, frames: Frames) -> np.ndarray:
        """d(marker position)/d(kappa): (T, M, 3, K) [m/m]."""
        n = len(frames.site_xpos)
        jac = np.zeros((n, self.n_markers, 3, self.pset.n_kappa))
        # Moving body b's pos by d (parent frame) translates b's whole subtree by R_parent d.
        v = np.einsum("tpij,pj->tpi", frames.xmat[:, self.kappa_parent], self.kappa_dir)
        for p, (k, _) in enumerate(self.kappa_pairs):
            column = jac[..., k]  # (T, M, 3) view
            column[:, self.kappa_sites[p]] += v[:, p, None, :]
        return jac

    def jac_offsets(self, frames: Frames) -> np.ndarray:
        """d(marker position)/d(own offset): (T, M, 3, 3), the rotation of each marker's body."""
        return frames.xmat[:, self.pset.site_body]

    def jac_theta(self, frames: Frames) -> np.ndarray:
        """Dense d(marker position)/d(theta): (T, M, 3, P) [m/m] (for tests and small T)."""
        n = len(frames.site_xpos)
        k, m = self.pset.n_kappa, self.n_markers
        jac = np.zeros((n, m, 3, k + 3 * m))
        jac[..., :k] = self.jac_kappa(frames)
        rot = self.jac_offsets(frames)
        for s in range(m):
            jac[:, s, :, k + 3 * s : k + 3 * s + 3] = rot[:, s]
        return jac

    # ------------------------------------------------------------ integration
    def integrate(self, qpos: np.ndarray, dv: np.ndarray, scale: float = 1.0) -> np.ndarray:
        """qpos (T, nq) advanced by scale * dv (T, nv) on the joint manifold."""
        qpos = self._check_qpos(qpos)
        check_shape("dv", dv, (len(qpos), self.nv))
        out = qpos.copy()
        for t in range(len(out)):
            mujoco.mj_integratePos(self.model, out[t], dv[t], scale)
        return out

    def difference(self, qpos_a: np.ndarray, qpos_b: np.ndarray) -> np.ndarray:
        """dv (T, nv) with integrate(qpos_a, dv) = qpos_b (``mj_differentiatePos``)."""
        qa, qb = self._check_qpos(qpos_a), self._check_qpos(qpos_b)
        out = np.empty((len(qa), self.nv))
        for t in range(len(qa)):
            mujoco.mj_differentiatePos(self.model, out[t], 1.0, qa[t], qb[t])
        return out
