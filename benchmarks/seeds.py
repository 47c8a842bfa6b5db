"""Accuracy of the joint LM over synthetic seeds, per damping schedule (docs/validation.md).

For each seed: the demo's experiment (500-frame range-of-motion trial, 1 mm noise, segment
lengths ±10 %, offsets ±20 mm), identified with `mocap_mj.identify` and scored against the
truth (`mocap_mj.outputs.score`): fit RMSE, iterations, kappa / offset errors over the bound, joint
centres, observable directions.

With the anatomical priors on (the default, as in ``mocap-mj demo``) the bound is printed
twice: from the data alone (the score's, ``CRLB``) and with the priors' information added
(``CRLB+prior``, :meth:`Identifiability.bound_rms_with_prior`).

Run: python benchmarks/seeds.py [--seeds 0 10] [--set NAME=VALUE ...] [--no-anatomy]
[--asymmetry-prior] [--marker-placement anatomical|uniform]
(--set: other values of `LMSettings` fields, e.g. `--set mu0=1e-6 mu_decrease=nielsen
refine_iterations=2 tol_noise=0.1` for the previous default.)
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj import ParameterSet
from mocap_mj.anatomy.anatomy import ASYMMETRY_SIGMA
from mocap_mj.capture.subject import Subject
from mocap_mj.outputs.score import score
from mocap_mj.outputs.write_fit import write_result
from mocap_mj.pipeline.anatomical import AnatomyPriors, anatomical_priors, prior_information
from mocap_mj.pipeline.api import identify
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.run_options import Tuning
from mocap_mj.solve.lm import LMSettings, Performance, Tolerances
from mocap_mj.solve.problem import TrialData
from mocap_synth import SynthConfig, synthesize, write_experiment
from mocap_synth.config import MARKER_PLACEMENTS


def _fields(settings: Any) -> set[str]:
    return {f.name for f in dataclasses.fields(settings)} - {"tolerances", "performance"}


def _settings(items: list[str], parser: argparse.ArgumentParser) -> LMSettings:
    """``--set NAME=VALUE``: fields of LMSettings, Tolerances or Performance."""
    groups: dict[str, Any] = {"": LMSettings(), "tolerances": Tolerances(),
                              "performance": Performance()}  # fmt: skip
    extra: dict[str, dict[str, Any]] = {g: {} for g in groups}
    for item in items:
        name, _, value = item.partition("=")
        group = next((g for g, v in groups.items() if name in _fields(v)), None)
        if group is None:
            parser.error(f"--set: LMSettings, Tolerances and Performance have no field {name!r}")
        kind = type(getattr(groups[group], name))
        extra[group][name] = value.lower() in ("1", "true", "yes") if kind is bool else kind(value)
    return LMSettings(
        **extra[""],
        tolerances=Tolerances(**extra["tolerances"]),
        performance=Performance(**extra["performance"]),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 10), metavar=("FIRST", "END"))
    parser.add_argument("--frames", type=int, default=500)
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="NAME=VALUE", help="other LMSettings fields"
    )
    parser.add_argument("--no-anatomy", action="store_true", help="solve without the priors")
    parser.add_argument(
        "--asymmetry-prior", action="store_true", help="add the population L/R prior (demo: off)"
    )
    parser.add_argument("--marker-placement", choices=MARKER_PLACEMENTS, default="anatomical")
    args = parser.parse_args()
    pset = ParameterSet()
    settings = _settings(args.set, parser)
    ratios: list[tuple[float, ...]] = []
    for seed in range(*args.seeds):
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            cfg = SynthConfig(frames=args.frames, seed=seed, marker_placement=args.marker_placement)
            exp = synthesize(cfg, pset)
            write_experiment(exp, d / "synth")
            trial = TrialData("rom", np.asarray(exp.markers), np.asarray(exp.times))
            (d / "result").mkdir()
            t0 = time.perf_counter()
            recipe = Recipe.of_settings(
                settings, init="nominal", anatomy=not args.no_anatomy,
                asymmetry_prior=args.asymmetry_prior, sliding_landmarks=False, select="all",
            )  # fmt: skip
            tuning = Tuning(settings.tolerances, settings.performance)
            fit = identify([trial], recipe, pset=pset, tuning=tuning)
            ident, idf = write_result(fit, d / "result", force=True), fit.identifiability
            seconds = time.perf_counter() - t0
            s = score(d / "synth", d / "result", pset=pset, plot=False)
        symmetric = ASYMMETRY_SIGMA if args.asymmetry_prior else None
        priors = [] if args.no_anatomy else anatomical_priors(
            pset, AnatomyPriors(Subject(), symmetric=symmetric)
        )  # fmt: skip
        pk, po = idf.bound_rms_with_prior(prior_information(priors, settings, pset.size))
        post = (s["kappa_rmse_mm"] / (pk * 1e3), s["offset_rmse_mm"] / (po * 1e3))
        print(
            f"seed {seed}: fit {ident['marker_rmse_mm']:.4f} mm, {ident['iterations']} it, "
            f"{seconds:.1f} s, kappa {s['kappa_crlb_ratio']:.2f}x, offsets "
            f"{s['offset_crlb_ratio']:.2f}x (CRLB {s['kappa_crlb_mm']:.3f} / "
            f"{s['offset_crlb_mm']:.3f} mm; CRLB+prior {pk * 1e3:.3f} / {po * 1e3:.3f} mm: "
            f"{post[0]:.2f}x / {post[1]:.2f}x), joint centres {s['joint_centre_rmse_mm']:.2f} mm "
            f"(bound {s['joint_centre_crlb_mm']:.2f}, {s['joint_centre_crlb_ratio']:.2f}x), "
            f"observable {s['observable_directions']}",
            flush=True,
        )
        ratios.append((s["kappa_crlb_ratio"], s["offset_crlb_ratio"], s["joint_centre_crlb_ratio"],
                       *post))  # fmt: skip
    # One trial's ratio is a random variable (an error over its standard deviation, with few
    # effective degrees of freedom); over seeds the RMS ratio is 1 for an efficient estimator.
    rms = np.sqrt(np.mean(np.square(ratios), axis=0))
    print(
        f"RMS over {len(ratios)} seeds of the ratio to the bound: kappa {rms[0]:.2f}, "
        f"offsets {rms[1]:.2f}, joint centres {rms[2]:.2f} (1 for an efficient estimator); "
        f"with the priors' information: kappa {rms[3]:.2f}, offsets {rms[4]:.2f}"
    )
    # One seed's spread: what a single-seed check (tests/test_identify.py) can tell apart.
    r = np.asarray(ratios)
    if len(r) > 1:
        names = ("kappa", "offsets", "joint centres", "kappa+prior", "offsets+prior")
        print("per seed: " + "; ".join(
            f"{n} mean {r[:, i].mean():.3f} sd {r[:, i].std(ddof=1):.3f} "
            f"p95 {np.percentile(r[:, i], 95):.2f} max {r[:, i].max():.2f}"
            for i, n in enumerate(names)
        ))  # fmt: skip


if __name__ == "__main__":
    main()
