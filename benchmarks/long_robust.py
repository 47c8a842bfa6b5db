"""Benchmark: a robust loss on selected frames (the recipe's ``select``), against the robust
fit of every frame.

    python benchmarks/long_robust.py --frames 30000 --select 1000 --work /tmp/w/robust

Synthesizes (``mocap-mj synth``, once) a ROM of ``--frames`` frames with 1 mm noise and
``--outliers`` of the samples displaced ``--outlier-mm`` (default 3 %, 50 mm), then times, in
child processes (wall and CPU, ``/usr/bin/time``),

    mocap-mj identify --markers markers.trc --recipe select-N.yaml --loss cauchy   (the subset)
    mocap-mj identify --markers markers.trc --recipe select-all.yaml --loss cauchy (every frame)
    mocap-mj identify --markers markers.trc --recipe select-N.yaml --loss l2       (no robust)

(each recipe holds ``select: N`` or ``select: all``)

and scores each model against the truth in the observable directions (standard deviation at
most 5 mm) of the Cramer-Rao bound of every frame (the information of every
``--info-stride``-th frame at the true poses and model, x the stride, sigma 1 mm; the
outliers' samples counted as ordinary ones, so the bound is a little optimistic), the truth
aligned on its clean markers as ``benchmarks/long.py`` does. Also the motion's marker RMSE
over the samples that are not outliers. Prints one line per run and a JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.problem import IdentificationProblem

sys.path.insert(0, str(Path(__file__).parent))
from long import observable_error, rms


def cli(*args: str) -> tuple[float, float, dict[str, object]]:
    """``mocap-mj ARGS --json`` in a child: wall [s], CPU [s] and its JSON output."""
    cmd = ["/usr/bin/time", "-f", "cpu %U %S", sys.executable, "-m", "mocap_mj", *args, "--json"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"{' '.join(args)} failed: {proc.stderr.strip()[-2000:]}")
    cpu = [ln.split() for ln in proc.stderr.splitlines() if ln.startswith("cpu ")][-1]
    return wall, float(cpu[1]) + float(cpu[2]), json.loads(proc.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=30_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--outliers", type=float, default=0.03)
    ap.add_argument("--outlier-mm", type=float, default=50.0)
    ap.add_argument("--select", default="1000")
    ap.add_argument("--info-stride", type=int, default=10)
    ap.add_argument("--work", default="/tmp/mocap-mj-long-robust")
    ap.add_argument("--runs", nargs="+", default=["all-cauchy", "select-cauchy", "select-l2"])
    ap.add_argument(
        "--reuse", action="store_true", help="score existing result folders, not run again"
    )
    ap.add_argument("identify_args", nargs="*", help="more identify options (after --)")
    args = ap.parse_args()
    work = Path(args.work)
    truth = work / f"rom-{args.frames}-{args.seed}-{args.outliers:g}-{args.outlier_mm:g}"
    if not (truth / "truth.json").exists():
        cli("synth", "--out", str(truth), "--frame-count", str(args.frames), "--movement", "rom",
            "--seed", str(args.seed), "--outliers", str(args.outliers),
            "--outlier-mm", str(args.outlier_mm), "--force")  # fmt: skip
    pset = ParameterSet()
    theta_true = np.array(json.loads((truth / "truth.json").read_text())["theta"])
    tm = load_motion(truth / "truth_motion.npz", pset.model)
    clean, qpos_true, times = tm.markers, tm.qpos, tm.times
    from mocap_mj.io import load_markers

    markers = load_markers(truth / "markers.trc").select(pset.marker_names)
    inlier = np.linalg.norm(markers - clean, axis=2) < 0.5 * args.outlier_mm * 1e-3
    kin = Kinematics(pset)
    kin.set_theta(theta_true)
    rows = np.arange(0, args.frames, args.info_stride)
    prob = IdentificationProblem(
        kin, clean[rows], qpos_true[rows].copy(), np.flatnonzero(~pset.frozen)
    )
    info = prob.information(prob.present.astype(float)) * args.info_stride
    idf = Identifiability(pset, info, 1e-3, observable_std=0.005, theta=theta_true)
    bk, bo = idf.bound_rms()
    results = []
    reference = None  # the robust fit of every frame, when it ran first
    for run in args.runs:
        select, loss = run.split("-")
        select = args.select if select == "select" else "all"
        out = work / f"{truth.name}-{run}-{select}{''.join(args.identify_args)}"
        if args.reuse and (out / "summary.json").exists():
            wall, cpu = float("nan"), float("nan")
            summary = json.loads((out / "summary.json").read_text())
        else:
            recipe = work / f"select-{select}.yaml"
            recipe.write_text(f"select: {select}\n")
            wall, cpu, summary = cli("identify", "--markers", str(truth / "markers.trc"),
                                     "--recipe", str(recipe), "--loss", loss, "--out", str(out),
                                     *args.identify_args, "--force")  # fmt: skip
        theta = pset.load_json(out / "theta.json")
        if run == "all-cauchy":
            reference = theta
        apart = float("nan")
        if reference is not None:  # from the robust fit of every frame, observable directions
            pk, po = rms(pset, idf.project(theta - reference)[0])
            apart = float(np.hypot(pk / bk, po / bo) / np.sqrt(2))
        e = observable_error(pset, theta, idf, rows, clean, times)
        ek, eo = rms(pset, e)
        with np.load(out / "motion.npz") as motion:
            kin.set_theta(theta)
            d = np.linalg.norm(kin.site_positions(motion["qpos"]) - markers, axis=2)
        r = {
            "run": run,
            "select": select,
            "loss": loss,
            "wall_seconds": wall,
            "cpu_seconds": cpu,
            "load_average": os.getloadavg(),
            "kappa_error_mm": ek * 1e3,
            "offset_error_mm": eo * 1e3,
            "kappa_bound_mm": bk * 1e3,
            "offset_bound_mm": bo * 1e3,
            "kappa_ratio": ek / bk,
            "offset_ratio": eo / bo,
            "motion_inlier_rmse_mm": float(np.sqrt(np.nanmean(d[inlier] ** 2)) * 1e3),
            "from_all_frames_cauchy_bounds": apart,
            "refine_steps_std": summary.get("refinement", {}).get("steps_std"),  # type: ignore[union-attr]
        }
        results.append(r)
        print(
            f"{run} (--select {select} --loss {loss}): {wall:.1f} s wall, {cpu:.1f} s CPU; "
            f"kinematic {r['kappa_error_mm']:.4f} mm = {r['kappa_ratio']:.2f}x, offsets "
            f"{r['offset_error_mm']:.4f} mm = {r['offset_ratio']:.2f}x the bound of every "
            f"frame; {apart:.2f} bounds (RMS) from every frame's cauchy fit; motion RMSE on "
            f"the inliers {r['motion_inlier_rmse_mm']:.3f} mm",
            flush=True,
        )
    print(json.dumps({"frames": args.frames, "outliers": args.outliers, "runs": results}))


if __name__ == "__main__":
    main()
