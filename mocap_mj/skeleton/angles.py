"""Readable joint coordinates: qpos as named columns in millimetres and degrees.

Hinges become one column in degrees, slide joints (the knees' rolling in a model as written,
:mod:`mocap_mj.skeleton.exported`) one in millimetres. Ball joints and the root orientation become
intrinsic X-Y-Z Cardan angles in degrees (``hip_l_x``, ``hip_l_y``, ``hip_l_z``); the root position
becomes ``root_x``, ``root_y``, ``root_z`` in millimetres.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.errors import check_shape


def angle_columns(model: mujoco.MjModel) -> list[str]:
    """Column names of :func:`joint_angle_table` for ``model``."""
    names: list[str] = []
    for j in range(model.njnt):
        name, typ = model.joint(j).name, int(model.jnt_type[j])
        if typ == int(mujoco.mjtJoint.mjJNT_FREE):
            names += [f"{name}_x_mm", f"{name}_y_mm", f"{name}_z_mm"]
            names += [f"{name}_rx_deg", f"{name}_ry_deg", f"{name}_rz_deg"]
        elif typ == int(mujoco.mjtJoint.mjJNT_BALL):
            names += [f"{name}_x_deg", f"{name}_y_deg", f"{name}_z_deg"]
        elif typ == int(mujoco.mjtJoint.mjJNT_SLIDE):
            names.append(f"{name}_mm")
        else:
            names.append(f"{name}_deg")
    return names


def joint_angle_table(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """qpos (T, nq) [m, quaternion, rad] -> (T, nv) table in mm and degrees (see module doc)."""
    qpos = np.asarray(qpos, dtype=float)
    check_shape("qpos", qpos, (None, model.nq))
    cols = []
    for j in range(model.njnt):
        adr, typ = int(model.jnt_qposadr[j]), int(model.jnt_type[j])
        if typ == int(mujoco.mjtJoint.mjJNT_FREE):
            cols.append(qpos[:, adr : adr + 3] * 1e3)
            adr += 3
        if typ in (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)):
            quat = qpos[:, adr : adr + 4]
            ok = np.all(np.isfinite(quat), axis=1)
            euler = np.full((len(qpos), 3), np.nan)
            if np.any(ok):
                wxyz = quat[ok]
                rot = Rotation.from_quat(np.column_stack([wxyz[:, 1:], wxyz[:, :1]]))
                euler[ok] = rot.as_euler("XYZ", degrees=True)
            cols.append(euler)
        elif typ == int(mujoco.mjtJoint.mjJNT_SLIDE):
            cols.append(qpos[:, adr : adr + 1] * 1e3)
        else:
            cols.append(np.degrees(qpos[:, adr : adr + 1]))
    return np.concatenate(cols, axis=1)
