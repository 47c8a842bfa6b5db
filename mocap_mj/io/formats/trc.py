"""OpenSim TRC marker files: read and write.

Layout (tab-separated)::

    PathFileType  4  (X/Y/Z)  trial.trc
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  ...
    100       100         250        39          mm     100           ...
    Frame#  Time  LASI        RASI        ...
                  X1  Y1  Z1  X2  Y2  Z2  ...
    (optional blank line)
    1       0.00  ...

The reader accepts every variant OpenSim's own TRCFileAdapter reads, and the unambiguous ones
other tools write:

- tabs or spaces between cells; doubled tabs and empty cells in the header lines (ignored,
  as OpenSim does); ``Time`` or ``Times``; Windows line ends; frame numbers starting anywhere;
- fewer keys than OpenSim's eight on line 2 (NumMarkers, and DataRate or CameraRate or two
  rows of Time, are needed);
- a missing, short or long X/Y/Z line: marker k's columns are 3k .. 3k + 2 (1-based, after
  Frame# and Time) whatever it says, as long as it does not contradict that order;
- data rows with empty columns the header does not count (columns empty in every row are
  dropped when that leaves one column per header cell), or with unnamed columns after the
  last marker's Z (ignored, counted in ``info["ignored_columns"]``); a tab-separated row that
  ends early has its last samples missing;
- a data section with fewer or more rows than NumFrames: read whole, with a warning.

Refused, with the line and what was expected: a marker-name count that differs from
NumMarkers, an X/Y/Z cell out of order, a space-separated row of the wrong width, a
tab-separated row narrower than the header when other rows are wider (no way to tell which
columns are missing), and a blank line inside the data.

An empty (or NaN) cell is a missing sample. The writer keeps the trajectory's axes (the
model's Z-up world); OpenSim's own convention is Y up, so rotate on import there if needed.
"""

from __future__ import annotations

import itertools
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.formats._common import (
    RawMarkers,
    check_rate,
    check_times,
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
    parse_rows,
)
from mocap_mj.io.formats._text_stream import encoding as text_encoding
from mocap_mj.io.formats._text_stream import lines as text_lines
from mocap_mj.io.formats.mocap_csv import _check_writable_names, _format_rows
from mocap_mj.io.trajectory import MarkerTrajectory

_INT = re.compile(r"\s*\d+\s*")
_AXIS = re.compile(r"[XYZ]\d*", re.IGNORECASE)
_NUMERIC = re.compile(r"\s*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*")


def looks_like(first_line: str) -> bool:
    """True if a file whose first line is ``first_line`` is a TRC file."""
    return first_line.lstrip().startswith("PathFileType")


def _cells(line: str) -> list[str]:
    """Header cells: split on tabs (names may hold spaces) or else on spaces; no empty cells."""
    parts = line.split("\t") if "\t" in line else line.split()
    return [c.strip() for c in parts if c.strip()]


def read(path: Path) -> RawMarkers:
    """Read an OpenSim TRC file (see the module docstring for the layout and leniencies)."""
    lines = read_lines(path)
    head = _header(path, lines)
    start = head.start
    body = lines[start:]
    while body and not body[-1].strip():
        body.pop()
    if not body:
        raise line_error(path, start + 1, "at least one row of data", "end of file")
    for n, line in enumerate(body):
        if not line.strip():
            raise line_error(path, start + 1 + n, "a row of data (no blank line inside)", "none")
    rows, ignored = _data_cells(path, body, start + 1, head.width)
    row_lines = list(range(start + 1, start + 1 + len(rows)))
    block = parse_numbers(path, rows, row_lines, head.columns)
    check_times(path, block[:, 1], row_lines, "Time")
    positions = xyz_positions(block, 2, head.n_markers)
    return head.raw(path, positions, block[:, 1].copy(), ignored, float(block[0, 0]))


class _Header(NamedTuple):
    """What a TRC file's header lines say: marker names, the rate (None: from the times),
    NumFrames (None if absent), the units, and the index of the first data line."""

    names: list[str]
    n_frames: int | None
    rate: float | None
    units: str | None
    start: int

    @property
    def n_markers(self) -> int:
        return len(self.names)

    @property
    def width(self) -> int:
        return 2 + 3 * self.n_markers

    @property
    def columns(self) -> list[str]:
        return ["Frame#", "Time"] + [f"{n}.{a}" for n in self.names for a in "XYZ"]

    def raw(
        self, path: Path, positions: np.ndarray, times: np.ndarray, ignored: int, first: float
    ) -> RawMarkers:
        """The RawMarkers of the file's positions (T, M, 3) and times (T,) [s]; ``first``: the
        Frame# of the first row (NaN: not given)."""
        rate = self.rate
        if rate is None:
            rate = rate_from_times(path, times, self.start + 1, "DataRate or two rows of Time")
        warnings = []
        if self.n_frames is not None and self.n_frames != len(times):
            warnings.append(
                f"{path}: line 3: NumFrames is {self.n_frames}, the file holds {len(times)} rows "
                f"of data: read the {len(times)} rows present"
            )
        return RawMarkers(
            format="trc",
            labels=self.names,
            positions=positions,
            times=times,
            rate=rate,
            units=self.units,
            units_where="line 3",
            labels_where="line 4",
            info={
                "warnings": warnings,
                "ignored_columns": ignored,
                "first_frame": int(first) if np.isfinite(first) else None,
            },
        )


def _header(path: Path, lines: Sequence[str]) -> _Header:
    """The header of a TRC file whose first lines are ``lines`` (its data start included)."""
    if len(lines) < 4:
        raise line_error(path, len(lines) + 1, "the 4 header lines of a TRC file", "end of file")
    keys, values = _cells(lines[1]), _cells(lines[2])
    if "NumMarkers" not in keys or len(values) < keys.index("NumMarkers") + 1:
        raise line_error(
            path, 2, "TRC header keys (DataRate ... NumFrames NumMarkers Units) over values",
            show(lines[1]),
        )  # fmt: skip
    header = dict(zip(keys, values, strict=False))
    for key in ("NumFrames", "NumMarkers"):
        if key in header and _INT.fullmatch(header[key]) is None:
            raise line_error(path, 3, f"a whole number for {key}", show(header[key]))
    n_markers = int(header["NumMarkers"])
    n_frames = int(header["NumFrames"]) if "NumFrames" in header else None
    rate_key = "DataRate" if "DataRate" in header else "CameraRate"
    rate = check_rate(path, 3, header[rate_key], rate_key) if rate_key in header else None
    units = header.get("Units") or None
    names = _marker_names(path, lines[3], n_markers)
    start = 4
    if start < len(lines) and _is_axes_line(lines[start]):
        _check_axes(path, lines[start], n_markers)
        start += 1
    while start < len(lines) and not lines[start].strip():
        start += 1
    return _Header(names, n_frames, rate, units, start)


def _marker_names(path: Path, line: str, n_markers: int) -> list[str]:
    cells = _cells(line)
    if (
        len(cells) < 2
        or not cells[0].lower().startswith("frame")
        or cells[1].lower() not in ("time", "times")
    ):
        raise line_error(path, 4, "'Frame#' and 'Time' then marker names", show(line))
    names = cells[2:]
    if len(names) != n_markers:
        raise line_error(
            path, 4, f"NumMarkers={n_markers} marker names (line 3)", f"{len(names)} names"
        )
    return names


def _is_axes_line(line: str) -> bool:
    """True for the X1 Y1 Z1 ... line (possibly empty, short or long); False for data."""
    cells = _cells(line)
    return all(_AXIS.fullmatch(c) for c in cells) and not (
        cells and all(_NUMERIC.fullmatch(c) for c in cells)
    )


def _check_axes(path: Path, line: str, n_markers: int) -> None:
    """Error if the X/Y/Z line contradicts the column order (a cell out of place)."""
    for k, cell in enumerate(_cells(line)[: 3 * n_markers]):
        want = f"{'XYZ'[k % 3]}{k // 3 + 1}"
        if cell.upper() not in (want, want[0]):
            raise line_error(path, 5, f"{want} in X/Y/Z cell {k + 1} (or no cell)", show(cell))


def _data_cells(
    path: Path, body: list[str], first_line: int, width: int
) -> tuple[list[list[str]], int]:
    """Each row cut to ``width`` cells, and how many unnamed trailing columns were ignored."""
    tabbed = any("\t" in line for line in body)
    raw = [line.split("\t") if tabbed else line.split() for line in body]
    used = [len(strip_trailing_empty(r)) for r in raw]
    if max(used) <= width:
        narrow = [k for k, n in enumerate(used) if n < (2 if tabbed else width)]
        if narrow:
            k = narrow[0]
            raise line_error(path, first_line + k, f"{width} cells (Frame#, Time, 3 per marker)",
                             str(used[k]))  # fmt: skip
        return [r[:width] + [""] * (width - len(r)) for r in raw], 0
    n_cols = max(len(r) for r in raw)
    padded = [r + [""] * (n_cols - len(r)) for r in raw]
    filled = np.array([[bool(c.strip()) for c in r] for r in padded])
    kept = np.flatnonzero(filled.any(axis=0))
    if len(kept) == width:  # doubled tabs or empty columns the header does not count
        return [[r[j] for j in kept] for r in padded], 0
    short = [k for k, r in enumerate(raw) if len(r) < width]
    if short:
        k = short[0]
        raise line_error(
            path, first_line + k, f"{width} cells (Frame#, Time, 3 per marker) as on other rows",
            str(used[k]),
        )  # fmt: skip
    return [r[:width] for r in raw], n_cols - width


def save_trc(path: str | os.PathLike[str], traj: MarkerTrajectory) -> None:
    """Write ``traj`` as an OpenSim TRC file in millimetres, atomically.

    Coordinates are written with 6 decimals in mm (1e-9 m steps), in the trajectory's own
    Z-up axes; missing samples as empty cells. Frames keep the recording's own numbers
    (``traj.source["first_frame"]``, also written as OrigDataStartFrame), from 1 when it
    numbers none.

    Parameters
    ----------
    path : str or PathLike
        Destination; replaced whole, or left as it was if writing fails.
    traj : MarkerTrajectory
        Positions (T, M, 3) [m] in the model's Z-up world.
    """
    target = Path(path)
    _check_writable_names(target, traj.names, "\t\n\r ")
    rate = f"{traj.rate:.10g}"  # 100, not 99.99999999999991 from a clock's float steps
    given = traj.source.get("first_frame")
    first = 1 if given is None else int(given)
    names = "\t".join(f"{n}\t\t" for n in traj.names)
    axes = "\t".join(f"X{k}\tY{k}\tZ{k}" for k in range(1, traj.n_markers + 1))
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{target.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate}\t{rate}\t{traj.n_frames}\t{traj.n_markers}\tmm\t{rate}\t{first}\t{traj.n_frames}",
        f"Frame#\tTime\t{names}",
        f"\t\t{axes}",
        "",
        *_format_rows(traj, "\t", first),
    ]
    atomic_write_text(target, "\n".join(lines) + "\n")


def open_chunks(path: Path, chunk: int = ROWS) -> TextChunks | str:
    """Read a TRC file ``chunk`` rows at a time into a memory map of its positions, with
    :func:`read`'s rules and errors, or say why it is read whole (the reason, a str).

    Three passes over the file, none holding it: the encoding (UTF-8, else Latin-1, as
    :func:`read_lines` decides for the whole file), the rows' layout (blank lines, tabs, the
    cells each row uses: the rules of :func:`_data_cells`, which look at every row), then the
    numbers, parsed ``chunk`` rows at a time by :func:`parse_numbers` into the memory map.
    Rows wider than the header (unnamed or empty extra columns, whose handling depends on
    every row at once) are left to :func:`read`.
    """
    encoding = text_encoding(path)
    with text_lines(path, encoding) as lines:
        head = list(itertools.islice(lines, HEAD_LINES))
    h = _header(path, head)
    if h.start >= HEAD_LINES:
        return f"more than {HEAD_LINES} lines before the data"
    layout = _layout(path, encoding, h)
    if isinstance(layout, str):
        return layout
    tabbed, n = layout

    def cells(line: str) -> list[str]:
        r = line.split("\t") if tabbed else line.split()
        return r[: h.width] + [""] * (h.width - len(r))

    positions, first_two = parse_rows(path, encoding, h.start, n, cells, h.columns, chunk)
    times = first_two[:, 1].copy()
    check_times(path, times, range(h.start + 1, h.start + 1 + n), "Time")
    return chunks_of(h.raw(path, positions, times, 0, float(first_two[0, 0])), positions)


def _layout(path: Path, encoding: str, h: _Header) -> tuple[bool, int] | str:
    """Whether the data rows are tab-separated and how many there are, checked as
    :func:`read` and :func:`_data_cells` check them (blank lines, narrow rows: the same
    errors); the reason to read the file whole when a row is wider than the header."""
    tabbed, last = False, -1
    blank: int | None = None  # the first of the blank lines since the last row
    inside: int | None = None  # the first blank line followed by a row
    tab_used: list[int] = []
    space_used: list[int] = []
    with text_lines(path, encoding) as lines:
        for n, line in enumerate(itertools.islice(lines, h.start, None)):
            if not line.strip():
                blank = n if blank is None else blank
            else:
                inside = blank if inside is None else inside
                blank, last = None, n
                tabbed = tabbed or "\t" in line
            tab_used.append(len(strip_trailing_empty(line.split("\t"))))
            space_used.append(len(line.split()))
    if last < 0:
        raise line_error(path, h.start + 1, "at least one row of data", "end of file")
    if inside is not None:
        raise line_error(path, h.start + 1 + inside, "a row of data (no blank line inside)", "none")
    used = (tab_used if tabbed else space_used)[: last + 1]
    if max(used) > h.width:
        return "rows wider than the header (read whole: which columns to keep needs every row)"
    for k, u in enumerate(used):
        if u < (2 if tabbed else h.width):
            raise line_error(path, h.start + 1 + k, f"{h.width} cells (Frame#, Time, 3 per "
                             "marker)", str(u))  # fmt: skip
    return tabbed, last + 1
