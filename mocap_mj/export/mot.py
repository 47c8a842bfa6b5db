"""OpenSim motion files (``.mot``): coordinates over time, and reading them back.

The columns are ``time`` [s] and the coordinates of :mod:`mocap_mj.export.coordinates` under
their OpenSim names, angles in degrees (``inDegrees=yes``, OpenSim's convention for motion
files), translations in metres. Frames not solved (NaN) are written as ``NaN``, which
OpenSim's ``TimeSeriesTable`` reads as missing.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from ..errors import InputFileError, check_shape
from ..io.atomic import atomic_write_text
from .coordinates import coordinate_values, model_coordinates


def mot_text(
    names: Sequence[str], times: np.ndarray, values: np.ndarray, *, name: str = "coordinates"
) -> str:
    """A ``.mot`` of values (T, C) already in file units (degrees, metres), times (T,) [s]."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    check_shape("values", values, (len(times), len(names)))
    header = [
        name,
        "version=1",
        f"nRows={len(times)}",
        f"nColumns={len(names) + 1}",
        "inDegrees=yes",
        "endheader",
        "\t".join(["time", *names]),
    ]
    rows = [
        "\t".join([f"{t:.6f}", *(f"{v:.8f}" if np.isfinite(v) else "NaN" for v in row)])
        for t, row in zip(times, values, strict=True)
    ]
    return "\n".join(header + rows) + "\n"


def coordinates_in_degrees(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Coordinate values (T, C) for qpos (T, nq): rotations [deg], translations [m]. A
    rotation is continuous over the frames (unwrapped: a Cardan angle that passes +-180 deg
    goes on past it, the same orientation), so that OpenSim's splines and filters of the
    coordinates see no jump of 360 deg."""
    values = coordinate_values(model, qpos)
    rotational = np.array([c.rotational for c in model_coordinates(model)])
    for k in np.flatnonzero(rotational):
        seen = np.isfinite(values[:, k])
        values[seen, k] = np.unwrap(values[seen, k])
    values[:, rotational] = np.degrees(values[:, rotational])
    return values


def write_mot(path: str | Path, model: mujoco.MjModel, times: np.ndarray, qpos: np.ndarray) -> None:
    """Write the coordinates of qpos (T, nq) at times (T,) [s] as a ``.mot``, atomically."""
    names = [c.name for c in model_coordinates(model)]
    text = mot_text(names, times, coordinates_in_degrees(model, qpos), name=Path(path).stem)
    atomic_write_text(path, text)


def read_mot(path: str | Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(column names without time, times (T,) [s], values (T, C) in file units) of a .mot/.sto.

    Reads OpenSim's storage layout: header lines up to ``endheader``, then a tab-separated
    table with a ``time`` column first.
    """
    path = Path(path)
    lines = path.read_text().splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip() == "endheader")
    except StopIteration:
        raise InputFileError(f"{path}: no 'endheader' line (expected an OpenSim .mot)") from None
    names = lines[end + 1].split("\t")
    if not names or names[0] != "time":
        raise InputFileError(f"{path}: line {end + 2}: expected column names starting 'time'")
    try:
        table = np.array(
            [[float(x) for x in line.split("\t")] for line in lines[end + 2 :] if line.strip()]
        )
    except ValueError as exc:
        raise InputFileError(f"{path}: expected numbers after the header: {exc}") from None
    table = table.reshape(-1, len(names))
    return names[1:], table[:, 0], table[:, 1:]
