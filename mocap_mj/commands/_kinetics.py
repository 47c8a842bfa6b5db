"""The kinetics of ``ik`` and ``identify`` (``--forces``): the plates read before the solve
(bad input is refused before any output), the joint moments computed and written after it
(docs/dynamics.md).

Per trial with loads: the plates (its ``--forces`` file, else the marker file's own when it is
a C3D with plates) -> each foot's load from the plates it alone stands on
(:func:`mocap_mj.capture.contacts.assign_feet`) -> a load on the model's foot body -> inverse
dynamics with the subject's mass -> dynamics.csv, grf.csv, root_residuals.csv in the trial's
folder (:mod:`mocap_mj.pipeline.trials`). Every trial's gait events go to its events.csv.
Without a body mass the kinetics are refused with one warning; the rest is written.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.inertia import BodyInertia, Sex
from mocap_mj.capture.contacts import (
    STILL_SPEED,
    Contact,
    FootLoads,
    assign_feet,
    contacts,
    pivot_speeds,
)
from mocap_mj.capture.events import GaitEvent, events_csv, gait_events
from mocap_mj.errors import MocapError
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.load import load_markers
from mocap_mj.io.plates import PlateRecord, read_grf_mot, read_plates
from mocap_mj.io.trajectory import MarkerTrajectory
from mocap_mj.outputs.dynamics_out import dynamics_of_files, write_dynamics
from mocap_mj.outputs.inertia_out import StanceTrial
from mocap_mj.outputs.kinetics_out import (
    FOOT_BODIES,
    GRF_CSV,
    body_loads,
    excluded_frames,
    residual_figures,
    sliced,
    stance_frames,
    write_grf,
)
from mocap_mj.pipeline.dynamics import CUTOFF_HZ, PASS_ORDER
from mocap_mj.skeleton.mjcf import load_written

EVENTS_CSV = "events.csv"
#: Where each command takes the body mass from, in its order.
MASS_SOURCES = {
    "identify": "--mass, --subject-file's mass or the C3D's PROCESSING Bodymass",
    "ik": "the C3D's PROCESSING Bodymass or a --model that identify wrote with a mass",
}


def model_sex(path: str | Path | None) -> str | None:
    """The sex recorded in the summary.json beside a model file that identify wrote (its
    subject's ``sex``), else None."""
    if path is None:
        return None
    summary = Path(path).parent / "summary.json"
    try:
        found = json.loads(summary.read_text()).get("sex")
    except (OSError, ValueError, AttributeError):
        return None
    value = found.get("value") if isinstance(found, dict) else None
    return value if value in ("male", "female") else None


def model_mass(path: str | Path | None) -> float | None:
    """The body mass [kg] a model file carries: the sum of its bodies' masses when every body
    has an ``<inertial>`` (a model.xml written by identify with a known mass); else None."""
    if path is None:
        return None
    try:
        text = Path(path).read_text()
    except OSError:
        return None
    bodies = text.count("<body ")
    if bodies == 0 or text.count("<inertial ") < bodies:
        return None
    model = _written(Path(path))
    return None if model is None else float(np.sum(model.body_mass))


@dataclass(frozen=True)
class TrialLoads:
    """One trial's plates as read before the solve: the ``source`` file, the plates' names,
    the contacts (:func:`~mocap_mj.capture.contacts.contacts`), the feet's loads (left,
    right) and speeds (T,) [m/s] (their slowest marker's,
    :func:`~mocap_mj.capture.contacts.pivot_speeds`) over the whole recording (T frames),
    its times (T,) [s] and its gait events."""

    markers: str
    source: str
    plates: tuple[str, ...]
    found: tuple[Contact, ...]
    feet: tuple[FootLoads, FootLoads]
    speeds: dict[str, np.ndarray]
    times: np.ndarray
    events: tuple[GaitEvent, ...]


@dataclass(frozen=True)
class Prepared:
    """The kinetics of a command's trials: each trial's loads (None: no plates), its gait
    events and its frames' times (T,) [s], the body mass [kg] (None: unknown), why there
    are no kinetics (None: there are) and de Leva's table for the segments (the subject's
    sex)."""

    loads: tuple[TrialLoads | None, ...]
    events: tuple[tuple[GaitEvent, ...], ...]
    times: tuple[np.ndarray, ...]
    mass: float | None
    refused: str | None
    events_missing: tuple[str, ...] = ()
    sex: Sex = "male"


def prepare(
    args: argparse.Namespace, markers: list[str], mass: float | None, sex: str = "male"
) -> Prepared:
    """Read every trial's plates and events (bad input raises MocapError here, before any
    output is written); ``sex`` names de Leva's table ("male", the default, or "female")."""
    forces = getattr(args, "forces", None)
    no_forces = forces is not None and [f.lower() for f in forces] == ["none"]
    if no_forces:
        forces = None
    elif forces and "none" in [f.lower() for f in forces]:
        raise MocapError("--forces: expected 'none' alone or one file per marker file")
    if forces and len(forces) != len(markers):
        raise MocapError(
            f"--forces: expected one file per marker file ({len(markers)}), got {len(forces)}"
        )
    loads: list[TrialLoads | None] = []
    events: list[tuple[GaitEvent, ...]] = []
    times: list[np.ndarray] = []
    missing: list[str] = []
    for i, path in enumerate(markers):
        traj = load_markers(
            path,
            subject=args.subject,
            marker_map=args.marker_map,
            up=getattr(args, "up", None),
            units=getattr(args, "units", None),
        )
        trial = None if no_forces else _trial_loads(args, path, forces, i, traj)
        loads.append(trial)
        times.append(traj.times)
        found, why = (trial.events, None) if trial is not None else _events(args, path, traj, None)
        events.append(found)
        if why is not None:
            missing.append(why)
    refused = None
    if not any(t is not None for t in loads):
        refused = "no force plates" if not no_forces else "--forces none"
    elif mass is None:
        refused = (
            f"no body mass ({MASS_SOURCES[args.command]}): no kinetics (dynamics.csv, grf.csv, "
            "root_residuals.csv)"
        )
        _warn(args, refused)
    table: Sex = "female" if sex == "female" else "male"
    return Prepared(tuple(loads), tuple(events), tuple(times), mass, refused, tuple(missing), table)


def _trial_loads(
    args: argparse.Namespace,
    path: str,
    forces: list[str] | None,
    i: int,
    traj: MarkerTrajectory,
) -> TrialLoads | None:
    source = forces[i] if forces else path
    if not forces and Path(path).suffix.lower() != ".c3d":
        return None
    try:
        plates = _read(source, traj, getattr(args, "up", None))
    except MocapError as exc:
        if forces:  # asked for: refused; a C3D's own plates: no kinetics, one warning
            raise
        _warn(args, f"{exc}: no kinetics for this trial")
        return None
    if not plates:
        if forces:
            raise MocapError(f"{source}: --forces: expected force plates, the file has none")
        return None
    try:
        found = contacts(plates, traj)
        feet = assign_feet(plates, traj)
        speeds = pivot_speeds(traj)
    except MocapError as exc:
        why = f"{path}: the feet on the force plates of {source}: {exc}"
        if forces:  # asked for: refused; a C3D's own plates: no kinetics, one warning
            raise MocapError(why) from None
        _warn(args, f"{why}: no kinetics for this trial")
        return None
    events, _ = _events(args, path, traj, feet)  # without heels and toes: none
    return TrialLoads(
        path, source, tuple(p.name for p in plates), tuple(found), feet, speeds, traj.times, events
    )


def _read(source: str, traj: MarkerTrajectory, up: str | None = None) -> list[PlateRecord]:
    """The plates of ``source`` at the trajectory's rate, frame k at its frame k (a .mot's
    rows from its first: trimmed or padded with unloaded frames to the trajectory's); a C3D's
    rotated by ``--up`` when given, as its markers are."""
    if Path(source).suffix.lower() in (".mot", ".sto"):
        plates = read_grf_mot(source, marker_rate=traj.rate)
        return [_fit_frames(p, traj.n_frames) for p in plates]
    plates = read_plates(source, marker_rate=traj.rate, up=up)
    for p in plates:
        if len(p.force) != traj.n_frames:
            raise MocapError(
                f"{source}: {p.name}: expected {traj.n_frames} frames (the marker file's), "
                f"got {len(p.force)}"
            )
    return plates


def _fit_frames(p: PlateRecord, frames: int) -> PlateRecord:
    n = min(frames, len(p.force))

    def fit(x: np.ndarray, fill: float) -> np.ndarray:
        out = np.full((frames, 3), fill)
        out[:n] = x[:n]
        return out

    return PlateRecord(
        p.name, p.plate_type, p.corners, fit(p.force, 0.0), fit(p.cop, np.nan),
        fit(p.free_moment, 0.0), p.rate,
    )  # fmt: skip


def _events(
    args: argparse.Namespace, path: str, traj: MarkerTrajectory, feet: Any
) -> tuple[tuple[GaitEvent, ...], str | None]:
    """The trial's gait events and, when the markers cannot tell (a marker set without heels
    and toes), none and why (summary.json's ``kinetics`` ``events_missing``)."""
    try:
        return tuple(gait_events(path, traj, loads=feet)), None
    except MocapError as exc:
        return (), f"{path}: {exc}"


def _warn(args: argparse.Namespace, line: str) -> None:
    print(f"mocap-mj {args.command}: warning: {line}", file=sys.stderr)


def write_trial(
    args: argparse.Namespace,
    prepared: Prepared,
    i: int,
    out: Path,
    folder: str,
    frames: slice,
    inertia: BodyInertia | None = None,
) -> tuple[dict[str, Any] | None, list[str]]:
    """Write trial ``i``'s events.csv and, with loads and a mass, its kinetics into
    ``out / folder`` (its motion.npz there, over the recording's rows ``frames``; model.xml
    in ``out``, with ``inertia``'s segment parameters, None: de Leva's); summary.json's entry
    of the trial's kinetics (None without) and the files written, relative to ``out``."""
    where = out / folder
    where.mkdir(parents=True, exist_ok=True)
    events = _in_frames(prepared.events[i], prepared, i, frames)
    atomic_write_text(where / EVENTS_CSV, events_csv(events))
    written = [_relative(where / EVENTS_CSV, out)]
    trial = prepared.loads[i]
    if trial is None or prepared.mass is None:
        return None, written
    mass = prepared.mass
    bodies = (
        {str(model.body(b).name) for b in range(model.nbody)}
        if (model := _written(out / "model.xml"))
        else set()
    )
    missing = [b for b in FOOT_BODIES.values() if b not in bodies]
    if missing:
        _warn(args, f"{out / 'model.xml'}: no foot body {', '.join(missing)}: no kinetics")
        return None, written
    feet, stance = trial_stance(trial, frames)
    head = _trial_head(trial, feet)
    if not any(f.on_plate.any() for f in feet):  # no load to compute joint moments under
        note = "no foot stands alone on a plate in the frames: no joint moments"
        return {**head, "stance_frames": 0, "files": written, "note": note}, written
    t0 = time.perf_counter()
    dyn, force_dofs = dynamics_of_files(
        out / "model.xml",
        where / "motion.npz",
        body_loads(feet),
        mass,
        sex=prepared.sex,
        inertia=inertia,
    )
    seconds = time.perf_counter() - t0
    files = write_dynamics(where, dyn, mass, force_dofs)
    grf = write_grf(where / GRF_CSV, dyn.times, feet)
    written += [_relative(f, out) for f in (*files, grf)]
    fig = residual_figures(dyn, feet, mass, stance)
    return {
        **head,
        "frames_on_plate": {f.side: int(f.on_plate.sum()) for f in feet},
        "body_mass_kg": mass,
        "sex": prepared.sex,
        "smoothing": {
            "filter": "Butterworth low-pass, zero lag (forward and backward)",
            "order": 2 * PASS_ORDER,
            "cutoff_hz": CUTOFF_HZ,
        },
        "stance_frames": fig.frames,
        "residual_force_rms_n": fig.force_rms_n,
        "residual_force_rms_pct_bw": fig.force_rms_pct_bw,
        "residual_force_rms_pct_peak_grf": fig.force_rms_pct_peak_grf,
        "peak_grf_n": fig.peak_grf_n,
        "residual_moment_rms_nm": fig.moment_rms_nm,
        "inverse_dynamics_seconds": seconds,
        "files": written,
    }, written


def trial_stance(trial: TrialLoads, frames: slice) -> tuple[tuple[FootLoads, ...], np.ndarray]:
    """The feet's loads of ``trial`` on the recording's rows ``frames`` and its stance frames
    (T,) bool there: a foot on a counted plate, no contact left out, and no still foot off
    the counted plates (its slowest marker under :data:`STILL_SPEED`: it stands, lands or
    pushes off on something unmeasured)."""
    feet = tuple(sliced(f, frames) for f in trial.feet)
    stance = stance_frames(feet, excluded_frames(trial.found, len(trial.times))[frames])
    for f in feet:
        stance &= f.on_plate | ~(trial.speeds[f.side][frames] < STILL_SPEED)
    return feet, stance


def stance_trials(
    prepared: Prepared, out: Path, folders: list[str], frames: list[slice]
) -> list[StanceTrial]:
    """Every trial with plates as the mass fit takes it: its motion.npz in ``out / folder``
    (``folders``, one per trial), its loads and stance frames over its rows ``frames``."""
    found = []
    for trial, folder, rows in zip(prepared.loads, folders, frames, strict=True):
        if trial is None:
            continue
        feet, stance = trial_stance(trial, rows)
        motion = out / folder / "motion.npz"
        found.append(StanceTrial(trial.markers, motion, tuple(body_loads(feet)), stance, feet))
    return found


def _relative(path: Path, out: Path) -> str:
    """``path`` as summary.json names it: relative to the result folder ``out``."""
    return path.relative_to(out).as_posix()


def _trial_head(trial: TrialLoads, feet: tuple[FootLoads, ...]) -> dict[str, Any]:
    """A trial's kinetics entry's first fields: its files, plates, each foot's counted plates
    and the contacts left out (one reason each)."""
    per_foot = {
        f.side: sorted(
            {trial.plates[c.plate] for c in trial.found if c.reason is None and c.side == f.side}
        )
        for f in feet
    }
    if not any(f.on_plate.any() for f in feet):
        per_foot = {f.side: [] for f in feet}
    return {
        "markers_file": trial.markers,
        "forces_file": trial.source,
        "plates": list(trial.plates),
        "plates_per_foot": per_foot,
        "excluded_contacts": sorted({r for f in trial.feet for r in f.excluded}),
    }


def _in_frames(
    events: tuple[GaitEvent, ...], prepared: Prepared, i: int, frames: slice
) -> list[GaitEvent]:
    times = prepared.times[i][frames]
    if len(times) == 0:
        return []
    return [e for e in events if times[0] - 1e-9 <= e.time <= times[-1] + 1e-9]


def _written(path: Path) -> Any:
    """The model file ``path`` as plain MuJoCo compiles it (None if it cannot)."""
    try:
        return load_written(path)
    except (MocapError, ValueError, OSError):
        return None


def summary_of(prepared: Prepared, entries: list[dict[str, Any] | None]) -> dict[str, Any]:
    """summary.json's ``kinetics`` section."""
    return {
        "trials": [e for e in entries if e is not None],
        "refused": prepared.refused,
        "body_mass_kg": prepared.mass,
        "events_missing": list(prepared.events_missing),
    }


def text_of(section: dict[str, Any]) -> str:
    """The kinetics lines of the command's output and report.md: per trial its plates per
    foot, the residual figures over stance and one line per excluded contact."""
    lines = []
    for e in section["trials"]:
        if "note" in e:
            lines.append(f"kinetics of {Path(e['markers_file']).name}: {e['note']}")
            lines += [f"  excluded contact: {r}" for r in e["excluded_contacts"]]
            continue
        per_foot = "; ".join(
            f"{side} foot {', '.join(p) or 'none'}" for side, p in e["plates_per_foot"].items()
        )
        if e["stance_frames"]:
            residual = (
                f"root residual over {e['stance_frames']} stance frames: force RMS "
                f"{e['residual_force_rms_n']:.0f} N ({e['residual_force_rms_pct_bw']:.1f} % "
                f"body weight, {e['residual_force_rms_pct_peak_grf']:.1f} % of the peak ground "
                f"reaction), moment RMS {e['residual_moment_rms_nm']:.1f} N m"
            )
        else:  # every loaded frame has a still foot off the plates (root_residuals.csv: all)
            residual = "no stance frame (a still foot off the plates on every loaded frame)"
        lines.append(
            f"kinetics of {Path(e['markers_file']).name} ({e['forces_file']}): {per_foot}; "
            f"{residual}; smoothing {e['smoothing']['order']}th-order zero-lag Butterworth, "
            f"{e['smoothing']['cutoff_hz']:g} Hz"
        )
        lines += [f"  excluded contact: {r}" for r in e["excluded_contacts"]]
    if section["refused"] and section["refused"] not in ("no force plates", "--forces none"):
        lines.append(f"kinetics: {section['refused']}")
    return "\n".join(lines)


def report_section(section: dict[str, Any]) -> str:
    """report.md's "Kinetics" section (empty without force plates)."""
    body = text_of(section)
    if not body:
        return ""
    return (
        "\n## Kinetics\n\n"
        + "\n".join(
            f"- {line.strip()}" if not line.startswith("  ") else f"  - {line.strip()}"
            for line in body.splitlines()
        )
        + "\n"
    )
