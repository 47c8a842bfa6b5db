"""Our Plug-in Gait against Vicon Nexus' own Plug-in Gait output stored in the same C3D.

    python benchmarks/plug_in_gait.py [--shared ../shared/data] [--trials NAME ...]

For each trial (default: Movement_trial, with its PROCESSING values and again with
Static_trial as the static trial, and Static_trial), runs :func:`mocap_mj.clinical.
plug_in_gait` with no flags and prints, per angle component Nexus wrote (AbsAnkleAngle
included), the RMS and the largest difference (wrapped to +-180 deg), per bone point the
median and the largest distance [mm], which miss the targets (0.01 deg and 0.1 mm in every
frame), and the static options: per foot, how far the given static offsets lie from the
plain and from the flat-foot calibration of the static trial, and the option taken; the head
offset and its source. Reads the files only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mocap_mj.capture.subject import Subject
from mocap_mj.clinical import calibrate, pig_from_c3d, plug_in_gait
from mocap_mj.clinical.model import PigResult
from mocap_mj.clinical.nexus_centres import read_nexus
from mocap_mj.io.load import load_markers
from mocap_mj.io.trajectory import MarkerTrajectory

ANGLE_TARGET = 0.01  # deg, the largest difference over the frames
POINT_TARGET = 0.1  # mm, the largest distance over the frames


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
            flag = "" if worst <= ANGLE_TARGET else "  MISS"
            if flag:
                misses.append(f"{name}_{axis}")
            lines.append(f"{name + '_' + axis:28s} {rms:8.3f} {worst:8.3f}{flag}")
    lines.append(f"{'bone point':28s} {'median mm':>9s} {'max mm':>8s}")
    for name in sorted(result.points):
        if name not in out.points:
            continue
        dist = np.linalg.norm(result.points[name] - out.points[name], axis=1) * 1e3
        med, worst = float(np.nanmedian(dist)), float(np.nanmax(dist))
        flag = "" if worst <= POINT_TARGET else "  MISS"
        if flag:
            misses.append(name)
        lines.append(f"{name:28s} {med:9.4f} {worst:8.4f}{flag}")
    if stat is None and not result.static:
        return lines, misses
    return lines + options(stat if stat is not None else traj, subject, result), misses


def options(static: MarkerTrajectory, given: Subject, result: PigResult) -> list[str]:
    """The static options: per foot the largest difference [rad] of the given offsets from
    the static trial's plain and flat-foot calibrations, the option taken; the head offset."""
    lines = ["static options (given offsets against the static trial's calibrations, rad)"]
    for s in "lr":
        names = (f"static_plantar_flex_{s}", f"static_rot_off_{s}")
        if not all(n in given.pig_values for n in names):
            lines.append(f"  foot {s}: no given offsets")
            continue
        off = {}
        for kind, flag in (("plain", 0.0), ("flat", 1.0)):
            cal = calibrate(static, given.with_pig({f"flat_foot_{s}": flag}, "benchmark"))
            off[kind] = max(abs(cal.pig(n) - given.pig(n)) for n in names)
        taken = "flat" if result.subject.flag(f"flat_foot_{s}") else "plain"
        lines.append(
            f"  foot {s}: plain {off['plain']:.2e}, flat {off['flat']:.2e} -> {taken} "
            f"(sole delta {result.subject.pig(f'sole_delta_{s}') * 1e3:g} mm)"
        )
    given_head = result.subject.pig_values.get("head_offset")
    source = "not given: 0" if given_head is None else given_head.source
    lines.append(f"  head offset {result.subject.pig('head_offset'):.4f} rad ({source})")
    return lines


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
