"""First-run time: `mocap-mj demo` with an empty numba cache, then again with the cache filled.

A fresh install has no compiled kernels: numba compiles them on first use and caches them on
disk (beside the modules, or in ``NUMBA_CACHE_DIR``). This script points ``NUMBA_CACHE_DIR`` at
a new temporary folder, runs the demo twice in fresh processes and prints, for each run, the
wall time and the CPU time (user + system) of the process and the processes it waited for. On
a shared machine the CPU time is the steadier figure: the wall time grows with the other load,
the compile's CPU time hardly does.

With ``--kernels`` the first run also prints the compile time of every kernel compiled from
Python (the entry kernels; each includes the helpers compiled for it), from numba's
``numba:compile`` events, and the CPU time of the demo's own process (without the second
process that ``--prewarm 1`` starts; with it, that process's compile is off the demo's
critical path). ``--prewarm 0/1``
sets ``MOCAP_MJ_PREWARM`` (the identification kernels compiled in a second process,
``mocap_mj/skeleton/prewarm.py``; default: its own rule).

Run: python benchmarks/cold_start.py [--python PATH] [--frames 500] [--runs 2] [--kernels]
[--prewarm 0|1] (``--python`` another environment's interpreter, e.g. to compare with an
older install; the demo is run as ``PYTHON -m mocap_mj demo``).
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

#: Run in the child with --kernels: the demo in-process, top-level compile events timed.
_LISTEN = """
import sys, time
from numba.core import event
depth, seconds = [], {}
class Listener(event.Listener):
    def on_start(self, ev):
        depth.append(time.perf_counter())
    def on_end(self, ev):
        t0 = depth.pop()
        if not depth:
            name = ev.data["dispatcher"].py_func.__qualname__
            seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - t0
event.register("numba:compile", Listener())
from mocap_mj.cli import main
try:
    main(sys.argv[1:])
except SystemExit as e:
    status = e.code
else:
    status = 0
for name, s in seconds.items():
    print(f"  compile {name:<24} {s:6.2f} s", file=sys.stderr)
print(f"  compile total{'':<19} {sum(seconds.values()):6.2f} s", file=sys.stderr)
print(f"  compile main process CPU {time.process_time():6.2f} s", file=sys.stderr)
sys.exit(status)
"""


def run_demo(
    python: str, out: Path, cache: Path, frames: int, kernels: bool, prewarm: str | None
) -> tuple[float, float, int, str]:
    """(wall [s], CPU [s], exit status, per-kernel lines) of one demo in a fresh process."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    if prewarm is not None:
        env["MOCAP_MJ_PREWARM"] = prewarm
    demo = ["demo", "--out", str(out), "--frame-count", str(frames), "--json"]
    cmd = [python, "-c", _LISTEN, *demo] if kernels else [python, "-m", "mocap_mj", *demo]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(
        cmd,
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
    lines = [x for x in proc.stderr.splitlines() if x.startswith("  compile ")]
    return wall, cpu, proc.returncode, "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--python", default=sys.executable, help="interpreter (default: this)")
    parser.add_argument("--frames", type=int, default=500, help="demo frames (default: 500)")
    parser.add_argument("--runs", type=int, default=2, help="runs on one cache (default: 2)")
    parser.add_argument(
        "--kernels", action="store_true", help="print each kernel's compile time (first run)"
    )
    parser.add_argument(
        "--prewarm", choices=["0", "1"], help="MOCAP_MJ_PREWARM (default: unset, its own rule)"
    )
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(f"python {args.python}; {os.cpu_count()} cores, load average {load:.1f} at start")
    with tempfile.TemporaryDirectory(prefix="mocap-cold-") as tmp:
        cache = Path(tmp) / "numba-cache"
        for i in range(args.runs):
            wall, cpu, status, lines = run_demo(
                args.python,
                Path(tmp) / f"demo{i}",
                cache,
                args.frames,
                args.kernels and i == 0,
                args.prewarm,
            )
            what = "first (empty cache)" if i == 0 else "again (cache filled)"
            print(f"demo run {i + 1}, {what}: wall {wall:6.1f} s, CPU {cpu:6.1f} s, exit {status}")
            if lines:
                print(lines)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
