"""Vicon Nexus CSV export: the "Trajectories" block.

Layout of the block (other blocks, e.g. "Devices" before it or "Model Outputs" after it,
are skipped)::

    Trajectories
    100
    ,,Subject:LASI,,,Subject:RASI,,,...
    Frame,Sub Frame,X,Y,Z,X,Y,Z,...
    ,,mm,mm,mm,mm,mm,mm,...
    1,0,123.4,...

A data row with an empty cell is a missing sample; the block ends at a blank line or at the
end of the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocap_mj.io.formats._common import (
    RawMarkers,
    check_rate,
    check_times,
    csv_cells,
    fit_row,
    line_error,
    parse_numbers,
    read_lines,
    show,
    strip_trailing_empty,
    xyz_positions,
)

#: Block titles a Nexus CSV export can start with.
BLOCKS = ("Trajectories", "Devices", "Model Outputs", "Joints", "Segments", "Trajectory Count")


def _first_cell(line: str) -> str:
    return line.split(",", 1)[0].strip()


def looks_like(first_line: str) -> bool:
    """True if a file whose first line is ``first_line`` is a Nexus CSV export."""
    return _first_cell(first_line) in BLOCKS


def read(path: Path) -> RawMarkers:
    """Read the Trajectories block of a Vicon Nexus CSV export."""
    lines = read_lines(path)
    top = next((i for i, ln in enumerate(lines) if _first_cell(ln) == "Trajectories"), None)
    if top is None:
        raise line_error(
            path, len(lines) + 1, "a 'Trajectories' block (Vicon Nexus CSV export)", "none"
        )
    if top + 4 >= len(lines):
        raise line_error(
            path,
            len(lines) + 1,
            "rate, names, axes and units lines after 'Trajectories'",
            "end of file",
        )
    rate_no, names_no, axes_no, units_no = top + 2, top + 3, top + 4, top + 5
    rate = check_rate(path, rate_no, lines[top + 1].split(",")[0], "Trajectories rate")

    axes = _axes(path, lines[top + 3], axes_no)
    n_markers = (len(axes) - 2) // 3
    width = len(axes)
    labels = _labels(path, lines[top + 2], names_no, n_markers, width)
    units, data_start = _units(path, lines, top, units_no, width)
    block, row_lines = _data_block(path, lines, data_start, labels, width)
    frames = block[:, 0]
    check_times(path, frames, row_lines, "Frame")
    return RawMarkers(
        format="vicon nexus csv",
        labels=labels,
        positions=xyz_positions(block, 2, n_markers),
        times=(frames - frames[0]) / rate,
        rate=rate,
        units=units,
        units_where=f"line {units_no}",
        labels_where=f"line {names_no}",
        info={"first_frame": int(frames[0]) if np.isfinite(frames[0]) else None},
    )


def _axes(path: Path, line: str, axes_no: int) -> list[str]:
    """The axes line 'Frame,Sub Frame,X,Y,Z,...' (line ``axes_no``) checked, as cells."""
    axes = [c.strip() for c in strip_trailing_empty(csv_cells(line))]
    if axes[:2] != ["Frame", "Sub Frame"] or len(axes) < 5 or (len(axes) - 2) % 3:
        raise line_error(path, axes_no, "'Frame,Sub Frame,X,Y,Z,...'", show(line))
    n_markers = (len(axes) - 2) // 3
    for k in range(n_markers):
        if [a.upper() for a in axes[2 + 3 * k : 5 + 3 * k]] != ["X", "Y", "Z"]:
            raise line_error(
                path, axes_no, f"X,Y,Z at column {3 + 3 * k}", show(axes[2 + 3 * k : 5 + 3 * k])
            )
    return axes


def _labels(path: Path, line: str, names_no: int, n_markers: int, width: int) -> list[str]:
    """The marker names of the names line (line ``names_no``): one every three columns."""
    named = csv_cells(line)
    if any(c.strip() for c in named[width:]) or any(c.strip() for c in named[:2]):
        raise line_error(path, names_no, f"{n_markers} names over {width} columns", show(named))
    named = named + [""] * (width - len(named))
    labels: list[str] = []
    for k in range(n_markers):
        cell = named[2 + 3 * k].strip()
        if not cell or any(c.strip() for c in named[3 + 3 * k : 5 + 3 * k]):
            raise line_error(
                path,
                names_no,
                f"a marker name at column {3 + 3 * k} then two empty cells",
                show(named[2 + 3 * k : 5 + 3 * k]),
            )
        labels.append(cell)
    return labels


def _units(
    path: Path, lines: list[str], top: int, units_no: int, width: int
) -> tuple[str | None, int]:
    """The length unit of the optional units row (line ``units_no``), None without one, and
    the index of the first data line."""
    units: str | None = None
    data_start = top + 4
    unit_cells = csv_cells(lines[top + 4])
    if unit_cells and not unit_cells[0].strip():  # a units row (data rows start with a frame)
        unit_cells = unit_cells + [""] * (width - len(unit_cells))
        seen = sorted({c.strip() for c in unit_cells[2:width]})
        if len(seen) != 1 or not seen[0]:
            raise line_error(path, units_no, "one length unit for every column", show(seen))
        units = seen[0]
        data_start = top + 5
    return units, data_start


def _data_block(
    path: Path, lines: list[str], data_start: int, labels: list[str], width: int
) -> tuple[np.ndarray, list[int]]:
    """The block's data rows (to a blank line, the next block or the end) as numbers
    (rows, 2 + 3 markers), and the 1-based line number of each row."""
    end = data_start
    while (
        end < len(lines)
        and lines[end].replace(",", "").strip()
        and _first_cell(lines[end]) not in BLOCKS
    ):
        end += 1
    if end == data_start:
        raise line_error(path, data_start + 1, "at least one row of data", "none")
    rows = [
        fit_row(path, n + 1, lines[n].split(","), width, "comma-separated cells")
        for n in range(data_start, end)
    ]
    row_lines = list(range(data_start + 1, end + 1))
    columns = ["Frame", "Sub Frame"] + [f"{lab}.{a}" for lab in labels for a in "XYZ"]
    block = parse_numbers(path, rows, row_lines, columns)
    return block, row_lines
