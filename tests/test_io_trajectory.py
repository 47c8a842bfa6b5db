"""MarkerTrajectory: validation, selection, slicing and the marker report."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from mocap_mj.errors import MocapError, ShapeError
from mocap_mj.io import MarkerTrajectory
from mocap_mj.io.marker_names import MARKER_NAMES


def _traj(n_frames: int = 4, names: tuple[str, ...] = ("LASI", "RASI", "XTRA")) -> MarkerTrajectory:
    rng = np.random.default_rng(0)
    return MarkerTrajectory(
        times=np.arange(n_frames) / 100.0,
        positions=rng.normal(size=(n_frames, len(names), 3)),
        names=names,
        rate=100.0,
        source={"path": "memory"},
    )


def test_properties_and_readonly_copies() -> None:
    pos = np.zeros((4, 3, 3))
    traj = MarkerTrajectory(np.arange(4) / 100, pos, ("A", "B", "C"), 100, {})
    assert (traj.n_frames, traj.n_markers) == (4, 3)
    pos[0, 0, 0] = 5.0  # the trajectory owns a copy
    assert traj.positions[0, 0, 0] == 0.0
    with pytest.raises(ValueError):
        traj.positions[0, 0, 0] = 1.0
    assert traj.positions.dtype == np.float64
    assert isinstance(traj.rate, float)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"positions": np.zeros((4, 2, 3))}, "positions"),  # M does not match names
        ({"positions": np.zeros((5, 3, 3))}, "positions"),  # T does not match times
        ({"positions": np.zeros((4, 3, 2))}, "positions"),
        ({"times": np.zeros((4, 1))}, "times"),
        ({"names": ("A", "A", "B")}, "names"),
        ({"names": ("A", "", "B")}, "names"),
        ({"rate": 0.0}, "rate"),
        ({"rate": float("nan")}, "rate"),
        ({"times": np.array([0, np.nan, 2, 3])}, "times"),
        ({"positions": np.full((4, 3, 3), np.inf)}, "positions"),
    ],
)
def test_validation_names_the_field(kwargs: dict[str, Any], field: str) -> None:
    args: dict[str, Any] = {
        "times": np.arange(4) / 100,
        "positions": np.zeros((4, 3, 3)),
        "names": ("A", "B", "C"),
        "rate": 100.0,
    }
    args.update(kwargs)
    with pytest.raises(ShapeError, match=f"^{field}") as info:
        MarkerTrajectory(**args)
    assert isinstance(info.value, MocapError)


def test_select_orders_and_fills_missing_with_nan() -> None:
    traj = _traj()
    got = traj.select(["RASI", "NOPE", "LASI"])
    assert got.shape == (4, 3, 3)
    np.testing.assert_array_equal(got[:, 0], traj.positions[:, 1])
    np.testing.assert_array_equal(got[:, 2], traj.positions[:, 0])
    assert np.isnan(got[:, 1]).all()
    assert traj.select("LASI").shape == (4, 1, 3)
    got[0, 0, 0] = 123.0  # a new array, not a view of the trajectory
    assert traj.positions[0, 1, 0] != 123.0


def test_slice_keeps_times_and_names() -> None:
    traj = _traj(n_frames=10)
    part = traj.slice(2, 5)
    assert part.n_frames == 3
    np.testing.assert_array_equal(part.times, traj.times[2:5])
    np.testing.assert_array_equal(part.positions, traj.positions[2:5])
    assert part.names == traj.names and part.rate == traj.rate
    assert part.source["frames"] == (2, 5)
    assert traj.slice(-3, None).n_frames == 3
    assert traj.slice(8, 100).n_frames == 2
    assert traj.slice(5, 2).n_frames == 0


def test_marker_report_counts_and_fractions() -> None:
    names = (*MARKER_NAMES[:37], "EXTRA1")  # RHEE and RTOE missing
    pos = np.ones((10, len(names), 3))
    pos[:3, names.index("LBHD")] = np.nan  # seen in 7 of 10 frames
    pos[0, names.index("LASI"), 2] = np.nan  # one coordinate missing = sample missing
    traj = MarkerTrajectory(np.arange(10) / 10, pos, names, 10.0, {})
    report = traj.marker_report()
    assert report.found == MARKER_NAMES[:37]
    assert report.missing == ("RHEE", "RTOE")
    assert report.extras == ("EXTRA1",)
    assert report.fraction_present["LBHD"] == pytest.approx(0.7)
    assert report.fraction_present["LASI"] == pytest.approx(0.9)
    assert report.fraction_present["RTOE"] == 0.0
    assert report.fraction_present["EXTRA1"] == 1.0
    assert not report.complete
    text = str(report)
    assert "37 of 39 model markers found" in text
    assert "missing: RHEE RTOE" in text
    assert "EXTRA1" in text
    assert "LBHD" in text and "70.0%" in text


def test_marker_report_complete_with_custom_model() -> None:
    traj = _traj(names=("A", "B"))
    report = traj.marker_report(("A", "B"))
    assert report.complete and report.missing == () and report.extras == ()
    assert "missing: none" in str(report)
