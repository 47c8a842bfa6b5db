"""Running OpenSim's InverseKinematicsTool on an exported model (needs the ``[opensim]`` extra).

Used by the side-by-side benchmark (``benchmarks/opensim_ik.py``) and the validation tests:
the MJCF model is exported with :func:`mocap_mj.export.osim.write_osim`, the markers with
:func:`mocap_mj.export.trc.write_trc` (same up axis), the tool runs from the setup file of
:mod:`mocap_mj.export.ik_setup` (every marker weighted 1, as ``mocap-mj ik``), and the
resulting ``.mot`` is turned back into MuJoCo ``qpos``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from ..errors import MocapError
from .coordinates import model_coordinates, qpos_from_coordinates
from .ik_setup import DEFAULT_ACCURACY, write_ik_setup
from .mot import read_mot
from .osim import write_osim
from .trc import write_trc


class OpenSimIK(NamedTuple):
    """Result of :func:`run_opensim_ik`.

    Attributes
    ----------
    qpos : (T, nq) float [m, quaternion, rad]
    seconds : float
        Wall time of the tool's ``run()`` alone (not the file writing) [s].
    """

    qpos: np.ndarray
    seconds: float


def import_opensim() -> Any:
    """``import opensim`` with a clear error when the extra is not installed."""
    try:
        import opensim
    except ImportError:
        raise MocapError("OpenSim is not installed: pip install 'mocap-mj[opensim]'") from None
    return opensim


def run_opensim_ik(
    model: mujoco.MjModel,
    names: Sequence[str],
    times: np.ndarray,
    markers: np.ndarray,
    workdir: str | Path,
    *,
    accuracy: float = DEFAULT_ACCURACY,
    up: str = "y",
) -> OpenSimIK:
    """OpenSim IK of markers (T, M, 3) [m, MJCF world, NaN = missing] at times (T,) [s].

    ``accuracy`` is the tool's convergence setting (OpenSim's default is 1e-5).
    """
    osim = import_opensim()
    work = Path(workdir).resolve()  # absolute paths: OpenSim resolves relative ones unevenly
    work.mkdir(parents=True, exist_ok=True)
    write_osim(work / "model.osim", model, up=up)
    write_trc(work / "markers.trc", names, times, markers, up=up)
    write_ik_setup(
        work / "ik_setup.xml",
        model_file=str(work / "model.osim"),
        marker_file=str(work / "markers.trc"),
        marker_names=names,
        time_range=(float(times[0]), float(times[-1])),
        output_motion_file=str(work / "ik.mot"),
        accuracy=accuracy,
    )
    omodel = osim.Model(str(work / "model.osim"))
    omodel.initSystem()
    tool = osim.InverseKinematicsTool(str(work / "ik_setup.xml"))
    tool.setModel(omodel)  # loaded outside the timing below
    t0 = time.perf_counter()
    ok = tool.run()
    seconds = time.perf_counter() - t0
    if not ok:
        raise MocapError(f"{work}: OpenSim's InverseKinematicsTool failed")
    cols, _, values = read_mot(work / "ik.mot")
    coords = model_coordinates(model)
    index = {n: i for i, n in enumerate(cols)}
    missing = [c.name for c in coords if c.name not in index]
    if missing:
        raise MocapError(f"{work / 'ik.mot'}: no column for {', '.join(missing)}")
    ordered = np.column_stack([values[:, index[c.name]] for c in coords])
    rotational = np.array([c.rotational for c in coords])
    ordered[:, rotational] = np.radians(ordered[:, rotational])
    return OpenSimIK(qpos_from_coordinates(model, ordered), seconds)
