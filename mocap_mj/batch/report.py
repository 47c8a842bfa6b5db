"""The dataset summary of a batch: ``summary.csv`` (one row per subject and trial) and
``report.md`` with figures across subjects (segment lengths, against height when the subject
files give it; marker RMSE per trial)."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.io.plots import _figure, _save, held_interrupts

from ..io.atomic import atomic_write_text
from .run import Outcome

#: Columns of summary.csv. RMSE in mm, times in s; ``parameters_at_bounds`` names the
#: kinematic parameters at or outside their range (';'-separated); ``marker_quality`` the
#: trial's marker-data findings (``none``, or their count and the markers they name:
#: :mod:`mocap_mj.capture.marker_quality`); ``resumed`` is true for a
#: subject whose complete result was kept from an earlier run.
COLUMNS = (
    "subject",
    "trial",
    "status",
    "resumed",
    "frames",
    "identify_rmse_mm",
    "ik_rmse_mm",
    "identify_seconds",
    "ik_seconds",
    "parameters_at_bounds",
    "marker_quality",
    "error",
)
#: Segment lengths drawn across subjects in report.md.
SEGMENTS = ("thigh_length_l", "shank_length_l", "upperarm_length_l", "forearm_length_l")


def summary_rows(outcomes: Sequence[Outcome]) -> list[dict[str, Any]]:
    rows = []
    for o in outcomes:
        for r in o.record.get("rows", []):
            row = {c: r.get(c, "") for c in COLUMNS}
            row["subject"] = o.name
            row["resumed"] = o.status == "resumed"
            rows.append(row)
    return rows


def write_summary_csv(path: Path, outcomes: Sequence[Outcome]) -> list[dict[str, Any]]:
    rows = summary_rows(outcomes)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(v) for k, v in row.items()})
    atomic_write_text(path, buf.getvalue())
    return rows


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4f}" if np.isfinite(value) else ""
    if isinstance(value, list | tuple):
        return ";".join(str(v) for v in value)
    return str(value)


def write_report(out: Path, outcomes: Sequence[Outcome], seconds: float) -> Path:
    """report.md with a table per subject and two figures; returns its path."""
    ok = [o for o in outcomes if o.status != "failed"]
    failed = [o for o in outcomes if o.status == "failed"]
    rows = summary_rows(outcomes)
    bad_trials = [r for r in rows if r["status"] != "ok"]
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
        ident = o.record.get("identify", {})
        trs = o.record.get("rows", [])
        ik = [r["ik_rmse_mm"] for r in trs if isinstance(r.get("ik_rmse_mm"), float)]
        lines.append(
            f"| {o.name} | {o.status} | {len(trs)} | {_num(ident.get('marker_rmse_mm'))} | "
            f"{_num(float(np.mean(ik)) if ik else None)} | {_num(o.record.get('seconds'))} | "
            f"{o.record.get('error', '')} |"
        )
    if bad_trials:
        lines += ["", "Failed trials:", ""]
        lines += [f"- {r['subject']} / {r['trial']}: {r['error']}" for r in bad_trials]
    figures = []
    if ok:
        figures.append(_plot_segments(out / "segments.png", ok))
    if any(isinstance(r.get("ik_rmse_mm"), float) for r in rows):
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
        y = [o.record.get("identify", {}).get("kappa_mm", {}).get(name, np.nan) for o in outcomes]
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
def _plot_rmse(path: Path, rows: Sequence[dict[str, Any]]) -> Path:
    done = [r for r in rows if isinstance(r.get("ik_rmse_mm"), float)]
    fig = _figure((1200, 700))
    ax = fig.add_subplot()
    ax.bar(np.arange(len(done)), [r["ik_rmse_mm"] for r in done])
    ax.set_xticks(
        np.arange(len(done)),
        [f"{r['subject']}/{r['trial']}" for r in done],
        rotation=60,
        ha="right",
        fontsize=6,
    )
    ax.set_ylabel("IK marker RMSE [mm]")
    ax.set_title("Marker RMSE per trial, subject's identified model")
    return _save(fig, path)
