"""Malformed marker files: every case is one InputFileError line naming the file and place."""

from __future__ import annotations

from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.errors import InputFileError
from mocap_mj.io import load_markers

CSV_HEAD = "# mocap-mj markers v1 units=mm rate=100\nframe,time,A_X,A_Y,A_Z,B_X,B_Y,B_Z\n"
TRC_HEAD = (
    "PathFileType\t4\t(X/Y/Z)\tx.trc\n"
    "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n"
    "100\t100\t2\t2\tmm\n"
    "Frame#\tTime\tA\t\t\tB\t\t\n"
    "\t\tX1\tY1\tZ1\tX2\tY2\tZ2\n"
    "\n"
)
NEXUS_HEAD = "Trajectories\n100\n,,S:A,,,S:B,,\nFrame,Sub Frame,X,Y,Z,X,Y,Z\n,,mm,mm,mm,mm,mm,mm\n"
MOTIVE_HEAD = (
    "Format Version,1.23,Export Frame Rate,100.0,Length Units,Millimeters\n\n"
    ",Type,Marker,Marker,Marker\n,Name,A,A,A\n,ID,1,1,1\n,,Position,Position,Position\n"
)

# (file name, content, where the message must point: its text after "{path}: ")
TEXT_CASES = [
    ("empty.csv", "", "line 1: expected a marker file (C3D, TRC, mocap-mj CSV, Vicon Nexus CSV "
     "or OptiTrack Motive CSV), got an empty file"),
    ("blank.trc", "\n\n", "line 1: expected a marker file"),
    ("binary.dat", "\x00\x01\x02garbage", "line 1: expected a marker file"),
    ("zero_frames.csv", CSV_HEAD, "line 3: expected at least one row of data"),
    ("ragged.csv", CSV_HEAD + "0,0,1,2,3,4,5,6\n1,0.01,1,2,3,4\n", "line 4: expected 8 comma"),
    ("extra_cell.csv", CSV_HEAD + "0,0,1,2,3,4,5,6,9\n", "line 3: expected 8 comma"),
    ("word.csv", CSV_HEAD + "0,0,1,2,3,4,abc,6\n", "line 3: expected a number in column 7"),
    ("underscore.csv", CSV_HEAD + "0,0,1_000,2,3,4,5,6\n", "line 3: expected a number in column 3"),
    ("cr.csv", CSV_HEAD + "0,0,1\r5,2,3,4,5,6\n", "line 3: expected a number in column 3"),
    ("inf.csv", CSV_HEAD + "0,0,1,inf,3,4,5,6\n", "line 3: expected a number in column 4"),
    ("huge.csv", CSV_HEAD + "0,0,1,1e999,3,4,5,6\n", "line 3: expected a number in column 4"),
    ("no_time.csv", CSV_HEAD + "0,,1,2,3,4,5,6\n", "line 3: expected a value in column time"),
    ("back_time.csv", CSV_HEAD + "0,0.1,1,2,3,4,5,6\n1,0.1,1,2,3,4,5,6\n", "line 4: expected time"),
    ("bad_header.csv", "frame,time,A_X,A_Y\n0,0,1,2\n", "line 1: expected a header"),
    ("bad_triple.csv", "frame,time,A_X,A_Y,B_Z\n0,0,1,2,3\n", "line 1: expected columns"),
    ("no_header.csv", "# mocap-mj markers v1 units=mm\n", "line 2: expected a header"),
    ("bad_version.csv", "# mocap-mj markers v9\nframe,time\n", "line 1: expected '# mocap-mj"),
    ("bad_rate.csv", CSV_HEAD.replace("rate=100", "rate=fast") + "0,0,1,2,3,4,5,6\n", "line 1:"),
    ("zero_rate.csv", CSV_HEAD.replace("rate=100", "rate=0") + "0,0,1,2,3,4,5,6\n", "line 1:"),
    ("bad_up.csv", CSV_HEAD.replace("mm", "mm up=w") + "0,0,1,2,3,4,5,6\n", "line 1: expected up="),
    ("inch.csv", CSV_HEAD.replace("mm", "inch") + "0,0,1,2,3,4,5,6\n", "line 1: expected len"),
    ("one_frame_no_rate.csv", "frame,time,A_X,A_Y,A_Z\n0,0,1,2,3\n", "line 1: expected a rate"),
    ("ragged.trc", TRC_HEAD.replace("\t", " ") + "1 0 1 2 3\n2 .01 1 2 3 4 5 6\n", "line 7: "
     "expected 8 cells"),
    ("wide_narrow.trc", TRC_HEAD + "1\t0\t1\t2\t3\n2\t.01\t1\t2\t3\t4\t5\t6\t7\n",
     "line 7: expected 8 cells (Frame#, Time, 3 per marker) as on other rows"),
    ("gap.trc", TRC_HEAD + "1\t0\t1\t2\t3\t4\t5\t6\n\n2\t.01\t1\t2\t3\t4\t5\t6\n",
     "line 8: expected a row of data (no blank line inside)"),
    ("word.trc", TRC_HEAD + "1\t0\t1\t2\t3\t4\t5\t6\n2\t.01\t1\t2\tx\t4\t5\t6\n", "line 8:"),
    ("head.trc", TRC_HEAD[:60], "line 3: expected the 4 header lines"),
    ("nummarkers.trc", TRC_HEAD.replace("\t2\tmm", "\t3\tmm"), "line 4: expected NumMarkers=3"),
    ("numframes.trc", TRC_HEAD.replace("\t2\t2\t", "\tmany\t2\t"), "line 3: expected a whole"),
    ("axes.trc", TRC_HEAD.replace("X2\tY2", "Y2\tX2") + "1\t0\t1\t2\t3\t4\t5\t6\n", "line 5: "
     "expected X2 in X/Y/Z cell 4"),
    ("names.trc", TRC_HEAD.replace("Time", "Frame"), "line 4: expected 'Frame#' and 'Time'"),
    ("furlong.trc", TRC_HEAD.replace("mm", "furlong") + "1\t0\t1\t2\t3\t4\t5\t6\n"
     "2\t.01\t1\t2\t3\t4\t5\t6\n", "line 3: expected length units mm, cm or m"),
    ("nexus.csv", "Devices\n1000\n,,F,,\nFrame,Sub Frame,Fx,Fy,Fz\n", "expected a 'Trajectories'"),
    ("nexus_units.csv", NEXUS_HEAD.replace(",mm,mm,mm\n", ",m,m,m\n") + "1,0,1,2,3,4,5,6\n",
     "line 5: expected one length unit"),
    ("nexus_ragged.csv", NEXUS_HEAD + "1,0,1,2,3,4,5,6\n2,0,1,2\n", "line 7: expected 8"),
    ("nexus_empty.csv", NEXUS_HEAD, "line 6: expected at least one row"),
    ("nexus_names.csv", NEXUS_HEAD.replace("S:A,,,S:B", "S:A,S:B,,"), "line 3: expected a marker"),
    ("motive_noframe.csv", MOTIVE_HEAD, "expected a 'Frame,Time (Seconds)"),
    ("motive_inch.csv", (MOTIVE_HEAD + "Frame,Time (Seconds),X,Y,Z\n0,0,1,2,3\n").replace(
        "Millimeters", "Inches"), "line 1: expected length units"),
    ("motive_xyz.csv", MOTIVE_HEAD + "Frame,Time (Seconds),X,X,Z\n0,0,1,2,3\n", "line 7:"),
    ("motive_word.csv", MOTIVE_HEAD + "Frame,Time (Seconds),X,Y,Z\n0,0,1,two,3\n", "line 8:"),
]  # fmt: skip


@pytest.mark.parametrize(("name", "content", "where"), TEXT_CASES, ids=[c[0] for c in TEXT_CASES])
def test_malformed_text_files(tmp_path: Path, name: str, content: str, where: str) -> None:
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(InputFileError) as info:
        load_markers(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert "\n" not in message
    assert where in message
    assert "expected" in message and "got" in message


def _small_c3d(path: Path, units: str = "mm", n_frames: int = 5) -> Path:
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B"]
    c3d["parameters"]["POINT"]["UNITS"]["value"] = [units]
    points = np.ones((4, 2, n_frames))
    points[:3] = np.arange(6 * n_frames).reshape(3, 2, n_frames) + 1.0
    points[2, 1] += 1500.0  # B 1.5 m above A: a human-sized cloud in mm
    c3d["data"]["points"] = points
    c3d.write(str(path))
    return path


@pytest.mark.parametrize(
    ("cut", "where"),
    [
        (0, "header: expected a C3D file of at least 512 bytes, got 0 bytes"),
        (100, "header: expected a C3D file of at least 512 bytes"),
        (512, "truncated"),
        (700, "truncated"),
        # ezc3d pads the file to whole 512-byte blocks; the 160 data bytes start the last one
        (-512 + 31, "data section: expected at least one frame of 32 bytes"),
        (-512, "data section: expected at least one frame of 32 bytes"),
    ],
)
def test_truncated_c3d(tmp_path: Path, cut: int, where: str) -> None:
    data = _small_c3d(tmp_path / "full.c3d").read_bytes()
    path = tmp_path / "cut.c3d"
    path.write_bytes(data[:cut])
    with pytest.raises(InputFileError) as info:
        load_markers(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert where in message


@pytest.mark.parametrize(("cut", "frames"), [(-512 + 159, 4), (-512 + 100, 3), (-512 + 32, 1)])
def test_c3d_with_fewer_frames_than_declared_reads_them_and_warns_once(
    tmp_path: Path, cut: int, frames: int, caplog: pytest.LogCaptureFixture
) -> None:
    full = _small_c3d(tmp_path / "full.c3d")
    data = full.read_bytes()
    path = tmp_path / "cut.c3d"
    path.write_bytes(data[:cut])
    traj = load_markers(path)
    whole = load_markers(full)
    assert traj.n_frames == frames == ezc3d.c3d(str(path))["data"]["points"].shape[2]
    np.testing.assert_array_equal(traj.positions, whole.positions[:frames])
    expected = f"{path}: data section: the header declares 5 frames, the file holds {frames}"
    assert [r.getMessage()[: len(expected)] for r in caplog.records] == [expected]
    assert traj.source["warnings"][0].startswith(expected)


def test_c3d_garbage_and_wrong_key(tmp_path: Path) -> None:
    path = tmp_path / "noise.c3d"
    path.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(InputFileError, match=r"byte 2: expected the C3D key 0x50, got 0x01"):
        load_markers(path)
    data = bytearray(_small_c3d(tmp_path / "ok.c3d").read_bytes())
    data[0] = 0  # parameter section block number
    path.write_bytes(bytes(data))
    with pytest.raises(InputFileError, match=r"byte 1: expected the parameter section"):
        load_markers(path)


def test_c3d_unknown_units_names_the_group(tmp_path: Path) -> None:
    path = _small_c3d(tmp_path / "feet.c3d", units="ft")
    with pytest.raises(InputFileError) as info:
        load_markers(path)
    assert str(info.value) == (
        f"{path}: group POINT:UNITS: expected length units mm, cm or m, got 'ft' "
        "(pass --units to say which)"
    )
    assert load_markers(path, units="mm").source["units_note"] == "given by --units"


def test_c3d_corrupt_parameter_offset(tmp_path: Path) -> None:
    path = _small_c3d(tmp_path / "c.c3d")
    data = bytearray(path.read_bytes())
    start = (data[0] - 1) * 512 + 4  # the first group entry
    n_char = data[start]
    data[start + 2 + n_char : start + 4 + n_char] = (1).to_bytes(2, "little")  # points backward
    path.write_bytes(bytes(data))
    with pytest.raises(InputFileError, match=r"expected an offset past this entry"):
        load_markers(path)


def test_missing_file_and_directory(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match=r"no such file"):
        load_markers(tmp_path / "none.c3d")
    with pytest.raises(InputFileError, match=r"is a folder, expected a marker file"):
        load_markers(tmp_path)


def test_only_non_marker_points(tmp_path: Path) -> None:
    path = tmp_path / "outputs.csv"
    path.write_text(
        "frame,time,LKneeAngles_X,LKneeAngles_Y,LKneeAngles_Z\n0,0,1,2,3\n1,.01,1,2,3\n"
    )
    with pytest.raises(InputFileError, match=r"line 1: expected at least one marker, got none"):
        load_markers(path)
