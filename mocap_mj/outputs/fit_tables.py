"""report.md's tables of an identification's sections, from summary.json's entries (mm):
the flexion axes, the hinge centres against their construction, the segment lengths and
their uncertainty; and segments.csv."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from mocap_mj.anatomy.partial import NOT_MEASURED
from mocap_mj.anatomy.segments import SegmentRow

from ..io.atomic import atomic_write_text

#: Columns of ``segments.csv``.
COLUMNS = (
    "name",
    "kind",
    "value_mm",
    "std_white_mm",
    "std_mm",
    "std_priors_mm",
    "nominal_mm",
    "lower_mm",
    "upper_mm",
    "flag",
)


def write_segments_csv(path: str | Path, rows: Sequence[SegmentRow]) -> None:
    """``segments.csv`` (columns :data:`COLUMNS`, millimetres, empty where not applicable)."""
    lines = [",".join(COLUMNS)]
    for r in rows:
        nums = (r.value, r.std_white, r.std, r.std_priors, r.nominal, r.lower, r.upper)
        cells = ["" if not math.isfinite(v) else f"{v * 1e3:.3f}" for v in nums]
        lines.append(",".join([r.name, r.kind, *cells, r.flag]))
    atomic_write_text(path, "\n".join(lines) + "\n")


#: Joint -> Plug-in Gait's construction of its flexion axis, as report.md names it.
CONSTRUCTION = {"knee": "the chord plane", "ankle": "the chord plane",
                "elbow": "through ELB", "wrist": "the wrist bar"}  # fmt: skip


def axis_lines(decisions: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """report.md's lines on the flexion axes (summary.json's ``joint_axes``; empty without
    decisions)."""
    if not decisions:
        return []
    lines = [
        "| joint | axis from | data sd (deg) | row sd (deg) | angle to Plug-in Gait's (deg) "
        "| marker RMSE (mm): this axis / Plug-in Gait's row "
        "| varus on flexion: this axis | Plug-in Gait's |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for joint, d in decisions.items():
        how = CONSTRUCTION[d["joint"].split("_")[0]]
        src = f"Plug-in Gait ({how})" if d["source"] == "plug-in-gait" else "the markers"
        if d.get("silent"):
            src += ", held: the data are silent"
        if d.get("conflict"):
            src += f" (they contradict {how})"
        rmse = d.get("rmse_mm") or {}
        both = (rmse.get("functional"), rmse.get("plug_in_gait_row"))
        fit = "-" if None in both else f"{both[0]:.2f} / {both[1]:.2f}"
        lines.append(
            f"| {joint} | {src} | {d['data_sd_deg']:.1f} | {d['row_sd_deg']:.1f} | "
            f"{d['angle_to_pig_deg']:+.1f} | {fit} | {_crosstalk_text(d.get('crosstalk_model'))} | "
            f"{_crosstalk_text(d.get('crosstalk_pig'))} |"
        )
    return lines


def _crosstalk_text(c: Mapping[str, float] | None) -> str:
    return "-" if not c else f"r {c['corr']:+.2f}, slope {c['slope']:+.2f}"


def hinge_lines(centres: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """report.md's table of :func:`hinge_report` (empty without entries)."""
    if not centres:
        return []
    lines = ["", "Hinge centres against their construction (x towards the lateral marker, z normal "
             "to it and the segment's second marker, mm; "
             "docs/model.md#the-constructions-start-and-prior):", "",
             "| joint | construction | constructed | identified | distance (mm) | sd (mm) "
             "| moved by the data |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for joint, c in centres.items():
        xyz = [" ".join(f"{v:.1f}" for v in c[k]) for k in ("construction_mm", "identified_mm")]
        lines.append(f"| {joint} | {c['construction']} | {xyz[0]} | {xyz[1]} | "
                     f"{c['distance_mm']:.1f} | {c['distance_sd_mm']:.1f} | "
                     f"{'yes' if c['moved_by_data'] else 'no'} |")  # fmt: skip
    return lines


def uncertainty_lines(summary: Mapping[str, Any]) -> list[str]:
    """report.md section rendered from the entries of :func:`uncertainty_summary` (none if
    ``summary`` has no ``segments``)."""
    segments = summary.get("segments")
    if not segments:
        return []
    tau = summary["correlation_time_frames"]

    def cell(v: float | None, fmt: str = ".1f") -> str:
        return "" if v is None else format(v, fmt)

    lines = [
        "## Segment lengths and their uncertainty",
        "",
        f"Residual correlation time: {tau:.1f} frames (white noise gives about 1). Standard "
        "deviations: `white` assumes independent frames (the Cramer-Rao figure); `inflated` "
        "divides the information by the correlation time, the honest figure of what the data "
        "tell on real recordings (soft-tissue artefact repeats over neighbouring frames); both "
        "include only the weak prior toward the initial model, so a length the motion does "
        "not determine shows that prior's width. `with priors` adds the anatomical priors the "
        "fit used: the uncertainty of the estimate; where it is much smaller than `inflated`, "
        "the priors, not the motion, place the length. All values also in segments.csv.",
        "",
        "| length (joint centre to joint centre) | value (mm) | std with priors (mm) | "
        "std inflated (mm) | std white (mm) | nominal (mm) | flagged parameters |",
        "|---|---:|---:|---:|---:|---:|---|",
    ]
    held = [n for n, r in segments.items() if r["kind"] == "length" and r["flag"] == NOT_MEASURED]
    for name, r in segments.items():
        if r["kind"] == "length" and name not in held:
            lines.append(
                f"| {name} | {cell(r['value_mm'])} | {cell(r.get('std_priors_mm'))} | "
                f"{cell(r['std_mm'])} | {cell(r['std_white_mm'])} | {cell(r['nominal_mm'])} | "
                f"{r['flag']} |"
            )
    if held:
        lines += ["", f"{len(held)} lengths not measured (held at the prior, flagged "
                  f"`{NOT_MEASURED}` in segments.csv) are not listed: "
                  f"{', '.join(held)}."]  # fmt: skip
    flagged = summary.get("parameters_flagged", {})
    lines += ["", "### Parameters at a bound or outside the plausible range", ""]
    if not flagged:
        lines.append("None.")
    else:
        lines += [
            "| parameter | value (mm) | std inflated (mm) | range (mm) | flag |",
            "|---|---:|---:|---|---|",
        ]
        for name, flag in flagged.items():
            r = segments[name]
            lines.append(
                f"| {name} | {cell(r['value_mm'])} | {cell(r['std_mm'])} | "
                f"[{cell(r['lower_mm'], '.0f')}, {cell(r['upper_mm'], '.0f')}] | {flag} |"
            )
    worst = summary.get("worst_markers_mm", {})
    lines += ["", "### Worst-fitting markers (RMS distance over the fitted frames)", ""]
    lines.append(", ".join(f"{n} {v:.1f} mm" for n, v in worst.items()) or "None.")
    return [*lines, ""]
