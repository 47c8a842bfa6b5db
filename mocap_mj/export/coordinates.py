"""OpenSim coordinates of an MJCF model: names, axes, ranges, and their values for a motion.

Every MJCF joint becomes OpenSim coordinates that reproduce its motion exactly:

- a hinge: one rotational coordinate with the joint's name and axis, value = qpos [rad];
- a ball joint: three rotational coordinates ``<joint>_ry``, ``<joint>_rx``, ``<joint>_rz``,
  the intrinsic (body-fixed) Y-X-Z Cardan angles of its quaternion [rad]: flexion about the
  mediolateral y axis first, so that the common large motion is not the middle angle (the
  middle angle has the gimbal singularity, at +-90 degrees);
- the free root: ``<joint>_tx``, ``_ty``, ``_tz`` [m] in the parent (world) frame, then the same
  Y-X-Z angles ``_ry``, ``_rx``, ``_rz`` [rad].

The MJCF bodies of the humanoid carry no rotation in the reference pose, so the axes are the
MJCF ``jnt_axis`` (ball and free joints: the body's y, x, z axes).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import MocapError, check_shape

#: Body-fixed rotation order of ball and free joints: axis letters and unit vectors.
CARDAN_ORDER = "YXZ"
_UNIT = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
#: Range written for the root translations [m] (OpenSim needs one; the root is unbounded).
ROOT_TRANSLATION_RANGE = (-100.0, 100.0)


@dataclass(frozen=True)
class Coordinate:
    """One OpenSim coordinate of an MJCF joint.

    Attributes
    ----------
    name : str
    joint : int
        MJCF joint id.
    rotational : bool
        True: an angle [rad] about ``axis``; False: a translation [m] along ``axis``.
    axis : (3,) tuple of float
        Unit axis in the parent-side joint frame (= the child body frame at zero angle).
    range : (2,) tuple of float [rad or m]
    """

    name: str
    joint: int
    rotational: bool
    axis: tuple[float, float, float]
    range: tuple[float, float]


def _kind(model: mujoco.MjModel, j: int) -> str:
    typ = int(model.jnt_type[j])
    if typ == int(mujoco.mjtJoint.mjJNT_FREE):
        return "free"
    if typ == int(mujoco.mjtJoint.mjJNT_BALL):
        return "ball"
    if typ == int(mujoco.mjtJoint.mjJNT_HINGE):
        return "hinge"
    raise MocapError(f"joint {model.joint(j).name!r}: slide joints cannot be exported")


def model_coordinates(model: mujoco.MjModel) -> tuple[Coordinate, ...]:
    """The coordinates of every joint of ``model``, in joint order (see the module doc)."""
    out: list[Coordinate] = []
    for j in range(model.njnt):
        name, kind = model.joint(j).name, _kind(model, j)
        limited = bool(model.jnt_limited[j])
        lo, hi = (float(v) for v in model.jnt_range[j])
        if kind == "hinge":
            axis = tuple(float(v) for v in model.jnt_axis[j])
            rng = (lo, hi) if limited else (-np.pi, np.pi)
            out.append(Coordinate(name, j, True, axis, rng))  # type: ignore[arg-type]
            continue
        if kind == "free":
            for letter in "XYZ":
                out.append(
                    Coordinate(
                        f"{name}_t{letter.lower()}", j, False, _UNIT[letter], ROOT_TRANSLATION_RANGE
                    )
                )
        # A ball range bounds the total rotation angle; each Cardan angle gets that bound.
        bound = hi if kind == "ball" and limited else np.pi
        for letter in CARDAN_ORDER:
            out.append(
                Coordinate(f"{name}_r{letter.lower()}", j, True, _UNIT[letter], (-bound, bound))
            )
    return tuple(out)


def coordinate_values(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Coordinate values (T, C) [rad, m] of :func:`model_coordinates` for qpos (T, nq).

    Frames with a NaN in a joint's qpos give NaN for that joint's coordinates.
    """
    qpos = np.asarray(qpos, dtype=float)
    check_shape("qpos", qpos, (None, model.nq))
    cols: list[np.ndarray] = []
    for j in range(model.njnt):
        adr, kind = int(model.jnt_qposadr[j]), _kind(model, j)
        if kind == "hinge":
            cols.append(qpos[:, adr : adr + 1])
            continue
        if kind == "free":
            cols.append(qpos[:, adr : adr + 3])
            adr += 3
        cols.append(quat_to_cardan(qpos[:, adr : adr + 4]))
    return np.concatenate(cols, axis=1)


def quat_to_cardan(quat: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions (T, 4) (w, x, y, z) -> intrinsic Y-X-Z angles (T, 3) [rad].

    Rows with a NaN give NaN.
    """
    quat = np.asarray(quat, dtype=float)
    out = np.full((len(quat), 3), np.nan)
    ok = np.all(np.isfinite(quat), axis=1)
    if np.any(ok):
        q = quat[ok]
        rot = Rotation.from_quat(np.column_stack([q[:, 1:], q[:, :1]]))
        out[ok] = rot.as_euler(CARDAN_ORDER)
    return out


def cardan_to_quat(angles: np.ndarray) -> np.ndarray:
    """Inverse of :func:`quat_to_cardan`: angles (T, 3) [rad] -> quaternions (T, 4) (w, x, y, z)."""
    xyzw = Rotation.from_euler(CARDAN_ORDER, np.asarray(angles, dtype=float)).as_quat()
    return np.column_stack([xyzw[:, 3:], xyzw[:, :3]])


def qpos_from_coordinates(model: mujoco.MjModel, values: np.ndarray) -> np.ndarray:
    """Inverse of :func:`coordinate_values`: values (T, C) [rad, m] -> qpos (T, nq)."""
    values = np.asarray(values, dtype=float)
    coords = model_coordinates(model)
    check_shape("values", values, (None, len(coords)))
    qpos = np.zeros((len(values), model.nq))
    c = 0
    for j in range(model.njnt):
        adr, kind = int(model.jnt_qposadr[j]), _kind(model, j)
        if kind == "hinge":
            qpos[:, adr] = values[:, c]
            c += 1
            continue
        if kind == "free":
            qpos[:, adr : adr + 3] = values[:, c : c + 3]
            adr, c = adr + 3, c + 3
        qpos[:, adr : adr + 4] = cardan_to_quat(values[:, c : c + 3])
        c += 3
    return qpos
