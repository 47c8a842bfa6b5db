"""Our model's angles beside Plug-in Gait's: reading the reference angles (Vicon Nexus'
points in a C3D, or a ``mocap-mj plug-in-gait`` folder's angles.csv), aligning the frames,
and the figures per component: RMS difference, constant offset and correlation; and a knee's
varus-valgus / flexion crosstalk (:func:`crosstalk`).

Angles are in radians inside, degrees in the tables and figures; a difference is wrapped to
+-180 deg before it is averaged.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from pathlib import Path

import ezc3d
import numpy as np

from ..errors import InputFileError, MocapError
from ..io.formats.c3d import _point_labels, recording_first_frame

#: Knee flexion range [deg] (5th to 95th percentile) below which no crosstalk is reported.
CROSSTALK_MIN_RANGE = 20.0

#: The angle names both tables carry, side letter first (``LKneeAngles``).
ANGLE_SUFFIX = "Angles"


@dataclass(frozen=True)
class Reference:
    """Reference angles: frame numbers (T,) and Vicon name -> (T, 3) [rad], NaN where
    missing; ``source``: the file read."""

    frames: np.ndarray
    angles: dict[str, np.ndarray]
    source: str


def c3d_angles(path: str | Path) -> Reference:
    """The angle points of a C3D (``LKneeAngles``...: Vicon Nexus' Plug-in Gait output),
    frames numbered as the marker reader numbers them; no angle points give an empty
    mapping."""
    try:
        c = ezc3d.c3d(str(path))
    except (RuntimeError, OSError) as exc:
        raise InputFileError(f"{path}: cannot read as C3D ({exc})") from None
    labels = _point_labels(c["parameters"]["POINT"])
    xyz = np.transpose(c["data"]["points"][:3], (2, 1, 0)).astype(float)
    xyz[np.all(xyz == 0.0, axis=2)] = np.nan
    first = recording_first_frame(int(c["header"]["points"]["first_frame"]))
    angles = {}
    for i, label in enumerate(labels[: xyz.shape[1]]):
        name = label.split(":")[-1]  # Nexus prefixes a subject's points with "Subject:"
        if name.endswith(ANGLE_SUFFIX) and name[:1] in "LR" and name not in angles:
            angles[name] = np.radians(xyz[:, i])
    return Reference(first + np.arange(xyz.shape[0]), angles, str(path))


def folder_angles(folder: str | Path) -> Reference:
    """The angles.csv of a ``mocap-mj plug-in-gait`` output folder ([deg] in the file)."""
    path = Path(folder) / "angles.csv"
    if not path.is_file():
        raise InputFileError(f"--compare {folder}: no angles.csv (a plug-in-gait output folder)")
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    if not rows or rows[0][:2] != ["frame", "time_s"]:
        raise InputFileError(f"{path}: expected the header frame,time_s,<Name>_X,...")
    header, body = rows[0], rows[1:]
    try:
        table = np.array([[float(v) if v else np.nan for v in r] for r in body]).reshape(
            len(body), len(header)
        )
    except ValueError:
        raise InputFileError(f"{path}: expected numbers in every row") from None
    names = [h[:-2] for h in header[2::3]]
    angles = {n: np.radians(table[:, 2 + 3 * k : 5 + 3 * k]) for k, n in enumerate(names)}
    return Reference(table[:, 0].astype(int), angles, str(path))


def numbered_like(frames: np.ndarray, ref: Reference) -> Reference:
    """``ref`` as is when most of our frames (T,) are among its frame numbers, else with its
    rows counted from 0 (our frames then count the recording's samples from its first)."""
    if np.mean(np.isin(frames, ref.frames)) >= 0.5:
        return ref
    return replace(ref, frames=np.arange(len(ref.frames)))


def aligned(frames: np.ndarray, ref: Reference) -> np.ndarray:
    """Rows of ``ref`` for our frames (T,): matched by frame number when most of ours are in
    the reference, else by position when both hold as many frames; (T,) indices into the
    reference, -1 where it has no such frame."""
    index = {int(f): i for i, f in enumerate(ref.frames)}
    rows = np.array([index.get(int(f), -1) for f in frames])
    if np.mean(rows >= 0) >= 0.5:
        return rows
    if len(ref.frames) == len(frames):
        return np.arange(len(frames))
    raise MocapError(
        f"{ref.source}: its frames {int(ref.frames[0])}..{int(ref.frames[-1])} do not match "
        f"ours ({int(frames[0])}..{int(frames[-1])}, {len(frames)} frames)"
    )


@dataclass(frozen=True)
class Row:
    """One angle component against the reference [deg]: RMS of the difference, its mean
    (the constant offset, ours minus theirs), the correlation, the reference's range."""

    name: str
    rms: float
    offset: float
    correlation: float
    reference_range: float


def compare(ours: dict[str, np.ndarray], theirs: dict[str, np.ndarray]) -> list[Row]:
    """Per component of every angle both hold ((T, 3) [rad], the same frames), in our order."""
    rows = []
    for name, a in ours.items():
        if name not in theirs:
            continue
        for k, axis in enumerate("XYZ"):
            x, y = np.degrees(a[:, k]), np.degrees(theirs[name][:, k])
            ok = np.isfinite(x) & np.isfinite(y)
            if ok.sum() < 2:
                continue
            d = np.degrees(np.angle(np.exp(1j * np.radians(x[ok] - y[ok]))))
            flat = np.std(x[ok]) < 1e-9 or np.std(y[ok]) < 1e-9
            r = np.nan if flat else float(np.corrcoef(x[ok], y[ok])[0, 1])
            rms = float(np.sqrt(np.mean(d**2)))
            rows.append(Row(f"{name}_{axis}", rms, float(np.mean(d)), r, float(np.ptp(y[ok]))))
    return rows


def table_lines(rows: list[Row]) -> list[str]:
    """A Markdown table of ``rows``."""
    lines = [
        "| angle | RMS difference (deg) | offset, ours - theirs (deg) | correlation | "
        "their range (deg) |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        corr = "n/a" if not np.isfinite(r.correlation) else f"{r.correlation:.3f}"
        lines.append(
            f"| {r.name} | {r.rms:.1f} | {r.offset:+.1f} | {corr} | {r.reference_range:.1f} |"
        )
    return lines


#: The figure of :func:`comparison_section`.
FIGURE = "angles_vs_plug_in_gait.png"


def comparison_section(
    folder: Path, frames: np.ndarray, times: np.ndarray, ours: dict[str, np.ndarray],
    ref: Reference, figure: str = FIGURE,
) -> tuple[list[str], list[Row]]:  # fmt: skip
    """(Markdown lines, rows) of ours (name -> (T, 3) [rad] at frames (T,), times (T,) [s])
    against ``ref``, with both curves per component drawn into ``folder`` / ``figure``."""
    from mocap_mj.io.plots import plot_angle_comparison

    idx = aligned(frames, ref)
    theirs = {
        n: np.where((idx >= 0)[:, None], v[np.maximum(idx, 0)], np.nan)
        for n, v in ref.angles.items()
    }
    rows = compare(ours, theirs)
    deg = {n: np.degrees(v) for n, v in ours.items()}
    plot_angle_comparison(
        folder / figure, times, deg, {n: np.degrees(v) for n, v in theirs.items()}
    )
    lines = [
        "## Angles against Plug-in Gait",
        "",
        f"Our model's angles (angles.csv, Plug-in Gait's conventions) beside those of "
        f"{ref.source}, {int(np.sum(idx >= 0))} frames in common. Where the two differ by "
        "construction: docs/clinical.md, \"Our model's angles and Plug-in Gait's\".",
        "",
        f"![angles]({figure})",
        "",
        *table_lines(rows),
        "",
    ]
    return lines, rows


def crosstalk(flexion: np.ndarray, varus: np.ndarray) -> tuple[float, float] | None:
    """Correlation and slope [deg/deg] of ``varus`` on ``flexion`` (T,) [deg] over the
    finite frames: the crosstalk a flexion axis placed off the joint's shows; None when
    flexion spans less than :data:`CROSSTALK_MIN_RANGE`."""
    ok = np.isfinite(flexion) & np.isfinite(varus)
    f, v = flexion[ok], varus[ok]
    if len(f) < 3 or np.ptp(np.percentile(f, [5, 95])) < CROSSTALK_MIN_RANGE:
        return None
    return float(np.corrcoef(f, v)[0, 1]), float(np.polyfit(f, v, 1)[0])
