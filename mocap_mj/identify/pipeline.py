"""Identify trials and write the result folder: shared by ``identify`` and ``demo``."""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..io.atomic import atomic_write_text
from ..parameters import ParameterSet
from .identifiability import Identifiability
from .lm import LMResult, LMSettings, TrialData, identify_lm
from .output import expected_rmse, write_result


def identify_to_folder(
    trials: Sequence[TrialData],
    out: Path,
    *,
    pset: ParameterSet,
    settings: LMSettings,
    theta0: np.ndarray | None = None,
    progress: bool = False,
    extra: dict[str, Any] | None = None,
) -> tuple[dict[str, Any], LMResult, Identifiability]:
    """Run the joint LM on the trials and write model.xml, theta.json, motion.npz,
    identifiability.json and report.md into ``out``; return (summary, result, identifiability)."""
    log: list[str] = []
    t0 = time.perf_counter()
    result = identify_lm(
        trials, pset=pset, theta0=theta0, settings=settings, progress=progress, log=log
    )
    seconds = time.perf_counter() - t0
    idf = Identifiability(
        pset,
        result.reduced_information,
        result.sigma,
        observable_std=settings.observable_std,
        theta=result.theta,
    )
    n_frames = sum(len(t.markers) for t in trials)
    n_used = sum(int(u.sum()) for u in result.used)
    bk, bo = idf.bound_rms()
    summary: dict[str, Any] = dict(extra or {})
    summary.update(
        {
            "solver": "lm",
            "loss": settings.loss,
            "frames": n_frames,
            "frames_used": n_used,
            "frames_skipped": n_frames - n_used,
            "seconds": seconds,
            "init_seconds": result.init_seconds,
            "iterations": result.iterations,
            "termination": result.termination.value,
            "marker_rmse_mm": result.marker_rmse * 1e3,
            "expected_rmse_mm": expected_rmse(result.sigma, result.n_unknowns, result.n_residuals)
            * 1e3,
            "sigma_mm": result.sigma * 1e3,
            "observable_directions": idf.rank,
            "unobservable_directions": int(np.sum(~idf.observable)),
            "kappa_crlb_rms_mm": bk * 1e3,
            "offset_crlb_rms_mm": bo * 1e3,
            "kappa_mm": {
                n: float(v) * 1e3 for n, v in zip(pset.kappa_names, result.theta, strict=False)
            },
            "log": log,
        }
    )
    write_result(out, pset, result, idf, trials, summary)
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary, result, idf


def result_text(summary: dict[str, Any], pset: ParameterSet, out: Path) -> str:
    return (
        f"identified {pset.size} parameters from {summary['frames_used']} frames in "
        f"{summary['seconds']:.2f} s ({summary['iterations']} LM iterations, "
        f"{summary['termination']})\n"
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm (noise alone would leave "
        f"{summary['expected_rmse_mm']:.3f} mm at the estimated sigma "
        f"{summary['sigma_mm']:.3f} mm); {summary['observable_directions']} of {pset.size} "
        f"directions observable, CRLB {summary['kappa_crlb_rms_mm']:.3f} mm (kinematic) / "
        f"{summary['offset_crlb_rms_mm']:.3f} mm (offsets)\n"
        f"wrote {out}/model.xml, theta.json, motion.npz, identifiability.json, report.md"
    )
