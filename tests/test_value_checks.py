"""Values no lab and no person can produce are refused where they enter, naming where.

Coordinates beyond 1 km (after unit conversion) in any marker format, subject measurements
outside the human ranges (flags, subject files, C3D PROCESSING groups), and numeric flags
outside their domain: one line naming the file and marker and frame, or the flag and range.
"""

from __future__ import annotations

from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.errors import InputFileError
from mocap_mj.io import load_markers
from mocap_mj.io.stream import open_markers

# Two markers 1.5 m apart over three frames, in mm: a human-sized cloud.
TRUTH_MM = np.array(
    [[[10.0, 20.0, 30.0], [15.0, 25.0, 1530.0]],
     [[11.0, 21.0, 31.0], [16.0, 26.0, 1531.0]],
     [[12.0, 22.0, 32.0], [17.0, 27.0, 1532.0]]]
)  # fmt: skip


def _csv(path: Path, pos: np.ndarray, units: str = "mm") -> Path:
    rows = [f"# mocap-mj markers v1 units={units} rate=100", "frame,time,A_X,A_Y,A_Z,B_X,B_Y,B_Z"]
    rows += [",".join([str(t), f"{t / 100:g}", *(f"{v:g}" for v in pos[t].ravel())])
             for t in range(len(pos))]  # fmt: skip
    path.write_text("\n".join(rows) + "\n")
    return path


def _trc(path: Path, pos: np.ndarray, units: str = "mm") -> Path:
    head = [
        "PathFileType\t4\t(X/Y/Z)\tx.trc",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits",
        f"100\t100\t{len(pos)}\t2\t{units}",
        "Frame#\tTime\tA\t\t\tB\t\t",
        "\t\tX1\tY1\tZ1\tX2\tY2\tZ2",
        "",
    ]
    rows = ["\t".join([str(t + 1), f"{t / 100:g}", *(f"{v:g}" for v in pos[t].ravel())])
            for t in range(len(pos))]  # fmt: skip
    path.write_text("\n".join(head + rows) + "\n")
    return path


def _c3d(path: Path, pos: np.ndarray, units: str = "mm") -> Path:
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B"]
    c3d["parameters"]["POINT"]["UNITS"]["value"] = [units]
    points = np.ones((4, 2, len(pos)))
    points[:3] = pos.transpose(2, 1, 0)
    c3d["data"]["points"] = points
    c3d.write(str(path))
    return path


WRITERS = {"csv": _csv, "trc": _trc, "c3d": _c3d}


@pytest.mark.parametrize("kind", sorted(WRITERS))
@pytest.mark.parametrize("value", [1e30, -2.5e6])
def test_a_coordinate_no_lab_can_produce_is_refused_naming_marker_and_frame(
    tmp_path: Path, kind: str, value: float
) -> None:
    pos = TRUTH_MM.copy()
    pos[2, 1, 0] = value  # B, frame 2, x
    path = WRITERS[kind](tmp_path / f"far.{kind}", pos)
    for read in (load_markers, open_markers):
        with pytest.raises(InputFileError) as info:
            read(path, up="z")
        message = str(info.value)
        assert message.startswith(f"{path}: B: frame 2 (t = 0.020 s): expected coordinates "
                                  "within 1000 m of the origin"), message  # fmt: skip
        assert f"got {value * 1e-3:.4g} m" in message and "\n" not in message


@pytest.mark.parametrize("kind", sorted(WRITERS))
def test_every_frame_far_is_called_far_not_a_unit_error(tmp_path: Path, kind: str) -> None:
    pos = TRUTH_MM.copy()
    pos[:, 1] = 1e30
    path = WRITERS[kind](tmp_path / f"far.{kind}", pos)
    with pytest.raises(InputFileError, match=r": B: frame 0 \(t = 0.000 s\): expected coord"):
        load_markers(path, up="z")


def test_a_unit_mix_up_still_names_the_unit_that_fits(tmp_path: Path) -> None:
    path = _csv(tmp_path / "mm.csv", TRUTH_MM, units="m")  # millimetres stated as metres
    with pytest.raises(InputFileError, match=r"units: expected a marker cloud .*pass --units mm$"):
        load_markers(path, up="z")


def test_a_coordinate_below_the_limit_is_read(tmp_path: Path) -> None:
    pos = TRUTH_MM.copy()
    pos[2, 1, 0] = 999_000.0  # 999 m: far, but a position
    traj = load_markers(_csv(tmp_path / "near.csv", pos), up="z")
    assert traj.positions[2, 1, 0] == pytest.approx(999.0)
