"""Benchmark: the hour-long recording through the command line, a C3D file in, motion out.

    python benchmarks/long_cli.py --cache /tmp/lead/long      # the cache of benchmarks/long.py
    python benchmarks/long_cli.py --frames 60000 --cache /tmp/w/long

Uses the synthetic recording of ``benchmarks/long.py`` (360,000 frames: a 30-minute ROM then a
30-minute walk, 1 mm noise; synthesized there once, read here as memory maps, never written)
and writes it, once and untimed, as a real C3D file (``--work``/hour.c3d: Intel floats in mm,
the frames past the header's 16-bit count declared in TRIAL:ACTUAL_END_FIELD and
POINT:LONG_FRAMES, :mod:`mocap_mj.io.formats.c3d_write`), or with ``--format trc`` as an
OpenSim TRC file (``save_trc``). Then it times, in a child process,

    mocap-mj identify --markers hour.c3d --out DIR --force --json

with the defaults a user gets (the recipe's ``select: auto``: 1000 pose-diverse frames, the
anatomical priors and ranges, the refinement on every frame, the IK of every frame written chunk by
chunk): wall time, the child's peak RSS (``/usr/bin/time``), and its stages from
summary.json. Untimed, the accuracy: the identified theta (theta.json) against the cached
truth, aligned and restricted to the observable directions as ``benchmarks/long.py`` does
(the hand's and the forearms' zeros free, :func:`mocap_mj.outputs.score.align_gauge_free`), beside
the Cramer-Rao bound of all frames (the information of every ``--info-stride``-th frame at
the written motion's poses, x the stride). Prints the figures and a JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.io import MarkerTrajectory, save_trc
from mocap_mj.io.formats.c3d_write import write_markers_c3d
from mocap_mj.pipeline.motion import load_motion

sys.path.insert(0, str(Path(__file__).parent))
from long import all_frames_bound, observable_error, rms, worst_markers


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=360_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default="/tmp/mocap-mj-long", help="benchmarks/long.py's cache")
    ap.add_argument("--work", default="/tmp/mocap-mj-long-cli", help="hour.c3d and the result")
    ap.add_argument("--info-stride", type=int, default=10)
    ap.add_argument("--select", default="auto", help="identify --select (default: auto)")
    ap.add_argument(
        "--format", choices=["c3d", "trc"], default="c3d", help="the file written (default: c3d)"
    )
    ap.add_argument(
        "--result", default="result", help="the result folder's name in --work (default: result)"
    )
    ap.add_argument("identify_args", nargs="*", help="more identify options (after --)")
    args = ap.parse_args()
    cache = Path(args.cache) / f"{args.frames}-{args.seed}"
    sys.path.insert(0, str(Path(__file__).parent))
    from long import cache_is_current

    if not cache_is_current(cache):
        here = Path(__file__).parent / "long.py"
        cmd = [sys.executable, str(here), "--synth-only", "--frames", str(args.frames)]
        subprocess.run([*cmd, "--seed", str(args.seed), "--cache", args.cache], check=True)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    pset = ParameterSet()
    markers = np.load(cache / "markers.npy", mmap_mode="r")
    times = np.load(cache / "times.npy")
    c3d = work / f"hour-{args.frames}-{args.seed}.{args.format}"
    if not c3d.exists():
        t = time.perf_counter()
        rate = 1.0 / (times[1] - times[0])
        if args.format == "c3d":
            write_markers_c3d(c3d, markers, pset.marker_names, rate)
        else:
            traj = MarkerTrajectory(times, np.asarray(markers), pset.marker_names, rate, {})
            save_trc(c3d, traj)
        mb = c3d.stat().st_size / 2**20
        print(f"wrote {c3d} ({mb:.0f} MB) in {time.perf_counter() - t:.0f} s")

    out = work / args.result
    cmd = [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(c3d), "--out", str(out)]
    # The child's peak RSS from /usr/bin/time: getrusage(RUSAGE_CHILDREN) would also count
    # this process's own resident memory at the spawn (Linux keeps the pre-exec high-water
    # mark), e.g. the text of a TRC file just written.
    timer = (
        ["/usr/bin/time", "-f", "peak_kib %M cpu %U %S"] if Path("/usr/bin/time").exists() else []
    )
    recipe = out.parent / f"{out.name}-recipe.yaml"  # the recipe's select: --select's value
    recipe.write_text(f"select: {args.select}\n")
    t0 = time.perf_counter()
    proc = subprocess.run(
        [*timer, *cmd, "--recipe", str(recipe), *args.identify_args, "--force", "--json"],
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"identify failed ({proc.returncode}): {proc.stderr.strip()[-2000:]}")
    timed = [ln.split() for ln in proc.stderr.splitlines() if ln.startswith("peak_kib ")]
    peak_kib = (
        int(timed[-1][1]) if timed else resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    )
    # CPU seconds (user + system) of the child: less dependent on other processes' load than
    # the wall time (they take cores, not this job's work).
    cpu = float(timed[-1][3]) + float(timed[-1][4]) if timed else float("nan")
    peak = peak_kib / 2**20  # GiB
    summary = json.loads(proc.stdout)

    theta = pset.load_json(out / "theta.json")
    clean = np.load(cache / "clean.npy", mmap_mode="r")
    qpos = load_motion(out / "motion.npz", pset.model).qpos
    fit = SimpleNamespace(theta=theta, free=~pset.frozen, sigma=summary["sigma_mm"] * 1e-3)
    idf_all = all_frames_bound(pset, fit, markers, qpos, args.info_stride)  # type: ignore[arg-type]
    frames = np.array(summary["frames_selected"][0])
    e = observable_error(pset, theta, idf_all, frames, clean, times)
    ek, eo = rms(pset, e)
    bk, bo = idf_all.bound_rms()
    ref = summary.get("refinement", {})
    result = {
        "frames": len(markers),
        "select": args.select,
        "seconds_total": wall,
        "cpu_seconds": cpu,
        "load_average": os.getloadavg(),
        "peak_rss_gib": peak,
        "read_seconds": summary.get("read_seconds"),
        "select_seconds": summary.get("select_seconds"),
        "identify_seconds": summary["seconds"],
        "motion_seconds": summary.get("motion_seconds", {}),
        "identify_iterations": summary["iterations"],
        "refine_seconds": ref.get("seconds", {}),
        "refine_steps_std": ref.get("steps_std", []),
        "motion_marker_rmse_mm": summary["motion_marker_rmse_mm"],
        "kappa_error_mm": ek * 1e3,
        "offset_error_mm": eo * 1e3,
        "kappa_crlb_all_mm": bk * 1e3,
        "offset_crlb_all_mm": bo * 1e3,
        "kappa_error_over_all_bound": ek / bk,
        "offset_error_over_all_bound": eo / bo,
        "worst_offsets_std_mm": worst_markers(pset, idf_all, e),
        "kappa_at_bound": summary.get("kappa_at_bound", {}),
    }
    rs, ms = result["refine_seconds"], result["motion_seconds"]
    print(
        f"{len(markers)} frames through `mocap-mj identify --markers {c3d.name}`: {wall:.1f} s "
        f"end to end, {cpu:.1f} s CPU (load average {os.getloadavg()[0]:.1f} after), (reading "
        f"{result['read_seconds'] or 0.0:.1f} s, selection "
        f"{result['select_seconds'] or 0.0:.1f} s, identification incl. the refinement "
        f"{summary['seconds']:.1f} s / {summary['iterations']} LM iterations: refinement "
        f"sample steps {rs.get('sample', 0.0):.1f} s, pass over every frame "
        f"{rs.get('pass', 0.0):.1f} s; motion {ms.get('all', 0.0):.1f} s: IK "
        f"{ms.get('ik', 0.0):.1f} s, the rest writing; the rest: start-up, checks, report), peak "
        f"RSS {peak:.2f} GiB; motion marker RMSE {result['motion_marker_rmse_mm']:.3f} mm\n"
        f"kinematic error {ek * 1e3:.3f} mm = {ek / bk:.2f}x all frames' bound "
        f"({bk * 1e3:.3f} mm); offsets {eo * 1e3:.3f} mm = {eo / bo:.2f}x ({bo * 1e3:.3f} mm)"
        f"\nrefinement steps (sd): {np.round(result['refine_steps_std'], 3).tolist()}"
    )
    print(json.dumps(result))


if __name__ == "__main__":
    main()
