"""Plug-in Gait's result files: angle and joint-centre tables (CSV), the C3D with the points
under Vicon's names, and the report. Conversion to mm and degrees happens here only.

Tables: ``frame`` (the recording's own frame number), ``time_s``, then ``<Name>_X``,
``_Y``, ``_Z`` per angle [deg] or per point [mm, the recording's lab frame]; an empty cell
where a value could not be computed (a marker missing in that frame). ``kinetics.csv``: the
kinetic outputs normalised by the body mass, in SI units (N m/kg, W/kg, N/kg, % body
weight), and the whole-body centre of mass ``CentreOfMass``, ``CentreOfMassFloor`` [mm, the
recording's lab frame]; result.c3d holds them in Vicon's units (moments in N mm/kg, the
centre of mass as points in mm).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mocap_mj.clinical.centre_of_mass import COM_NAMES
from mocap_mj.clinical.model import PigResult
from mocap_mj.clinical.subject import pig_dict
from mocap_mj.clinical.tables import series_table

from ..export.c3d import C3DPoints, write_points_c3d
from ..io.atomic import atomic_write_text

#: The points of joint_centres.csv: every bone's origin, then its proximal point.
CENTRE_POINTS = (
    "PELO", "LFEO", "RFEO", "LTIO", "RTIO", "LFOO", "RFOO", "LTOO", "RTOO", "TRXO", "HEDO",
    "LCLO", "RCLO", "LHUO", "RHUO", "LRAO", "RRAO", "LHNO", "RHNO",
    "PELP", "LFEP", "RFEP", "LTIP", "RTIP", "LFOP", "RFOP", "LTOP", "RTOP", "TRXP", "HEDP",
    "LCLP", "RCLP", "LHUP", "RHUP", "LRAP", "RRAP", "LHNP", "RHNP",
)  # fmt: skip


def angles_csv(result: PigResult) -> str:
    """angles.csv text: every angle in degrees."""
    return series_table(result.frames, result.times, result.angles, 180.0 / np.pi)


def centres_csv(result: PigResult) -> str:
    """joint_centres.csv text: the bone origins and proximal points in mm."""
    pts = {n: result.points[n] for n in CENTRE_POINTS if n in result.points}
    return series_table(result.frames, result.times, pts, 1e3)


#: Kinetic outputs per Vicon group: the name endings, its unit in result.c3d and the scale
#: from ours (N/kg, N m/kg, W/kg) to it.
C3D_KINETIC = {
    "FORCES": (("Force", "GRF"), "N/kg", 1.0),
    "MOMENTS": (("Moment",), "Nmm/kg", 1e3),
    "POWERS": (("Power",), "W/kg", 1.0),
}


def kinetics_csv(result: PigResult, kinetics: dict[str, np.ndarray]) -> str:
    """kinetics.csv text: every kinetic output in its SI unit per kg (% body weight for
    ``NormalisedGRF``), the centre of mass points (:data:`COM_NAMES`, held in m) in mm."""
    table = {n: v * (1e3 if n in COM_NAMES else 1.0) for n, v in sorted(kinetics.items())}
    return series_table(result.frames, result.times, table, 1.0)


def _kinetic_description(name: str) -> str:
    unit = "% body weight" if name.endswith("NormalisedGRF") else "per kg body mass"
    return f"Plug-in Gait kinetics, {unit}"


def write_result_c3d(
    path: Path, result: PigResult, rate: float, kinetics: dict[str, np.ndarray] | None = None
) -> None:
    """result.c3d: the bone points and the centre of mass points of ``kinetics``
    (:data:`COM_NAMES`) [mm], the angles [deg] and the kinetic outputs (Vicon's units: N/kg,
    N mm/kg, W/kg) under Vicon's names."""
    coms = [n for n in COM_NAMES if n in (kinetics or {})]
    points = sorted(result.points)
    angles = sorted(result.angles)
    columns = [result.points[n] * 1e3 for n in points]
    columns += [(kinetics or {})[n] * 1e3 for n in coms]
    columns += [np.degrees(result.angles[n]) for n in angles]
    groups: dict[str, tuple[list[str], str]] = {}
    for group, (endings, unit, scale) in C3D_KINETIC.items():
        names = sorted(n for n in kinetics or {} if n.endswith(endings))
        if names:
            groups[group] = (names, unit)
            columns += [(kinetics or {})[n] * scale for n in names]
    extra = [n for names, _ in groups.values() for n in names]
    descriptions = (
        ["Plug-in Gait bone point"] * len(points)
        + ["Plug-in Gait whole-body centre of mass"] * len(coms)
        + ["Plug-in Gait angle"] * len(angles)
        + [_kinetic_description(n) for n in extra]
    )
    first_frame = int(result.frames[0]) if len(result.frames) else 0
    write_points_c3d(
        path,
        C3DPoints(
            points + coms + angles + extra,
            descriptions,
            np.stack(columns, axis=1),
            rate,
            first_frame,
        ),
        angle_labels=angles,
        modeled=points + coms,
        kinetic=groups,
    )


def report_md(
    result: PigResult,
    source: str,
    kinetics: dict[str, np.ndarray] | None = None,
    notes: Sequence[str] = (),
) -> str:
    """report.md: what was computed, from which values, the angle ranges and, with
    ``kinetics``, the peak moments and powers (``notes``: why contacts were left out)."""
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
    for name, v in pig_dict(result.subject).items():
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
    lines += _kinetics_lines(kinetics, notes)
    return "\n".join(lines) + "\n"


def _kinetics_lines(kinetics: dict[str, np.ndarray] | None, notes: Sequence[str]) -> list[str]:
    """report.md's kinetics section: min / max of each moment [N m/kg] and power [W/kg]."""
    lines = ["", "## Kinetics (kinetics.csv): min / max over the trial", ""]
    coms = [n for n in COM_NAMES if n in (kinetics or {})]
    if coms:
        lines += [f"- {', '.join(coms)}: the whole-body centre of mass [mm], in kinetics.csv "
                  "and result.c3d"]  # fmt: skip
    if not kinetics or not set(kinetics) - set(coms):
        return [*lines, *(f"- {n}" for n in notes or ["no force plates: no kinetics"])]
    lines += [*(f"- {n}" for n in notes), *([""] if notes or coms else [])]
    lines += ["| output | X | Y | Z |", "|---|---|---|---|"]
    for name in sorted(n for n in kinetics if n.endswith(("Moment", "Power"))):
        cells = []
        for k in range(3):
            col = kinetics[name][:, k][np.isfinite(kinetics[name][:, k])]
            cells.append(f"{col.min():.3f} / {col.max():.3f}" if len(col) else "n/a")
        lines.append(f"| {name} | {' | '.join(cells)} |")
    return lines


def write_all(
    out: Path,
    result: PigResult,
    rate: float,
    source: str,
    kinetics: dict[str, np.ndarray] | None = None,
    notes: Sequence[str] = (),
) -> None:
    """Every result file into the folder ``out`` (kinetics.csv when ``kinetics`` is given;
    ``notes``: the kinetics' notes for report.md)."""
    atomic_write_text(out / "angles.csv", angles_csv(result))
    atomic_write_text(out / "joint_centres.csv", centres_csv(result))
    if kinetics:
        atomic_write_text(out / "kinetics.csv", kinetics_csv(result, kinetics))
    write_result_c3d(out / "result.c3d", result, rate, kinetics)
    atomic_write_text(out / "report.md", report_md(result, source, kinetics, notes))
