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

import itertools
import os
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

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
    h = _header(path, lines)
    body = lines[h.start :]
    while body and not body[-1].strip():
        body.pop()
    if not body:
        raise _no_rows(path, h)
    rows = [
        fit_row(path, h.line + 1 + n, line.split(","), h.width, "comma-separated cells")
        for n, line in enumerate(body)
    ]
    row_lines = list(range(h.line + 1, h.line + 1 + len(rows)))
    block = parse_numbers(path, rows, row_lines, h.columns)
    return h.raw(path, xyz_positions(block, 2, len(h.names)), block[:, 0], block[:, 1].copy())


class _Header(NamedTuple):
    """What a mocap-mj CSV's lines before the data say: the comment's settings and its line
    (0: none), the column header's cells and line (1-based), the marker names."""

    meta: dict[str, str]
    meta_line: int
    columns: list[str]
    line: int
    names: list[str]

    @property
    def width(self) -> int:
        return len(self.columns)

    @property
    def start(self) -> int:
        """Index of the first data line."""
        return self.line

    def raw(
        self, path: Path, positions: np.ndarray, frames: np.ndarray, times: np.ndarray
    ) -> RawMarkers:
        """The RawMarkers of the file's positions (T, M, 3), frame column (T,) and times
        (T,) [s], after the checks of the whole file (frame numbers, times, rate, up)."""
        row_lines = range(self.line + 1, self.line + 1 + len(times))
        for i_missing in np.flatnonzero(np.isnan(frames)):
            raise line_error(path, row_lines[int(i_missing)], "a frame number", "an empty cell")
        check_times(path, times, row_lines, "time")
        meta, meta_line = self.meta, self.meta_line
        if "rate" in meta:
            rate = check_rate(path, meta_line, meta["rate"], "rate= in the header comment")
        else:
            rate = rate_from_times(path, times, self.line, "a rate= setting in a '# mocap-mj' line")
        up = meta.get("up")
        if up is not None and up.lower().lstrip("+") not in UP_AXES:
            raise line_error(path, meta_line, f"up= one of {', '.join(UP_AXES)}", show(up))
        return RawMarkers(
            format="mocap-mj csv",
            labels=self.names,
            positions=positions,
            times=times,
            rate=rate,
            units=meta.get("units", "mm"),
            units_where=f"line {meta_line}" if "units" in meta else "mocap-mj csv default (mm)",
            labels_where=f"line {self.line}",
            up_hint=up.lower() if up else None,
            info={"up_stated": up is not None, "first_frame": int(frames[0])},
        )


def _no_rows(path: Path, h: _Header) -> Exception:
    return line_error(path, h.line + 1, "at least one row of data", "end of file")


def _header(path: Path, lines: Sequence[str]) -> _Header:
    """The header of a mocap-mj CSV whose first lines are ``lines`` (its column header
    included)."""
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
    return _Header(meta, meta_line, header, header_no, names)


def open_chunks(path: Path, chunk: int = ROWS) -> TextChunks | str:
    """Read a mocap-mj CSV ``chunk`` rows at a time into a memory map of its positions, with
    :func:`read`'s rules and errors, or say why it is read whole (the reason, a str).

    Three passes over the file, none holding it: the encoding (as :func:`read_lines`
    decides it for the whole file), the rows' widths (:func:`fit_row`'s rule on every row
    before the last non-blank one, the first error in the file raised, as :func:`read`
    checks every row before it parses one), then the numbers, ``chunk`` rows at a time
    (:func:`parse_numbers`, whose first bad cell is the whole file's first)."""
    encoding = text_encoding(path)
    with text_lines(path, encoding) as lines:
        head = list(itertools.islice(lines, HEAD_LINES))
    h = _header(path, head)
    if h.start >= HEAD_LINES:
        return f"more than {HEAD_LINES} lines before the data"
    n_rows = count_rows(path, encoding, h.start, h.width)
    positions, first_two = parse_rows(
        path, encoding, h.start, n_rows, lambda line: line.split(",")[: h.width], h.columns, chunk
    )
    frames, times = first_two[:, 0].copy(), first_two[:, 1].copy()
    return chunks_of(h.raw(path, positions, frames, times), positions)


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
