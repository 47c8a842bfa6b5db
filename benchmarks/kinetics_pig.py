"""Our Plug-in Gait kinetics against Vicon Nexus' own, stored in the same C3D.

    python benchmarks/kinetics_pig.py [--trial PATH] [--plates auto|all|1,4]

Runs the kinetics of ``mocap-mj plug-in-gait`` (no flags: ``--plates auto``, the contacts the
recording's own ground reactions count, else every plate a foot stands on alone) on the
trial and, so that no figure can echo Nexus' outputs, on a copy of it stripped of them
(``../shared/tools/strip_outputs.py``: markers and plates only), and prints
per component Nexus wrote the RMS difference over the frames both wrote (moments [N m/kg],
powers [W/kg], joint forces [N/kg], ground reaction [% of its peak]) and which miss the
targets (0.05 N m/kg, 0.1 W/kg, 1 %), then the RMS over the frames where each foot stands on
a plate we count only when Nexus counts one too (``agreeing``: what differs when a lab
counts other plates than ours); for ``CentreOfMass`` and ``CentreOfMassFloor`` [mm] also the
RMS and largest distance. ``--plates`` as the command's (Nexus counted 1 and 4 of
Movement_trial's four; the stripped copy has no ground reactions of Nexus', so ``auto``
falls back to ``all`` there). Reads the trial only; the stripped copy goes to a
temporary folder.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import ezc3d
import numpy as np

from mocap_mj.clinical import pig_from_c3d, plug_in_gait
from mocap_mj.clinical.centre_of_mass import COM_NAMES, pig_centre_of_mass, with_trunk
from mocap_mj.clinical.kinetics import PlateChoice, trial_kinetics
from mocap_mj.io.load import load_markers
from mocap_mj.io.plates import read_plates, recorded_ground_reactions

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared"
#: Nexus' units per kind (its C3D stores moments in N mm/kg) and our targets.
KINDS: dict[str, tuple[float, float | None, str]] = {
    "Moment": (1e-3, 0.05, "N m/kg"), "Power": (1.0, 0.1, "W/kg"), "Force": (1.0, None, "N/kg")
}  # fmt: skip


def ours(trial: Path, plates: str) -> tuple[dict[str, np.ndarray], list[str]]:
    """Our kinetic outputs of ``trial`` as the plug-in-gait command computes them, with the
    centre of mass [m]."""
    traj = load_markers(trial)
    subject = pig_from_c3d(trial)
    result = plug_in_gait(traj, subject)
    mass = subject.get("mass")
    if mass is None:
        raise SystemExit(f"{trial}: no body mass in PROCESSING:Bodymass")
    counted = None if plates in ("auto", "all") else {int(v) for v in plates.split(",")}
    markers = {n: traj.positions[:, i] for i, n in enumerate(traj.names)}
    out, notes = trial_kinetics(
        result.segments,
        with_trunk(result.segments, result.centres, markers, subject.marker_radius),
        read_plates(trial, window="centred", offsets="none"),
        traj,
        body_mass=mass,
        progression=result.progression,
        choice=PlateChoice(counted, recorded_ground_reactions(trial) if plates == "auto" else None),
    )
    com = pig_centre_of_mass(result.segments, result.centres, markers,
                             marker_radius=subject.marker_radius)  # fmt: skip
    return out | com, notes


def nexus(trial: Path) -> dict[str, np.ndarray]:
    """Nexus' kinetic points and centre of mass (T, 3) in its units, NaN where it wrote
    none."""
    c3d = ezc3d.c3d(str(trial))
    labels = [s.strip() for s in c3d["parameters"]["POINT"]["LABELS"]["value"]]
    pts = c3d["data"]["points"][:3]
    kinetic = ("Moment", "Power", "Force", "GRF")
    return {
        n: pts[:, i, :].T.copy()
        for i, n in enumerate(labels)
        if n.endswith(kinetic) or n in COM_NAMES
    }


def compare(mine: dict[str, np.ndarray], theirs: dict[str, np.ndarray]) -> list[str]:
    """Printed lines, a MISS on each component over its target."""
    lines = [f"{'component':26s} {'RMS':>8s} {'unit':>7s} {'frames':>6s} {'agreeing':>9s}"]
    # the frames where our foot is on a counted plate only if Nexus' is (Nexus writes its
    # ground reaction where it counts a plate): the figures the choice of plates leaves
    agree = {
        s: ~np.isfinite(mine[f"{s}GroundReactionForce"][:, 2])
        | np.isfinite(theirs[f"{s}GroundReactionForce"][:, 2])
        for s in "LR"
        if f"{s}GroundReactionForce" in theirs
    }
    for name in sorted(mine):
        if name not in theirs:
            continue
        kind = next((k for k in KINDS if name.endswith(k)), None)
        target: float | None
        if name in COM_NAMES:
            lines.append(_com_line(name, mine[name] * 1e3, theirs[name]))
            continue
        if name.endswith("GroundReactionForce") or name.endswith("NormalisedGRF"):
            scale, target, unit = 1.0, 1.0, "% peak"
        elif kind is not None:
            scale, target, unit = KINDS[kind]
        else:
            continue
        ref = theirs[name] * scale
        for k, axis in enumerate("XYZ"):
            if kind == "Power" and axis != "Z":
                continue
            both = np.isfinite(ref[:, k]) & np.isfinite(mine[name][:, k])
            d = mine[name][both, k] - ref[both, k]
            rms = float(np.sqrt(np.mean(d**2))) if both.any() else float("nan")
            if unit == "% peak":
                peak = float(np.nanmax(np.abs(ref[:, 2]))) if both.any() else float("nan")
                rms = 100.0 * rms / peak
            flag = "  MISS" if target is not None and not rms <= target else ""
            # the trunk's loads come up both legs
            both_feet = agree.get("L", both) & agree.get("R", both)
            same = both & (both_feet if "Waist" in name or "Neck" in name
                           else agree.get(name[0], both))  # fmt: skip
            part = float(np.sqrt(np.mean((mine[name][same, k] - ref[same, k]) ** 2)))
            if unit == "% peak":
                part = 100.0 * part / peak
            lines.append(
                f"{name + '_' + axis:26s} {rms:8.4f} {unit:>7s} {both.sum():6d} "
                f"{part:9.4f} ({same.sum()}){flag}"
            )
    return lines


def _com_line(name: str, mine: np.ndarray, theirs: np.ndarray) -> str:
    """The printed line of a centre of mass point, ``mine`` and ``theirs`` (T, 3) [mm]: RMS
    per axis, then the RMS and largest distance."""
    both = np.isfinite(mine).all(axis=1) & np.isfinite(theirs).all(axis=1)
    d = mine[both] - theirs[both]
    axes = " ".join(f"{a} {np.sqrt(np.mean(d[:, k] ** 2)):.2f}" for k, a in enumerate("XYZ"))
    dist = np.linalg.norm(d, axis=1)
    return (f"{name:26s} RMS {np.sqrt(np.mean(dist**2)):.2f} max {dist.max():.2f} mm over "
            f"{both.sum()} frames ({axes})")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", type=Path, default=SHARED / "data/real/Movement_trial.c3d")
    ap.add_argument("--plates", default="auto", help="auto (default), all or numbers: 1,4")
    args = ap.parse_args()
    theirs = nexus(args.trial)
    with tempfile.TemporaryDirectory() as tmp:
        stripped = Path(tmp) / "stripped.c3d"
        subprocess.run(
            [
                sys.executable,
                str(SHARED / "tools/strip_outputs.py"),
                str(args.trial),
                str(stripped),
            ],
            check=True,
        )
        for label, path in (("the trial as Nexus wrote it", args.trial), ("stripped", stripped)):
            mine, notes = ours(path, args.plates)
            print(f"\n## {label}: {path.name}, plates counted: {args.plates}")
            print(*(f"note: {n}" for n in notes), sep="\n") if notes else None
            print("\n".join(compare(mine, theirs)))


if __name__ == "__main__":
    main()
