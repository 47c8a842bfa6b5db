"""The knee's rolling: a translation of the shank origin in the thigh frame coupled to flexion.

The tibia rolls and slides on the femoral condyles, so the knee is not a fixed hinge: the
standard musculoskeletal models move the tibia's origin in the femur frame as a function of
the knee angle (Yamaguchi & Zajac 1989; Delp et al. 1990, OpenSim's gait2392 and Rajagopal
et al. 2016 ``knee_r`` CustomJoint: ``translation1`` (anterior) and ``translation2``
(superior) are splines of ``knee_angle_r``). Here the same coupling is a cubic in the flexion
angle q [rad], in the parent (thigh) frame, zero at full extension, per unit of a reference
length L [m] (the thigh length it is scaled to, as OpenSim scaling scales the femur)::

    t(q) = L (c1 q + c2 q^2 + c3 q^3)            for q <= q_max,
    t(q) = t(q_max) + t'(q_max) (q - q_max)       beyond (continued at its slope).

The coupling is fixed, not identified: over a trial it is indistinguishable from the hinge's
position (a hinge fitted to a deep knee flexion lands where the rolling centre sits on
average), so it is taken from the literature and scaled once, before the solve; the kinematic
parameters' Jacobian then stays ``R_parent d`` (docs/model.md, "The knee's rolling").

A model records it as MJCF ``<custom><numeric>`` entries ``mocap_mj_roll:BODY:JOINT`` with
data ``(L, q_max, c1x, c1y, c1z, c2x, c2y, c2z, c3x, c3y, c3z)``; a model without them has
fixed hinges (model files written before the coupling existed read as before). A model file
the tool writes also carries each coupling as two slide joints for plain MuJoCo
(:mod:`mocap_mj.skeleton.exported`); compiled as it is, such a model's couplings are its joints and
:func:`read` skips them. The joint must be the body's first joint and a hinge whose axis (in
the parent frame) is normal to every coefficient vector, so that the coupling is a planar
motion about an instantaneous centre (:func:`mocap_mj.kernels._tree.dof_axes`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from xml.etree import ElementTree

import mujoco
import numpy as np

from mocap_mj.errors import MocapError

#: Prefix of the ``<custom><numeric>`` entries that record a coupling.
RECORD_PREFIX = "mocap_mj_roll"

#: Suffixes of the slide joints that carry a coupling in a model as written (``JOINT_t1``,
#: ``JOINT_t2``; :mod:`mocap_mj.skeleton.exported`).
SLIDE_SUFFIXES = ("_t1", "_t2")

#: gait2392's femur length at full extension [m]: minus its ``knee_r`` ``translation2`` spline
#: at knee_angle 0, the length its translations are relative to (the unit of the coefficients).
GAIT2392_FEMUR_LENGTH = 0.3958


@dataclass(frozen=True)
class Rolling:
    """The couplings of a model (n of them, one per coupled body).

    Attributes
    ----------
    bodies, joints, qposadr : (n,) int
        The coupled body, its flexion joint (the body's first joint) and that joint's qpos
        address.
    length : (n,) float [m]
        The reference length L each coupling is scaled to.
    qmax : (n,) float [rad]
        The angle beyond which the translation continues at its slope.
    coef : (n, 3, 3) float [1/rad^k]
        Row k-1: the coefficient vector of q^k per unit length, parent frame.
    """

    bodies: np.ndarray
    joints: np.ndarray
    qposadr: np.ndarray
    length: np.ndarray
    qmax: np.ndarray
    coef: np.ndarray

    def translation(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """t (T, n, 3) [m] and dt/dq (T, n, 3) [m/rad] of the flexion angles q (T, n) [rad]."""
        q = np.asarray(q, dtype=float)
        u = np.minimum(q, self.qmax)
        c = self.coef * self.length[:, None, None]  # (n, 3, 3) [m/rad^k]
        powers = np.stack([u, u**2, u**3], axis=-1)  # (T, n, 3)
        slopes = np.stack([np.ones_like(u), 2 * u, 3 * u**2], axis=-1)
        t = np.einsum("tnk,nki->tni", powers, c)
        d = np.einsum("tnk,nki->tni", slopes, c)
        return t + d * (q - u)[..., None], d

    def scaled(self, lengths: np.ndarray) -> Rolling:
        """The same couplings scaled to the reference lengths (n,) [m]."""
        return Rolling(
            self.bodies, self.joints, self.qposadr, np.asarray(lengths, float), self.qmax, self.coef
        )

    def body_pos(self, base: np.ndarray, qpos: np.ndarray) -> np.ndarray:
        """Body positions (T, nbody, 3) [m]: base (nbody, 3) with the coupled bodies moved by
        t(q) for each pose of qpos (T, nq)."""
        qpos = np.atleast_2d(qpos)
        out = np.repeat(np.asarray(base, float)[None], len(qpos), axis=0)
        t, _ = self.translation(qpos[:, self.qposadr])
        out[:, self.bodies] += t
        return out


def _name(model: mujoco.MjModel, obj: str, i: int) -> str:
    return str(getattr(model, obj)(i).name)


def read(model: mujoco.MjModel) -> Rolling | None:
    """The couplings recorded in ``model`` (see the module docstring), or None without any.

    Raises MocapError naming the entry when an entry's body or joint does not exist, the joint
    is not the body's first joint or not a hinge, the data is not 11 numbers, or a
    coefficient vector is not normal to the hinge axis.
    """
    rows = []
    for i in range(model.nnumeric):
        name = _name(model, "numeric", i)
        if not name.startswith(f"{RECORD_PREFIX}:"):
            continue
        parts = name.split(":")
        data = np.asarray(model.numeric(i).data, dtype=float)
        if len(parts) != 3 or data.size != 11 or not np.all(np.isfinite(data)):
            raise MocapError(
                f"model numeric {name}: expected {RECORD_PREFIX}:BODY:JOINT with 11 numbers "
                "(L, q_max, 3 coefficient vectors)"
            )
        try:
            body, joint = model.body(parts[1]).id, model.joint(parts[2]).id
        except KeyError:
            raise MocapError(
                f"model numeric {name}: no body {parts[1]} or joint {parts[2]}"
            ) from None
        first = model.body_jntadr[body]
        if joint == first + 2 and np.all(
            model.jnt_type[first:joint] == mujoco.mjtJoint.mjJNT_SLIDE
        ):
            continue  # carried by two slide joints: a model as written (mocap_mj.skeleton.exported)
        if first != joint or model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE:
            raise MocapError(f"model numeric {name}: {parts[2]} is not {parts[1]}'s first hinge")
        coef = data[2:].reshape(3, 3)
        q = model.body_quat[body]
        axis = np.zeros(3)
        mujoco.mju_rotVecQuat(axis, model.jnt_axis[joint], q)
        if np.any(np.abs(coef @ axis) > 1e-9 * (1 + np.abs(coef).max())):
            raise MocapError(f"model numeric {name}: the translation is not normal to the axis")
        rows.append((body, joint, int(model.jnt_qposadr[joint]), data[0], data[1], coef))
    if not rows:
        return None
    cols = list(zip(*rows, strict=True))
    return Rolling(
        np.array(cols[0], dtype=np.int64),
        np.array(cols[1], dtype=np.int64),
        np.array(cols[2], dtype=np.int64),
        np.array(cols[3], dtype=float),
        np.array(cols[4], dtype=float),
        np.array(cols[5], dtype=float),
    )


def set_lengths(model: mujoco.MjModel, lengths: dict[str, float]) -> None:
    """Write the reference length L [m] of the couplings of the bodies named in ``lengths``
    into ``model`` in place (its numeric data)."""
    for i in range(model.nnumeric):
        name = _name(model, "numeric", i)
        if name.startswith(f"{RECORD_PREFIX}:") and name.split(":")[1] in lengths:
            model.numeric_data[model.numeric_adr[i]] = float(lengths[name.split(":")[1]])


def record(xml: str, model: mujoco.MjModel) -> str:
    """MJCF text ``xml`` with the numeric data of ``model``'s couplings (its scaled lengths)
    written over the entries of the same name, at full precision."""
    root = ElementTree.fromstring(xml)
    values = {}
    for i in range(model.nnumeric):
        name = _name(model, "numeric", i)
        if name.startswith(f"{RECORD_PREFIX}:"):
            values[name] = np.asarray(model.numeric(i).data, dtype=float)
    for elem in root.iter("numeric"):
        data = values.get(elem.get("name", ""))
        if data is not None:
            elem.set("data", " ".join(repr(float(v)) for v in data))
    ElementTree.indent(root, space="  ")
    return ElementTree.tostring(root, encoding="unicode") + "\n"


def slide_names(joint: str) -> tuple[str, str]:
    """The names of the two slide joints that carry ``joint``'s coupling in a model as
    written (:mod:`mocap_mj.skeleton.exported`)."""
    return (f"{joint}{SLIDE_SUFFIXES[0]}", f"{joint}{SLIDE_SUFFIXES[1]}")


def without(xml: str) -> str:
    """MJCF text ``xml`` without its couplings' entries (and, in a model as written, their
    slide joints and equalities): the same model with fixed hinges (e.g. for a solver that
    knows only MuJoCo's joints, as ``benchmarks/ik.py``'s mink)."""
    root = ElementTree.fromstring(xml)
    slides: set[str] = set()
    for custom in root.iter("custom"):
        for elem in list(custom):
            if elem.tag == "numeric" and elem.get("name", "").startswith(f"{RECORD_PREFIX}:"):
                slides.update(slide_names(elem.get("name", "").split(":")[-1]))
                custom.remove(elem)
    for parent in root.iter():
        for elem in list(parent):
            if elem.tag == "joint" and {elem.get("name"), elem.get("joint1")} & slides:
                parent.remove(elem)
    return ElementTree.tostring(root, encoding="unicode") + "\n"


_READ = object()


def kinematics(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    step: Callable[[mujoco.MjModel, mujoco.MjData], None] = mujoco.mj_kinematics,
    roll: Rolling | object | None = _READ,
) -> None:
    """``step(model, data)`` (``mj_kinematics`` by default, or ``mj_forward``) with the
    coupled bodies placed for ``data.qpos``: their ``body_pos`` is moved by t(q) for the call
    and restored after it, so MuJoCo's frames, sites and geoms show the rolling. Every
    MuJoCo forward pass on a model that may carry a coupling goes through here. ``roll``:
    the model's couplings if the caller has read them already (:func:`read`, once per model
    rather than once per frame)."""
    if roll is _READ:
        roll = read(model)
    if not isinstance(roll, Rolling):
        step(model, data)
        return
    base = np.array(model.body_pos[roll.bodies])
    t, _ = roll.translation(np.asarray(data.qpos)[roll.qposadr][None])
    model.body_pos[roll.bodies] = base + t[0]
    try:
        step(model, data)
    finally:
        model.body_pos[roll.bodies] = base


def posed(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    *,
    data: mujoco.MjData | None = None,
    roll: Rolling | object | None = _READ,
) -> Iterator[tuple[int, mujoco.MjData]]:
    """(frame index, data after ``mj_kinematics``) for each frame of qpos (T, nq) without NaN,
    the coupled bodies placed as :func:`kinematics` places them, with the couplings read once
    and every frame's translation computed at once (a long trial's hundreds of thousands of
    frames cost MuJoCo's pass each, little more). The same ``MjData`` (``data``, or a new one)
    is reused: read what you need before the next frame; ``model.body_pos`` is restored when
    the iteration ends. ``roll``: the model's couplings if the caller has read them already."""
    q = np.asarray(qpos, dtype=float)
    data = mujoco.MjData(model) if data is None else data
    frames = np.flatnonzero(np.all(np.isfinite(q), axis=1)).tolist()
    if roll is _READ:
        roll = read(model)
    if not isinstance(roll, Rolling):
        for t in frames:
            data.qpos[:] = q[t]
            mujoco.mj_kinematics(model, data)
            yield t, data
        return
    base = np.array(model.body_pos[roll.bodies])
    shift, _ = roll.translation(q[:, roll.qposadr])
    try:
        for t in frames:
            data.qpos[:] = q[t]
            model.body_pos[roll.bodies] = base + shift[t]
            mujoco.mj_kinematics(model, data)
            yield t, data
    finally:
        model.body_pos[roll.bodies] = base


__all__ = [
    "GAIT2392_FEMUR_LENGTH",
    "RECORD_PREFIX",
    "SLIDE_SUFFIXES",
    "Rolling",
    "kinematics",
    "posed",
    "read",
    "record",
    "set_lengths",
    "slide_names",
    "without",
]
