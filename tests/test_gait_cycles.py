"""Gait cycles, spatiotemporal parameters and scores: cycles and their dropped ones from
events, resampling, the synthetic walk's parameters against its truth (within 1 %),
Qualisys.c3d's cycles from its own events and from the kinematics, and the GVS / GPS
arithmetic on a normative file made here."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mocap_mj.capture.events import GaitEvent, events_from_c3d, events_from_kinematics
from mocap_mj.clinical.cycles import PERCENT, gait_cycles, resample
from mocap_mj.clinical.gait_scores import GPS_VARIABLES, read_normative, scores
from mocap_mj.clinical.spatiotemporal import PARAMETERS, cycle_parameters, summary_rows
from mocap_mj.errors import InputFileError
from mocap_mj.io import load_markers

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
QUALISYS = SHARED / "vendors" / "Qualisys.c3d"


def _e(side: str, kind: str, time: float) -> GaitEvent:
    return GaitEvent(side, kind, time, round(time * 100) + 1, "test")


def test_cycles_from_events_and_the_dropped_ones() -> None:
    events = [
        _e("left", "foot_strike", 0.1), _e("right", "foot_off", 0.2),
        _e("right", "foot_strike", 0.6), _e("left", "foot_off", 0.7),
        _e("left", "foot_strike", 1.1), _e("right", "foot_strike", 1.6),  # no right off
        _e("left", "foot_off", 1.7), _e("left", "foot_strike", 2.1),
    ]  # fmt: skip
    cycles, dropped = gait_cycles(events, np.arange(0.0, 2.5, 0.01))
    assert [(c.side, c.number, c.start, c.stop) for c in cycles] == [
        ("left", 1, 0.1, 1.1), ("left", 2, 1.1, 2.1),
    ]  # fmt: skip
    first = cycles[0]
    assert (first.foot_off, first.opposite_off, first.opposite_strike) == (0.7, 0.2, 0.6)
    assert cycles[1].opposite_off is None  # the right foot off is missing
    assert first.percent(first.foot_off) == pytest.approx(60.0)
    assert len(dropped) == 3
    assert any("right cycle 0.600-1.600 s: no right foot off" in d for d in dropped)
    assert any("left foot strike at 2.100 s: no later left foot strike" in d for d in dropped)
    # events beyond the frames do not count: the last strike is outside
    cycles, _ = gait_cycles(events, np.arange(0.0, 2.0, 0.01))
    assert len(cycles) == 1


def test_resample_is_linear_between_frames() -> None:
    times = np.arange(0.0, 2.0, 0.01)
    values = np.stack([3.0 * times, times**0, -times], axis=1)
    cycle = gait_cycles(
        [_e("left", "foot_strike", 0.123), _e("left", "foot_off", 0.5),
         _e("left", "foot_strike", 1.234)], times,
    )[0][0]  # fmt: skip
    out = resample(values, times, cycle)
    at = 0.123 + PERCENT / 100 * (1.234 - 0.123)
    np.testing.assert_allclose(out[:, 0], 3.0 * at, atol=1e-12)
    np.testing.assert_allclose(out[:, 2], -at, atol=1e-12)
    values[50, 1] = np.nan  # a missing frame leaves NaN on the points beside it only
    out = resample(values, times, cycle)
    bad = np.flatnonzero(~np.isfinite(out[:, 1]))
    assert len(bad) and np.all(np.abs(at[bad] - 0.5) < 0.01)


@pytest.fixture(scope="module")
def walk() -> object:
    from mocap_synth import SynthConfig, synthesize

    return synthesize(SynthConfig(motion="walk", frames=400, rate=100.0, seed=3, noise_mm=1.0))


def test_synthetic_walk_parameters_within_one_percent_of_the_truth(walk: object) -> None:
    """On the noisy markers (1 mm) at the walk's own events: cadence, speed, stride and step
    length and time within 1 % of the truth (truth_gait.json's), stance and the supports
    within 0.1 % of the cycle."""
    from mocap_synth.gait_truth import truth_events, truth_gait

    truth = truth_gait(walk)  # type: ignore[arg-type]
    traj = walk.trajectory()  # type: ignore[attr-defined]
    cycles, _ = gait_cycles(truth_events(walk), traj.times)  # type: ignore[arg-type]
    assert {c.side for c in cycles} == {"left", "right"} and len(cycles) >= 4
    stats = summary_rows([(c.side, cycle_parameters(c, traj)) for c in cycles])
    for side, got in stats.items():
        for name in ("stride_time_s", "step_time_s", "cadence_steps_per_min",
                     "walking_speed_m_s", "stride_length_m"):  # fmt: skip
            assert got[name][0] == pytest.approx(truth[name], rel=0.01), (side, name)
        step = truth["per_side"][side]["step_length_m"]
        assert got["step_length_m"][0] == pytest.approx(step, rel=0.01), side
        for name in ("stance_pct", "single_support_pct", "double_support_pct"):
            assert got[name][0] == pytest.approx(truth[name], abs=0.1), (side, name)
    # the truth itself: speed = stride / period, 60 % stance
    assert truth["walking_speed_m_s"] * truth["stride_time_s"] == pytest.approx(
        truth["stride_length_m"]
    )


def test_qualisys_cycles_from_its_events_and_from_the_kinematics() -> None:
    """Qualisys.c3d's 7 events give one cycle per side; every one of them but the first
    strike (0.07 s after the recording starts: no heel-lead maximum before it) has a
    kinematic event (Zeni, strikes at the heel's fastest descent) within 2 frames (10 ms),
    and the kinematic events give the right cycle again within 2 frames."""
    if not QUALISYS.is_file():
        pytest.skip("../shared/data not present: Qualisys.c3d's cycles need the shared folder")
    traj = load_markers(QUALISYS)
    events = events_from_c3d(QUALISYS)
    ref, dropped = gait_cycles(events, traj.times)
    assert [c.side for c in ref] == ["left", "right"] and len(dropped) == 2
    kinematic = events_from_kinematics(traj, toe={"left": "L_FM1", "right": "R_FM1"})
    for e in events[1:]:
        near = [k for k in kinematic if (k.side, k.kind) == (e.side, e.kind)]
        assert min(abs(k.frame - e.frame) for k in near) <= 2, e
    found, _ = gait_cycles(kinematic, traj.times)
    right = [k for k in found if k.side == "right" and abs(k.start - ref[1].start) < 0.1]
    assert len(right) == 1
    for a, b in ((ref[1].start, right[0].start), (ref[1].stop, right[0].stop),
                 (ref[1].foot_off, right[0].foot_off)):  # fmt: skip
        assert abs(a - b) <= 2 / traj.rate + 1e-6


def _normative(path: Path, offset_deg: float = 0.0) -> Path:
    """A normative file: mean 10 sin(2 pi p) deg (+ offset), sd 5 deg, on every 1 %."""
    pct = np.arange(0, 101, 1)
    lines = ["variable,percent,mean,sd"]
    for variable, _ in GPS_VARIABLES:
        lines += [f"{variable},{p},{10 * np.sin(2 * np.pi * p / 100) + offset_deg:.9f},5"
                  for p in pct]  # fmt: skip
    path.write_text("\n".join(lines) + "\n")
    return path


def test_scores_arithmetic(tmp_path: Path) -> None:
    """Curves the normative mean plus a constant give that constant as GVS; the GPS is the
    RMS of the GVS (pelvis from the left), worked out by hand here."""
    normative = read_normative(_normative(tmp_path / "norm.csv"))
    base = np.radians(10 * np.sin(2 * np.pi * PERCENT / 100))
    shift = {"left": 2.0, "right": 4.0}  # deg, on every variable of the side
    curves = {}
    for side in ("left", "right"):
        for number in (1, 2):
            extra = shift[side] + (1.0 if number == 2 else -1.0)  # cycles 1 and 3 deg off
            for name in ("PelvisAngles", "HipAngles", "KneeAngles", "AnkleAngles",
                         "FootProgressAngles"):  # fmt: skip
                curves[(side, number, name)] = np.stack([base + np.radians(extra)] * 3, axis=1)
    got = scores(curves, normative)
    assert not isinstance(got, str)
    for (side, variable), (gvs, n) in got.gvs.items():
        assert n == 2 and np.degrees(gvs) == pytest.approx(shift[side], abs=1e-6), variable
    assert ("right", "PelvisAngles_X") not in got.gvs  # the pelvis on one side
    left, right = 2.0, np.sqrt((3 * 2.0**2 + 6 * 4.0**2) / 9)
    overall = np.sqrt((3 * 2.0**2 + 6 * 2.0**2 + 6 * 4.0**2) / 15)
    assert np.degrees(got.gps["left"]) == pytest.approx(left, abs=1e-6)
    assert np.degrees(got.gps["right"]) == pytest.approx(right, abs=1e-6)
    assert np.degrees(got.gps["overall"]) == pytest.approx(overall, abs=1e-6)
    # a set without the knee gives no scores, and says why
    text = (tmp_path / "norm.csv").read_text().splitlines()
    (tmp_path / "partial.csv").write_text("\n".join(r for r in text if "Knee" not in r))
    why = scores(curves, read_normative(tmp_path / "partial.csv"))
    assert isinstance(why, str) and "KneeAngles_X" in why


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("variable,pct,mean,sd\n", "line 1"),
        ("variable,percent,mean,sd\nKneeAngles_X,0,1,-1\n", "line 2"),
        ("variable,percent,mean,sd\nKneeAngles_X,50,1,1\nKneeAngles_X,40,1,1\n", "line 3"),
        ("variable,percent,mean,sd\nKneeAngles_X,0,one,1\n", "line 2"),
        ("variable,percent,mean,sd\nKneeAngles_X,0,1,1\n", "at least two points"),
    ],
)
def test_bad_normative_file_names_the_line(tmp_path: Path, text: str, where: str) -> None:
    path = tmp_path / "norm.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=where):
        read_normative(path)


def test_implausible_cycles_are_said() -> None:
    """A side whose mean stride lasts 5 s (a missed strike, a trial that is no walk) is
    implausible; a usual stride is not."""
    from mocap_mj.outputs.gait_report import TrialCycles, implausible

    def trial(stride_s: float) -> TrialCycles:
        cycle = gait_cycles(
            [_e("left", "foot_strike", 0.1), _e("left", "foot_off", 0.1 + 0.6 * stride_s),
             _e("left", "foot_strike", 0.1 + stride_s)], np.arange(0.0, 8.0, 0.01),
        )[0][0]  # fmt: skip
        params = {"stride_time_s": stride_s, "walking_speed_m_s": 1.3 / stride_s,
                  "stance_pct": cycle.percent(cycle.foot_off)}  # fmt: skip
        full = {n: params.get(n, np.nan) for n in PARAMETERS}
        return TrialCycles("t", [cycle], [], {}, {}, [full])

    assert implausible([trial(1.1)]) == []
    assert implausible([trial(5.0)]) == ["left stride_time_s 5: expected 0.4 to 4"]
