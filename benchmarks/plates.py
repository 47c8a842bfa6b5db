"""Force plates and gait events of C3D files; prints figures.

    python benchmarks/plates.py [FILE.c3d ...]

Default: the shared recordings with force plates (../shared/data/real/Movement_trial.c3d and
the vendors' Qualisys, FP_Type1, FP_Type3, Kistler). Per file: each plate's type, peak
vertical force [N] and, where PROCESSING:Bodymass states the mass, in body weights, the foot
each contact counts for (or why it is left out), and the gait events found with their
source (:func:`mocap_mj.capture.events.gait_events`: the EVENT group, else the plates, else
the kinematics). A file the reader refuses prints its one-line reason.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

from mocap_mj.capture.contacts import assign_feet, contacts
from mocap_mj.capture.events import gait_events
from mocap_mj.errors import MocapError
from mocap_mj.io import MarkerTrajectory, load_markers
from mocap_mj.io.formats.c3d import read_parameters
from mocap_mj.io.plates import read_plates

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
DEFAULT = [
    SHARED / "real" / "Movement_trial.c3d",
    *(
        SHARED / "vendors" / f
        for f in ("Qualisys.c3d", "FP_Type1.c3d", "FP_Type3.c3d", "Kistler.c3d")
    ),
]
G = 9.80665  # [m/s^2]
#: Foot markers tried per side: Plug-in Gait's, then metatarsal heads (Qualisys's set).
FOOT_NAMES = {
    "left": ("LHEE", "LTOE", "LANK", "L_FM1", "L_FM5"),
    "right": ("RHEE", "RTOE", "RANK", "R_FM1", "R_FM5"),
}


def body_mass(path: Path) -> float | None:
    """PROCESSING:Bodymass [kg], None when the file states none."""
    entry = read_parameters(path).get("PROCESSING", {}).get("Bodymass", {})
    value = entry.get("value") if isinstance(entry, dict) else None
    try:
        mass = float(next(iter(value))) if value is not None else 0.0
    except (TypeError, ValueError, IndexError):
        return None
    return mass if mass > 0 else None


def feet_of(traj: MarkerTrajectory) -> dict[str, tuple[str, ...]] | None:
    feet = {s: tuple(n for n in names if n in traj.names) for s, names in FOOT_NAMES.items()}
    return feet if all(feet.values()) else None


def report(path: Path) -> None:
    print(f"{path.name}")
    try:
        plates = read_plates(path)
    except MocapError as exc:
        print(f"  refused: {exc}")
        return
    mass = body_mass(path)
    for p in plates:
        peak = float(p.force[:, 2].max())
        bw = f", {peak / (mass * G):.2f} body weights" if mass else ""
        print(f"  {p.name}: type {p.plate_type}, {int(p.loaded.sum())} loaded frames of "
              f"{len(p.force)} at {p.rate:g} Hz, peak Fz {peak:.0f} N{bw}")  # fmt: skip
    try:
        traj = load_markers(path)
    except MocapError as exc:
        print(f"  no markers for feet and events: {exc}")
        return
    feet = feet_of(traj)
    loads = None
    first = traj.first_frame or 1
    if feet is not None:
        for c in contacts(plates, traj, feet=feet):
            what = c.reason or f"{c.side} foot"
            where = f"frames {first + c.start}-{first + c.stop - 1}"
            print(f"  contact {plates[c.plate].name} {where}: {what}")
        loads = assign_feet(plates, traj, feet=feet)
    try:
        events = gait_events(path, traj, loads=loads)
    except MocapError as exc:
        print(f"  events: none ({exc})")
        return
    counts = Counter((e.source, e.side, e.kind) for e in events)
    if not counts:
        print("  events: none found")
    for (source, side, kind), n in sorted(counts.items()):
        frames = [e.frame for e in events if (e.source, e.side, e.kind) == (source, side, kind)]
        print(f"  events ({source}): {side} {kind.replace('_', ' ')} x{n} at frames {frames}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, help="C3D files (default: the shared ones)")
    args = parser.parse_args()
    for path in args.files or [p for p in DEFAULT if p.is_file()]:
        report(path)


if __name__ == "__main__":
    main()
