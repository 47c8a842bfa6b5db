"""Joint-centre trajectories as a CSV table (``joint_centres.csv`` of ``ik`` and ``identify``).

Layout (one row per frame, comma-separated, header in the first line):

``frame``
    The recording's own frame number (the C3D header's, a TRC's or CSV's frame column; with
    ``--frames A:B`` the first row is the file's row A; from 0 for data that numbers none).
``time_s``
    Time [s] in the recording (frame f of a C3D at (f - 1) / rate).
``<centre>_x_mm``, ``<centre>_y_mm``, ``<centre>_z_mm``
    World position [mm] of each joint centre of
    :data:`mocap_mj.skeleton.joint_centres.JOINT_CENTRES`
    (``lumbosacral``, ..., ``knee_l``, ..., ``wrist_r``), in that order: the origin of the
    joint's child body, in the frame of the marker data. Empty cells for frames that were not
    solved.

Millimetres (:data:`UNIT`, not the metres used inside) because the marker files are in
millimetres and the table is meant to be read beside them: the columns are named and scaled
from it (:func:`mocap_mj.io.units.unit_column`, :func:`~mocap_mj.io.units.per_metre`).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from mocap_mj.errors import check_shape
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.units import per_metre, unit_column
from mocap_mj.kernels._fixed_text import csv_rows
from mocap_mj.skeleton.joint_centres import JOINT_CENTRE_NAMES, joint_centre_trajectories

#: The length unit of the table's positions.
UNIT = "mm"


def joint_centre_columns() -> list[str]:
    """Header of ``joint_centres.csv``: ``frame``, ``time_s``, then 3 columns per centre."""
    centres = (unit_column(f"{c}_{a}", UNIT) for c in JOINT_CENTRE_NAMES for a in "xyz")
    return ["frame", "time_s", *centres]


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
    text, centres = joint_centre_text(model, times, qpos, first_frame=first_frame)
    header = ",".join(joint_centre_columns()) + "\n"
    atomic_write_text(path, header + text.decode())
    return centres


#: The cells' ``%`` formats: frame, time [s], then the centres [mm].
_FORMATS = ("%d", "%.6f", *(["%.4f"] * (3 * len(JOINT_CENTRE_NAMES))))


def joint_centre_text(
    model: mujoco.MjModel, times: np.ndarray, qpos: np.ndarray, *, first_frame: int = 0
) -> tuple[bytes, np.ndarray]:
    """The CSV rows (no header; UTF-8, each ending in a newline) of
    :func:`write_joint_centres_csv` for qpos (T, nq) at times (T,) [s], the first of them
    frame ``first_frame``, and the centres (T, J, 3) [m]: one formatting for the whole table
    and for a table written chunk by chunk. The cells are ``%d``, ``%.6f`` and ``%.4f``'s
    text (empty for unsolved frames), formatted by a compiled kernel
    (:func:`mocap_mj.kernels._fixed_text.csv_rows`: an hour's rows are millions of cells)."""
    times = np.asarray(times, dtype=float)
    check_shape("times", times, (len(qpos),))
    centres = joint_centre_trajectories(model, qpos)
    flat = centres.reshape(len(centres), -1) * per_metre(UNIT)
    frames = first_frame + np.arange(len(times), dtype=np.int64)
    values = np.concatenate([times[:, None], flat], axis=1)
    decimals = [6, *([4] * flat.shape[1])]
    return csv_rows(frames[:, None], values, decimals, _FORMATS), centres
