"""IK throughput on the synthetic ROM trial: this project's LM (both dampings) against mink.

All in one process, on the same data: 500 frames of the synthetic range-of-motion trial
(`mocap_synth`, seed 0), 1 mm noise, the true model (the humanoid with fixed-hinge knees,
which mink can solve: `mocap_mj.skeleton.rolling.without`). The converged marker RMSE is taken from
a tight solve; each method runs until its marker RMSE is within 0.01 mm of it, and frames/s
is frames divided by wall time. mink (a benchmark-only dependency, `pip install .[bench]`)
tracks the 39 sites with position-only FrameTasks, warm-started from the previous frame,
iterating each frame until its RMSE changes by less than 1e-4 mm.

Run: python benchmarks/ik.py [--frames 500] [--repeat 5]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Literal

import numba
import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.mjcf import model_path
from mocap_mj.solve.ik import IKSettings, IKSolver
from mocap_synth import SynthConfig, synthesize


def rmse(kin: Kinematics, qpos: np.ndarray, markers: np.ndarray) -> float:
    d = np.linalg.norm(kin.marker_positions(qpos) - markers, axis=2)
    return float(np.sqrt(np.mean(d**2)))


def run_ours(
    kin: Kinematics, markers: np.ndarray, damping: Literal["adaptive", "sugihara"], repeat: int
) -> tuple[float, float, float]:
    """Best wall time of ``repeat`` whole-trial solves (the kernels are compiled already)."""
    settings = IKSettings(damping=damping, tol_cost=1e-6, tol_step=1e-7)
    solver = IKSolver(kin, settings)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = solver.solve_trial(markers)
        best = min(best, time.perf_counter() - t0)
    return best, result.rmse(), float(result.iterations.mean())


def run_mink(kin: Kinematics, markers: np.ndarray, start: np.ndarray) -> tuple[float, float]:
    import mink
    import mujoco

    model = kin.model
    config = mink.Configuration(model)
    tasks = [
        mink.FrameTask(kin.pset.marker_names[s], "site", position_cost=1.0, orientation_cost=0.0)
        for s in range(kin.n_markers)
    ]
    limits = [mink.ConfigurationLimit(model)]
    qpos = np.empty((len(markers), model.nq))
    config.update(start)
    t0 = time.perf_counter()
    for t, frame in enumerate(markers):
        for task, p in zip(tasks, frame, strict=True):
            task.set_target(mink.SE3.from_translation(p))
        last = np.inf
        for _ in range(50):
            vel = mink.solve_ik(config, tasks, 1.0, solver="daqp", damping=1e-6, limits=limits)
            config.integrate_inplace(vel, 1.0)
            err = np.linalg.norm(
                np.array([config.data.site_xpos[s] for s in range(kin.n_markers)]) - frame, axis=1
            )
            now = float(np.sqrt(np.mean(err**2)))
            if abs(last - now) < 1e-7:
                break
            last = now
        qpos[t] = config.q
    seconds = time.perf_counter() - t0
    del mujoco
    return seconds, rmse(kin, qpos, markers)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=500)
    parser.add_argument("--repeat", type=int, default=5, help="best of this many runs (ours)")
    args = parser.parse_args()
    # mink solves MuJoCo's joints only: every method works on the humanoid with fixed-hinge
    # knees (mocap_mj.skeleton.rolling.without), the truth included.
    with tempfile.TemporaryDirectory() as tmp:
        plain = Path(tmp) / "humanoid.xml"
        plain.write_text(rolling.without(model_path().read_text()))
        pset = ParameterSet(plain)
    exp = synthesize(SynthConfig(frames=args.frames, seed=0), pset)
    kin = Kinematics(pset)
    kin.set_theta(np.asarray(exp.theta_true))
    markers = np.asarray(exp.markers)
    tight = IKSolver(kin, IKSettings(tol_cost=1e-12, tol_step=1e-11, max_iterations=300))
    reference = tight.solve_trial(markers).rmse()
    print(f"{args.frames} frames, converged marker RMSE {reference * 1e3:.4f} mm")
    print(f"compiled kernels on {numba.get_num_threads()} threads (compile time excluded)")
    print(f"{'method':<28}{'frames/s':>10}{'RMSE (mm)':>11}{'within 0.01':>13}{'iters':>7}")
    rows = []
    dampings: tuple[Literal["adaptive", "sugihara"], ...] = ("adaptive", "sugihara")
    for damping in dampings:
        seconds, r, iters = run_ours(kin, markers, damping, args.repeat)
        rows.append((f"mocap-mj LM ({damping})", seconds, r, iters))
    try:
        seconds, r = run_mink(kin, markers, np.asarray(exp.qpos[0]))
        rows.append(("mink (daqp, warm start)", seconds, r, float("nan")))
    except ImportError as exc:
        print(f"mink not installed ({exc}); pip install '.[bench]'")
    for label, seconds, r, iters in rows:
        ok = "yes" if abs(r - reference) < 1e-5 else "no"
        rate = args.frames / seconds
        print(f"{label:<28}{rate:>10,.0f}{r * 1e3:>11.4f}{ok:>13}{iters:>7.1f}")
    ours = rows[0][1]
    for label, seconds, *_ in rows[1:]:
        print(f"speed ratio adaptive / {label}: {seconds / ours:.1f}x")


if __name__ == "__main__":
    main()
