"""The Python API (``mocap_mj.identify``, ``Recipe``, ``write_result``, ``solve_motion``) and the
command line compute the same thing: theta to the last bit, on a synthetic trial and on a
shared recording, and a result folder's ``recipe.yaml`` re-runs it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import mocap_mj
from mocap_mj import cli
from mocap_mj.capture.subject import from_c3d
from mocap_mj.errors import InputFileError
from mocap_mj.io import load_markers
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.skeleton.mjcf import load_model
from mocap_synth import SynthConfig, synthesize, write_experiment

STATIC = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "Static_trial.c3d"
#: The frames of the shared recording both runs fit: enough for a determined fit, quick.
WINDOW = (0, 100)


def _api_fit(path: Path, window: tuple[int, int] | None, recipe: mocap_mj.Recipe) -> mocap_mj.Fit:
    """The README's Python API example, step by step: read the markers in the model's marker
    order, keep the frames of ``window``, read the subject's measurements a C3D file carries
    and identify."""
    pset = mocap_mj.ParameterSet()
    traj = load_markers(str(path), model_names=pset.marker_names)
    a, b = window or (0, len(traj.times))
    markers, times = traj.select(pset.marker_names)[a:b], traj.times[a:b]
    recording = mocap_mj.Recording(str(path), markers, times, traj.rate, first_frame=a)
    subject = from_c3d(path) if path.suffix.lower() == ".c3d" else None
    return mocap_mj.identify([recording], recipe, subject, pset=pset)


def _command(out: Path, *options: str) -> np.ndarray:
    assert cli.main(["identify", "--json", "--out", str(out), *options]) == 0
    return mocap_mj.ParameterSet().load_json(out / "theta.json")


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("synth")
    write_experiment(synthesize(SynthConfig(frames=80, seed=3), mocap_mj.ParameterSet()), folder)
    return folder / "markers.csv"


def test_recipe_round_trips_through_yaml(tmp_path: Path) -> None:
    recipe = mocap_mj.Recipe(loss="huber", symmetric=0.004, select=500, trial_weights=False)
    recipe.save(tmp_path / "recipe.yaml")
    assert mocap_mj.Recipe.load(tmp_path / "recipe.yaml") == recipe
    (tmp_path / "partial.yaml").write_text("loss: cauchy\n")
    assert mocap_mj.Recipe.load(tmp_path / "partial.yaml") == mocap_mj.Recipe(loss="cauchy")


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("los: cauchy\n", ["bad.yaml", "'los'"]),
        ("anatomy: 3\n", ["bad.yaml", "'anatomy'", "3"]),
        ("loss: square\n", ["bad.yaml", "square"]),
        ("select: some\n", ["bad.yaml", "some"]),
        ("- a list\n", ["bad.yaml", "mapping"]),
    ],
)
def test_a_bad_recipe_file_is_one_line_naming_file_and_field(
    tmp_path: Path, text: str, words: list[str]
) -> None:
    (tmp_path / "bad.yaml").write_text(text)
    with pytest.raises(InputFileError) as err:
        mocap_mj.Recipe.load(tmp_path / "bad.yaml")
    message = str(err.value)
    assert "\n" not in message and all(w in message for w in words), message


@pytest.mark.slow
def test_api_and_command_give_the_same_theta_on_a_synthetic_trial(
    synthetic: Path, tmp_path: Path
) -> None:
    recipe = mocap_mj.Recipe(loss="huber", max_iterations=30, sliding_landmarks=False)
    mocap_mj.Recipe(max_iterations=30, sliding_landmarks=False).save(tmp_path / "r.yaml")
    flags = ["--loss", "huber", "--recipe", str(tmp_path / "r.yaml")]
    by_command = _command(tmp_path / "cli", "--markers", str(synthetic), *flags)
    fit = _api_fit(synthetic, None, recipe)
    assert np.array_equal(fit.theta, by_command)
    # The folder written from the fit holds the command's theta.json and recipe, byte for byte.
    mocap_mj.write_result(fit, tmp_path / "api")
    for name in ("theta.json", "recipe.yaml", "model.xml", "motion.npz"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert mocap_mj.Recipe.load(tmp_path / "cli" / "recipe.yaml") == recipe
    # --recipe of the folder re-runs it without the flags.
    again = _command(
        tmp_path / "again",
        "--markers",
        str(synthetic),
        "--recipe",
        str(tmp_path / "cli" / "recipe.yaml"),
    )
    assert np.array_equal(again, by_command)


def test_a_fit_names_its_checks_in_si(synthetic: Path) -> None:
    """Fit's checks (parameters outside their range, implausible, each marker's RMSE) are
    typed and in metres: summary.json's figures (mm) divided by 1000, and they follow the
    ranges given."""
    from dataclasses import replace

    fit = _api_fit(synthetic, None, mocap_mj.Recipe(max_iterations=10, sliding_landmarks=False))
    summary = fit.summary()
    written = summary["kappa_outside_bounds_mm"]
    outside = fit.kappa_outside_bounds()
    assert set(outside) == set(written)
    for name, row in outside.items():
        assert np.allclose(np.array(row) * 1e3, written[name], rtol=0, atol=1e-9), name
    assert list(fit.implausible) == summary["implausible"]
    per_marker = fit.report.checks.marker_rmse_by_marker
    assert list(per_marker) == list(fit.pset.marker_names)
    for name, v in summary["marker_rmse_by_marker_mm"].items():
        assert v == pytest.approx(per_marker[name] * 1e3, abs=1e-9), name
    assert summary["seconds"] == fit.timings["seconds"] > 0
    kappa = fit.theta[: fit.pset.n_kappa]
    narrow = replace(fit, ranges=(kappa + 0.01, kappa + 0.02))  # every length below its range
    moved = narrow.kappa_outside_bounds()
    assert list(moved) == list(fit.pset.kappa_names)
    assert np.allclose([moved[n][0] for n in moved], kappa, rtol=0, atol=0)
    assert np.allclose([moved[n][1] - moved[n][0] for n in moved], 0.01, rtol=0, atol=1e-12)


@pytest.mark.slow
@pytest.mark.skipif(not STATIC.exists(), reason=f"{STATIC} (shared real recording) not present")
def test_api_and_command_give_the_same_theta_on_a_real_recording(tmp_path: Path) -> None:
    frames = f"{WINDOW[0]}:{WINDOW[1]}"
    by_command = _command(tmp_path / "cli", "--markers", str(STATIC), "--frames", frames)
    fit = _api_fit(STATIC, WINDOW, mocap_mj.Recipe())
    assert np.array_equal(fit.theta, by_command)
    # The fit's SI figures are the summary's millimetres.
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert fit.marker_rmse * 1e3 == pytest.approx(summary["marker_rmse_mm"], rel=1e-12)
    assert fit.theta_std.shape == fit.theta.shape and np.all(np.isfinite(fit.theta_std))
    centres = fit.joint_centres(0)
    assert centres.shape[0] == WINDOW[1] - WINDOW[0] and centres.shape[2] == 3
    again = _command(
        tmp_path / "again", "--markers", str(STATIC), "--frames", frames,
        "--recipe", str(tmp_path / "cli" / "recipe.yaml"),
    )  # fmt: skip
    assert np.array_equal(again, by_command)


@pytest.mark.slow
@pytest.mark.skipif(not STATIC.exists(), reason=f"{STATIC} (shared real recording) not present")
def test_the_readme_example_is_the_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The README's Python API block, run as it is on the shared static trial (as
    ``trial.c3d``), gives the theta of ``mocap-mj identify --markers trial.c3d``."""
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    code = re.search(r"## Python API.*?```python\n(.*?)```", readme, re.S)
    assert code is not None, "README.md has no Python API example"
    (tmp_path / "trial.c3d").symlink_to(STATIC)
    monkeypatch.chdir(tmp_path)
    names: dict[str, object] = {}
    exec(code.group(1), names)
    fit = names["fit"]
    assert isinstance(fit, mocap_mj.Fit)
    by_command = _command(tmp_path / "cli", "--markers", "trial.c3d")
    assert np.array_equal(fit.theta, by_command)
    written = (tmp_path / "result" / "theta.json").read_bytes()
    assert written == (tmp_path / "cli" / "theta.json").read_bytes()


@pytest.mark.slow
def test_selection_in_memory_equals_the_streamed_motion(synthetic: Path, tmp_path: Path) -> None:
    """A selected (long-recording) identification: the API's motion of every frame in memory
    is the command's motion.npz, solved chunk by chunk into files."""
    recipe = mocap_mj.Recipe(select=40, sliding_landmarks=False, max_iterations=20)
    recipe.save(tmp_path / "r.yaml")
    flags = ["--recipe", str(tmp_path / "r.yaml")]
    by_command = _command(tmp_path / "cli", "--markers", str(synthetic), *flags)
    fit = _api_fit(synthetic, None, recipe)
    assert np.array_equal(fit.theta, by_command)
    assert fit.motion is not None and fit.summary()["frames_selected"]
    streamed = load_motion(
        tmp_path / "cli" / "motion.npz", load_model(tmp_path / "cli" / "model.xml")
    )
    assert len(fit.motion[0].qpos) == 80
    assert np.array_equal(fit.motion[0].qpos, streamed.qpos, equal_nan=True)


def test_solve_motion_is_the_ik_command(synthetic: Path, tmp_path: Path) -> None:
    assert (
        cli.main(["ik", "--json", "--markers", str(synthetic), "--out", str(tmp_path / "ik")]) == 0
    )
    pset = mocap_mj.ParameterSet()
    traj = load_markers(str(synthetic), model_names=pset.marker_names)
    trial = mocap_mj.TrialData(str(synthetic), traj.select(pset.marker_names), traj.times)
    motion = mocap_mj.solve_motion(pset, trial)
    written = load_motion(tmp_path / "ik" / "motion.npz", load_model(tmp_path / "ik" / "model.xml"))
    assert np.array_equal(motion.qpos, written.qpos, equal_nan=True)
    summary = json.loads((tmp_path / "ik" / "summary.json").read_text())
    assert motion.ik is not None and motion.ik.rmse() * 1e3 == summary["marker_rmse_mm"]
