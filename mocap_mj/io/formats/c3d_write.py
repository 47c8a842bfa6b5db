"""Marker-only C3D files of any length: an hour at 100 Hz is 360,000 frames.

The C3D header counts frames in 16 bits (at most 65,535) and ezc3d 1.7.2 writes and reads
no more. Longer recordings keep the header's count at its limit and state the true count
in TRIAL:ACTUAL_START_FIELD / ACTUAL_END_FIELD (as Vicon does: two 16-bit words each, low
word first) and POINT:LONG_FRAMES (as C3Dserver does: a float); the data section holds every
frame. :func:`mocap_mj.io.formats.c3d.open_chunks` reads them. The header and parameters
are ezc3d's (it writes the header's frames); the frame records are written here, chunk by
chunk, in ezc3d's encoding (Intel floats, millimetres; a missing sample is x = y = z = 0
with the fourth word -1.0, a present one 0.0), which is checked against ezc3d's own records
of those frames.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.io.atomic import atomic_path
from mocap_mj.io.formats.c3d_check import check_c3d
from mocap_mj.io.ownership import scratch_folder

#: The header's largest frame count (16 bits).
HEADER_FRAMES = 65_535
#: Frames encoded at a time.
CHUNK = 20_000


def frame_records(markers: np.ndarray) -> np.ndarray:
    """The point records (n, M, 4) float32 of markers (n, M, 3) [m], NaN where missing: x,
    y, z in mm and the residual word, as ezc3d writes them (see the module docstring)."""
    present = np.all(np.isfinite(markers), axis=2)
    rec = np.zeros((*markers.shape[:2], 4), dtype="<f4")
    rec[..., :3] = np.where(present[..., None], markers * 1e3, 0.0)
    rec[..., 3] = np.where(present, 0.0, -1.0)
    return rec


def write_markers_c3d(
    path: str | Path,
    markers: np.ndarray,
    names: Sequence[str],
    rate: float,
    *,
    header_frames: int = HEADER_FRAMES,
) -> None:
    """Write markers (T, M, 3) [m] (NaN where missing; a memory map is read ``CHUNK``
    frames at a time) named ``names`` at ``rate`` [Hz] as a C3D file in mm, atomically;
    past ``header_frames`` frames (default the header's limit; lower in tests) the true
    count goes in TRIAL:ACTUAL_*_FIELD and POINT:LONG_FRAMES."""
    n = len(markers)
    head = min(n, header_frames)
    c3d = ezc3d.c3d()
    point = c3d["parameters"]["POINT"]
    point["RATE"]["value"] = np.array([float(rate)])
    point["LABELS"]["value"] = list(names)
    point["UNITS"]["value"] = ["mm"]
    if n > head:
        c3d.add_parameter("TRIAL", "ACTUAL_START_FIELD", [1, 0])
        c3d.add_parameter("TRIAL", "ACTUAL_END_FIELD", _words(n))
        c3d.add_parameter("POINT", "LONG_FRAMES", [float(n)])
    first = np.asarray(markers[:head], dtype=float)
    data = np.ones((4, len(names), head))
    data[:3] = np.transpose(np.nan_to_num(first * 1e3), (2, 1, 0))
    missing = ~np.all(np.isfinite(first), axis=2).T
    c3d["data"]["points"] = data
    c3d["data"]["meta_points"]["residuals"] = np.where(missing, -1.0, 0.0)[np.newaxis]
    with scratch_folder() as tmp:
        written = Path(tmp) / "head.c3d"
        c3d.write(str(written))
        layout = check_c3d(written)
        blob = written.read_bytes()
    start = layout.data_offset
    if blob[start : start + layout.data_bytes] != frame_records(first).tobytes():
        raise RuntimeError("the frame records differ from ezc3d's: encoding changed?")
    with atomic_path(path) as out, open(out, "wb") as handle:
        handle.write(blob[:start])
        for s in range(0, n, CHUNK):
            handle.write(frame_records(np.asarray(markers[s : s + CHUNK], dtype=float)).tobytes())


def _words(value: int) -> list[int]:
    """A 32-bit count as two signed 16-bit words, low word first (TRIAL:ACTUAL_END_FIELD)."""
    low, high = value & 0xFFFF, value >> 16
    return [low - 0x10000 if low >= 0x8000 else low, high]
