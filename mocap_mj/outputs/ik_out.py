"""The files of ``ik``: motion.csv (readable joint coordinates) and summary.json's figures of
the fit.

motion.csv names one column per degree of freedom of the model as written. Hinges become one
column in degrees, slide joints (the knees' rolling in a model as written,
:mod:`mocap_mj.skeleton.exported`) one in millimetres. Ball joints and the root orientation
become intrinsic X-Y-Z Cardan angles in degrees (``hip_l_x_deg``, ``hip_l_y_deg``,
``hip_l_z_deg``); the root position becomes ``root_x_mm``, ``root_y_mm``, ``root_z_mm``.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.errors import check_shape
from mocap_mj.io.atomic import atomic_write_text


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


def write_motion_csv(
    path: Path, model: mujoco.MjModel, times: np.ndarray, qpos: np.ndarray, first_frame: int = 0
) -> None:
    """motion.csv: frame (the recording's number, from ``first_frame``), time_s (times (T,)
    [s]), then :func:`angle_columns` in mm and degrees, of ``model`` as written (qpos (T, nq)
    of its layout, the knees' slide joints included: :mod:`mocap_mj.skeleton.exported`)."""
    table = joint_angle_table(model, qpos)
    header = ",".join(["frame", "time_s", *angle_columns(model)])
    lines = [header]
    for i, (t, row) in enumerate(zip(times, table, strict=True)):
        cells = ["" if not np.isfinite(v) else f"{v:.6f}" for v in row]
        lines.append(f"{first_frame + i},{t:.6f}," + ",".join(cells))
    atomic_write_text(path, "\n".join(lines) + "\n")


def fit_fields(rmse: float, frame_rmse_max: float) -> dict[str, float]:
    """summary.json's figures of the IK's fit in mm: the marker RMSE ``rmse`` [m] over every
    present sample and the largest frame's RMSE ``frame_rmse_max`` [m]."""
    return {"marker_rmse_mm": rmse * 1e3, "frame_rmse_max_mm": frame_rmse_max * 1e3}
