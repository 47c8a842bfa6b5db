"""OpenSim model (``.osim``, format 4.x) of an MJCF model, written as XML (no OpenSim needed).

Bodies keep their MJCF names, frames and origins (x anterior, y left, z up in the reference
pose). Every MJCF body with joints hangs from its parent by one ``CustomJoint`` named after the
child body, whose coordinates are those of :mod:`mocap_mj.export.coordinates` (hinges about
their MJCF axes, ball and free joints as body-fixed Y-X-Z rotations), so the same coordinate
values give the same pose in both programs. Markers are the MJCF sites on their bodies.

The root joint hangs from a ground frame that turns the MJCF world (z up) into OpenSim's ground:
``up="y"`` (OpenSim's convention, the default) rotates it by -90 degrees about x (MJCF x -> x,
y -> -z, z -> y); ``up="z"`` keeps the MJCF world. Marker files for this model must use the
same up axis (:func:`mocap_mj.export.trc.write_trc`). The MJCF capsules and spheres are drawn
as OpenSim cylinders and spheres.

A knee that rolls (:mod:`mocap_mj.skeleton.rolling`) gets its translation functions of the flexion
coordinate, as gait2392's knee: the joint's ``translation1..3`` (parent-frame x, y, z) are
``SimmSpline`` functions sampled from the model's t(q) every :data:`ROLLING_STEP` over the
coordinate's range and :data:`ROLLING_MARGIN` beyond each end (within 2 micrometres of it).

Masses and inertias are ``inertia``'s when given (:func:`mocap_mj.anatomy.inertia.segment_inertia`:
de Leva's, the parameters the tool's inverse dynamics uses, which ``export`` passes when the
subject's mass is known), else the MJCF's (from its display geoms at 1000 kg/m^3) multiplied by
``mass / total`` when the subject's ``mass`` [kg] is given, so that the bodies sum to it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.anatomy.inertia import BodyInertia
from mocap_mj.skeleton import rolling

from ..errors import MocapError
from ..io.atomic import atomic_write_text
from .coordinates import Coordinate, model_coordinates

#: OpenSim document version written (4.6).
OSIM_VERSION = "40600"
#: Ground-frame orientations (body-fixed X-Y-Z angles [rad]) per up axis.
UP_ORIENTATION = {"y": (-np.pi / 2, 0.0, 0.0), "z": (0.0, 0.0, 0.0)}
_GRAVITY = 9.80665
#: Knot spacing and the extent past the coordinate's range of the rolling splines [rad].
ROLLING_STEP = np.radians(2.5)
ROLLING_MARGIN = np.radians(30.0)


def up_rotation(up: str) -> np.ndarray:
    """(3, 3) rotation taking MJCF world coordinates to the ground frame of ``up``."""
    check_up(up)
    a = UP_ORIENTATION[up][0]
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def check_up(up: str) -> None:
    if up not in UP_ORIENTATION:
        raise MocapError(f"up axis {up!r}: expected one of {', '.join(UP_ORIENTATION)}")


def _vec(values: Iterable[float]) -> str:
    return " ".join(repr(float(v)) for v in values)


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrs: str) -> ET.Element:
    elem = ET.SubElement(parent, tag, attrs)
    if text is not None:
        elem.text = text
    return elem


def _offset_frame(
    parent: ET.Element,
    name: str,
    socket: str,
    translation: Iterable[float],
    orientation: Iterable[float] = (0.0, 0.0, 0.0),
) -> None:
    frame = _sub(parent, "PhysicalOffsetFrame", name=name)
    _sub(frame, "socket_parent", socket)
    _sub(frame, "translation", _vec(translation))
    _sub(frame, "orientation", _vec(orientation))


def _orthogonal_axes(used: list[tuple[float, float, float]]) -> list[np.ndarray]:
    """Unit axes completing ``used`` (rotation axes of one joint) to three independent ones."""
    axes = [np.asarray(a, dtype=float) for a in used]
    for candidate in np.eye(3):
        if len(axes) == 3:
            break
        trial = np.array([*axes, candidate])
        if np.linalg.matrix_rank(trial) == len(trial):
            axes.append(candidate)
    return axes[len(used) :]


#: A translation as a function of a coordinate: (coordinate name, knots (n,) [rad],
#: values (n,) [m]).
Spline = tuple[str, np.ndarray, np.ndarray]


def _transform_axis(
    parent: ET.Element,
    name: str,
    coordinate: str | None,
    axis: Iterable[float],
    spline: Spline | None = None,
) -> None:
    ta = _sub(parent, "TransformAxis", name=name)
    _sub(ta, "coordinates", spline[0] if spline else coordinate or "")
    _sub(ta, "axis", _vec(axis))
    if spline:
        fn = _sub(ta, "SimmSpline", name="function")
        _sub(fn, "x", _vec(spline[1]))
        _sub(fn, "y", _vec(spline[2]))
    elif coordinate:
        fn = _sub(ta, "LinearFunction", name="function")
        _sub(fn, "coefficients", "1 0")
    else:
        fn = _sub(ta, "Constant", name="function")
        _sub(fn, "value", "0")


@dataclass(frozen=True)
class _ParentFrame:
    """Where a joint sits in its parent: the parent's ``name`` and ``socket`` (its path), the
    joint's ``translation`` (3,) [m] and ``orientation`` (3,) [rad] (body-fixed X-Y-Z
    angles) in the parent's frame."""

    name: str
    socket: str
    translation: np.ndarray
    orientation: Iterable[float]


def _custom_joint(
    parent: ET.Element,
    name: str,
    child: str,
    at: _ParentFrame,
    coords: list[Coordinate],
    rolling_splines: list[Spline] | None = None,
) -> None:
    joint = _sub(parent, "CustomJoint", name=name)
    _sub(joint, "socket_parent_frame", f"{at.name}_offset")
    _sub(joint, "socket_child_frame", f"{child}_offset")
    cset = _sub(joint, "coordinates")
    for c in coords:
        ce = _sub(cset, "Coordinate", name=c.name)
        _sub(ce, "default_value", "0")
        _sub(ce, "default_speed_value", "0")
        _sub(ce, "range", _vec(c.range))
        _sub(ce, "clamped", "false")
        _sub(ce, "locked", "false")
    frames = _sub(joint, "frames")
    _offset_frame(frames, f"{at.name}_offset", at.socket, at.translation, at.orientation)
    _offset_frame(frames, f"{child}_offset", f"/bodyset/{child}", (0.0, 0.0, 0.0))
    rot = [c for c in coords if c.rotational]
    trans = [c for c in coords if not c.rotational]
    if len(rot) > 3 or len(trans) > 3:
        raise MocapError(f"body {child!r}: more than three rotations or translations")
    st = _sub(joint, "SpatialTransform")
    rot_axes: list[tuple[str | None, Iterable[float]]] = [(c.name, c.axis) for c in rot]
    rot_axes += [(None, a) for a in _orthogonal_axes([c.axis for c in rot])]
    for i, (cname, axis) in enumerate(rot_axes):
        _transform_axis(st, f"rotation{i + 1}", cname, axis)
    by_axis = {tuple(float(v) for v in c.axis): c.name for c in trans}
    if rolling_splines and trans:
        raise MocapError(f"body {child!r}: a rolling joint with translational coordinates")
    for i, unit in enumerate(np.eye(3)):
        spline = rolling_splines[i] if rolling_splines else None
        _transform_axis(st, f"translation{i + 1}", by_axis.get(tuple(unit.tolist())), unit, spline)


def _rolling_splines(
    model: mujoco.MjModel, coords: Sequence[Coordinate]
) -> dict[int, list[Spline]]:
    """Per rolling body: its parent-frame x, y, z translations as splines of the flexion
    coordinate (:mod:`mocap_mj.skeleton.rolling`), sampled over the coordinate's range and a
    margin."""
    roll = rolling.read(model)
    if roll is None:
        return {}
    out = {}
    for i, (b, j) in enumerate(zip(roll.bodies, roll.joints, strict=True)):
        c = next(c for c in coords if c.joint == j)
        lo, hi = c.range[0] - ROLLING_MARGIN, c.range[1] + ROLLING_MARGIN
        x = np.linspace(lo, hi, int(np.ceil((hi - lo) / ROLLING_STEP)) + 1)
        q = np.zeros((x.size, roll.bodies.size))
        q[:, i] = x
        t, _ = roll.translation(q)
        out[int(b)] = [(c.name, x, t[:, i, k]) for k in range(3)]
    return out


def _inertia(
    model: mujoco.MjModel, b: int, scale: float, given: BodyInertia | None = None
) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass [kg], centre of mass (3,) [m], inertia (6,) [kg m^2] Ixx Iyy Izz Ixy Ixz Iyz):
    ``given``'s for the body when it has it, else the model's times ``scale``."""
    name = model.body(b).name
    if given is not None and name in given.bodies:
        i = given.bodies.index(name)
        full = np.asarray(given.inertia[i], dtype=float)
        six = np.array([full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]])
        return float(given.mass[i]), np.asarray(given.com[i], dtype=float), six
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.body_iquat[b])
    r = rot.reshape(3, 3)
    full = r @ np.diag(model.body_inertia[b]) @ r.T * scale
    six = np.array([full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]])
    return float(model.body_mass[b] * scale), np.array(model.body_ipos[b], dtype=float), six


def _geometry(body: ET.Element, model: mujoco.MjModel, b: int) -> None:
    """Display geometry: each MJCF capsule or cylinder as an OpenSim ``Cylinder`` (its axis
    is the frame's y, MJCF's is z), each sphere as a ``Sphere``, on an offset frame of the body.
    The hemispherical caps of capsules are not drawn."""
    frames: list[tuple[str, ET.Element]] = []
    for g in range(int(model.body_geomadr[b]), int(model.body_geomadr[b] + model.body_geomnum[b])):
        typ = int(model.geom_type[g])
        size = model.geom_size[g]
        if typ in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
            shape = ET.Element("Cylinder")
            _sub(shape, "radius", repr(float(size[0])))
            _sub(shape, "half_height", repr(float(size[1])))
        elif typ == int(mujoco.mjtGeom.mjGEOM_SPHERE):
            shape = ET.Element("Sphere")
            _sub(shape, "radius", repr(float(size[0])))
        else:
            continue
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        # OpenSim's cylinder axis is y: turn the frame so that its y is the geom's z.
        r = rot.reshape(3, 3) @ np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
        name = model.geom(g).name or f"{model.body(b).name}_geom{g}"
        frame = ET.Element("PhysicalOffsetFrame", name=f"{name}_frame")
        _sub(frame, "socket_parent", "..")
        _sub(frame, "translation", _vec(model.geom_pos[g]))
        _sub(frame, "orientation", _vec(_body_fixed_xyz(r)))
        shape.set("name", name)
        _sub(shape, "socket_frame", "..")
        colour = _sub(shape, "Appearance", name="appearance")
        _sub(colour, "color", _vec(model.geom_rgba[g][:3]))
        attached = _sub(frame, "attached_geometry")
        attached.append(shape)
        frames.append((name, frame))
    if frames:
        components = _sub(body, "components")
        for _, frame in frames:
            components.append(frame)


def _body_fixed_xyz(r: np.ndarray) -> np.ndarray:
    """Body-fixed X-Y-Z angles (3,) [rad] of a rotation matrix (3, 3), OpenSim's orientation."""
    return Rotation.from_matrix(r).as_euler("XYZ")


def _check_frames(model: mujoco.MjModel) -> None:
    """Refuses a model whose body frames are rotated or whose joints sit away from their
    body's origin (the export assumes neither)."""
    for b in range(1, model.nbody):
        if np.any(np.abs(model.body_quat[b] - np.array([1.0, 0, 0, 0])) > 1e-12):
            raise MocapError(
                f"body {model.body(b).name!r}: rotated body frames are not supported "
                "(the exported joints assume frames aligned in the reference pose)"
            )
        if int(model.body_jntnum[b]) and np.any(
            np.abs(
                model.jnt_pos[model.body_jntadr[b] : model.body_jntadr[b] + model.body_jntnum[b]]
            )
            > 1e-12
        ):
            raise MocapError(f"body {model.body(b).name!r}: joints away from the body origin")


def osim_xml(
    model: mujoco.MjModel,
    *,
    name: str = "mocap_mj_subject",
    up: str = "y",
    mass: float | None = None,
    inertia: BodyInertia | None = None,
) -> str:
    """The ``.osim`` text of ``model`` (see the module doc); ``inertia`` gives the bodies'
    inertial parameters, else ``mass`` [kg] scales the model's."""
    check_up(up)
    if not name or any(ch in name for ch in "\\*+ \t\n/"):
        raise MocapError(f"model name {name!r}: OpenSim names cannot contain spaces, \\ * + or /")
    _check_frames(model)
    total = float(np.sum(model.body_mass[1:]))
    if mass is not None and not (mass > 0 and np.isfinite(mass)):
        raise MocapError(f"subject mass {mass}: expected a positive number of kilograms")
    scale = 1.0 if mass is None or total <= 0 else mass / total
    coords = model_coordinates(model)
    splines = _rolling_splines(model, coords)
    by_joint: dict[int, list[Coordinate]] = {}
    for c in coords:
        by_joint.setdefault(c.joint, []).append(c)

    doc = ET.Element("OpenSimDocument", Version=OSIM_VERSION)
    root = _sub(doc, "Model", name=name)
    _sub(root, "credits", "mocap-mj export of an MJCF model")
    _sub(root, "length_units", "meters")
    _sub(root, "force_units", "N")
    gravity = up_rotation(up) @ np.array([0.0, 0.0, -_GRAVITY])
    _sub(root, "gravity", _vec(np.where(np.abs(gravity) < 1e-12, 0.0, gravity)))
    _sub(root, "Ground", name="ground")
    bodies = _sub(_sub(root, "BodySet", name="bodyset"), "objects")
    joints = _sub(_sub(root, "JointSet", name="jointset"), "objects")
    for b in range(1, model.nbody):
        bname = model.body(b).name
        m, com, six = _inertia(model, b, scale, inertia)
        body = _sub(bodies, "Body", name=bname)
        _sub(body, "mass", repr(m))
        _sub(body, "mass_center", _vec(com))
        _sub(body, "inertia", _vec(six))
        _geometry(body, model, b)
        parent = int(model.body_parentid[b])
        jids = range(int(model.body_jntadr[b]), int(model.body_jntadr[b] + model.body_jntnum[b]))
        jcoords = [c for j in jids for c in by_joint.get(j, [])]
        if parent == 0:
            psock, pname, orient = "/ground", "ground", UP_ORIENTATION[up]
        else:
            pname = model.body(parent).name
            psock, orient = f"/bodyset/{pname}", (0.0, 0.0, 0.0)
        # A free joint's qpos is the world position: its body_pos is not an offset.
        free = any(not c.rotational for c in jcoords)
        pos = np.zeros(3) if free else model.body_pos[b]
        if jcoords:
            at = _ParentFrame(pname, psock, pos, orient)
            _custom_joint(joints, bname, bname, at, jcoords, splines.get(b))
        else:
            joint = _sub(joints, "WeldJoint", name=bname)
            _sub(joint, "socket_parent_frame", f"{pname}_offset")
            _sub(joint, "socket_child_frame", f"{bname}_offset")
            frames = _sub(joint, "frames")
            _offset_frame(frames, f"{pname}_offset", psock, pos, orient)
            _offset_frame(frames, f"{bname}_offset", f"/bodyset/{bname}", (0.0, 0.0, 0.0))
    markers = _sub(_sub(root, "MarkerSet", name="markerset"), "objects")
    for s in range(model.nsite):
        marker = _sub(markers, "Marker", name=model.site(s).name)
        _sub(marker, "socket_parent_frame", f"/bodyset/{model.body(model.site_bodyid[s]).name}")
        _sub(marker, "location", _vec(model.site_pos[s]))
        _sub(marker, "fixed", "false")
    ET.indent(doc, space="  ")
    return '<?xml version="1.0" encoding="UTF-8" ?>\n' + ET.tostring(doc, encoding="unicode") + "\n"


def write_osim(
    path: str | Path,
    model: mujoco.MjModel,
    *,
    name: str = "mocap_mj_subject",
    up: str = "y",
    mass: float | None = None,
    inertia: BodyInertia | None = None,
) -> None:
    """Write :func:`osim_xml` to ``path`` atomically."""
    atomic_write_text(path, osim_xml(model, name=name, up=up, mass=mass, inertia=inertia))
