"""OpenSim's inverse dynamics on an exported model, and the tool's own in OpenSim's coordinates.

:func:`run_opensim_id` writes the model (:func:`mocap_mj.export.osim.write_osim`, with the
inertial parameters the tool's inverse dynamics uses), the coordinates
(:func:`mocap_mj.export.mot.write_mot`), the ground reactions and their ``ExternalLoads``
(:mod:`mocap_mj.export.grf`) and an ``InverseDynamicsTool`` setup (:func:`id_setup_xml`), and
runs OpenSim's tool (the ``[opensim]`` extra). OpenSim reports a generalised force per
coordinate (``<coordinate>_moment`` [N m], ``_force`` [N]).

The tool's inverse dynamics (:func:`mocap_mj.pipeline.dynamics.inverse_dynamics`) reports one
per MuJoCo degree of freedom of the model as written: a ball joint's three about its body's
axes (its angular velocity's components), a knee's flexion and the two slides that carry its
rolling. :func:`in_coordinates` turns them into OpenSim's coordinates by virtual work, tau_c =
J^T tau with J = du/dc the change of the degrees of freedom u per coordinate c (central
differences of :data:`STEP` [rad, m]): a hinge's is its own, a ball joint's Cardan angles get
the Jacobian of the angles, and a knee's flexion gains its slides' forces times the rolling's
slope, as OpenSim's knee, whose translations are splines of the flexion.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from ..anatomy.inertia import BodyInertia
from ..errors import MocapError, check_shape
from ..io.atomic import atomic_write_text
from ..skeleton.exported import Layout
from .coordinates import coordinate_values, model_coordinates, qpos_from_coordinates
from .grf import GroundReactions, write_grf
from .mot import read_mot, write_mot
from .opensim_ik import import_opensim
from .osim import OSIM_VERSION, write_osim

#: The coordinate step [rad or m] of :func:`in_coordinates`' central differences.
STEP = 1e-6


def id_setup_xml(
    *,
    model_file: str,
    coordinates_file: str,
    time_range: tuple[float, float],
    output_file: str,
    loads_file: str | None = None,
    cutoff_hz: float | None = None,
) -> str:
    """An ``InverseDynamicsTool`` setup: the model, its coordinates (``.mot``), the external
    loads (an ``ExternalLoads`` file, or none), the coordinates' low-pass cutoff [Hz] (None:
    OpenSim's -1, the coordinates as given) and the generalised forces' ``.sto``."""
    cut = -1.0 if cutoff_hz is None else float(cutoff_hz)
    return "\n".join([
        '<?xml version="1.0" encoding="UTF-8" ?>',
        f'<OpenSimDocument Version="{OSIM_VERSION}">',
        '  <InverseDynamicsTool name="inverse_dynamics">',
        "    <results_directory>.</results_directory>",
        f"    <model_file>{model_file}</model_file>",
        f"    <time_range>{time_range[0]!r} {time_range[1]!r}</time_range>",
        "    <forces_to_exclude>Muscles</forces_to_exclude>",
        f"    <external_loads_file>{loads_file or ''}</external_loads_file>",
        f"    <coordinates_file>{coordinates_file}</coordinates_file>",
        f"    <lowpass_cutoff_frequency_for_coordinates>{cut!r}"
        "</lowpass_cutoff_frequency_for_coordinates>",
        f"    <output_gen_force_file>{output_file}</output_gen_force_file>",
        "  </InverseDynamicsTool>",
        "</OpenSimDocument>",
        "",
    ])  # fmt: skip


def run_opensim_id(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    times: np.ndarray,
    workdir: str | Path,
    *,
    inertia: BodyInertia | None = None,
    loads: GroundReactions | None = None,
    up: str = "y",
    cutoff_hz: float | None = None,
) -> tuple[list[str], np.ndarray, np.ndarray]:
    """OpenSim's inverse dynamics of the internal model ``model`` (the tool's, without the
    knees' slides) moving as qpos (T, nq) at times (T,) [s] under ``loads``, its bodies'
    parameters ``inertia``; ``cutoff_hz``: OpenSim's own low-pass of the coordinates (None:
    none). Returns the coordinates' names (:func:`model_coordinates`' order), OpenSim's
    times (T',) [s] and generalised forces (T', C) [N m, N]. Files go to ``workdir``."""
    osim = import_opensim()
    work = Path(workdir).resolve()
    work.mkdir(parents=True, exist_ok=True)
    write_osim(work / "model.osim", model, up=up, inertia=inertia)
    write_mot(work / "coordinates.mot", model, times, qpos)
    loads_file = None
    if loads is not None:
        _, xml = write_grf(work / "grf.mot", loads, up=up)
        loads_file = str(xml)
    setup = work / "id_setup.xml"
    atomic_write_text(setup, id_setup_xml(
        model_file=str(work / "model.osim"), coordinates_file=str(work / "coordinates.mot"),
        time_range=(float(times[0]), float(times[-1])), output_file="id.sto",
        loads_file=loads_file, cutoff_hz=cutoff_hz,
    ))  # fmt: skip
    tool = osim.InverseDynamicsTool(str(setup))
    tool.setResultsDir(str(work))
    if not tool.run():
        raise MocapError(f"{work}: OpenSim's InverseDynamicsTool failed")
    cols, t_out, values = read_mot(work / "id.sto")
    index = {n.rsplit("_", 1)[0]: i for i, n in enumerate(cols)}
    names = [c.name for c in model_coordinates(model)]
    missing = [n for n in names if n not in index]
    if missing:
        raise MocapError(f"{work / 'id.sto'}: no generalised force of {', '.join(missing)}")
    return names, t_out, np.column_stack([values[:, index[n]] for n in names])


def in_coordinates(
    internal: mujoco.MjModel, written: mujoco.MjModel, qpos: np.ndarray, tau: np.ndarray
) -> np.ndarray:
    """The generalised forces (T, nv) [N m, N] of the model as written ``written`` (the
    tool's inverse dynamics) at its qpos (T, nq_written), as OpenSim's coordinates' (T, C) of
    the internal model ``internal`` (module doc); NaN where qpos or tau is."""
    layout = Layout.of(internal)
    q = np.asarray(qpos, dtype=float)
    check_shape("qpos", q, (None, layout.nq_written))
    check_shape("tau", np.asarray(tau), (len(q), written.nv))
    if written.nq != layout.nq_written:
        raise MocapError(f"in_coordinates: the written model has nq {written.nq}, expected "
                         f"{layout.nq_written} (the internal model's with the slides)")  # fmt: skip
    values = coordinate_values(internal, layout.internal(q))  # (T, C)
    n_c = values.shape[1]
    out = np.full((len(q), n_c), np.nan)
    du = np.zeros(written.nv)
    for t in np.flatnonzero(np.isfinite(values).all(axis=1) & np.isfinite(tau).all(axis=1)):
        steps = np.repeat(values[t][None], 2 * n_c, axis=0)
        steps[np.arange(n_c), np.arange(n_c)] += STEP
        steps[n_c + np.arange(n_c), np.arange(n_c)] -= STEP
        posed = layout.written(qpos_from_coordinates(internal, steps))
        jac = np.empty((written.nv, n_c))
        for i in range(n_c):
            mujoco.mj_differentiatePos(written, du, 2.0 * STEP, posed[n_c + i], posed[i])
            jac[:, i] = du
        out[t] = jac.T @ tau[t]
    return out


__all__ = ["STEP", "id_setup_xml", "in_coordinates", "run_opensim_id"]
