"""CSV tables: clinical angles (Plug-in Gait's table), per-marker residuals, and segment
scale factors.

All files are comma-separated with one header row; ``frame`` is the recording's own frame
number and ``time_s`` its time [s]; empty cells are missing values (a marker not measured, a
frame not solved). The angle table is Plug-in Gait's (``frame,time_s``, then
``LPelvisAngles_X``...).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from mocap_mj.export.read_result import posed_frames
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.joint_centres import JOINT_CENTRES

from ..errors import check_shape
from ..io.atomic import atomic_write_text
from .clinical import angles_table_text

#: Segments of the scale table: (segment, proximal joint centre, distal joint centre). The
#: length is the distance between the two centres in the reference pose, which is what
#: OpenSim's Scale tool compares between marker pairs (a scale factor per segment).
SEGMENTS: tuple[tuple[str, str, str], ...] = (
    ("pelvis_width", "hip_l", "hip_r"),
    ("lumbar", "lumbosacral", "thoracolumbar"),
    ("thorax", "thoracolumbar", "cervicothoracic"),
    ("thigh_l", "hip_l", "knee_l"),
    ("shank_l", "knee_l", "ankle_l"),
    ("foot_l", "ankle_l", "mtp_l"),
    ("thigh_r", "hip_r", "knee_r"),
    ("shank_r", "knee_r", "ankle_r"),
    ("foot_r", "ankle_r", "mtp_r"),
    ("clavicle_l", "sternoclavicular_l", "shoulder_l"),
    ("upperarm_l", "shoulder_l", "elbow_l"),
    ("forearm_l", "elbow_l", "wrist_l"),
    ("clavicle_r", "sternoclavicular_r", "shoulder_r"),
    ("upperarm_r", "shoulder_r", "elbow_r"),
    ("forearm_r", "elbow_r", "wrist_r"),
)


def _cell(value: float, fmt: str) -> str:
    return format(value, fmt) if np.isfinite(value) else ""


def table_text(
    header: Sequence[str], times: np.ndarray, values: np.ndarray, fmt: str, first_frame: int = 0
) -> str:
    """CSV text: ``frame,time_s,<header>`` then one row per frame of values (T, C); frame i is
    numbered ``first_frame + i``."""
    values = np.asarray(values, dtype=float)
    check_shape("values", values, (len(times), len(header)))
    lines = [",".join(["frame", "time_s", *header])]
    for i, (t, row) in enumerate(zip(times, values, strict=True)):
        lines.append(f"{first_frame + i},{t:.6f}," + ",".join(_cell(v, fmt) for v in row))
    return "\n".join(lines) + "\n"


def write_angles_csv(
    path: str | Path,
    model: mujoco.MjModel,
    times: np.ndarray,
    qpos: np.ndarray,
    first_frame: int = 0,
) -> None:
    """Plug-in Gait's angles of the model (:mod:`mocap_mj.export.clinical`) in degrees, the
    table ``mocap-mj plug-in-gait`` writes (``frame,time_s``, then ``<Name>_X,_Y,_Z``)."""
    atomic_write_text(path, angles_table_text(model, times, qpos, first_frame))


def marker_residuals(
    model: mujoco.MjModel, qpos: np.ndarray, markers: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Model markers (T, M, 3) [m] for qpos (T, nq) and their distance (T, M) [m] to the
    measured markers (T, M, 3) [m] (NaN where either is missing)."""
    qpos = np.asarray(qpos, dtype=float)
    check_shape("markers", markers, (len(qpos), model.nsite, 3))
    fitted = np.full((len(qpos), model.nsite, 3), np.nan)
    for t, data in posed_frames(model, qpos):
        fitted[t] = data.site_xpos
    return fitted, np.linalg.norm(fitted - markers, axis=2)


def write_residuals_csv(
    path: str | Path,
    names: Sequence[str],
    times: np.ndarray,
    distance: np.ndarray,
    first_frame: int = 0,
) -> None:
    """Per-marker residuals: distance (T, M) [m] written in millimetres, one column a marker."""
    header = [f"{n}_mm" for n in names]
    atomic_write_text(path, table_text(header, times, distance * 1e3, ".4f", first_frame))


def segment_lengths(model: mujoco.MjModel) -> np.ndarray:
    """Lengths (S,) [m] of :data:`SEGMENTS` in the reference pose (``qpos0``)."""
    data = mujoco.MjData(model)
    rolling.kinematics(model, data)
    body = {name: model.body(b).id for name, b in JOINT_CENTRES}
    return np.array(
        [np.linalg.norm(data.xpos[body[a]] - data.xpos[body[b]]) for _, a, b in SEGMENTS]
    )


def scale_table_text(subject: mujoco.MjModel, nominal: mujoco.MjModel) -> str:
    """CSV of segment lengths [mm] of subject and nominal model and their ratio (scale factor)."""
    a, b = segment_lengths(subject), segment_lengths(nominal)
    lines = ["segment,from,to,nominal_mm,identified_mm,scale_factor"]
    for (seg, p, d), la, lb in zip(SEGMENTS, a, b, strict=True):
        lines.append(f"{seg},{p},{d},{lb * 1e3:.2f},{la * 1e3:.2f},{la / lb:.4f}")
    return "\n".join(lines) + "\n"
