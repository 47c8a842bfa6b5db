"""``mocap_mj.identify`` on what ``load_markers`` returns runs the command's whole pipeline
(labels corrected, a marker set's landmarks measuring the knees, frames, excluded markers):
the API and ``mocap-mj identify`` give theta equal to the last bit on a recording with a label
exchange and on a set with medial markers, and a result folder's ``recipe.yaml`` alone re-runs
the command bit for bit; a flag given overrides its recipe field."""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from _motion import smooth_motion

import mocap_mj
from mocap_mj import Kinematics, ParameterSet, cli
from mocap_mj.capture.marker_set import load_marker_set, model_with_marker_set
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv
from mocap_mj.skeleton.mjcf import model_path
from mocap_synth import SynthConfig, synthesize, write_experiment

#: The medial set's subject: epicondyles 130 mm apart (a 116 mm knee, 14 mm markers).
HALF = 0.065
FRAMES = 150


def _command(out: Path, *options: str) -> np.ndarray:
    """theta.json of ``mocap-mj identify OPTIONS --out OUT``, named by its model's markers."""
    assert cli.main(["identify", "--json", "--out", str(out), *options]) == 0
    return ParameterSet(out / "model.xml").load_json(out / "theta.json")


@pytest.fixture(scope="module")
def swapped(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic range of motion whose LKNE and RKNE labels are exchanged for a while."""
    folder = tmp_path_factory.mktemp("swap")
    exp = synthesize(SynthConfig(frames=FRAMES, seed=3, swaps=1), ParameterSet())
    assert exp.swapped, "the synthetic trial has no exchange"
    write_experiment(exp, folder)
    return folder / "markers.csv"


@pytest.fixture(scope="module")
def medial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A subject with wide knees in the bundled Plug-in Gait set with medial markers."""
    folder = tmp_path_factory.mktemp("medial")
    marker_set = load_marker_set(model_path("marker_sets/plug_in_gait_medial.yaml"))
    (folder / "medial.xml").write_text(model_with_marker_set(marker_set).to_xml())
    pset = ParameterSet(folder / "medial.xml")
    truth = pset.nominal.copy()
    for name, y in (("LKNE", HALF), ("LKNEM", -HALF), ("RKNE", -HALF), ("RKNEM", HALF)):
        truth[pset.n_kappa + 3 * pset.marker_index(name) + 1] = y
    kin = Kinematics(pset)
    qpos = smooth_motion(kin, FRAMES, seed=6)
    kin.set_theta(truth)
    rng = np.random.default_rng(7)
    x = kin.marker_positions(qpos) + rng.normal(0.0, 1e-3, (FRAMES, pset.n_markers, 3))
    path = folder / "medial.csv"
    save_csv(path, MarkerTrajectory(np.arange(FRAMES) / 100.0, x, pset.marker_names, 100.0))
    return path


@pytest.mark.slow
def test_api_corrects_the_exchange_as_the_command_does(
    swapped: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    by_command = _command(tmp_path / "cli", "--markers", str(swapped))
    with caplog.at_level(logging.WARNING, logger="mocap_mj.notices"):
        fit = mocap_mj.identify([load_markers(swapped)])
    assert np.array_equal(fit.theta, by_command)
    (entry,) = fit.report.quality.relabelled
    assert entry.applied and {"LKNE", "RKNE"} <= set(entry.message.split())
    assert entry.after < entry.before  # [m]: the correction fits better
    assert any(r.getMessage().startswith("relabelled: ") for r in caplog.records)
    # Without the correction the fit differs: the exchange matters to theta.
    unfixed = mocap_mj.identify([load_markers(swapped)], mocap_mj.Recipe(relabel=False))
    assert not np.array_equal(unfixed.theta, fit.theta)
    # The folder's recipe alone re-runs the command.
    again = _command(tmp_path / "again", "--markers", str(swapped), "--recipe",
                     str(tmp_path / "cli" / "recipe.yaml"))  # fmt: skip
    assert np.array_equal(again, by_command)


@pytest.mark.slow
def test_api_measures_the_knees_of_a_medial_set_as_the_command_does(
    medial: Path, tmp_path: Path
) -> None:
    out = tmp_path / "cli"
    by_command = _command(out, "--markers", str(medial), "--marker-set", "plug_in_gait_medial")
    recipe = mocap_mj.Recipe(marker_set="plug_in_gait_medial")
    fit = mocap_mj.identify([load_markers(medial)], recipe)
    assert "LKNEM" in fit.pset.marker_names
    assert np.array_equal(fit.theta, by_command)
    widths = fit.subject.to_dict()
    assert widths["knee_width_l"]["value"] == pytest.approx(2 * HALF - 0.014, abs=0.003)
    again = _command(tmp_path / "again", "--markers", str(medial), "--recipe",
                     str(out / "recipe.yaml"))  # fmt: skip
    assert np.array_equal(again, by_command)


@pytest.mark.slow
def test_a_recipe_holds_frames_exclusions_and_loss_and_a_flag_overrides_it(
    swapped: Path, tmp_path: Path
) -> None:
    flags = ["--frames", "10:140", "--exclude-markers", "RFIN", "--loss", "huber"]
    by_command = _command(tmp_path / "cli", "--markers", str(swapped), *flags)
    recipe = mocap_mj.Recipe.load(tmp_path / "cli" / "recipe.yaml")
    assert (recipe.frames, recipe.exclude_markers, recipe.loss) == ("10:140", ("RFIN",), "huber")
    fit = mocap_mj.identify([load_markers(swapped)], recipe)
    assert np.array_equal(fit.theta, by_command)
    again = _command(tmp_path / "again", "--markers", str(swapped), "--recipe",
                     str(tmp_path / "cli" / "recipe.yaml"))  # fmt: skip
    assert np.array_equal(again, by_command)
    # --frames given overrides the recipe's frames, the rest of the recipe kept.
    other = _command(tmp_path / "other", "--markers", str(swapped), "--recipe",
                     str(tmp_path / "cli" / "recipe.yaml"), "--frames", "0:140")  # fmt: skip
    written = mocap_mj.Recipe.load(tmp_path / "other" / "recipe.yaml")
    assert written == replace(recipe, frames="0:140")
    assert not np.array_equal(other, by_command)


def test_the_recipes_run_fields_round_trip_and_bad_ones_are_one_line(tmp_path: Path) -> None:
    recipe = mocap_mj.Recipe(
        model="base.xml", marker_set="plug_in_gait_medial", exclude_markers=["RFIN", "LFIN"],
        frames="10:-5", relabel=False, strict=True,
    )  # fmt: skip
    assert recipe.exclude_markers == ("RFIN", "LFIN")
    recipe.save(tmp_path / "r.yaml")
    assert mocap_mj.Recipe.load(tmp_path / "r.yaml") == recipe
    for text, words in (
        ("frames: 1-2\n", ["bad.yaml", "--frames", "1-2"]),
        ("exclude_markers: RFIN\n", ["bad.yaml", "exclude_markers"]),
        ("relabel: no way\n", ["bad.yaml", "relabel"]),
        ("marker_set: 3\n", ["bad.yaml", "marker_set", "3"]),
    ):
        (tmp_path / "bad.yaml").write_text(text)
        with pytest.raises(mocap_mj.InputFileError) as err:
            mocap_mj.Recipe.load(tmp_path / "bad.yaml")
        assert "\n" not in str(err.value) and all(w in str(err.value) for w in words), err.value
