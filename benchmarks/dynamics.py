"""Inverse dynamics throughput (frames per second) on the bundled humanoid as written.

Times :func:`mocap_mj.pipeline.dynamics.inverse_dynamics` on a synthetic walk
(``mocap_synth.motion.walk``) at 100 Hz with a load on each foot (the whole call: tangent
coordinates, the 6 Hz filter, differences, MuJoCo's inverse dynamics and ``mj_applyFT`` every
frame) and, apart, the smoothing alone.
Best of ``--repeat`` runs; the machine's load average is printed beside the figures.

Run: python benchmarks/dynamics.py [--frames 10000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.pipeline.dynamics import CUTOFF_HZ, BodyLoad, inverse_dynamics, smoothed
from mocap_mj.skeleton import exported
from mocap_synth.motion import walk


def best_of(fn: Callable[[], object], repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    pset = ParameterSet()
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / "model.xml"
        path.write_text(pset.to_xml(pset.nominal))
        model = inertial_model(path, 75.0)
    motion = walk(pset.model, args.frames, 100.0, np.random.default_rng(0))
    qpos = exported.Layout.of(pset.model).written(motion)
    times = np.arange(args.frames) / 100.0
    half = np.tile([0.0, 0.0, 0.5 * 75.0 * 9.81], (args.frames, 1))
    loads = [
        BodyLoad(f"foot_{s}", half, np.tile([0.1, y, 0.0], (args.frames, 1)), np.zeros_like(half))
        for s, y in (("l", 0.1), ("r", -0.1))
    ]
    n = args.frames
    print(f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    print(f"model nq {model.nq}, nv {model.nv}; {n} frames at 100 Hz, two foot loads")
    whole = best_of(lambda: inverse_dynamics(model, qpos, times, loads), args.repeat)
    smooth = best_of(lambda: smoothed(model, qpos, 0.01, CUTOFF_HZ), args.repeat)
    print(f"{'stage':<44} {'s':>8} {'frames/s':>10}")
    print(f"{'inverse_dynamics (whole call, 6 Hz filter)':<44} {whole:8.3f} {n / whole:10.0f}")
    print(f"{'  smoothing and differences alone':<44} {smooth:8.3f} {n / smooth:10.0f}")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
