"""OptiTrack Motive CSV export: labelled marker positions only.

Layout (format version 1.2x)::

    Format Version,1.23,Take Name,...,Export Frame Rate,120.000000,...,Length Units,Millimeters,...
    (blank)
    ,Type,Marker,Marker,Marker,Rigid Body,...
    ,Name,Skel:LASI,Skel:LASI,Skel:LASI,RB1,...
    ,ID,1,1,1,...
    (,Parent,... in some versions)
    ,,Position,Position,Position,Rotation,...
    Frame,Time (Seconds),X,Y,Z,X,...
    0,0.000000,...

Only columns of Type ``Marker`` and kind ``Position`` are kept; rigid bodies, bones and
their markers are dropped. Motive's world is Y-up unless the export says otherwise.
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
    rate_from_times,
    read_lines,
    show,
    strip_trailing_empty,
    xyz_positions,
)
from mocap_mj.io.formats._text_stream import (
    HEAD_LINES,
    ROWS,
    TextChunks,
    chunks_of,
    count_rows,
    parse_rows,
)
from mocap_mj.io.formats._text_stream import encoding as text_encoding
from mocap_mj.io.formats._text_stream import lines as text_lines

_MAX_HEADER_LINES = 16


def looks_like(first_line: str) -> bool:
    """True if a file whose first line is ``first_line`` is a Motive CSV export."""
    return first_line.lstrip().startswith("Format Version,")


def read(path: Path) -> RawMarkers:
    """Read the labelled markers of an OptiTrack Motive CSV export."""
    lines = read_lines(path)
    h = _header(path, lines)
    body = lines[h.start :]
    while body and not body[-1].strip():
        body.pop()
    if not body:
        raise line_error(path, h.start + 1, "at least one row of data", "end of file")
    rows = []
    for n, line in enumerate(body):
        cells = fit_row(path, h.start + 1 + n, line.split(","), h.width, "comma-separated cells")
        rows.append([cells[j] for j in h.keep])
    row_lines = list(range(h.start + 1, h.start + 1 + len(rows)))
    block = parse_numbers(path, rows, row_lines, h.column_names)
    positions = xyz_positions(block, 2, len(h.labels))
    return h.raw(path, positions, block[:, 1].copy(), float(block[0, 0]))


def open_chunks(path: Path, chunk: int = ROWS) -> TextChunks:
    """Read the labelled markers ``chunk`` rows at a time into a memory map of their
    positions, with :func:`read`'s rules and errors.

    Three passes over the file, none holding it: the encoding (as :func:`read_lines`
    decides it for the whole file), the rows' widths (:func:`count_rows`: every row up to
    the last non-blank one, the first error in the file raised, as :func:`read` checks
    every row before it parses one), then the marker columns' numbers, ``chunk`` rows at a
    time (:func:`parse_numbers`, whose first bad cell is the whole file's first)."""
    encoding = text_encoding(path)
    with text_lines(path, encoding) as lines:
        head = list(itertools.islice(lines, HEAD_LINES))
    h = _header(path, head)
    n_rows = count_rows(path, encoding, h.start, h.width)

    def cells(line: str) -> list[str]:
        row = line.split(",")
        return [row[j] for j in h.keep]

    positions, first_two = parse_rows(path, encoding, h.start, n_rows, cells, h.column_names, chunk)
    return chunks_of(
        h.raw(path, positions, first_two[:, 1].copy(), float(first_two[0, 0])), positions
    )


class _Header(NamedTuple):
    """What a Motive export says before its data: the first line's settings, the marker
    columns (name -> axis -> column), the columns dropped as not markers, the axes line's
    cells, the Name row's line (1-based) and the index of the first data line."""

    meta: dict[str, str]
    columns: dict[str, dict[str, int]]
    dropped: list[str]
    axes: list[str]
    name_line: int
    start: int

    @property
    def labels(self) -> list[str]:
        return list(self.columns)

    @property
    def width(self) -> int:
        return len(self.axes)

    @property
    def keep(self) -> list[int]:
        """The columns read: frame, time and every marker's X, Y, Z."""
        return [0, 1] + [self.columns[n][a] for n in self.labels for a in "XYZ"]

    @property
    def column_names(self) -> list[str]:
        return self.axes[:2] + [f"{n}.{a}" for n in self.labels for a in "XYZ"]

    def raw(self, path: Path, positions: np.ndarray, times: np.ndarray, first: float) -> RawMarkers:
        """The RawMarkers of the positions (T, M, 3) [file units] and times (T,) [s], after
        the times' check and the rate's; ``first``: the Frame of the first row (NaN: none)."""
        check_times(path, times, range(self.start + 1, self.start + 1 + len(times)),
                    "Time (Seconds)")  # fmt: skip
        meta = self.meta
        rate_key = next((k for k in ("Export Frame Rate", "Capture Frame Rate") if k in meta), None)
        if rate_key is not None:
            rate = check_rate(path, 1, meta[rate_key], rate_key)
        else:
            rate = rate_from_times(path, times, 1, "an 'Export Frame Rate' setting")
        return RawMarkers(
            format="optitrack motive csv",
            labels=self.labels,
            positions=positions,
            times=times,
            rate=rate,
            units=meta.get("Length Units") or None,
            units_where="line 1",
            labels_where=f"line {self.name_line}",
            up_hint="y",
            dropped=self.dropped,
            info={
                **{
                    k: meta[k]
                    for k in ("Format Version", "Take Name", "Coordinate Space")
                    if k in meta
                },
                "first_frame": int(first) if np.isfinite(first) else None,
            },
        )


def _header(path: Path, lines: Sequence[str]) -> _Header:
    """The header of a Motive export whose first lines (at least its first
    ``_MAX_HEADER_LINES``, or all) are ``lines``."""
    first = csv_cells(lines[0]) if lines else []
    meta = {first[i].strip(): first[i + 1].strip() for i in range(0, len(first) - 1, 2)}
    frame_idx = _frame_line(path, lines)
    axes = [c.strip() for c in strip_trailing_empty(csv_cells(lines[frame_idx]))]
    types, names, kind_row, name_line = _header_rows(path, lines, frame_idx, len(axes))
    columns, dropped = _marker_columns(path, frame_idx, axes, types, names, kind_row)
    return _Header(meta, columns, dropped, axes, name_line, frame_idx + 1)


def _frame_line(path: Path, lines: Sequence[str]) -> int:
    """Index of the 'Frame,Time (Seconds),X,Y,Z,...' line within the header."""
    frame_idx = next(
        (
            i
            for i, ln in enumerate(lines[:_MAX_HEADER_LINES])
            if [c.strip().lower() for c in ln.split(",")[:2]] == ["frame", "time (seconds)"]
        ),
        None,
    )
    if frame_idx is None:
        raise line_error(
            path,
            min(len(lines), _MAX_HEADER_LINES) + 1,
            "a 'Frame,Time (Seconds),X,Y,Z,...' line in the header",
            "none",
        )
    return frame_idx


def _header_rows(
    path: Path, lines: Sequence[str], frame_idx: int, width: int
) -> tuple[list[str], list[str], list[str], int]:
    """The Type, Name and kind (',,Position,...') rows above the frame line, each padded to
    ``width`` cells, and the 1-based line number of the Name row."""
    rows_by_label: dict[str, list[str]] = {}
    line_of: dict[str, int] = {}
    kind_row: list[str] | None = None
    for i in range(1, frame_idx):
        cells = csv_cells(lines[i])
        if not any(c.strip() for c in cells):
            continue
        cells = (cells + [""] * width)[: max(width, len(cells))]
        label = cells[0].strip() or cells[1].strip()
        if label:
            rows_by_label[label] = cells
            line_of[label] = i + 1
        else:
            kind_row = cells
    for label, row in (("Type", rows_by_label.get("Type")), ("Name", rows_by_label.get("Name"))):
        if row is None:
            raise line_error(path, frame_idx, f"a ',{label},...' row above this line", "none")
    if kind_row is None:
        raise line_error(path, frame_idx, "a ',,Position,...' row above this line", "none")
    types, names = rows_by_label["Type"], rows_by_label["Name"]
    name_line = line_of["Name"]
    return types, names, kind_row, name_line


def _marker_columns(
    path: Path,
    frame_idx: int,
    axes: list[str],
    types: list[str],
    names: list[str],
    kind_row: list[str],
) -> tuple[dict[str, dict[str, int]], list[str]]:
    """The X, Y and Z column of every marker's position (name -> axis -> column) and the
    columns dropped as not markers ('name (type)')."""
    columns: dict[str, dict[str, int]] = {}
    dropped: list[str] = []
    for j in range(2, len(axes)):
        kind, name = types[j].strip(), names[j].strip()
        if kind != "Marker":
            tag = f"{name} ({kind or 'no type'})"
            if tag not in dropped:
                dropped.append(tag)
            continue
        if kind_row[j].strip() != "Position":
            continue
        axis = axes[j].upper()
        if axis not in ("X", "Y", "Z") or axis in columns.setdefault(name, {}):
            raise line_error(
                path, frame_idx + 1, f"one X, Y and Z column for marker {name!r}", show(axes[j])
            )
        columns[name][axis] = j
    for name, cols in columns.items():
        if len(cols) != 3:
            raise line_error(
                path, frame_idx + 1, f"X, Y and Z columns for marker {name!r}", show(sorted(cols))
            )
    return columns, dropped
