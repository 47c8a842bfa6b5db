"""TRC as OpenSim and vendors write it, one missing-data rule in every format, units sanity,
and C3D files the structural check refuses but ezc3d reads."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.commands.options import add_input_options
from mocap_mj.errors import InputFileError
from mocap_mj.io import load_markers
from mocap_mj.io.formats.c3d_check import check_c3d

# Two markers, three frames, millimetres: A near the floor, B 1.5 m up.
TRUTH_MM = np.array(
    [[[10.0 + t, 20.0, 100.0], [30.0, 40.0, 1500.0 + t]] for t in range(3)]
)  # (T, M, 3) [mm]
H1 = "PathFileType\t4\t(X/Y/Z)\tx.trc"
KEYS = "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
KEYS += "\tOrigNumFrames"
VALUES = "100\t100\t3\t2\tmm\t100\t1\t3"
NAMES = "Frame#\tTime\tA\t\t\tB\t\t"
AXES = "\t\tX1\tY1\tZ1\tX2\tY2\tZ2"
ROWS = ["\t".join([str(t + 1), f"{t / 100:.2f}", *(f"{v:g}" for v in TRUTH_MM[t].ravel())])
        for t in range(3)]  # fmt: skip


def _spaces(lines: list[str]) -> list[str]:
    return [" ".join(line.split()) for line in lines]


# name -> lines; every one reads as TRUTH_MM
LENIENT = {
    "base": [H1, KEYS, VALUES, NAMES, AXES, "", *ROWS],
    "crlf": [H1, KEYS, VALUES, NAMES, AXES, "", *ROWS],
    "times": [H1, KEYS, VALUES, NAMES.replace("Time", "Times"), AXES, "", *ROWS],
    "spaces": [*_spaces([H1, KEYS, VALUES, NAMES, AXES]), "", *_spaces(ROWS)],
    "doubled_tabs": [H1, *(x.replace("\t", "\t\t") for x in (KEYS, VALUES, NAMES)), AXES, *ROWS],
    "empty_column": [H1, KEYS, VALUES, NAMES + "\t", AXES + "\t", "", *(r + "\t" for r in ROWS)],
    "empty_data_column": [H1, KEYS, VALUES, NAMES, AXES,
                          *(r.replace("\t", "\t\t", 1) for r in ROWS)],
    "no_axes_line": [H1, KEYS, VALUES, NAMES, *ROWS],
    "short_axes_line": [H1, KEYS, VALUES, NAMES, "\t\tX1\tY1\tZ1", "", *ROWS],
    "long_axes_line": [H1, KEYS, VALUES, NAMES, AXES + "\tX3\tY3\tZ3", "", *ROWS],
    "trailing_columns": [H1, KEYS, VALUES, NAMES, AXES, "", *(r + "\t7\t8\t9" for r in ROWS)],
    "frames_from_100": [H1, KEYS, VALUES, NAMES, AXES, "",
                        *(f"{t + 100}" + r[r.index("\t"):] for t, r in enumerate(ROWS))],
    "five_keys": [H1, "\t".join(KEYS.split("\t")[:5]), "100\t100\t3\t2\tmm", NAMES, AXES, *ROWS],
}  # fmt: skip
# name -> (lines, the message after "{path}: ")
REFUSED = {
    "names_vs_nummarkers": (
        [H1, KEYS, VALUES.replace("\t2\tmm", "\t3\tmm"), NAMES, AXES, *ROWS],
        "line 4: expected NumMarkers=3 marker names (line 3), got 2 names",
    ),
    "axes_out_of_order": (
        [H1, KEYS, VALUES, NAMES, AXES.replace("X2\tY2", "Y2\tX2"), *ROWS],
        "line 5: expected X2 in X/Y/Z cell 4 (or no cell), got 'Y2'",
    ),
    "space_row_short": (
        [*_spaces([H1, KEYS, VALUES, NAMES, AXES]), *_spaces(ROWS[:1]), "2 0.01 11 20 100"],
        "line 7: expected 8 cells (Frame#, Time, 3 per marker), got 5",
    ),
    "no_time": (
        [H1, KEYS, VALUES, NAMES.replace("Time", "Seconds"), AXES, *ROWS],
        "line 4: expected 'Frame#' and 'Time' then marker names, got",
    ),
    "blank_inside": (
        [H1, KEYS, VALUES, NAMES, AXES, *ROWS[:2], "", ROWS[2]],
        "line 8: expected a row of data (no blank line inside), got none",
    ),
}


def _write(path: Path, lines: list[str], newline: str = "\n") -> Path:
    path.write_bytes((newline.join(lines) + newline).encode())
    return path


@pytest.mark.parametrize("name", sorted(LENIENT))
def test_trc_leniencies_read_the_same_markers(tmp_path: Path, name: str) -> None:
    path = _write(tmp_path / f"{name}.trc", LENIENT[name], "\r\n" if name == "crlf" else "\n")
    traj = load_markers(path, up="z")
    assert traj.names == ("A", "B") and traj.rate == 100.0
    np.testing.assert_allclose(traj.positions, TRUTH_MM / 1000.0, rtol=1e-12)
    np.testing.assert_allclose(traj.times, [0.0, 0.01, 0.02])
    if name == "trailing_columns":
        assert traj.source["ignored_columns"] == 3


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_trc_ambiguities_are_refused_with_the_line(tmp_path: Path, name: str) -> None:
    lines, where = REFUSED[name]
    path = _write(tmp_path / f"{name}.trc", lines)
    with pytest.raises(InputFileError) as info:
        load_markers(path, up="z")
    assert str(info.value).startswith(f"{path}: {where}")


def test_trc_row_count_other_than_numframes_is_read_with_a_warning(tmp_path: Path) -> None:
    path = _write(tmp_path / "n.trc", [H1, KEYS, VALUES.replace("\t3\t2", "\t5\t2"), NAMES, *ROWS])
    traj = load_markers(path, up="z")
    assert traj.n_frames == 3
    assert traj.source["warnings"] == [
        f"{path}: line 3: NumFrames is 5, the file holds 3 rows of data: read the 3 rows present"
    ]


@pytest.mark.skipif(importlib.util.find_spec("opensim") is None, reason="opensim not installed")
def test_every_variant_opensim_reads_we_read_identically(tmp_path: Path) -> None:
    import opensim

    read_by_opensim = 0
    for name, lines in LENIENT.items():
        path = _write(tmp_path / f"{name}.trc", lines, "\r\n" if name == "crlf" else "\n")
        try:
            table = opensim.TimeSeriesTableVec3(str(path))
        except Exception:  # OpenSim refuses it: our leniency goes further
            continue
        read_by_opensim += 1
        theirs = np.array(
            [[[table.getRowAtIndex(t)[k][i] for i in range(3)] for k in range(2)] for t in range(3)]
        )  # (T, M, 3) [file units]
        ours = load_markers(path, up="z")
        np.testing.assert_allclose(ours.positions * 1000.0, theirs, rtol=1e-12)
        assert list(table.getColumnLabels()) == list(ours.names)
    # the baseline, CRLF, doubled tabs, header empty columns, long X/Y/Z line, frame numbers
    assert read_by_opensim >= 6
    for name, (lines, _) in REFUSED.items():
        if name in ("names_vs_nummarkers", "no_time", "space_row_short"):
            with pytest.raises(Exception):  # noqa: B017  (OpenSim raises a generic error)
                opensim.TimeSeriesTableVec3(str(_write(tmp_path / f"r_{name}.trc", lines)))


# ---------------------------------------------------------------- one missing-data rule


def _c3d(path: Path, positions_mm: np.ndarray, residuals: np.ndarray | None = None) -> Path:
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B"]
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    points = np.ones((4, 2, positions_mm.shape[0]))
    points[:3] = positions_mm.transpose(2, 1, 0)
    c3d["data"]["points"] = points
    if residuals is not None:
        c3d["data"]["meta_points"] = {
            "residuals": residuals.T[None].astype(float),
            "camera_masks": np.zeros((7, 2, positions_mm.shape[0]), dtype=bool),
        }
    c3d.write(str(path))
    return path


def _text_file(tmp_path: Path, kind: str, rows_mm: np.ndarray) -> Path:
    """``rows_mm`` (T, 2, 3) written in ``kind``; NaN as an empty cell, zeros as 0."""

    def cell(v: float) -> str:
        return "" if np.isnan(v) else f"{v:g}"

    if kind == "trc":
        rows = [
            "\t".join([str(t + 1), f"{t / 100:g}", *map(cell, rows_mm[t].ravel())])
            for t in range(len(rows_mm))
        ]
        return _write(tmp_path / "m.trc", [H1, KEYS, VALUES, NAMES, AXES, "", *rows])
    if kind == "csv":
        head = ["# mocap-mj markers v1 units=mm rate=100", "frame,time,A_X,A_Y,A_Z,B_X,B_Y,B_Z"]
        rows = [",".join([str(t), f"{t / 100:g}", *map(cell, rows_mm[t].ravel())])
                for t in range(len(rows_mm))]  # fmt: skip
        return _write(tmp_path / "m.csv", head + rows)
    if kind == "nexus":
        head = ["Trajectories", "100", ",,S:A,,,S:B,,", "Frame,Sub Frame,X,Y,Z,X,Y,Z",
                ",,mm,mm,mm,mm,mm,mm"]  # fmt: skip
        rows = [",".join([str(t + 1), "0", *map(cell, rows_mm[t].ravel())])
                for t in range(len(rows_mm))]  # fmt: skip
        return _write(tmp_path / "m.nexus.csv", head + rows)
    assert kind == "motive"
    head = [
        "Format Version,1.23,Export Frame Rate,100.0,Length Units,Millimeters", "",
        ",Type,Marker,Marker,Marker,Marker,Marker,Marker", ",Name,A,A,A,B,B,B",
        ",ID,1,1,1,2,2,2", ",,Position,Position,Position,Position,Position,Position",
        "Frame,Time (Seconds),X,Y,Z,X,Y,Z",
    ]  # fmt: skip
    rows = [",".join([str(t), f"{t / 100:g}", *map(cell, rows_mm[t].ravel())])
            for t in range(len(rows_mm))]  # fmt: skip
    return _write(tmp_path / "m.motive.csv", head + rows)


@pytest.mark.parametrize("kind", ["trc", "csv", "nexus", "motive", "c3d"])
def test_zeros_empty_cells_and_nan_are_missing_in_every_format(tmp_path: Path, kind: str) -> None:
    rows = TRUTH_MM.copy()
    rows[1, 1] = 0.0  # B written as 0 0 0 in frame 2
    rows[2, 0] = np.nan  # A empty in frame 3
    residuals = None
    if kind == "c3d":
        residuals = np.zeros((3, 2))
        residuals[0, 0] = -1.0  # A flagged by a negative residual in frame 1
        path = _c3d(tmp_path / "m.c3d", np.nan_to_num(rows, nan=0.0), residuals)
    else:
        path = _text_file(tmp_path, kind, rows)
    traj = load_markers(path, up="z")
    gone = np.zeros((3, 2), dtype=bool)
    gone[1, 1] = gone[2, 0] = True
    if kind == "c3d":
        gone[0, 0] = True
    assert (np.isnan(traj.positions).all(axis=2) == gone).all()
    np.testing.assert_allclose(traj.positions[~gone], TRUTH_MM[~gone] / 1000.0, rtol=1e-12)
    assert traj.source["missing_samples"] == {"A": int(gone[:, 0].sum()), "B": 1}
    zeros = {"B": 1, "A": 1} if kind == "c3d" else {"B": 1}  # C3D writes NaN as 0 0 0
    assert traj.source["zero_samples"] == zeros
    report = str(traj.marker_report(["A", "B"]))
    assert "B          66.7%  1 missing (1 written as 0 0 0)" in report


# ---------------------------------------------------------------- units sanity


@pytest.mark.parametrize(
    ("stated", "factor", "likely"),
    [("m", 1.0, "mm"), ("mm", 1e-3, "m"), ("cm", 1.0, "mm"), ("m", 0.1, "cm")],
)
def test_units_that_do_not_fit_the_cloud_are_an_error_naming_the_flag(
    tmp_path: Path, stated: str, factor: float, likely: str
) -> None:
    values = VALUES.replace("mm", stated)
    rows = [
        "\t".join([str(t + 1), f"{t / 100:g}", *(f"{v * factor:g}" for v in TRUTH_MM[t].ravel())])
        for t in range(3)
    ]
    path = _write(tmp_path / "u.trc", [H1, KEYS, values, NAMES, AXES, *rows])
    with pytest.raises(InputFileError) as info:
        load_markers(path, up="z")
    message = str(info.value)
    assert message.startswith(f"{path}: units: expected a marker cloud 0.05..10 m across in ")
    assert message.endswith(f"the file is likely in {likely}: pass --units {likely}")
    traj = load_markers(path, up="z", units=likely)
    np.testing.assert_allclose(traj.positions, TRUTH_MM / 1000.0, rtol=1e-12)
    assert traj.source["units"] == likely and traj.source["units_note"] == "given by --units"


def test_units_flag_is_a_marker_option() -> None:
    parser = argparse.ArgumentParser()
    add_input_options(parser)
    assert parser.parse_args(["--markers", "x.trc", "--units", "cm"]).units == "cm"
    with pytest.raises(SystemExit):
        parser.parse_args(["--markers", "x.trc", "--units", "inch"])


# ---------------------------------------------------------------- C3D beyond the check


def test_c3d_the_check_refuses_but_ezc3d_reads_is_read(tmp_path: Path) -> None:
    path = _c3d(tmp_path / "odd.c3d", TRUTH_MM)
    data = bytearray(path.read_bytes())
    at = data.index(b"DESCRIPTIONS")  # a tab in a parameter name: odd, yet ezc3d reads it
    data[at + 2] = 0x09
    path.write_bytes(bytes(data))
    with pytest.raises(InputFileError, match=r"expected a printable name"):
        check_c3d(path)
    traj = load_markers(path, up="z")
    assert traj.names == ("A", "B")
    np.testing.assert_allclose(traj.positions, TRUTH_MM / 1000.0, rtol=1e-6)


def test_aliases_never_take_a_name_the_callers_model_uses(tmp_path: Path) -> None:
    lines = [H1, KEYS, VALUES, NAMES.replace("\tA\t", "\tl asis\t").replace("\tB\t", "\tLHEEL\t"),
             AXES, *ROWS]  # fmt: skip
    path = _write(tmp_path / "names.trc", lines)
    plain = load_markers(path, up="z")
    assert plain.names == ("LASI", "LHEE")
    assert plain.source["aliased"] == {"l asis": "LASI", "LHEEL": "LHEE"}
    custom = load_markers(path, up="z", model_names=("LASI", "LHEEL"))
    assert custom.names == ("LASI", "LHEEL") and custom.source["aliased"] == {"l asis": "LASI"}
