"""Values no lab and no person can produce are refused where they enter, naming where.

Coordinates beyond 1 km (after unit conversion) in any marker format, subject measurements
outside the human ranges (flags, subject files, C3D PROCESSING groups), and numeric flags
outside their domain: one line naming the file and marker and frame, or the flag and range.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from mocap_mj.anatomy.plausibility import implausible_reasons
from mocap_mj.capture.subject import from_c3d, from_yaml
from mocap_mj.errors import InputFileError, MocapError
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
#: The number each file gives its first row (messages name the recording's own frames).
FIRST_FRAME = {"csv": 0, "trc": 1, "c3d": 1}


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
        frame = FIRST_FRAME[kind] + 2
        assert message.startswith(f"{path}: B: frame {frame} (t = 0.020 s): expected coordinates "
                                  "within 1000 m of the origin"), message  # fmt: skip
        assert f"got {value * 1e-3:.4g} m" in message and "\n" not in message


@pytest.mark.parametrize("kind", sorted(WRITERS))
def test_every_frame_far_is_called_far_not_a_unit_error(tmp_path: Path, kind: str) -> None:
    pos = TRUTH_MM.copy()
    pos[:, 1] = 1e30
    path = WRITERS[kind](tmp_path / f"far.{kind}", pos)
    frame = FIRST_FRAME[kind]
    with pytest.raises(
        InputFileError, match=rf": B: frame {frame} \(t = 0.000 s\): expected coord"
    ):
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


# ---------------------------------------------------------------- subject measurements


@pytest.fixture(scope="module")
def synth_markers(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from mocap_synth import SynthConfig, synthesize, write_experiment

    root = tmp_path_factory.mktemp("values")
    write_experiment(synthesize(SynthConfig(frames=40, seed=5)), root / "synth")
    return root / "synth" / "markers.csv"


def _identify(markers: Path, out: Path, *flags: str) -> tuple[int, str, str]:
    proc = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(markers),
         "--out", str(out), *flags],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    return proc.returncode, proc.stdout, proc.stderr


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--height", "5000"], "argument --height: expected a standing height within "
         "0.5..2.75 m (any person), got '5000' = 5 m; a bare number is mm"),
        (["--height", "1.75"], "argument --height: expected a standing height within "
         "0.5..2.75 m (any person), got '1.75' = 0.00175 m; a bare number is mm: give the "
         "unit, e.g. 1750mm, 175cm, 1.75m"),
        (["--height", "1e308"], "argument --height: expected a standing height within"),
        (["--subject-file", "{s}"], "{s}: knee_width_r: expected a distance between the femoral "
         "epicondyles (right) within 30..300 mm (any person), got 5000 mm"),
        (["--mass", "nan"], "--mass: expected a body mass within 2..650 kg (any person), got nan"),
        (["--recipe", "{r0}"], "{r0}: observable_std: expected a standard deviation in m "
                               "within 1e-05..1, got 0"),
        (["--recipe", "{r1}"], "{r1}: observable_std: expected a standard deviation in m "
                               "within 1e-05..1, got -0.001"),
        (["--recipe", "{r2}"], "{r2}: symmetric: expected a width in m within 0.0001..1, got 0"),
    ],
)  # fmt: skip
@pytest.mark.slow
def test_values_no_person_has_are_refused_naming_the_flag_and_range(
    synth_markers: Path, tmp_path: Path, flags: list[str], message: str
) -> None:
    files = {
        "s": ("s.yaml", "knee_width_l: 100 mm\nknee_width_r: 5000 mm\n"),
        "r0": ("r0.yaml", "observable_std: 0\n"),
        "r1": ("r1.yaml", "observable_std: -0.001\n"),
        "r2": ("r2.yaml", "symmetric: 0\n"),
    }
    paths = {}
    for key, (name, text) in files.items():
        paths[key] = tmp_path / name
        paths[key].write_text(text)
    flags = [f.format(**paths) for f in flags]
    message = message.format(**paths)
    code, _, err = _identify(synth_markers, tmp_path / "out", *flags)
    assert code == 2, err
    assert message in err and "Traceback" not in err
    assert f"mocap-mj identify: error: {message}" in err.splitlines()[-1]
    assert not (tmp_path / "out").exists()


def test_subject_file_and_c3d_values_name_the_file_and_key(tmp_path: Path) -> None:
    f = tmp_path / "s.yaml"
    f.write_text("height: 1700\n")  # millimetres written where metres are meant
    with pytest.raises(MocapError) as info:
        from_yaml(f)
    assert str(info.value) == (
        f"{f}: height: expected a standing height within 500..2750 mm (any person), got "
        "1.7e+06 mm (a number without a unit is in m or kg)"
    )
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = ("LKNE",)
    c3d["data"]["points"] = np.ones((4, 1, 3))
    c3d.add_parameter("PROCESSING", "LKneeWidth", [1400.0])  # cm read as mm, or a typo
    c3d.write(str(tmp_path / "s.c3d"))
    expected = r"s\.c3d: PROCESSING:LKneeWidth: expected a distance between the femoral "
    with pytest.raises(MocapError, match=expected + r"epicondyles \(left\) within 30\.\.300 mm"):
        from_c3d(tmp_path / "s.c3d")


def test_broken_subject_file_is_one_line_naming_the_line(tmp_path: Path) -> None:
    f = tmp_path / "s.yaml"
    f.write_text("height: 1.7\nmass: [70\n")
    with pytest.raises(MocapError) as info:
        from_yaml(f)
    assert str(info.value).startswith(f"{f}: expected a YAML subject file: line 3, column 1: ")
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------- implausible fits


@pytest.mark.slow
def test_a_recording_in_centimetres_read_as_millimetres_exits_3(
    synth_markers: Path, tmp_path: Path
) -> None:
    """A person 10 times too small fits as no person: the result is written for
    inspection, the reasons are one line, the exit status is 3 and summary.json says so."""
    lines = synth_markers.read_text().splitlines()
    rows = [",".join([*r.split(",")[:2], *(f"{float(v) / 10:.4f}" for v in r.split(",")[2:])])
            for r in lines[2:]]  # fmt: skip
    small = tmp_path / "cm.csv"
    small.write_text("\n".join([*lines[:2], *rows]) + "\n")  # the header still says mm
    code, _, err = _identify(small, tmp_path / "out")
    assert code == 3, err
    last = err.strip().splitlines()[-1]
    assert last.startswith(
        f"mocap-mj identify: implausible result (exit status 3; written to {tmp_path / 'out'} "
        "for inspection): "
    )
    assert "stature 0.1" in last and "outside any person's 0.5..2.75 m" in last
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["exit_status"] == 3 and summary["implausible"]
    assert (tmp_path / "out" / "model.xml").is_file() and "Traceback" not in err


def test_implausible_reasons_thresholds() -> None:
    assert implausible_reasons(0.004, 0, 34, 1.68) == []
    assert implausible_reasons(0.029, 17, 34, 0.5) == []
    (rmse,) = implausible_reasons(0.111, 0, 34, 1.7)
    assert rmse.startswith("marker RMSE 111 mm, above the 30 mm")
    (bound,) = implausible_reasons(0.01, 26, 34, None)
    assert bound.startswith("26 of 34 kinematic parameters held at a bound")
    assert len(implausible_reasons(float("nan"), 0, 34, 3.0)) == 2


@pytest.mark.slow
def test_an_overflowed_fit_reports_nothing_observable_instead_of_failing() -> None:
    """A fit whose information overflowed (NaN) reports every direction unobservable: the
    report is written (the fit's checks then call it implausible), no SVD error."""
    from mocap_mj.skeleton.parameters import ParameterSet
    from mocap_mj.solve.identifiability import Identifiability

    pset = ParameterSet()
    info = np.eye(pset.size)
    info[3, 5] = info[5, 3] = np.nan
    idf = Identifiability(pset, info, 3e26)
    data = idf.to_json()
    assert data["observable_directions"] == 0
    assert len(data["directions"]) == pset.size
    assert idf.report_lines()[0] == "## Identifiability"
