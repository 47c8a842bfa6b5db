"""``mocap-mj identify``: the subject's model (segment lengths, marker offsets) and motion."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ..cli import add_json_flag, finish, prepare_out
from ..errors import MocapError
from ..identify.lm import LMSettings, TrialData
from ..identify.output import frame_range
from ..identify.pipeline import INITS, identify_to_folder, result_text
from ..identify.plausibility import kappa_outside_bounds, marker_rmse_by_marker, plausibility_text
from ..identify.ranges import kappa_ranges
from ..parameters import ParameterSet
from ._markers import add_marker_options, load_trial
from ._subject import add_subject_options, subject_from_args


def register(sub: Any) -> None:
    p = sub.add_parser("identify", help="identify the subject's model from marker trials")
    add_marker_options(p, several=True)
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--model", help="initial MJCF model (default: the bundled humanoid)")
    p.add_argument("--solver", choices=["lm", "paper"], default="lm")
    p.add_argument(
        "--init",
        choices=list(INITS),
        default="placed",
        help="initial model and prior mean (lm solver): placed = the nominal model scaled to "
        "the subject from marker distances, marker offsets then placed by IK (default); "
        "scaled = scaled only; nominal = the bundled model as it is",
    )
    p.add_argument("--frames", help="frames to fit, A:B (default: all)")
    p.add_argument("--loss", choices=["l2", "huber", "cauchy"], default="l2")
    p.add_argument("--robust", action="store_true", help="same as --loss cauchy")
    p.add_argument("--max-iterations", type=int, default=100)
    p.add_argument("--prior-mm", type=float, default=50.0, help="weak prior width [mm]")
    p.add_argument("--observable-mm", type=float, default=5.0, help="observable if std below")
    add_subject_options(p)
    g = p.add_argument_group("paper solver (Algorithm 1 of Zou & Sugihara)")
    g.add_argument("--sampling", choices=["batch", "even", "random", "stochastic"])
    g.add_argument("--iterations", type=int, default=100)
    g.add_argument("--step", type=float, help="gradient step alpha")
    g.add_argument("--delta", type=float, help="finite-difference perturbation [m]")
    g.add_argument("--fraction", type=float, default=0.1)
    g.add_argument("--seed", type=int, default=0)
    p.add_argument("--force", action="store_true", help="overwrite a non-empty output folder")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    pset = ParameterSet(args.model)
    loaded = [load_trial(path, pset.marker_names, args) for path in args.markers]
    trials = []
    ranges = []
    for t in loaded:
        sl = frame_range(args.frames, len(t.markers))
        if sl.stop - sl.start < 1:
            raise MocapError(f"{t.path}: --frames {args.frames} selects no frame")
        ranges.append([sl.start, sl.stop])
        trials.append(TrialData(t.path, t.markers[sl], t.times[sl]))
    subject = subject_from_args(args, [t.path for t in loaded])  # bad input before any output
    out = prepare_out(args.out, force=args.force)
    if args.solver == "paper":
        from ..identify.paper import run_paper_cli

        return run_paper_cli(args, pset, trials, ranges, out)
    loss = "cauchy" if args.robust else args.loss
    settings = LMSettings(
        max_iterations=args.max_iterations,
        loss=loss,
        prior_sigma=args.prior_mm * 1e-3,
        observable_std=args.observable_mm * 1e-3,
    )
    summary, result, _ = identify_to_folder(
        trials,
        out,
        pset=pset,
        settings=settings,
        init=args.init,
        subject=subject,
        anatomical=not args.no_anatomy,
        symmetric=None if args.symmetric is None else args.symmetric * 1e-3,
        asymmetry_prior=not args.no_asymmetry_prior,
        progress=not args.json,
        extra={"markers_files": [t.path for t in loaded], "frames_fitted_range": ranges},
    )
    per_marker = marker_rmse_by_marker(pset, result, trials)
    lower, upper = kappa_ranges(pset, subject)
    outside = kappa_outside_bounds(pset, result.theta, lower, upper)
    summary["marker_rmse_by_marker_mm"] = {
        n: None if not np.isfinite(v) else float(v) * 1e3
        for n, v in zip(pset.marker_names, per_marker, strict=True)
    }
    summary["kappa_outside_bounds_mm"] = {n: [v * 1e3 for v in b] for n, b in outside.items()}
    reports = "\n".join(str(t.report) for t in loaded)
    text = f"{reports}\n{result_text(summary, pset, out)}\n"
    measured = "; ".join(
        f"{n} {m['value'] * (1 if m['unit'] == 'kg' else 1e3):g} "
        f"{'kg' if m['unit'] == 'kg' else 'mm'} ({m['source']})"
        for n, m in summary["measurements"].items()
    )
    text += f"measurements: {measured or 'none (regressions from the markers)'}\n"
    plaus = plausibility_text(pset, per_marker, outside, at_bound=summary["kappa_at_bound"])
    return finish(args, summary, text + plaus, out)
