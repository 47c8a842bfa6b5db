"""Joints held at a limit of their range: the share of frames found per hinge side and per
ball cone, reported in summary.json, stdout and report.md."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mocap_mj.anatomy.plausibility import joints_at_limit, limits_text, plausibility_text
from mocap_mj.cli import main
from mocap_mj.io import MarkerTrajectory, save_csv
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.lm import LMSettings, solver_joint_range
from mocap_synth.config import SynthConfig
from mocap_synth.experiment import synthesize


def _quat(axis: np.ndarray, angle: float) -> np.ndarray:
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis / np.linalg.norm(axis)])


def test_shares_per_hinge_side_and_ball_cone() -> None:
    pset = ParameterSet()
    model = pset.model
    rng = solver_joint_range(model, LMSettings())
    q = np.tile(model.qpos0, (100, 1))
    knee = model.joint("knee_flex_l")
    lo, hi = rng[knee.id]
    q[:30, knee.qposadr[0]] = lo  # held at the lower limit
    q[30:35, knee.qposadr[0]] = hi - np.radians(0.2)  # within the tolerance of the upper
    q[35:, knee.qposadr[0]] = lo + np.radians(2.0)  # near but not at a limit
    thorax = model.joint("thorax")
    cone = rng[thorax.id, 1]
    a = thorax.qposadr[0]
    q[:50, a : a + 4] = _quat(np.array([0.0, 1.0, 0.0]), cone)
    q[50:, a : a + 4] = _quat(np.array([1.0, 1.0, 0.0]), cone - np.radians(3.0))
    nan_rows = np.full((7, model.nq), np.nan)  # frames without a pose are not counted
    held = joints_at_limit(model, rng, [q[:60], nan_rows, q[60:]])
    assert list(held) == ["thorax", "knee_flex_l"]
    assert held["thorax"]["limit"] == "cone" and held["thorax"]["share"] == 0.5
    assert np.isclose(held["thorax"]["limit_deg"], np.degrees(cone))
    assert held["knee_flex_l"] == {"share": 0.3, "limit": "lower", "limit_deg": np.degrees(lo)}
    # Below 1 % of the frames (one of 200): not reported.
    q[1:35, knee.qposadr[0]] = lo + np.radians(2.0)
    q[:50, a : a + 4] = q[50, a : a + 4]
    assert joints_at_limit(model, rng, [q, q[1:]]) == {}
    assert joints_at_limit(model, rng, [np.tile(model.qpos0, (10, 1))]) == {}
    text = limits_text(held)
    assert text.startswith("thorax cone") and "knee_flex_l lower" in text and "30%" in text
    # The command's line names the joints held in at least 10 % of the frames only.
    line = plausibility_text(pset, np.zeros(pset.n_markers), {}, at_limit=held)
    assert "joints held at a limit" in line and "thorax" in line
    few = {"knee_flex_l": {"share": 0.05, "limit": "lower", "limit_deg": -5.0}}
    assert "joints held" not in plausibility_text(pset, np.zeros(pset.n_markers), {}, at_limit=few)


def test_ik_reports_a_joint_held_at_its_limit(tmp_path: Path) -> None:
    # A walk tracked with a model whose left knee may not flex past 5 degrees: the knee is
    # held at that limit in the frames where the walk flexes it further.
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=60, noise_mm=1.0, seed=0, motion="walk"), pset)
    csv = tmp_path / "walk.csv"
    save_csv(csv, MarkerTrajectory(exp.times, np.asarray(exp.markers), pset.marker_names, 100.0))
    knee = pset.model.joint("knee_flex_l")
    flexed = np.degrees(np.asarray(exp.qpos)[:, knee.qposadr[0]]) > 5.0
    assert 0.2 < flexed.mean() < 0.9  # the walk flexes it past 5 degrees in part of the frames
    text = pset.path.read_text().replace(
        'name="knee_flex_l" type="hinge" axis="0 1 0" range="-10 150"',
        'name="knee_flex_l" type="hinge" axis="0 1 0" range="-5 5"',
    )
    model = tmp_path / "knee_held.xml"
    model.write_text(text)
    code = main(["ik", "--markers", str(csv), "--model", str(model), "--out",
                 str(tmp_path / "ik"), "--json"])  # fmt: skip
    assert code == 0
    held = json.loads((tmp_path / "ik" / "summary.json").read_text())["joints_at_limit"]
    assert held["knee_flex_l"]["limit"] == "upper"
    assert abs(held["knee_flex_l"]["share"] - flexed.mean()) < 0.1
