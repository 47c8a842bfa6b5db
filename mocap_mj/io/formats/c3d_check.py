"""A pure-Python structural check of a C3D file, done before ezc3d reads it in-process.

ezc3d trusts the file: on corrupted input it can hang or crash the interpreter. This module
walks the header and parameter section itself, bounds-checks every entry, and checks that the
parameters ezc3d dereferences exist and hold numbers. Passing the check is a sufficient
condition for reading in-process, not a necessary one: the reader sends every file the check
refuses to ezc3d in a separate process (:mod:`mocap_mj.io.formats.c3d_probe`) and reads it
after all when ezc3d reads it there, so the check never refuses a file ezc3d reads. A data
section shorter than the header declares is not an error here: ezc3d reads the whole frames
present (``C3DLayout.n_frames``) and the reader warns.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import mmap
import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mocap_mj.errors import InputFileError

BLOCK = 512
#: A file's bytes: read, or memory-mapped.
_Bytes = bytes | mmap.mmap
INTEL, DEC, MIPS = 84, 85, 86
_TYPES = {-1: 1, 1: 1, 2: 2, 4: 4}
_MAX_ENTRIES = 65536
#: Parameters ezc3d reads as one number without checking they hold one (else it crashes).
_SCALARS = (
    ("POINT", "USED"), ("POINT", "SCALE"), ("POINT", "RATE"), ("POINT", "DATA_START"),
    ("POINT", "FRAMES"), ("ANALOG", "USED"), ("ANALOG", "RATE"), ("ANALOG", "GEN_SCALE"),
    ("ROTATION", "USED"), ("ROTATION", "DATA_START"), ("ROTATION", "RATE"),
    ("ROTATION", "RATIO"), ("FORCE_PLATFORM", "USED"),
)  # fmt: skip


@dataclass(frozen=True)
class Param:
    """One parameter: its type (-1 char, 1 byte, 2 int16, 4 float), dimensions and values."""

    type: int
    dims: tuple[int, ...]
    values: tuple[float, ...] | tuple[str, ...]


@dataclass(frozen=True)
class C3DLayout:
    """What the check learnt: parameters by (GROUP, NAME), and the data section's extent."""

    params: dict[tuple[str, str], Param]
    n_points: int
    n_frames: int
    frames_declared: int
    float_data: bool
    data_offset: int
    data_bytes: int
    processor: int = INTEL


@dataclass(frozen=True)
class _Points:
    """The POINT group's counts: ``n_points`` (POINT:USED), ``n_frames`` (POINT:FRAMES),
    ``rate`` [Hz] (POINT:RATE), and whether the data are floats (the header's scale factor
    is negative)."""

    n_points: float
    n_frames: float
    rate: float
    float_data: bool


@dataclass(frozen=True)
class _Analogs:
    """The ANALOG group's counts: ``n_analogs`` channels, ``per_frame`` samples per point
    frame (both 0 without ANALOG)."""

    n_analogs: float
    per_frame: float


class C3DTruncatedError(InputFileError):
    """The file ends inside its header, parameter section, or before its first data frame.

    ezc3d cannot read such a file either (it fails, or loops on the missing bytes), so this
    refusal stands without asking ezc3d.
    """


def _err(path: Path, where: str, expected: str, got: str) -> InputFileError:
    return InputFileError(f"{path}: {where}: expected {expected}, got {got}")


def _cut(path: Path, where: str, expected: str, got: str) -> C3DTruncatedError:
    return C3DTruncatedError(f"{path}: {where}: expected {expected}, got {got}")


class _Reader:
    def __init__(self, path: Path, data: _Bytes, processor: int, section_end: int) -> None:
        self.path, self.data, self.processor = path, data, processor
        self.int_fmt = ">" if processor == MIPS else "<"
        self.section_end = section_end  # where the parameter section says it ends

    def need(self, start: int, length: int, what: str) -> bytes:
        if start < 0 or start + length > len(self.data):
            # Final only when the file ends inside its declared parameter section; an entry
            # pointing past the end of a whole file is a corrupted offset, for ezc3d to judge.
            error = _cut if len(self.data) < self.section_end else _err
            raise error(
                self.path,
                f"byte {start + 1}",
                f"{what} ({length} bytes)",
                f"end of file at byte {len(self.data)} (truncated)",
            )
        return self.data[start : start + length]

    def int8(self, pos: int, what: str) -> int:
        return struct.unpack("b", self.need(pos, 1, what))[0]

    def uint8(self, pos: int, what: str) -> int:
        return self.need(pos, 1, what)[0]

    def uint16(self, pos: int, what: str) -> int:
        return struct.unpack(self.int_fmt + "H", self.need(pos, 2, what))[0]

    def floats(self, raw: bytes) -> tuple[float, ...]:
        n = len(raw) // 4
        if self.processor == DEC:  # swap the 16-bit words, then scale the exponent
            swapped = b"".join(raw[i + 2 : i + 4] + raw[i : i + 2] for i in range(0, 4 * n, 4))
            return tuple(v / 4.0 for v in struct.unpack(f"<{n}f", swapped))
        return struct.unpack(f"{self.int_fmt}{n}f", raw)


def _values(reader: _Reader, kind: int, dims: tuple[int, ...], raw: bytes) -> tuple:
    if kind == -1:
        text = raw.decode("latin-1")
        width = dims[0] if dims else 1
        if width == 0:
            return ()
        return tuple(text[i : i + width].rstrip(" \x00") for i in range(0, len(text), width))
    if kind == 1:
        return tuple(struct.unpack(f"{len(raw)}b", raw))
    if kind == 2:
        return tuple(struct.unpack(f"{reader.int_fmt}{len(raw) // 2}h", raw))
    return reader.floats(raw)


def _walk_parameters(reader: _Reader, start: int) -> dict[tuple[str, str], Param]:
    path = reader.path
    groups: dict[int, str] = {}
    pending: list[tuple[int, str, Param, int]] = []
    pos = start
    for _ in range(_MAX_ENTRIES):
        n_char = reader.int8(pos, "a parameter entry")
        if n_char == 0:
            break
        gid = reader.int8(pos + 1, "a group id")
        if gid == 0:
            raise _err(path, f"byte {pos + 2}", "a non-zero group id", "0")
        raw_name = reader.need(pos + 2, abs(n_char), "a group or parameter name")
        if not all(b >= 0x20 and b != 0x7F for b in raw_name):  # spaces occur (Qualisys)
            raise _err(path, f"byte {pos + 3}", "a printable name", repr(raw_name)[:60])
        name = raw_name.decode("latin-1").upper()
        off_pos = pos + 2 + abs(n_char)
        offset = reader.uint16(off_pos, "the offset to the next entry")
        if gid < 0:
            n_desc = reader.uint8(off_pos + 2, "a description length")
            end = off_pos + 3 + n_desc
            reader.need(off_pos + 3, n_desc, "a description")
            groups[-gid] = name
        else:
            kind = reader.int8(off_pos + 2, "a parameter type")
            if kind not in _TYPES:
                raise _err(path, f"parameter {name}", "type -1, 1, 2 or 4", str(kind))
            n_dims = reader.uint8(off_pos + 3, "a dimension count")
            if kind == -1 and n_dims == 0:  # ezc3d crashes on dimensionless text
                raise _err(path, f"parameter {name}", "text with dimensions", "none")
            dims = tuple(reader.need(off_pos + 4, n_dims, "the dimensions"))
            count = math.prod(dims) if dims else 1
            data_pos = off_pos + 4 + n_dims
            raw = reader.need(data_pos, _TYPES[kind] * count, f"the values of {name}")
            n_desc = reader.uint8(data_pos + len(raw), "a description length")
            end = data_pos + len(raw) + 1 + n_desc
            reader.need(end - n_desc, n_desc, "a description")
            pending.append((gid, name, Param(kind, dims, _values(reader, kind, dims, raw)), pos))
        if offset == 0:
            break
        nxt = off_pos + offset
        if nxt < end:
            raise _err(
                path,
                f"byte {off_pos + 1}",
                f"an offset past this entry (to byte {end + 1} or on)",
                f"one to byte {nxt + 1}",
            )
        pos = nxt
    else:
        raise _err(path, "parameter section", f"at most {_MAX_ENTRIES} entries", "more")
    params: dict[tuple[str, str], Param] = {}
    for gid, name, param, at in pending:
        if gid not in groups:
            raise _err(path, f"byte {at + 1}", f"parameter {name} in a declared group", f"id {gid}")
        params[(groups[gid], name)] = param
    return params


def _is_labels(name: str) -> bool:
    """True for LABELS, LABELS2, LABELS3... (point labels beyond 255 continue there)."""
    return name == "LABELS" or (name.startswith("LABELS") and name[6:].isdigit())


def _number(path: Path, params: dict[tuple[str, str], Param], key: tuple[str, str]) -> float:
    param = params.get(key)
    if param is None or param.type == -1 or not param.values:
        raise _err(path, f"group {key[0]}:{key[1]}", "a number", "none")
    value = float(param.values[0])
    if param.type == 2 and value < 0 and key[1] == "FRAMES":  # often stored unsigned
        value += 65536
    if not math.isfinite(value):
        raise _err(path, f"group {key[0]}:{key[1]}", "a finite number", str(value))
    return value


def check_c3d(path: Path) -> C3DLayout:
    """Check that ``path`` is a complete, self-consistent C3D file; return its layout.

    A file without a POINT group, or with POINT:USED = 0, passes with ``n_points = 0`` and
    nothing past the parameter section checked (there are no marker points to read).

    Raises
    ------
    InputFileError
        Naming the file and the byte or ``group GROUP:PARAMETER`` that is wrong.
    """
    with _mapped(path) as data:
        return _check(path, data)


@contextlib.contextmanager
def _mapped(path: Path) -> Iterator[_Bytes]:
    """The file's bytes, memory-mapped: the check touches the header and parameter section
    only, so an hour's data section is never read (an empty file: no bytes)."""
    with open(path, "rb") as handle:
        if os.fstat(handle.fileno()).st_size == 0:
            yield b""
            return
        with mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as data:
            yield data


def _check(path: Path, data: _Bytes) -> C3DLayout:
    """:func:`check_c3d` on the file's bytes."""
    reader, params = _read_parameters(path, data)
    if not any(group == "POINT" for group, _ in params):
        return C3DLayout(params, 0, 0, 0, False, 0, 0)
    _check_scalars(path, params)
    points = _check_points(path, params, reader, data)
    if points is None:
        return C3DLayout(params, 0, 0, 0, False, 0, 0)
    analogs = _check_analogs(path, params, points.rate)
    layout = _data_layout(path, params, reader, data, points, analogs)
    return dataclasses.replace(layout, processor=reader.processor)


def _read_parameters(path: Path, data: _Bytes) -> tuple[_Reader, dict[tuple[str, str], Param]]:
    """Check the header's pointer to the parameter section and its processor type; return
    the reader (byte order of that processor) and the parameters by (group, name)."""
    if len(data) < BLOCK:
        raise _cut(path, "header", f"a C3D file of at least {BLOCK} bytes", f"{len(data)} bytes")
    if data[1] != 0x50:
        raise _err(path, "byte 2", "the C3D key 0x50", f"0x{data[1]:02x}")
    if data[0] < 2:
        raise _err(path, "byte 1", "the parameter section's block number (2 or more)", str(data[0]))
    start = (data[0] - 1) * BLOCK
    if start + 4 > len(data):
        raise _cut(
            path,
            "byte 1",
            f"a parameter section at byte {start + 1}",
            f"a file of {len(data)} bytes (truncated)",
        )
    processor = data[start + 3]
    if processor not in (INTEL, DEC, MIPS):
        raise _err(path, f"byte {start + 4}", "processor type 84, 85 or 86", str(processor))
    reader = _Reader(path, data, processor, start + max(1, data[start + 2]) * BLOCK)
    params = _walk_parameters(reader, start + 4)
    return reader, params


def _check_scalars(path: Path, params: dict[tuple[str, str], Param]) -> None:
    """Check that the counts and rates present (``_SCALARS``) are numbers in their range."""
    for key in _SCALARS:
        if key == ("ANALOG", "RATE") and _empty(params, key) and _is_zero(params, "ANALOG"):
            continue  # an empty ANALOG:RATE with no channels (Theia3D): ezc3d reads it as 0
        if key in params:
            value = _number(path, params, key)
            limit = 1000 if key[1] == "RATIO" else 65535
            if key[1] in ("USED", "RATIO", "DATA_START", "FRAMES") and not (
                0 <= value <= limit and value == int(value)
            ):
                raise _err(path, f"group {key[0]}:{key[1]}", f"a count in 0..{limit}", f"{value:g}")
            if key[1] == "RATE" and value < 0:
                raise _err(path, f"group {key[0]}:{key[1]}", "a rate of 0 or more", f"{value:g}")


def _check_points(
    path: Path, params: dict[tuple[str, str], Param], reader: _Reader, data: _Bytes
) -> _Points | None:
    """Check the POINT group; return its counts, or None when POINT:USED is 0 (no marker
    points to read)."""
    n_points = _number(path, params, ("POINT", "USED"))
    n_frames = _number(path, params, ("POINT", "FRAMES"))
    rate = _number(path, params, ("POINT", "RATE"))
    if not (0 <= n_points < 32768 and n_points == int(n_points)):
        raise _err(path, "group POINT:USED", "a point count in 0..32767", f"{n_points:g}")
    if n_points == 0:
        return None
    if n_frames < 1 or n_frames != int(n_frames):
        raise _err(path, "group POINT:FRAMES", "at least one frame", f"{n_frames:g}")
    if not 1e-3 <= rate <= 1e6:
        raise _err(path, "group POINT:RATE", "a frame rate in 0.001..1e6 Hz", f"{rate:g}")
    float_data = reader.floats(data[12:16])[0] < 0  # header scale factor: negative = float data
    scale = _number(path, params, ("POINT", "SCALE"))
    if not float_data and scale == 0:
        raise _err(path, "group POINT:SCALE", "a non-zero scale for integer data", "0")
    labels = sum(
        len(p.values)
        for (group, name), p in params.items()
        if group == "POINT" and p.type == -1 and _is_labels(name)
    )
    if labels < n_points:
        raise _err(path, "group POINT:LABELS", f"{int(n_points)} labels (POINT:USED)", str(labels))
    return _Points(n_points, n_frames, rate, float_data)


def _check_analogs(path: Path, params: dict[tuple[str, str], Param], rate: float) -> _Analogs:
    """Check the ANALOG group (and that there is no rotation data) against the point ``rate``
    [Hz]; return its counts."""
    n_analogs, per_frame = 0.0, 0.0
    if any(group == "ANALOG" for group, _ in params):
        n_analogs = _number(path, params, ("ANALOG", "USED"))
        analog_rate = (
            0.0
            if n_analogs == 0 and _empty(params, ("ANALOG", "RATE"))
            else (_number(path, params, ("ANALOG", "RATE")))
        )
        if not (0 <= n_analogs < 32768 and n_analogs == int(n_analogs)):
            raise _err(path, "group ANALOG:USED", "a channel count in 0..32767", f"{n_analogs:g}")
        if not 0 <= analog_rate < rate * 65536:
            raise _err(
                path, "group ANALOG:RATE", "a rate up to 65535 x POINT:RATE", f"{analog_rate:g}"
            )
        per_frame = float(int(analog_rate / rate))
        if n_analogs:
            _number(path, params, ("ANALOG", "GEN_SCALE"))
            for per_channel in ("SCALE", "OFFSET"):
                got = params.get(("ANALOG", per_channel))
                if got is None or got.type == -1 or len(got.values) < n_analogs:
                    have = "none" if got is None else f"{len(got.values)} values"
                    want = f"{int(n_analogs)} values (ANALOG:USED)"
                    raise _err(path, f"group ANALOG:{per_channel}", want, have)
    if ("ROTATION", "USED") in params and _number(path, params, ("ROTATION", "USED")) != 0:
        raise _err(path, "group ROTATION:USED", "0 (rotation data is not supported)", "more")
    return _Analogs(n_analogs, per_frame)


def _data_layout(
    path: Path,
    params: dict[tuple[str, str], Param],
    reader: _Reader,
    data: _Bytes,
    points: _Points,
    analogs: _Analogs,
) -> C3DLayout:
    """Check the header's pointer to the data section and that it holds a frame at least;
    return the layout (frames cut to those the file holds)."""
    n_points, n_frames, float_data = points.n_points, points.n_frames, points.float_data
    n_analogs, per_frame = analogs.n_analogs, analogs.per_frame
    value_bytes = 4 if float_data else 2
    data_block = struct.unpack(reader.int_fmt + "H", data[16:18])[0]
    if data_block < 2:
        raise _err(path, "byte 17", "the data section's block number (2 or more)", str(data_block))
    frame_bytes = value_bytes * (4 * int(n_points) + int(per_frame) * int(n_analogs))
    data_offset = (data_block - 1) * BLOCK
    present = max(0, len(data) - data_offset) // frame_bytes
    if present < 1:
        raise _cut(
            path,
            "data section",
            f"at least one frame of {frame_bytes} bytes from byte {data_offset + 1}",
            f"a file of {len(data)} bytes (truncated)",
        )
    frames = min(int(n_frames), present)
    return C3DLayout(
        params, int(n_points), frames, int(n_frames), float_data, data_offset, frames * frame_bytes
    )


def _empty(params: dict[tuple[str, str], Param], key: tuple[str, str]) -> bool:
    """True if the parameter is absent or holds no value."""
    param = params.get(key)
    return param is None or not param.values


def _is_zero(params: dict[tuple[str, str], Param], group: str) -> bool:
    """True if ``group``:USED is absent, empty or 0."""
    used = params.get((group, "USED"))
    return used is None or not used.values or used.type == -1 or float(used.values[0]) == 0
