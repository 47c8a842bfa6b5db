"""The five real C3D recordings in ../shared/data/real (see SOURCES.md there)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocap_mj.io import load_markers
from mocap_mj.io.marker_names import MARKER_NAMES

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
SKIP = "../shared/data/real not present: real-data checks need the shared folder beside the repo"

# file -> (frames, rate [Hz], vertical axis in the file, number of extra markers)
FILES = {
    "Movement_trial.c3d": (323, 120.0, "z", 0),
    "Static_trial.c3d": (498, 120.0, "z", 0),
    "Test_func_rknee.c3d": (217, 12.0, "-z", 21),
    "Test_func_rhip.c3d": (525, 12.0, "-z", 21),
    "anatomical_posture.c3d": (122, 12.0, "-z", 21),
}
HEAD = ["LFHD", "RFHD", "LBHD", "RBHD"]
FEET = ["LANK", "RANK", "LHEE", "RHEE", "LTOE", "RTOE"]


@pytest.fixture(scope="module", params=sorted(FILES))
def trial(request: pytest.FixtureRequest):
    path = REAL / request.param
    if not path.is_file():
        pytest.skip(SKIP)
    return request.param, load_markers(path)


def test_all_model_markers_in_metres_z_up(trial) -> None:
    name, traj = trial
    frames, rate, up, n_extra = FILES[name]
    assert traj.n_frames == frames and traj.rate == rate
    assert traj.source["units"] == "mm"
    assert traj.source["up"] == up and traj.source["up_detected"]
    report = traj.marker_report()
    assert report.missing == ()
    assert len(report.extras) == n_extra
    head = np.nanmedian(traj.select(HEAD)[..., 2])
    feet = np.nanmedian(traj.select(FEET)[..., 2])
    assert 1.2 < head - feet < 2.0  # metres, head above feet
    # Marker spacing is human-sized in metres: pelvis width ASIS-ASIS 0.15..0.40 m.
    asis = np.nanmedian(np.linalg.norm(traj.select(["LASI"]) - traj.select(["RASI"]), axis=-1))
    assert 0.15 < asis < 0.40


def test_gaps_are_nan(trial) -> None:
    name, traj = trial
    report = traj.marker_report()
    if name == "anatomical_posture.c3d":
        gaps = {n for n in report.found if report.fraction_present[n] < 1.0}
        assert gaps == {"LBHD"}
        assert report.fraction_present["LBHD"] == pytest.approx(121 / 122)
        lbhd = traj.select(["LBHD"])[:, 0]
        assert np.isnan(lbhd).any(axis=1).sum() == 1 and np.isnan(lbhd).all(axis=1).sum() == 1
    else:
        assert report.complete


def test_non_marker_points_are_dropped_and_listed(trial) -> None:
    name, traj = trial
    dropped = traj.source["dropped"]
    if name in ("Movement_trial.c3d", "Static_trial.c3d"):
        for label in ("PELO", "LFEA", "LKneeAngles", "*115"):
            assert label in dropped
        if name == "Movement_trial.c3d":
            assert {"CentreOfMass", "LHipPower", "LAnkleForce", "RKneeMoment"} <= set(dropped)
        assert not set(dropped) & set(MARKER_NAMES)
        assert traj.names == tuple(n for n in traj.names if n in MARKER_NAMES)
    else:
        assert dropped == []
        assert {"S1", "C2", "LKNEM", "RTOE5"} <= set(traj.source["extras"])


def test_biobuddy_trials_agree_on_segment_lengths() -> None:
    paths = [
        REAL / n for n in ("Test_func_rknee.c3d", "Test_func_rhip.c3d", "anatomical_posture.c3d")
    ]
    if not all(p.is_file() for p in paths):
        pytest.skip(SKIP)
    # One subject: the pelvis width LASI-RASI should agree across trials within a few mm.
    widths = []
    for path in paths:
        traj = load_markers(path)
        d = np.linalg.norm(traj.select(["LASI"]) - traj.select(["RASI"]), axis=-1)
        widths.append(np.nanmedian(d))
    assert max(widths) - min(widths) < 0.01


def test_subject_from_c3d_metadata(trial) -> None:
    name, traj = trial
    if name.startswith(("Test_func", "anatomical")):
        assert traj.source["subjects"] == ["P01_MH", "P01"]
        again = load_markers(REAL / name, subject="P01")
        assert again.source["subject"] == "P01"
        np.testing.assert_array_equal(again.positions, traj.positions)
    else:
        assert traj.source["subjects"] == ["Test"]
