"""``mocap-mj experiment paper``: Table 1 and Figs 3-4 of Zou & Sugihara on synthetic data.

One synthetic trial (5 s at 100 Hz, range-of-motion preset, 1 mm noise, truth model perturbed
from the nominal one) is identified from the nominal model by Algorithm 1
(:mod:`mocap_synth.paper`) with the paper's four frame samplings, and by the project's
joint LM (:func:`mocap_mj.solve.lm.identify_lm`). Every identified model is then evaluated the
same way: IK of every frame with that model, marker error per frame (Fig 3) and accumulated
over the trial (Fig 4), and parameter errors against the truth.

Files written to ``--out``: ``report.md`` (Table 1 and notes), ``table1.csv``/``table1.json``,
``frame_error.csv`` (marker RMSE per frame and model, mm), ``traces.json`` (per-iteration E,
RMSE, time of every run), ``fig3.png``, ``fig4.png``, ``convergence.png``, ``summary.json``.

The batch sampling solves 151 x 500 IK problems per iteration; it is run for fewer iterations
(``--batch-iterations``) and its time extrapolated per iteration to the others' iteration
count. The stochastic rows for 100 and 300 iterations are the states of the 500-iteration run
after 100 and 300 iterations (the run is deterministic given the seed, so a shorter run is
exactly its beginning).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.commands.common import (
    finish,
    output_folder,
    write_summary,
)
from mocap_mj.commands.progress import progress_bar
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.plots import held_interrupts
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.ik import IKSolver
from mocap_mj.solve.lm import LMSettings, TrialData, identify_lm
from mocap_mj.solve.solver_result import IterationLog
from mocap_synth.paper import (
    DEFAULT_DELTA,
    DEFAULT_STEP,
    PaperResult,
    PaperSettings,
    identify_paper,
    reduced_information,
)

from .config import SynthConfig
from .experiment import Experiment, synthesize

#: The paper's Table 1 (500 frames, 100 iterations; 1 frame per iteration for stochastic) [s].
PAPER_TABLE1: tuple[tuple[str, int, int, float], ...] = (
    ("batch", 500, 100, 6759.0),
    ("even", 50, 100, 690.0),
    ("random", 50, 100, 712.0),
    ("stochastic", 1, 100, 15.5),
    ("stochastic", 1, 300, 44.5),
    ("stochastic", 1, 500, 76.0),
)


#: Label of the starting model (in the table and frame_error.csv, not in the figures).
INITIAL = "initial (nominal) model"


@dataclass(frozen=True)
class PaperExperiment:
    """Sizes of a run.

    Attributes
    ----------
    frames : int, frames of the synthetic trial (100 Hz)
    iterations : int, iterations of batch (extrapolated), even and random
    batch_iterations : int, iterations batch is actually run
    stochastic : tuple of int, iteration counts reported for stochastic (one run, the largest)
    step, delta, fraction : Algorithm 1's alpha, Delta [m] and sampled share
    seed : int, synthesis and sampling seed
    lm_iterations : int, iteration limit of the joint LM
    """

    frames: int = 500
    iterations: int = 100
    batch_iterations: int = 10
    stochastic: tuple[int, ...] = (100, 300, 500)
    step: float = DEFAULT_STEP
    delta: float = DEFAULT_DELTA
    fraction: float = 0.1
    seed: int = 0
    lm_iterations: int = 100


FULL = PaperExperiment()
QUICK = PaperExperiment(frames=100, iterations=15, batch_iterations=2, stochastic=(15, 45, 75))


@dataclass
class Row:
    """One line of Table 1."""

    method: str
    label: str
    frames: int
    loops: int
    seconds: float
    measured_seconds: float
    theta: np.ndarray
    note: str = ""


def run(args: argparse.Namespace) -> int:
    base = QUICK if args.quick else FULL
    cfg = PaperExperiment(
        frames=base.frames,
        iterations=base.iterations,
        batch_iterations=args.batch_iterations or base.batch_iterations,
        stochastic=base.stochastic,
        seed=args.seed,
    )
    with output_folder(args.out, force=args.force) as out:
        summary = run_experiment(cfg, out, progress=not args.json, quick=args.quick)
        write_summary(out, summary)
    text = "\n".join(table_lines(summary["table"])) + f"\n\nwrote {args.out}/report.md"
    return finish(args, summary, text)


# --------------------------------------------------------------------------- the runs
def run_experiment(
    cfg: PaperExperiment, out: Path, *, progress: bool = True, quick: bool = False
) -> dict[str, Any]:
    """Run every method, evaluate every model, write the files; return the summary."""
    t_all = time.perf_counter()
    exp = synthesize(
        SynthConfig(frames=cfg.frames, rate=100.0, seed=cfg.seed, marker_placement="uniform")
    )
    pset = exp.pset
    trials = [TrialData("synthetic", np.array(exp.markers), np.array(exp.times))]
    rows: list[Row] = []
    traces: dict[str, Any] = {}
    refits: dict[str, list[int]] = {}

    def paper(sampling: str, iterations: int) -> PaperResult:
        settings = PaperSettings(
            sampling=sampling, iterations=iterations, step=cfg.step, delta=cfg.delta,
            fraction=cfg.fraction, seed=cfg.seed,
        )  # fmt: skip
        with progress_bar(f"paper ({sampling})", progress) as bar:
            r = identify_paper(trials, pset=pset, settings=settings, progress=bar)
        traces[sampling] = _trace_json(r)
        refits[sampling] = r.refits
        return r

    # Batch: run batch_iterations, extrapolate the time per iteration.
    rb = paper("batch", cfg.batch_iterations)
    per_it = (rb.seconds - rb.init_seconds) / len(rb.trace)
    note = (
        f"run for {len(rb.trace)} iterations ({rb.seconds - rb.init_seconds:.1f} s); time "
        f"extrapolated to {cfg.iterations}; errors after {len(rb.trace)} iterations"
    )
    n = cfg.frames
    note += _refit_note(rb.refits)
    rows.append(Row("batch", "batch", n, cfg.iterations, per_it * cfg.iterations,
                    rb.seconds - rb.init_seconds, rb.theta, note))  # fmt: skip
    for sampling in ("even", "random"):
        r = paper(sampling, cfg.iterations)
        rows.append(Row(sampling, f"1/{round(1 / cfg.fraction)} {sampling}",
                        len(r.trace[0].frames), cfg.iterations, r.seconds - r.init_seconds,
                        r.seconds - r.init_seconds, r.theta,
                        _refit_note(r.refits).lstrip("; ")))  # fmt: skip
    rows += _stochastic_rows(paper("stochastic", max(cfg.stochastic)), cfg.stochastic)
    lm, row, traces["lm"] = _joint_lm(trials, pset, cfg, progress)
    rows.append(row)
    init_ik = rb.init_seconds

    # Common yardstick: the observable subspace of the LM's reduced information.
    info, sigma, n_res, n_unk = reduced_information(pset, lm.theta, trials, lm.qpos)
    idf = Identifiability(pset, info, sigma, theta=lm.theta)
    table, frame_err = evaluate(exp, rows, idf, progress=progress)
    initial = _evaluate_one(exp, INITIAL, pset.nominal, idf, frame_err)
    initial.update(method="initial", frames=0, loops=0, seconds=0.0, measured_seconds=0.0)
    table.insert(0, initial)
    batch_time = rows[0].seconds
    for t in table:
        t["speed_vs_batch"] = batch_time / t["seconds"] if t["seconds"] > 0 else None

    summary: dict[str, Any] = {
        "experiment": "paper",
        "quick": quick,
        "settings": _settings_entry(cfg, exp),
        "initial_ik_seconds": init_ik,
        "table": table,
        "observable_directions": idf.rank,
        "kappa_crlb_rms_mm": idf.bound_rms()[0] * 1e3,
        "offset_crlb_rms_mm": idf.bound_rms()[1] * 1e3,
        "lm_expected_rmse_mm": float(np.sqrt(3) * sigma * np.sqrt(max(1 - n_unk / n_res, 0))) * 1e3,
        "fresh_ik_iterations": refits,
        "paper_table1": [
            {"method": m, "frames": f, "loops": k, "seconds": s} for m, f, k, s in PAPER_TABLE1
        ],
        "seconds_total": 0.0,
    }
    _write_files(out, exp, table, frame_err, traces, summary)
    summary["seconds_total"] = time.perf_counter() - t_all
    return summary


def _stochastic_rows(rs: PaperResult, counts: Sequence[int]) -> list[Row]:
    """The stochastic run's rows: its first k iterations for each k of ``counts``."""
    rows = []
    for k in counts:
        it = rs.trace[k - 1]
        sec = it.seconds - rs.init_seconds
        note = (
            ""
            if k == len(rs.trace)
            else (f"first {k} iterations of the {len(rs.trace)}-iteration run")
        )
        note += _refit_note([i for i in rs.refits if i <= k])
        rows.append(Row("stochastic", f"stochastic {k}", 1, k, sec, sec, it.theta,
                        note.lstrip("; ")))  # fmt: skip
    return rows


def _joint_lm(
    trials: list[TrialData], pset: ParameterSet, cfg: PaperExperiment, progress: bool
) -> tuple[Any, Row, list[dict[str, Any]]]:
    """The joint LM on the experiment's trial: its result, its row (initial IK included in
    the time) and its trace (iteration, seconds from its start, cost, RMSE [mm])."""
    t0 = time.perf_counter()
    with progress_bar("joint LM", progress) as bar:
        lm = identify_lm(trials, pset=pset, settings=LMSettings(max_iterations=cfg.lm_iterations),
                         progress=bar)  # fmt: skip
    lm_seconds = time.perf_counter() - t0
    row = Row("lm", "joint LM (this project)", cfg.frames, lm.iterations, lm_seconds,
              lm_seconds, lm.theta, f"initial IK {lm.init_seconds:.1f} s included")  # fmt: skip
    logs = [t for t in lm.trace if isinstance(t, IterationLog)]  # the joint LM's entries
    assert len(logs) == len(lm.trace)
    elapsed = lm.init_seconds + np.cumsum([t.seconds for t in logs])  # from its start
    trace = [
        {"iteration": t.iteration, "seconds": float(e), "cost": t.cost, "rmse_mm": t.rmse * 1e3}
        for t, e in zip(logs, elapsed, strict=True)
    ]
    return lm, row, trace


def _settings_entry(cfg: PaperExperiment, exp: Any) -> dict[str, Any]:
    """summary.json's ``settings``: the experiment's and the synthetic data's."""
    return {
        "frames": cfg.frames,
        "rate_hz": 100.0,
        "iterations": cfg.iterations,
        "batch_iterations": cfg.batch_iterations,
        "stochastic": list(cfg.stochastic),
        "step": cfg.step,
        "delta_m": cfg.delta,
        "fraction": cfg.fraction,
        "seed": cfg.seed,
        "synth": exp.config.to_dict(),
    }


def _refit_note(refits: list[int]) -> str:
    if not refits:
        return ""
    return f"; fresh IK of all frames (local minima) at iteration(s) {refits}"


def _trace_json(r: PaperResult) -> list[dict[str, Any]]:
    return [
        {
            "iteration": p.iteration,
            "seconds": p.seconds - r.init_seconds,
            "frames": len(p.frames),
            "energy_m2": p.energy,
            "rmse_mm": p.rmse * 1e3,
            "grad_norm": p.grad_norm,
        }
        for p in r.trace
    ]


def evaluate(
    exp: Experiment, rows: list[Row], idf: Identifiability, *, progress: bool = False
) -> tuple[list[dict[str, Any]], dict[str, np.ndarray]]:
    """Table rows (dicts) and per-frame marker RMSE (label -> (T,) mm) of every model."""
    frame_err: dict[str, np.ndarray] = {}
    table = []
    it = rows
    if progress:
        from tqdm import tqdm

        it = tqdm(rows, desc="evaluate models", unit="model", leave=False, delay=2)
    for row in it:
        t = _evaluate_one(exp, row.label, row.theta, idf, frame_err)
        t.update(
            method=row.method, label=row.label, frames=row.frames, loops=row.loops,
            seconds=row.seconds, measured_seconds=row.measured_seconds, note=row.note,
        )  # fmt: skip
        table.append(t)
    return table, frame_err


def _evaluate_one(
    exp: Experiment,
    label: str,
    theta: np.ndarray,
    idf: Identifiability,
    frame_err: dict[str, np.ndarray],
) -> dict[str, Any]:
    """IK of every frame with model theta; marker error and parameter errors [mm]."""
    pset = exp.pset
    kin = Kinematics(pset)
    kin.set_theta(theta)
    r = IKSolver(kin).solve_trial(np.array(exp.markers))
    frame_err[label] = r.marker_rmse * 1e3
    err = theta - exp.theta_true
    e_obs, _ = idf.project(err)
    k = pset.n_kappa
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))) * 1e3)  # noqa: E731
    return {
        "method": label,
        "label": label,
        "marker_rmse_mm": r.rmse() * 1e3,
        "accumulated_error_mm": float(np.nansum(r.marker_rmse) * 1e3),
        "kappa_rmse_mm": rms(err[:k]),
        "offset_rmse_mm": rms(err[k:]),
        "kappa_observable_rmse_mm": rms(e_obs[:k]),
        "offset_observable_rmse_mm": rms(e_obs[k:]),
        "note": "",
    }


# --------------------------------------------------------------------------- output
def table_lines(table: list[dict[str, Any]]) -> list[str]:
    """Table 1 as Markdown."""
    lines = [
        "| method | frames sampled | loops | time (s) | marker RMSE (mm) | kappa err (mm) "
        "| offset err (mm) | kappa err, observable (mm) | offset err, observable (mm) "
        "| speed vs batch |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for t in table:
        speed = t.get("speed_vs_batch")
        lines.append(
            f"| {t['label']} | {t['frames']} | {t['loops']} | {t['seconds']:.1f} | "
            f"{t['marker_rmse_mm']:.3f} | {t['kappa_rmse_mm']:.2f} | {t['offset_rmse_mm']:.2f} "
            f"| {t['kappa_observable_rmse_mm']:.2f} | {t['offset_observable_rmse_mm']:.2f} | "
            f"{'' if speed is None else f'{speed:.1f}x'} |"
        )
    return lines


def _write_files(
    out: Path,
    exp: Experiment,
    table: list[dict[str, Any]],
    frame_err: Mapping[str, np.ndarray],
    traces: Mapping[str, Any],
    summary: dict[str, Any],
) -> None:
    times = np.array(exp.times)
    keys = [
        "label", "method", "frames", "loops", "seconds", "measured_seconds", "marker_rmse_mm",
        "accumulated_error_mm", "kappa_rmse_mm", "offset_rmse_mm", "kappa_observable_rmse_mm",
        "offset_observable_rmse_mm", "speed_vs_batch", "note",
    ]  # fmt: skip
    with open(out / "table1.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for t in table:
            w.writerow([t.get(k) for k in keys])
    atomic_write_text(out / "table1.json", json.dumps(table, indent=2) + "\n")
    labels = list(frame_err)
    with open(out / "frame_error.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_s", *labels])
        for i, t in enumerate(times):
            w.writerow([f"{t:.3f}", *(f"{frame_err[k][i]:.6f}" for k in labels)])
    atomic_write_text(out / "traces.json", json.dumps(traces) + "\n")
    identified = {k: v for k, v in frame_err.items() if k != INITIAL}
    plot_frame_error(out / "fig3.png", times, identified)
    plot_accumulated(out / "fig4.png", times, identified)
    plot_convergence(out / "convergence.png", traces)
    atomic_write_text(out / "report.md", "\n".join(report_lines(summary)) + "\n")


def report_lines(summary: Mapping[str, Any]) -> list[str]:
    s = summary["settings"]
    lines = [
        "# Algorithm 1 of Zou & Sugihara: Table 1 and Figs 3-4 on synthetic data",
        "",
        f"Synthetic trial: {s['frames']} frames at {s['rate_hz']:.0f} Hz, range-of-motion "
        f"preset, {s['synth']['noise_mm']:g} mm noise, truth perturbed from the nominal model "
        f"(kinematic parameters -/+ {s['synth']['kappa_scale'] * 100:.0f} %, offsets -/+ "
        f"{s['synth']['offset_mm']:g} mm), seed {s['seed']}. Every method starts from the "
        f"nominal model. Algorithm 1: alpha = {s['step']:g}, Delta = {s['delta_m']:g} m "
        f"(forward differences), {s['fraction']:g} of the frames for even/random.",
        "",
        "Time: the iterations, wall clock on a shared 2-core machine; the initial IK of all "
        f"frames ({summary['initial_ik_seconds']:.1f} s) is common to every Algorithm-1 run and "
        "not included. The joint LM's time includes its own initial IK. Marker RMSE: IK of "
        "every frame with the identified model. Parameter errors: RMS over the 34 kinematic "
        "parameters / 117 offset components against the truth, all directions and (columns "
        f"'observable') projected on the {summary['observable_directions']} observable "
        "directions of the reduced information (the others cannot be determined from markers).",
        "",
        f"Noise floor of the marker RMSE (noise alone, perfect model): "
        f"{summary['lm_expected_rmse_mm']:.3f} mm. Cramer-Rao bound (RMS) of the observable "
        f"directions: {summary['kappa_crlb_rms_mm']:.2f} mm (kinematic), "
        f"{summary['offset_crlb_rms_mm']:.2f} mm (offsets).",
        "",
    ]
    if summary.get("quick"):
        lines += ["**Quick run** (CI): fewer frames and iterations than the paper.", ""]
    lines += ["## Table 1", "", *table_lines(summary["table"]), ""]
    notes = [f"- {t['label']}: {t['note']}" for t in summary["table"] if t.get("note")]
    if notes:
        lines += ["Notes:", "", *notes, ""]
    lines += [
        "## The paper's Table 1 (500 frames)",
        "",
        "| method | frames sampled | loops | time (s) |",
        "|---|---|---|---|",
        *(
            f"| {p['method']} | {p['frames']} | {p['loops']} | {p['seconds']:g} |"
            for p in summary["paper_table1"]
        ),
        "",
        "## Figures",
        "",
        "- `fig3.png`: marker RMSE of every frame with each identified model (paper's Fig 3).",
        "- `fig4.png`: the same, accumulated over the trial (paper's Fig 4).",
        "- `convergence.png`: E per sampled frame against time for every run.",
        "",
    ]
    return lines


# --------------------------------------------------------------------------- figures
def plot_frame_error(path: Path, times: np.ndarray, errors: Mapping[str, np.ndarray]) -> None:
    """Fig 3: marker error per frame (mm) for each model."""
    try:
        from mocap_mj.io.plots import plot_marker_error_per_frame
    except ImportError:
        _plot_series(path, times, errors, cumulative=False)
        return
    plot_marker_error_per_frame(path, times, errors, title="Marker error per frame (Fig 3)")


def plot_accumulated(path: Path, times: np.ndarray, errors: Mapping[str, np.ndarray]) -> None:
    """Fig 4: marker error accumulated over the frames (mm)."""
    try:
        from mocap_mj.io.plots import plot_error_accumulation
    except ImportError:
        _plot_series(path, times, errors, cumulative=True)
        return
    plot_error_accumulation(path, times, errors, title="Accumulated marker error (Fig 4)")


def _figure() -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4.67), dpi=150, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


@held_interrupts
def _plot_series(
    path: Path, times: np.ndarray, errors: Mapping[str, np.ndarray], *, cumulative: bool
) -> None:
    fig = _figure()
    ax = fig.add_subplot()
    for label, e in errors.items():
        y = np.cumsum(np.nan_to_num(e)) if cumulative else e
        ax.plot(times, y, lw=1.2, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("accumulated marker error [mm]" if cumulative else "marker error [mm]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    fig.savefig(path, format="png")


@held_interrupts
def plot_convergence(path: Path, traces: Mapping[str, Any]) -> None:
    """Marker RMSE of the frames each run uses [mm] against its time [s] (log scales)."""
    fig = _figure()
    ax = fig.add_subplot()
    for name, tr in traces.items():
        if not tr:
            continue
        t = [p["seconds"] for p in tr]
        y = [p["rmse_mm"] for p in tr]
        ax.plot(t, y, lw=1.0, label=name, marker="." if len(t) < 30 else None)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_yscale("log")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("marker RMSE of the frames in use [mm]")
    ax.set_title("Convergence against time")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="small")
    fig.savefig(path, format="png")


# --------------------------------------------------------------------------- alpha, Delta
def run_steps(args: argparse.Namespace) -> int:
    with output_folder(args.out, force=args.force) as out:
        summary = measure_steps(progress=not args.json)
        lines = steps_report(summary)
        atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
        write_summary(out, summary)
    return finish(args, summary, "\n".join(lines))


def measure_steps(
    *,
    frames: int = 100,
    steps: tuple[float, ...] = (0.02, 0.05, 0.1, 0.15, 0.2),
    deltas: tuple[float, ...] = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
    run_deltas: tuple[float, ...] = (1e-2, 1e-3, 1e-6),
    iterations: int = 30,
    seed: int = 0,
    progress: bool = False,
) -> dict[str, Any]:
    """Gradient accuracy against Delta and IK iterations; runs for several alpha and Delta."""
    from mocap_synth.paper import GradientEstimator, analytic_gradient

    exp = synthesize(SynthConfig(frames=frames, rate=100.0, seed=seed, marker_placement="uniform"))
    pset = exp.pset
    markers = np.array(exp.markers)
    trials = [TrialData("synthetic", markers, np.array(exp.times))]
    k = pset.n_kappa
    out: dict[str, Any] = {"frames": frames, "iterations": iterations, "seed": seed}

    # 1. Gradient accuracy at the nominal model (every 10th frame, converged poses).
    kin = Kinematics(pset)
    kin.set_theta(pset.nominal)
    sub = markers[::10]
    q0 = IKSolver(kin).solve_trial(markers).qpos[::10]
    est = GradientEstimator(pset, 1e-6)
    est.set_theta(pset.nominal)
    q = est.solve(sub, est.solve(sub, q0))
    ga = analytic_gradient(kin, sub, q)
    rows = []
    for delta in deltas:
        for its in (1, 2, 3, 100) if delta == DEFAULT_DELTA else (2,):
            e = GradientEstimator(pset, delta, perturbed_iterations=its)
            e.set_theta(pset.nominal)
            t0 = time.perf_counter()
            e0, ep = e.perturbed_energy(sub, q)
            sec = time.perf_counter() - t0
            g = np.zeros(pset.size)
            g[e.params] = np.sum(ep - e0[:, None], axis=0) / delta
            rel = float(np.linalg.norm(g - ga) / np.linalg.norm(ga))
            rows.append(
                {"delta_m": delta, "perturbed_iterations": its, "seconds": sec,
                 "relative_error": rel}
            )  # fmt: skip
    out["gradient"] = rows

    # 2. Largest curvature of E per frame (with the poses re-solved): alpha < 2 / lambda_max.
    info, sigma, *_ = reduced_information(pset, np.array(exp.theta_true), trials,
                                          [np.array(exp.qpos)])  # fmt: skip
    lam = np.linalg.eigvalsh(2 * info / frames)
    out["hessian_per_frame_max"] = float(lam[-1])
    out["alpha_limit"] = float(2 / lam[-1])
    idf = Identifiability(pset, info, sigma, theta=np.array(exp.theta_true))

    # 3. Runs: even sampling (every 10th frame), several alpha and Delta.
    def run_one(step: float, delta: float) -> dict[str, Any]:
        st = PaperSettings(sampling="even", iterations=iterations, step=step, delta=delta)
        with progress_bar("paper (even)", progress) as bar:
            r = identify_paper(trials, pset=pset, settings=st, progress=bar)
        err = r.theta - exp.theta_true
        e_obs, e_rest = idf.project(err)
        energies = [p.energy for p in r.trace]
        return {
            "step": step, "delta_m": delta, "marker_rmse_mm": r.marker_rmse * 1e3,
            "E_first": energies[0], "E_last": energies[-1], "E_max": max(energies),
            "bound_active_iterations": r.clipped,
            "kappa_observable_rmse_mm": float(np.sqrt(np.mean(e_obs[:k] ** 2)) * 1e3),
            "offset_observable_rmse_mm": float(np.sqrt(np.mean(e_obs[k:] ** 2)) * 1e3),
            "unobservable_error_norm_mm": float(np.linalg.norm(e_rest) * 1e3),
            "seconds": r.seconds - r.init_seconds,
        }  # fmt: skip

    out["alpha_runs"] = [run_one(a, DEFAULT_DELTA) for a in steps]
    out["delta_runs"] = [run_one(DEFAULT_STEP, d) for d in run_deltas]
    return out


def steps_report(s: Mapping[str, Any]) -> list[str]:
    """Markdown tables of :func:`measure_steps`."""
    lines = [
        f"# Algorithm 1: alpha, Delta, perturbed IK ({s['frames']} frames, seed {s['seed']})",
        "",
        "## Finite-difference gradient vs the envelope-theorem gradient (nominal model)",
        "",
        "| Delta (m) | perturbed IK iterations | relative error | time (s) |",
        "|---|---|---|---|",
        *(
            f"| {g['delta_m']:g} | {g['perturbed_iterations']} | {g['relative_error']:.2e} | "
            f"{g['seconds']:.2f} |"
            for g in s["gradient"]
        ),
        "",
        f"Largest eigenvalue of the per-frame Hessian of E: {s['hessian_per_frame_max']:.2f} "
        f"(alpha limit 2 / lambda = {s['alpha_limit']:.3f}).",
        "",
        f"## Runs: even sampling, {s['iterations']} iterations",
        "",
        "| alpha | Delta (m) | E first | E last | E max | bound active | marker RMSE (mm) "
        "| kappa err obs. (mm) | offset err obs. (mm) | unobservable err (mm) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in [*s["alpha_runs"], *s["delta_runs"]]:
        lines.append(
            f"| {r['step']:g} | {r['delta_m']:g} | {r['E_first']:.3e} | {r['E_last']:.3e} | "
            f"{r['E_max']:.3e} | {r['bound_active_iterations']} | {r['marker_rmse_mm']:.3f} | "
            f"{r['kappa_observable_rmse_mm']:.2f} | {r['offset_observable_rmse_mm']:.2f} | "
            f"{r['unobservable_error_norm_mm']:.1f} |"
        )
    return lines
