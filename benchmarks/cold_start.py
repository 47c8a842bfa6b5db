"""First-run time: `mocap-mj demo` with an empty numba cache, then again with the cache filled.

A fresh install has no compiled kernels: numba compiles them on first use and caches them on
disk (beside the modules, or in ``NUMBA_CACHE_DIR``). This script points ``NUMBA_CACHE_DIR`` at
a new temporary folder, runs the demo twice in fresh processes and prints, for each run, the
wall time and the CPU time (user + system) of the process. On a shared machine the CPU time
is the steadier figure: the wall time grows with the other load, the compile's CPU time
hardly does.

Run: python benchmarks/cold_start.py [--python PATH] [--frames 500] [--runs 2]
(``--python`` another environment's interpreter, e.g. to compare with an older install;
the demo is run as ``PYTHON -m mocap_mj demo``).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run_demo(python: str, out: Path, cache: Path, frames: int) -> tuple[float, float, int]:
    """(wall [s], CPU [s], exit status) of one demo in a fresh process."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(
        [python, "-m", "mocap_mj", "demo", "--out", str(out), "--frames", str(frames), "--json"],
        env=env,
        cwd=out.parent,  # not the checkout: `-m` would import the package from the cwd
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        print(proc.stderr, file=sys.stderr)
    return wall, cpu, proc.returncode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--python", default=sys.executable, help="interpreter (default: this)")
    parser.add_argument("--frames", type=int, default=500, help="demo frames (default: 500)")
    parser.add_argument("--runs", type=int, default=2, help="runs on one cache (default: 2)")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(f"python {args.python}; {os.cpu_count()} cores, load average {load:.1f} at start")
    with tempfile.TemporaryDirectory(prefix="mocap-cold-") as tmp:
        cache = Path(tmp) / "numba-cache"
        for i in range(args.runs):
            wall, cpu, status = run_demo(args.python, Path(tmp) / f"demo{i}", cache, args.frames)
            what = "first (empty cache)" if i == 0 else "again (cache filled)"
            print(f"demo run {i + 1}, {what}: wall {wall:6.1f} s, CPU {cpu:6.1f} s, exit {status}")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
