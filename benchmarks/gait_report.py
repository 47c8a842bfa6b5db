"""The gait report's targets: gait events and cycles on Qualisys.c3d, spatiotemporal
parameters on synthetic walks, and the time of ``mocap-mj gait-report``.

    python benchmarks/gait_report.py [--seeds N] [--frames T]

1. Qualisys.c3d (../shared/data/vendors): the cycles its 7 EVENT-group events give, and
   each event's distance in frames to the nearest kinematic one of its side and kind (Zeni
   et al. 2008, strikes at the heel's fastest descent; ``L_FM1``/``R_FM1`` for the toes).
2. Synthetic walks (seeds 0..N-1, T frames at 100 Hz, 1 mm noise): each side's mean
   cadence, walking speed, stride length and time, step length and time from the noisy
   markers at the walk's own events, against truth_gait.json's (the largest relative error
   over the seeds and sides), and the same from the kinematic events (the synthetic feet
   never land: the heel's descent and lead do not mark a strike as on a floor).
3. ``mocap-mj gait-report`` on one synthetic walk (its events, a subject file): wall time.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mocap_mj.capture.events import events_from_c3d, events_from_kinematics
from mocap_mj.clinical.cycles import gait_cycles
from mocap_mj.clinical.spatiotemporal import cycle_parameters, summary_rows
from mocap_mj.io import load_markers

ROOT = Path(__file__).resolve().parents[1]
QUALISYS = ROOT.parent / "shared" / "data" / "vendors" / "Qualisys.c3d"
COMPARED = ("cadence_steps_per_min", "walking_speed_m_s", "stride_length_m", "stride_time_s",
            "step_time_s")  # fmt: skip
SUBJECT = (
    "knee_width_l: 105 mm\nknee_width_r: 105 mm\nankle_width_l: 70 mm\nankle_width_r: 70 mm\n"
    "leg_length_l: 900 mm\nleg_length_r: 900 mm\n"
)


def qualisys() -> None:
    if not QUALISYS.is_file():
        print(f"Qualisys.c3d: {QUALISYS} absent, skipped")
        return
    traj = load_markers(QUALISYS)
    ref = events_from_c3d(QUALISYS)
    cycles, dropped = gait_cycles(ref, traj.times)
    print(f"Qualisys.c3d: {len(ref)} events -> cycles "
          + ", ".join(f"{c.side} {c.start:.3f}-{c.stop:.3f} s" for c in cycles)
          + f" ({len(dropped)} incomplete dropped)")  # fmt: skip
    found = events_from_kinematics(traj, toe={"left": "L_FM1", "right": "R_FM1"})
    for e in ref:
        near = [k.frame - e.frame for k in found if (k.side, k.kind) == (e.side, e.kind)]
        gap = min(near, key=abs) if near else None
        shown = "none found" if gap is None or abs(gap) > 20 else f"{gap:+d} frames"
        print(f"  {e.side:5s} {e.kind:11s} frame {e.frame}: kinematic {shown}")


def walks(seeds: int, frames: int) -> None:
    from mocap_synth import SynthConfig, synthesize
    from mocap_synth.gait_truth import truth_events, truth_gait

    worst = {"truth events": (0.0, ""), "kinematic events": (0.0, "")}
    for seed in range(seeds):
        exp = synthesize(SynthConfig(motion="walk", frames=frames, rate=100.0, seed=seed))
        truth = truth_gait(exp)
        traj = exp.trajectory()
        for label, events in (("truth events", truth_events(exp)),
                              ("kinematic events", events_from_kinematics(traj))):  # fmt: skip
            cycles, _ = gait_cycles(events, traj.times)
            stats = summary_rows([(c.side, cycle_parameters(c, traj)) for c in cycles])
            errors = []
            for side, got in stats.items():
                errors += [(abs(got[n][0] / truth[n] - 1), f"{side} {n}") for n in COMPARED]
                step = truth["per_side"][side]["step_length_m"]
                errors.append((abs(got["step_length_m"][0] / step - 1), f"{side} step_length_m"))
            largest = max(errors)
            worst[label] = max(worst[label], largest)
            print(f"seed {seed} {label:16s}: {len(cycles)} cycles, largest error "
                  f"{100 * largest[0]:.3f} % ({largest[1]}; speed truth "
                  f"{truth['walking_speed_m_s']:.3f} m/s, cadence "
                  f"{truth['cadence_steps_per_min']:.1f} steps/min)")  # fmt: skip
    for label, (value, name) in worst.items():
        print(f"synthetic walks, {label}: largest relative error {100 * value:.3f} % ({name})")


def command(frames: int) -> None:
    from mocap_synth import SynthConfig, synthesize, write_experiment
    from mocap_synth.gait_truth import write_gait_truth

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        exp = synthesize(SynthConfig(motion="walk", frames=frames, rate=100.0, seed=0))
        write_experiment(exp, folder / "s", extra=lambda out: write_gait_truth(exp, out))
        (folder / "subject.yaml").write_text(SUBJECT)
        argv = [sys.executable, "-m", "mocap_mj", "gait-report", "--markers",
                str(folder / "s" / "markers.trc"), "--events",
                str(folder / "s" / "truth_events.csv"), "--subject-file",
                str(folder / "subject.yaml"), "--out", str(folder / "r")]  # fmt: skip
        t0 = time.perf_counter()
        done = subprocess.run(argv, capture_output=True, text=True, check=False)
        seconds = time.perf_counter() - t0
        html = folder / "r" / "report.html"
        size = html.stat().st_size / 1e3 if html.is_file() else float("nan")
        print(
            f"gait-report on {frames} frames: exit {done.returncode}, {seconds:.1f} s wall "
            f"(process start included), report.html {size:.0f} kB"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--frames", type=int, default=500)
    args = parser.parse_args()
    np.set_printoptions(precision=4)
    qualisys()
    walks(args.seeds, args.frames)
    command(args.frames)


if __name__ == "__main__":
    main()
