"""mocap-mj's own marker CSV: read and write.

Layout::

    # mocap-mj markers v1 units=mm rate=100 up=z
    frame,time,LASI_X,LASI_Y,LASI_Z,RASI_X,...
    0,0.000000000,123.456789,...
    1,0.010000000,,,,...

The comment line is optional (units then default to mm, the rate comes from the time
column); ``up=`` states the vertical axis of the coordinates (the writer always writes the
model's Z-up world). Coordinates are millimetres unless ``units=`` says otherwise; an empty
cell is a missing sample.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from mocap_mj.errors import MocapError
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.formats._common import (
    RawMarkers,
    check_rate,
    check_times,
    fit_row,
    line_error,
    parse_numbers,
    rate_from_times,
    read_lines,
    show,
    strip_trailing_empty,
    xyz_positions,
)
from mocap_mj.io.orientation import UP_AXES
from mocap_mj.io.trajectory import MarkerTrajectory

MAGIC = "# mocap-mj markers"
_VERSION = "v1"
_AXES = ("X", "Y", "Z")


def looks_like(first_line: str) -> bool:
    """True if a file whose first line is ``first_line`` is in this format."""
    head = first_line.strip().lower().replace(" ", "")
    return first_line.startswith(MAGIC) or head.startswith("frame,time,")


def _parse_comment(path: Path, line_no: int, line: str) -> dict[str, str]:
    words = line[len(MAGIC) :].split()
    if not words or words[0] != _VERSION:
        raise line_error(path, line_no, f"'{MAGIC} {_VERSION} ...'", show(line))
    meta: dict[str, str] = {}
    for word in words[1:]:
        key, sep, value = word.partition("=")
        if not sep or not key or not value:
            raise line_error(path, line_no, "key=value settings after the version", show(word))
        meta[key.lower()] = value
    return meta


def read(path: Path) -> RawMarkers:
    """Read a mocap-mj marker CSV (see the module docstring for the layout)."""
    lines = read_lines(path)
    meta: dict[str, str] = {}
    meta_line = 0
    i = 0
    while i < len(lines) and (lines[i].startswith("#") or not lines[i].strip()):
        if lines[i].startswith(MAGIC):
            meta, meta_line = _parse_comment(path, i + 1, lines[i]), i + 1
        i += 1
    if i == len(lines):
        raise line_error(path, i + 1, "a header 'frame,time,NAME_X,...'", "end of file")
    header_no = i + 1
    header = [c.strip() for c in strip_trailing_empty(lines[i].split(","))]
    if (
        len(header) < 2
        or header[0].lower() != "frame"
        or header[1].lower() != "time"
        or (len(header) - 2) % 3
    ):
        raise line_error(
            path, header_no, "a header 'frame,time,NAME_X,NAME_Y,NAME_Z,...'", show(lines[i])
        )
    names: list[str] = []
    for k in range(2, len(header), 3):
        triple = header[k : k + 3]
        base = triple[0][:-2]
        want = [f"{base}_{a}" for a in _AXES]
        if not base or [c.upper() for c in triple] != [w.upper() for w in want]:
            raise line_error(
                path, header_no, f"columns NAME_X,NAME_Y,NAME_Z at column {k + 1}", show(triple)
            )
        names.append(base)
    width = len(header)

    body = lines[i + 1 :]
    while body and not body[-1].strip():
        body.pop()
    if not body:
        raise line_error(path, header_no + 1, "at least one row of data", "end of file")
    rows = [
        fit_row(path, header_no + 1 + n, line.split(","), width, "comma-separated cells")
        for n, line in enumerate(body)
    ]
    row_lines = list(range(header_no + 1, header_no + 1 + len(rows)))
    block = parse_numbers(path, rows, row_lines, header)
    for i_missing in np.flatnonzero(np.isnan(block[:, 0])):
        raise line_error(path, row_lines[int(i_missing)], "a frame number", "an empty cell")
    times = block[:, 1]
    check_times(path, times, row_lines, "time")

    if "rate" in meta:
        rate = check_rate(path, meta_line, meta["rate"], "rate= in the header comment")
    else:
        rate = rate_from_times(path, times, header_no, "a rate= setting in a '# mocap-mj' line")
    up = meta.get("up")
    if up is not None and up.lower().lstrip("+") not in UP_AXES:
        raise line_error(path, meta_line, f"up= one of {', '.join(UP_AXES)}", show(up))
    return RawMarkers(
        format="mocap-mj csv",
        labels=names,
        positions=xyz_positions(block, 2, len(names)),
        times=times.copy(),
        rate=rate,
        units=meta.get("units", "mm"),
        units_where=f"line {meta_line}" if "units" in meta else "mocap-mj csv default (mm)",
        labels_where=f"line {header_no}",
        up_hint=up.lower() if up else None,
        info={"up_stated": up is not None},
    )


def _check_writable_names(path: Path, names: tuple[str, ...], forbidden: str) -> None:
    for name in names:
        if name != name.strip() or any(ch in name for ch in forbidden):
            raise MocapError(f"{path}: cannot write marker name {name!r} (it has {forbidden!r})")


def _format_rows(traj: MarkerTrajectory, sep: str, first_frame: int) -> list[str]:
    mm = traj.positions.reshape(traj.n_frames, -1) * 1000.0
    out = []
    for t in range(traj.n_frames):
        cells = ["" if v != v else f"{v:.6f}" for v in mm[t].tolist()]
        out.append(f"{t + first_frame}{sep}{traj.times[t]:.9f}{sep}{sep.join(cells)}")
    return out


def save_csv(path: str | os.PathLike[str], traj: MarkerTrajectory) -> None:
    """Write ``traj`` as a mocap-mj marker CSV, atomically.

    Coordinates are written in millimetres with 6 decimals (1e-9 m steps), times with 9
    decimals; missing samples as empty cells. The text is a function of ``traj`` alone.

    Parameters
    ----------
    path : str or PathLike
        Destination; replaced whole, or left as it was if writing fails.
    traj : MarkerTrajectory
        Positions (T, M, 3) [m] in the model's Z-up world.
    """
    target = Path(path)
    _check_writable_names(target, traj.names, ',\n\r\t"')
    header = ["frame", "time"] + [f"{n}_{a}" for n in traj.names for a in _AXES]
    lines = [
        f"{MAGIC} {_VERSION} units=mm rate={traj.rate!r} up=z",
        ",".join(header),
        *_format_rows(traj, ",", 0),
    ]
    atomic_write_text(target, "\n".join(lines) + "\n")
