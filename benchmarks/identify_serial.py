"""The serial parts of a 500-frame identification alone, and the calling thread per run.

Minima of --repeats calls (the calling thread's CPU, `time.thread_time`, so that another
user's load on the shared machine inflates it least): the step of each iteration of seed 0
(`lm.bounded_step` on the reduced systems that seed 0's solve formed), a change of theta
with the compiled tree (`Kinematics.set_theta` + `tree`), the pose finish without its IK
iterations (`lm.finish_poses`, 0 iterations: integrate and project) and with one, the
prior (`IdentificationProblem.prior`) and a nested `single_blas_thread` call. With --runs R: the
calling thread's CPU of whole identifications of seeds 0-9, the minimum of R per seed,
summed over the seeds (iterations printed, to compare two versions' answers). It calls
only long-standing functions, so the same script times a `git archive` of an older version
(``PYTHONPATH=ARCHIVE python benchmarks/identify_serial.py``) to compare two versions.

Run: python benchmarks/identify_serial.py [--repeats 30] [--runs 3]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import mocap_mj
from mocap_mj import Kinematics, ParameterSet
from mocap_mj.kernels._threads import one_blas_thread, single_blas_thread
from mocap_mj.solve import lm as lm_module
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, identify_lm
from mocap_mj.solve.problem import ProblemOptions, TrialData, build_problem
from mocap_synth import SynthConfig, synthesize


def _best(fn: Callable[[], Any], repeats: int) -> float:
    """Minimum calling-thread CPU [s] of ``repeats`` calls of fn()."""
    times = []
    for _ in range(repeats):
        t0 = time.thread_time()
        fn()
        times.append(time.thread_time() - t0)
    return min(times)


def _trial(seed: int, pset: ParameterSet) -> TrialData:
    exp = synthesize(SynthConfig(frames=500, seed=seed), pset)
    return TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))


def parts(repeats: int) -> None:
    pset = ParameterSet()
    trial = _trial(0, pset)
    systems: list[tuple[np.ndarray, ...]] = []
    solve = lm_module.informed_solve

    def keep(s: np.ndarray, s_damped: np.ndarray, rhs: np.ndarray, floor: float) -> np.ndarray:
        systems.append((s.copy(), s_damped.copy(), rhs.copy(), np.array(floor)))
        return solve(s, s_damped, rhs, floor)

    lm_module.informed_solve = keep  # type: ignore[assignment]
    identify_lm([trial], pset=pset)
    lm_module.informed_solve = solve  # type: ignore[assignment]
    pf = systems[0][0].shape[0]
    inf = np.full(pf, np.inf)
    with one_blas_thread():
        step = sum(
            _best(
                lambda s=s: lm_module.bounded_step(  # type: ignore[misc]
                    s[0], s[2], s[1], np.zeros(pf), -inf, inf, float(s[3])
                ),
                repeats,
            )
            for s in systems
        )
    print(f"the {len(systems)} steps of seed 0 (bounded_step): {step * 1e3:.2f} ms")
    kin = Kinematics(pset)
    theta = pset.nominal.copy()
    kin.set_theta(theta)
    kin.tree()

    def retheta() -> None:
        kin.set_theta(theta)
        kin.tree()

    print(f"set_theta + tree(): {_best(retheta, repeats) * 1e3:.3f} ms")
    qpos = IKSolver(kin).solve_trial(trial.markers).qpos
    free = np.flatnonzero(~pset.frozen)
    problem = build_problem(
        kin, [trial], [qpos], [np.ones(len(qpos), dtype=bool)], free,
        ProblemOptions(priors=[LMSettings().weak_prior(theta)]),
    )  # fmt: skip
    dq = np.random.default_rng(0).normal(0.0, 1e-3, (problem.n, kin.nv))
    w = problem.present.astype(float)
    finish = _best(lambda: lm_module.finish_poses(problem, theta, dq, w, 0), repeats)
    print(f"finish_poses, 0 iterations (integrate, project): {finish * 1e3:.3f} ms")
    finish = _best(lambda: lm_module.finish_poses(problem, theta, dq, w, 1), repeats)
    print(f"finish_poses, 1 iteration (both threads): {finish * 1e3:.3f} ms")
    with one_blas_thread():  # as inside identify_lm
        prior = _best(lambda: problem.prior(theta), repeats)
    print(f"problem.prior: {prior * 1e3:.3f} ms")

    @single_blas_thread
    def inner() -> None:
        pass

    @single_blas_thread
    def outer() -> float:
        return _best(inner, 100)

    print(f"nested single_blas_thread call: {min(outer() for _ in range(10)) * 1e6:.1f} us")


def runs(repeats: int) -> None:
    pset = ParameterSet()
    trials = [_trial(s, pset) for s in range(10)]
    identify_lm([trials[0]], pset=pset)  # kernels loaded
    mains, iterations = [], []
    for trial in trials:
        times = []
        for _ in range(repeats):
            t0 = time.thread_time()
            result = identify_lm([trial], pset=pset)
            times.append(time.thread_time() - t0)
        mains.append(min(times))
        iterations.append(result.iterations)
    print("calling thread per seed [s]:", " ".join(f"{m:.3f}" for m in mains))
    print(f"sum over seeds 0-9: {sum(mains):.3f} s; iterations {iterations}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30, help="calls per part (minimum)")
    parser.add_argument("--runs", type=int, metavar="R", help="whole runs instead (minimum of R)")
    args = parser.parse_args()
    print(mocap_mj.__file__)
    if args.runs:
        runs(args.runs)
    else:
        parts(args.repeats)


if __name__ == "__main__":
    main()
