"""Cross-trial consistency on two real trials of one subject.

Identifies a model from trial A alone and one from trial B alone (``--init placed``, as
``mocap-mj identify``), then reports:

1. each trial's own marker RMSE;
2. each model used for IK on the other trial (as ``mocap-mj ik --model``): RMSE and its ratio
   to that trial's own-model RMSE;
3. every distance between adjacent joint centres (and between the hip centres), from each
   model, with each trial's standard deviation of it (:func:`length_std`), and whether both
   trials excite it.

Run: python benchmarks/cross_trial.py [A.c3d B.c3d] [--loss cauchy] [--prior-mm 50] [--json F]
(defaults: ../shared/data/real/Test_func_rknee.c3d and Test_func_rhip.c3d).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.io import load_markers
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.run_options import Tuning
from mocap_mj.solve.consistency import (
    correlation_time,
    excited_lengths,
    joint_centre_lengths,
    length_std,
)
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, Tolerances
from mocap_mj.solve.problem import TrialData

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


def load(path: Path, pset: ParameterSet) -> TrialData:
    traj = load_markers(str(path))
    return TrialData(path.stem, traj.select(pset.marker_names), np.asarray(traj.times))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "trials",
        nargs="*",
        default=[str(REAL / "Test_func_rknee.c3d"), str(REAL / "Test_func_rhip.c3d")],
    )
    parser.add_argument("--loss", default="l2")
    parser.add_argument("--prior-mm", type=float, default=None)
    parser.add_argument("--mu0", type=float, default=None)
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args()
    paths = [Path(p) for p in args.trials]
    if len(paths) != 2 or not all(p.is_file() for p in paths):
        print(f"need two trial files; got {args.trials}", file=sys.stderr)
        return 2
    pset = ParameterSet()
    trials = [load(p, pset) for p in paths]
    st = LMSettings(
        loss=args.loss,
        prior_sigma=LMSettings.prior_sigma if args.prior_mm is None else args.prior_mm * 1e-3,
        tolerances=Tolerances(**({} if args.mu0 is None else {"mu0": args.mu0})),
    )
    print(f"settings: {st}")
    results = []
    for t in trials:
        t0 = time.perf_counter()
        recipe = Recipe.of_settings(st, sliding_landmarks=False, select="all")
        fit = identify([t], recipe, pset=pset, tuning=Tuning(st.tolerances))
        results.append(res := fit.result)
        print(
            f"{t.name}: own RMSE {res.marker_rmse * 1e3:.3f} mm, {res.iterations} it, "
            f"{time.perf_counter() - t0:.1f} s, {fit.identifiability.rank} obs"
        )
    out: dict[str, Any] = {"settings": repr(st), "own_rmse_mm": {}, "cross": {}, "lengths": {}}
    for t, r in zip(trials, results, strict=True):
        out["own_rmse_mm"][t.name] = r.marker_rmse * 1e3
    for i, j in ((0, 1), (1, 0)):
        kin = Kinematics(pset)
        kin.set_theta(results[i].theta)
        ik = IKSolver(kin).solve_trial(trials[j].markers)
        rmse = ik.rmse()
        ratio = rmse / results[j].marker_rmse
        key = f"{trials[i].name} -> {trials[j].name}"
        out["cross"][key] = {"rmse_mm": rmse * 1e3, "ratio": ratio}
        print(f"{key}: {rmse * 1e3:.3f} mm ({ratio:.2f}x)")
    lengths = [joint_centre_lengths(pset, r.theta) for r in results]
    # Excitation: the white-noise standard deviation (the fit's CRLB, default prior), as the
    # observable directions of identifiability.json; beside it the same with the residuals'
    # correlation time (honest about real data) and the fit's own prior.
    white = [length_std(pset, r) for r in results]
    taus = [correlation_time(pset, r, [t]) for r, t in zip(results, trials, strict=True)]
    honest = [
        length_std(pset, r, tau=tau, settings=st) for r, tau in zip(results, taus, strict=True)
    ]
    both = excited_lengths(white)
    out["tau_frames"] = taus
    print(f"residual correlation time: {taus[0]:.1f} / {taus[1]:.1f} frames")
    print(
        f"{'length':<22} {'A':>7} {'B':>7} {'diff':>6} {'sdA':>6} {'sdB':>6} "
        f"{'sdA(tau)':>8} {'sdB(tau)':>8}  both"
    )
    for name in lengths[0]:
        a, b = lengths[0][name], lengths[1][name]
        out["lengths"][name] = {
            "a_mm": a * 1e3, "b_mm": b * 1e3, "diff_mm": abs(a - b) * 1e3,
            "sd_white_mm": [s[name] * 1e3 for s in white],
            "sd_tau_mm": [s[name] * 1e3 for s in honest], "both": name in both,
        }  # fmt: skip
        print(
            f"{name:<22} {a * 1e3:7.1f} {b * 1e3:7.1f} {abs(a - b) * 1e3:6.1f} "
            f"{white[0][name] * 1e3:6.2f} {white[1][name] * 1e3:6.2f} "
            f"{honest[0][name] * 1e3:8.2f} {honest[1][name] * 1e3:8.2f}  "
            f"{'yes' if name in both else ''}"
        )
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
