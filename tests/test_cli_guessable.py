"""A command line one can guess: a flag means one thing in every command, the commands that
read markers take the same input flags, a length carries its unit, a flag given overrides its
recipe field wherever there is a recipe, and ``--help`` answers without NumPy, MuJoCo or numba."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest

from mocap_mj import cli
from mocap_mj.batch.dataset import CHOICES, FLAGS, OPTION_KEYS, load_dataset
from mocap_mj.capture.subject import HUMAN_RANGES
from mocap_mj.commands import options
from mocap_mj.commands.batch import identify_args
from mocap_mj.commands.identify import recipe_from_args
from mocap_mj.errors import InputFileError
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.solve.losses import LossName

#: The commands that read marker recordings, and their input flags.
READERS = ("identify", "ik", "plug-in-gait")
INPUT_FLAGS = ("--markers", "--subject", "--marker-map", "--up", "--units", "--frames")


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    [sub] = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def _action(parser: argparse.ArgumentParser, flag: str) -> argparse.Action:
    return parser._option_string_actions[flag]


def test_up_is_the_input_axis_with_one_set_of_values_everywhere() -> None:
    """``--up`` takes the six axes in every command that has it (batch too); export's axis of
    the files it writes is ``--out-up``, another concept."""
    having = {c: p for c, p in _commands().items() if "--up" in p._option_string_actions}
    assert {"identify", "ik", "plug-in-gait", "batch"} <= set(having)
    for command, parser in having.items():
        action = _action(parser, "--up")
        if action.help == argparse.SUPPRESS:  # export's renamed flag
            continue
        assert tuple(action.choices or ()) == options.UP_AXES, command
        assert "vertical axis of the" in (action.help or "") or command == "batch", command
    assert tuple(_action(_commands()["export"], "--out-up").choices or ()) == ("y", "z")
    assert CHOICES["up"] == options.UP_AXES


def test_every_command_that_reads_markers_takes_the_same_input_flags() -> None:
    """The same flags, values and help (``--frames`` says which frames it picks: to fit, to
    solve)."""
    commands = _commands()
    for flag in INPUT_FLAGS[1:]:
        seen = {
            (a.help if flag != "--frames" else "", a.metavar, tuple(a.choices or ()), a.type)
            for a in (_action(commands[c], flag) for c in READERS)
        }
        assert len(seen) == 1, (flag, seen)
    for flag in ("--up", "--units", "--frames", "--subject", "--marker-map"):
        assert flag in commands["batch"]._option_string_actions, flag


@pytest.mark.parametrize("text", ["1750", "1750mm", "1750 mm", "175cm", "1.75m", "1.75 m"])
def test_a_length_may_carry_its_unit_and_a_bare_number_keeps_the_documented_one(
    text: str,
) -> None:
    parser = _commands()["identify"]
    args = parser.parse_args(["--markers", "m.c3d", "--out", "o", "--height", text])
    assert args.height == pytest.approx(1.75, rel=1e-15)
    if text == "1750":  # as the flag in mm gave it: 1750 * 1e-3, to the last bit
        assert args.height == 1750 * 1e-3


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("1.75", "got '1.75' = 0.00175 m; a bare number is mm: give the unit"),
        ("175in", "with its unit, such as 1750mm, 175cm, 1.75m"),
        ("2.9m", "within 0.5..2.75 m (any person), got '2.9m'"),
        ("nan", "with its unit"),
    ],
)
def test_an_implausible_length_is_refused_naming_the_flag_and_the_spellings(
    text: str, words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as stop:
        cli.main(["identify", "--markers", "m.c3d", "--out", "o", "--height", text])
    assert stop.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("mocap-mj identify: error: argument --height: expected a standing")
    assert words in last


def test_the_height_range_is_the_measurements() -> None:
    assert (options.HEIGHT("0.5m"), options.HEIGHT("2.75m")) == HUMAN_RANGES["height"]


def _identify_args(*flags: str) -> argparse.Namespace:
    return _commands()["identify"].parse_args(["--markers", "m.c3d", "--out", "o", *flags])


def test_a_flag_given_overrides_its_recipe_field(tmp_path: Path) -> None:
    recipe = tmp_path / "recipe.yaml"
    recipe.write_text("loss: huber\nsliding_landmarks: true\nmax_iterations: 7\n")
    base = recipe_from_args(_identify_args("--recipe", str(recipe)))
    assert (base.loss, base.sliding_landmarks, base.max_iterations) == ("huber", True, 7)
    given = recipe_from_args(
        _identify_args("--recipe", str(recipe), "--loss", "cauchy", "--no-sliding-landmarks")
    )
    assert given == Recipe(loss="cauchy", sliding_landmarks=False, max_iterations=7)
    assert recipe_from_args(_identify_args()) == Recipe()  # no flag: the recipe's defaults


def test_batch_takes_the_recipe_flags_and_passes_them_to_identify(tmp_path: Path) -> None:
    """``batch --loss`` and ``--no-sliding-landmarks`` (and a manifest's options of those
    names) reach identify as its flags; a value outside identify's choices is refused before
    any subject runs."""
    args = _commands()["batch"].parse_args(
        [str(tmp_path), "--out", "o", "--loss", "cauchy", "--no-sliding-landmarks", "--up", "y"]
    )
    assert (args.loss, args.no_sliding_landmarks, args.up) == ("cauchy", True, "y")
    passed = identify_args({"loss": "cauchy", "no_sliding_landmarks": True, "up": "y"}, [],
                           None, tmp_path)  # fmt: skip
    assert (passed.loss, passed.no_sliding_landmarks, passed.up) == ("cauchy", True, "y")
    assert recipe_from_args(passed) == Recipe(loss="cauchy", sliding_landmarks=False)
    assert recipe_from_args(identify_args({}, [], None, tmp_path)) == Recipe()
    identify = _commands()["identify"]
    for key in OPTION_KEYS:
        assert FLAGS[key] in identify._option_string_actions, key
    assert set(CHOICES["loss"]) == set(LossName.__args__)  # type: ignore[attr-defined]

    (tmp_path / "S01").mkdir()
    (tmp_path / "S01" / "walk.trc").write_text("")
    manifest = tmp_path / "m.yaml"
    manifest.write_text(
        "options: {loss: huber, no_sliding_landmarks: true}\n"
        "subjects: [{name: S01, trials: [S01/walk.trc]}]\n"
    )
    [subject] = load_dataset(manifest)
    assert dict(subject.options) == {"loss": "huber", "no_sliding_landmarks": True}
    manifest.write_text("options: {up: w}\nsubjects: [{name: S01, trials: [S01/walk.trc]}]\n")
    with pytest.raises(InputFileError, match="option 'up': expected one of x, y, z"):
        load_dataset(manifest)


def test_quality_is_one_flag_and_its_older_spellings_keep_working() -> None:
    for flags, strict, no_relabel in (
        ((), False, False),
        (("--quality", "refuse"), True, False),
        (("--quality", "warn"), False, True),
        (("--strict",), True, False),
        (("--no-relabel",), False, True),
    ):
        args = _identify_args(*flags)
        assert (args.strict, args.no_relabel) == (strict, no_relabel), flags


def test_export_up_is_renamed_out_up_and_keeps_working(
    capsys: pytest.CaptureFixture[str],
) -> None:
    parser = _commands()["export"]
    assert parser.parse_args(["R", "--out", "x.osim"]).out_up == "y"
    assert parser.parse_args(["R", "--out", "x.osim", "--out-up", "z"]).out_up == "z"
    args = parser.parse_args(["R", "--out", "x.osim", "--up", "z"])
    assert args.out_up == "z"
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "mocap-mj export: warning: --up z: renamed; use --out-up z (--up is the vertical axis "
        "of the input markers in the other commands)"
    ]
    with pytest.raises(SystemExit):
        parser.parse_args(["R", "--out", "x.osim", "--up", "x"])


def test_plates_chooses_plates_and_synth_writes_one_with_with_plate(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--plates`` is the choice of the plates that count (plug-in-gait's, gait-report's);
    synth's switch that
    writes a trial with a plate is ``--with-plate`` (``--plates`` still works, warned)."""
    having = [c for c, p in _commands().items() if "--plates" in p._option_string_actions]
    listed = [c for c in having if _action(_commands()[c], "--plates").help != argparse.SUPPRESS]
    assert sorted(listed) == ["gait-report", "plug-in-gait"]
    synth = _commands()["synth"]
    assert synth.parse_args(["--out", "o"]).plates is None
    assert synth.parse_args(["--out", "o", "--with-plate"]).plates == "75"  # kg, the default
    assert synth.parse_args(["--out", "o", "--with-plate", "60"]).plates == "60"
    assert capsys.readouterr().err == ""
    assert synth.parse_args(["--out", "o", "--plates"]).plates == "75"
    assert capsys.readouterr().err.strip().splitlines() == [
        "mocap-mj synth: warning: --plates: renamed; use --with-plate (--plates chooses the "
        "plates that count in plug-in-gait)"
    ]


#: Loaded by ``--help`` of no command.
HEAVY = ("numpy", "scipy", "mujoco", "numba", "ezc3d", "yaml")

_HELP_OF_EVERY_COMMAND = """
import contextlib, io, json, sys
from mocap_mj.cli import main
from mocap_mj.commands.registry import build_parser
import argparse
[sub] = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
for module in [m for m in sys.modules if m.split(".")[0] in HEAVY]:
    raise SystemExit(f"{module} loaded by building the parser")
found = {}
for command in [None, *sub.choices]:
    with contextlib.redirect_stdout(io.StringIO()) as text, contextlib.suppress(SystemExit):
        main([command, "--help"] if command else ["--help"])
    found[command or ""] = (
        [m for m in sys.modules if m.split(".")[0] in HEAVY], len(text.getvalue())
    )
print(json.dumps(found))
"""


def test_help_of_every_command_loads_no_numpy_mujoco_or_numba() -> None:
    """One process asks every command (the add-ons' too) for its ``--help``, in turn: none
    loads NumPy, SciPy, MuJoCo, numba, ezc3d or PyYAML (benchmarks/cli_help.py times it)."""
    code = f"HEAVY = {HEAVY!r}\n{_HELP_OF_EVERY_COMMAND}"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout)
    assert {"identify", "ik", "plug-in-gait", "export", "batch", "synth", "demo"} <= set(found)
    for command, (heavy, length) in found.items():
        assert heavy == [], (command, heavy)
        assert length > 200, command  # the help was printed


REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


@pytest.mark.slow
@pytest.mark.skipif(
    not REAL.is_dir(), reason="../shared/data/real not present: needs the shared Nexus trial"
)
def test_plug_in_gait_frames_are_the_whole_runs_rows(tmp_path: Path) -> None:
    """``plug-in-gait --frames 100:300`` writes the rows of those frames, under the
    recording's numbers, with the angles the whole trial's run gives them (Plug-in Gait's
    angles are per frame); ``--up z`` (the trial's detected axis) changes nothing."""
    import numpy as np

    path = REAL / "Movement_trial.c3d"
    whole, part = tmp_path / "whole", tmp_path / "part"
    assert cli.main(["plug-in-gait", "--markers", str(path), "--out", str(whole)]) == 0
    argv = ["plug-in-gait", "--markers", str(path), "--frames", "100:300", "--up", "z"]
    assert cli.main([*argv, "--out", str(part)]) == 0
    a = np.genfromtxt(whole / "angles.csv", delimiter=",", names=True)
    b = np.genfromtxt(part / "angles.csv", delimiter=",", names=True)
    assert len(b) == 200
    np.testing.assert_array_equal(b["frame"], a["frame"][100:300])
    for name in a.dtype.names or ():
        np.testing.assert_allclose(b[name], a[name][100:300], atol=1e-9, err_msg=name)
    summary = json.loads((part / "summary.json").read_text())
    assert summary["markers"] == str(path)
