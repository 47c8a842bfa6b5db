"""Our identified model's angles (Plug-in Gait's conventions) against Vicon Nexus' own.

    python benchmarks/model_angles.py [--shared ../shared/data] [--work /tmp/model_angles]

Runs ``mocap-mj identify --markers Movement_trial.c3d`` and prints, per angle component Nexus
wrote, the RMS difference, the constant offset (ours - Nexus', mean), the correlation and
Nexus' range; a component that moves more than 10 deg in Nexus' output with a correlation
below 0.9 is flagged ``SIGN``. Then identifies copies of the recording turned about the
vertical by 90 and 180 deg and moved 10 m (written to ``--work`` with ezc3d; the shared file
is only read) and prints the largest change of any angle against the original (target
0.5 deg).
"""

from __future__ import annotations

import argparse
import subprocess
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.clinical.compare import aligned, c3d_angles, compare, folder_angles, numbered_like

MOVES = 10.0  # deg: components that move more than this in Nexus' output keep its sign
CORRELATION = 0.9
INVARIANCE = 0.5  # deg


def identify(c3d: Path, out: Path) -> Path:
    """``mocap-mj identify`` of ``c3d`` into ``out`` (replaced)."""
    cmd = ["mocap-mj", "identify", "--markers", str(c3d), "--out", str(out), "--force"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return out


def turned_copy(c3d: Path, out: Path, degrees: float, shift_mm: float) -> Path:
    """A copy of ``c3d`` with every valid point turned about z by ``degrees`` and moved
    ``shift_mm`` along x (invalid samples kept as they are)."""
    c = ezc3d.c3d(str(c3d))
    pts = np.array(c["data"]["points"])
    res = c["data"]["meta_points"]["residuals"][0]
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1.0]])
    valid = (res >= 0) & np.any(pts[:3] != 0.0, axis=0)
    moved = np.einsum("ij,jnt->int", rot, pts[:3]) + np.array([shift_mm, 0, 0])[:, None, None]
    pts[:3] = np.where(valid[None], moved, pts[:3])
    c["data"]["points"] = pts
    c.write(str(out))
    return out


def nexus_lines(c3d: Path, result: Path) -> list[str]:
    ours = folder_angles(result)
    ref = numbered_like(ours.frames, c3d_angles(c3d))
    idx = aligned(ours.frames, ref)
    theirs = {k: np.where((idx >= 0)[:, None], v[idx], np.nan) for k, v in ref.angles.items()}
    rows = compare(ours.angles, theirs)
    head = f"{'angle component':24s} {'RMS':>6s} {'offset':>7s} {'corr':>6s} {'Nexus range':>11s}"
    lines = [head]
    for r in rows:
        flag = "  SIGN" if r.reference_range > MOVES and not r.correlation >= CORRELATION else ""
        lines.append(
            f"{r.name:24s} {r.rms:6.1f} {r.offset:+7.1f} {r.correlation:6.3f} "
            f"{r.reference_range:11.1f}{flag}"
        )
    moving = [r for r in rows if r.reference_range > MOVES]
    bad = [r.name for r in moving if not r.correlation >= CORRELATION]
    lines.append(
        f"{len(moving) - len(bad)} of {len(moving)} components moving > {MOVES:.0f} deg in "
        f"Nexus' output correlate >= {CORRELATION}; below: {', '.join(bad) or 'none'}"
    )
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--shared", type=Path, default=Path("../shared/data"))
    ap.add_argument("--work", type=Path, default=Path("/tmp/model_angles"))
    args = ap.parse_args()
    trial = args.shared / "real" / "Movement_trial.c3d"
    args.work.mkdir(parents=True, exist_ok=True)
    base = identify(trial, args.work / "original")
    print(f"== {trial.name}: our model's angles against Nexus' (deg)")
    print("\n".join(nexus_lines(trial, base)))
    ours = folder_angles(base).angles
    print(f"\n== turned about the vertical and moved 10 m: largest change (target {INVARIANCE})")
    for degrees in (90.0, 180.0):
        name = f"turned_{int(degrees)}"
        copy = turned_copy(trial, args.work / f"{name}.c3d", degrees, 10_000.0)
        other = folder_angles(identify(copy, args.work / name)).angles
        worst = max(
            (float(np.nanmax(np.abs(np.degrees(np.angle(np.exp(1j * (ours[k] - other[k]))))))), k)
            for k in ours
        )
        flag = "" if worst[0] <= INVARIANCE else "  MISS"
        print(f"{degrees:5.0f} deg + 10 m: {worst[0]:.3f} deg ({worst[1]}){flag}")


if __name__ == "__main__":
    main()
