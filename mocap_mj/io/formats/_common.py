"""What every reader returns, and the text-parsing helpers the text readers share."""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.errors import InputFileError

#: Numeric cell: optional sign, digits with optional point, optional exponent (no inf, no "_").
_NUMBER = re.compile(r"\s*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*")
#: A cell meaning "no sample": empty, blank, or NaN as other tools write it.
_MISSING = re.compile(r"\s*(?:[nN][aA][nN])?\s*")
#: Characters that can appear in a block of numeric cells joined by \x1f (fast pre-check).
_NOT_NUMERIC_CHAR = re.compile(r"[^0-9eE+\-.nNaA \t\x1f]")


@dataclass
class RawMarkers:
    """Marker data as a reader found it: file labels, file units, file axes.

    Attributes
    ----------
    labels : list of str, length M
        Point labels as written in the file (subject prefixes included).
    positions : (T, M, 3) float [file units]
        NaN where a sample is missing (a sample is missing whole if any coordinate is).
    times : (T,) float [s]
        Time of each frame.
    rate : float [Hz]
        Frame rate.
    units : str or None
        The length unit the file states, verbatim; None when it states none.
    units_where : str
        Where the unit was read (for error messages), e.g. "group POINT:UNITS" or "line 3".
    labels_where : str
        Where the labels were read (for error messages), e.g. "group POINT:LABELS".
    up_hint : str or None
        Vertical axis the format or its metadata implies ("y" for Motive), if any.
    dropped : list of str
        Non-marker columns or points the reader left out, by label.
    non_markers : set of str
        Labels the file's own metadata says are not markers (model outputs); the loader
        drops them unless they are model marker names or the caller's marker map names them.
    subjects : list of str
        Subject names the file's metadata declares (C3D SUBJECTS:NAMES), if any.
    info : dict
        Format-specific facts worth keeping in the trajectory's ``source``.
    """

    format: str
    labels: list[str]
    positions: np.ndarray
    times: np.ndarray
    rate: float
    units: str | None
    units_where: str
    labels_where: str
    up_hint: str | None = None
    dropped: list[str] = field(default_factory=list)
    non_markers: set[str] = field(default_factory=set)
    subjects: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)


def show(value: object, limit: int = 60) -> str:
    """A one-line, bounded rendering of a value for an error message."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 4] + "...'"


def line_error(path: Path, line: int, expected: str, got: str) -> InputFileError:
    """``InputFileError("{path}: line {line}: expected {expected}, got {got}")``.

    ``got`` is already formatted: use :func:`show` for a cell's text.
    """
    return InputFileError(f"{path}: line {line}: expected {expected}, got {got}")


def read_lines(path: Path) -> list[str]:
    """The file's lines without end-of-line characters (UTF-8, else Latin-1)."""
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return [line[:-1] if line.endswith("\r") else line for line in lines]


def csv_cells(line: str) -> list[str]:
    """The cells of one comma-separated line, honouring quotes ("a,b" is one cell)."""
    try:
        return next(csv.reader([line]), [])
    except csv.Error:  # stray carriage return or the like: fall back to a plain split
        return line.split(",")


def strip_trailing_empty(cells: list[str]) -> list[str]:
    """Cells without the empty (or blank) cells at the end of the row."""
    end = len(cells)
    while end and not cells[end - 1].strip():
        end -= 1
    return cells[:end]


def fit_row(path: Path, line: int, cells: list[str], width: int, what: str) -> list[str]:
    """``cells`` cut to ``width``; error if the row is shorter or has non-empty extra cells."""
    if len(cells) < width or any(c.strip() for c in cells[width:]):
        raise line_error(path, line, f"{width} {what}", str(len(strip_trailing_empty(cells))))
    return cells[:width]


def parse_numbers(
    path: Path,
    rows: Sequence[Sequence[str]],
    lines: Sequence[int],
    columns: Sequence[str],
) -> np.ndarray:
    """Parse a block of numeric cells; empty/blank/NaN cells become NaN.

    Parameters
    ----------
    path : Path
        For error messages.
    rows : sequence of N sequences of C str
        The cells, already cut to the same width C.
    lines : sequence of N int
        1-based line number of each row, for error messages.
    columns : sequence of C str
        Column names, for error messages.

    Returns
    -------
    (N, C) float
    """
    n_cols = len(columns)
    if not rows:
        return np.empty((0, n_cols))
    flat = [cell for row in rows for cell in row]
    joined = "\x1f".join(flat)
    values: np.ndarray | None = None
    if _NOT_NUMERIC_CHAR.search(joined) is None:
        try:
            values = np.array([c if c.strip() else "nan" for c in flat], dtype=np.float64)
        except ValueError:
            values = None
        if values is not None and np.isinf(values).any():
            values = None
    if values is None:  # the cell-by-cell parse, which names the first bad cell
        parsed = [
            _parse_cell(path, line, j, cell, columns)
            for row, line in zip(rows, lines, strict=True)
            for j, cell in enumerate(row)
        ]
        values = np.array(parsed, dtype=np.float64)
    return values.reshape(len(rows), n_cols)


def _parse_cell(path: Path, line: int, j: int, cell: str, columns: Sequence[str]) -> float:
    if _MISSING.fullmatch(cell):
        return math.nan
    try:
        value = float(cell) if _NUMBER.fullmatch(cell) else math.inf
    except ValueError:
        value = math.inf
    if not math.isfinite(value):
        raise line_error(path, line, f"a number in column {j + 1} ({columns[j]})", show(cell))
    return value


def check_times(path: Path, times: np.ndarray, lines: Sequence[int], column: str) -> None:
    """Error unless ``times`` (T,) [s] are all present and strictly increasing."""
    for i in np.flatnonzero(np.isnan(times)):
        raise line_error(path, lines[int(i)], f"a value in column {column}", "an empty cell")
    steps = np.diff(times)
    for i in np.flatnonzero(~(steps > 0)):
        raise line_error(
            path,
            lines[int(i) + 1],
            f"{column} greater than on the previous row ({times[i]:g})",
            f"{times[i + 1]:g}",
        )


def rate_from_times(path: Path, times: np.ndarray, line: int, what: str) -> float:
    """Frame rate [Hz] from the median step of ``times`` (T,) [s]; error if T < 2."""
    if times.shape[0] < 2:
        raise line_error(path, line, f"{what} (one frame gives no rate)", "none")
    rate = float(1.0 / np.median(np.diff(times)))
    if not math.isfinite(rate):
        raise line_error(path, line, f"{what} (the time steps are too small)", f"{rate:g} Hz")
    return rate


def check_rate(path: Path, line: int, text: str, what: str) -> float:
    """Parse a frame rate [Hz] cell; error unless it is a positive finite number."""
    if _NUMBER.fullmatch(text) is None or not (0 < float(text) < math.inf):
        raise line_error(path, line, f"a positive frame rate ({what})", show(text))
    return float(text)


def xyz_positions(block: np.ndarray, first_col: int, n_markers: int, stride: int = 3) -> np.ndarray:
    """(T, M, 3) positions from a numeric block (T, C) whose marker triples start at first_col.

    A sample with any coordinate missing is set missing as a whole.
    """
    cols = first_col + np.arange(n_markers)[:, None] * stride + np.arange(3)[None, :]
    pos = block[:, cols]
    pos[np.isnan(pos).any(axis=2)] = np.nan
    return pos
