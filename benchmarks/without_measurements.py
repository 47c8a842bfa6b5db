"""Joint centres without the subject's measurements, against Vicon's Plug-in Gait output.

    python benchmarks/without_measurements.py --out DIR [--shared DATA] [--trials NAME ...]

A Nexus export without its subject file: each shared trial whose C3D carries both the
subject's measurements (the PROCESSING group: knee, ankle, elbow and wrist widths, height,
leg lengths...) and Vicon's Plug-in Gait bone points is copied into ``DIR/files/`` with that
group removed (ezc3d; the original is only read). ``mocap-mj identify`` runs on the original
(``DIR/<trial>``) and on the copy (``DIR/<trial>_unmeasured``); for each, per centre, the
median over frames of the distance between ours (``joint_centres.csv``) and Vicon's (from
the original file; ``--shared`` default ../shared/data), and its anterior / lateral /
proximal components in Vicon's segment frame
(:func:`mocap_mj.clinical.nexus_centres.centre_gaps`). Prints mm. Without the
measurements the widths are regressed (``mocap_mj.anatomy.anatomy.WIDTH_RATIO``): the
figures show what the population prior costs on the shared subject.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path

import ezc3d

from mocap_mj.cli import main as cli_main
from mocap_mj.clinical.nexus_centres import centre_gaps, read_nexus, rows_for

sys.path.insert(0, str(Path(__file__).parent))
from vicon_pig import _ours  # the same reading of joint_centres.csv


def _unmeasured_copy(c3d: Path, out: Path) -> bool:
    """``c3d`` written to ``out`` without its PROCESSING group; False when it has none."""
    data = ezc3d.c3d(str(c3d))
    if "PROCESSING" not in data["parameters"]:
        return False
    del data["parameters"]["PROCESSING"]
    out.parent.mkdir(parents=True, exist_ok=True)
    data.write(str(out))
    return True


def _line(label: str, c3d: Path, result: Path) -> str:
    nexus = read_nexus(c3d)
    assert nexus is not None
    frames, ours = _ours(result)
    gaps = centre_gaps(nexus, rows_for(frames, nexus), ours)
    cells = [f"{g.joint} {g.distance * 1e3:.1f} ("
             + "/".join(f"{v * 1e3:+.0f}" for v in g.components) + ")" for g in gaps]  # fmt: skip
    return f"  {label}: " + ", ".join(cells)


def main() -> int:
    here = Path(__file__).resolve().parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--shared", type=Path, default=here.parent.parent / "shared" / "data")
    ap.add_argument("--trials", nargs="*", default=None)
    args = ap.parse_args()
    files = sorted((args.shared / "real").glob("*.c3d"))
    if args.trials:
        files = [f for f in files if f.stem in args.trials]
    print("median |ours - Vicon's| mm per centre (anterior/lateral/proximal in Vicon's frame)")
    for c3d in files:
        if read_nexus(c3d) is None:
            continue
        copy = args.out / "files" / c3d.name
        if not _unmeasured_copy(c3d, copy):
            continue
        print(f"{c3d.stem}:")
        for label, src, dest in (("measured", c3d, c3d.stem),
                                 ("unmeasured", copy, f"{c3d.stem}_unmeasured")):  # fmt: skip
            result = args.out / dest
            argv = ["identify", "--markers", str(src), "--out", str(result), "--force"]
            with contextlib.redirect_stdout(io.StringIO()):  # the command's own summary
                code = cli_main(argv)
            if code not in (0, 3):
                print(f"  {label}: identify exited {code}")
                continue
            print(_line(label, c3d, result) + ("" if code == 0 else " [exit 3]"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
