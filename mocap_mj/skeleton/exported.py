"""The model as written for MuJoCo: the knee's rolling as MuJoCo joints, and qpos in both layouts.

The solvers work on the internal model (the bundled humanoid's 48 degrees of freedom), where a
coupled body's origin is moved by t(q) of its flexion angle through ``body_pos``
(:mod:`mocap_mj.skeleton.rolling`). Plain MuJoCo does not know that record, so a model file the tool
writes carries the coupling in MuJoCo's own terms, as the MuJoCo ports of OpenSim models do
(MyoSuite, MyoConverter):

* two slide joints ``JOINT_t1`` and ``JOINT_t2`` before each coupled hinge ``JOINT``, the
  body's first joints, moving its origin along two orthonormal directions normal to the
  hinge axis (parent frame; t1 is the parent's x projected on that plane, t2 = t1 x axis: for
  the bundled knees, anterior and superior in the thigh frame, gait2392's ``translation1``
  and ``translation2``);
* an ``<equality><joint joint1="JOINT_tk" joint2="JOINT" polycoef="0 c1 c2 c3 c4"/>`` for
  each slide: a quartic in the hinge angle, zero at full extension, fitted by least squares
  to the coupling over the hinge's range (the cubic, and its linear continuation beyond
  q_max), so that ``mj_step`` keeps the coupling;
* the ``<custom>`` record of :mod:`mocap_mj.skeleton.rolling` stays: it is the exact coupling, which
  the tool reads back (:func:`internal_spec` removes the slides and their equalities).

The written qpos (``motion.npz``, ``motion.csv``) holds the slides' exact values e_k . t(q)
in every frame, so plain ``mj_kinematics`` puts every body where the tool does.
:class:`Layout` maps one qpos layout onto the other; every writer and reader of qpos uses it.
A model file without the slides (written before they existed, or the bundled humanoid) is the
internal model itself, and a motion of its width is internal qpos.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

import mujoco
import numpy as np

from mocap_mj.errors import InputFileError
from mocap_mj.skeleton import rolling

#: Suffixes of the slide joints that carry a coupling (joint names ``JOINT_t1``, ``JOINT_t2``).
SLIDE_SUFFIXES = rolling.SLIDE_SUFFIXES
slide_names = rolling.slide_names

#: Grid of the least-squares fit of each slide's quartic over the hinge's range.
FIT_POINTS = 2001

#: The equalities' ``solref`` (time constant [s], damping ratio) and ``solimp``: stiffer than
#: MuJoCo's defaults (0.02 s; 0.9-0.95), under which the slides lagged their hinge by up to
#: 26 mm when a swinging knee hit its limit (the legs under gravity from a pelvis held still,
#: 1 s); with these the lag stays below 0.3 mm. 0.004 s is twice the default 2 ms timestep
#: (MuJoCo raises a time constant below that to it).
SOLREF = (0.004, 1.0)
SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)


def coupled_joints(model: mujoco.MjModel) -> list[tuple[str, str]]:
    """(body, hinge) names of the couplings recorded in ``model``'s ``<custom>`` entries."""
    out = []
    for i in range(model.nnumeric):
        parts = str(model.numeric(i).name).split(":")
        if parts[0] == rolling.RECORD_PREFIX and len(parts) == 3:
            out.append((parts[1], parts[2]))
    return out


def carried(model: mujoco.MjModel) -> bool:
    """Whether ``model`` carries its couplings as slide joints (compiled from a written file)."""
    names = {model.joint(j).name for j in range(model.njnt)}
    return any(slide_names(j)[0] in names for _, j in coupled_joints(model))


def _quat_rotate(quat: np.ndarray, v: np.ndarray) -> np.ndarray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(v, float), np.asarray(quat, float))
    return out


def slide_basis(model: mujoco.MjModel, roll: rolling.Rolling) -> np.ndarray:
    """The slides' unit directions (n, 2, 3), parent frame: t1 = the parent's x projected on
    the plane normal to the hinge axis (its z where x is along the axis), t2 = t1 x axis."""
    out = np.zeros((len(roll.bodies), 2, 3))
    for i, (b, j) in enumerate(zip(roll.bodies, roll.joints, strict=True)):
        axis = _quat_rotate(model.body_quat[b], model.jnt_axis[j])
        axis /= np.linalg.norm(axis)
        e1 = np.eye(3)[0] - axis[0] * axis
        if np.linalg.norm(e1) < 1e-6:
            e1 = np.eye(3)[2] - axis[2] * axis
        e1 /= np.linalg.norm(e1)
        out[i] = e1, np.cross(e1, axis)
    return out


@dataclass(frozen=True)
class Layout:
    """The internal qpos (nq) and the written qpos (nq + 2 n, the slides of n couplings before
    their hinges) of one model.

    Attributes
    ----------
    nq : int
        Internal qpos size.
    columns : (nq,) int
        The written column of each internal coordinate.
    slides : (n, 2) int
        The written columns of each coupling's two slides.
    basis : (n, 2, 3) float
        The slides' unit directions, parent frame (:func:`slide_basis`).
    roll : Rolling or None
        The couplings (None: both layouts are the same).
    """

    nq: int
    columns: np.ndarray
    slides: np.ndarray
    basis: np.ndarray
    roll: rolling.Rolling | None

    @classmethod
    def of(cls, model: mujoco.MjModel) -> Layout:
        """The layouts of the internal model ``model`` (its couplings as :func:`rolling.read`
        reads them, with their scaled lengths)."""
        roll = rolling.read(model)
        if roll is None:
            empty = np.zeros((0, 2), dtype=np.int64)
            return cls(model.nq, np.arange(model.nq), empty, np.zeros((0, 2, 3)), None)
        before = np.searchsorted(np.sort(roll.qposadr), np.arange(model.nq), side="right")
        columns = np.arange(model.nq) + 2 * before
        start = columns[roll.qposadr] - 2  # the slides sit just before their hinge
        slides = np.stack([start, start + 1], axis=1)
        return cls(model.nq, columns, slides, slide_basis(model, roll), roll)

    @property
    def nq_written(self) -> int:
        """Written qpos size: nq plus two slides per coupling."""
        return self.nq + 2 * len(self.slides)

    def written(self, qpos: np.ndarray) -> np.ndarray:
        """Written qpos (T, nq_written) of internal qpos (T, nq): the slides hold each
        coupling's translation along their directions, e_k . t(q) [m] (NaN with the hinge)."""
        q = np.asarray(qpos, dtype=float)
        out = np.empty((*q.shape[:-1], self.nq_written))
        out[..., self.columns] = q
        if self.roll is not None:
            flat = q.reshape(-1, self.nq)
            t, _ = self.roll.translation(flat[:, self.roll.qposadr])  # (T, n, 3)
            s = np.einsum("tni,nki->tnk", t, self.basis)
            out[..., self.slides] = s.reshape(*q.shape[:-1], *self.slides.shape)
        return out

    def internal(self, qpos: np.ndarray) -> np.ndarray:
        """Internal qpos (T, nq) of written qpos (T, nq_written): the slides dropped."""
        return np.asarray(qpos, dtype=float)[..., self.columns]

    def read(self, qpos: np.ndarray, source: str) -> np.ndarray:
        """Internal qpos (T, nq) of a motion file's qpos (T, C): C = nq_written (written by
        this version) or nq (a file written before the slides existed, or of a model without
        couplings); anything else raises InputFileError naming ``source``."""
        q = np.asarray(qpos, dtype=float)
        if q.ndim == 2 and q.shape[1] == self.nq_written:
            return self.internal(q)
        if q.ndim == 2 and q.shape[1] == self.nq:
            return q
        expected = f"nq = {self.nq}"
        if self.roll is not None:
            expected = f"nq = {self.nq_written} (with the knees' slide joints) or {self.nq}"
        raise InputFileError(
            f"{source}: qpos has {q.shape[-1] if q.ndim else 0} columns, the model has {expected}"
        )


def polycoef(layout: Layout, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Quartic coefficients (n, 2, 5) [m/rad^k], constant term 0, of each slide's value as a
    function of its hinge's angle: least squares on :data:`FIT_POINTS` angles over each
    hinge's range [lo, hi] (n,) [rad]."""
    roll = layout.roll
    assert roll is not None
    out = np.zeros((len(roll.bodies), 2, 5))
    for i in range(len(roll.bodies)):
        q = np.linspace(lo[i], hi[i], FIT_POINTS)
        grid = np.zeros((FIT_POINTS, len(roll.bodies)))
        grid[:, i] = q
        t, _ = roll.translation(grid)
        values = t[:, i] @ layout.basis[i].T  # (FIT_POINTS, 2)
        powers = np.stack([q, q**2, q**3, q**4], axis=1)
        coef, *_ = np.linalg.lstsq(powers, values, rcond=None)
        out[i, :, 1:] = coef.T
    return out


def _fmt(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in values)


def with_slides(xml: str, model: mujoco.MjModel, joint_range: np.ndarray | None = None) -> str:
    """MJCF text ``xml`` of the internal model ``model`` (same bodies and joints; ``xml``
    holding the coupling record) with each coupling written as two slide joints and their
    equalities (module docstring). The quartics are fitted over the hinges' ranges in
    ``joint_range`` (njnt, 2) [rad] (default: ``model.jnt_range``)."""
    layout = Layout.of(model)
    roll = layout.roll
    if roll is None:
        return xml
    rng = np.asarray(model.jnt_range if joint_range is None else joint_range, dtype=float)
    coef = polycoef(layout, rng[roll.joints, 0], rng[roll.joints, 1])
    root = ElementTree.fromstring(xml)
    bodies = {elem.get("name"): elem for elem in root.iter("body")}
    equality = root.find("equality")
    if equality is None:
        equality = ElementTree.SubElement(root, "equality")
    for i, (b, j) in enumerate(zip(roll.bodies, roll.joints, strict=True)):
        body, joint = bodies[model.body(b).name], model.joint(j).name
        first = next(k for k, child in enumerate(body) if child.tag == "joint")
        conj = np.array(model.body_quat[b]) * (1, -1, -1, -1)
        for k, name in enumerate(slide_names(joint)):
            axis = _quat_rotate(conj, layout.basis[i, k])  # parent frame -> body frame
            slide = ElementTree.Element(
                "joint", name=name, type="slide", axis=_fmt(axis), limited="false"
            )
            body.insert(first + k, slide)
            ElementTree.SubElement(
                equality,
                "joint",
                name=name,
                joint1=name,
                joint2=joint,
                polycoef=_fmt(coef[i, k]),
                solref=_fmt(np.array(SOLREF)),
                solimp=_fmt(np.array(SOLIMP)),
            )
    ElementTree.indent(root, space="  ")
    return ElementTree.tostring(root, encoding="unicode") + "\n"


def equality_residuals(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Residuals (neq_joint,) [m] of ``model``'s joint equalities at qpos (nq,) of its own
    layout: q1 - poly(q2), both relative to ``qpos0``, as MuJoCo's constraint measures them."""
    q = np.asarray(qpos, dtype=float)
    out = []
    for e in range(model.neq):
        if model.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT:
            continue
        a = [model.jnt_qposadr[model.eq_obj1id[e]], model.jnt_qposadr[model.eq_obj2id[e]]]
        y, x = q[a] - model.qpos0[a]
        out.append(y - np.polynomial.polynomial.polyval(x, model.eq_data[e, :5]))
    return np.array(out)


def stepped_residual(
    model: mujoco.MjModel, qpos: np.ndarray, seconds: float = 1.0
) -> tuple[float, np.ndarray]:
    """The largest joint-equality residual [m] over ``seconds`` of ``mj_step`` from qpos
    (nq,) at rest, and the final qpos (nq,): the coupling kept under simulation."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    worst = float(np.max(np.abs(equality_residuals(model, data.qpos)), initial=0.0))
    while data.time < seconds:
        mujoco.mj_step(model, data)
        worst = max(worst, float(np.max(np.abs(equality_residuals(model, data.qpos)))))
    return worst, np.array(data.qpos)


def held_root(path: str | Path) -> mujoco.MjModel:
    """The model file ``path`` compiled as plain MuJoCo does, with its free root removed: the
    root body held in the world (its qpos is the file's without the root's 7 coordinates)."""
    spec = mujoco.MjSpec.from_file(str(path))
    for joint in list(spec.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            spec.delete(joint)
    return spec.compile()


def internal_spec(path: str | Path) -> mujoco.MjSpec:
    """``MjSpec`` of the MJCF file ``path`` as the tool models it: the slide joints that carry
    a recorded coupling (and their equalities) removed, the record kept; a file without them
    as it is."""
    spec = mujoco.MjSpec.from_file(str(path))
    hinges = [
        n.name.split(":")[2]
        for n in spec.numerics
        if n.name.startswith(f"{rolling.RECORD_PREFIX}:") and n.name.count(":") == 2
    ]
    slides = {s for h in hinges for s in slide_names(h)}
    for eq in list(spec.equalities):
        if eq.type == mujoco.mjtEq.mjEQ_JOINT and eq.name1 in slides:
            spec.delete(eq)
    for joint in list(spec.joints):
        if joint.name in slides:
            spec.delete(joint)
    return spec


__all__ = [
    "FIT_POINTS",
    "SLIDE_SUFFIXES",
    "SOLIMP",
    "SOLREF",
    "Layout",
    "carried",
    "coupled_joints",
    "equality_residuals",
    "held_root",
    "internal_spec",
    "polycoef",
    "slide_basis",
    "slide_names",
    "stepped_residual",
    "with_slides",
]
