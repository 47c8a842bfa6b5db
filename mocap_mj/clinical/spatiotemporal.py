"""Spatiotemporal parameters of gait cycles, as gait labs define them (Vicon Nexus's and
Polygon's definitions; Baker 2013, *Measuring Walking*, ch. 5), per cycle of a side:

- stride time: from the foot strike to the next of the same foot [s]; cadence: steps per
  minute, 120 / stride time (two steps a stride);
- stride length: the horizontal distance the heel marker travels from the cycle's strike to
  the next [m]; its direction is the cycle's direction of progression; walking speed: stride
  length / stride time [m/s];
- step time: from the other foot's strike inside the cycle to the cycle's closing strike
  [s]; step length: along the progression, the closing heel's lead over the other heel at
  the closing strike [m]; step width: across it, their distance there [m];
- stance: strike to foot off, % of the cycle; swing: 100 - stance; single support: the other
  foot's off to its strike (its swing) [%]; double support: stance - single support (the two
  periods with both feet down) [%]; foot off: stance's end [%].

The heel marker is ``LHEE`` / ``RHEE`` (the ankle marker ``LANK`` / ``RANK`` without it);
heights are the trajectory's z (up). A parameter whose events or markers are missing is NaN.
Means and standard deviations (sample, n - 1) are over a side's cycles, NaN ignored.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mocap_mj.io.trajectory import MarkerTrajectory

from .cycles import GaitCycle

__all__ = ["PARAMETERS", "cycle_parameters", "heel_markers", "summary_rows"]

#: Each parameter's name (its unit in the name, cadence in the clinic's steps/min).
PARAMETERS = (
    "stride_time_s", "step_time_s", "cadence_steps_per_min", "walking_speed_m_s",
    "stride_length_m", "step_length_m", "step_width_m", "stance_pct", "swing_pct",
    "single_support_pct", "double_support_pct", "foot_off_pct",
)  # fmt: skip


def heel_markers(trajectory: MarkerTrajectory) -> dict[str, str | None]:
    """side -> the marker the stride is measured on: the heel, else the ankle, else None."""
    names = set(trajectory.names)
    out: dict[str, str | None] = {}
    for side, p in (("left", "L"), ("right", "R")):
        out[side] = next((m for m in (p + "HEE", p + "ANK") if m in names), None)
    return out


def _at(trajectory: MarkerTrajectory, marker: str | None, time: float) -> np.ndarray:
    """The marker's position (3,) [m] at ``time`` [s], linear between frames (NaN without)."""
    if marker is None:
        return np.full(3, np.nan)
    xyz = trajectory.select([marker])[:, 0]
    return np.array([np.interp(time, trajectory.times, xyz[:, k]) for k in range(3)])


def cycle_parameters(cycle: GaitCycle, trajectory: MarkerTrajectory) -> dict[str, float]:
    """:data:`PARAMETERS` of one cycle (module docstring) from the trial's markers."""
    heels = heel_markers(trajectory)
    other = "right" if cycle.side == "left" else "left"
    begin = _at(trajectory, heels[cycle.side], cycle.start)
    end = _at(trajectory, heels[cycle.side], cycle.stop)
    opposite = _at(trajectory, heels[other], cycle.stop)
    stride = (end - begin)[:2]
    length = float(np.linalg.norm(stride))
    ahead = stride / length if length > 0 else np.full(2, np.nan)
    across = np.array([-ahead[1], ahead[0]])
    lead = (end - opposite)[:2]
    stance = cycle.percent(cycle.foot_off)
    single = cycle.percent(cycle.opposite_strike) - cycle.percent(cycle.opposite_off)
    step_time = np.nan if cycle.opposite_strike is None else cycle.stop - cycle.opposite_strike
    return {
        "stride_time_s": cycle.duration,
        "step_time_s": float(step_time),
        "cadence_steps_per_min": 120.0 / cycle.duration,
        "walking_speed_m_s": length / cycle.duration,
        "stride_length_m": length,
        "step_length_m": float(lead @ ahead),
        "step_width_m": float(abs(lead @ across)),
        "stance_pct": stance,
        "swing_pct": 100.0 - stance,
        "single_support_pct": single,
        "double_support_pct": stance - single,
        "foot_off_pct": stance,
    }


def summary_rows(
    rows: Sequence[tuple[str, dict[str, float]]],
) -> dict[str, dict[str, tuple[float, float, int]]]:
    """side -> parameter -> (mean, sample sd, cycles counted) over ``rows`` ((side,
    parameters) per cycle); NaN ignored, sd NaN under two values."""
    out: dict[str, dict[str, tuple[float, float, int]]] = {}
    for side in ("left", "right"):
        mine = [p for s, p in rows if s == side]
        if not mine:
            continue
        out[side] = {}
        for name in PARAMETERS:
            v = np.array([p[name] for p in mine], dtype=float)
            v = v[np.isfinite(v)]
            mean = float(v.mean()) if len(v) else float("nan")
            sd = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
            out[side][name] = (mean, sd, len(v))
    return out
