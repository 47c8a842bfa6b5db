"""The command line a person can hold in their head: few flags per command, one line for each
removed flag naming its new spelling, and a recipe and subject file that give the theta the
removed flags gave."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

import mocap_mj
from mocap_mj import cli
from mocap_mj.capture.subject import from_values
from mocap_mj.commands._removed import REMOVED, STILL_WORKS, message
from mocap_mj.io import load_markers
from mocap_synth import SynthConfig, synthesize, write_experiment

#: identify's flags at most (``-h`` aside), and every other command's.
MAX_IDENTIFY_FLAGS = 20
MAX_FLAGS = 20


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    [sub] = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def _listed_flags(parser: argparse.ArgumentParser) -> list[str]:
    """The flags ``--help`` lists (hidden removed flags and ``-h`` aside)."""
    return [
        a.option_strings[-1]
        for a in parser._actions
        if a.option_strings and "-h" not in a.option_strings and a.help != argparse.SUPPRESS
    ]


def test_identify_lists_at_most_20_flags(capsys: pytest.CaptureFixture[str]) -> None:
    identify = _commands()["identify"]
    flags = _listed_flags(identify)
    assert len(flags) <= MAX_IDENTIFY_FLAGS, flags
    identify.print_help()
    shown = capsys.readouterr().out
    assert all(f in shown for f in flags)
    assert all(f"{f} " not in shown for f in REMOVED["identify"])  # hidden from --help


@pytest.mark.parametrize("command", sorted(_commands()))
def test_every_command_lists_few_flags(command: str) -> None:
    flags = _listed_flags(_commands()[command])
    assert len(flags) <= MAX_FLAGS, (command, len(flags), flags)
    assert len(set(flags)) == len(flags)


def test_a_flag_name_keeps_one_meaning_across_commands() -> None:
    """``--height`` is a subject's height only, a length with its unit (render's image size is
    ``--size WxH``); a unit placeholder (MM, KG, PX, M) is the same wherever a flag appears;
    ``--frames`` is a range ``A:B`` everywhere (``A:B[:S]`` where a stride makes sense; a
    number of frames to make is ``--frame-count``); ``--motion`` is a motion file."""
    seen: dict[str, dict[str, str]] = {}
    for command, parser in _commands().items():
        for a in parser._actions:
            if a.option_strings and a.help != argparse.SUPPRESS:
                seen.setdefault(a.option_strings[-1], {})[command] = str(a.metavar)
    assert seen["--height"] == {"identify": "LENGTH"}
    units = {"MM", "KG", "PX", "M", "WxH"}
    for flag, by in seen.items():
        assert len({m for m in by.values() if m in units}) <= 1, (flag, by)
    assert set(seen["--frames"].values()) == {"A:B", "A:B[:S]"}, seen["--frames"]
    assert set(seen["--motion"].values()) == {"FILE"}, seen["--motion"]


@pytest.mark.parametrize(
    ("command", "flag"), [(c, f) for c, flags in REMOVED.items() for f in flags]
)
def test_a_removed_flag_is_one_line_naming_the_new_spelling(
    command: str, flag: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = {
        "identify": ["identify", "--markers", "m.c3d", "--out", str(tmp_path / "o")],
        "ik": ["ik", "--markers", "m.c3d", "--out", str(tmp_path / "o")],
        "batch": ["batch", str(tmp_path), "--out", str(tmp_path / "o")],
        "render": ["render", str(tmp_path), "--out", str(tmp_path / "o.png")],
        "synth": ["synth", "--out", str(tmp_path / "o")],
        "demo": ["demo", "--out", str(tmp_path / "o")],
    }[command]
    for values in ([], ["2"], ["paper"]):
        with pytest.raises(SystemExit) as stop:
            cli.main([*argv, flag, *values])
        assert stop.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [message(command, flag)], err
    new = REMOVED[command][flag]
    assert "use " in new or "put " in new or "experiment" in new


def test_solver_lm_still_works_with_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert STILL_WORKS["identify"]["--solver"].keys() == {"lm"}
    argv = ["identify", "--markers", str(tmp_path / "none.csv"), "--out", str(tmp_path / "o")]
    assert cli.main([*argv, "--solver", "lm"]) == 2  # the missing file, not the flag
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("mocap-mj identify: warning: --solver lm: removed;")
    assert "no such file" in err[1] and len(err) == 2


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("synth")
    write_experiment(synthesize(SynthConfig(frames=60, seed=4), mocap_mj.ParameterSet()), folder)
    return folder / "markers.csv"


@pytest.mark.slow
def test_recipe_and_subject_file_give_the_theta_of_the_removed_flags(
    synthetic: Path, tmp_path: Path
) -> None:
    """The removed flags ``--init scaled --max-iterations 25 --prior-mm 40 --observable-mm 4
    --symmetric 3 --no-sliding-landmarks --knee-width 105 --ankle-width 70 68`` became, in
    the command, this recipe and these measurements (millimetres times 1e-3): the recipe
    file and the subject file that say the same give that theta to the last bit."""
    flags_recipe = mocap_mj.Recipe(
        init="scaled",
        max_iterations=25,
        prior_sigma=40 * 1e-3,
        observable_std=4 * 1e-3,
        symmetric=3 * 1e-3,
        sliding_landmarks=False,
    )
    widths = [("knee_width", 105, 105), ("ankle_width", 70, 68)]
    pairs = [
        (f"{name}_{side}", mm * 1e-3)
        for name, left, right in widths
        for side, mm in (("l", left), ("r", right))
    ]
    flags_subject = from_values([("height", 1750 * 1e-3), *pairs], "command line")
    pset = mocap_mj.ParameterSet()
    traj = load_markers(str(synthetic), model_names=pset.marker_names)
    trial = mocap_mj.TrialData(str(synthetic), traj.select(pset.marker_names), traj.times)
    expected = mocap_mj.identify([trial], flags_recipe, flags_subject, pset=pset).theta

    (tmp_path / "recipe.yaml").write_text(
        "init: scaled\nmax_iterations: 25\nprior_sigma: 0.04\nobservable_std: 0.004\n"
        "symmetric: 0.003\nsliding_landmarks: false\n"
    )
    (tmp_path / "subject.yaml").write_text(
        "knee_width_l: 105 mm\nknee_width_r: 105 mm\nankle_width_l: 70 mm\nankle_width_r: 68 mm\n"
    )
    out = tmp_path / "new"
    argv = ["identify", "--markers", str(synthetic), "--out", str(out), "--json",
            "--recipe", str(tmp_path / "recipe.yaml"),
            "--subject-file", str(tmp_path / "subject.yaml"), "--height", "1750"]  # fmt: skip
    assert cli.main(argv) == 0
    theta = pset.load_json(out / "theta.json")
    assert np.array_equal(theta, expected)
    assert mocap_mj.Recipe.load(out / "recipe.yaml") == flags_recipe
