"""Issue #14 targets on the shared real trials (skip without ../shared): parameters within
their anatomical ranges, left/right lengths within 10 mm, knee/ankle/elbow/wrist centres at
width/2 + marker radius from their lateral marker within 5 mm where the file records the
widths, marker RMSE within 10 mm. Frame subsets keep them to a few seconds each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mocap_mj import ParameterSet
from mocap_mj.cli import main
from mocap_mj.identify.plausibility import (
    kappa_outside_bounds,
    left_right_differences,
    width_errors,
)
from mocap_mj.identify.ranges import kappa_ranges
from mocap_mj.results import load_motion
from mocap_mj.subject import from_c3d, from_values, from_yaml

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
SKIP = "../shared/data/real not present: real-data checks need the shared folder beside the repo"


@pytest.mark.parametrize(("name", "frames"), [("Static_trial.c3d", "0:150"),
                                              ("anatomical_posture.c3d", "0:122")])  # fmt: skip
def test_real_skeleton_targets(tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str,
                               frames: str) -> None:  # fmt: skip
    path = REAL / name
    if not path.is_file():
        pytest.skip(SKIP)
    out = tmp_path / "out"
    args = ["identify", "--markers", str(path), "--out", str(out), "--frames", frames]
    subject = from_c3d(path)
    if not subject.values:  # no measurements in the file: give some by YAML file and flag
        (tmp_path / "s.yaml").write_text("knee_width_l: 100 mm\nknee_width_r: 0.1\n")
        args += ["--subject-file", str(tmp_path / "s.yaml"), "--height", "1750"]
        subject = from_yaml(tmp_path / "s.yaml").update(
            from_values([("height", 1.75)], "command line")
        )
    assert main([*args, "--json", "--force"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    pset = ParameterSet()
    theta = pset.load_json(out / "theta.json")
    assert summary["marker_rmse_mm"] <= 10.0
    assert kappa_outside_bounds(pset, theta, *kappa_ranges(pset, subject)) == {}
    lr = left_right_differences(pset, theta)
    assert max(lr.values()) <= 0.010, lr
    # The measurements reach the summary with their source.
    assert {n: m["source"] for n, m in summary["measurements"].items()} == {
        n: m.source for n, m in subject.values.items()
    }
    motion = load_motion(out / "motion.npz")
    widths = width_errors(pset, theta, motion.qpos, motion.markers, subject)
    assert len(widths) == sum(
        subject.get(f"{w}_{s}") is not None
        for w in ("knee_width", "ankle_width", "elbow_width", "wrist_width")
        for s in "lr"
    )
    assert all(abs(v) <= 0.005 for v in widths.values()), widths
    assert np.isfinite(summary["prior_weighting"]["noise_mm"])
