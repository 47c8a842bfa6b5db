"""Gait events: foot strike and foot off of each side, with their times, frames and source.

Three sources, in the order :func:`gait_events` tries them:

1. **The recording's own events**: a C3D file's EVENT group (``EVENT:CONTEXTS``, ``LABELS``,
   ``TIMES``, ``USED``), as Vicon Nexus ("Left" / "Right", "Foot Strike" / "Foot Off") or
   Qualisys ("LHS", "RTO": side letter, then HS / FS / IC for a strike, TO / FO for an off)
   write them. Other events ("General", "Event") are left out.
2. **The force plates**: on a plate the foot alone stands on (:mod:`mocap_mj.capture.contacts`),
   foot strike at the first frame whose vertical force exceeds the threshold (default 20 N),
   foot off at the first frame after the contact at or below it; a contact already under way
   when the recording starts gives no strike, one still under way at its end no off.
3. **The kinematics** (Zeni, Richards & Higginson 2008, Gait Posture 27:710): along the
   direction of progression (the horizontal direction of the pelvis's travel from the first
   to the last frame), foot strike at each maximum of the heel's lead over the sacrum, foot
   off at each minimum of the toe's; the sacrum is SACR or the mean of LPSI and RPSI. The
   heel-lead maximum comes 30-40 ms before the heel lands (6-8 frames on Qualisys.c3d), so
   each strike moves to the heel's fastest descent in the 0.1 s after it (the foot-velocity
   rule of O'Connor et al. 2007, Gait Posture 25:469): within 2 frames of the plates' there.

Times are on the recording's time axis (a frame f of the recording at (f - 1) / rate [s], as
the lab's software and :class:`~mocap_mj.io.trajectory.MarkerTrajectory`'s ``times`` count);
``frame`` is the recording's frame number.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.signal import find_peaks

from mocap_mj.capture.contacts import FootLoads
from mocap_mj.errors import InputFileError, MocapError
from mocap_mj.io.formats.c3d import read_parameters
from mocap_mj.io.trajectory import MarkerTrajectory

__all__ = [
    "EVENTS_HEADER",
    "SOURCES",
    "GaitEvent",
    "add_events",
    "events_csv",
    "events_from_c3d",
    "events_from_kinematics",
    "events_from_loads",
    "gait_events",
    "read_events_csv",
]

#: Each event's ``source``, by the rule that found it.
SOURCES = {
    "c3d": "the recording's EVENT group",
    "plates": "force plate",
    "kinematics": "kinematics (Zeni et al. 2008)",
}
KINDS = ("foot_strike", "foot_off")
#: Vicon Nexus's labels of the two kinds, as written into a C3D EVENT group.
_VICON_LABELS = {"foot_strike": "Foot Strike", "foot_off": "Foot Off"}


@dataclass(frozen=True)
class GaitEvent:
    """One gait event: ``side`` ("left" / "right"), ``kind`` ("foot_strike" / "foot_off"),
    ``time`` [s] on the recording's time axis, ``frame`` (the recording's frame number, from
    1) and ``source`` (one of :data:`SOURCES`' values)."""

    side: str
    kind: str
    time: float
    frame: int
    source: str


def events_from_c3d(path: str | os.PathLike[str], *, rate: float | None = None) -> list[GaitEvent]:
    """The foot strikes and foot offs of a C3D file's EVENT group, in time order (empty when
    it has none). ``rate`` [Hz]: the frame rate for the frame numbers (default POINT:RATE).

    Raises
    ------
    InputFileError
        The file is not a C3D ezc3d reads, or its EVENT group's TIMES do not hold a (minutes,
        seconds) pair per event.
    """
    file = Path(path)
    try:
        params = read_parameters(file)
    except Exception as exc:  # ezc3d raises RuntimeError, OSError, ValueError...
        message = " ".join(str(exc).split())[:200]
        raise InputFileError(f"{file}: ezc3d could not read it: {message}") from exc
    group = params.get("EVENT", {})
    labels = _strings(group, "LABELS")
    contexts = _strings(group, "CONTEXTS")
    used = _values(group, "USED")
    n = int(used[0]) if used else len(labels)
    if n == 0:
        return []
    times = np.asarray(group.get("TIMES", {}).get("value", []), dtype=float)
    if times.ndim != 2 or times.shape[0] != 2 or times.shape[1] < n:
        raise InputFileError(
            f"{file}: group EVENT:TIMES: expected (minutes, seconds) of {n} events, got an "
            f"array of shape {times.shape}"
        )
    frame_rate = rate if rate is not None else _rate(file, params)
    out = []
    for k in range(min(n, len(labels))):
        got = _kind(contexts[k] if k < len(contexts) else "", labels[k])
        if got is None:
            continue
        time = float(60.0 * times[0, k] + times[1, k])
        out.append(GaitEvent(got[0], got[1], time, _frame(time, frame_rate), SOURCES["c3d"]))
    return sorted(out, key=lambda e: (e.time, e.side))


def events_from_loads(
    loads: Sequence[FootLoads], times: np.ndarray, *, threshold_n: float = 20.0
) -> list[GaitEvent]:
    """Foot strikes and foot offs from the feet's counted plate contacts (module docstring),
    in time order. ``times`` (T,) [s]: the frames' times (``MarkerTrajectory.times``)."""
    rate = _rate_of(times)
    out = []
    for foot in loads:
        up = foot.on_plate & (foot.force[:, 2] > threshold_n)
        edges = np.diff(up.astype(int))
        for i in np.flatnonzero(edges == 1) + 1:  # up from frame i
            out.append(_event(foot.side, "foot_strike", float(times[i]), rate, "plates"))
        for i in np.flatnonzero(edges == -1) + 1:  # down from frame i
            out.append(_event(foot.side, "foot_off", float(times[i]), rate, "plates"))
    return sorted(out, key=lambda e: (e.time, e.side))


def events_from_kinematics(
    trajectory: MarkerTrajectory,
    *,
    heel: dict[str, str] | None = None,
    toe: dict[str, str] | None = None,
    sacrum: Sequence[str] | None = None,
    min_interval_s: float = 0.3,
    min_prominence_m: float = 0.05,
    descent_s: float = 0.1,
) -> list[GaitEvent]:
    """Foot strikes and foot offs after Zeni et al. 2008 (module docstring), in time order.

    ``heel``, ``toe``: side -> marker (default Plug-in Gait's LHEE/RHEE, LTOE/RTOE);
    ``sacrum``: the markers whose mean is the sacrum (default SACR, else LPSI and RPSI). Two
    events of one kind and side are at least ``min_interval_s`` apart (default 0.3 s: a
    stride lasts 0.8-1.5 s), and each stands out from its neighbours by
    ``min_prominence_m`` (default 5 cm: a step's heel lead is some 30 cm). A strike moves
    to the heel's fastest descent within ``descent_s`` after the heel-lead maximum (default
    0.1 s; 0: Zeni's maximum itself).

    Raises
    ------
    MocapError
        A marker it needs is not in the trajectory.
    """
    names = set(trajectory.names)
    heel = heel or {"left": "LHEE", "right": "RHEE"}
    toe = toe or {"left": "LTOE", "right": "RTOE"}
    chosen = list(sacrum) if sacrum else (["SACR"] if "SACR" in names else ["LPSI", "RPSI"])
    needed = [*heel.values(), *toe.values(), *chosen]
    missing = [n for n in needed if n not in names]
    if missing:
        raise MocapError(
            f"gait events from kinematics: expected the markers {', '.join(needed)}, the "
            f"trajectory lacks {', '.join(missing)}"
        )
    pelvis = np.nanmean(trajectory.select(chosen), axis=1)  # (T, 3)
    seen = np.flatnonzero(np.isfinite(pelvis).all(axis=1))
    if len(seen) < 2:
        return []
    travel = pelvis[seen[-1], :2] - pelvis[seen[0], :2]
    if np.linalg.norm(travel) < min_prominence_m:
        return []  # no progression: standing, turning on the spot
    direction = travel / np.linalg.norm(travel)
    rate, distance = trajectory.rate, max(1, round(min_interval_s * trajectory.rate))
    out = []
    for side in ("left", "right"):
        for kind, marker, signal_sign in (("foot_strike", heel, 1.0), ("foot_off", toe, -1.0)):
            lead = (trajectory.select([marker[side]])[:, 0, :2] - pelvis[:, :2]) @ direction
            signal = _filled(signal_sign * lead)
            if signal is None:
                continue
            peaks, _ = find_peaks(signal, distance=distance, prominence=min_prominence_m)
            if kind == "foot_strike" and descent_s > 0:
                height = _filled(trajectory.select([marker[side]])[:, 0, 2])
                peaks = peaks if height is None else _descents(height, peaks, descent_s * rate)
            for i in peaks:
                out.append(_event(side, kind, float(trajectory.times[i]), rate, "kinematics"))
    return sorted(out, key=lambda e: (e.time, e.side))


def gait_events(
    path: str | os.PathLike[str] | None,
    trajectory: MarkerTrajectory,
    *,
    loads: Sequence[FootLoads] | None = None,
    threshold_n: float = 20.0,
) -> list[GaitEvent]:
    """The recording's gait events from the first source that has any (module docstring):
    the C3D EVENT group of ``path`` (a C3D file; None or another format: skipped), else the
    feet's plate ``loads``, else the kinematics of ``trajectory``."""
    if path is not None and Path(path).suffix.lower() == ".c3d":
        found = events_from_c3d(path, rate=trajectory.rate)
        if found:
            return found
    if loads:
        found = events_from_loads(loads, trajectory.times, threshold_n=threshold_n)
        if found:
            return found
    return events_from_kinematics(trajectory)


def add_events(c3d: Any, events: Sequence[GaitEvent]) -> None:
    """Add ``events`` to the EVENT group of the ezc3d object ``c3d`` (before it is written),
    as Vicon Nexus writes them: context "Left" / "Right", label "Foot Strike" / "Foot Off",
    time as (0 minutes, seconds), the source as the description."""
    for e in events:
        c3d.add_event(
            [0.0, float(e.time)],
            context=e.side.capitalize(),
            label=_VICON_LABELS[e.kind],
            description=e.source,
        )


#: events.csv's columns: side, kind, the recording's frame number, time [s], source.
EVENTS_HEADER = ("side", "kind", "frame", "time_s", "source")


def events_csv(events: Sequence[GaitEvent]) -> str:
    """events.csv's text: a header (:data:`EVENTS_HEADER`) and a row per event, in order."""
    lines = [",".join(EVENTS_HEADER)]
    for e in events:
        lines.append(f"{e.side},{e.kind},{e.frame},{e.time:.6f},{e.source}")
    return "\n".join(lines) + "\n"


def read_events_csv(path: str | os.PathLike[str]) -> list[GaitEvent]:
    """The events of an events.csv file (:func:`events_csv`).

    Raises
    ------
    InputFileError
        The file cannot be read, its header is not :data:`EVENTS_HEADER`, or a row is not a
        side, a kind, a frame number, a time and a source (the message names the row).
    """
    file = Path(path)
    try:
        lines = file.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise InputFileError(f"{file}: cannot read: {exc.strerror or exc}") from None
    if not lines or tuple(lines[0].split(",")) != EVENTS_HEADER:
        raise InputFileError(f"{file}: line 1: expected the header {','.join(EVENTS_HEADER)}")
    out = []
    for i, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",", 4)
        try:
            side, kind, frame, time, source = cells
            event = GaitEvent(side, kind, time=float(time), frame=int(frame), source=source)
        except ValueError:
            event = None
        if event is None or event.side not in ("left", "right") or event.kind not in KINDS:
            raise InputFileError(
                f"{file}: line {i}: expected side (left/right), kind (foot_strike/foot_off), "
                f"frame, time_s and source, got {line[:60]!r}"
            )
        out.append(event)
    return out


def _event(side: str, kind: str, time: float, rate: float, source: str) -> GaitEvent:
    return GaitEvent(side, kind, time, _frame(time, rate), SOURCES[source])


def _frame(time: float, rate: float) -> int:
    """The recording's frame number at ``time`` [s] (frame f at (f - 1) / rate)."""
    return round(time * rate) + 1


def _rate_of(times: np.ndarray) -> float:
    if len(times) < 2:
        raise MocapError(f"gait events: expected at least two frames, got {len(times)}")
    return float(1.0 / np.median(np.diff(times)))


def _descents(height: np.ndarray, peaks: np.ndarray, window: float) -> np.ndarray:
    """Per frame of ``peaks``, the frame of the fastest fall of ``height`` (T,) [m] within
    ``window`` frames after it (the peak itself when the window holds no fall)."""
    fall = np.gradient(height)
    out = []
    for i in peaks:
        stop = min(len(height), i + max(1, round(window)) + 1)
        j = i + int(np.argmin(fall[i:stop]))
        out.append(j if fall[j] < 0 else i)
    return np.asarray(out, dtype=int)


def _filled(signal: np.ndarray) -> np.ndarray | None:
    """``signal`` (T,) with its gaps linearly interpolated; None when under half is seen."""
    ok = np.isfinite(signal)
    if ok.sum() < max(3, len(signal) // 2):
        return None
    x = np.arange(len(signal))
    return np.asarray(np.interp(x, x[ok], signal[ok]))


_QUALISYS = re.compile(r"^(?P<side>[LR])(?P<kind>HS|FS|IC|TO|FO)$", re.IGNORECASE)


def _kind(context: str, label: str) -> tuple[str, str] | None:
    """(side, kind) of an EVENT entry, None for an event other than a foot strike or off."""
    text, ctx = label.strip(), context.strip().lower()
    match = _QUALISYS.match(text)
    if match:
        side = "left" if match["side"].upper() == "L" else "right"
        kind = "foot_off" if match["kind"].upper() in ("TO", "FO") else "foot_strike"
        return side, kind
    if ctx not in ("left", "right"):
        return None
    low = text.lower()
    if "strike" in low or "contact" in low:
        return ctx, "foot_strike"
    if "off" in low:
        return ctx, "foot_off"
    return None


def _rate(file: Path, params: dict[str, Any]) -> float:
    rate = _values(params.get("POINT", {}), "RATE")
    if not rate or not float(rate[0]) > 0:
        raise InputFileError(f"{file}: group POINT:RATE: expected a positive frame rate")
    return float(rate[0])


def _values(group: dict[str, Any], name: str) -> list[Any]:
    entry = group.get(name)
    if not isinstance(entry, dict) or entry.get("value") is None:
        return []
    value = entry["value"]
    return list(np.ravel(value)) if not isinstance(value, list) else value


def _strings(group: dict[str, Any], name: str) -> list[str]:
    return [str(v).strip() for v in _values(group, name)]
