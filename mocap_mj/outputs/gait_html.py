"""report.html, the gait report a lab hands out, and the writing of the report's files.

One self-contained page (no script, no link out; its figures PNG in ``data:`` URIs): the
trials and their events, the cycles and those dropped, the kinematics page, the kinetics page
when some cycle has plate loads, the spatiotemporal table (each side's mean and sd), the
scores (or why there are none) and the subject values with their sources.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.clinical.gait_scores import GPS_VARIABLES, Normative, Scores, scores
from mocap_mj.clinical.spatiotemporal import PARAMETERS, summary_rows
from mocap_mj.io.atomic import atomic_write_text

from .gait_figures import KINEMATIC_PANELS, KINETIC_PANELS, page_png
from .gait_report import TrialCycles, cycles_csv, implausible, scores_csv, spatiotemporal_csv

__all__ = ["pooled_scores", "report_html", "write_gait_report"]

_STYLE = (
    "body{font-family:sans-serif;margin:1.5em;max-width:1100px}"
    "table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}"
    "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}"
    "th:first-child,td:first-child{text-align:left}img{max-width:100%}"
)


def pooled_scores(trials: Sequence[TrialCycles], normative: Normative | None) -> Scores | str:
    """The scores of every trial's cycles against ``normative``, or why there are none."""
    if normative is None:
        return "no --normative file: the scores (GVS, GPS) need a normative set"
    pooled = {}
    for i, t in enumerate(trials):
        for (side, number, name), v in t.angles.items():
            pooled[(side, 1000 * i + number, name)] = v
    if not pooled:
        return "no complete gait cycle: no scores"
    return scores(pooled, normative)


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<img class="plot" alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in rows
    )
    return f"<table><tr>{cells}</tr>{body}</table>"


def _number(value: float, digits: int = 3) -> str:
    return f"{value:.{digits}g}" if np.isfinite(value) else "n/a"


def _spatiotemporal(trials: Sequence[TrialCycles]) -> str:
    rows = [(c.side, p) for t in trials for c, p in zip(t.cycles, t.parameters, strict=True)]
    stats = summary_rows(rows)
    sides = list(stats)
    body = [
        [name, *(f"{_number(stats[s][name][0])} ± {_number(stats[s][name][1])}" for s in sides)]
        for name in PARAMETERS
    ]
    return _table(["parameter (mean ± sd)", *sides], body)


def _scores(result: Scores | str) -> str:
    if isinstance(result, str):
        return f"<p>Scores omitted: {html.escape(result)}.</p>"
    names = dict(GPS_VARIABLES)
    body = []
    for variable, label in names.items():
        left = result.gvs.get(("left", variable))
        right = result.gvs.get(("right", variable))
        body.append([f"GVS {label}", *(_number(np.degrees(v[0])) if v else "(left)"
                                       for v in (left, right))])  # fmt: skip
    body.append(["GPS", *(_number(np.degrees(result.gps[s])) for s in ("left", "right"))])
    return _table(["score [deg]", "left", "right"], body) + (
        f"<p>Overall GPS: {_number(np.degrees(result.gps['overall']))} deg.</p>"
    )


def report_html(
    trials: Sequence[TrialCycles],
    normative: Normative | None,
    result: Scores | str,
    subject: Mapping[str, Mapping[str, Any]],
    notes: Sequence[str] = (),
) -> str:
    """report.html's text (module docstring); ``subject``: name -> {value, unit, source}."""
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>Gait report</title>"
             f"<style>{_STYLE}</style></head><body><h1>Gait report</h1>"]  # fmt: skip
    for t in trials:
        left = sum(c.side == "left" for c in t.cycles)
        source = t.cycles[0].source if t.cycles else "none"
        parts.append(
            f"<p><b>{html.escape(t.name)}</b>: {left} left and {len(t.cycles) - left} right "
            f"cycles; events: {html.escape(source)}.</p>"
        )
    lines = [*notes, *(d for t in trials for d in t.dropped)]
    if lines:
        parts.append("<ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in lines) + "</ul>")
    band = "normative mean ± 1 sd grey" if normative else "no normative set"
    parts.append(f"<h2>Kinematics</h2><p>Left red, right green; each cycle thin, the mean "
                 f"thick; foot off dashed; {band}.</p>")  # fmt: skip
    parts.append(_img(page_png(KINEMATIC_PANELS, trials, normative=normative), "kinematics"))
    parts.append("<h2>Kinetics</h2>")
    if any(t.kinetics for t in trials):
        png = page_png(KINETIC_PANELS, trials, kinetic=True, normative=normative)
        parts.append(_img(png, "kinetics"))
    else:
        parts.append("<p>No cycle with its stance on a counted force plate: no kinetics.</p>")
    parts.append("<h2>Spatiotemporal parameters</h2>" + _spatiotemporal(trials))
    parts.append("<h2>Scores (Baker et al. 2009)</h2>" + _scores(result))
    rows = [[n, _number(float(v["value"]), 6), str(v["unit"]), str(v["source"])]
            for n, v in subject.items()]  # fmt: skip
    table = (
        _table(["name", "value", "unit", "source"], rows)
        if rows
        else ("<p>None: the angles are the identified model's, which needs no measurement.</p>")
    )
    parts.append("<h2>Subject values</h2>" + table)
    return "".join(parts) + "</body></html>\n"


def write_gait_report(
    out: Path,
    trials: Sequence[TrialCycles],
    normative: Normative | None,
    subject: Mapping[str, Mapping[str, Any]],
    notes: Sequence[str] = (),
) -> dict[str, Any]:
    """cycles.csv, spatiotemporal.csv, scores.csv (with a normative set) and report.html
    into ``out``; summary.json's ``gait_report`` entry."""
    result = pooled_scores(trials, normative)
    atomic_write_text(out / "cycles.csv", cycles_csv(trials))
    atomic_write_text(out / "spatiotemporal.csv", spatiotemporal_csv(trials))
    files = ["cycles.csv", "spatiotemporal.csv"]
    if not isinstance(result, str):
        atomic_write_text(out / "scores.csv", scores_csv(result))
        files.append("scores.csv")
    bad = implausible(trials)
    lines = [*(f"implausible: {b}" for b in bad), *notes]
    atomic_write_text(out / "report.html", report_html(trials, normative, result, subject, lines))
    files.append("report.html")
    return {
        "files": files,
        "cycles": {t.name: _counts(t) for t in trials},
        "dropped": [d for t in trials for d in t.dropped],
        "normative": normative.source if normative else None,
        "scores_omitted": result if isinstance(result, str) else None,
        "gps_deg": None if isinstance(result, str) else _degrees(result.gps),
        "implausible": bad,
    }


def _counts(trial: TrialCycles) -> dict[str, int]:
    return {s: sum(c.side == s for c in trial.cycles) for s in ("left", "right")}


def _degrees(values: Mapping[str, float]) -> dict[str, float]:
    return {k: float(np.degrees(v)) for k, v in values.items()}
