"""Identify trials and write the result folder: shared by ``identify`` and ``demo``."""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import check_determined
from ..errors import MocapError
from ..ik import IKSettings
from ..io.atomic import atomic_folder, atomic_write_text
from ..parameters import ParameterSet
from ..strict_json import dumps, jsonable
from ..tables import write_joint_centres_csv
from .identifiability import Identifiability
from .initial import place_markers, scaled_theta, segment_scales
from .lm import LMSettings, identify_lm, solver_joint_range
from .output import write_result
from .plausibility import kappa_outside_bounds, marker_rmse_by_marker
from .problem import TrialData
from .result import IdentificationResult, ProgressCallback
from .segments import SegmentRow, uncertainty_summary, write_segments_csv

#: Initial models of :func:`identify_to_folder` (``init``).
INITS = ("placed", "scaled", "nominal")


def identify_to_folder(
    trials: Sequence[TrialData],
    out: Path,
    *,
    pset: ParameterSet,
    settings: LMSettings,
    theta0: np.ndarray | None = None,
    init: str = "nominal",
    progress: ProgressCallback | None = None,
    extra: dict[str, Any] | None = None,
) -> tuple[dict[str, Any], IdentificationResult, Identifiability]:
    """Run the joint LM on the trials and write model.xml, theta.json, motion.npz,
    identifiability.json and report.md into ``out``; return (summary, result, identifiability).

    ``out`` is replaced whole at the end (:func:`mocap_mj.io.atomic.atomic_folder`): it holds
    the complete result or what it held before. Trials with fewer marker coordinates than
    unknowns are refused before the fit (:func:`mocap_mj.checks.check_determined`).

    Without ``theta0`` the initial model (and prior mean) is, for ``init="scaled"``, the
    nominal model scaled to the subject from the trials' marker distances
    (:func:`mocap_mj.identify.initial.scaled_theta`); for ``init="placed"`` that skeleton
    with the marker offsets placed by IK (:func:`mocap_mj.identify.initial.place_markers`;
    ``mocap-mj identify`` does this by default); for ``init="nominal"`` the nominal model
    (the default here: the demo's synthetic truth is the nominal model perturbed, so the
    nominal model is its best prior mean). ``progress`` is called with every LM iteration;
    the solver's log lines (logger ``mocap_mj``) are kept in the summary's ``log``.
    """
    t0 = time.perf_counter()
    if init not in INITS:
        raise MocapError(f"init must be one of {', '.join(INITS)}; got {init!r}")
    init_used = "given" if theta0 is not None else init
    check_determined(
        [t.name for t in trials],
        [t.markers for t in trials],
        IKSettings().min_markers,
        pset.model.nv,
        int(np.sum(~pset.frozen)),
    )
    scales: dict[str, float] = {}
    if theta0 is None and init != "nominal":
        markers = [t.markers for t in trials]
        estimates = segment_scales(pset, markers)
        theta0 = scaled_theta(pset, markers, scales=estimates)
        scales = {n: e.value for n, e in estimates.items()}
        if init == "placed":
            theta0 = place_markers(pset, theta0, markers)
    with captured_log() as log:
        result = identify_lm(trials, pset=pset, theta0=theta0, settings=settings, progress=progress)
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
            "init": init_used,
            "init_scales": scales,
            "frames": n_frames,
            "frames_used": n_used,
            "frames_skipped": n_frames - n_used,
            "seconds": seconds,
            "init_seconds": result.init_seconds,
            "iterations": result.iterations,
            "termination": result.termination.value,
            "marker_rmse_mm": result.marker_rmse * 1e3,
            "sigma_mm": result.sigma * 1e3,
            "n_residuals": result.n_residuals,
            "n_unknowns": result.n_unknowns,
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
    rows = _add_checks(summary, pset, result, trials, settings)
    summary = jsonable(summary)
    with atomic_folder(out, force=True) as staging:
        write_result(
            staging,
            pset,
            result,
            idf,
            trials,
            summary,
            joint_range=solver_joint_range(pset.model, settings),
        )
        _write_tables(staging, pset, result, trials, rows, summary.get("frames_fitted_range"))
        atomic_write_text(staging / "summary.json", dumps(summary, indent=2) + "\n")
    return summary, result, idf


def _add_checks(
    summary: dict[str, Any],
    pset: ParameterSet,
    result: IdentificationResult,
    trials: Sequence[TrialData],
    settings: LMSettings,
) -> list[SegmentRow]:
    """Add the real-data checks to ``summary`` (worst markers, parameters outside their range,
    the segment table with inflated standard deviations); return the segment rows."""
    per_marker = marker_rmse_by_marker(pset, result, trials)
    outside = kappa_outside_bounds(pset, result.theta)
    summary["marker_rmse_by_marker_mm"] = {
        n: float(v) * 1e3 for n, v in zip(pset.marker_names, per_marker, strict=True)
    }
    summary["kappa_outside_bounds_mm"] = {n: [v * 1e3 for v in b] for n, b in outside.items()}
    entries, rows = uncertainty_summary(pset, result, trials, per_marker, settings)
    summary.update(entries)
    return rows


def _write_tables(
    out: Path,
    pset: ParameterSet,
    result: IdentificationResult,
    trials: Sequence[TrialData],
    rows: Sequence[SegmentRow],
    ranges: Sequence[Sequence[int]] | None,
) -> None:
    """segments.csv, and joint_centres.csv per trial (``joint_centres_<i>.csv`` for the
    others, like motion.npz); ``ranges``: each trial's fitted [first, stop) frames of its
    file (default: from frame 0)."""
    write_segments_csv(out / "segments.csv", rows)
    model = pset.model_for(result.theta)
    starts = [int(r[0]) for r in ranges] if ranges else [0] * len(trials)
    for i, (trial, qpos, first) in enumerate(zip(trials, result.qpos, starts, strict=True)):
        name = "joint_centres.csv" if i == 0 else f"joint_centres_{i}.csv"
        write_joint_centres_csv(out / name, model, trial.times, qpos, first_frame=first)


class _ListHandler(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


@contextlib.contextmanager
def captured_log() -> Iterator[list[str]]:
    """The INFO messages of the ``mocap_mj`` logger while the block runs, as a list."""
    handler = _ListHandler()
    root = logging.getLogger("mocap_mj")
    level = root.level
    root.addHandler(handler)
    if root.getEffectiveLevel() > logging.INFO:
        root.setLevel(logging.INFO)
    try:
        yield handler.lines
    finally:
        root.removeHandler(handler)
        root.setLevel(level)


def result_text(summary: dict[str, Any], pset: ParameterSet, out: Path) -> str:
    return (
        f"identified {pset.size} parameters from {summary['frames_used']} frames in "
        f"{summary['seconds']:.2f} s ({summary['iterations']} LM iterations, "
        f"{summary['termination']})\n"
        f"marker RMSE {summary['marker_rmse_mm']:.3f} mm, i.e. a per-axis noise sigma of "
        f"{summary['sigma_mm']:.3f} mm given {summary['n_unknowns']} unknowns and "
        f"{summary['n_residuals']} residuals; {summary['observable_directions']} of {pset.size} "
        f"directions observable, CRLB {summary['kappa_crlb_rms_mm']:.3f} mm (kinematic) / "
        f"{summary['offset_crlb_rms_mm']:.3f} mm (offsets)\n"
        f"wrote {out}/model.xml, theta.json, motion.npz, joint_centres.csv, segments.csv, "
        "identifiability.json, report.md"
    )
