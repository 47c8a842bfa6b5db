"""Clinical joint angles of a result: Plug-in Gait's angles of the identified model.

The angles are those of ``mocap-mj plug-in-gait`` (Vicon's names, components and signs),
computed from the model's segments built the Plug-in Gait way
(:mod:`mocap_mj.clinical.from_model`), so that a result's angles.csv and Plug-in Gait's
line up column by column. Conventions: docs/clinical.md.
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..clinical.from_model import model_angles
from ..clinical.tables import series_table


def clinical_angles(model: mujoco.MjModel, qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Plug-in Gait's angles of ``model`` at qpos (T, nq): Vicon name -> (T, 3) [rad]."""
    return model_angles(model, qpos)


def angles_table_text(
    model: mujoco.MjModel, times: np.ndarray, qpos: np.ndarray, first_frame: int = 0
) -> str:
    """angles.csv text: ``frame`` (from ``first_frame``), ``time_s``, then
    ``<Name>_X,_Y,_Z`` [deg] for times (T,) [s] and qpos (T, nq)."""
    frames = first_frame + np.arange(len(times))
    return series_table(frames, np.asarray(times), model_angles(model, qpos), 180.0 / np.pi)
