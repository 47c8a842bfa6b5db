"""The gait report's tables: each trial's cycles with its curves and spatiotemporal
parameters (:class:`TrialCycles`), and cycles.csv, spatiotemporal.csv and scores.csv; where
its angles come from (:class:`AnglesSource`, summary.json's :func:`source_fields`).

``cycles.csv``: long format, a row per trial, side, cycle, variable and point: ``trial``,
``side``, ``cycle`` (from 1, per trial and side), ``variable`` (the Plug-in Gait name without
its side, an axis appended: ``KneeAngles_X``), ``percent`` (0-100) and ``value`` (degrees
for angles; kinetics per kg body mass in SI: N m/kg, W/kg, N/kg; % body weight for
``NormalisedGRF``). ``spatiotemporal.csv``: a row per cycle, then per side its ``mean`` and
``sd`` rows (:data:`~mocap_mj.clinical.spatiotemporal.PARAMETERS`). ``scores.csv``: a row
per side and GVS variable, then the GPS rows (side ``left``, ``right``, ``overall``) [deg].

A cycle's kinetics count when its foot stands on a counted plate through its stance (its
ground reaction non-zero from 10 to 90 % of the stance); other cycles give their angles
only, a line says so.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocap_mj.capture.events import GaitEvent
from mocap_mj.clinical.cycles import PERCENT, GaitCycle, gait_cycles, resample_all
from mocap_mj.clinical.gait_scores import GPS_VARIABLES, Scores, unit_scale
from mocap_mj.clinical.spatiotemporal import PARAMETERS, cycle_parameters, summary_rows
from mocap_mj.io.trajectory import MarkerTrajectory

__all__ = [
    "PLAUSIBLE",
    "AnglesSource",
    "TrialCycles",
    "cycles_csv",
    "implausible",
    "kinetic_kept",
    "scores_csv",
    "source_fields",
    "spatiotemporal_csv",
    "trial_cycles",
]

Curves = dict[tuple[str, int, str], np.ndarray]


@dataclass
class TrialCycles:
    """One trial's cycles: its ``name``, the ``cycles``, the ``dropped`` lines, its angle
    ``angles`` and kinetic ``kinetics`` curves ((side, cycle, variable) -> (101, 3), SI),
    each cycle's spatiotemporal ``parameters`` and the events' ``source``."""

    name: str
    cycles: list[GaitCycle]
    dropped: list[str]
    angles: Curves
    kinetics: Curves = field(default_factory=dict)
    parameters: list[dict[str, float]] = field(default_factory=list)


@dataclass(frozen=True)
class AnglesSource:
    """Where a gait report's angles come from: ``angles`` (the words summary.json and the
    page give) and, for the angles of a model identified on the trials, its model.xml
    ``model`` and marker RMSE ``marker_rmse`` [m] (None: unknown)."""

    angles: str
    model: str | None = None
    marker_rmse: float | None = None


def source_fields(source: AnglesSource) -> dict[str, Any]:
    """summary.json's fields of ``source``: ``angles`` and, for an identified model,
    ``marker_rmse_mm`` (null: unknown) and ``model``."""
    if source.model is None:
        return {"angles": source.angles}
    rmse = None if source.marker_rmse is None else source.marker_rmse * 1e3
    return {"angles": source.angles, "marker_rmse_mm": rmse, "model": source.model}


def kinetic_kept(cycle: GaitCycle, curves: Curves) -> bool:
    """Whether the cycle's foot stands on a counted plate through its stance (module
    docstring): its ``GroundReactionForce`` curve non-zero from 10 to 90 % of the stance."""
    grf = curves.get((cycle.side, cycle.number, "GroundReactionForce"))
    if grf is None:
        return False
    stance = cycle.percent(cycle.foot_off)
    rows = (PERCENT >= 0.1 * stance) & (PERCENT <= 0.9 * stance)
    norm = np.linalg.norm(grf[rows], axis=1)
    return bool(rows.any() and np.all(np.isfinite(norm)) and np.all(norm > 0))


def trial_cycles(
    name: str,
    events: Sequence[GaitEvent],
    trajectory: MarkerTrajectory,
    angles: Mapping[str, np.ndarray],
    kinetics: Mapping[str, np.ndarray] | None = None,
) -> TrialCycles:
    """The cycles of a trial from its ``events``, ``trajectory`` (T frames) and its Plug-in
    Gait series by Vicon name (``LKneeAngles``... (T, 3) [rad]; ``kinetics``: ``LHipMoment``
    ... (T, 3) per kg, SI), at the trajectory's times."""
    times = trajectory.times
    cycles, dropped = gait_cycles(events, times)
    curves = resample_all(dict(angles), times, cycles)
    kinetic: Curves = {}
    if kinetics:
        every = resample_all(dict(kinetics), times, cycles)
        for c in cycles:
            mine = {k: v for k, v in every.items() if k[:2] == (c.side, c.number)}
            if kinetic_kept(c, mine):
                kinetic |= mine
            else:
                dropped.append(
                    f"{c.side} cycle {c.number} ({c.start:.3f}-{c.stop:.3f} s): the foot is "
                    "not on a counted force plate through its stance: angles only"
                )
    parameters = [cycle_parameters(c, trajectory) for c in cycles]
    return TrialCycles(name, cycles, dropped, curves, kinetic, parameters)


#: The range of a side's mean parameter outside which the cycles are implausible (an event
#: missed or misplaced, a trial that is not a walk): stride time [s], speed [m/s], stance [%].
PLAUSIBLE = {
    "stride_time_s": (0.4, 4.0),
    "walking_speed_m_s": (0.0, 5.0),
    "stance_pct": (20.0, 95.0),
}


def implausible(trials: Sequence[TrialCycles]) -> list[str]:
    """One line per side whose mean parameter lies outside :data:`PLAUSIBLE` (the command
    then exits with status 3)."""
    rows = [(c.side, p) for t in trials for c, p in zip(t.cycles, t.parameters, strict=True)]
    out = []
    for side, stats in summary_rows(rows).items():
        for name, (low, high) in PLAUSIBLE.items():
            mean = stats[name][0]
            if np.isfinite(mean) and not low <= mean <= high:
                out.append(f"{side} {name} {mean:.3g}: expected {low:g} to {high:g}")
    return out


def cycles_csv(trials: Sequence[TrialCycles]) -> str:
    """cycles.csv's text (module docstring)."""
    lines = ["trial,side,cycle,variable,percent,value"]
    for t in trials:
        for (side, number, name), values in sorted({**t.angles, **t.kinetics}.items()):
            scale = unit_scale(name)
            for k, axis in enumerate("XYZ"):
                variable = f"{name}_{axis}"
                for p, v in zip(PERCENT, values[:, k], strict=True):
                    cell = f"{v * scale:.6g}" if np.isfinite(v) else ""
                    lines.append(f"{t.name},{side},{number},{variable},{p:g},{cell}")
    return "\n".join(lines) + "\n"


def _cell(value: float) -> str:
    return f"{value:.6g}" if np.isfinite(value) else ""


def spatiotemporal_csv(trials: Sequence[TrialCycles]) -> str:
    """spatiotemporal.csv's text: a row per cycle, then each side's mean and sd."""
    lines = [",".join(("trial", "side", "cycle", "start_s", "stop_s", *PARAMETERS))]
    rows = []
    for t in trials:
        for c, p in zip(t.cycles, t.parameters, strict=True):
            rows.append((c.side, p))
            cells = [_cell(p[n]) for n in PARAMETERS]
            lines.append(",".join([t.name, c.side, str(c.number), f"{c.start:.6f}",
                                   f"{c.stop:.6f}", *cells]))  # fmt: skip
    for side, stats in summary_rows(rows).items():
        for k, label in ((0, "mean"), (1, "sd")):
            cells = [_cell(stats[n][k]) for n in PARAMETERS]
            lines.append(",".join(["all", side, label, "", "", *cells]))
    return "\n".join(lines) + "\n"


def scores_csv(result: Scores) -> str:
    """scores.csv's text: ``side,score,variable,value_deg,cycles``: a GVS row per side and
    variable (the pelvis's on the left), then the three GPS rows."""
    lines = ["side,score,variable,value_deg,cycles"]
    names = dict(GPS_VARIABLES)
    for (side, variable), (value, n) in result.gvs.items():
        lines.append(f"{side},GVS,{variable} ({names[variable]}),{_cell(np.degrees(value))},{n}")
    for side, value in result.gps.items():
        lines.append(f"{side},GPS,,{_cell(np.degrees(value))},")
    return "\n".join(lines) + "\n"
