"""Gait cycles: each side's cycles from one foot strike to the next, and series resampled to
the cycle's 101 points (0, 1, ..., 100 % of it).

A cycle of a side runs from a foot strike of that side to its next foot strike, and is kept
when a foot off of that side lies between them (its stance ends there) and both strikes lie
within the recorded times; a strike with no later strike of its side (the recording ends),
or two strikes with no foot off between (a missed event), give no cycle, and the reason is
said. The other side's foot off and foot strike inside the cycle (None when absent) bound its
single support. Event times are on the recording's time axis (:mod:`mocap_mj.capture.events`);
resampling interpolates linearly between the frames, so a cycle needs no event on a frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mocap_mj.capture.events import GaitEvent

__all__ = ["PERCENT", "GaitCycle", "gait_cycles", "resample", "resample_all"]

#: The 101 points of a cycle [% of the cycle].
PERCENT = np.arange(101, dtype=float)
SIDES = ("left", "right")


@dataclass(frozen=True)
class GaitCycle:
    """One gait cycle of ``side``: numbered ``number`` (from 1, per side and trial), from the
    foot strike at ``start`` [s] to the next at ``stop`` [s], its foot off at ``foot_off``
    [s], the other foot's off ``opposite_off`` and strike ``opposite_strike`` [s] inside it
    (None when the events do not hold them), the events' ``source``."""

    side: str
    number: int
    start: float
    stop: float
    foot_off: float
    opposite_off: float | None
    opposite_strike: float | None
    source: str

    @property
    def duration(self) -> float:
        """The stride time [s]."""
        return self.stop - self.start

    def percent(self, time: float | None) -> float:
        """``time`` [s] as % of the cycle (NaN for None)."""
        return float("nan") if time is None else 100.0 * (time - self.start) / self.duration


def gait_cycles(
    events: Sequence[GaitEvent], times: np.ndarray
) -> tuple[list[GaitCycle], list[str]]:
    """The complete cycles of ``events`` within ``times`` (T,) [s] (the recording's frames),
    in time order, and one line per dropped cycle saying why (module docstring)."""
    first, last = (float(times[0]), float(times[-1])) if len(times) else (0.0, -1.0)
    eps = 1e-9
    inside = [e for e in events if first - eps <= e.time <= last + eps]
    cycles: list[GaitCycle] = []
    dropped: list[str] = []
    for side in SIDES:
        other = "right" if side == "left" else "left"
        strikes = sorted(e.time for e in inside if e.side == side and e.kind == "foot_strike")
        offs = sorted(e.time for e in inside if e.side == side and e.kind == "foot_off")
        number = 0
        for k, start in enumerate(strikes):
            if k + 1 == len(strikes):
                dropped.append(
                    f"{side} foot strike at {start:.3f} s: no later {side} foot strike "
                    "(the recording ends), incomplete cycle dropped"
                )
                continue
            stop = strikes[k + 1]
            off = [t for t in offs if start < t < stop]
            if not off:
                dropped.append(
                    f"{side} cycle {start:.3f}-{stop:.3f} s: no {side} foot off between its "
                    "strikes (a missed event), dropped"
                )
                continue
            number += 1
            source = next(e.source for e in inside if e.time == start and e.side == side)
            cycles.append(
                GaitCycle(
                    side, number, start, stop, off[0],
                    _first(inside, other, "foot_off", start, stop),
                    _first(inside, other, "foot_strike", start, stop),
                    source,
                )
            )  # fmt: skip
    return sorted(cycles, key=lambda c: (c.start, c.side)), dropped


def _first(
    events: Sequence[GaitEvent], side: str, kind: str, start: float, stop: float
) -> float | None:
    found = [e.time for e in events if e.side == side and e.kind == kind and start < e.time < stop]
    return min(found) if found else None


def resample(values: np.ndarray, times: np.ndarray, cycle: GaitCycle) -> np.ndarray:
    """``values`` (T, k) at ``times`` (T,) [s] on the cycle's 101 points: (101, k), linear
    between frames; NaN where a neighbouring frame is NaN or the cycle leaves the frames."""
    values = np.asarray(values, dtype=float)
    flat = values.reshape(len(times), -1)
    at = cycle.start + PERCENT / 100.0 * cycle.duration
    out = np.full((len(at), flat.shape[1]), np.nan)
    if len(times) < 2:
        return out.reshape((len(at), *values.shape[1:]))
    j = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 2)
    w = (at - times[j]) / (times[j + 1] - times[j])
    ok = (at >= times[0] - 1e-9) & (at <= times[-1] + 1e-9)
    w = np.clip(w, 0.0, 1.0)
    out[ok] = (1.0 - w[ok, None]) * flat[j[ok]] + w[ok, None] * flat[j[ok] + 1]
    return out.reshape((len(at), *values.shape[1:]))


def resample_all(
    series: dict[str, np.ndarray], times: np.ndarray, cycles: Sequence[GaitCycle]
) -> dict[tuple[str, int, str], np.ndarray]:
    """Every series of a side (``L``/``R``-prefixed name -> (T, 3)) on each cycle of that
    side: (side, cycle number, name without the prefix) -> (101, 3)."""
    out = {}
    for c in cycles:
        prefix = c.side[0].upper()
        for name, values in series.items():
            if name.startswith(prefix) and len(name) > 1:
                out[(c.side, c.number, name[1:])] = resample(values, times, c)
    return out
