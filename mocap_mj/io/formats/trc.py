"""OpenSim TRC marker files: read and write.

Layout (tab-separated)::

    PathFileType  4  (X/Y/Z)  trial.trc
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  ...
    100       100         250        39          mm     100           ...
    Frame#  Time  LASI        RASI        ...
                  X1  Y1  Z1  X2  Y2  Z2  ...
    (optional blank line)
    1       0.00  ...

An empty (or NaN) cell is a missing sample. The writer keeps the trajectory's axes (the
model's Z-up world); OpenSim's own convention is Y up, so rotate on import there if needed.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.formats._common import (
    RawMarkers,
    check_rate,
    check_times,
    fit_row,
    line_error,
    parse_numbers,
    read_lines,
    show,
    strip_trailing_empty,
    xyz_positions,
)
from mocap_mj.io.formats.mocap_csv import _check_writable_names, _format_rows
from mocap_mj.io.trajectory import MarkerTrajectory

_INT = re.compile(r"\s*\d+\s*")


def looks_like(first_line: str) -> bool:
    """True if a file whose first line is ``first_line`` is a TRC file."""
    return first_line.lstrip().startswith("PathFileType")


def _split(line: str) -> list[str]:
    return line.split("\t") if "\t" in line else line.split()


def read(path: Path) -> RawMarkers:
    """Read an OpenSim TRC file (see the module docstring for the layout)."""
    lines = read_lines(path)
    if len(lines) < 5:
        raise line_error(path, len(lines) + 1, "the 5 header lines of a TRC file", "end of file")
    keys = [c.strip() for c in strip_trailing_empty(_split(lines[1]))]
    values = [c.strip() for c in _split(lines[2])]
    if len(values) < len(keys) or "NumFrames" not in keys or "NumMarkers" not in keys:
        raise line_error(
            path,
            2,
            "TRC header keys (DataRate ... NumFrames NumMarkers Units) over values",
            show(lines[1]),
        )
    header = dict(zip(keys, values, strict=False))
    for key in ("NumFrames", "NumMarkers"):
        if _INT.fullmatch(header[key]) is None:
            raise line_error(path, 3, f"a whole number for {key}", show(header[key]))
    n_frames, n_markers = int(header["NumFrames"]), int(header["NumMarkers"])
    rate_key = "DataRate" if "DataRate" in header else "CameraRate"
    if rate_key not in header:
        raise line_error(path, 2, "a DataRate or CameraRate key", show(lines[1]))
    rate = check_rate(path, 3, header[rate_key], rate_key)
    units = header.get("Units") or None

    names_row = _split(lines[3])
    if "\t" not in lines[3]:  # whitespace-separated: names follow each other
        names_row = names_row[:2] + [c for n in names_row[2:] for c in (n, "", "")]
    width = 2 + 3 * n_markers
    if (
        len(names_row) < 2
        or not names_row[0].strip().lower().startswith("frame")
        or (names_row[1].strip().lower() != "time")
    ):
        raise line_error(path, 4, "'Frame#' and 'Time' then marker names", show(lines[3]))
    named = strip_trailing_empty(names_row)
    if len(named) != max(2, width - 2):
        raise line_error(
            path,
            4,
            f"NumMarkers={n_markers} marker names, one every 3 columns",
            f"{len([c for c in named if c.strip()]) - 2} names over {len(named)} columns",
        )
    names_row = named + [""] * (width - len(named))
    names: list[str] = []
    for k in range(n_markers):
        name = names_row[2 + 3 * k].strip()
        if not name or any(c.strip() for c in names_row[3 + 3 * k : 5 + 3 * k]):
            raise line_error(
                path,
                4,
                f"marker {k + 1} of NumMarkers={n_markers} at column {3 + 3 * k}",
                show(names_row[2 + 3 * k : 5 + 3 * k]),
            )
        names.append(name)
    axes_row = [c.strip().upper() for c in _split(lines[4])]
    if "\t" in lines[4]:
        axes_row = axes_row[2:]
    axes_row = strip_trailing_empty(axes_row)
    if len(axes_row) != 3 * n_markers or [c[:1] for c in axes_row] != ["X", "Y", "Z"] * n_markers:
        raise line_error(
            path, 5, f"X1 Y1 Z1 ... X{n_markers} Y{n_markers} Z{n_markers}", show(lines[4])
        )

    start = 5
    while start < len(lines) and not lines[start].strip():
        start += 1
    body = lines[start:]
    while body and not body[-1].strip():
        body.pop()
    if not body or n_frames == 0:
        raise line_error(path, start + 1, "at least one row of data", "end of file")
    if len(body) != n_frames:
        raise line_error(path, 3, f"NumFrames={n_frames} rows of data", str(len(body)))
    rows = [
        fit_row(
            path,
            start + 1 + n,
            line.split("\t") if "\t" in line else line.split(),
            width,
            "cells (Frame#, Time, 3 per marker)",
        )
        for n, line in enumerate(body)
    ]
    row_lines = list(range(start + 1, start + 1 + len(rows)))
    columns = ["Frame#", "Time"] + [f"{n}.{a}" for n in names for a in "XYZ"]
    block = parse_numbers(path, rows, row_lines, columns)
    check_times(path, block[:, 1], row_lines, "Time")
    return RawMarkers(
        format="trc",
        labels=names,
        positions=xyz_positions(block, 2, n_markers),
        times=block[:, 1].copy(),
        rate=rate,
        units=units,
        units_where="line 3",
        labels_where="line 4",
    )


def save_trc(path: str | os.PathLike[str], traj: MarkerTrajectory) -> None:
    """Write ``traj`` as an OpenSim TRC file in millimetres, atomically.

    Coordinates are written with 6 decimals in mm (1e-9 m steps), in the trajectory's own
    Z-up axes; missing samples as empty cells. Frames are numbered from 1.

    Parameters
    ----------
    path : str or PathLike
        Destination; replaced whole, or left as it was if writing fails.
    traj : MarkerTrajectory
        Positions (T, M, 3) [m] in the model's Z-up world.
    """
    target = Path(path)
    _check_writable_names(target, traj.names, "\t\n\r ")
    rate = repr(traj.rate)
    names = "\t".join(f"{n}\t\t" for n in traj.names)
    axes = "\t".join(f"X{k}\tY{k}\tZ{k}" for k in range(1, traj.n_markers + 1))
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{target.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate}\t{rate}\t{traj.n_frames}\t{traj.n_markers}\tmm\t{rate}\t1\t{traj.n_frames}",
        f"Frame#\tTime\t{names}",
        f"\t\t{axes}",
        "",
        *_format_rows(traj, "\t", 1),
    ]
    atomic_write_text(target, "\n".join(lines) + "\n")
