"""The cost of the API's argument checks (mocap_mj/arguments.py) against the work they guard.

Per trial size (synthetic ROM markers, 39 markers, tiled to T frames): the time of
``TrialData(...)`` (markers and times checked) and of the checks ``mocap_mj.identify`` runs on
entry (types, the markers' count, the marker cloud's size on up to 200 frames), the median of
``--repeats`` calls each; and for scale, one IK solve of 100 frames with the same model
(``solve_motion``, checks included). Printed in milliseconds.

Run: python benchmarks/arguments.py [--sizes 500 5000 50000] [--repeats 20]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import partial

import numpy as np

import mocap_mj
from mocap_mj import ParameterSet, TrialData
from mocap_mj.pipeline.arguments import IDENTIFY, identify_call
from mocap_synth import SynthConfig, synthesize


def median_ms(call: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def identify_checks(trial: TrialData, pset: ParameterSet) -> None:
    """What ``@validated(identify_call, **IDENTIFY)`` runs for ``identify([trial], pset=pset)``."""
    given = {"trials": [trial], "recipe": mocap_mj.Recipe(), "pset": pset}
    for name, value in given.items():
        IDENTIFY[name](name, value)
    identify_call(given)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[500, 5000, 50000])
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=500, seed=0), pset)
    base = np.asarray(exp.markers)
    print(f"{'frames':>8} {'TrialData ms':>13} {'identify checks ms':>19}")
    for size in args.sizes:
        markers = np.concatenate([base] * (size // len(base) + 1))[:size]
        times = np.arange(size) / 100.0
        trial = TrialData("rom", markers, times)
        made = median_ms(partial(TrialData, "rom", markers, times), args.repeats)
        checks = median_ms(partial(identify_checks, trial, pset), args.repeats)
        print(f"{size:>8} {made:>13.3f} {checks:>19.3f}")
    short = TrialData("rom", base[:100], np.asarray(exp.times)[:100])
    mocap_mj.solve_motion(pset, short)  # kernels loaded
    ik = median_ms(lambda: mocap_mj.solve_motion(pset, short), 3)
    print(f"for scale: solve_motion on 100 frames {ik:.1f} ms")


if __name__ == "__main__":
    main()
