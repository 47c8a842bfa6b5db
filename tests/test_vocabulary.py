"""One vocabulary in the messages: a partial set's markers are counted and listed as the
set's, not the model's; ``--check`` counts the points that are no markers; the noise the
priors were weighed against is named for what it is."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mocap_mj.cli import main
from mocap_mj.io.trajectory import MarkerTrajectory
from mocap_mj.outputs.write_fit import weighting_text
from mocap_mj.skeleton.parameters import ParameterSet

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
LOWER = "LASI RASI LPSI RPSI LTHI LKNE LTIB LANK LHEE LTOE RTHI RKNE RTIB RANK RHEE RTOE".split()


def test_a_lower_body_set_is_counted_as_the_set() -> None:
    names = ParameterSet().marker_names
    pos = np.zeros((5, len(LOWER) - 1, 3))
    traj = MarkerTrajectory(np.arange(5) / 100, pos, tuple(LOWER[:-1]), 100.0, {})
    report = traj.marker_report(names)
    assert "15 of 39 model markers found" in str(report)  # a set that is the model's
    ours = dataclasses.replace(report, set_name="plug_in_gait_lower_body", set_markers=tuple(LOWER))
    text = str(ours)
    assert "15 of the 16 markers of the set 'plug_in_gait_lower_body' found" in text
    assert "missing: RTOE\n" in text  # the set's missing marker, no upper-body one
    assert "C7" not in text and "LELB" not in text
    assert "the model's 23 other markers are not of the set" in text


def test_check_counts_the_points_that_are_no_markers(capsys: pytest.CaptureFixture[str]) -> None:
    path = REAL / "Movement_trial.c3d"
    if not path.is_file():
        pytest.skip(f"{path} absent (the shared real data)")
    assert main(["marker-sets", "--check", str(path)]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("points that are no markers"))
    count = int(line.split("ignored (")[1].split(")")[0])
    assert count >= 50  # Nexus's angles, bone points, forces, moments, powers
    assert "LKneeAngles" in line or "PELO" in line


def test_the_prior_noise_is_named_for_what_it_is() -> None:
    # correlated residuals: sigma raised to the 5 mm floor, times sqrt(tau)
    w = {"noise_mm": 5.0 * np.sqrt(20.5), "sigma_mm": 2.813, "tau_frames": 20.5}
    text = weighting_text(w)
    assert f"{w['noise_mm']:.2f} mm" in text and "2.81 mm" in text
    assert "one independent marker observation" in text and "floor 5 mm" in text
    white = weighting_text({"noise_mm": 1.0, "sigma_mm": 1.01, "tau_frames": 1.1})
    assert white.startswith("priors weighed against the nominal marker noise of 1.00 mm")
