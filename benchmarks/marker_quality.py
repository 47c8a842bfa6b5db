"""Speed of the marker-data quality check (:mod:`mocap_mj.capture.marker_quality`); prints figures.

    python benchmarks/marker_quality.py [--frames 1000 10000 100000 360000] [--repeat 3]

A synthetic range of motion (mocap_synth, 100 Hz, soft tissue 10 mm/rad) played forwards
and backwards (continuous, so that no seam is a jump) up to each length: the
check's time per call (best of ``--repeat``) and per 1000 frames. It runs before every
identify and ik, on hour-long recordings too (360,000 frames at 100 Hz).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mocap_mj.capture.marker_quality import check_marker_quality, marker_segments
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_synth import SynthConfig, synthesize


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, nargs="+", default=[1000, 10_000, 100_000, 360_000])
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=1000, motion="rom", sta_mm=10.0, seed=0), pset)
    base = np.concatenate([exp.markers, exp.markers[::-1]])
    segments = marker_segments(pset.model)
    for n in args.frames:
        x = np.concatenate([base] * (-(-n // len(base))))[:n]
        best = np.inf
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            found = check_marker_quality("bench", pset.marker_names, x, 100.0, segments)
            best = min(best, time.perf_counter() - t0)
        print(
            f"{n:>8,} frames: {best * 1e3:8.1f} ms ({best * 1e6 / n:.2f} ms per 1000 frames), "
            f"{len(found)} finding(s)"
        )


if __name__ == "__main__":
    main()
