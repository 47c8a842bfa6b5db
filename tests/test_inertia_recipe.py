"""The recipe's ``inertia: fit``: the segments' masses fitted to the force plates by ``identify``
(mocap_mj/outputs/inertia_out.py, docs/dynamics.md).

The truth (mocap_synth/plates.py): a range-of-motion trial played four times slower and leant
onto the right foot, the truth's 16 segment masses de Leva's scaled by 0.8-1.25, and a plate
under the right foot holding the wrench the truth motion needs. ``identify`` with the truth
model as its initial model (no anatomical priors, noiseless markers: the identified model is
the truth's within a fraction of a millimetre) and ``inertia: fit`` then recovers every
determined mass within 10 % of the truth (measured: 5.3 % at most) and cuts the root residual
(3.5 % of body weight before, 0.005 % after). Without a stance frame (the quiet stance of
``synth --with-plate``: the left foot stands still beside the plate) the run says so in one
notice line and keeps de Leva's masses.
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.anatomy.inertia import BODY_SEGMENTS, segment_inertia
from mocap_mj.errors import MocapError
from mocap_mj.outputs.inertia_out import StanceTrial, fit_inertia, scaled_inertia
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.skeleton.mjcf import load_model

MASS = 70.0  # [kg]
SLOW = 4.0  # the range of motion played this many times slower
FRAMES = 600


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args], capture_output=True, text=True, timeout=600
    )


def test_the_recipe_field_round_trips_and_refuses_a_bad_value(tmp_path: Path) -> None:
    assert Recipe().inertia == "regression"
    recipe = Recipe(inertia="fit")
    recipe.save(tmp_path / "recipe.yaml")
    assert "inertia: fit" in (tmp_path / "recipe.yaml").read_text()
    assert Recipe.load(tmp_path / "recipe.yaml") == recipe
    (tmp_path / "old.yaml").write_text("loss: l2\n")  # a recipe from before the field
    assert Recipe.load(tmp_path / "old.yaml").inertia == "regression"
    (tmp_path / "bad.yaml").write_text("inertia: measured\n")
    with pytest.raises(MocapError) as info:
        Recipe.load(tmp_path / "bad.yaml")
    assert str(info.value) == (
        f"{tmp_path / 'bad.yaml'}: inertia must be one of regression, fit; got 'measured'"
    )
    with pytest.raises(MocapError, match="inertia must be one of"):
        Recipe(inertia="Fit")  # type: ignore[arg-type]


def test_without_stance_frames_the_regression_stays_with_one_notice(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    pset = ParameterSet()
    path = tmp_path / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    trial = StanceTrial("T.c3d", tmp_path / "motion.npz", (), np.zeros(10, bool), ())
    with caplog.at_level(logging.WARNING, logger="mocap_mj.notices"):
        inertia, section = fit_inertia(path, [trial], MASS)
    assert section == {"source": "regression", "note": "no stance frame on the force plates"}
    np.testing.assert_array_equal(inertia.mass, segment_inertia(load_model(path), MASS).mass)
    (line,) = [r.getMessage() for r in caplog.records]
    assert line.startswith("warning: inertia fit: no stance frame") and "\n" not in line


def test_scaled_inertia_keeps_the_centres_of_mass(tmp_path: Path) -> None:
    """A body's mass and inertia scale together (its radii of gyration and centre kept)."""
    pset = ParameterSet()
    path = tmp_path / "model.xml"
    path.write_text(pset.to_xml(pset.nominal))
    regression = segment_inertia(load_model(path), MASS)

    class Fit:
        bodies = ("thigh_l", "head")
        scale = np.array([1.2, 0.5])

    out = scaled_inertia(regression, Fit())  # type: ignore[arg-type]
    k = regression.bodies.index("thigh_l")
    assert out.mass[k] == pytest.approx(1.2 * regression.mass[k])
    np.testing.assert_allclose(out.inertia[k], 1.2 * regression.inertia[k])
    np.testing.assert_array_equal(out.com, regression.com)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, float]]:
    from mocap_synth import plates
    from mocap_synth.config import SynthConfig
    from mocap_synth.experiment import synthesize, write_experiment

    base = tmp_path_factory.mktemp("inertia_fit")
    truth, out = base / "truth", base / "identify"
    rng = np.random.default_rng(0)
    scale = {b: float(s) for b, s in zip(BODY_SEGMENTS, rng.uniform(0.8, 1.25, 16), strict=True)}
    config = SynthConfig(motion="rom", frames=FRAMES, rate=100 * SLOW, noise_mm=0.0, seed=5)
    exp = plates.leaning(plates.slowed(synthesize(config), SLOW), MASS, scale)

    def plate(folder: Path) -> list[str]:
        model = folder / "truth_model.xml"
        return [plates.write_plate_c3d(folder / "plates.c3d", exp, model, MASS, scale).name]

    write_experiment(exp, truth, extra=plate)
    recipe = Recipe(inertia="fit", init="nominal", anatomy=False,
                    model=str(truth / "truth_model.xml"))  # fmt: skip
    recipe.save(base / "recipe.yaml")
    proc = run("identify", "--markers", str(truth / "plates.c3d"), "--recipe",
               str(base / "recipe.yaml"), "--out", str(out))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "segment masses fitted to the force plates" in proc.stdout
    return out, scale


@pytest.mark.slow
def test_identify_recovers_the_determined_masses(fitted: tuple[Path, dict[str, float]]) -> None:
    out, scale = fitted
    section = json.loads((out / "summary.json").read_text())["inertia"]
    assert section["source"] == "fit"
    segments = section["segments"]
    determined = [b for b, s in segments.items() if s["determined"]]
    assert len(determined) >= 6, segments
    for b in determined:
        truth = scale[b] * segments[b]["regression_mass_kg"]
        assert abs(segments[b]["fitted_mass_kg"] / truth - 1) < 0.10, b
    pooled = section["residuals"]["pooled"]
    assert pooled["before"]["force_rms_pct_bw"] > 1.0  # de Leva's masses: a residual
    assert pooled["after"]["force_rms_n"] < 0.1 * pooled["before"]["force_rms_n"]
    assert pooled["after"]["moment_rms_nm"] < 0.1 * pooled["before"]["moment_rms_nm"]
    assert len(section["singular_values"]) == 16
    # model.xml holds the fitted masses; the kinetics were computed with them
    model = load_model(out / "model.xml")
    for b, s in segments.items():
        assert model.body_mass[model.body(b).id] == pytest.approx(s["fitted_mass_kg"])
    (entry,) = json.loads((out / "summary.json").read_text())["kinetics"]["trials"]
    assert entry["residual_force_rms_n"] == pytest.approx(section["residuals"]["trials"][0]
                                                          ["after"]["force_rms_n"])  # fmt: skip


@pytest.mark.slow
def test_the_report_has_the_segment_masses(fitted: tuple[Path, dict[str, float]]) -> None:
    out, _ = fitted
    report = (out / "report.md").read_text()
    section = report.split("## Segment masses", 1)[1]
    assert "| segment | regression [kg] | fitted [kg] | sd [kg] | determined |" in section
    assert section.count("\n| ") == 17  # the header and 16 segments
    assert "Singular values of the information" in section
    assert "before: force RMS" in section and "after: force RMS" in section
    assert "% body weight" in section and "% of the peak ground reaction" in section
    assert "inertia: fit" in (out / "recipe.yaml").read_text()


@pytest.mark.slow
def test_no_stance_frame_keeps_the_regression(tmp_path: Path) -> None:
    synth, out = tmp_path / "synth", tmp_path / "identify"
    proc = run("synth", "--out", str(synth), "--movement", "static", "--noise-mm", "0",
               "--frame-count", "120", "--seed", "5", "--with-plate", "68")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    (tmp_path / "recipe.yaml").write_text("inertia: fit\n")
    proc = run("identify", "--markers", str(synth / "plates.c3d"), "--recipe",
               str(tmp_path / "recipe.yaml"), "--out", str(out))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    notices = [line for line in proc.stderr.splitlines() if "inertia fit" in line]
    assert notices == [
        "mocap-mj identify: warning: inertia fit: no stance frame on the force plates: the "
        "segments keep de Leva's masses"
    ]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["inertia"] == {"source": "regression",
                                  "note": "no stance frame on the force plates"}  # fmt: skip
    model = load_model(out / "model.xml")
    np.testing.assert_allclose(model.body_mass[1:], segment_inertia(model, 68.0).mass)
