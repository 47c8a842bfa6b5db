"""Accuracy of the joint LM over synthetic seeds, per damping schedule (docs/identification.md).

For each seed: the demo's experiment (500-frame range-of-motion trial, 1 mm noise, segment
lengths ±10 %, offsets ±20 mm), identified with `identify_to_folder` and scored against the
truth (`mocap_mj.score`): fit RMSE, iterations, kappa / offset errors over the bound, joint
centres, observable directions.

Run: python benchmarks/seeds.py [--seeds 0 10] [--mu0 1e-6] [--single]
(--single: the given schedule alone, without the default second start; --mu0 1e-2 --single
--third: the second schedule alone.)
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.identify import LMSettings, TrialData
from mocap_mj.identify.pipeline import identify_to_folder
from mocap_mj.score import score
from mocap_synth import SynthConfig, synthesize, write_experiment


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 10), metavar=("FIRST", "END"))
    parser.add_argument("--frames", type=int, default=500)
    parser.add_argument("--mu0", type=float, default=1e-6)
    parser.add_argument("--single", action="store_true", help="no second start")
    parser.add_argument("--third", action="store_true", help="mu / 3 after a success")
    args = parser.parse_args()
    pset = ParameterSet()
    settings = LMSettings(
        mu0=args.mu0,
        second_start=not args.single,
        mu_decrease="third" if args.third else "nielsen",
    )
    for seed in range(*args.seeds):
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            exp = synthesize(SynthConfig(frames=args.frames, seed=seed), pset)
            write_experiment(exp, d / "synth")
            trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
            (d / "result").mkdir()
            t0 = time.perf_counter()
            ident, _, _ = identify_to_folder(
                [trial], d / "result", pset=pset, settings=settings,
                extra={"frames_fitted_range": [[0, args.frames]]},
            )  # fmt: skip
            seconds = time.perf_counter() - t0
            s = score(d / "synth", d / "result", pset=pset, plot=False)
        print(
            f"seed {seed}: fit {ident['marker_rmse_mm']:.4f} mm, {ident['iterations']} it, "
            f"{seconds:.1f} s, kappa {s['kappa_crlb_ratio']:.2f}x, offsets "
            f"{s['offset_crlb_ratio']:.2f}x, joint centres {s['joint_centre_rmse_mm']:.2f} mm, "
            f"observable {s['observable_directions']}",
            flush=True,
        )


if __name__ == "__main__":
    main()
