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

import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

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
from mocap_mj.io.formats._text_stream import ROWS, TextChunks, chunks_of, parse_rows
from mocap_mj.io.formats._text_stream import encoding as text_encoding
from mocap_mj.io.formats._text_stream import lines as text_lines

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
        raise _no_block(path, len(lines))
    h = _header(path, lines[top : top + 5], top, len(lines))
    end = h.data_start
    while end < len(lines) and _is_row(lines[end]):
        end += 1
    if end == h.data_start:
        raise _no_rows(path, h)
    rows = [
        fit_row(path, n + 1, lines[n].split(","), h.width, "comma-separated cells")
        for n in range(h.data_start, end)
    ]
    row_lines = list(range(h.data_start + 1, end + 1))
    block = parse_numbers(path, rows, row_lines, h.columns)
    return h.raw(path, xyz_positions(block, 2, len(h.labels)), block[:, 0])


def open_chunks(path: Path, chunk: int = ROWS) -> TextChunks:
    """Read the Trajectories block ``chunk`` rows at a time into a memory map of its
    positions, with :func:`read`'s rules and errors.

    Three passes over the file, none holding it: the encoding (as :func:`read_lines`
    decides it for the whole file), the block's header and rows (:func:`fit_row` on every
    row to the block's end, the first error raised, as :func:`read` checks every row before
    it parses one), then the numbers, ``chunk`` rows at a time (:func:`parse_numbers`,
    whose first bad cell is the whole block's first)."""
    encoding = text_encoding(path)
    head: list[str] = []
    top, n_lines = None, 0
    with text_lines(path, encoding) as lines:
        for line in lines:
            n_lines += 1
            if top is None and _first_cell(line) == "Trajectories":
                top = n_lines - 1
            if top is not None:
                head.append(line)
                if len(head) == 5:
                    break
        if top is None:
            raise _no_block(path, n_lines)
        h = _header(path, head, top, n_lines)
        n_rows = 0
        for line in itertools.chain(head[h.data_start - top :], lines):
            if not _is_row(line):
                break
            fit_row(path, h.data_start + 1 + n_rows, line.split(","), h.width,
                    "comma-separated cells")  # fmt: skip
            n_rows += 1
    if n_rows == 0:
        raise _no_rows(path, h)
    positions, first_two = parse_rows(
        path, encoding, h.data_start, n_rows, lambda ln: ln.split(",")[: h.width], h.columns, chunk
    )
    return chunks_of(h.raw(path, positions, first_two[:, 0].copy()), positions)


def _is_row(line: str) -> bool:
    """True for a row of the block's data: not blank, not the title of the next block."""
    return bool(line.replace(",", "").strip()) and _first_cell(line) not in BLOCKS


def _no_block(path: Path, n_lines: int) -> Exception:
    return line_error(path, n_lines + 1, "a 'Trajectories' block (Vicon Nexus CSV export)", "none")


def _no_rows(path: Path, h: _Header) -> Exception:
    return line_error(path, h.data_start + 1, "at least one row of data", "none")


class _Header(NamedTuple):
    """What the lines of a Trajectories block before its data say: the rate [Hz], the
    marker labels, the row width, the length unit (None: no units row) and its line
    (1-based), the names line (1-based) and the index of the first data line."""

    rate: float
    labels: list[str]
    width: int
    units: str | None
    units_no: int
    names_no: int
    data_start: int

    @property
    def columns(self) -> list[str]:
        return ["Frame", "Sub Frame"] + [f"{lab}.{a}" for lab in self.labels for a in "XYZ"]

    def raw(self, path: Path, positions: np.ndarray, frames: np.ndarray) -> RawMarkers:
        """The RawMarkers of the block's positions (T, M, 3) [file units] and Frame column
        (T,), after the frame numbers' check."""
        check_times(path, frames, range(self.data_start + 1, self.data_start + 1 + len(frames)),
                    "Frame")  # fmt: skip
        return RawMarkers(
            format="vicon nexus csv",
            labels=self.labels,
            positions=positions,
            times=(frames - 1) / self.rate,
            rate=self.rate,
            units=self.units,
            units_where=f"line {self.units_no}",
            labels_where=f"line {self.names_no}",
            info={"first_frame": int(frames[0]) if np.isfinite(frames[0]) else None},
        )


def _header(path: Path, head: Sequence[str], top: int, n_lines: int) -> _Header:
    """The header of the Trajectories block at line index ``top`` of a file of ``n_lines``
    lines, from its lines ``head`` (top .. top + 4; fewer: the file ends there)."""
    if len(head) < 5:
        raise line_error(
            path, n_lines + 1, "rate, names, axes and units lines after 'Trajectories'",
            "end of file",
        )  # fmt: skip
    rate_no, names_no, axes_no, units_no = top + 2, top + 3, top + 4, top + 5
    rate = check_rate(path, rate_no, head[1].split(",")[0], "Trajectories rate")
    axes = _axes(path, head[3], axes_no)
    n_markers = (len(axes) - 2) // 3
    width = len(axes)
    labels = _labels(path, head[2], names_no, n_markers, width)
    units = _units(path, head[4], units_no, width)
    data_start = top + 4 if units is None else top + 5
    return _Header(rate, labels, width, units, units_no, names_no, data_start)


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


def _units(path: Path, line: str, units_no: int, width: int) -> str | None:
    """The length unit of the optional units row ``line`` (line ``units_no``), None when the
    line is not one (data rows start with a frame number)."""
    unit_cells = csv_cells(line)
    if not unit_cells or unit_cells[0].strip():
        return None
    unit_cells = unit_cells + [""] * (width - len(unit_cells))
    seen = sorted({c.strip() for c in unit_cells[2:width]})
    if len(seen) != 1 or not seen[0]:
        raise line_error(path, units_no, "one length unit for every column", show(seen))
    return seen[0]
