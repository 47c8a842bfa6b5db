"""Plug-in Gait's result files: angle and joint-centre tables (CSV), the C3D with the points
under Vicon's names, and the report. Conversion to mm and degrees happens here only.

Tables: ``frame`` (the recording's own frame number), ``time_s``, then ``<Name>_X``,
``_Y``, ``_Z`` per angle [deg] or per point [mm, the recording's lab frame]; an empty cell
where a value could not be computed (a marker missing in that frame).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mocap_mj.clinical.model import PigResult
from mocap_mj.clinical.tables import series_table

from ..export.c3d import write_points_c3d
from ..io.atomic import atomic_write_text

#: The points of joint_centres.csv: bone origins, then the proximal points.
CENTRE_POINTS = (
    "PELO", "LFEO", "RFEO", "LTIO", "RTIO", "LFOO", "RFOO", "LTOO", "RTOO", "TRXO", "HEDO",
    "LCLO", "RCLO", "LHUO", "RHUO", "LRAO", "RRAO", "LHNO", "RHNO",
    "LFEP", "RFEP", "LTIP", "RTIP", "LHUP", "RHUP", "LRAP", "RRAP", "LHNP", "RHNP",
)  # fmt: skip


def angles_csv(result: PigResult) -> str:
    """angles.csv text: every angle in degrees."""
    return series_table(result.frames, result.times, result.angles, 180.0 / np.pi)


def centres_csv(result: PigResult) -> str:
    """joint_centres.csv text: the bone origins and proximal points in mm."""
    pts = {n: result.points[n] for n in CENTRE_POINTS if n in result.points}
    return series_table(result.frames, result.times, pts, 1e3)


def write_result_c3d(path: Path, result: PigResult, rate: float) -> None:
    """result.c3d: the bone points [mm] and the angles [deg] under Vicon's names."""
    points = sorted(result.points)
    angles = sorted(result.angles)
    values = np.concatenate(
        [np.stack([result.points[n] * 1e3 for n in points], axis=1),
         np.stack([np.degrees(result.angles[n]) for n in angles], axis=1)],
        axis=1,
    )  # fmt: skip
    write_points_c3d(
        path,
        labels=points + angles,
        descriptions=["Plug-in Gait bone point"] * len(points)
        + ["Plug-in Gait angle"] * len(angles),
        values=values,
        rate=rate,
        angle_labels=angles,
        modeled=points,
        first_frame=int(result.frames[0]) if len(result.frames) else 0,
    )


def report_md(result: PigResult, source: str) -> str:
    """report.md: what was computed, from which values, and the angle ranges."""
    lines = [
        f"# Plug-in Gait: {source}",
        "",
        f"- frames {int(result.frames[0])}..{int(result.frames[-1])} ({len(result.frames)})"
        if len(result.frames)
        else "- no frames",
        f"- processed as a {'static' if result.static else 'dynamic'} trial",
        f"- direction of progression (lab): {np.round(result.progression, 3).tolist()}",
        *(f"- {n}" for n in result.notes),
        "",
        "## Subject values",
        "",
        "| name | value | unit | source |",
        "|---|---|---|---|",
    ]
    for name, v in result.subject.to_dict().items():
        lines.append(f"| {name} | {v['value']:.6g} | {v['unit']} | {v['source']} |")
    lines += ["", "## Angles (deg): min / max over the trial", "", "| angle | X | Y | Z |",
              "|---|---|---|---|"]  # fmt: skip
    for name in sorted(result.angles):
        a = np.degrees(result.angles[name])
        cells = []
        for k in range(3):
            col = a[:, k][np.isfinite(a[:, k])]
            cells.append(f"{col.min():.1f} / {col.max():.1f}" if len(col) else "n/a")
        lines.append(f"| {name} | {' | '.join(cells)} |")
    return "\n".join(lines) + "\n"


def write_all(out: Path, result: PigResult, rate: float, source: str) -> None:
    """Every result file into the folder ``out``."""
    atomic_write_text(out / "angles.csv", angles_csv(result))
    atomic_write_text(out / "joint_centres.csv", centres_csv(result))
    write_result_c3d(out / "result.c3d", result, rate)
    atomic_write_text(out / "report.md", report_md(result, source))
