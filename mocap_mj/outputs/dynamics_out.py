"""The inverse dynamics of a result folder, and its tables.

``dynamics.csv``
    ``time_s``, then for every degree of freedom (:func:`mocap_mj.pipeline.dynamics.dof_names`)
    ``<dof>_Nm`` (a rotation's moment [N m]; ``<dof>_N`` for a translation's force [N]),
    ``<dof>_Nm_per_kg`` (``_N_per_kg``: the same per kilogram of body mass) and ``<dof>_W``
    (its power [W]). An empty cell where a frame was not computed.
``root_residuals.csv``
    ``time_s``, the root's residual force ``force_X_N``, ``_Y_N``, ``_Z_N`` [N] (world
    frame), the same in per cent of body weight ``force_X_pct_bw`` ... and
    ``force_norm_pct_bw``, and the residual moment about the root body's origin
    ``moment_X_Nm`` ... [N m] (world frame).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from mocap_mj.anatomy.inertia import BodyInertia, Sex, apply_inertia, inertial_model
from mocap_mj.errors import MocapError
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.pipeline.dynamics import (
    CUTOFF_HZ,
    BodyLoad,
    Dynamics,
    inverse_dynamics,
    translational,
)
from mocap_mj.pipeline.motion import ResultDir, load_motion

#: Standard gravity [m/s^2] that body weight is measured in.
STANDARD_GRAVITY = 9.80665

DYNAMICS_CSV = "dynamics.csv"
RESIDUALS_CSV = "root_residuals.csv"


def _cell(v: float) -> str:
    return "" if not np.isfinite(v) else f"{v:.6g}"


def _table(header: list[str], times: np.ndarray, cols: np.ndarray) -> str:
    lines = [",".join(header)]
    for t, row in zip(times, cols, strict=True):
        lines.append(",".join([f"{t:.6f}", *(_cell(v) for v in row)]))
    return "\n".join(lines) + "\n"


def dynamics_table(dyn: Dynamics, mass: float, force_dofs: np.ndarray) -> str:
    """dynamics.csv's text (module docstring) of ``dyn`` for a body of ``mass`` [kg];
    ``force_dofs`` (nv,) bool marks the translations (:func:`translational`)."""
    _check_mass(mass)
    header = ["time_s"]
    for name, force in zip(dyn.dof_names, force_dofs, strict=True):
        unit = "N" if force else "Nm"
        header += [f"{name}_{unit}", f"{name}_{unit}_per_kg", f"{name}_W"]
    cols = np.stack([dyn.tau, dyn.tau / mass, dyn.power], axis=2).reshape(len(dyn.times), -1)
    return _table(header, dyn.times, cols)


def residuals_table(dyn: Dynamics, mass: float) -> str:
    """root_residuals.csv's text (module docstring) of ``dyn`` for a body of ``mass`` [kg]."""
    _check_mass(mass)
    weight = mass * STANDARD_GRAVITY
    pct = 100.0 * dyn.root_force / weight
    norm = np.linalg.norm(pct, axis=1, keepdims=True)
    header = ["time_s"] + [f"force_{a}_N" for a in "XYZ"] + [f"force_{a}_pct_bw" for a in "XYZ"]
    header += ["force_norm_pct_bw"] + [f"moment_{a}_Nm" for a in "XYZ"]
    cols = np.concatenate([dyn.root_force, pct, norm, dyn.root_moment], axis=1)
    return _table(header, dyn.times, cols)


def write_dynamics(
    folder: str | Path,
    dyn: Dynamics,
    mass: float,
    force_dofs: np.ndarray,
    *,
    suffix: str = "",
) -> list[Path]:
    """Write dynamics.csv and root_residuals.csv into ``folder`` (atomically; ``suffix``
    before the extension, e.g. "_1" for a result's second trial); their paths."""
    folder = Path(folder)
    out = [folder / _suffixed(DYNAMICS_CSV, suffix), folder / _suffixed(RESIDUALS_CSV, suffix)]
    atomic_write_text(out[0], dynamics_table(dyn, mass, force_dofs))
    atomic_write_text(out[1], residuals_table(dyn, mass))
    return out


def _suffixed(name: str, suffix: str) -> str:
    stem, ext = name.rsplit(".", 1)
    return f"{stem}{suffix}.{ext}"


def dynamics_of_result(
    result_dir: str | Path,
    loads: Sequence[BodyLoad],
    mass: float,
    *,
    sex: Sex = "male",
    cutoff_hz: float | None = CUTOFF_HZ,
) -> tuple[Dynamics, np.ndarray]:
    """The inverse dynamics of the result folder ``result_dir`` (``mocap-mj ik``'s or
    ``identify``'s: model.xml and motion.npz) under ``loads`` (each (T, 3) over motion.npz's
    frames) for a subject of ``mass`` [kg] (:func:`dynamics_of_files`)."""
    _check_mass(mass)
    rd = ResultDir.open(result_dir)
    return dynamics_of_files(rd.model, rd.motion, loads, mass, sex=sex, cutoff_hz=cutoff_hz)


def dynamics_of_files(
    model_path: str | Path,
    motion_path: str | Path,
    loads: Sequence[BodyLoad],
    mass: float,
    *,
    sex: Sex = "male",
    cutoff_hz: float | None = CUTOFF_HZ,
    inertia: BodyInertia | None = None,
) -> tuple[Dynamics, np.ndarray]:
    """The inverse dynamics of the motion file ``motion_path`` (a result's motion.npz or
    motion_<i>.npz) on the model file ``model_path`` (its model.xml) under ``loads`` (each
    (T, 3) over the motion's frames) for a subject of ``mass`` [kg]: the model as plain
    MuJoCo compiles it with de Leva's inertial parameters
    (:func:`mocap_mj.anatomy.inertia.inertial_model`), or with ``inertia`` when given (the
    masses fitted to the plates, :mod:`mocap_mj.outputs.inertia_out`), the motion in its
    written layout. Returns the :class:`Dynamics` and the translation flags (nv,) for
    :func:`write_dynamics`."""
    _check_mass(mass)
    model = model_with(model_path, mass, sex=sex, inertia=inertia)
    motion = load_motion(motion_path)
    if motion.qpos.shape[1] != model.nq:
        raise MocapError(
            f"{motion_path}: qpos has {motion.qpos.shape[1]} columns, expected nq = {model.nq} "
            f"of {model_path} as written (the knees' slide joints included)"
        )
    dyn = inverse_dynamics(model, motion.qpos, motion.times, loads, cutoff_hz=cutoff_hz)
    return dyn, translational(model)


def model_with(
    model_path: str | Path, mass: float, *, sex: Sex = "male", inertia: BodyInertia | None = None
) -> mujoco.MjModel:
    """The model file ``model_path`` as plain MuJoCo compiles it with ``inertia`` in its bodies
    (None: de Leva's for ``mass`` [kg] and ``sex``)."""
    if inertia is None:
        return inertial_model(model_path, mass, sex=sex)
    spec = mujoco.MjSpec.from_file(str(model_path))
    apply_inertia(spec, inertia)
    return spec.compile()


def _check_mass(mass: float) -> None:
    if not np.isfinite(mass) or mass <= 0:
        raise MocapError(f"body mass: expected a positive number of kilograms, got {mass}")


__all__ = [
    "DYNAMICS_CSV",
    "RESIDUALS_CSV",
    "STANDARD_GRAVITY",
    "dynamics_of_files",
    "dynamics_of_result",
    "dynamics_table",
    "model_with",
    "residuals_table",
    "write_dynamics",
]
