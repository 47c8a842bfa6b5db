"""Identification speed: the joint LM against the paper's Algorithm 1, and scaling with T.

In one process on the synthetic ROM trial (`mocap_synth`, seed 0, 1 mm noise, segment lengths
±10 %, offsets ±20 mm):

1. the joint LM on 500 frames, all parameters: time to convergence, error vs its bound
   (seed 0), and the time on seeds 1 to 9 (after the kernels loaded, which is timed apart);
   with --baseline, each seed is also solved without the coarse phase (`coarse_frames=0`),
   back to back in the same process: times (and the median process CPU time, the figure to
   compare under load), iterations, errors against the bound, and the
   difference of the final F in sigma^2 (the same minimum: well below 1);
2. Algorithm 1 (this project's faithful implementation, `mocap_synth.paper`) with stochastic
   and batch sampling on the same data, run for a time budget: the time it needs to reach
   the LM's parameter error (or how far it got), and the speed ratio;
3. the LM at 500, 5,000 (and, with --large, 50,000; or --sizes) frames: seconds and peak
   traced memory (coarse+fine iterations; with --baseline also without the coarse phase).

The parameter error is the RMS, over the observable directions of theta, of the difference
to the truth aligned with the LM's estimate along the unobservable ones (`mocap_mj.outputs.score`).

Run: python benchmarks/identify.py [--budget 120] [--large] [--seeds 10] [--baseline]
     [--repeats 3] [--only-500] [--sizes 50000 --skip-to-sizes]
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
from typing import Any

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.outputs.score import align_truth
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMSettings, Tolerances, identify_lm
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.solver_result import IterationLog
from mocap_synth import SynthConfig, synthesize


def trial(frames: int, seed: int = 0) -> tuple[Any, TrialData]:
    exp = synthesize(SynthConfig(frames=frames, seed=seed), ParameterSet())
    return exp, TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=float, default=120.0, help="seconds per paper run")
    parser.add_argument("--large", action="store_true", help="also 50,000 frames")
    parser.add_argument("--seeds", type=int, default=10, help="500-frame trials timed (seeds)")
    parser.add_argument(
        "--baseline", action="store_true", help="also solve every seed without the coarse phase"
    )
    parser.add_argument("--repeats", type=int, default=1, help="timed solves per seed (median)")
    parser.add_argument("--only-500", action="store_true", help="stop after the 500-frame part")
    parser.add_argument("--sizes", type=int, nargs="*", help="frames of part 3 (default 500 5000)")
    parser.add_argument("--skip-to-sizes", action="store_true", help="only part 3")
    args = parser.parse_args()
    pset = ParameterSet()

    exp, data = trial(500)
    # The compiled kernels load (or, in a fresh environment, compile) on first use: once per
    # process, timed apart. 100 frames: batches of 64 frames and more use the kernels'
    # parallel variants, which load separately.
    t0 = time.perf_counter()
    identify_lm(
        [TrialData("warm-up", data.markers[:100], data.times[:100])],
        pset=pset,
        settings=LMSettings(max_iterations=1),
    )
    print(f"0. kernels loaded in {time.perf_counter() - t0:.2f} s (first call in a process)\n")
    if args.skip_to_sizes:
        _scaling(pset, args.sizes or [500, 5000, 50_000], args.baseline)
        return
    t0 = time.perf_counter()
    lm = identify_lm([data], pset=pset)
    t_lm = time.perf_counter() - t0
    idf = Identifiability(pset, lm.reduced_information, lm.sigma, theta=lm.theta)
    aligned = align_truth(pset, lm.theta, np.asarray(exp.markers_clean), data.times)
    basis = idf.basis

    def err(theta: np.ndarray) -> float:
        e = basis @ (basis.T @ (theta - aligned))
        return float(np.sqrt(np.mean(e**2)))

    bound = float(np.sqrt(np.mean(np.diag(idf.crlb))))
    e_lm = err(lm.theta)
    print(f"1. joint LM, 500 frames, {pset.size} parameters")
    print(
        f"   {t_lm:.2f} s ({lm.init_seconds:.2f} s initial IK), {lm.iterations} iterations, "
        f"{lm.termination.value}"
    )
    print(
        f"   observable theta error {e_lm * 1e3:.3f} mm RMS, CRLB {bound * 1e3:.3f} mm "
        f"(ratio {e_lm / bound:.2f}); marker RMSE {lm.marker_rmse * 1e3:.3f} mm"
    )
    for log in lm.trace[:: max(1, len(lm.trace) // 8)]:
        print(f"   iter {log.iteration:3d}  error {err(log.theta) * 1e3:8.3f} mm")
    if args.baseline or args.repeats > 1:
        _compare_seeds(pset, args.seeds, args.repeats, args.baseline)
    else:
        times = []
        for seed in range(1, args.seeds):
            _, d = trial(500, seed=seed)
            t0 = time.perf_counter()
            r = identify_lm([d], pset=pset)
            times.append(time.perf_counter() - t0)
            print(f"   seed {seed}: {times[-1]:.2f} s, {r.iterations} iterations")
        if times:
            times.append(t_lm)
            print(
                f"   seeds 0-{args.seeds - 1}: median {np.median(times):.2f} s, "
                f"{sum(t <= 1.0 for t in times)} of {len(times)} within 1 s"
            )
    if args.only_500:
        return

    print(f"\n2. Algorithm 1 (finite differences through IK), budget {args.budget:.0f} s each")
    try:
        from mocap_synth.paper import PaperSettings, identify_paper
    except ImportError:
        print("   not available")
    else:
        for sampling, iters in (("stochastic", 100_000), ("batch", 100)):
            settings = PaperSettings(sampling=sampling, iterations=iters)
            result = _run_budget(identify_paper, data, pset, settings, args.budget)
            errors = [(it.seconds, err(it.theta)) for it in result.trace]
            reached = next((s for s, e in errors if e <= e_lm * 1.05), None)
            last_s, last_e = errors[-1] if errors else (float("nan"), float("nan"))
            if reached is not None:
                print(
                    f"   {sampling:<10} reached the LM's error (+5 %) after {reached:.1f} s: "
                    f"{reached / t_lm:.0f}x the LM's time"
                )
            else:
                print(
                    f"   {sampling:<10} {len(errors)} iterations in {last_s:.1f} s: error "
                    f"{last_e * 1e3:.2f} mm ({last_e / e_lm:.1f}x the LM's after "
                    f"{last_s / t_lm:.0f}x its time); not reached"
                )

    _scaling(pset, args.sizes or [500, 5000] + ([50_000] if args.large else []), args.baseline)


def _scaling(pset: ParameterSet, sizes: list[int], baseline: bool) -> None:
    """Part 3: the LM at each size (seed 1), with ``baseline`` also without the coarse phase."""
    print("\n3. joint LM: frames vs time (linear?) and peak traced memory")
    paths = {"coarse": LMSettings()}
    if baseline:
        paths["plain"] = LMSettings(tolerances=Tolerances(coarse_frames=0))
    for n in sizes:
        _, d = trial(n, seed=1)
        final = {}
        for name, st in paths.items():
            tracemalloc.start()
            t0 = time.perf_counter()
            r = identify_lm([d], pset=pset, settings=st)
            seconds = time.perf_counter() - t0
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            logs = [log for log in r.trace if isinstance(log, IterationLog)]
            full = [log for log in logs if log.frames == n]
            per_it = np.mean([log.seconds for log in full])
            final[name] = r
            print(
                f"   {n:>7} frames, {name:<6}: {seconds:8.1f} s, {r.iterations - len(full)}+"
                f"{len(full)} iterations, {per_it * 1e3:8.1f} ms/iteration on every frame "
                f"({per_it / n * 1e6:.1f} us/frame), peak {peak / 2**20:6.0f} MiB, "
                f"RMSE {r.marker_rmse * 1e3:.3f} mm"
            )
        if baseline:
            a, b = final["coarse"], final["plain"]
            print(
                f"   {n:>7} frames: F - F_plain "
                f"{(a.trace[-1].cost - b.trace[-1].cost) / b.sigma**2:+.2f} sigma^2, "
                f"max|dtheta| {np.abs(a.theta - b.theta).max() * 1e3:.2f} mm"
            )


def _compare_seeds(pset: ParameterSet, seeds: int, repeats: int, baseline: bool) -> None:
    """Seeds 0..seeds-1 at 500 frames: the median of ``repeats`` timed solves each, with
    (``baseline``) the LM without the coarse phase solved right after on the same data."""
    paths = {"coarse": LMSettings()}
    if baseline:
        paths["plain"] = LMSettings(tolerances=Tolerances(coarse_frames=0))
    times: dict[str, list[float]] = {k: [] for k in paths}
    cpu: dict[str, list[float]] = {k: [] for k in paths}  # process CPU, both cores' threads
    print(f"   seeds 0-{seeds - 1}, median of {repeats} solves; error / bound on observable theta")
    for seed in range(seeds):
        exp, d = trial(500, seed=seed)
        out = {}
        for name, st in paths.items():
            ts, cs = [], []
            for _ in range(repeats):
                t0, c0 = time.perf_counter(), time.process_time()
                r = identify_lm([d], pset=pset, settings=st)
                ts.append(time.perf_counter() - t0)
                cs.append(time.process_time() - c0)
            times[name].append(float(np.median(ts)))
            cpu[name].append(float(np.median(cs)))
            out[name] = r
        line = f"   seed {seed}:"
        for name, r in out.items():
            logs = [log for log in r.trace if isinstance(log, IterationLog)]
            coarse = sum(1 for log in logs if 0 < log.frames < 500)
            line += (
                f"  {name} {times[name][-1]:.3f} s, {coarse}+{r.iterations - coarse} it, "
                f"error {_error_ratio(pset, exp, d, r):.3f}x"
            )
        if baseline:
            a, b = out["coarse"], out["plain"]
            d_cost = (a.trace[-1].cost - b.trace[-1].cost) / b.sigma**2
            d_theta = float(np.abs(a.theta - b.theta).max())
            line += f"  | F - F_plain {d_cost:+.2f} sigma^2, max|dtheta| {d_theta * 1e3:.2f} mm"
        print(line)
    for name, ts in times.items():
        print(
            f"   {name}: median {np.median(ts):.3f} s (range {min(ts):.3f}-{max(ts):.3f} s), "
            f"{sum(t <= 0.3 for t in ts)} of {len(ts)} within 0.3 s; CPU median "
            f"{np.median(cpu[name]):.3f} s"
        )
    if baseline:
        ratio = np.array(times["coarse"]) / np.array(times["plain"])
        print(f"   coarse / plain time: median {np.median(ratio):.2f}")


def _error_ratio(pset: ParameterSet, exp: Any, data: TrialData, r: Any) -> float:
    """RMS error of r.theta over its observable directions against the truth, over the
    RMS Cramer-Rao bound."""
    idf = Identifiability(pset, r.reduced_information, r.sigma, theta=r.theta)
    aligned = align_truth(pset, r.theta, np.asarray(exp.markers_clean), data.times)
    e = idf.basis @ (idf.basis.T @ (r.theta - aligned))
    return float(np.sqrt(np.mean(e**2)) / np.sqrt(np.mean(np.diag(idf.crlb))))


def _run_budget(identify_paper, data, pset, settings, budget):  # type: ignore[no-untyped-def]
    """Algorithm 1 with as many iterations as fit in ``budget`` seconds (from a short probe)."""
    from dataclasses import replace

    probe = identify_paper([data], pset=pset, settings=replace(settings, iterations=3))
    per_iteration = (probe.trace[-1].seconds - probe.trace[0].seconds) / 2
    start = probe.trace[0].seconds
    iterations = int(np.clip((budget - start) / max(per_iteration, 1e-3), 3, settings.iterations))
    return identify_paper([data], pset=pset, settings=replace(settings, iterations=iterations))


if __name__ == "__main__":
    main()
