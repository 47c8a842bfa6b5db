"""A lower-body marker set on synthetic data: the legs at the Cramer-Rao bound of that problem,
the rest held at the prior (docs/recordings.md#partial-marker-sets).

For each seed: the demo's experiment (range of motion, 1 mm noise, segment lengths +-10 %,
offsets +-20 mm) with only the 16 Plug-in Gait lower-body markers kept (the others NaN in
every frame), identified with :func:`mocap_mj.identify` as ``mocap-mj demo`` does (anatomical
priors and ranges on). Prints the noise estimate against the simulated noise, the error of the
measured kinematic parameters (projected on the observable directions, as ``mocap_mj.outputs.score``
does) against their Cramer-Rao bound from that fit's reduced information, the same for the
measured marker offsets, and the largest distance of a frozen parameter from its prior mean
(the initial model: 0 when frozen).

Run: python benchmarks/partial_synth.py [--seeds 0 4] [--frames 500]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.outputs.write_fit import write_result
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize

LOWER = "LASI RASI LPSI RPSI LTHI LKNE LTIB LANK LHEE LTOE RTHI RKNE RTIB RANK RHEE RTOE".split()


def lower_body_trial(markers: np.ndarray, times: np.ndarray, pset: ParameterSet) -> TrialData:
    """The trial with every marker outside :data:`LOWER` missing; markers (T, M, 3) [m]."""
    kept = np.array([n in LOWER for n in pset.marker_names])
    m = np.array(markers, dtype=float)
    m[:, ~kept] = np.nan
    return TrialData("lower", m, np.asarray(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 4), metavar=("FIRST", "END"))
    parser.add_argument("--frames", type=int, default=500)
    args = parser.parse_args()
    base = ParameterSet()
    ratios = []
    for seed in range(*args.seeds):
        exp = synthesize(SynthConfig(frames=args.frames, seed=seed), base)
        trial = lower_body_trial(exp.markers, exp.times, base)
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            recipe = Recipe(init="nominal", sliding_landmarks=False, select="all")
            fit = identify([trial], recipe, pset=base)
            summary = write_result(fit, Path(tmp) / "result")
            result, idf = fit.result, fit.identifiability
            seconds = time.perf_counter() - t0
        free = result.free
        k = base.n_kappa
        err = result.theta - np.asarray(exp.theta_true)
        e_obs, _ = idf.project(np.where(free, err, 0.0))
        var = np.diag(idf.crlb)
        fk, fo = np.flatnonzero(free[:k]), k + np.flatnonzero(free[k:])
        rk = float(np.sqrt(np.mean(e_obs[fk] ** 2) / np.mean(var[fk])))
        ro = float(np.sqrt(np.mean(e_obs[fo] ** 2) / np.mean(var[fo])))
        held = float(np.max(np.abs(result.theta[~free] - result.theta0[~free])))
        ratios.append((rk, ro))
        print(
            f"seed {seed}: {summary['parameters_measured']} of {base.size} measured, fit "
            f"{summary['marker_rmse_mm']:.3f} mm, sigma {summary['sigma_mm']:.3f} mm "
            f"(simulated 1.000), {summary['iterations']} it, {seconds:.1f} s; measured kappa "
            f"{rk:.2f}x the bound ({np.sqrt(np.mean(var[fk])) * 1e3:.3f} mm RMS), offsets "
            f"{ro:.2f}x ({np.sqrt(np.mean(var[fo])) * 1e3:.3f} mm); frozen parameters at most "
            f"{held * 1e3:.3g} mm from the prior mean",
            flush=True,
        )
    rms = np.sqrt(np.mean(np.square(ratios), axis=0))
    print(f"RMS over {len(ratios)} seeds: kappa {rms[0]:.2f}x, offsets {rms[1]:.2f}x the bound")


if __name__ == "__main__":
    main()
