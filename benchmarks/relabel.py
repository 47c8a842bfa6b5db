"""Label errors put into the shared recordings on purpose, found and corrected; prints figures.

    python benchmarks/relabel.py [--data ../shared/data/real] [--identify Movement_trial ...]
                                 [--frames 1000 10000 100000]

Every shared trial is read, and its labels exchanged after loading (the files are never
touched): RKNE with RTIB and LASI with RASI over the whole trial, LTHI with LKNE over the
middle third of the frames (LTHI missing for the 3 frames before it and LKNE for the 3 after:
a swap between two occlusions), and the two front head markers with the two back ones
(LFHD/RFHD with LBHD/RBHD). For each trial the script prints the time of
:func:`mocap_mj.pipeline.relabel.find_label_errors` on the unmodified data and on the data with all
four exchanges, the corrections found, whether each exchange was found with its markers and
frames, and whether the corrected data equal the original (present samples, bit for bit).

With ``--identify NAME ...`` it also runs ``mocap-mj identify`` on those trials with each
exchange alone and as read (with the same added occlusions), both written as mocap-mj CSV to a
temporary folder, and prints the largest difference of the identified kinematic parameters
(segment lengths, theta.json) [mm], with the labels corrected and, for comparison, left as
labelled (``--no-relabel``). (The exchanges are identified one at a time: the pelvis's
LASI/RASI and the head's front/back exchange together mirror both groups, which the reader
refuses as a mirrored export, ``mocap_mj.io.handedness``.)

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
from mocap_mj.pipeline.relabel import Relabel, apply_relabels, find_label_errors, reference_theta
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet

HERE = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


#: The exchanges put in (module docstring): name, pairs, whether over the middle third only.
EXCHANGES: tuple[tuple[str, tuple[tuple[str, str], ...], bool], ...] = (
    ("RKNE-RTIB", (("RKNE", "RTIB"),), False),
    ("LASI-RASI", (("LASI", "RASI"),), False),
    ("LTHI-LKNE span", (("LTHI", "LKNE"),), True),
    ("head front-back", (("LFHD", "LBHD"), ("RFHD", "RBHD")), False),
)


def exchanged(
    x: np.ndarray, names: list[str], which: tuple[str, ...] | None = None
) -> tuple[np.ndarray, list[tuple]]:
    """x (T, M, 3) [m] with the exchanges named in ``which`` (default: all four), and what
    a correction must say of each: (sorted marker names, first frame, last frame + 1)."""
    y = np.array(x)
    n = len(y)
    a, b = n // 3, 2 * n // 3
    col = {m: i for i, m in enumerate(names)}
    want = []
    for name, pairs, span in EXCHANGES:
        if which is not None and name not in which:
            continue
        sl = slice(a, b) if span else slice(None)
        for p, q in pairs:
            y[sl, [col[p], col[q]]] = y[sl, [col[q], col[p]]]
        if span:  # the swap starts after LTHI's occlusion and ends at LKNE's
            y[a - 3 : a, col["LTHI"]] = np.nan
            y[b : b + 3, col["LKNE"]] = np.nan
        want.append((tuple(sorted(m for pq in pairs for m in pq)), *((a, b) if span else (0, n))))
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
    """``mocap-mj identify`` on the trial with each exchange and on the trial as read (with
    the same added occlusions), both written as mocap-mj CSV (the same digits): the largest
    difference of the identified kinematic parameters [mm]."""
    names = list(pset.marker_names)
    tr = load_markers(str(path), model_names=pset.marker_names)
    x = tr.select(pset.marker_names)
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)

        def identify(key: str, data: np.ndarray, *flags: str) -> dict[str, float]:
            f = tmp / f"{key.replace(' ', '_')}{'_'.join(flags)}.csv"
            save_csv(f, MarkerTrajectory(tr.times, data, pset.marker_names, tr.rate))
            t0 = time.perf_counter()
            code = cli(["identify", "--markers", str(f), "--out", str(f.with_suffix("")), *flags])
            print(f"identify {path.stem} {key}: exit {code}, {time.perf_counter() - t0:.1f} s")
            theta = json.loads((f.with_suffix("") / "theta.json").read_text())
            return {k: _value(theta, k) for k in pset.kappa_names}

        for name, _, _ in EXCHANGES:
            y, _ = exchanged(x, names, (name,))
            a = identify(f"{name} as read", np.where(np.isnan(y), np.nan, x))
            for flags in ((), ("--no-relabel",)):
                b = identify(name, y, *flags)
                diffs = {k: abs(a[k] - b[k]) * 1e3 for k in pset.kappa_names}
                worst = max(diffs, key=lambda k: diffs[k])
                how = "left as labelled" if flags else "corrected"
                print(
                    f"{path.name} {name}: largest kinematic parameter difference, exchanged "
                    f"and {how}, against as read: {diffs[worst]:.3f} mm ({worst})"
                )


def _value(theta: dict, name: str) -> float:
    """A kinematic parameter [m] of a theta.json (its ``kappa`` table)."""
    return float(theta["kappa"][name])


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
    p.add_argument(
        "--identify",
        metavar="NAME",
        nargs="*",
        default=[],
        help="trials (file stems) to identify as well",
    )
    p.add_argument("--frames", type=int, nargs="*", default=[], help="synthetic lengths to time")
    args = p.parse_args()
    pset = ParameterSet()
    if args.frames:
        long_recordings(args.frames, pset)
        return
    for path in sorted(args.data.glob("*.c3d")):
        search(path, pset)
    for name in args.identify:
        identify_difference(args.data / f"{name}.c3d", pset)


if __name__ == "__main__":
    main()
