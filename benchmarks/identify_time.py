"""Where the time of a whole `mocap-mj identify` goes, beside its fit.

A synthetic subject recorded in four trials (TRC files: a range of motion, a walk, a static
pose, another walk; one seed, so one subject), two of them with a left/right label swap for a
while, is identified by `mocap-mj identify --markers A B C D` in this process, after one
warm-up run (the kernels compiled and the modules imported: the figures are those of a
second identification, as a lab's). Timers wrapped around the command's parts give their
wall time: reading the files, the marker-data checks, the relabelling (finding and
correcting the swaps, inside the checks), the fit (`solve_trials`), describing it
(identifiability, checks, segment table), every frame's motion, the plots, and the result
folder with its report (written less the plots). The rule it checks: the whole command
within twice its fit.

Run: python benchmarks/identify_time.py [--frames 300] [--runs 1] [--keep DIR]
"""

from __future__ import annotations

import argparse
import collections
import functools
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, redirect_stdout
from pathlib import Path
from typing import Any

import mocap_mj.commands.identify as command
import mocap_mj.io.plots as plots
import mocap_mj.pipeline.api as api
import mocap_mj.pipeline.prepare as prepare
import mocap_mj.pipeline.quality as quality
from mocap_mj.cli import main
from mocap_synth import SynthConfig, synthesize, write_experiment

#: The four trials: movement, frames as a share of --frames, label swaps.
TRIALS = (("rom", 1.0, 0), ("walk", 1.0, 1), ("static", 0.3, 0), ("walk", 1.0, 1))
SECONDS: dict[str, float] = collections.defaultdict(float)
#: CPU seconds of this process (both cores' threads) per part: steadier on a busy machine.
CPU: dict[str, float] = collections.defaultdict(float)
#: The parts, in the order printed; "checks" and "write" are given less what they contain.
PARTS = (
    "reading",
    "marker set",
    "checks",
    "relabelling",
    "fit",
    "describe",
    "motion",
    "plots",
    "write",
)


def _timed(part: str, fn: Callable[..., Any]) -> Callable[..., Any]:
    depth = [0]

    @functools.wraps(fn)
    def run(*args: Any, **kwargs: Any) -> Any:
        depth[0] += 1
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            depth[0] -= 1
            if depth[0] == 0:  # a recursive or repeated inner call is counted once
                SECONDS[part] += time.perf_counter() - t0
                CPU[part] += time.process_time() - c0

    return run


@contextmanager
def _timers() -> Iterator[None]:
    """Wrap the command's parts (module attributes, as the command looks them up)."""
    targets = [
        (command, "load_trial", "reading"),
        (command, "choose_marker_set", "marker set"),
        (prepare, "check_trials", "checks"),
        (prepare, "check_markers", "checks"),
        (quality, "relabel", "relabelling"),
        (api, "solve_trials", "fit"),
        (api, "_described", "describe"),
        (api, "every_frame_motion", "motion"),
        (api, "write_every_frame_motion", "motion"),
        (command, "write_result", "write"),
        *((plots, n, "plots") for n in dir(plots) if n.startswith("plot_")),
    ]
    missing = [f"{m.__name__}.{n}" for m, n, _ in targets if not hasattr(m, n)]
    if missing:  # a part moved: its time would count as "other" without a word
        raise SystemExit(f"identify_time.py: no {', '.join(missing)} to time")
    saved = [(m, n, getattr(m, n)) for m, n, _ in targets if hasattr(m, n)]
    for m, n, part in targets:
        if hasattr(m, n):
            setattr(m, n, _timed(part, getattr(m, n)))
    try:
        yield
    finally:
        for m, n, fn in saved:
            setattr(m, n, fn)


def _exclusive(table: dict[str, float]) -> dict[str, float]:
    """The parts' seconds with "checks" less the relabelling and "write" less the plots."""
    shown = dict(table)
    shown["checks"] = shown.get("checks", 0.0) - shown.get("relabelling", 0.0)
    shown["write"] = shown.get("write", 0.0) - shown.get("plots", 0.0)
    return shown


def _subject(root: Path, frames: int) -> list[Path]:
    """The four trials' TRC files under ``root``."""
    files = []
    for i, (motion, share, swaps) in enumerate(TRIALS):
        config = SynthConfig(frames=max(20, int(share * frames)), seed=11, motion=motion,
                             swaps=swaps)  # fmt: skip
        folder = root / f"trial{i}_{motion}"
        write_experiment(synthesize(config), folder)
        files.append(folder / "markers.trc")
    return files


def _identify(files: list[Path], out: Path) -> tuple[float, float, int]:
    """One `mocap-mj identify` of ``files`` into ``out``: wall and CPU seconds, exit status."""
    argv = ["identify", "--markers", *map(str, files), "--out", str(out), "--json"]
    t0, c0 = time.perf_counter(), time.process_time()
    with open(os.devnull, "w") as null, redirect_stdout(null):
        status = main(argv)
    return time.perf_counter() - t0, time.process_time() - c0, status


def run(frames: int, runs: int, keep: Path | None) -> int:
    with tempfile.TemporaryDirectory(prefix="identify-time-") as tmp:
        root = keep or Path(tmp)
        files = _subject(root / "subject", frames)
        _identify(files, root / "warm")  # compile and import before the timed runs
        for k in range(runs):
            SECONDS.clear()
            CPU.clear()
            with _timers():
                wall, cpu, status = _identify(files, root / f"run{k}")
            if status != 0:
                print(f"identify exited {status}", file=sys.stderr)
                return status
            swapped = sum(1 for t in TRIALS if t[2])
            static = max(20, int(0.3 * frames))
            print(f"run {k + 1}: {len(files)} trials ({swapped} with a label swap), {frames} "
                  f"frames each, the static {static}; wall s, CPU s")  # fmt: skip
            for name, total, table in (("wall", wall, SECONDS), ("CPU", cpu, CPU)):
                shown = _exclusive(table)
                shown["other"] = total - sum(shown.values())
                fit = shown.get("fit", 0.0)
                print(f"  {name:<5}" + "".join(f" {p} {shown.get(p, 0.0):.2f}" for p in
                                               (*PARTS, "other")))  # fmt: skip
                print(f"  {name:<5} whole {total:.2f} s = {total / fit:.2f} x the fit "
                      "(rule: within 2 x)")  # fmt: skip
            print(f"  load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=300, help="frames of each moving trial")
    p.add_argument("--runs", type=int, default=1, help="timed runs after the warm-up")
    p.add_argument("--keep", type=Path, help="write the trials and results here")
    a = p.parse_args()
    raise SystemExit(run(a.frames, a.runs, a.keep))
