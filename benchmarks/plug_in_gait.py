"""Our Plug-in Gait against Vicon Nexus' own Plug-in Gait output stored in the same C3D.

    python benchmarks/plug_in_gait.py [--shared ../shared/data] [--trials NAME ...]

For each trial (default: Movement_trial, with its PROCESSING values and again with
Static_trial as the static trial, and Static_trial), runs :func:`mocap_mj.clinical.
plug_in_gait` with no flags and prints, per angle component Nexus wrote, the RMS and the
largest difference (wrapped to +-180 deg), per bone point the median distance [mm], and
which miss the targets (1 deg RMS, 1 mm median). Reads the files only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mocap_mj.clinical import pig_from_c3d, plug_in_gait
from mocap_mj.clinical.nexus_centres import read_nexus
from mocap_mj.io.load import load_markers

ANGLE_TARGET = 1.0  # deg RMS
POINT_TARGET = 1.0  # mm median


def compare(trial: Path, static: Path | None) -> tuple[list[str], list[str]]:
    """(printed lines, names that miss a target) for one run."""
    traj = load_markers(trial)
    subject = pig_from_c3d(trial)
    stat = None
    if static is not None:
        stat = load_markers(static)
        subject = pig_from_c3d(static).update(subject)
    result = plug_in_gait(traj, subject, stat)
    out = read_nexus(trial)
    if out is None:
        raise SystemExit(f"{trial}: holds no Plug-in Gait bone points of Nexus's")
    lines, misses = [], []
    lines.append(f"{'angle component':28s} {'RMS deg':>8s} {'max deg':>8s}")
    for name in sorted(result.angles):
        if name not in out.angles:
            continue
        nexus = out.angles[name]
        ours = np.degrees(result.angles[name])
        for k, axis in enumerate("XYZ"):
            d = np.degrees(np.angle(np.exp(1j * np.radians(ours[:, k] - nexus[:, k]))))
            d = d[np.isfinite(d)]
            rms, worst = float(np.sqrt(np.mean(d**2))), float(np.max(np.abs(d)))
            flag = "" if rms <= ANGLE_TARGET else "  MISS"
            if flag:
                misses.append(f"{name}_{axis}")
            lines.append(f"{name + '_' + axis:28s} {rms:8.3f} {worst:8.3f}{flag}")
    lines.append(f"{'bone point':28s} {'median mm':>9s}")
    for name in sorted(result.points):
        if name not in out.points:
            continue
        dist = np.linalg.norm(result.points[name] - out.points[name], axis=1) * 1e3
        med = float(np.nanmedian(dist))
        flag = "" if med <= POINT_TARGET else "  MISS"
        if flag:
            misses.append(name)
        lines.append(f"{name:28s} {med:9.2f}{flag}")
    return lines, misses


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--shared", type=Path, default=Path("../shared/data"))
    args = ap.parse_args()
    real = args.shared / "real"
    runs = [
        ("Movement_trial (PROCESSING values)", real / "Movement_trial.c3d", None),
        ("Movement_trial --static Static_trial", real / "Movement_trial.c3d",
         real / "Static_trial.c3d"),
        ("Static_trial (PROCESSING values)", real / "Static_trial.c3d", None),
    ]  # fmt: skip
    for title, trial, static in runs:
        lines, misses = compare(trial, static)
        print(f"\n== {title}")
        print("\n".join(lines))
        print(f"misses the targets: {', '.join(misses) if misses else 'none'}")


if __name__ == "__main__":
    main()
