"""Vicon's subject files (``.vsk``, ``.mp``) as ``--subject-file``: the same measurements and
Plug-in Gait values as the C3D's PROCESSING group they are copied into, their sources named,
and a malformed file refused in one line naming the file and the parameter."""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.subject import from_c3d
from mocap_mj.capture.vicon_subject import from_file, vicon_numbers
from mocap_mj.cli import main
from mocap_mj.clinical import pig_from_c3d, pig_from_file
from mocap_mj.errors import InputFileError, MocapError
from mocap_mj.io.formats.c3d import read_parameters

STATIC = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "Static_trial.c3d"
needs_static = pytest.mark.skipif(
    not STATIC.is_file(), reason="shared data absent: ../shared/data/real/Static_trial.c3d"
)


def _processing(path: Path) -> dict[str, float]:
    """The PROCESSING group's numbers, under the names Vicon's subject files give them
    (``LKneeWidth`` -> ``LeftKneeWidth``)."""
    group = read_parameters(path)["PROCESSING"]
    out = {}
    for key, entry in group.items():
        if isinstance(entry, dict) and "value" in entry:
            name = re.sub(r"^L(?=[A-Z][a-z])", "Left", re.sub(r"^R(?=[A-Z][a-z])", "Right", key))
            out[name] = float(np.asarray(entry["value"], dtype=float).ravel()[0])
    return out


def _write_vsk(path: Path, values: Mapping[str, object]) -> Path:
    rows = "\n".join(
        f'      <Parameter NAME="{k}" VALUE="{v}" PRIOR="0"/>' for k, v in values.items()
    )
    path.write_text(
        '<?xml version="1.0" encoding="UTF-8" standalone="no" ?>\n'
        '<KinematicModel VERSION="1.0" MODEL="PlugInGait">\n'
        f"  <Parameters>\n{rows}\n  </Parameters>\n"
        "  <Skeleton/>\n</KinematicModel>\n"
    )
    return path


def _write_mp(path: Path, values: Mapping[str, object]) -> Path:
    path.write_text("".join(f"${k} = {v}\n" for k, v in values.items()))
    return path


@needs_static
@pytest.mark.parametrize("kind", ["vsk", "mp"])
def test_vicon_file_of_the_processing_values_gives_the_c3d_measurements(
    tmp_path: Path, kind: str
) -> None:
    values = _processing(STATIC)
    assert values["LeftKneeWidth"] == 144.0  # the file's own, renamed as Vicon's files name it
    write = _write_vsk if kind == "vsk" else _write_mp
    path = write(tmp_path / f"subject.{kind}", {k: repr(v) for k, v in values.items()})
    ours, theirs = from_file(path), from_c3d(STATIC)
    assert {k: m.value for k, m in ours.values.items()} == {
        k: m.value for k, m in theirs.values.items()
    }
    assert ours.get("knee_width_l") == pytest.approx(0.144, abs=1e-12)
    assert ours.values["knee_width_l"].source == f"{path}: {kind}:LeftKneeWidth"
    pig_ours, pig_theirs = pig_from_file(path), pig_from_c3d(STATIC)
    assert {k: m.value for k, m in pig_ours.pig_values.items()} == {
        k: m.value for k, m in pig_theirs.pig_values.items()
    }
    flex = pig_ours.pig_values["static_plantar_flex_l"]
    assert flex.value == pytest.approx(0.25269872, abs=1e-7)
    assert flex.source == f"{path}: {kind}:LeftStaticPlantFlex"


@pytest.mark.slow
@needs_static
def test_plug_in_gait_with_the_vsk_gives_the_c3d_values_angles(tmp_path: Path) -> None:
    values = {k: repr(v) for k, v in _processing(STATIC).items()}
    vsk = _write_vsk(tmp_path / "subject.vsk", values)
    base = ["plug-in-gait", "--markers", str(STATIC), "--json"]
    assert main([*base, "--out", str(tmp_path / "c3d")]) == 0
    assert main([*base, "--subject-file", str(vsk), "--out", str(tmp_path / "vsk")]) == 0
    a = (tmp_path / "c3d" / "angles.csv").read_text()
    b = (tmp_path / "vsk" / "angles.csv").read_text()
    assert a == b


@pytest.mark.slow
def test_identify_records_the_mp_file_as_the_source(tmp_path: Path) -> None:
    import mocap_mj
    from mocap_synth import SynthConfig, synthesize, write_experiment

    write_experiment(synthesize(SynthConfig(frames=40, seed=3), mocap_mj.ParameterSet()), tmp_path)
    values = {"Bodymass": "70.5", "LeftKneeWidth": "105", "RightKneeWidth": "104",
              "HipWidth": "123.8"}  # fmt: skip
    mp = _write_mp(tmp_path / "subject.mp", values)
    out = tmp_path / "fit"
    args = ["identify", "--markers", str(tmp_path / "markers.csv"), "--subject-file", str(mp)]
    assert main([*args, "--out", str(out), "--json"]) in (0, 3)
    measured = json.loads((out / "summary.json").read_text())["measurements"]
    assert measured["mass"] == {"value": 70.5, "unit": "kg", "source": f"{mp}: mp:Bodymass"}
    assert measured["knee_width_l"]["value"] == pytest.approx(0.105)
    assert measured["knee_width_r"]["source"] == f"{mp}: mp:RightKneeWidth"
    assert "HipWidth" not in json.dumps(measured)  # a model output, not a measurement


MALFORMED = [
    ("vsk", {"Bodymass": "70", "LeftKneeWidth": "wide"},
     "parameter LeftKneeWidth: expected a number"),
    ("vsk", "<KinematicModel><Parameters>", "expected a Vicon .vsk (XML) subject file"),
    ("mp", {"Bodymass": "70", "RightAnkleWidth": "n/a"}, "line 2: parameter RightAnkleWidth"),
    ("mp", "$Bodymass = 70\nLeftKneeWidth 105\n", "line 2: expected '$Name = value'"),
    ("vsk", {"LeftKneeWidth": "1050"}, "vsk:LeftKneeWidth: expected a distance between"),
    ("vsk", {"LeftStaticPlantFlex": "14.5"},
     "parameter LeftStaticPlantFlex: expected an angle in radians"),
]  # fmt: skip


def _malformed(tmp_path: Path, kind: str, content: object) -> Path:
    path = tmp_path / f"subject.{kind}"
    if isinstance(content, dict):
        (_write_vsk if kind == "vsk" else _write_mp)(path, content)
    else:
        path.write_text(str(content))
    return path


@pytest.mark.parametrize(("kind", "content", "expected"), MALFORMED)
def test_a_malformed_vicon_file_is_refused_naming_file_and_parameter(
    tmp_path: Path, kind: str, content: object, expected: str
) -> None:
    path = _malformed(tmp_path, kind, content)
    with pytest.raises(MocapError) as err:
        pig_from_file(path)
    text = str(err.value)
    assert "\n" not in text and text.startswith(str(path)) and expected in text, text
    if "StaticPlantFlex" not in expected:  # the measurements alone (identify) refuse it too
        with pytest.raises(MocapError, match=re.escape(expected)):
            from_file(path)


@needs_static
@pytest.mark.parametrize(("kind", "content", "expected"), MALFORMED[:2])
def test_the_command_refuses_a_malformed_vicon_file_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, content: object, expected: str
) -> None:
    path = _malformed(tmp_path, kind, content)
    before = path.read_bytes()
    pig = ["plug-in-gait", "--markers", str(STATIC), "--subject-file", str(path)]
    assert main([*pig, "--out", str(tmp_path / "out")]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and str(path) in lines[0] and expected in lines[0], lines
    assert path.read_bytes() == before  # a user's file is never modified
    assert not (tmp_path / "out").exists()


def test_unknown_parameters_are_ignored_and_known_ones_read(tmp_path: Path) -> None:
    vsk = _write_vsk(tmp_path / "s.vsk", {"Bodymass": "80", "MyOwnParameter": "x",
                                          "LeftElbowWidth": "72.5"})  # fmt: skip
    assert vicon_numbers(vsk) == [("vsk", "Bodymass", 80.0), ("vsk", "LeftElbowWidth", 72.5)]
    with pytest.raises(InputFileError, match="without a NAME"):
        vicon_numbers(_write_vsk(tmp_path / "t.vsk", {"": "3"}))
