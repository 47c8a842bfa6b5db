"""The dataset summary of a batch: the rows of ``summary.csv`` (one per subject and trial,
written by :func:`mocap_mj.outputs.batch_out.write_summary_csv`) and ``report.md`` with
figures across subjects (segment lengths, against height when the subject files give it;
marker RMSE per trial), from the subjects' records read back in SI."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.io.plots import _figure, _save, held_interrupts
from mocap_mj.outputs.batch_out import TrialRow, read_identify, read_rows

from ..io.atomic import atomic_write_text
from .run import Outcome

#: Segment lengths drawn across subjects in report.md.
SEGMENTS = ("thigh_length_l", "shank_length_l", "upperarm_length_l", "forearm_length_l")


def summary_rows(outcomes: Sequence[Outcome]) -> list[TrialRow]:
    """Every subject's trials (their records read back in SI), the rows of summary.csv."""
    return [r for o in outcomes for r in read_rows(o.record, o.name, o.status == "resumed")]


def write_report(out: Path, outcomes: Sequence[Outcome], seconds: float) -> Path:
    """report.md with a table per subject and two figures; returns its path."""
    ok = [o for o in outcomes if o.status != "failed"]
    failed = [o for o in outcomes if o.status == "failed"]
    rows = summary_rows(outcomes)
    bad_trials = [r for r in rows if r.status != "ok"]
    lines = [
        "# Batch report",
        "",
        f"{len(outcomes)} subjects: {len(ok)} identified "
        f"({sum(o.status == 'skipped' for o in outcomes)} kept from an earlier run), "
        f"{len(failed)} failed; {len(rows)} trials, {len(bad_trials)} failed; "
        f"{seconds:.1f} s.",
        "",
        "| subject | status | trials | identify RMSE [mm] | IK RMSE [mm] (mean) | time [s] "
        "| error |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        rmse = read_identify(o.record).marker_rmse
        trs = read_rows(o.record, o.name, False)
        ik = [r.ik_rmse for r in trs if r.ik_rmse is not None]
        lines.append(
            f"| {o.name} | {o.status} | {len(trs)} | {_num(None if rmse is None else rmse * 1e3)}"
            f" | {_num(float(np.mean(ik)) * 1e3 if ik else None)} | "
            f"{_num(o.record.get('seconds'))} | {o.record.get('error', '')} |"
        )
    if bad_trials:
        lines += ["", "Failed trials:", ""]
        lines += [f"- {r.subject} / {r.trial}: {r.error}" for r in bad_trials]
    figures = []
    if ok:
        figures.append(_plot_segments(out / "segments.png", ok))
    if any(r.ik_rmse is not None for r in rows):
        figures.append(_plot_rmse(out / "rmse_per_trial.png", rows))
    lines += ["", *[f"![{f.stem}]({f.name})" for f in figures]]
    path = out / "report.md"
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path


def _num(value: Any) -> str:
    return f"{value:.2f}" if isinstance(value, float | int) else ""


@held_interrupts
def _plot_segments(path: Path, outcomes: Sequence[Outcome]) -> Path:
    heights = [o.record.get("height_m") for o in outcomes]
    by_height = all(isinstance(h, float | int) for h in heights)
    x = np.array(heights, dtype=float) if by_height else np.arange(len(outcomes), dtype=float)
    fig = _figure((1200, 700))
    ax = fig.add_subplot()
    for name in SEGMENTS:
        y = [read_identify(o.record).kappa.get(name, np.nan) * 1e3 for o in outcomes]
        ax.plot(x, y, "o", label=name)
    if by_height:
        ax.set_xlabel("height [m]")
    else:
        ax.set_xticks(x, [o.name for o in outcomes], rotation=45, ha="right")
        ax.set_xlabel("subject (no heights in the subject files)")
    ax.set_ylabel("identified length [mm]")
    ax.set_title("Segment lengths across subjects")
    ax.legend(fontsize=7)
    return _save(fig, path)


@held_interrupts
def _plot_rmse(path: Path, rows: Sequence[TrialRow]) -> Path:
    done = [(r, r.ik_rmse) for r in rows if r.ik_rmse is not None]
    fig = _figure((1200, 700))
    ax = fig.add_subplot()
    ax.bar(np.arange(len(done)), [rmse * 1e3 for _, rmse in done])
    ax.set_xticks(
        np.arange(len(done)),
        [f"{r.subject}/{r.trial}" for r, _ in done],
        rotation=60,
        ha="right",
        fontsize=6,
    )
    ax.set_ylabel("IK marker RMSE [mm]")
    ax.set_title("Marker RMSE per trial, subject's identified model")
    return _save(fig, path)
