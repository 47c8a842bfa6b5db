"""A normative set and the scores against it: the Gait Variable Scores and the Gait Profile
Score (Baker et al. 2009, Gait Posture 30:265).

**The normative file** (``--normative``): CSV with the header ``variable,percent,mean,sd``
and a row per variable and point of the cycle: ``variable`` is a cycles.csv variable without
its side (``KneeAngles_X``, ``HipMoment_X``...), ``percent`` the point [% of the cycle,
0-100, ascending per variable, any spacing: interpolated to the 101 points], ``mean`` and
``sd`` (>= 0) in cycles.csv's units (degrees for angles, N m/kg, W/kg). One set serves both
sides, as Plug-in Gait writes each side's angles in its own sign convention.

**The scores.** A Gait Variable Score (GVS) is the RMS over the cycle's 101 points of one
cycle's curve minus the normative mean [deg]; a side's GVS of a variable is its mean over
the side's cycles. The nine variables (:data:`GPS_VARIABLES`): pelvic tilt, obliquity and
rotation, hip flexion, adduction and rotation, knee flexion, ankle dorsiflexion and foot
progression. The pelvis counts on one side, the left (its two sides mirror each other): a
side's Gait Profile Score (GPS) is the RMS of the left pelvis's three GVS and the side's six
others; the overall GPS the RMS of the fifteen (the pelvis's three, each side's six).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mocap_mj.errors import InputFileError

from .cycles import PERCENT

__all__ = [
    "GPS_VARIABLES",
    "HEADER",
    "Normative",
    "Scores",
    "read_normative",
    "scores",
    "unit_scale",
]

HEADER = ("variable", "percent", "mean", "sd")
#: The nine kinematic variables of the GPS: (cycles.csv variable, its clinical name).
GPS_VARIABLES = (
    ("PelvisAngles_X", "pelvic tilt"), ("PelvisAngles_Y", "pelvic obliquity"),
    ("PelvisAngles_Z", "pelvic rotation"), ("HipAngles_X", "hip flexion"),
    ("HipAngles_Y", "hip adduction"), ("HipAngles_Z", "hip rotation"),
    ("KneeAngles_X", "knee flexion"), ("AnkleAngles_X", "ankle dorsiflexion"),
    ("FootProgressAngles_Z", "foot progression"),
)  # fmt: skip
PELVIS = ("PelvisAngles_X", "PelvisAngles_Y", "PelvisAngles_Z")
SIDES = ("left", "right")


def unit_scale(variable: str) -> float:
    """The factor from a variable's SI value to its files' unit: degrees for an angle, 1
    for the kinetics (already per kg in SI)."""
    return 180.0 / np.pi if "Angles" in variable else 1.0


@dataclass(frozen=True)
class Normative:
    """A normative set: ``source`` (the file), variable -> (mean (101,), sd (101,)) in SI
    (rad for angles) on the cycle's 101 points."""

    source: str
    curves: dict[str, tuple[np.ndarray, np.ndarray]]


def read_normative(path: str | os.PathLike[str]) -> Normative:
    """The normative file ``path`` (module docstring).

    Raises
    ------
    InputFileError
        The file cannot be read, its header is not :data:`HEADER`, a row is not a variable
        and three numbers (sd >= 0, percent in 0-100 and ascending per variable), or a
        variable has under two points (the message names the line).
    """
    file = Path(path)
    try:
        lines = file.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{file}: cannot read: {exc}") from None
    if not lines or tuple(c.strip() for c in lines[0].split(",")) != HEADER:
        raise InputFileError(f"{file}: line 1: expected the header {','.join(HEADER)}")
    points: dict[str, list[tuple[float, float, float]]] = {}
    for i, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = [c.strip() for c in line.split(",")]
        try:
            name, pct, mean, sd = cells[0], *(float(c) for c in cells[1:])
        except ValueError:
            name, pct, mean, sd = "", np.nan, np.nan, np.nan
        seen = points.setdefault(name, [])
        ok = (
            len(cells) == 4 and name and np.isfinite([pct, mean, sd]).all() and sd >= 0
            and 0 <= pct <= 100 and (not seen or pct > seen[-1][0])
        )  # fmt: skip
        if not ok:
            raise InputFileError(
                f"{file}: line {i}: expected a variable, a percent (0-100, ascending per "
                f"variable), a mean and an sd >= 0, got {line[:60]!r}"
            )
        seen.append((pct, mean, sd))
    curves = {}
    for name, rows in points.items():
        if len(rows) < 2:
            raise InputFileError(f"{file}: {name}: expected at least two points of the cycle")
        at, means, sds = (np.array(c) for c in zip(*rows, strict=True))
        scale = unit_scale(name)
        curves[name] = (np.interp(PERCENT, at, means) / scale, np.interp(PERCENT, at, sds) / scale)
    return Normative(str(file), curves)


@dataclass(frozen=True)
class Scores:
    """The scores: ``gvs`` (side, variable) -> (mean GVS [rad], cycles counted); ``gps``
    ``left``, ``right``, ``overall`` -> GPS [rad] (NaN when a GVS is missing)."""

    gvs: dict[tuple[str, str], tuple[float, int]]
    gps: dict[str, float]


def scores(curves: Mapping[tuple[str, int, str], np.ndarray], normative: Normative) -> Scores | str:
    """The GVS and GPS (module docstring) of the cycles' ``curves`` ((side, cycle, variable
    without its side's prefix, e.g. ``KneeAngles``) -> (101, 3) [rad], as
    :func:`~mocap_mj.clinical.cycles.resample_all` gives them) against ``normative``; a
    line saying why when they cannot be computed."""
    lacking = [v for v, _ in GPS_VARIABLES if v not in normative.curves]
    if lacking:
        return f"{normative.source}: no normative curve of {', '.join(lacking)}: no GVS or GPS"
    gvs: dict[tuple[str, str], tuple[float, int]] = {}
    for side in SIDES:
        for variable, _ in GPS_VARIABLES:
            if side == "right" and variable in PELVIS:
                continue
            name, axis = variable[:-2], "XYZ".index(variable[-1])
            mean = normative.curves[variable][0]
            values = [
                float(np.sqrt(np.mean((c[:, axis] - mean) ** 2)))
                for (s, _, n), c in curves.items()
                if s == side and n == name and np.isfinite(c[:, axis]).all()
            ]
            gvs[(side, variable)] = (float(np.mean(values)) if values else np.nan, len(values))
    pelvis = [gvs[("left", v)][0] for v in PELVIS]
    legs = {s: [gvs[(s, v)][0] for v, _ in GPS_VARIABLES if v not in PELVIS] for s in SIDES}

    def rms(values: list[float]) -> float:
        return float(np.sqrt(np.mean(np.square(values))))

    gps = {
        "left": rms(pelvis + legs["left"]),
        "right": rms(pelvis + legs["right"]),
        "overall": rms(pelvis + legs["left"] + legs["right"]),
    }
    return Scores(gvs, gps)
