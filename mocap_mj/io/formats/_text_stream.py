"""Text marker files read chunk by chunk: the file's lines one at a time, a memory map of
the positions, and what :mod:`mocap_mj.io.stream` reads from it.

The text readers (``open_chunks`` of :mod:`~mocap_mj.io.formats.trc`,
:mod:`~mocap_mj.io.formats.mocap_csv`, :mod:`~mocap_mj.io.formats.nexus_csv` and
:mod:`~mocap_mj.io.formats.motive_csv`) check the whole file's layout in one
pass and parse its numbers in another, never holding the file: these are their shared parts.
"""

from __future__ import annotations

import codecs
import contextlib
import itertools
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mocap_mj.errors import InputFileError
from mocap_mj.io.formats._common import (
    RawMarkers,
    fit_row,
    line_error,
    parse_numbers,
    xyz_positions,
)

#: Lines read to find a header's end before the data.
HEAD_LINES = 64
#: Rows parsed at a time: their cells as Python strings take about 20 kB per row of 39
#: markers, 100 MB for 5,000 rows.
ROWS = 5_000


class TextChunks(NamedTuple):
    """A marker file read chunk by chunk: ``raw`` as the format's whole read gives it, its
    positions (T, M, 3) [file units] a memory map on an anonymous temporary file;
    ``frames``; ``read(start, stop)``: those frames' positions."""

    raw: RawMarkers
    frames: int
    read: Callable[[int, int], np.ndarray]


def encoding(path: Path) -> str:
    """ "utf-8-sig" if the whole file decodes as UTF-8, else "latin-1"
    (:func:`mocap_mj.io.formats._common.read_lines`'s choice), read 1 MB at a time."""
    decoder = codecs.getincrementaldecoder("utf-8")()
    with open(path, "rb") as handle:
        try:
            while block := handle.read(1 << 20):
                decoder.decode(block)
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            return "latin-1"
    return "utf-8-sig"


@contextlib.contextmanager
def lines(path: Path, encoding: str) -> Iterator[Iterator[str]]:
    """The file's lines as :func:`mocap_mj.io.formats._common.read_lines` splits them (on
    "\\n", a trailing "\\r" cut), decoded one at a time."""
    with open(path, "rb") as handle:

        def each() -> Iterator[str]:
            for k, raw in enumerate(handle):
                text = raw.decode(encoding if k == 0 else encoding.replace("-sig", ""))
                text = text[:-1] if text.endswith("\n") else text
                yield text[:-1] if text.endswith("\r") else text

        yield each()


def count_rows(path: Path, encoding: str, start: int, width: int) -> int:
    """The data rows of a comma-separated file whose data start at line ``start`` (0-based)
    and end at its last non-blank line: their number, every one checked by :func:`fit_row`
    (``width`` cells, no non-empty extra cell) as the whole reads check them before they
    parse a number, so that the first error in the file is the one raised; no row at all is
    an error at line ``start + 1``."""
    first_bad: tuple[int, InputFileError] | None = None
    last = -1
    with lines(path, encoding) as each:
        for n, line in enumerate(itertools.islice(each, start, None)):
            if line.strip():
                last = n
            if first_bad is None:
                try:
                    fit_row(path, start + 1 + n, line.split(","), width, "comma-separated cells")
                except InputFileError as exc:
                    first_bad = (n, exc)
    if last < 0:
        raise line_error(path, start + 1, "at least one row of data", "end of file")
    if first_bad is not None and first_bad[0] <= last:
        raise first_bad[1]
    return last + 1


def positions_map(frames: int, markers: int) -> np.ndarray:
    """A (frames, markers, 3) float memory map on an anonymous temporary file (gone with
    the array)."""
    return np.memmap(
        tempfile.TemporaryFile(prefix="mocap-mj-"), float, "w+", shape=(frames, markers, 3)
    )


def parse_rows(
    path: Path,
    encoding: str,
    start: int,
    n_rows: int,
    cells: Callable[[str], list[str]],
    columns: Sequence[str],
    chunk: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The data rows of a text marker file, ``chunk`` at a time: lines start .. start +
    n_rows - 1 (0-based; 1-based line numbers in errors), each cut into ``cells(line)``
    (``len(columns)`` of them: frame, time, then X, Y, Z per marker) and parsed by
    :func:`parse_numbers`. Returns the positions (n_rows, M, 3) [file units] in a memory map
    (:func:`positions_map`) and the first two columns (n_rows, 2) (frame and time)."""
    n_markers = (len(columns) - 2) // 3
    positions = positions_map(n_rows, n_markers)
    first_two = np.empty((n_rows, 2))
    with lines(path, encoding) as each:
        body = itertools.islice(each, start, start + n_rows)
        for s in range(0, n_rows, chunk):
            rows = [cells(line) for line in itertools.islice(body, chunk)]
            first = start + 1 + s
            block = parse_numbers(path, rows, range(first, first + len(rows)), columns)
            positions[s : s + len(rows)] = xyz_positions(block, 2, n_markers)
            first_two[s : s + len(rows)] = block[:, :2]
    return positions, first_two


def chunks_of(raw: RawMarkers, positions: np.ndarray) -> TextChunks:
    """The :class:`TextChunks` of ``raw`` whose positions are the memory map ``positions``."""
    positions.flush()  # type: ignore[attr-defined]

    def read(start: int, stop: int) -> np.ndarray:
        return np.asarray(positions[start:stop])

    return TextChunks(raw, len(positions), read)
