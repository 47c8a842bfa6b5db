"""C3D files, read through ezc3d after a structural check of our own.

Every 3D point of POINT:LABELS (+ LABELS2, LABELS3... past 255 points) is read; the points
the file itself lists as model outputs (POINT:ANGLES, FORCES, MOMENTS, POWERS, SCALARS,
REACTIONS, MODELED_MARKERS and any group POINT:TYPE_GROUPS names) are reported in
``non_markers`` for the loader to drop. A sample whose residual is negative is missing (NaN);
the loader applies the missing-data rule shared by every format (NaN, all-zero samples).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import ezc3d
import numpy as np

from mocap_mj.errors import InputFileError
from mocap_mj.io.formats._common import RawMarkers
from mocap_mj.io.formats.c3d_check import (
    DEC,
    INTEL,
    C3DLayout,
    C3DTruncatedError,
    check_c3d,
)
from mocap_mj.io.formats.c3d_probe import ezc3d_failure
from mocap_mj.io.ownership import scratch_folder
from mocap_mj.io.units import metres_per_unit

#: POINT parameters that list non-marker points (model outputs), as Vicon writes them.
NON_MARKER_GROUPS = (
    "ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS", "MODELED_MARKERS",
)  # fmt: skip


def recording_first_frame(ezc3d_first_frame: int) -> int:
    """The recording's number of its first frame from ezc3d's header value: the C3D header
    numbers frames from 1 (ezc3d reports it less 1), so frame f is at (f - 1) / rate seconds
    of the recording, as the lab's own software counts it."""
    return ezc3d_first_frame + 1


def looks_like(head: bytes) -> bool:
    """True if a file starting with ``head`` has the C3D key byte."""
    return len(head) >= 2 and head[1] == 0x50 and head[0] >= 1


def _values(params: dict[str, Any], group: str, name: str) -> list[Any]:
    entry = params.get(group, {}).get(name)
    if not isinstance(entry, dict):
        return []
    value = entry.get("value")
    if value is None:
        return []
    return list(np.ravel(value)) if not isinstance(value, list) else value


def _point_labels(point: dict[str, Any]) -> list[str]:
    labels = [str(v) for v in _values({"POINT": point}, "POINT", "LABELS")]
    k = 2
    while f"LABELS{k}" in point:
        labels += [str(v) for v in _values({"POINT": point}, "POINT", f"LABELS{k}")]
        k += 1
    return [label.strip() for label in labels]


def _non_marker_names(point: dict[str, Any]) -> set[str]:
    groups = list(NON_MARKER_GROUPS)
    listed = _values({"POINT": point}, "POINT", "TYPE_GROUPS")
    type_groups = [str(v).strip().upper() for v in listed]
    groups += type_groups[::2]  # (group, singular) pairs
    names: set[str] = set()
    for group in groups:
        if group in ("LABELS", "DESCRIPTIONS", "UNITS") or group.startswith("LABELS"):
            continue
        names.update(str(v).strip() for v in _values({"POINT": point}, "POINT", group))
    names.discard("")
    return names


def _up_hint(point: dict[str, Any]) -> str | None:
    screen = [str(v).strip().upper() for v in _values({"POINT": point}, "POINT", "Y_SCREEN")]
    if screen and len(screen[0]) == 2 and screen[0][0] in "+-" and screen[0][1] in "XYZ":
        return ("-" if screen[0][0] == "-" else "") + screen[0][1].lower()
    return None


def read(path: Path) -> RawMarkers:
    """Read the marker points of a C3D file, as ezc3d reads them.

    The structural check runs first; a file it refuses is read all the same when ezc3d reads
    it in a separate process (see :mod:`mocap_mj.io.formats.c3d_probe`), except a file that
    ends before its first frame (ezc3d cannot read those: it fails or loops). When the data
    section holds fewer frames than the header declares, the frames present are read and
    ``info["warnings"]`` says so (the loader logs it once).
    """
    layout = _checked(path)
    return _raw(path, _ezc3d(path), layout)


def _checked(path: Path) -> C3DLayout | None:
    """The structural check's layout; None for a file it refuses that ezc3d reads."""
    try:
        layout: C3DLayout | None = check_c3d(path)
    except C3DTruncatedError:
        raise
    except InputFileError:
        if ezc3d_failure(path) is not None:
            raise
        layout = None
    if layout is not None and layout.n_points == 0:
        raise _no_points(path)
    return layout


class _Read(NamedTuple):
    """What ezc3d read: parameters, the header's point section, points (4, M, T) [file
    units] and residuals (1, M, T)."""

    params: dict[str, Any]
    header: dict[str, Any]
    points: np.ndarray
    residuals: np.ndarray


def _ezc3d(path: Path | str, shown: Path | None = None) -> _Read:
    """The file read by ezc3d (``shown``: the name for errors, default ``path``)."""
    try:
        c3d = ezc3d.c3d(str(path))
        return _Read(
            c3d["parameters"],
            c3d["header"]["points"],
            np.asarray(c3d["data"]["points"], dtype=np.float64),
            np.asarray(c3d["data"]["meta_points"]["residuals"], dtype=np.float64),
        )
    except Exception as exc:  # ezc3d raises RuntimeError, OSError, ValueError...
        message = " ".join(str(exc).split())[:200]
        raise InputFileError(f"{shown or path}: ezc3d could not read it: {message}") from exc


def _raw(path: Path, got: _Read, layout: C3DLayout | None, frames: int | None = None) -> RawMarkers:
    """The RawMarkers of ezc3d's reading; ``frames``: the file's frames when ``got`` holds
    only its first few (a streamed read: positions then hold those few)."""
    point = got.params.get("POINT", {})
    points, residuals = got.points, got.residuals
    if points.ndim != 3 or points.shape[1] == 0:
        raise _no_points(path)
    n_points, n_read = int(points.shape[1]), int(points.shape[2])
    n_frames = n_read if frames is None else frames
    if n_frames == 0 or n_read == 0:
        raise InputFileError(f"{path}: data section: expected at least one frame, got none")
    labels = _point_labels(point)[:n_points]
    labels += [f"*{k + 1}" for k in range(len(labels), n_points)]  # unlabelled: dropped
    positions = points[:3].transpose(2, 1, 0).copy()  # (T, M, 3)
    if residuals.shape == (1, n_points, n_read):
        positions[residuals[0].T < 0] = np.nan
    positions[np.isnan(positions).any(axis=2)] = np.nan
    _check_finite(path, positions, labels)
    rate = _rate(path, point, got.header)
    units, units_where, per_point = _units(path, labels, point)
    if per_point is not None:
        positions *= per_point[:, None]
    subjects = [str(v).strip() for v in _values(got.params, "SUBJECTS", "NAMES") if str(v).strip()]
    warnings = []
    declared = layout.frames_declared if layout is not None else n_frames
    if declared > n_frames:
        warnings.append(
            f"{path}: data section: the header declares {declared} frames, the file holds "
            f"{n_frames}: read the {n_frames} frames present"
        )
    first = recording_first_frame(int(got.header["first_frame"]))
    return RawMarkers(
        format="c3d",
        labels=labels,
        positions=positions,
        times=(first - 1 + np.arange(n_frames)) / rate,
        rate=rate,
        units=units,
        units_where=units_where,
        labels_where="group POINT:LABELS",
        up_hint=_up_hint(point),
        non_markers=_non_marker_names(point),
        subjects=subjects,
        info={"first_frame": first, "warnings": warnings},
    )


def _check_finite(path: Path, positions: np.ndarray, labels: list[str], first: int = 0) -> None:
    """Error naming the first frame (``first``: the frame of row 0) and point holding an
    infinite coordinate."""
    bad = np.argwhere(np.isinf(positions))
    if len(bad):
        frame, k = int(bad[0][0]), int(bad[0][1])
        raise InputFileError(
            f"{path}: data section: expected finite coordinates, got infinity in frame "
            f"{first + frame + 1} for point {labels[k]!r}"
        )


def _no_points(path: Path) -> InputFileError:
    return InputFileError(
        f"{path}: group POINT:USED: expected marker points, got none (the file holds no "
        f"marker data: force plates, analog channels or rotations only)"
    )


def _rate(path: Path, point: dict[str, Any], header: dict[str, Any]) -> float:
    """POINT:RATE [Hz], else the header's frame rate; error unless positive and finite."""
    for value in (*_values({"POINT": point}, "POINT", "RATE")[:1], header.get("frame_rate")):
        try:
            rate = float(value)
        except (TypeError, ValueError):
            continue
        if math.isfinite(rate) and rate > 0:
            return rate
    raise InputFileError(f"{path}: group POINT:RATE: expected a positive frame rate, got none")


def _units(
    path: Path, labels: list[str], point: dict[str, Any]
) -> tuple[str | None, str, np.ndarray | None]:
    """The points' length unit (None if unstated), where it was read, and the per-point
    factors (M,) to metres when the points' units differ (the unit is then "m"), else None.

    POINT:UNITS holds one unit, or one per point (NDI Optotrak).
    """
    units = [str(v).strip() for v in _values({"POINT": point}, "POINT", "UNITS")]
    if not units or not units[0]:
        return None, "group POINT:UNITS", None
    per_point = units[: len(labels)] if len(units) > 1 else []
    if len({u.lower() for u in per_point if u}) <= 1:
        return units[0], "group POINT:UNITS", None
    scales = np.ones(len(labels))
    for k, unit in enumerate(per_point):
        scale = metres_per_unit(unit or units[0])
        if scale is None:
            raise InputFileError(
                f"{path}: group POINT:UNITS: expected length units mm, cm or m for point "
                f"{labels[k]!r}, got {unit!r}"
            )
        scales[k] = scale
    return "m", "group POINT:UNITS (per point, converted to m)", scales


#: Frames ezc3d reads of a streamed file (header, parameters and these frames, from a copy
#: of the file's start): the decoder below must reproduce them exactly.
PROBE_FRAMES = 4


class C3DChunks(NamedTuple):
    """A C3D file opened for reading in chunks (:func:`open_chunks`).

    Fields: ``raw``, the file as :func:`read` describes it (labels, units, rate, times of
    every frame...) with ``positions`` of its first frames only; ``frames``, the frames the
    file holds; ``read(start, stop)``: positions (n, M, 3) [file units] of those frames, as
    :func:`read` gives them (residual < 0 and NaN samples missing, per-point units applied).
    """

    raw: RawMarkers
    frames: int
    read: Callable[[int, int], np.ndarray]


def open_chunks(path: Path) -> C3DChunks | str:
    """Open a C3D file to read its points chunk by chunk, or say why it is read whole (the
    reason, a str).

    ezc3d reads a file whole: its Python API has no way to read the header and parameters
    alone. So ezc3d reads a copy of the file's start (header, parameters, ``PROBE_FRAMES``
    frames), which gives the names, units and rate exactly as :func:`read` gets them, and the
    point block is then read from a memory map of fixed-size frame records: Intel floats or
    Intel 16-bit integers times POINT:SCALE, the residual's sign from the record's fourth
    word, as ezc3d decodes them. The decoder must reproduce ezc3d's first frames bit for
    bit, else the file is read whole. DEC and MIPS files, per-point scales, and a scale
    whose sign contradicts the header are read whole (by ezc3d).
    """
    try:
        layout = check_c3d(path)
    except InputFileError as exc:
        return f"the structural check refused it ({exc})"
    if layout.n_points == 0 or layout.n_frames == 0:
        return "it holds no marker points"
    if layout.processor != INTEL:
        kind = "DEC" if layout.processor == DEC else "MIPS"
        return f"{kind} processor encoding (ezc3d reads it)"
    frame_bytes = layout.data_bytes // layout.n_frames
    frames = _long_frames(path, layout, frame_bytes)
    probe = min(layout.n_frames, PROBE_FRAMES)
    with scratch_folder() as tmp:
        head = Path(tmp) / "head.c3d"
        with open(path, "rb") as src, open(head, "wb") as dst:
            dst.write(src.read(layout.data_offset + probe * frame_bytes))
        got = _ezc3d(head, shown=path)
    raw = _raw(path, got, layout, frames=frames)
    scales = {float(v) for v in _values(got.params, "POINT", "SCALE")}
    if len(scales) != 1:
        return f"POINT:SCALE holds {len(scales)} different values"
    scale = scales.pop()
    if (scale < 0) != layout.float_data:
        return "POINT:SCALE's sign contradicts the header's (float or integer data)"
    _, _, per_point = _units(path, raw.labels, got.params.get("POINT", {}))
    decoder = _Decoder(path, layout, frames, frame_bytes, scale, per_point, raw.labels)
    first = decoder(0, probe)
    if first.shape != raw.positions.shape or not np.array_equal(
        first, raw.positions, equal_nan=True
    ):
        return "its first frames decode differently from ezc3d's reading"
    return C3DChunks(raw, frames, decoder)


def read_parameters(path: Path) -> dict[str, Any]:
    """The file's parameter groups as ezc3d reads them (``c3d["parameters"]``).

    ezc3d reads a file whole, every point and analog sample, while the parameters of even an
    hour's recording are a few kilobytes at its start: a file whose layout the structural
    check understands (:func:`check_c3d`) is read from a copy of its header, parameters and
    at most ``PROBE_FRAMES`` frames, as :func:`open_chunks` reads its names and units; any
    other file is read whole. POINT:FRAMES, which ezc3d sets to the frames it read, then
    counts those of the copy. Raises ezc3d's own exceptions, as a whole read does.
    """
    try:
        layout = check_c3d(path)
    except InputFileError:
        layout = None
    if layout is None or layout.n_frames == 0:
        return dict(ezc3d.c3d(str(path), extract_forceplat_data=False)["parameters"])
    frame_bytes = layout.data_bytes // layout.n_frames
    with scratch_folder() as tmp:
        head = Path(tmp) / "head.c3d"
        with open(path, "rb") as src, open(head, "wb") as dst:
            dst.write(
                src.read(layout.data_offset + min(layout.n_frames, PROBE_FRAMES) * frame_bytes)
            )
        return dict(ezc3d.c3d(str(head), extract_forceplat_data=False)["parameters"])


def _long_frames(path: Path, layout: C3DLayout, frame_bytes: int) -> int:
    """The frames of the data section: more than the header's 16-bit count (65,535) when
    TRIAL:ACTUAL_START_FIELD and ACTUAL_END_FIELD (Vicon: two 16-bit words each, low word
    first) or POINT:LONG_FRAMES (C3Dserver, a float) say so and the file holds them; else
    the structural check's count. ezc3d stops at the header's count."""
    count = layout.n_frames
    end, start = (
        layout.params.get(("TRIAL", "ACTUAL_END_FIELD")),
        layout.params.get(("TRIAL", "ACTUAL_START_FIELD")),
    )
    long_frames = layout.params.get(("POINT", "LONG_FRAMES"))
    words = [
        [int(v) & 0xFFFF for v in p.values]
        for p in (start, end)
        if p is not None and p.type == 2 and len(p.values) == 2
    ]
    if len(words) == 2:
        first, last = (w[0] + (w[1] << 16) for w in words)
        count = max(count, last - first + 1)
    elif long_frames is not None and long_frames.type == 4 and long_frames.values:
        count = max(count, int(float(long_frames.values[0])))
    held = (os.path.getsize(path) - layout.data_offset) // frame_bytes
    return count if count <= held else layout.n_frames


class _Decoder:
    """Positions (n, M, 3) [file units] of frames [start, stop) from the memory-mapped
    point block (see :func:`open_chunks`)."""

    def __init__(
        self,
        path: Path,
        layout: C3DLayout,
        frames: int,
        frame_bytes: int,
        scale: float,
        per_point: np.ndarray | None,
        labels: list[str],
    ) -> None:
        self.path, self.scale, self.per_point, self.labels = path, scale, per_point, labels
        self.float_data, self.n_points = layout.float_data, layout.n_points
        dtype = np.dtype("<f4" if layout.float_data else "<i2")
        self.words = np.memmap(
            path,
            dtype=dtype,
            mode="r",
            offset=layout.data_offset,
            shape=(frames, frame_bytes // dtype.itemsize),
        )

    def __call__(self, start: int, stop: int) -> np.ndarray:
        m = self.n_points
        block = np.array(self.words[start:stop, : 4 * m]).reshape(-1, m, 4)
        if self.float_data:
            # x, y, z: floats; the fourth float's high 16-bit word: the residual, signed,
            # times -scale (ezc3d Point: camera mask word first, residual word second)
            positions = block[..., :3].astype(np.float64)
            word = np.ascontiguousarray(block[..., 3]).view("<i2").reshape(-1, m, 2)[..., 1]
            residual = word.astype(np.float64) * -self.scale
        else:
            # integers times scale; the fourth word's second byte: the residual, signed
            positions = block[..., :3].astype(np.float64) * self.scale
            byte = np.ascontiguousarray(block[..., 3]).view(np.int8).reshape(-1, m, 2)[..., 1]
            residual = byte.astype(np.float64) * self.scale
        positions[residual < 0] = np.nan
        positions[np.isnan(positions).any(axis=2)] = np.nan
        _check_finite(self.path, positions, self.labels, first=start)
        if self.per_point is not None:
            positions *= self.per_point[:, None]
        return positions
