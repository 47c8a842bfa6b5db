"""Label errors put into the shared recordings on purpose, found and corrected; prints figures.

    python benchmarks/relabel.py [--data ../shared/data/real] [--identify Movement_trial]
                                 [--frames 1000 10000 100000]

Every shared trial is read, and its labels exchanged after loading (the files are never
touched): RKNE with RTIB and LASI with RASI over the whole trial, LTHI with LKNE over the
middle third of the frames (LTHI missing for the 3 frames before it and LKNE for the 3 after:
a swap between two occlusions), and the two front head markers with the two back ones
(LFHD/RFHD with LBHD/RBHD). For each trial the script prints the time of
:func:`mocap_mj.relabel.find_label_errors` on the unmodified data and on the data with all
four exchanges, the corrections found, whether each exchange was found with its markers and
frames, and whether the corrected data equal the original (present samples, bit for bit).

With ``--identify NAME`` it also runs ``mocap-mj identify`` on that trial, as read and with
the exchanges (written as a mocap-mj CSV to a temporary folder), and prints the largest
difference of the identified kinematic parameters (segment lengths, theta.json) [mm].

With ``--frames`` it times the search on synthetic recordings of those lengths (mocap_synth's
range of motion at 100 Hz, soft tissue 10 mm/rad, played forwards and backwards), unmodified
and with LASI/RASI exchanged over the whole recording.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from mocap_mj.cli import main as cli
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv
from mocap_mj.kinematics import Kinematics
from mocap_mj.parameters import ParameterSet
from mocap_mj.relabel import Relabel, apply_relabels, find_label_errors, reference_theta

HERE = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


def exchanged(x: np.ndarray, names: list[str]) -> tuple[np.ndarray, list[tuple]]:
    """x (T, M, 3) [m] with the four exchanges, and what a correction must say of each:
    (sorted marker names, first frame, last frame + 1)."""
    y = np.array(x)
    n = len(y)
    a, b = n // 3, 2 * n // 3
    col = {m: i for i, m in enumerate(names)}

    def swap(p: str, q: str, sl: slice = slice(None)) -> None:
        y[sl, [col[p], col[q]]] = y[sl, [col[q], col[p]]]

    swap("RKNE", "RTIB")
    swap("LASI", "RASI")
    swap("LTHI", "LKNE", slice(a, b))
    y[a - 3 : a, col["LTHI"]] = np.nan
    y[b : b + 3, col["LKNE"]] = np.nan
    swap("LFHD", "LBHD")
    swap("RFHD", "RBHD")
    want = [
        (("RKNE", "RTIB"), 0, n),
        (("LASI", "RASI"), 0, n),
        (("LKNE", "LTHI"), a, b),
        (("LBHD", "LFHD", "RBHD", "RFHD"), 0, n),
    ]
    return y, want


def said(r: Relabel) -> tuple:
    return (tuple(sorted(r.markers)), *r.frames)


def search(path: Path, pset: ParameterSet) -> None:
    names = list(pset.marker_names)
    tr = load_markers(str(path), model_names=pset.marker_names)
    x = tr.select(pset.marker_names)
    kin = Kinematics(pset)
    kin.set_theta(reference_theta(pset, x))
    t0 = time.perf_counter()
    clean = find_label_errors(path.name, x, tr.rate, kin)
    t_clean = time.perf_counter() - t0
    y, want = exchanged(x, names)
    kin.set_theta(reference_theta(pset, y))
    t0 = time.perf_counter()
    found = find_label_errors(path.name, y, tr.rate, kin)
    t_found = time.perf_counter() - t0
    fixed = apply_relabels(y, names, found, path.name)
    ok = np.isfinite(fixed)
    same = bool(np.array_equal(fixed[ok], x[ok]))
    got = {said(r) for r in found}
    print(
        f"{path.name}: {len(x)} frames at {tr.rate:g} Hz; unmodified: {len(clean)} "
        f"correction(s) in {t_clean:.2f} s; exchanged: {len(found)} in {t_found:.2f} s; "
        f"found as put in: {sum(w in got for w in want)} of {len(want)}; corrected data "
        f"equal the original: {same}"
    )
    for r in clean + found:
        print(f"    {r.message}")


def identify_difference(path: Path, pset: ParameterSet) -> None:
    names = list(pset.marker_names)
    tr = load_markers(str(path), model_names=pset.marker_names)
    y, _ = exchanged(tr.select(pset.marker_names), names)
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / f"{path.stem}_exchanged.csv"
        save_csv(copy, MarkerTrajectory(tr.times, y, pset.marker_names, tr.rate))
        theta = {}
        for key, src in (("original", path), ("exchanged", copy)):
            out = Path(tmp) / key
            t0 = time.perf_counter()
            code = cli(["identify", "--markers", str(src), "--out", str(out)])
            print(f"identify {key}: exit {code}, {time.perf_counter() - t0:.1f} s")
            theta[key] = json.loads((out / "theta.json").read_text())
    a, b = theta["original"], theta["exchanged"]
    kappa = [k for k in pset.kappa_names if k in json.dumps(a)]
    diffs = {k: abs(_value(a, k) - _value(b, k)) * 1e3 for k in kappa}
    worst = max(diffs, key=lambda k: diffs[k])
    print(
        f"{path.name}: largest kinematic parameter difference, exchanged and corrected "
        f"against the file as read: {diffs[worst]:.3f} mm ({worst})"
    )


def _value(theta: dict, name: str) -> float:
    """A kinematic parameter [m] of a theta.json."""
    for key in ("kappa", "kinematic", "parameters"):
        if isinstance(theta.get(key), dict) and name in theta[key]:
            v = theta[key][name]
            return float(v["value"] if isinstance(v, dict) else v)
    return float(theta[name])


def long_recordings(frames: list[int], pset: ParameterSet) -> None:
    from mocap_synth import SynthConfig, synthesize

    exp = synthesize(SynthConfig(frames=1000, motion="rom", sta_mm=10.0, seed=0), pset)
    base = np.concatenate([exp.markers, exp.markers[::-1]])
    col = pset.marker_names.index
    for n in frames:
        x = np.concatenate([base] * (-(-n // len(base))))[:n]
        kin = Kinematics(pset)
        kin.set_theta(reference_theta(pset, x))
        y = np.array(x)
        y[:, [col("LASI"), col("RASI")]] = x[:, [col("RASI"), col("LASI")]]
        out = []
        for data in (x, y):
            t0 = time.perf_counter()
            found = find_label_errors("long", data, 100.0, kin)
            out.append(f"{len(found)} correction(s) in {time.perf_counter() - t0:.2f} s")
        print(f"{n:>8,} frames: unmodified {out[0]}; LASI/RASI exchanged {out[1]}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, default=HERE)
    p.add_argument("--identify", metavar="NAME", help="trial (file stem) to identify as well")
    p.add_argument("--frames", type=int, nargs="*", default=[], help="synthetic lengths to time")
    args = p.parse_args()
    pset = ParameterSet()
    if args.frames:
        long_recordings(args.frames, pset)
        return
    for path in sorted(args.data.glob("*.c3d")):
        search(path, pset)
    if args.identify:
        identify_difference(args.data / f"{args.identify}.c3d", pset)


if __name__ == "__main__":
    main()
