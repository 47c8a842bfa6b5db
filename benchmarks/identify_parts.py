"""Where a 500-frame identification goes: CPU and wall time per part of `identify_lm`.

Timers are wrapped around the solver's parts (the joint LM, the Schur blocks, the pose
finish, the step, the back substitution, the IK entry points, the refits, the final reduced
information, residuals and prior) and the synthetic ROM trials of seeds --seeds are solved
once each after the kernels loaded. CPU is `time.process_time` (both cores' threads), so it
is the figure to compare on a shared machine; "main" is the calling thread's CPU
(`time.thread_time`): its own share of the parallel kernels plus everything serial, the floor
of the wall time when the other core is free. Parts nest (the Schur blocks are inside
`build_system`, which is inside the joint LM). Used for docs/validation.md#speed.

Run: python benchmarks/identify_parts.py [--seeds 0 6] [--kernels 30]
"""

from __future__ import annotations

import argparse
import collections
import functools
import time
from typing import Any

import numba
import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.kernels import _schur
from mocap_mj.kernels._threads import one_blas_thread
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.solve import ik as ik_module
from mocap_mj.solve import lm as lm_module
from mocap_mj.solve import problem as problem_module
from mocap_mj.solve.coarse import coarse_rows
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, Tolerances, identify_lm
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize

CPU: dict[str, float] = collections.defaultdict(float)
MAIN: dict[str, float] = collections.defaultdict(float)
WALL: dict[str, float] = collections.defaultdict(float)
CALLS: collections.Counter[str] = collections.Counter()


def timed(owner: Any, name: str, label: str) -> None:
    """Replace ``owner.name`` by a wrapper adding its CPU and wall time under ``label``."""
    fn = getattr(owner, name)

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        c0, m0, w0 = time.process_time(), time.thread_time(), time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            CPU[label] += time.process_time() - c0
            MAIN[label] += time.thread_time() - m0
            WALL[label] += time.perf_counter() - w0
            CALLS[label] += 1

    setattr(owner, name, wrapper)


def _best(fn: Any, repeats: int) -> tuple[float, float, float]:
    """Minimum wall, process CPU and calling-thread CPU [s] of ``repeats`` calls of fn()."""
    wall, cpu, main = [], [], []
    for _ in range(repeats):
        w0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
        fn()
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
        main.append(time.thread_time() - m0)
    return min(wall), min(cpu), min(main)


def kernels(repeats: int) -> None:
    """Two parts alone, minimum of ``repeats`` calls (robust to a shared machine's load): one
    Schur pass over 500 frames on one thread (seed 0, poses of a cold IK under the nominal
    model) and the cold IK of the coarse phase's 100-frame subset (both threads)."""
    pset = ParameterSet()
    exp = synthesize(SynthConfig(frames=500, seed=0), pset)
    markers = np.asarray(exp.markers)
    kin = Kinematics(pset)
    solver = IKSolver(kin)
    qpos = solver.solve_trial(markers).qpos
    tr, kt = kin.tree(), kin.kappa_tables()
    present = np.all(np.isfinite(markers), axis=2)
    target, w = np.nan_to_num(markers), present.astype(float)
    free = np.flatnonzero(~pset.frozen)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    with one_blas_thread():
        wall, _, _ = _best(
            lambda: _schur.frame_blocks(tr, kt, target, w, qpos, free, 1e-6), repeats
        )
    numba.set_num_threads(threads)
    print(f"Schur pass, 500 frames, one thread: {wall * 1e3:.2f} ms (minimum of {repeats})")
    trials = [TrialData("rom", markers, np.asarray(exp.times))]
    rows = coarse_rows(trials, pset, Tolerances().coarse_frames)
    assert rows is not None
    subset = markers[rows[0]]
    wall, cpu, main = _best(lambda: solver.solve_trial(subset), repeats)
    print(
        f"cold IK of the {len(subset)}-frame subset, {threads} threads: wall {wall * 1e3:.1f} ms, "
        f"CPU {cpu * 1e3:.1f} ms, calling thread {main * 1e3:.1f} ms (minima of {repeats})"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 6), help="first, last + 1")
    parser.add_argument(
        "--kernels", type=int, metavar="N", help="only time two parts alone (minimum of N calls)"
    )
    args = parser.parse_args()
    if args.kernels:
        kernels(args.kernels)
        return
    problem = problem_module.IdentificationProblem
    for owner, name, label in (
        (lm_module, "solve_lm", "joint LM (both phases)"),
        (lm_module, "build_system", "reduced system (Schur blocks + sums)"),
        (_schur, "frame_blocks", "Schur blocks (kernel + Gram product)"),
        (lm_module, "finish_poses", "pose finish after each step"),
        (lm_module, "bounded_step", "step (eigen-decomposition, active set)"),
        (_schur, "back_substitute", "back substitution"),
        (lm_module, "initial_ik", "cold IK (chains, arm starts)"),
        (ik_module.IKSolver, "solve_from_heads", "IK of every frame from the subset's poses"),
        (lm_module, "refit_frames", "refits"),
        (problem, "information", "final reduced information"),
        (problem, "residuals", "residuals"),
        (problem, "prior", "prior gradient and Hessian"),
    ):
        if hasattr(owner, name):
            timed(owner, name, label)
    pset = ParameterSet()

    def trial(seed: int) -> TrialData:
        exp = synthesize(SynthConfig(frames=500, seed=seed), pset)
        return TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))

    first = trial(0)
    warm = TrialData("warm-up", first.markers[:100], first.times[:100])
    identify_lm([warm], pset=pset, settings=LMSettings(max_iterations=1))
    identify_lm([first], pset=pset)
    CPU.clear()
    MAIN.clear()
    WALL.clear()
    CALLS.clear()
    trials = [trial(s) for s in range(*args.seeds)]
    c0, m0, w0, iterations = time.process_time(), time.thread_time(), time.perf_counter(), 0
    for d in trials:
        iterations += identify_lm([d], pset=pset).iterations
    n = len(trials)
    print(
        f"seeds {args.seeds[0]}-{args.seeds[1] - 1}, per run: CPU "
        f"{(time.process_time() - c0) / n * 1e3:.0f} ms, main thread "
        f"{(time.thread_time() - m0) / n * 1e3:.0f} ms, wall "
        f"{(time.perf_counter() - w0) / n * 1e3:.0f} ms, {iterations / n:.1f} iterations"
    )
    for label in sorted(CPU, key=lambda k: -CPU[k]):
        print(
            f"  {label:44s} CPU {CPU[label] / n * 1e3:6.1f} ms  main "
            f"{MAIN[label] / n * 1e3:6.1f} ms  wall "
            f"{WALL[label] / n * 1e3:6.1f} ms  calls {CALLS[label] / n:.1f}"
        )


if __name__ == "__main__":
    main()
