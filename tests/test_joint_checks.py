"""The anatomical checks of an identified skeleton (:mod:`mocap_mj.anatomy.joint_checks`): a
correct synthetic fit passes every one; a knee centre on the far side of KNE, an elbow centre
in front of ELB and hips outside the pelvis are refused, naming the joint and the distance
constructed, and ``identify`` then exits 3 with the result written for inspection."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mocap_mj.anatomy.joint_checks import (
    AXIS_DETERMINED_DEG,
    HOLD_FACTOR,
    HOLD_RMSE_RATIO,
    MIN_TOLERANCE,
    Check,
    checks_summary,
    held_joints,
    joint_checks,
    violations,
)
from mocap_mj.capture.subject import Subject
from mocap_mj.cli import main
from mocap_mj.pipeline.anatomical import AnatomyPriors, Weighing, anatomical_priors
from mocap_mj.pipeline.prepare import Prepared
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.pipeline.steps import _held_at_construction, solve_trials
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData
from mocap_synth import Experiment, SynthConfig, synthesize, write_experiment

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

FRAMES = 80


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


@pytest.fixture(scope="module")
def experiment(pset: ParameterSet) -> Experiment:
    return synthesize(SynthConfig(frames=FRAMES, seed=3), pset)


@pytest.fixture(scope="module")
def symmetric(pset: ParameterSet) -> Experiment:
    """A truth whose left and right sides mirror each other (the refusals' starting point)."""
    return synthesize(SynthConfig(frames=FRAMES, seed=3, symmetric=True), pset)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory, experiment: Experiment) -> Path:
    """A synthetic trial identified with the default recipe."""
    root = tmp_path_factory.mktemp("checks")
    write_experiment(experiment, root / "synth")
    out = root / "fit"
    status = main(["identify", "--markers", str(root / "synth" / "markers.csv"), "--out",
                   str(out), "--json"])  # fmt: skip
    assert status == 0
    return out


def _check(checks: list[Check], joint: str, start: str) -> Check:
    (found,) = [c for c in checks if c.joint == joint and c.what.startswith(start)]
    return found


def _offset_index(pset: ParameterSet, marker: str, axis: int) -> int:
    return pset.n_kappa + 3 * pset.marker_index(marker) + axis


def _centre(pset: ParameterSet, theta: np.ndarray, body: str) -> np.ndarray:
    return pset.body_pos(theta)[pset.model.body(body).id]


def _flipped_knee(pset: ParameterSet, theta: np.ndarray) -> np.ndarray:
    """``theta`` with LKNE mirrored about the knee centre along the knee axis: the centre
    then lies lateral of LKNE by the distance it lay medial of it."""
    out = theta.copy()
    k = _offset_index(pset, "LKNE", 1)
    out[k] = 2 * _centre(pset, theta, "shank_l")[1] - theta[k]
    return out


#: How far [m] the wrong-side elbow's centre sits in front of LELB.
ELBOW_FORWARD = 0.040


def _forward_elbow(pset: ParameterSet, theta: np.ndarray) -> np.ndarray:
    """``theta`` with LELB moved behind the elbow centre by :data:`ELBOW_FORWARD`."""
    out = theta.copy()
    out[_offset_index(pset, "LELB", 0)] = _centre(pset, theta, "ulna_l")[0] - ELBOW_FORWARD
    return out


def test_a_correct_synthetic_fit_passes_every_check(fitted: Path, pset: ParameterSet) -> None:
    summary = json.loads((fitted / "summary.json").read_text())
    assert summary["implausible"] == [] and summary["exit_status"] == 0
    entries = [c for cs in summary["anatomy_checks"].values() for c in cs]
    assert entries and not any(c["violated"] for c in entries)
    # every joint of the full Plug-in Gait set is checked
    joints = {f"{j}_{s}" for j in ("knee", "ankle", "elbow", "wrist", "hip") for s in "lr"}
    assert joints | {"hips", "knee_lr"} <= set(summary["anatomy_checks"])
    n = sum(c["enforced"] for c in entries)
    assert f"- joints against the body (docs/model.md#flexion-axes): {n} checks pass" in (
        (fitted / "report.md").read_text()
    )
    theta = pset.load_json(fitted / "theta.json")
    checks = joint_checks(pset, theta, Subject())
    assert checks_summary(checks).keys() >= {"knee_l", "hips"}
    knee = _check(checks, "knee_l", "centre medial of LKNE")
    offsets, centre = pset.split(theta)[1], _centre(pset, theta, "shank_l")
    assert knee.value == pytest.approx(offsets[pset.marker_index("LKNE")][1] - centre[1])


def test_the_truths_pass_every_check_and_a_knee_thrown_to_one_side_fails_the_mirror(
    experiment: Experiment, symmetric: Experiment, pset: ParameterSet
) -> None:
    assert violations(joint_checks(pset, symmetric.theta_true, Subject())) == []
    theta = experiment.theta_true  # its sides differ as the synthetic perturbation has them
    assert violations(joint_checks(pset, theta, Subject())) == []
    left, right = (_centre(pset, theta, f"foot_{s}") for s in "lr")
    ankle = _check(joint_checks(pset, theta, Subject()), "ankle_lr", "left centre")
    assert ankle.value == pytest.approx(abs(left[1] + right[1]), abs=1e-12)  # right mirrored
    thrown = theta.copy()  # the left knee centre and everything below it 120 mm lateral
    thrown[pset.index("knee_lateral_l")] += 0.120
    checks = joint_checks(pset, thrown, Subject())
    knee = _check(checks, "knee_lr", "left centre")
    left, right = (_centre(pset, thrown, f"shank_{s}") for s in "lr")
    assert left[1] - _centre(pset, theta, "shank_l")[1] == pytest.approx(0.120, abs=1e-12)
    assert knee.value == pytest.approx(abs(left[1] + right[1]), abs=1e-12) and knee.violated
    assert {c.joint for c in checks if c.violated} == {"knee_l", "knee_lr"}


def test_a_flipped_knee_is_caught_with_the_distance_constructed(
    fitted: Path, pset: ParameterSet
) -> None:
    theta = pset.load_json(fitted / "theta.json")
    before = _check(joint_checks(pset, theta, Subject()), "knee_l", "centre medial")
    checks = joint_checks(pset, _flipped_knee(pset, theta), Subject())
    after = _check(checks, "knee_l", "centre medial")
    assert before.value > 0.03  # medial of LKNE
    assert after.value == pytest.approx(-before.value, abs=1e-12)  # as far lateral
    assert after.low is not None and after.violated
    assert after.margin == pytest.approx(after.value - after.low)
    lines = violations(checks)
    assert len(lines) == 1 and lines[0].startswith("joint outside the body: knee_l:"), lines
    assert f"{after.value * 1e3:.0f} mm" in lines[0]
    # a measured width narrows the limits to 15 mm about width/2 + r
    subject = Subject()
    subject.set("knee_width_l", 0.100, "test")
    measured = _check(joint_checks(pset, theta, subject), "knee_l", "centre medial")
    assert measured.low == pytest.approx(0.050 + subject.marker_radius - MIN_TOLERANCE)
    assert measured.high == pytest.approx(0.050 + subject.marker_radius + MIN_TOLERANCE)


def test_a_wrong_side_elbow_is_caught(fitted: Path, pset: ParameterSet) -> None:
    theta = pset.load_json(fitted / "theta.json")
    checks = joint_checks(pset, _forward_elbow(pset, theta), Subject())
    forward = _check(checks, "elbow_l", "centre anterior of LELB")
    assert forward.value == pytest.approx(ELBOW_FORWARD, abs=1e-12)
    assert forward.violated and forward.high == MIN_TOLERANCE
    lines = violations(checks)
    assert len(lines) == 1 and "elbow_l: centre anterior of LELB 40 mm" in lines[0], lines


def test_hips_outside_the_pelvis_are_caught(fitted: Path, pset: ParameterSet) -> None:
    theta = pset.load_json(fitted / "theta.json")
    wide = theta.copy()
    for side in "lr":
        wide[pset.index(f"hip_width_{side}")] += 0.057
    before, after = joint_checks(pset, theta, Subject()), joint_checks(pset, wide, Subject())
    for side in "lr":
        a, b = (_check(c, f"hip_{side}", "centre medial of") for c in (before, after))
        assert b.value == pytest.approx(a.value - 0.057, abs=1e-12) and b.value < 0
        assert b.violated
    a, b = (_check(c, "hips", "distance between") for c in (before, after))
    gap = _centre(pset, theta, "thigh_l") - _centre(pset, theta, "thigh_r")
    gap[1] += 0.114  # each hip 57 mm further out
    assert b.value == pytest.approx(float(np.linalg.norm(gap)), abs=1e-12) and b.violated
    assert not a.violated
    assert {line.split(":")[1].strip() for line in violations(after)} == {"hip_l", "hip_r", "hips"}
    # a hip above the ASIS plane is outside the pelvis too
    high = theta.copy()
    high[pset.index("hip_height_l")] = -0.010  # the centre 10 mm above the hip's body origin
    up = _check(joint_checks(pset, high, Subject()), "hip_l", "centre below the ASIS plane")
    assert up.violated


def test_an_axis_far_from_the_construction_is_refused_unless_the_data_place_it(
    fitted: Path, pset: ParameterSet
) -> None:
    theta = pset.load_json(fitted / "theta.json")
    decision = {"joint": "elbow_l", "wand": "LELB", "marker": "LELB", "source": "plug-in-gait",
                "data_sd_deg": 2 * AXIS_DETERMINED_DEG}  # fmt: skip
    turned = theta.copy()  # ELB turned 45 degrees forward about the elbow centre
    centre = _centre(pset, theta, "ulna_l")
    k = [_offset_index(pset, "LELB", a) for a in (0, 1)]
    lateral = float(np.hypot(*(theta[i] - centre[j] for i, j in zip(k, (0, 1), strict=True))))
    turned[k[0]] = centre[0] + lateral * np.sin(np.radians(45))
    turned[k[1]] = centre[1] + lateral * np.cos(np.radians(45))
    axis = _check(joint_checks(pset, turned, Subject(), decisions={"elbow_l": decision}),
                  "elbow_l", "flexion axis")  # fmt: skip
    assert axis.value == pytest.approx(45.0, abs=0.5) and axis.violated
    for placed in ({"source": "functional"}, {"data_sd_deg": AXIS_DETERMINED_DEG}):
        by_data = {"elbow_l": {**decision, **placed}}
        reported = _check(joint_checks(pset, turned, Subject(), decisions=by_data),
                          "elbow_l", "flexion axis")  # fmt: skip
        assert reported.value == pytest.approx(axis.value) and not reported.violated


def _refused(
    root: Path,
    experiment: Experiment,
    pset: ParameterSet,
    theta: np.ndarray,
    capsys: pytest.CaptureFixture[str],
) -> tuple[int, dict[str, Any], list[str]]:
    """``identify`` (the default recipe: anatomical priors on) of the markers the model
    ``theta`` carries in the synthetic motion, with the experiment's noise: the markers
    hold the joint where ``theta`` has it, against the priors, with a small marker RMSE."""
    kin = Kinematics(pset)
    kin.set_theta(theta)
    exp = experiment
    clean = kin.marker_positions(exp.qpos)
    noisy = clean + (exp.markers - exp.markers_clean)
    write_experiment(replace(exp, theta_true=theta, markers_clean=clean, markers=noisy), root)
    capsys.readouterr()
    out = ["--out", str(root / "fit")]
    status = main(["identify", "--markers", str(root / "markers.csv"), *out])
    err = [line for line in capsys.readouterr().err.splitlines() if "implausible" in line]
    return status, json.loads((root / "fit" / "summary.json").read_text()), err


def test_identify_refuses_a_flipped_knee_with_exit_3(
    tmp_path: Path, symmetric: Experiment, pset: ParameterSet, capsys: pytest.CaptureFixture[str]
) -> None:
    theta = _flipped_knee(pset, symmetric.theta_true)
    status, summary, err = _refused(tmp_path, symmetric, pset, theta, capsys)
    assert status == 3 and summary["exit_status"] == 3
    assert summary["marker_rmse_mm"] < 2.0  # the markers fit: only the anatomy tells
    (entry,) = [c for c in summary["anatomy_checks"]["knee_l"] if c["what"].startswith("centre")]
    truth = _check(joint_checks(pset, theta, Subject()), "knee_l", "centre medial")
    # The fit starts from the chord's centre, medial of the flipped LKNE, and the motion
    # carries it back to the flipped truth's side: -51 mm against the truth's -56 (the
    # alignment prior, 0 +- 3 degrees of the thigh, holds it 5 mm short along the axis).
    assert entry["violated"] and entry["value_mm"] == pytest.approx(truth.value * 1e3, abs=6.0)
    assert len(err) == 1 and re.search(
        r"knee_l: centre medial of LKNE .* -\d+ mm \(limits", err[0]
    ), err
    assert all("knee_l" in r for r in summary["implausible"]), summary["implausible"]
    held = summary["held_at_construction"]  # re-solved held: the markers fit far worse
    assert held["joints"] == ["knee_l"] and not held["kept"]
    assert held["marker_rmse_mm"][1] > HOLD_RMSE_RATIO * held["marker_rmse_mm"][0]
    assert "held at its construction the markers fit at" in err[0]


def test_identify_refuses_a_wrong_side_elbow_with_exit_3(
    tmp_path: Path, symmetric: Experiment, pset: ParameterSet, capsys: pytest.CaptureFixture[str]
) -> None:
    theta = _forward_elbow(pset, symmetric.theta_true)
    status, summary, err = _refused(tmp_path, symmetric, pset, theta, capsys)
    assert status == 3
    (entry,) = [c for c in summary["anatomy_checks"]["elbow_l"] if "anterior" in c["what"]]
    assert entry["violated"] and entry["value_mm"] == pytest.approx(ELBOW_FORWARD * 1e3, abs=5.0)
    assert len(err) == 1 and "elbow_l: centre anterior of LELB" in err[0], err
    assert all("elbow_l" in r for r in summary["implausible"]), summary["implausible"]
    assert summary["held_at_construction"]["joints"] == ["elbow_l"]
    assert not summary["held_at_construction"]["kept"]
    report = (tmp_path / "fit" / "report.md").read_text()
    assert "- joints outside the body (exit status 3): elbow_l centre anterior of LELB" in report


def test_holding_a_joint_narrows_its_construction_rows_only(pset: ParameterSet) -> None:
    subject = Subject()
    subject.set("knee_width_l", 0.100, "test")
    axes: dict[str, float | None] = {"LTHI": 0.005}
    free = anatomical_priors(pset, AnatomyPriors(subject, symmetric=0.005), axes=axes)
    joints = ["knee_l", "hip_r"]
    held = anatomical_priors(pset, AnatomyPriors(subject, symmetric=0.005, held=joints), axes=axes)
    changed = {}
    for a, b in zip(free, held, strict=True):
        for label, s0, s1 in zip(a.labels, a.sigma, b.sigma, strict=True):
            if s0 != s1:
                changed[label] = s1 / s0
    assert all(v == pytest.approx(HOLD_FACTOR) for v in changed.values())
    assert set(changed) == {
        "LKNE.x = 0 (on the joint axis)", "LKNE.z = -thigh_length",
        "LKNE.y = centre + knee_width/2 + r",
        "LTHI in the plane of the joint centre and LKNE (Plug-in Gait's chord)",
        "hip_depth_r = 0.24 PD + 9.9 mm (Harrington 2007)",
        "hip_width_r = 0.33 PW + 7.3 mm (Harrington 2007)",
        "hip_height_r = 0.30 PW + 10.9 mm (Harrington 2007)",
    }  # fmt: skip
    checks = [Check(j, "d", 1.0, None, 0.0) for j in ("hips", "ankle_lr", "elbow_l")]
    checks.append(Check("knee_r", "d", 0.0, None, 1.0))  # passes: not held
    assert held_joints(checks) == ["ankle_l", "ankle_r", "elbow_l", "hip_l", "hip_r"]


def test_a_joint_the_markers_leave_free_is_held_at_its_construction(
    symmetric: Experiment,
) -> None:
    """A result with the left knee centre thrown 120 mm lateral (the markers barely see the
    knee centre along its axis): re-solved with both knees held, the knees come back inside
    the body and the markers fit as well, so the held solve is kept."""
    recipe = Recipe()
    settings = recipe.settings()
    trials = [TrialData("synthetic", symmetric.markers, symmetric.times)]
    prepared = Prepared(recipe, ParameterSet(), trials, [0], Subject(), MarkerQuality(), {})
    solved = solve_trials(prepared, trials, settings)
    pset, first = solved.pset, solved.result
    thrown = first.theta.copy()
    thrown[pset.index("knee_lateral_l")] += 0.120
    bad = replace(first, theta=thrown)
    assert held_joints(joint_checks(pset, thrown, solved.subject)) == ["knee_l", "knee_r"]
    assert solved.anatomy is not None
    solve = {"pset": pset, "theta0": first.theta0, "settings": settings,
             "weighing": Weighing(solved.slides), "progress": None}  # fmt: skip
    result, weighting = _held_at_construction(trials, bad, solved.weighting, solved.anatomy, solve)
    record = weighting.held_at_construction
    assert record.joints == ["knee_l", "knee_r"] and record.kept
    assert weighting.held_joints == ["knee_l", "knee_r"]
    assert record.marker_rmse[1] <= HOLD_RMSE_RATIO * record.marker_rmse[0]
    assert violations(joint_checks(pset, result.theta, solved.subject)) == []
    # the knee centre is back where the construction puts it, within the row's width
    knee = _check(joint_checks(pset, result.theta, solved.subject), "knee_l", "centre medial")
    assert abs(knee.value - 0.5 * (knee.low + knee.high)) < 0.005  # type: ignore[operator]
