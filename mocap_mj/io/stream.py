"""``open_markers``: a marker file read chunk by chunk, as :func:`load_markers` reads it whole.

An hour at 100 Hz holds 360,000 frames: 39 markers in float64 are 340 MB, and the C3D
reader (ezc3d) holds every point, analog sample and residual of the file besides. Here a
C3D file's point block is read from a memory map of its fixed-size frame records
(:func:`mocap_mj.io.formats.c3d.open_chunks`), ``chunk`` frames at a time, and a TRC file's
rows are parsed a few thousand at a time into a memory map
(:func:`mocap_mj.io.formats.trc.open_chunks`); the names, units, vertical axis and
missing-sample rules are :func:`load_markers`' own (:class:`mocap_mj.io.load.Reading`), so
that both give the same positions bit for bit. Other files (DEC/MIPS C3D, TRC rows wider
than the header, text files with more than 64 lines before the data) are read whole and
served from memory: ``how`` says which and why.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.lib.format import open_memmap

from mocap_mj.io.formats import c3d, detect_format, mocap_csv, motive_csv, nexus_csv, trc
from mocap_mj.io.load import Reading, _arguments, _selection, load_markers
from mocap_mj.io.marker_names import MARKER_NAMES
from mocap_mj.io.trajectory import MarkerReport, first_frame, marker_report

__all__ = ["CHUNK", "MarkerStream", "open_markers"]

#: Frames converted at a time [frames]: 20,000 frames of 60 points are 30 MB.
CHUNK = 20_000


class MarkerStream:
    """A marker file's markers in metres, Z up, with model names, read ``chunk`` frames at a
    time (:func:`open_markers`).

    Attributes
    ----------
    names : (M,) str, the markers kept, in the file's order (as :func:`load_markers`)
    times : (T,) float [s]
    rate : float [Hz]
    source : dict, :func:`load_markers`' ``source`` record
    how : str, "in chunks" or why the file was read whole
    """

    def __init__(
        self,
        names: Sequence[str],
        times: np.ndarray,
        rate: float,
        source: dict[str, Any],
        read: Any,
        how: str,
    ) -> None:
        self.names, self.times, self.rate = tuple(names), np.asarray(times), float(rate)
        self.source, self.how, self._read = source, how, read

    @property
    def n_frames(self) -> int:
        return len(self.times)

    @property
    def first_frame(self) -> int:
        """The recording's own number of frame 0 (:func:`~mocap_mj.io.trajectory.first_frame`)."""
        return first_frame(self.source)

    def positions(self, start: int, stop: int) -> np.ndarray:
        """Frames [start, stop) (n, M, 3) [m], NaN where missing."""
        start, stop = max(0, start), min(stop, self.n_frames)
        return np.asarray(self._read(start, stop))

    def chunks(self, chunk: int = CHUNK) -> Iterator[tuple[int, np.ndarray]]:
        """(first frame, positions (n, M, 3) [m]) of every ``chunk`` frames."""
        for s in range(0, self.n_frames, chunk):
            yield s, self.positions(s, s + chunk)

    def marker_report(self, model_names: Sequence[str] = MARKER_NAMES) -> MarkerReport:
        """As :meth:`mocap_mj.io.trajectory.MarkerTrajectory.marker_report`."""
        missing = self.source.get("missing_samples", {})
        absent = np.array([missing.get(n, 0) for n in self.names], dtype=int)
        return marker_report(self.names, self.n_frames, absent, self.source, model_names)

    def select_to_npy(self, names: Sequence[str], path: Path, chunk: int = CHUNK) -> np.ndarray:
        """The markers ``names`` (in that order; all-NaN columns for names the file lacks)
        of every frame written into the ``.npy`` file ``path``, chunk by chunk; returns it
        memory-mapped (T, K, 3) [m]."""
        index = {n: i for i, n in enumerate(self.names)}
        cols = [(k, index[n]) for k, n in enumerate(names) if n in index]
        out = open_memmap(path, mode="w+", dtype=np.float64, shape=(self.n_frames, len(names), 3))
        for s, pos in self.chunks(chunk):
            block = np.full((len(pos), len(names), 3), np.nan)
            for k, i in cols:
                block[:, k] = pos[:, i]
            out[s : s + len(pos)] = block
        out.flush()
        return out


def open_markers(
    path: str | os.PathLike[str],
    *,
    subject: str | None = None,
    marker_map: Mapping[str, str] | str | os.PathLike[str] | None = None,
    up: str | None = None,
    units: str | None = None,
    model_names: Collection[str] = MARKER_NAMES,
    chunk: int = CHUNK,
) -> MarkerStream:
    """Open a marker file as :func:`load_markers` reads it (same arguments, same names,
    units, vertical axis, missing samples and errors), its positions read on demand.

    C3D files with Intel float or 16-bit integer points are read in chunks from a memory
    map (:func:`mocap_mj.io.formats.c3d.open_chunks`), text files (TRC, mocap-mj, Nexus
    and Motive CSV) parsed in chunks into one (``open_chunks`` of the format's module):
    the positions are read for the units check, the missing-sample counts and the vertical
    axis, then as the caller asks, never held, ``chunk`` frames at a time. Any other file
    is read whole by :func:`load_markers`.
    """
    file, wanted_up, rename = _arguments(path, marker_map, up, units)
    fmt = detect_format(file)
    reason = f"{fmt} files are read whole"
    readers = {
        "c3d": c3d.open_chunks,
        "trc": lambda f: trc.open_chunks(f, min(chunk, trc.ROWS)),
        "mocap-mj csv": lambda f: mocap_csv.open_chunks(f, min(chunk, mocap_csv.ROWS)),
        "vicon nexus csv": lambda f: nexus_csv.open_chunks(f, min(chunk, nexus_csv.ROWS)),
        "optitrack motive csv": lambda f: motive_csv.open_chunks(f, min(chunk, motive_csv.ROWS)),
    }
    if fmt in readers:
        opened = readers[fmt](file)
        if not isinstance(opened, str):
            sel = _selection(file, opened.raw, subject, rename, model_names)

            def spans() -> Iterator[np.ndarray]:
                for s in range(0, opened.frames, chunk):
                    yield opened.read(s, min(s + chunk, opened.frames))

            reading = Reading(file, opened.raw, sel, units, wanted_up, rename, spans)

            def read(start: int, stop: int) -> np.ndarray:
                return reading.convert(opened.read(start, stop))

            raw = opened.raw
            return MarkerStream(sel.names, raw.times, raw.rate, reading.source, read, "in chunks")
        reason = opened
    traj = load_markers(
        file, subject=subject, marker_map=marker_map, up=up, units=units, model_names=model_names
    )

    def whole(start: int, stop: int) -> np.ndarray:
        return traj.positions[start:stop]

    return MarkerStream(
        traj.names, traj.times, traj.rate, traj.source, whole, f"read whole: {reason}"
    )
