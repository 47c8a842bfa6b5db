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
    rate_from_times,
    read_lines,
    show,
    strip_trailing_empty,
    xyz_positions,
)

_MAX_HEADER_LINES = 16


def looks_like(first_line: str) -> bool:
    """True if a file whose first line is ``first_line`` is a Motive CSV export."""
    return first_line.lstrip().startswith("Format Version,")


def read(path: Path) -> RawMarkers:
    """Read the labelled markers of an OptiTrack Motive CSV export."""
    lines = read_lines(path)
    first = csv_cells(lines[0]) if lines else []
    meta = {first[i].strip(): first[i + 1].strip() for i in range(0, len(first) - 1, 2)}
    frame_idx = _frame_line(path, lines)
    axes = [c.strip() for c in strip_trailing_empty(csv_cells(lines[frame_idx]))]
    width = len(axes)
    types, names, kind_row, name_line = _header_rows(path, lines, frame_idx, width)
    columns, dropped = _marker_columns(path, frame_idx, axes, types, names, kind_row)
    labels = list(columns)
    block, row_lines = _data_block(path, lines, frame_idx, axes, columns)
    times = block[:, 1]
    check_times(path, times, row_lines, "Time (Seconds)")

    rate_key = next((k for k in ("Export Frame Rate", "Capture Frame Rate") if k in meta), None)
    if rate_key is not None:
        rate = check_rate(path, 1, meta[rate_key], rate_key)
    else:
        rate = rate_from_times(path, times, 1, "an 'Export Frame Rate' setting")
    return RawMarkers(
        format="optitrack motive csv",
        labels=labels,
        positions=xyz_positions(block, 2, len(labels)),
        times=times.copy(),
        rate=rate,
        units=meta.get("Length Units") or None,
        units_where="line 1",
        labels_where=f"line {name_line}",
        up_hint="y",
        dropped=dropped,
        info={k: meta[k] for k in ("Format Version", "Take Name", "Coordinate Space") if k in meta},
    )


def _frame_line(path: Path, lines: list[str]) -> int:
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
    path: Path, lines: list[str], frame_idx: int, width: int
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


def _data_block(
    path: Path,
    lines: list[str],
    frame_idx: int,
    axes: list[str],
    columns: dict[str, dict[str, int]],
) -> tuple[np.ndarray, list[int]]:
    """The data rows below the frame line as numbers (rows, 2 + 3 markers): frame, time and
    every marker's X, Y, Z; and the 1-based line number of each row."""
    width = len(axes)
    labels = list(columns)
    body = lines[frame_idx + 1 :]
    while body and not body[-1].strip():
        body.pop()
    if not body:
        raise line_error(path, frame_idx + 2, "at least one row of data", "end of file")
    keep = [0, 1] + [columns[n][a] for n in labels for a in "XYZ"]
    rows = []
    for n, line in enumerate(body):
        cells = fit_row(path, frame_idx + 2 + n, line.split(","), width, "comma-separated cells")
        rows.append([cells[j] for j in keep])
    row_lines = list(range(frame_idx + 2, frame_idx + 2 + len(rows)))
    column_names = [axes[0], axes[1]] + [f"{n}.{a}" for n in labels for a in "XYZ"]
    block = parse_numbers(path, rows, row_lines, column_names)
    return block, row_lines
