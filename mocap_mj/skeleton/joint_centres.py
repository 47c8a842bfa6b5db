"""Joint centres of the humanoid: named body origins, and their trajectories for a motion.

Every joint of the bundled humanoid sits at the origin of its child body (``docs/model.md``),
so a joint centre's world position is that body's ``xpos``. The names below are the ones the
outputs use (CSV columns, C3D points): anatomical joints, left (``_l``) and right (``_r``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from mocap_mj.errors import check_shape
from mocap_mj.skeleton import rolling

#: (joint-centre name, child body whose origin it is), in output order.
JOINT_CENTRES: tuple[tuple[str, str], ...] = (
    ("lumbosacral", "lumbar"),
    ("thoracolumbar", "thorax"),
    ("cervicothoracic", "head"),
    ("hip_l", "thigh_l"),
    ("knee_l", "shank_l"),
    ("ankle_l", "foot_l"),
    ("mtp_l", "toes_l"),
    ("hip_r", "thigh_r"),
    ("knee_r", "shank_r"),
    ("ankle_r", "foot_r"),
    ("mtp_r", "toes_r"),
    ("sternoclavicular_l", "clavicle_l"),
    ("shoulder_l", "upperarm_l"),
    ("elbow_l", "ulna_l"),
    ("wrist_l", "hand_l"),
    ("sternoclavicular_r", "clavicle_r"),
    ("shoulder_r", "upperarm_r"),
    ("elbow_r", "ulna_r"),
    ("wrist_r", "hand_r"),
)

#: Joint-centre names, in output order.
JOINT_CENTRE_NAMES: tuple[str, ...] = tuple(name for name, _ in JOINT_CENTRES)


def centre_bodies(model: mujoco.MjModel) -> np.ndarray:
    """Body ids (J,) of :data:`JOINT_CENTRES` in ``model``."""
    return np.array([model.body(body).id for _, body in JOINT_CENTRES], dtype=int)


def joint_centre_trajectories(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """World positions (T, J, 3) [m] of the joint centres for qpos (T, nq).

    ``model`` carries the subject's parameters (e.g. ``ParameterSet.model_for(theta)``).
    Frames whose qpos has a NaN (not solved) give NaN rows.
    """
    qpos = np.asarray(qpos, dtype=float)
    check_shape("qpos", qpos, (None, model.nq))
    bodies = centre_bodies(model)
    out = np.full((len(qpos), len(bodies), 3), np.nan)
    for t, data in rolling.posed(model, qpos):
        out[t] = data.xpos[bodies]
    return out
