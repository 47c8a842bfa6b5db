"""Joint-centre trajectories as a CSV table (``joint_centres.csv`` of ``ik`` and ``identify``).

Layout (one row per frame, comma-separated, header in the first line):

``frame``
    Frame index in the marker file (0-based; with ``identify --frames A:B`` the first row is
    frame A).
``time``
    Time [s].
``<centre>_x_mm``, ``<centre>_y_mm``, ``<centre>_z_mm``
    World position [mm] of each joint centre of :data:`mocap_mj.joint_centres.JOINT_CENTRES`
    (``lumbosacral``, ..., ``knee_l``, ..., ``wrist_r``), in that order: the origin of the
    joint's child body, in the frame of the marker data. Empty cells for frames that were not
    solved.

Millimetres (not the metres used inside) because the marker files are in millimetres and the
table is meant to be read beside them.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from .errors import check_shape
from .io.atomic import atomic_write_text
from .joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories


def joint_centre_columns() -> list[str]:
    """Header of ``joint_centres.csv``: ``frame``, ``time``, then 3 columns per centre."""
    return ["frame", "time", *(f"{c}_{a}_mm" for c in JOINT_CENTRE_NAMES for a in "xyz")]


def write_joint_centres_csv(
    path: str | Path,
    model: mujoco.MjModel,
    times: np.ndarray,
    qpos: np.ndarray,
    *,
    first_frame: int = 0,
) -> np.ndarray:
    """Write the joint centres of ``model`` (carrying the subject's parameters) for qpos
    (T, nq) at times (T,) [s] as CSV (layout in the module docstring; the first row is frame
    ``first_frame`` of the marker file); return them (T, J, 3) [m], NaN for unsolved frames."""
    rows, centres = joint_centre_rows(model, times, qpos, first_frame=first_frame)
    atomic_write_text(path, "\n".join([",".join(joint_centre_columns()), *rows]) + "\n")
    return centres


def joint_centre_rows(
    model: mujoco.MjModel, times: np.ndarray, qpos: np.ndarray, *, first_frame: int = 0
) -> tuple[list[str], np.ndarray]:
    """The CSV rows (no header) of :func:`write_joint_centres_csv` for qpos (T, nq) at times
    (T,) [s], the first of them frame ``first_frame``, and the centres (T, J, 3) [m]: one
    formatting for the whole table and for a table written chunk by chunk."""
    times = np.asarray(times, dtype=float)
    check_shape("times", times, (len(qpos),))
    centres = joint_centre_trajectories(model, qpos)
    flat = centres.reshape(len(centres), -1) * 1e3
    # One %-format per row (a row without NaN: every solved frame) is ten times faster than a
    # format per cell, with the same text ("%.4f" and f"{:.4f}" agree).
    whole = "%d,%.6f," + ",".join(["%.4f"] * flat.shape[1])
    finite = np.all(np.isfinite(flat), axis=1)
    lines = []
    for i, (t, row) in enumerate(zip(times.tolist(), flat.tolist(), strict=True)):
        if finite[i]:
            lines.append(whole % (first_frame + i, t, *row))
        else:
            cells = ("" if not np.isfinite(v) else f"{v:.4f}" for v in row)
            lines.append(f"{first_frame + i},{t:.6f}," + ",".join(cells))
    return lines, centres
