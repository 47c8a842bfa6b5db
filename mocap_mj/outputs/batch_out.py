"""The files of ``batch`` in millimetres: each subject's record (``subject.json``: its
identification's figures and a row per trial, :func:`identify_fields`, :func:`row_fields`)
and the dataset's summary.csv (:func:`write_summary_csv`), with the records read back in SI
(:func:`read_identify`, :func:`read_rows`) for the dataset's report."""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mocap_mj.io.atomic import atomic_write_text

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


@dataclass(frozen=True)
class TrialRow:
    """One trial of a batch's subject, in SI: its subject and file name, ``status`` (ok,
    failed, timed out) and ``error`` (one line); its frames, the identification's marker RMSE
    [m] and wall time [s], the kinematic parameters at or outside their range, the marker-data
    cell, the IK's marker RMSE [m] and wall time [s]: None where the trial has none (a file
    that could not be read, an IK that failed). ``resumed``: its subject's result was kept
    from an earlier run."""

    subject: str
    trial: str
    status: str = "failed"
    error: str = ""
    frames: int | None = None
    identify_rmse: float | None = None
    identify_seconds: float | None = None
    parameters_at_bounds: tuple[str, ...] | None = None
    marker_quality: str | None = None
    ik_rmse: float | None = None
    ik_seconds: float | None = None
    resumed: bool = False


def row_fields(row: TrialRow) -> dict[str, Any]:
    """A subject record's row of ``row`` (its RMSE in mm; the figures it has, in
    :class:`TrialRow`'s order)."""
    mm = {"identify_rmse": "identify_rmse_mm", "ik_rmse": "ik_rmse_mm"}
    out: dict[str, Any] = {}
    for name in TrialRow.__dataclass_fields__:
        value = getattr(row, name)
        if name == "resumed" or value is None:
            continue
        if name in mm:
            out[mm[name]] = value * 1e3
        else:
            out[name] = list(value) if isinstance(value, tuple) else value
    return out


def read_rows(record: Mapping[str, Any], subject: str, resumed: bool) -> list[TrialRow]:
    """The rows of a subject's record (:func:`row_fields`' or a failed job's) in SI, as
    ``subject``'s and ``resumed`` or not."""
    out = []
    for r in record.get("rows", []):
        bounds = r.get("parameters_at_bounds")
        out.append(
            TrialRow(
                subject, str(r.get("trial", "")), str(r.get("status", "")),
                error=str(r.get("error", "")),
                frames=r.get("frames"),
                identify_rmse=_metres(r.get("identify_rmse_mm")),
                identify_seconds=r.get("identify_seconds"),
                parameters_at_bounds=None if bounds is None else tuple(bounds),
                marker_quality=r.get("marker_quality"),
                ik_rmse=_metres(r.get("ik_rmse_mm")),
                ik_seconds=r.get("ik_seconds"),
                resumed=resumed,
            )
        )  # fmt: skip
    return out


def _metres(mm: Any) -> float | None:
    """A record's figure in mm as metres (None: absent); divided, so that the metres written
    again in mm give the record's figure back."""
    return float(mm) / 1e3 if isinstance(mm, float | int) else None


def identify_fields(
    marker_rmse: float,
    seconds: float | None,
    iterations: int,
    termination: str,
    kappa: Mapping[str, float],
    implausible: Any,
) -> dict[str, Any]:
    """A subject record's ``identify``: the fit's marker RMSE ``marker_rmse`` [m] and its
    kinematic parameters ``kappa`` (name -> [m]) in mm, its wall time [s], iterations,
    termination and the reasons it is implausible (summary.json's)."""
    return {
        "marker_rmse_mm": marker_rmse * 1e3,
        "seconds": seconds,
        "iterations": iterations,
        "termination": termination,
        "kappa_mm": {n: v * 1e3 for n, v in kappa.items()},
        "implausible": implausible,
    }


class IdentifyFigures(NamedTuple):
    """A subject record's identification read back (:func:`read_identify`), in SI: its
    marker RMSE [m] (None: none recorded) and kinematic parameters (name -> [m])."""

    marker_rmse: float | None
    kappa: dict[str, float]


def read_identify(record: Mapping[str, Any]) -> IdentifyFigures:
    """The identification's figures of a subject's record (:func:`identify_fields`, mm) in
    SI (empty for a subject whose job failed)."""
    ident = record.get("identify") or {}
    kappa = ident.get("kappa_mm") or {}
    return IdentifyFigures(
        _metres(ident.get("marker_rmse_mm")), {n: float(v) / 1e3 for n, v in kappa.items()}
    )


def write_summary_csv(path: Path, rows: Sequence[TrialRow]) -> None:
    """summary.csv (:data:`COLUMNS`) of ``rows``: RMSE in mm, figures to 4 decimals, empty
    cells where a row has none."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        fields = {**row_fields(row), "subject": row.subject, "resumed": row.resumed}
        writer.writerow({c: _cell(fields.get(c, "")) for c in COLUMNS})
    atomic_write_text(path, buf.getvalue())


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4f}" if np.isfinite(value) else ""
    if isinstance(value, list | tuple):
        return ";".join(str(v) for v in value)
    return str(value)
