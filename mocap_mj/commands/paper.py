"""``mocap-mj identify --solver paper``: Algorithm 1 of Zou & Sugihara, then the LM's folder."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from ..cli import finish
from ..errors import MocapError
from ..identify.identifiability import Identifiability
from ..identify.initial import marker_stature, segment_scales
from ..identify.output import expected_rmse, write_files
from ..identify.paper import (
    DEFAULT_DELTA,
    DEFAULT_STEP,
    PaperResult,
    PaperSettings,
    identify_paper,
    trace_lines,
)
from ..identify.plausibility import implausible_reasons
from ..identify.problem import TrialData
from ..parameters import ParameterSet
from .progress import progress_bar


def run_paper(
    args: argparse.Namespace,
    pset: ParameterSet,
    trials: list[TrialData],
    ranges: list[list[int]],
    out: Path,
) -> int:
    """Algorithm 1 with the command's settings; writes the same folder as the LM path."""
    if args.sampling is None:
        raise MocapError("--solver paper needs --sampling batch, even, random or stochastic")
    settings = PaperSettings(
        sampling=args.sampling,
        iterations=args.iterations,
        step=DEFAULT_STEP if args.step is None else args.step,
        delta=DEFAULT_DELTA if args.delta is None else args.delta,
        fraction=args.fraction,
        seed=args.seed,
    )
    with progress_bar(f"identify (paper, {settings.sampling})", enabled=not args.json) as bar:
        result = identify_paper(trials, pset=pset, settings=settings, progress=bar)
    idf = Identifiability(
        pset,
        result.reduced_information,
        result.sigma,
        observable_std=args.observable_mm * 1e-3,
        theta=result.theta,
    )
    summary = paper_summary(pset, result, idf, trials, ranges)
    k = pset.n_kappa
    summary["implausible"] = implausible_reasons(  # the LM path's checks (exit status 3)
        result.marker_rmse,
        int(np.sum(result.at_bound[:k])),
        int(np.sum(~pset.frozen[:k])),
        marker_stature(segment_scales(pset, [t.markers for t in trials])),
    )
    iterations = [
        "## Iterations (Algorithm 1 of Zou & Sugihara)",
        "",
        f"sampling {settings.sampling}, alpha {settings.step:g}, Delta {settings.delta:g} m, "
        f"{result.ik_problems} IK problems",
        "",
        *trace_lines(result),
        "",
    ]
    write_files(out, pset, result, idf, trials, summary, iterations)
    text = (
        f"identified {pset.size} parameters from {summary['frames_used']} frames in "
        f"{result.seconds:.2f} s (Algorithm 1, {settings.sampling} sampling, "
        f"{len(result.trace)} iterations, {result.ik_problems} IK problems)\n"
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm (noise floor "
        f"{summary['expected_rmse_mm']:.3f} mm); {idf.rank} of {pset.size} directions observable\n"
        f"wrote {args.out}/model.xml, theta.json, motion.npz, identifiability.json, report.md"
    )
    return finish(args, summary, text, out)


def paper_summary(
    pset: ParameterSet,
    result: PaperResult,
    idf: Identifiability,
    trials: list[TrialData],
    ranges: list[list[int]],
) -> dict[str, Any]:
    """summary.json of a paper run."""
    st = result.settings
    n_frames = sum(len(t.markers) for t in trials)
    n_used = sum(int(u.sum()) for u in result.used)
    return {
        "markers_files": [t.name for t in trials],
        "frames_fitted_range": ranges,
        "solver": "paper",
        "sampling": st.sampling,
        "step": st.step,
        "delta_m": st.delta,
        "fraction": st.fraction,
        "seed": st.seed,
        "perturbed_iterations": st.perturbed_iterations,
        "loss": "l2",
        "frames": n_frames,
        "frames_used": n_used,
        "frames_skipped": n_frames - n_used,
        "frames_per_iteration": len(result.trace[0].frames),
        "seconds": result.seconds,
        "init_seconds": result.init_seconds,
        "final_ik_seconds": result.final_seconds,
        "iterations": len(result.trace),
        "ik_problems": result.ik_problems,
        "frames_repaired": result.repaired,
        "fresh_ik_iterations": result.refits,
        "termination": result.status.value,
        "marker_rmse_mm": result.marker_rmse * 1e3,
        "energy_m2": result.energy,
        "expected_rmse_mm": expected_rmse(result.sigma, result.n_unknowns, result.n_residuals)
        * 1e3,
        "sigma_mm": result.sigma * 1e3,
        "observable_directions": idf.rank,
        "unobservable_directions": int(np.sum(~idf.observable)),
        "kappa_crlb_rms_mm": idf.bound_rms()[0] * 1e3,
        "offset_crlb_rms_mm": idf.bound_rms()[1] * 1e3,
        "kappa_mm": {
            n: float(v) * 1e3 for n, v in zip(pset.kappa_names, result.theta, strict=False)
        },
    }
