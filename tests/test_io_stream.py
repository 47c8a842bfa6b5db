"""Marker files read chunk by chunk (io.stream, c3d.open_chunks, c3d_write) and motion
written chunk by chunk (identify.motion_out): the same bytes and positions as whole."""

from __future__ import annotations

import argparse
import struct
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.commands import _markers
from mocap_mj.errors import InputFileError
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv, save_trc
from mocap_mj.io.formats.c3d_check import check_c3d
from mocap_mj.io.formats.c3d_write import frame_records, write_markers_c3d
from mocap_mj.io.stream import open_markers
from mocap_mj.long.motion_out import write_motion_chunks
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_mj.solve.problem import TrialData

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
FILES = sorted((SHARED / "real").glob("*.c3d")) + sorted((SHARED / "vendors").glob("*.c3d"))
CHUNK = 64  # frames: every shared file spans several chunks but the smallest


def _markers_of(frames: int, seed: int = 3) -> np.ndarray:
    """A synthetic ROM's markers (frames, 39, 3) [m], a few samples missing."""
    from mocap_synth import SynthConfig, synthesize

    m = synthesize(SynthConfig(frames=frames, motion="rom", seed=seed)).markers.copy()
    m[10:14, 5] = np.nan
    m[40, :, :] = np.nan
    return m


def _same(path: Path) -> str:
    """Assert that the chunked read of ``path`` equals load_markers' bit for bit; returns how
    it was read."""
    try:
        whole = load_markers(path)
    except InputFileError as exc:
        with pytest.raises(InputFileError) as got:
            open_markers(path, chunk=CHUNK)
        assert str(got.value) == str(exc)
        return "error"
    stream = open_markers(path, chunk=CHUNK)
    positions = np.concatenate([p for _, p in stream.chunks(CHUNK)])
    assert np.array_equal(positions, whole.positions, equal_nan=True)
    assert stream.names == whole.names and np.array_equal(stream.times, whole.times)
    assert stream.source == whole.source
    assert stream.marker_report() == whole.marker_report()
    return stream.how


@pytest.mark.slow
@pytest.mark.skipif(not FILES, reason=f"no shared C3D files in {SHARED}")
def test_chunked_c3d_equals_load_markers_on_the_shared_files() -> None:
    how = {p.name: _same(p) for p in FILES}
    streamed = [n for n, h in how.items() if h == "in chunks"]
    # Intel float files are read in chunks (the DEC one whole, by ezc3d); files without
    # points fail alike.
    assert len(streamed) >= 8, how
    assert all(h in ("in chunks", "error") or "DEC" in h for h in how.values()), how


def test_chunked_c3d_of_a_synthetic_recording(tmp_path: Path) -> None:
    """Float and 16-bit integer C3D files of a synthetic ROM, and one longer than its
    header's count: read in chunks exactly as whole (ezc3d), to float32 of the truth."""
    names = ParameterSet().marker_names
    m = _markers_of(300)
    path = tmp_path / "rom.c3d"
    write_markers_c3d(path, m, names, 100.0)
    assert _same(path) == "in chunks"
    got = np.concatenate([p for _, p in open_markers(path, chunk=CHUNK).chunks(CHUNK)])
    assert np.array_equal(np.isnan(got), np.isnan(m))
    assert np.nanmax(np.abs(got - m)) < 1e-6  # float32 mm of metre-sized coordinates
    ints = tmp_path / "rom_int16.c3d"
    _int16_copy(path, ints, scale=0.1)
    assert not check_c3d(ints).float_data
    assert _same(ints) == "in chunks"
    err = np.nanmax(np.abs(load_markers(ints).positions - m))
    assert err <= 0.05e-3 + 1e-6, err  # scale / 2, and float32 of the float file (above)

    # Past the header's 16-bit count (here cut to 120 frames): ezc3d reads the header's
    # frames, the chunked reader every frame TRIAL:ACTUAL_END_FIELD declares.
    long = tmp_path / "long.c3d"
    write_markers_c3d(long, m, names, 100.0, header_frames=120)
    stream = open_markers(long, chunk=CHUNK)
    assert stream.how == "in chunks" and stream.n_frames == 300
    every = np.concatenate([p for _, p in stream.chunks(CHUNK)])
    assert np.array_equal(every, got, equal_nan=True)
    assert np.array_equal(every[:120], load_markers(long).positions, equal_nan=True)


def _int16_copy(src: Path, dst: Path, scale: float) -> None:
    """``src`` (Intel float, written by write_markers_c3d) as Intel 16-bit integers times
    ``scale`` [mm]: POINT:SCALE and the header's scale set to it, the records rewritten
    (residual byte -1 where missing, as ezc3d reads it)."""
    data = bytearray(src.read_bytes())
    layout = check_c3d(src)
    section = bytes(data[512 * (data[0] - 1) : layout.data_offset])
    group = section.find(b"POINT") - 1
    gid = -struct.unpack("b", section[group : group + 1])[0]
    name = section.find(bytes([gid]) + b"SCALE") + 1  # n_char (-5 if locked), gid, name
    assert abs(struct.unpack("b", section[name - 2 : name - 1])[0]) == 5
    assert section[name + 7] == 4 and section[name + 8] == 0  # a float, no dimension
    value = 512 * (data[0] - 1) + name + 9  # after the name, the offset, type, dimensions
    data[value : value + 4] = struct.pack("<f", scale)
    data[12:16] = struct.pack("<f", scale)
    rec = np.frombuffer(bytes(data[layout.data_offset :]), dtype="<f4").reshape(
        layout.n_frames, layout.n_points, 4
    )
    ints = np.zeros(rec.shape, dtype="<i2")
    ints[..., :3] = np.round(rec[..., :3] / scale).astype("<i2")
    missing = rec[..., 3] < 0
    words = np.zeros((*missing.shape, 2), dtype=np.int8)  # camera mask byte, residual byte
    words[..., 1] = np.where(missing, -1, 0)
    ints[..., 3] = words.view("<i2")[..., 0]
    dst.write_bytes(bytes(data[: layout.data_offset]) + ints.tobytes())


def test_frame_records_encode_as_ezc3d() -> None:
    rec = frame_records(np.array([[[0.001, 0.002, 0.003], [np.nan, 0.0, 0.0]]]))
    assert rec.tolist() == [[[1.0, 2.0, 3.0, 0.0], [0.0, 0.0, 0.0, -1.0]]]


def test_load_trial_maps_a_long_c3d_chunk_by_chunk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """identify's reader: a C3D file above the threshold becomes a memory-mapped .npy in the
    model's order, equal to the whole read."""
    names = ParameterSet().marker_names
    path = tmp_path / "rom.c3d"
    write_markers_c3d(path, _markers_of(300), names, 100.0)
    args = argparse.Namespace(subject=None, marker_map=None, up=None, units=None)
    whole = _markers.load_trial(str(path), names, args)
    monkeypatch.setattr(_markers, "STREAM_ABOVE", 100)
    mapped = _markers.load_trial(str(path), names, args, scratch=tmp_path)
    assert isinstance(mapped.markers, np.memmap) and not isinstance(whole.markers, np.memmap)
    assert np.array_equal(mapped.markers, whole.markers, equal_nan=True)
    assert np.array_equal(mapped.times, whole.times) and mapped.report == whole.report


def test_motion_written_in_chunks_is_save_motions_bytes(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    n, names = 50, ("A", "BB", "CCC")
    qpos, markers = rng.normal(size=(n, 7)), rng.normal(size=(n, 3, 3))
    markers[3, 1] = np.nan
    times = np.arange(n) / 100.0
    save_motion(tmp_path / "whole.npz", Motion(qpos, times, markers, names))
    chunks = (qpos[s : s + 7] for s in range(0, n, 7))
    trial = TrialData("t", markers, times)
    write_motion_chunks(tmp_path / "chunks.npz", trial, names, 7, chunks, chunk=7)
    assert (tmp_path / "chunks.npz").read_bytes() == (tmp_path / "whole.npz").read_bytes()
    short = (qpos[s : s + 7] for s in range(0, n - 7, 7))
    with pytest.raises(ValueError, match=r"qpos\.npy"):
        write_motion_chunks(tmp_path / "bad.npz", trial, names, 7, short, chunk=7)
    assert not (tmp_path / "bad.npz").exists()


def _trc_text(tmp_path: Path) -> str:
    """A synthetic ROM as save_trc writes it (tab-separated, a few samples missing)."""
    names = ParameterSet().marker_names
    path = tmp_path / "base.trc"
    save_trc(path, MarkerTrajectory(np.arange(120) / 100.0, _markers_of(120), names, 100.0, {}))
    return path.read_text()


def _rows(text: str, edit: Callable[[list[str]], None]) -> str:
    lines = text.split("\n")
    edit(lines)
    return "\n".join(lines)


def _set(k: int, value: str) -> Callable[[list[str]], None]:
    def edit(lines: list[str]) -> None:
        lines[k] = value

    return edit


VARIANTS: dict[str, Callable[[str], str]] = {
    "as written": lambda t: t,
    "CRLF": lambda t: t.replace("\n", "\r\n"),
    "trailing blank lines": lambda t: t + "\n\n  \n",
    "blank line inside": lambda t: _rows(t, _set(40, "")),
    "short row": lambda t: _rows(t, _set(50, "45\t0.44\t1.0")),  # its last samples missing
    "narrow row": lambda t: _rows(t, _set(50, "45")),
    "bad cell": lambda t: _rows(t, _set(60, "55\tx" + "\t1" * 117)),
    "bad cell, second chunk": lambda t: _rows(t, _set(100, "95\t0.94" + "\t1" * 116 + "\tx")),
    "empty columns": lambda t: "\n".join(line + "\t\t" for line in t.split("\n")),
    "extra column": lambda t: "\n".join(
        line + "\t7" if line[:1].isdigit() else line for line in t.split("\n")
    ),
    "Latin-1 name": lambda t: t.replace("LASI", "L\xc4SI"),
}


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_chunked_trc_equals_load_markers(tmp_path: Path, variant: str) -> None:
    """TRC rows parsed ``CHUNK`` at a time into a memory map: the same positions, source and
    errors as the whole read, or read whole when a row is wider than the header."""
    path = tmp_path / "v.trc"
    path.write_bytes(VARIANTS[variant](_trc_text(tmp_path)).encode("latin-1"))
    how = _same(path)
    if variant == "extra column":
        assert how.startswith("read whole: rows wider")
    elif variant in ("blank line inside", "narrow row", "bad cell", "bad cell, second chunk"):
        assert how == "error"
    else:
        assert how == "in chunks"


def _csv_text(tmp_path: Path) -> str:
    """A synthetic ROM as save_csv writes it (a comment line, a few samples missing)."""
    names = ParameterSet().marker_names
    path = tmp_path / "base.csv"
    save_csv(path, MarkerTrajectory(np.arange(120) / 100.0, _markers_of(120), names, 100.0, {}))
    return path.read_text()


def _row(k: int, cells: str) -> Callable[[str], str]:
    """The text with data row k (0-based after the comment and the column header) replaced."""
    return lambda t: _rows(t, _set(k + 2, cells))


CSV_VARIANTS: dict[str, Callable[[str], str]] = {
    "as written": lambda t: t,
    "CRLF": lambda t: t.replace("\n", "\r\n"),
    "trailing blank lines": lambda t: t + "\n\n  \n",
    "no comment line": lambda t: t.split("\n", 1)[1],
    "blank line inside": _row(40, ""),
    "narrow row": _row(50, "50,0.5,1.0"),
    "non-empty extra cell": _row(70, "70,0.7" + ",1" * 117 + ",9"),
    "bad cell": _row(60, "60,0.6,x" + ",1" * 116),
    # the second chunk's narrow row is reported before the first chunk's bad cell, as whole
    "bad cell, narrow row after": lambda t: _row(100, "100")(_row(10, "10,0.1,x" + ",1" * 116)(t)),
    "missing frame number": _row(90, ",0.9" + ",1" * 117),
    "Latin-1 name": lambda t: t.replace("LASI", "L\xc4SI"),
}


@pytest.mark.parametrize("variant", list(CSV_VARIANTS))
def test_chunked_mocap_csv_equals_load_markers(tmp_path: Path, variant: str) -> None:
    """mocap-mj CSV rows parsed ``CHUNK`` at a time into a memory map: the same positions,
    source and errors (the first in the file, as the whole read finds it) as the whole read."""
    path = tmp_path / "v.csv"
    path.write_bytes(CSV_VARIANTS[variant](_csv_text(tmp_path)).encode("latin-1"))
    how = _same(path)
    errors = ("blank line inside", "narrow row", "non-empty extra cell", "bad cell")
    errors += ("bad cell, narrow row after", "missing frame number")
    assert how == ("error" if variant in errors else "in chunks")


def _same_tree(a: object, b: object) -> bool:
    """Nested dicts, lists and arrays equal (NaN equal to NaN)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same_tree(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same_tree(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        x, y = np.asarray(a), np.asarray(b)
        if x.dtype.kind in "fc" and y.dtype.kind in "fc":
            return x.shape == y.shape and bool(np.array_equal(x, y, equal_nan=True))
        return x.shape == y.shape and bool(np.array_equal(x, y))
    return a == b


@pytest.mark.skipif(not FILES, reason=f"no shared C3D files in {SHARED}")
def test_parameters_from_the_files_start_equal_the_whole_read() -> None:
    """``read_parameters`` (the subject's measurements of ``identify``) reads a copy of the
    file's start: the same parameter groups as ezc3d's whole read of every shared file, but
    POINT:FRAMES (the frames ezc3d read: those of the copy)."""
    import ezc3d

    from mocap_mj.io.formats.c3d import PROBE_FRAMES, read_parameters

    for path in FILES:
        whole = dict(ezc3d.c3d(str(path), extract_forceplat_data=False)["parameters"])
        head = read_parameters(path)
        frames = [g["POINT"].pop("FRAMES")["value"] for g in (whole, head)]
        assert _same_tree(head, whole), path.name
        # read from the copy, or whole where the structural check refuses the file
        assert frames[1][0] in (min(frames[0][0], PROBE_FRAMES), frames[0][0]), path.name


def _nexus_text() -> str:
    """A synthetic ROM as a Vicon Nexus export (a Devices block before the Trajectories, a
    Model Outputs block after; frames numbered from 101; a few samples missing)."""
    from test_io_readers import nexus_text

    return nexus_text(ParameterSet().marker_names, _markers_of(120) * 1000.0, 100.0)


#: The Trajectories block's first data line (0-based) in ``_nexus_text``.
NEXUS_DATA = 13


def _nexus_row(k: int, cells: str) -> Callable[[str], str]:
    """The Nexus text with data row k replaced."""
    return lambda t: _rows(t, _set(NEXUS_DATA + k, cells))


NEXUS_VARIANTS: dict[str, Callable[[str], str]] = {
    "as written": lambda t: t,
    "CRLF": lambda t: t.replace("\n", "\r\n"),
    "no units row": lambda t: _rows(t, lambda lines: lines.pop(NEXUS_DATA - 1)),
    "units m, the values mm": lambda t: t.replace(",mm,mm,mm", ",m,m,m"),
    "Trajectories first, nothing after": lambda t: "\n".join(
        t.split("\n")[8 : t.split("\n").index("Model Outputs") - 1]
    ),
    "trailing empty cells": lambda t: "\n".join(
        line + ",," if line[:1].isdigit() else line for line in t.split("\n")
    ),
    "non-empty extra cell": _nexus_row(70, "171,0" + ",1" * 117 + ",9"),
    "short row": _nexus_row(50, "151,0,1.0"),
    "bad cell": _nexus_row(60, "161,0,x" + ",1" * 116),
    "bad cell, second chunk": _nexus_row(100, "201,0" + ",1" * 116 + ",x"),
    "bad cell, short row after": lambda t: _nexus_row(100, "201")(
        _nexus_row(10, "111,0,x" + ",1" * 116)(t)
    ),
    "missing frame number": _nexus_row(90, ",0" + ",1" * 117),
    "frame numbers going back": _nexus_row(90, "150,0" + ",1" * 117),
    "bad rate": lambda t: t.replace("Trajectories\n100\n", "Trajectories\nfast\n"),
    "Latin-1 name": lambda t: t.replace("LASI", "L\xc4SI"),
}


@pytest.mark.slow
@pytest.mark.parametrize("variant", list(NEXUS_VARIANTS))
def test_chunked_nexus_csv_equals_load_markers(tmp_path: Path, variant: str) -> None:
    """Vicon Nexus rows parsed ``CHUNK`` at a time into a memory map: the same positions,
    times, source and errors (the first in the block) as the whole read."""
    path = tmp_path / "v.csv"
    path.write_bytes(NEXUS_VARIANTS[variant](_nexus_text()).encode("latin-1"))
    how = _same(path)
    errors = ("non-empty extra cell", "short row", "bad cell", "bad cell, second chunk")
    errors += ("bad cell, short row after", "missing frame number", "frame numbers going back")
    errors += ("bad rate", "units m, the values mm")  # the header's, the units check's
    assert how == ("error" if variant in errors else "in chunks")


def _motive_text() -> str:
    """A synthetic ROM as an OptiTrack Motive export (a rigid body's 7 columns before the
    markers, an unlabelled marker after; Y up; a few samples missing)."""
    from test_io_readers import motive_text

    return motive_text(ParameterSet().marker_names, _markers_of(120) * 1000.0, 100.0)


def _motive_row(k: int, cells: str) -> Callable[[str], str]:
    """The Motive text with data row k replaced (rigid body 7 cells, markers, 3 more)."""
    return lambda t: _rows(t, _set(7 + k, cells))


MOTIVE_VARIANTS: dict[str, Callable[[str], str]] = {
    "as written": lambda t: t,
    "CRLF": lambda t: t.replace("\n", "\r\n"),
    "trailing blank lines": lambda t: t + "\n\n  \n",
    "no frame rate (from the times)": lambda t: t.replace("Frame Rate,100.000000,", "Rate,x,"),
    "bad cell in the rigid body": _motive_row(30, "30,0.3,x" + ",1" * 126),
    "blank line inside": _motive_row(40, ""),
    "narrow row": _motive_row(50, "50,0.5,1.0"),
    "non-empty extra cell": _motive_row(70, "70,0.7" + ",1" * 127 + ",9"),
    "bad cell": _motive_row(60, "60,0.6" + ",1" * 7 + ",x" + ",1" * 119),
    "bad cell, narrow row after": lambda t: _motive_row(100, "100")(
        _motive_row(10, "10,0.1" + ",1" * 7 + ",x" + ",1" * 119)(t)
    ),
    "times going back": _motive_row(90, "90,0.5" + ",1" * 127),
    "Latin-1 name": lambda t: t.replace("LASI", "L\xc4SI"),
}


@pytest.mark.slow
@pytest.mark.parametrize("variant", list(MOTIVE_VARIANTS))
def test_chunked_motive_csv_equals_load_markers(tmp_path: Path, variant: str) -> None:
    """OptiTrack Motive rows parsed ``CHUNK`` at a time into a memory map (the marker columns
    only): the same positions, times, source and errors as the whole read."""
    path = tmp_path / "v.csv"
    path.write_bytes(MOTIVE_VARIANTS[variant](_motive_text()).encode("latin-1"))
    how = _same(path)
    errors = ("blank line inside", "narrow row", "non-empty extra cell", "bad cell")
    errors += ("bad cell, narrow row after", "times going back")
    assert how == ("error" if variant in errors else "in chunks")
