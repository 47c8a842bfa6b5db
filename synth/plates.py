"""A synthetic trial with a force plate whose load is the truth model's own inverse dynamics.

The subject stands on its right foot: every frame, the whole truth body is turned about the
right ankle centre until its centre of mass lies straight above it (a rigid turn of the root,
a few degrees; the joint angles are the motion's), so that the ground reaction it needs has
its centre of pressure under that foot. The plate (type 2: six channels, the force and moment
on the plate about its sensor origin) lies under the right foot and holds, every frame, the
wrench the truth motion needs (the root residual of :func:`~mocap_mj.pipeline.dynamics.
inverse_dynamics` without loads, on the truth model with de Leva's segment parameters for
``mass``, of the motion unfiltered, as a plate measures it). With it as the load the truth's
residual is zero, and ``ik`` with the truth model, which filters the markers and the plate
alike, should find it again.

For the segments' mass fit (the recipe's ``inertia: fit``) the truth's segment masses can be
de Leva's scaled per body (``scale``: body -> factor of its mass, first moment and inertia),
and :func:`slowed` plays a motion several times slower: a range-of-motion trial slowed enough
that its centre of pressure stays under the supporting foot, its poses varied enough that the
plate determines most segments' masses.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Mapping
from pathlib import Path

import ezc3d
import mujoco
import numpy as np

from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.io.atomic import atomic_write_bytes
from mocap_mj.pipeline.dynamics import inverse_dynamics
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.kinematics import Kinematics

from .experiment import Experiment

#: Analog samples per marker frame.
PER_FRAME = 10
#: The plate's sides [m]: along the progression (x) and across (y), narrower than the feet's
#: distance so that the left foot stands beside it.
PLATE_SIZE = (0.50, 0.16)
#: The sensor origin relative to the surface centre, plate axes [m] (below the surface).
ORIGIN = np.array([0.0, 0.0, -0.040])
RIGHT_FOOT = "foot_r"


def _turn_to(v: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking the direction of ``v`` (3,) to +z."""
    u = v / np.linalg.norm(v)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(u, z)
    s, c = float(np.linalg.norm(axis)), float(u @ z)
    if s < 1e-12:
        return np.eye(3)
    k = axis / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * kx + (1 - c) * kx @ kx


def lean_onto_right_foot(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """qpos (T, nq) of ``model`` (as written, with its inertials) with the root turned about
    the right ankle centre (the foot body's origin) so that the centre of mass lies above it."""
    data = mujoco.MjData(model)
    out = np.array(qpos, dtype=float)
    root = int(model.jnt_bodyid[0])
    foot = int(model.body(RIGHT_FOOT).id)
    quat = np.zeros(4)
    for t in range(len(out)):
        data.qpos[:] = out[t]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        ankle = data.xpos[foot].copy()
        turn = _turn_to(data.subtree_com[root] - ankle)
        out[t, :3] = ankle + turn @ (out[t, :3] - ankle)
        mujoco.mju_mat2Quat(quat, turn.ravel())
        mujoco.mju_mulQuat(out[t, 3:7], quat, out[t, 3:7].copy())
    return out


def truth_inertial_model(
    model_path: Path, mass: float, scale: Mapping[str, float] | None = None
) -> mujoco.MjModel:
    """The model file ``model_path`` with de Leva's parameters for ``mass`` [kg], each body of
    ``scale`` with its mass and inertia times its factor (None: de Leva's)."""
    model = inertial_model(model_path, mass)
    for body, factor in (scale or {}).items():
        model.body_mass[model.body(body).id] *= factor
        model.body_inertia[model.body(body).id] *= factor
    return model


def slowed(exp: Experiment, factor: float) -> Experiment:
    """``exp`` played ``factor`` times slower: the same frames and markers at 1 / ``factor``
    of its rate (its velocities divided by ``factor``, its accelerations by its square)."""
    rate = exp.config.rate / factor
    return dataclasses.replace(
        exp,
        times=np.arange(len(exp.times)) / rate,
        config=dataclasses.replace(exp.config, rate=rate),
    )


def leaning(exp: Experiment, mass: float, scale: Mapping[str, float] | None = None) -> Experiment:
    """``exp`` with its truth motion leant onto the right foot (:func:`lean_onto_right_foot`
    on the truth model as written, with de Leva's parameters for ``mass`` [kg], scaled by
    ``scale``: :func:`truth_inertial_model`); the measurement keeps its deviations from the
    clean markers (noise, gaps)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "truth_model.xml"
        exp.pset.export_mjcf(path, exp.theta_true)
        model = truth_inertial_model(path, mass, scale)
    layout = Layout.of(exp.pset.model)
    written = lean_onto_right_foot(model, layout.written(exp.qpos))
    qpos = np.array(exp.qpos, dtype=float)
    qpos[:, :7] = written[:, :7]  # the root: the same columns in both layouts
    kin = Kinematics(exp.pset)
    kin.set_theta(exp.theta_true)
    clean = np.array(kin.forward(qpos).site_xpos)
    measured = clean + (exp.markers - exp.markers_clean)
    return dataclasses.replace(exp, qpos=qpos, markers_clean=clean, markers=measured)


def needed_wrench(
    model_path: Path, exp: Experiment, mass: float, scale: Mapping[str, float] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The ground reaction the truth motion needs per frame: force (T, 3) [N] and moment
    about the world origin (T, 3) [N m] (the root residual without loads on
    :func:`truth_inertial_model`, of the motion as it is: a plate measures the body's
    wrench unfiltered, and the commands filter it with the markers)."""
    model = truth_inertial_model(model_path, mass, scale)
    written = Layout.of(exp.pset.model).written(exp.qpos)
    dyn = inverse_dynamics(model, written, exp.times, cutoff_hz=None)
    force = dyn.root_force
    moment = dyn.root_moment + np.cross(dyn.qpos[:, :3], force)
    return force, moment


def plate_corners(exp: Experiment) -> np.ndarray:
    """(4, 3) [m]: a plate of :data:`PLATE_SIZE` centred under the right foot's markers
    (their mean over the trial), its surface 1 cm below their lowest sample; corners in
    the C3D order (plate x = c1 - c2 along +y of the lab, y = c1 - c4 along +x)."""
    names = exp.pset.marker_names
    feet = [i for i, n in enumerate(names) if n in ("RHEE", "RTOE", "RANK")]
    pts = exp.markers_clean[:, feet]
    cx, cy = pts[..., 0].mean(), pts[..., 1].mean()
    z = float(pts[..., 2].min()) - 0.01
    hx, hy = PLATE_SIZE[0] / 2, PLATE_SIZE[1] / 2
    return np.array(
        [[cx + hx, cy + hy, z], [cx + hx, cy - hy, z], [cx - hx, cy - hy, z],
         [cx - hx, cy + hy, z]]
    )  # fmt: skip


def plate_channels(force: np.ndarray, moment_o: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(T, 6) type-2 channels [N, N mm]: the force on the plate and its moment about the
    sensor origin, plate axes, of the ground reaction force (T, 3) [N] with moment
    ``moment_o`` (T, 3) [N m] about the world origin (lab frame)."""
    centre = corners.mean(axis=0)
    x, y = corners[0] - corners[1], corners[0] - corners[3]
    rot = np.stack([x / np.linalg.norm(x), y / np.linalg.norm(y)], axis=1)
    rot = np.column_stack([rot, np.cross(rot[:, 0], rot[:, 1])])  # plate axes in the lab
    action = -force  # on the plate
    moment_c = -(moment_o - np.cross(centre, force))  # the action's, about the centre
    f_p, m_c = action @ rot, moment_c @ rot
    m_o = m_c + np.cross(ORIGIN, f_p)
    return np.concatenate([f_p, m_o * 1e3], axis=1)


def _int_parameter(c3d: ezc3d.c3d, name: str, values: list[int], shape: list[int]) -> None:
    param = ezc3d.ezc3d.Parameter(name, "")
    param.set(ezc3d.ezc3d.VecInt(values), ezc3d.ezc3d.VecUInt(shape))
    c3d["parameters"].add_parameter("FORCE_PLATFORM", param)


def write_plate_c3d(
    path: Path,
    exp: Experiment,
    model_path: Path,
    mass: float,
    scale: Mapping[str, float] | None = None,
) -> Path:
    """Write ``path``: the measured markers [mm], one type-2 plate under the right foot with
    the wrench the truth motion needs (:func:`needed_wrench`, the truth's masses de Leva's
    scaled by ``scale``), PROCESSING:Bodymass ``mass`` [kg]. Missing samples are written as
    invalid points."""
    force, moment = needed_wrench(model_path, exp, mass, scale)
    corners = plate_corners(exp)
    channels = plate_channels(force, moment, corners)
    rate = exp.config.rate
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = np.array([rate])
    c3d["parameters"]["POINT"]["LABELS"]["value"] = list(exp.pset.marker_names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    markers = np.array(exp.markers, dtype=float)  # (T, M, 3)
    points = np.ones((4, markers.shape[1], len(markers)))
    points[:3] = np.transpose(markers, (2, 1, 0)) * 1e3
    missing = ~np.isfinite(markers).all(axis=2).T
    points[:3, missing] = 0.0
    c3d["data"]["points"] = points
    c3d["data"]["meta_points"]["residuals"] = np.where(missing, -1.0, 0.0)[np.newaxis]
    c3d["parameters"]["ANALOG"]["RATE"]["value"] = np.array([rate * PER_FRAME])
    c3d["parameters"]["ANALOG"]["LABELS"]["value"] = ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]
    c3d["parameters"]["ANALOG"]["UNITS"]["value"] = ["N", "N", "N", "Nmm", "Nmm", "Nmm"]
    c3d["data"]["analogs"] = np.repeat(channels, PER_FRAME, axis=0).T[np.newaxis]
    _int_parameter(c3d, "USED", [1], [1])
    _int_parameter(c3d, "TYPE", [2], [1])
    _int_parameter(c3d, "ZERO", [1, 0], [2])
    c3d.add_parameter("FORCE_PLATFORM", "CORNERS", (corners * 1e3).T.reshape(3, 4, 1))
    c3d.add_parameter("FORCE_PLATFORM", "ORIGIN", (ORIGIN * 1e3).reshape(3, 1))
    _int_parameter(c3d, "CHANNEL", list(range(1, 7)), [6, 1])
    c3d.add_parameter("PROCESSING", "Bodymass", [float(mass)])
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "plates.c3d"
        c3d.write(str(scratch))
        atomic_write_bytes(path, scratch.read_bytes())
    return path
