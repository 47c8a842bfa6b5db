"""The synthetic walk's gait truth: its events and its spatiotemporal parameters.

The walk's legs follow periodic curves (:func:`mocap_synth.motion.walk`): the left foot
strikes at phase 0 of its curves, the right half a stride later, each foot comes off at
:data:`~mocap_synth.motion.WALK_FOOT_OFF` of its cycle. From the stride period P [s] and
stride length L [m] the walk draws: stride time P, step time P / 2, cadence 120 / P steps/min,
walking speed L / P, stride length L, stance 60 %, single support 40 %, double support 20 %;
step length and width are measured on the noise-free heel markers at the true foot strikes
(:func:`mocap_mj.clinical.spatiotemporal.cycle_parameters`: the legs' curves differ a little
between sides, and a foot slides a little in stance, so they are not exactly L / 2).

Files: ``truth_events.csv`` (events.csv's format: what ``gait-report --events`` reads) and
``truth_gait.json`` (the parameters per side, mean over the complete cycles).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.capture.events import GaitEvent, events_csv
from mocap_mj.clinical.cycles import gait_cycles
from mocap_mj.clinical.spatiotemporal import cycle_parameters, summary_rows
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.trajectory import MarkerTrajectory

from .experiment import STREAMS, Experiment
from .motion import WALK_FOOT_OFF, walk_gait
from .postures import blend_end

__all__ = ["TRUTH_FILES", "truth_events", "truth_gait", "write_gait_truth"]

TRUTH_FILES = ("truth_events.csv", "truth_gait.json")
SOURCE = "synthetic truth"


def _draws(exp: Experiment) -> tuple[float, float, float]:
    """The walk's period [s], stride [m] and phase at 0 [cycles], drawn again from the seed."""
    seeds = np.random.SeedSequence(exp.config.seed).spawn(len(STREAMS))
    return walk_gait(np.random.default_rng(seeds[STREAMS.index("motion")]))


def truth_events(exp: Experiment) -> list[GaitEvent]:
    """The walk's foot strikes and foot offs within its frames, in time order (a walk
    starting in a posture: those after it has blended into the walk)."""
    period, _, phase0 = _draws(exp)
    rate = exp.config.rate
    last = float(exp.times[-1])
    first = blend_end(exp.config.pose, last)
    out = []
    for side, shift in (("left", 0.0), ("right", 0.5)):
        for kind, at in (("foot_strike", 0.0), ("foot_off", WALK_FOOT_OFF)):
            k = np.arange(-1, int(last / period) + 3)
            times = (k + at - phase0 - shift) * period
            times = times[(times >= first) & (times <= last)]
            out += [GaitEvent(side, kind, float(t), round(t * rate) + 1, SOURCE) for t in times]
    return sorted(out, key=lambda e: (e.time, e.side))


def truth_gait(exp: Experiment) -> dict[str, Any]:
    """truth_gait.json's content (module docstring); lengths [m], times [s], shares [%]."""
    period, stride, _ = _draws(exp)
    clean = MarkerTrajectory(
        times=np.array(exp.times), positions=np.array(exp.markers_clean),
        names=exp.marker_names, rate=exp.config.rate,
    )  # fmt: skip
    cycles, _ = gait_cycles(truth_events(exp), clean.times)
    measured = summary_rows([(c.side, cycle_parameters(c, clean)) for c in cycles])
    sides = {}
    for side, stats in measured.items():
        sides[side] = {
            "cycles": stats["stride_time_s"][2],
            "step_length_m": stats["step_length_m"][0],
            "step_width_m": stats["step_width_m"][0],
        }
    return {
        "description": "mocap-mj synthetic walk: its gait events and spatiotemporal truth",
        "stride_time_s": period,
        "step_time_s": period / 2,
        "cadence_steps_per_min": 120.0 / period,
        "walking_speed_m_s": stride / period,
        "stride_length_m": stride,
        "stance_pct": 100.0 * WALK_FOOT_OFF,
        "swing_pct": 100.0 * (1.0 - WALK_FOOT_OFF),
        "single_support_pct": 100.0 * (1.0 - WALK_FOOT_OFF),
        "double_support_pct": 100.0 * (2.0 * WALK_FOOT_OFF - 1.0),
        "per_side": sides,
    }


def write_gait_truth(exp: Experiment, out: Path) -> list[str]:
    """truth_events.csv and truth_gait.json into ``out`` (a walk only); their names."""
    if exp.config.motion != "walk":
        return []
    atomic_write_text(out / TRUTH_FILES[0], events_csv(truth_events(exp)))
    atomic_write_text(out / TRUTH_FILES[1], json.dumps(truth_gait(exp), indent=2) + "\n")
    return list(TRUTH_FILES)
