"""Gait events: Qualisys.c3d's own EVENT group against the events its force plates and its
kinematics (Zeni et al. 2008) give, the sources' order, and events written into a C3D."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.contacts import assign_feet
from mocap_mj.capture.events import (
    SOURCES,
    GaitEvent,
    events_from_c3d,
    events_from_kinematics,
    events_from_loads,
    gait_events,
)
from mocap_mj.export.c3d import C3DPoints, write_points_c3d
from mocap_mj.io import load_markers
from mocap_mj.io.plates import read_plates

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
QUALISYS = SHARED / "vendors" / "Qualisys.c3d"
MOVEMENT = SHARED / "real" / "Movement_trial.c3d"
SKIP = "../shared/data not present: the gait-event checks on real files need the shared folder"
FEET = {"left": ("LHEE", "LANK", "L_FM1", "L_FM5"), "right": ("RHEE", "RANK", "R_FM1", "R_FM5")}
#: Qualisys.c3d has no toe marker: the first metatarsal head stands in (Zeni's toe).
TOE = {"left": "L_FM1", "right": "R_FM1"}


def _need(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(SKIP)
    return path


def _nearest(event: GaitEvent, events: list[GaitEvent]) -> GaitEvent:
    same = [e for e in events if e.side == event.side and e.kind == event.kind]
    return min(same, key=lambda e: abs(e.time - event.time))


def test_qualisys_event_group_is_read() -> None:
    events = events_from_c3d(_need(QUALISYS))
    # EVENT:LABELS LHS RTO RHS LTO LHS RTO RHS at 3.59 .. 5.03 s, 200 Hz
    assert [(e.side[0], e.kind) for e in events] == [
        ("l", "foot_strike"), ("r", "foot_off"), ("r", "foot_strike"), ("l", "foot_off"),
        ("l", "foot_strike"), ("r", "foot_off"), ("r", "foot_strike"),
    ]  # fmt: skip
    assert events[0].time == pytest.approx(3.59, abs=1e-6) and events[0].frame == 719
    assert all(e.source == SOURCES["c3d"] for e in events)


@pytest.mark.parametrize(("threshold_n", "frames"), [(5.0, 2), (20.0, 5)])
def test_plate_events_match_the_recording_s_own(threshold_n: float, frames: int) -> None:
    """Qualisys's events sit where a plate's force crosses a few newtons: with a 5 N
    threshold the plates' four events are within 1 frame of them (asserted: 2); at the
    default 20 N the foot offs come up to 5 frames (25 ms) earlier, the strikes 1-2 later."""
    path = _need(QUALISYS)
    traj = load_markers(path)
    loads = assign_feet(read_plates(path, threshold_n=threshold_n), traj, feet=FEET)
    assert all(not f.excluded for f in loads)
    found = events_from_loads(loads, traj.times, threshold_n=threshold_n)
    assert len(found) == 4  # a strike and an off on each of the two plates
    ref = events_from_c3d(path)
    for e in found:
        assert e.source == SOURCES["plates"]
        assert abs(e.frame - _nearest(e, ref).frame) <= frames, e


def test_zeni_events_match_the_recording_s_own() -> None:
    """Zeni's events against Qualisys's: foot offs within 2 frames (10 ms); foot strikes,
    moved from the heel-lead maximum (6-8 frames early) to the heel's fastest descent, within
    2 frames too. The first strike, 0.07 s after the recording starts, has no maximum before
    it to stand out from and is not found."""
    path = _need(QUALISYS)
    traj = load_markers(path)
    ref = events_from_c3d(path)
    found = events_from_kinematics(traj, toe=TOE)
    inside = [e for e in found if ref[0].time - 0.1 <= e.time <= ref[-1].time + 0.1]
    clear = [e for e in ref if traj.times[0] + 0.1 <= e.time <= traj.times[-1] - 0.1]
    assert len(inside) == len(clear) == len(ref) - 1
    for e in inside:
        assert e.source == SOURCES["kinematics"]
        assert abs(e.frame - _nearest(e, ref).frame) <= 2, e
    zeni = events_from_kinematics(traj, toe=TOE, descent_s=0.0)  # the maxima themselves
    early = [_nearest(e, ref).frame - e.frame for e in zeni if e.kind == "foot_strike"]
    assert early and min(early) >= 5, early


def test_sources_in_order() -> None:
    qualisys = _need(QUALISYS)
    traj = load_markers(qualisys)
    assert {e.source for e in gait_events(qualisys, traj)} == {SOURCES["c3d"]}
    movement = _need(MOVEMENT)  # no EVENT entries: the plates decide
    traj = load_markers(movement)
    loads = assign_feet(read_plates(movement), traj)
    from_plates = gait_events(movement, traj, loads=loads)
    assert from_plates and {e.source for e in from_plates} == {SOURCES["plates"]}
    # down the stairs: right strikes plate 4, left plate 3, right plate 2, left plate 1
    strikes = [e.side for e in from_plates if e.kind == "foot_strike"]
    assert strikes == ["right", "left", "right", "left"]
    assert {e.source for e in gait_events(None, traj)} <= {SOURCES["kinematics"]}


def test_events_written_into_a_c3d_read_back(tmp_path: Path) -> None:
    events = [
        GaitEvent("left", "foot_strike", 0.25, 26, SOURCES["plates"]),
        GaitEvent("right", "foot_off", 0.5, 51, SOURCES["kinematics"]),
    ]
    path = tmp_path / "result.c3d"
    values = np.zeros((80, 1, 3)) + 100.0
    points = C3DPoints(["M1"], ["marker"], values, 100.0)
    write_points_c3d(path, points, angle_labels=[], modeled=[], events=events)
    back = events_from_c3d(path)
    assert [(e.side, e.kind, e.frame) for e in back] == [(e.side, e.kind, e.frame) for e in events]
    np.testing.assert_allclose([e.time for e in back], [0.25, 0.5], atol=1e-6)
