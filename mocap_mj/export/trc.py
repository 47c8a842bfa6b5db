"""TRC marker files for OpenSim, with a choice of up axis.

Uses the project's TRC writer (:func:`mocap_mj.io.formats.trc.save_trc`, millimetres) after
rotating the MJCF world (z up) into the ground frame of :func:`mocap_mj.export.osim.up_rotation`:
``up="y"`` (OpenSim's convention, the default) or ``up="z"``. Use the same ``up`` for the
``.osim`` that will be fitted to the file.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mocap_mj.export.read_result import frame_rate

from ..io.formats.trc import save_trc
from ..io.trajectory import MarkerTrajectory
from .osim import up_rotation


def write_trc(
    path: str | Path,
    names: Sequence[str],
    times: np.ndarray,
    positions: np.ndarray,
    *,
    up: str = "y",
    first_frame: int | None = None,
) -> None:
    """Write positions (T, M, 3) [m, MJCF world, NaN = missing] at times (T,) [s] as TRC;
    ``first_frame``: the recording's number of frame 0 (None: frames numbered from 1)."""
    rotated = np.asarray(positions, dtype=float) @ up_rotation(up).T
    traj = MarkerTrajectory(
        times=np.asarray(times, dtype=float),
        positions=rotated,
        names=tuple(names),
        rate=frame_rate(times),
        source={"first_frame": first_frame},
    )
    save_trc(path, traj)
