"""The same person captured differently: does the identified skeleton depend on the capture?

    python benchmarks/capture_variants.py [C3D ...] [--out DIR] [--only NAME ...] [--seed N]

For every C3D (default: Movement_trial.c3d and Test_func_rknee.c3d from ../shared/data/real)
this writes variants of the recording with ezc3d into a scratch folder (the input file is
read, never written: every parameter group, subject measurements included, is copied) and
runs ``mocap-mj identify`` on the original and on each variant. Per variant it prints the
largest difference from the original's model of any joint-centre distance
(:func:`mocap_mj.solve.consistency.joint_centre_lengths`, as benchmarks/anatomy.py) and of
segments.csv's lengths, the marker RMSE, the kinematic parameters outside their range or at
a bound, the marker-quality findings, the wall time, and the expected outcome:

* ``exact``: rotated about the vertical, translated, another vertical axis (a proper
  rotation), metres, subject prefixes: the same numbers in another frame or unit, so the
  same skeleton up to the solver's tolerance;
* ``degraded``: fewer frames, a part of the trial, reversed time, gaps, a ghost: the same
  person with less or worse data, so a skeleton within the spread of the single-trial
  models (:data:`DEGRADED_MM`);
* ``refused``: a mirrored (left-handed) world: ``identify`` must exit non-zero with one line
  naming the file, never fit a left/right-swapped skeleton.

Transforms act in the file's own axes around its detected vertical (``load_markers``'s
``source["up"]``): a rotation about the vertical of the file, whichever axis that is.
"""

from __future__ import annotations

import argparse
import copy
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.io import load_markers
from mocap_mj.io.names import split_prefix
from mocap_mj.io.orientation import rotation_to_z_up
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import joint_centre_lengths

REAL = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "real"
DEFAULT_TRIALS = ("Movement_trial.c3d", "Test_func_rknee.c3d")
#: What an exact transform may change [mm]: the numbers differ only by rounding, and the LM
#: stops on a relative cost change, so along a flat direction of the cost (Qualisys.c3d's
#: inter-hip distance) two runs stop up to 0.18 mm apart (metres alone, a pure rescaling:
#: 0.06 mm); 0.5 mm leaves a margin and is far below any heading- or unit-dependent start.
EXACT_MM = 0.5
#: What less or worse data of the same trial may change [mm]: the single-trial models of one
#: subject differ by up to ~10 mm per joint-centre distance (docs/validation.md#real-recordings).
DEGRADED_MM = 10.0


@dataclass
class Capture:
    """A recording being varied: every point of the file (T, N, 3) in the file's axes and
    unit (NaN missing), its labels, the point rate [Hz], the original frame of each row (T,)
    (to carry the analog samples and residuals along), the unit, and the column of each
    model marker name (the loader's aliases resolved: L_FLE is LKNE)."""

    points: np.ndarray
    labels: list[str]
    rate: float
    frames: np.ndarray
    units: str
    columns: dict[str, int]


@dataclass(frozen=True)
class Variant:
    name: str
    kind: str  # "exact", "degraded" or "refused"
    what: str
    apply: Callable[[Capture, np.ndarray, np.random.Generator], Capture]


def _in_z_up(c: Capture, up: np.ndarray, f: Callable[[np.ndarray], np.ndarray]) -> Capture:
    """``c`` with ``f`` applied to its points expressed Z up (mm), then back in file axes."""
    z_up = c.points @ up.T
    out = copy.copy(c)
    out.points = f(z_up) @ up
    return out


def _rotate(deg: float) -> Callable[[Capture, np.ndarray, np.random.Generator], Capture]:
    a = np.deg2rad(deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return lambda c, up, rng: _in_z_up(c, up, lambda p: p @ rot.T)


def _translate(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    return _in_z_up(c, up, lambda p: p + np.array([3200.0, -4700.0, 850.0]))


def _vertical(axis: str) -> Callable[[Capture, np.ndarray, np.random.Generator], Capture]:
    """The file rewritten with ``axis`` vertical (a proper rotation of the original)."""

    def apply(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
        out = copy.copy(c)
        out.points = (c.points @ up.T) @ rotation_to_z_up(axis)
        return out

    return apply


def _mirror(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    return _in_z_up(c, up, lambda p: p * np.array([1.0, -1.0, 1.0]))


def _metres(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    out = copy.copy(c)
    out.points, out.units = c.points * 1e-3, "m"
    return out


def _prefix(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    out = copy.copy(c)
    out.labels = [f"Subject01:{n}" for n in c.labels]
    return out


def _rows(c: Capture, rows: np.ndarray, rate: float | None = None) -> Capture:
    return Capture(c.points[rows], c.labels, rate or c.rate, c.frames[rows], c.units, c.columns)


def _thin(k: int) -> Callable[[Capture, np.ndarray, np.random.Generator], Capture]:
    return lambda c, up, rng: _rows(c, np.arange(0, len(c.frames), k), c.rate / k)


def _upsample(k: int) -> Callable[[Capture, np.ndarray, np.random.Generator], Capture]:
    """``k`` times the rate, the samples between frames linearly interpolated (missing where
    either neighbour is): a high-rate system's file of the same motion."""

    def apply(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
        pos = np.arange((len(c.frames) - 1) * k + 1) / k
        i = np.minimum(pos.astype(int), len(c.frames) - 2)
        a = (pos - i)[:, None, None]
        points = (1.0 - a) * c.points[i] + a * c.points[i + 1]
        frames = c.frames[np.round(pos).astype(int)]
        return Capture(points, c.labels, c.rate * k, frames, c.units, c.columns)

    return apply


def _half(which: int) -> Callable[[Capture, np.ndarray, np.random.Generator], Capture]:
    def apply(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
        n = len(c.frames) // 2
        return _rows(c, np.arange(n) if which == 0 else np.arange(n, len(c.frames)))

    return apply


def _reverse(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    return _rows(c, np.arange(len(c.frames))[::-1])


def _column(c: Capture, names: tuple[str, ...]) -> int:
    for name in names:
        if name in c.columns:
            return c.columns[name]
    raise SystemExit(f"none of {names} in the file")


def _unlabelled(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    """Five extra unlabelled points (``*101`` ...) wandering within 2 m of the subject."""
    out = copy.copy(c)
    centre = np.nanmedian(c.points.reshape(-1, 3), axis=0)
    scale = 1.0 if c.units == "mm" else 1e-3
    walk = np.cumsum(rng.normal(0.0, 5.0, (len(c.frames), 5, 3)), axis=0) * scale
    extra = centre + rng.uniform(-2000.0, 2000.0, (1, 5, 3)) * scale + walk
    out.points = np.concatenate([c.points, extra], axis=1)
    out.labels = [*c.labels, *(f"*{101 + k}" for k in range(5))]
    return out


def _gaps(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    """10 % of one knee marker's frames missing, at random frames."""
    out = copy.copy(c)
    out.points = c.points.copy()
    j = _column(c, ("RKNE", "LKNE"))
    t = rng.choice(len(c.frames), size=len(c.frames) // 10, replace=False)
    out.points[t, j] = np.nan
    return out


def _late_start(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    """Every point missing in the first 10 % of frames (the subject outside the volume)."""
    out = copy.copy(c)
    out.points = c.points.copy()
    out.points[: len(c.frames) // 10] = np.nan
    return out


def _foot_blocks(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    """One foot marker missing for 30 % of the frames, in three blocks of 10 %."""
    out = copy.copy(c)
    out.points = c.points.copy()
    j = _column(c, ("LHEE", "RHEE", "LTOE", "RTOE"))
    n = len(c.frames)
    for start in (0.15, 0.45, 0.75):
        a = int(start * n)
        out.points[a : a + n // 10, j] = np.nan
    return out


def _ghost(c: Capture, up: np.ndarray, rng: np.random.Generator) -> Capture:
    """1 % of frames (at least 2) with one knee marker displaced by 50-100 mm."""
    out = copy.copy(c)
    out.points = c.points.copy()
    j = _column(c, ("LKNE", "RKNE"))
    t = rng.choice(np.arange(2, len(c.frames)), size=max(2, len(c.frames) // 100), replace=False)
    direction = rng.normal(size=(len(t), 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    scale = 1.0 if c.units == "mm" else 1e-3
    out.points[t, j] += direction * rng.uniform(50.0, 100.0, size=(len(t), 1)) * scale
    return out


VARIANTS: tuple[Variant, ...] = (
    Variant("rot90", "exact", "rotated 90 deg about the vertical", _rotate(90.0)),
    Variant("rot180", "exact", "rotated 180 deg about the vertical", _rotate(180.0)),
    Variant("rot37", "exact", "rotated 37 deg (walking diagonally)", _rotate(37.0)),
    Variant("translate", "exact", "origin moved (3.2, -4.7, 0.85) m", _translate),
    Variant("up_y", "exact", "vertical axis Y (proper rotation)", _vertical("y")),
    Variant("up_-z", "exact", "vertical axis -Z (proper rotation)", _vertical("-z")),
    Variant("metres", "exact", "coordinates in m, POINT:UNITS m", _metres),
    Variant("prefix", "exact", "labels 'Subject01:NAME'", _prefix),
    Variant("unlabelled", "exact", "five extra unlabelled points '*101'...", _unlabelled),
    Variant("thin2", "degraded", "every 2nd frame, half the rate", _thin(2)),
    Variant("thin4", "degraded", "every 4th frame, a quarter of the rate", _thin(4)),
    Variant("upsample8", "degraded", "8x the rate, interpolated", _upsample(8)),
    Variant("first_half", "degraded", "the first half of the frames", _half(0)),
    Variant("second_half", "degraded", "the second half of the frames", _half(1)),
    Variant("reversed", "degraded", "time reversed", _reverse),
    Variant("gaps10", "degraded", "10 % of one knee marker's frames missing", _gaps),
    Variant(
        "late_start", "degraded", "all markers missing in the first 10 % of frames", _late_start
    ),
    Variant(
        "foot_blocks", "degraded", "a foot marker missing 30 % of frames in blocks", _foot_blocks
    ),
    Variant("ghost", "degraded", "1 % of frames: a knee marker 50-100 mm off", _ghost),
    Variant("mirror", "refused", "one horizontal axis negated (left-handed)", _mirror),
)


def read_capture(path: Path) -> tuple[ezc3d.c3d, Capture]:
    c3d = ezc3d.c3d(str(path))
    points = np.array(c3d["data"]["points"][:3].transpose(2, 1, 0), dtype=float)  # (T, N, 3)
    residuals = c3d["data"]["meta_points"]["residuals"][0].T  # (T, N)
    points[residuals < 0] = np.nan
    point = c3d["parameters"]["POINT"]
    labels = list(point["LABELS"]["value"])
    for extra in ("LABELS2", "LABELS3"):
        labels += list(point[extra]["value"]) if extra in point else []
    units = str(point["UNITS"]["value"][0]).strip()
    rate = float(point["RATE"]["value"][0])
    source = load_markers(path).source
    aliased = {**source.get("aliased", {}), **source.get("renamed", {})}
    columns = {aliased.get(split_prefix(n)[1], split_prefix(n)[1]): i for i, n in enumerate(labels)}
    return c3d, Capture(points, labels, rate, np.arange(points.shape[0]), units, columns)


def write_capture(original: ezc3d.c3d, c: Capture, path: Path) -> None:
    """``c`` written as a C3D with every parameter of ``original`` kept (rate, units and labels
    set; residuals, camera masks and analog samples carried along with their frames)."""
    out = copy.deepcopy(original)
    n_frames, n_points, _ = c.points.shape
    pts = np.ones((4, n_points, n_frames))
    missing = np.isnan(c.points).any(axis=2)  # (T, N)
    pts[:3] = np.where(missing[..., None], 0.0, c.points).transpose(2, 1, 0)
    out["data"]["points"] = pts
    meta = out["data"]["meta_points"]
    extra = n_points - meta["residuals"].shape[1]  # points a variant added
    res = np.pad(meta["residuals"][:, :, c.frames], ((0, 0), (0, extra), (0, 0)))
    res[0][missing.T] = -1.0
    meta["residuals"] = res
    meta["camera_masks"] = np.pad(meta["camera_masks"][:, :, c.frames],
                                  ((0, 0), (0, extra), (0, 0)))  # fmt: skip
    analog = out["parameters"]["ANALOG"]
    point_rate = float(original["parameters"]["POINT"]["RATE"]["value"][0])
    per_frame = round(float(analog["RATE"]["value"][0]) / point_rate) if "RATE" in analog else 0
    if per_frame and out["data"]["analogs"].shape[1]:
        cols = (c.frames[:, None] * per_frame + np.arange(per_frame)).ravel()
        out["data"]["analogs"] = out["data"]["analogs"][:, :, cols]
        analog["RATE"]["value"] = [c.rate * per_frame]
    point = out["parameters"]["POINT"]
    point["RATE"]["value"] = [c.rate]
    point["UNITS"]["value"] = [c.units]
    point["LABELS"]["value"] = c.labels[:255]
    if "DESCRIPTIONS" in point and extra:
        point["DESCRIPTIONS"]["value"] = [*point["DESCRIPTIONS"]["value"], *[""] * extra][:255]
    for k, extra in enumerate(("LABELS2", "LABELS3")):
        if extra in point:
            point[extra]["value"] = c.labels[255 * (k + 1) : 255 * (k + 2)]
    out.write(str(path))


@dataclass
class Run:
    code: int
    seconds: float
    stderr: str
    summary: dict
    lengths: dict[str, float]  # joint-centre distances [m]
    segments: dict[str, float]  # segments.csv value_mm
    stds: dict[str, float]  # segments.csv std_mm (inflated by the residuals' correlation)


def identify(path: Path, out: Path, pset: ParameterSet) -> Run:
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "identify", "--markers", str(path), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        return Run(proc.returncode, seconds, proc.stderr.strip(), {}, {}, {}, {})
    summary = json.loads((out / "summary.json").read_text())
    lengths = joint_centre_lengths(pset, pset.load_json(out / "theta.json"))
    rows = [line.split(",") for line in (out / "segments.csv").read_text().splitlines()]
    col, sd = rows[0].index("value_mm"), rows[0].index("std_mm")
    segments = {r[0]: float(r[col]) for r in rows[1:] if r[1] == "length"}
    stds = {r[0]: float(r[sd]) for r in rows[1:] if r[1] == "length"}
    return Run(0, seconds, proc.stderr.strip(), summary, lengths, segments, stds)


def stature_mm(s: dict) -> float:
    """The stature the run used [mm]: measured, else estimated."""
    measured = s.get("measurements", {}).get("height")
    if measured:
        return float(measured["value"]) * 1e3
    return float((s.get("stature_estimate") or {}).get("value", float("nan"))) * 1e3


def _max_diff(a: dict[str, float], b: dict[str, float], scale: float) -> tuple[float, str]:
    diffs = sorted(((abs(a[k] - b[k]) * scale, k) for k in a if k in b), reverse=True)
    return diffs[0] if diffs else (float("nan"), "-")


def line(name: str, kind: str, run: Run, base: Run) -> str:
    tol = {"exact": EXACT_MM, "degraded": DEGRADED_MM}.get(kind)
    if run.code != 0:
        last = run.stderr.splitlines()[-1] if run.stderr else ""
        verdict = "ok (refused)" if kind == "refused" else "FAIL (refused)"
        return (f"| {name} | {kind} | exit {run.code} | | | | | | | {run.seconds:.1f} | "
                f"{verdict}: {last} |")  # fmt: skip
    jc, jc_name = _max_diff(run.lengths, base.lengths, 1e3)
    seg, seg_name = _max_diff(run.segments, base.segments, 1.0)
    z = max(abs(run.segments[k] - base.segments[k]) / base.stds[k] for k in base.segments
            if k in run.segments and base.stds[k] > 0)  # fmt: skip
    stature = stature_mm(run.summary) - stature_mm(base.summary)
    s = run.summary
    outside = ", ".join(s.get("kappa_outside_bounds_mm") or {}) or "-"
    at_bound = ", ".join(s.get("kappa_at_bound") or {}) or "-"
    kinds = [f["kind"] for f in s.get("marker_quality", {}).get("findings", [])]
    findings = ", ".join(f"{k} x{kinds.count(k)}" for k in sorted(set(kinds))) or "-"
    worst = max(jc, seg)
    if kind == "refused":
        verdict = "FAIL (fitted)"
    else:
        verdict = "ok" if tol is not None and worst <= tol else f"FAIL (> {tol} mm)"
    return (f"| {name} | {kind} | {s['frames_used']} | {jc:.3f} ({jc_name}) | {seg:.3f} "
            f"({seg_name}) | {z:.2f} | {stature:+.1f} | {s['marker_rmse_mm']:.2f} | {outside} / "
            f"{at_bound} | {findings} | "
            f"{run.seconds:.1f} | {verdict} |")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("trials", nargs="*", type=Path)
    ap.add_argument("--out", type=Path, help="scratch folder (default: a temporary one)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="variants to run (default: all)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    trials = args.trials or [REAL / n for n in DEFAULT_TRIALS]
    scratch = args.out or Path(tempfile.mkdtemp(prefix="capture_variants_"))
    scratch.mkdir(parents=True, exist_ok=True)
    variants = [v for v in VARIANTS if not args.only or v.name in args.only]
    pset = ParameterSet()
    print(f"scratch folder: {scratch}; tolerances: exact {EXACT_MM} mm, degraded "
          f"{DEGRADED_MM} mm (largest joint-centre distance or segments.csv length "
          "difference)")  # fmt: skip
    for trial in trials:
        up = rotation_to_z_up(load_markers(trial).source["up"])
        original, capture = read_capture(trial)
        folder = scratch / trial.stem
        folder.mkdir(exist_ok=True)
        base = identify(trial, folder / "original", pset)
        if base.code != 0:
            raise SystemExit(f"{trial}: the original does not identify: {base.stderr}")
        s = base.summary
        print(f"\n{trial.name}: {s['frames_used']} frames at {capture.rate:g} Hz, RMSE "
              f"{s['marker_rmse_mm']:.2f} mm, {base.seconds:.1f} s\n")  # fmt: skip
        print(
            "| variant | expected | frames | max joint-centre diff mm | max segments.csv diff "
            "mm | max diff / std | stature diff mm | RMSE mm | outside / at bound | findings | "
            "s | verdict |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for v in variants:
            rng = np.random.default_rng(args.seed)
            path = folder / f"{v.name}.c3d"
            write_capture(original, v.apply(capture, up, rng), path)
            print(line(v.name, v.kind, identify(path, folder / v.name, pset), base), flush=True)


if __name__ == "__main__":
    main()
