"""Benchmark: reading an hour's Vicon Nexus or OptiTrack Motive CSV, in chunks and whole.

    python benchmarks/read_text.py --cache /tmp/lead/long151 --work /tmp/wt18l/read
    python benchmarks/read_text.py --cache /tmp/lead/long151 --work /tmp/wt18l/read --frames 60000

Uses the synthetic recording of ``benchmarks/long.py`` (its cache, read as memory maps) and
writes it once, untimed, as a Vicon Nexus CSV export (a Trajectories block, mm, frames from 1)
and an OptiTrack Motive CSV export (Y up, millimetres), 6 decimals, chunk by chunk
(:func:`write_nexus`, :func:`write_motive`). Then, for each file, in a child process timed by
``/usr/bin/time`` (wall time, peak RSS):

* **in chunks**: what ``mocap-mj identify`` does with a long file
  (:func:`mocap_mj.commands._markers.load_trial` with a scratch folder: ``open_markers`` and
  the model's markers written chunk by chunk into a memory-mapped ``.npy``);
* **whole**: ``load_markers`` and ``select`` (every frame's markers in memory), and whether
  its positions equal the chunked ``.npy`` bit for bit.

Prints one line per run and a JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.io import rotation_to_z_up
from mocap_mj.kernels._fixed_text import csv_rows

#: Frames formatted at a time by the writers.
CHUNK = 20_000

CHILD = """
import argparse, json, sys, time
from pathlib import Path
import numpy as np
from mocap_mj import ParameterSet
from mocap_mj.commands._markers import load_trial
from mocap_mj.io import load_markers
path, mode, npy = sys.argv[1:4]
names = ParameterSet().marker_names
t = time.perf_counter()
if mode == "chunks":
    args = argparse.Namespace(subject=None, marker_map=None, up=None, units=None)
    trial = load_trial(path, names, args, scratch=Path(npy).parent)
    Path(trial.markers.filename).replace(npy)
    how, equal = type(trial.markers).__name__, None
else:
    traj = load_markers(path)
    markers = traj.select(names)
    how = "whole"
    equal = bool(np.array_equal(markers, np.load(npy, mmap_mode="r"), equal_nan=True))
print(json.dumps({"seconds": time.perf_counter() - t, "how": how, "equal": equal}))
"""


def write_nexus(path: Path, markers: np.ndarray, names: Sequence[str], rate: float) -> None:
    """markers (T, M, 3) [m], Z up, as a Vicon Nexus CSV export's Trajectories block in mm
    (frames from 1, 6 decimals, missing samples empty)."""
    m = len(names)
    head = [
        "Trajectories",
        f"{rate:g}",
        ",," + ",".join(f"Subject:{n},," for n in names),
        "Frame,Sub Frame," + ",".join("X,Y,Z" for _ in names),
        ",," + ",".join("mm,mm,mm" for _ in names),
    ]
    formats = ["%d", "%d"] + ["%.6f"] * (3 * m)
    with open(path, "wb") as out:
        out.write(("\n".join(head) + "\n").encode())
        for s in range(0, len(markers), CHUNK):
            block = np.asarray(markers[s : s + CHUNK], dtype=float).reshape(-1, 3 * m) * 1e3
            frames = np.arange(s + 1, s + 1 + len(block))
            ints = np.stack([frames, np.zeros_like(frames)], axis=1)
            out.write(csv_rows(ints, block, [6] * (3 * m), formats))


def write_motive(path: Path, markers: np.ndarray, names: Sequence[str], rate: float) -> None:
    """markers (T, M, 3) [m], Z up, as an OptiTrack Motive CSV export (format 1.23, Y up,
    millimetres, times with 6 decimals, missing samples empty)."""
    m = len(names)
    to_file = rotation_to_z_up("y")  # file = z_up @ R, as the reader applies file @ R.T
    head = [
        f"Format Version,1.23,Take Name,hour,Capture Frame Rate,{rate:f},"
        f"Export Frame Rate,{rate:f},Rotation Type,Quaternion,Length Units,Millimeters,"
        "Coordinate Space,Global",
        "",
        ",Type," + ",".join(["Marker"] * 3 * m),
        ",Name," + ",".join(f"Skeleton:{n}" for n in names for _ in "xyz"),
        ",ID," + ",".join(str(k + 1) for k in range(m) for _ in "xyz"),
        ",," + ",".join(["Position"] * 3 * m),
        "Frame,Time (Seconds)," + ",".join("X,Y,Z" for _ in names),
    ]
    formats = ["%d"] + ["%.6f"] * (1 + 3 * m)
    with open(path, "wb") as out:
        out.write(("\n".join(head) + "\n").encode())
        for s in range(0, len(markers), CHUNK):
            block = np.asarray(markers[s : s + CHUNK], dtype=float) @ to_file * 1e3
            frames = np.arange(s, s + len(block))
            floats = np.concatenate([(frames / rate)[:, None], block.reshape(len(block), -1)], 1)
            out.write(csv_rows(frames, floats, [6] * (1 + 3 * m), formats))


def run(path: Path, mode: str, npy: Path) -> dict[str, object]:
    """One timed child process: ``mode`` "chunks" or "whole" on the file ``path``."""
    timer = ["/usr/bin/time", "-f", "peak_kib %M cpu %U %S"]
    t0 = time.perf_counter()
    proc = subprocess.run(
        [*timer, sys.executable, "-c", CHILD, str(path), mode, str(npy)],
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"{mode} read of {path} failed: {proc.stderr.strip()[-2000:]}")
    timed = [ln.split() for ln in proc.stderr.splitlines() if ln.startswith("peak_kib ")][-1]
    inner = json.loads(proc.stdout.strip().splitlines()[-1])
    return {
        "file": path.name,
        "mode": mode,
        "wall_seconds": wall,
        "read_seconds": inner["seconds"],
        "cpu_seconds": float(timed[3]) + float(timed[4]),
        "peak_rss_gib": int(timed[1]) / 2**20,
        "equal_to_chunks": inner["equal"],
        "load_average": os.getloadavg(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=360_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default="/tmp/mocap-mj-long", help="benchmarks/long.py's cache")
    ap.add_argument("--work", default="/tmp/mocap-mj-read-text", help="the files written")
    ap.add_argument("--formats", nargs="+", default=["nexus", "motive"])
    ap.add_argument("--no-whole", action="store_true", help="time the chunked read only")
    args = ap.parse_args()
    cache = Path(args.cache) / f"360000-{args.seed}"
    markers = np.load(cache / "markers.npy", mmap_mode="r")[: args.frames]
    times = np.load(cache / "times.npy")
    rate = float(1.0 / (times[1] - times[0]))
    names = ParameterSet().marker_names
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    writers = {"nexus": write_nexus, "motive": write_motive}
    results = []
    for fmt in args.formats:
        path = work / f"hour-{args.frames}-{args.seed}.{fmt}.csv"
        if not path.exists():
            t = time.perf_counter()
            part = path.with_suffix(".part")
            writers[fmt](part, markers, names, rate)
            part.replace(path)
            mb = path.stat().st_size / 2**20
            print(f"wrote {path} ({mb:.0f} MB) in {time.perf_counter() - t:.0f} s", flush=True)
        npy = work / f"{path.stem}.npy"
        for mode in ["chunks"] + ([] if args.no_whole else ["whole"]):
            r = run(path, mode, npy)
            results.append(r)
            print(
                f"{fmt} {mode}: {r['wall_seconds']:.1f} s wall ({r['read_seconds']:.1f} s "
                f"reading, {r['cpu_seconds']:.1f} s CPU), peak RSS {r['peak_rss_gib']:.2f} GiB"
                + ("" if r["equal_to_chunks"] is None else f", equal: {r['equal_to_chunks']}"),
                flush=True,
            )
    print(json.dumps(results))


if __name__ == "__main__":
    main()
