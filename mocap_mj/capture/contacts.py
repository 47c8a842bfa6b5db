"""Which foot stands on which force plate: each plate's load assigned to a foot.

A plate counts for a foot only while that foot alone stands on it. A *contact* is a run of
loaded frames of one plate (vertical force over the threshold the plate was read with:
:class:`~mocap_mj.io.plates.PlateRecord`'s ``loaded``). Its foot is the one whose markers
lie nearest the centre of pressure, horizontally: the distance from the centre of pressure
to the nearest segment joining two of the foot's markers (heel, toe, ankle), medianed over
the contact's frames, must be at most ``cop_tolerance_m`` (default 0.10 m: half a foot's
length). A contact is left out, with a reason, when

- no foot's markers lie that near the centre of pressure (a hand, an object, a gap);
- the other foot also stands on the plate during it: a marker of the other foot inside the
  plate's outline, its lowest marker within ``stand_height_m`` (0.12 m) of the surface and
  the foot still (its markers' mean speed under ``still_speed`` = 0.5 m/s; a swinging foot
  passing over the plate moves at 1-5 m/s);
- the same foot is the foot of a contact of another plate at the same time (it straddles
  two plates: neither plate holds its whole load).

A recording that already holds the ground reaction under each foot from the software that
processed it (Vicon Nexus' ``LGroundReactionForce``, ``RGroundReactionForce``:
:func:`~mocap_mj.io.plates.recorded_ground_reactions`) carries that software's own choice of
contacts, manual ones included (a lab sets a plate Invalid, Left or Right in Nexus, and only
its outputs keep the choice). :func:`as_recorded` applies it to the contacts above: one
counts when the recording's ground reaction of its foot is there over at least half its
frames and matches the plate's force (the RMS difference of the force magnitudes within
:data:`RECORDED_MATCH`, 5 % of the contact's peak, per kg or in N); one whose frames the
recording leaves empty is left out; any other keeps the rules' verdict, with a note.

The foot markers are Plug-in Gait's (``LHEE``, ``LTOE``, ``LANK`` and the right side's) by
default; another marker set passes its own (e.g. the markers :func:`~mocap_mj.capture.roles.roles`
gives for the roles ``LHEE``, ``LTOE``, ``LANK``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from mocap_mj.errors import MocapError, ShapeError
from mocap_mj.io.plates import PlateRecord
from mocap_mj.io.trajectory import MarkerTrajectory

__all__ = [
    "PIG_FEET",
    "RECORDED_MATCH",
    "STILL_SPEED",
    "Contact",
    "FootLoads",
    "as_recorded",
    "assign_feet",
    "contacts",
    "foot_speeds",
    "pivot_speeds",
]

#: Plug-in Gait's foot markers per side: heel, toe (second metatarsal head), lateral malleolus.
PIG_FEET: dict[str, tuple[str, ...]] = {
    "left": ("LHEE", "LTOE", "LANK"),
    "right": ("RHEE", "RTOE", "RANK"),
}
SIDES = ("left", "right")
#: A foot whose markers' speed is under this [m/s] is still (standing): their mean speed for
#: a second foot on a plate, its slowest marker's off the plates (:func:`pivot_speeds`); a
#: swinging foot moves at 1-5 m/s, and at 0.7 m/s or more as it slows to land.
STILL_SPEED = 0.5
#: A contact matches the recording's ground reaction of its foot when the RMS difference of
#: the force magnitudes is within this fraction of the contact's peak.
RECORDED_MATCH = 0.05


@dataclass(frozen=True)
class FootLoads:
    """The ground reaction under one foot per marker frame, from the plates it alone stood on.

    Fields: ``side`` ("left" or "right"); ``force`` (T, 3) [N], the force on the foot, 0
    where the foot is not on a counted plate; ``cop`` (T, 3) [m], the centre of pressure, NaN
    where not loaded; ``free_moment`` (T, 3) [N m], the free moment about the vertical at the
    centre of pressure, 0 where not loaded; ``on_plate`` (T,) bool, the frames of counted
    contacts; ``excluded``: a reason per contact left out (plate, frames, why).
    """

    side: str
    force: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    on_plate: np.ndarray
    excluded: tuple[str, ...]


@dataclass(frozen=True)
class Contact:
    """A run of loaded rows [start, stop) (indices into the trajectory's frames) of plate
    ``plate`` (index), the foot nearest its centre of pressure (``side``, None if none is
    near enough) and why it is left out (``reason``, None when it counts; it names frames by
    the recording's numbers)."""

    plate: int
    start: int
    stop: int
    side: str | None
    reason: str | None


def contacts(
    plates: Sequence[PlateRecord],
    trajectory: MarkerTrajectory,
    *,
    feet: Mapping[str, Sequence[str]] | None = None,
    cop_tolerance_m: float = 0.10,
    stand_height_m: float = 0.12,
    still_speed: float = 0.5,
) -> list[Contact]:
    """Every contact of ``plates`` with its foot and, for those left out, the reason (the
    rules: the module docstring). ``plates`` must hold ``trajectory``'s frames (read at its
    rate from the same recording); ``feet``: side -> its foot markers (default
    :data:`PIG_FEET`, those ``trajectory`` holds)."""
    points = _foot_points(trajectory, feet)
    n = trajectory.n_frames
    for plate in plates:
        if len(plate.force) != n:
            raise ShapeError(
                f"{plate.name}: expected {n} frames (the trajectory's), got {len(plate.force)}"
            )
    speed = {s: _speed(p, trajectory.rate) for s, p in points.items()}
    first = trajectory.first_frame or 1  # the recording's number of row 0
    found: list[Contact] = []
    for k, plate in enumerate(plates):
        for start, stop in _runs(plate.loaded):
            frames = slice(start, stop)
            dist = {
                s: _median(_cop_distance(plate.cop[frames], p[frames])) for s, p in points.items()
            }
            side = min(dist, key=lambda s: dist[s])
            where = f"{plate.name}, frames {first + start}-{first + stop - 1}"
            if dist[side] > cop_tolerance_m:
                found.append(Contact(k, start, stop, None, (
                    f"{where}: no foot's markers within {cop_tolerance_m:g} m of the centre "
                    f"of pressure"
                )))  # fmt: skip
                continue
            other = SIDES[1 - SIDES.index(side)]
            if other in points and _stands(
                plate, points[other][frames], speed[other][frames], stand_height_m, still_speed
            ):
                found.append(Contact(k, start, stop, side, f"{where}: both feet on the plate"))
                continue
            found.append(Contact(k, start, stop, side, None))
    return _straddles(found, plates, first)


def assign_feet(
    plates: Sequence[PlateRecord],
    trajectory: MarkerTrajectory,
    *,
    feet: Mapping[str, Sequence[str]] | None = None,
    cop_tolerance_m: float = 0.10,
    stand_height_m: float = 0.12,
    still_speed: float = 0.5,
) -> tuple[FootLoads, FootLoads]:
    """The loads (left, right) of each foot from the contacts that count (:func:`contacts`;
    the rules: the module docstring). A reason is reported in ``excluded`` of the foot
    nearest the contact's centre of pressure (of both feet when no foot is near)."""
    found = contacts(
        plates,
        trajectory,
        feet=feet,
        cop_tolerance_m=cop_tolerance_m,
        stand_height_m=stand_height_m,
        still_speed=still_speed,
    )
    n = trajectory.n_frames
    out = []
    for side in SIDES:
        force, free = np.zeros((n, 3)), np.zeros((n, 3))
        cop = np.full((n, 3), np.nan)
        on = np.zeros(n, dtype=bool)
        reasons = []
        for c in found:
            if c.reason is not None:
                if c.side in (side, None):
                    reasons.append(c.reason)
                continue
            if c.side != side:
                continue
            plate, frames = plates[c.plate], slice(c.start, c.stop)
            force[frames] = plate.force[frames]
            cop[frames] = plate.cop[frames]
            free[frames] = plate.free_moment[frames]
            on[frames] = True
        out.append(FootLoads(side, force, cop, free, on, tuple(reasons)))
    return out[0], out[1]


def as_recorded(
    found: Sequence[Contact],
    plates: Sequence[PlateRecord],
    recorded: Mapping[str, np.ndarray],
    *,
    body_mass: float,
    first: int = 1,
) -> tuple[list[Contact], list[str]]:
    """The contacts ``found`` (:func:`contacts`) with the choice the recording carries
    (the rules: the module docstring). ``recorded``: side -> (T, 3) the ground reaction the
    recording holds under that foot, NaN where it holds none
    (:func:`~mocap_mj.io.plates.recorded_ground_reactions`), per kg of ``body_mass`` [kg]
    or in N; ``first``: the recording's number of row 0. Returns the contacts (those the
    recording leaves out with that reason) and a note per contact it cannot decide."""
    frames = len(plates[0].force) if plates else 0
    if any(len(v) != frames for v in recorded.values()):
        lengths = ", ".join(f"{len(v)}" for v in recorded.values())
        note = f"the recording's ground reactions hold {lengths} frames, the plates {frames}"
        return list(found), [f"{note}: the rules decide"]
    out, notes = [], []
    for c in found:
        values = recorded.get(c.side or "")
        if c.side is None or values is None:
            out.append(c)
            continue
        rows = slice(c.start, c.stop)
        theirs = np.linalg.norm(values[rows], axis=1)
        ours = np.linalg.norm(plates[c.plate].force[rows], axis=1)
        seen = np.isfinite(theirs)
        where = f"{plates[c.plate].name}, frames {first + c.start}-{first + c.stop - 1}"
        if not seen.any():
            out.append(Contact(c.plate, c.start, c.stop, c.side, (
                f"{where}: the recording's own ground reaction of the {c.side} foot leaves "
                "it out"
            )))  # fmt: skip
            continue
        peak = float(np.max(ours[seen]))
        gaps = [np.sqrt(np.mean((theirs[seen] * scale - ours[seen]) ** 2)) / peak
                for scale in (body_mass, 1.0)]  # fmt: skip
        if seen.mean() >= 0.5 and min(gaps) <= RECORDED_MATCH:
            out.append(Contact(c.plate, c.start, c.stop, c.side, None))
            continue
        out.append(c)
        notes.append(
            f"{where}: the recording's ground reaction of the {c.side} foot differs from the "
            f"plate's ({100 * min(gaps):.0f} % of its peak, {seen.mean():.0%} of the frames); "
            "the rules decide"
        )
    return out, notes


def foot_speeds(
    trajectory: MarkerTrajectory, feet: Mapping[str, Sequence[str]] | None = None
) -> dict[str, np.ndarray]:
    """Side -> the mean speed (T,) [m/s] of its foot markers (``feet``, default
    :data:`PIG_FEET`; central differences; NaN where none is seen)."""
    return {s: _speed(p, trajectory.rate) for s, p in _foot_points(trajectory, feet).items()}


def pivot_speeds(
    trajectory: MarkerTrajectory, feet: Mapping[str, Sequence[str]] | None = None
) -> dict[str, np.ndarray]:
    """Side -> the speed (T,) [m/s] of its slowest foot marker (``feet``, default
    :data:`PIG_FEET`; central differences; NaN where none is seen).

    A loaded foot turns about a point of its sole (the heel as it lands, the forefoot as it
    pushes off) while its other markers move: the marker nearest that point is the one that
    stays still, so a foot is still (standing, :data:`STILL_SPEED`) when its slowest marker
    is. Their mean is not: a forefoot still pushing off under a rising heel and ankle moves
    at 0.5-1.2 m/s on the mean (Movement_trial.c3d's last push-off from the floor)."""
    out = {}
    for side, points in _foot_points(trajectory, feet).items():
        if len(points) < 2:
            out[side] = np.zeros(len(points))
            continue
        speeds = np.linalg.norm(np.gradient(points, 1.0 / trajectory.rate, axis=0), axis=2)
        seen = np.isfinite(speeds)
        slowest = np.where(seen, speeds, np.inf).min(axis=1)
        out[side] = np.where(seen.any(axis=1), slowest, np.nan)
    return out


def _foot_points(
    trajectory: MarkerTrajectory, feet: Mapping[str, Sequence[str]] | None
) -> dict[str, np.ndarray]:
    """Side -> its foot markers' positions (T, K, 3) [m]."""
    chosen = feet if feet is not None else PIG_FEET
    out = {}
    for side, names in chosen.items():
        if side not in SIDES:
            raise MocapError(f"feet: expected the sides 'left' and 'right', got {side!r}")
        have = [n for n in names if n in trajectory.names]
        if not have:
            raise MocapError(
                f"feet: the {side} foot's markers {', '.join(names)}: none is in the "
                f"trajectory (it has: {', '.join(trajectory.names[:12])}...)"
            )
        out[side] = trajectory.select(have)
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs [start, stop) of True in ``mask`` (T,)."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))  # fmt: skip


def _cop_distance(cop: np.ndarray, foot: np.ndarray) -> np.ndarray:
    """(T,) [m]: horizontal distance from ``cop`` (T, 3) to the nearest segment between two
    of the ``foot`` markers (T, K, 3) (to the marker itself for a single one); NaN where
    unknown."""
    c = cop[:, None, :2]
    if foot.shape[1] == 1:
        return np.asarray(np.linalg.norm(c[:, 0] - foot[:, 0, :2], axis=1))
    best = np.full(len(cop), np.inf)
    for i, j in combinations(range(foot.shape[1]), 2):
        a, b = foot[:, i, :2], foot[:, j, :2]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", c[:, 0] - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
        d = np.linalg.norm(c[:, 0] - (a + t[:, None] * ab), axis=1)
        best = np.fmin(best, d)
    best[~np.isfinite(best)] = np.nan
    return best


def _median(values: np.ndarray) -> float:
    """The median of the finite ``values``; infinity without any."""
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if len(finite) else float("inf")


def _speed(points: np.ndarray, rate: float) -> np.ndarray:
    """(T,) [m/s]: the mean speed of the markers ``points`` (T, K, 3) (central differences)."""
    if len(points) < 2:
        return np.zeros(len(points))
    speeds = np.linalg.norm(np.gradient(points, 1.0 / rate, axis=0), axis=2)  # (T, K)
    seen = np.isfinite(speeds)
    total = np.where(seen, speeds, 0.0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(total / seen.sum(axis=1))  # NaN where no marker is seen


def _stands(
    plate: PlateRecord,
    foot: np.ndarray,
    speed: np.ndarray,
    stand_height_m: float,
    still_speed: float,
) -> bool:
    """True if the foot (markers (T, K, 3), mean speed (T,)) stands on ``plate`` at a frame:
    a marker inside its outline, its lowest marker within ``stand_height_m`` of the surface,
    and still."""
    corners = plate.corners
    if not np.isfinite(corners).all():
        return False
    lo, hi = corners[:, :2].min(axis=0), corners[:, :2].max(axis=0)
    xy = foot[..., :2]
    inside = np.any(np.all((xy >= lo) & (xy <= hi), axis=2), axis=1)
    with np.errstate(invalid="ignore"):
        low = np.nanmin(foot[..., 2], axis=1) - corners[:, 2].mean() <= stand_height_m
        still = speed < still_speed
    return bool(np.any(inside & low & still))


def _straddles(found: list[Contact], plates: Sequence[PlateRecord], first: int) -> list[Contact]:
    """Contacts of one foot on two plates at once, marked left out (both of them); ``first``:
    the recording's number of frame 0, for the reasons."""
    out = list(found)
    for a, b in combinations(range(len(found)), 2):
        ca, cb = found[a], found[b]
        if ca.side is None or ca.side != cb.side or ca.plate == cb.plate:
            continue
        start, stop = max(ca.start, cb.start), min(ca.stop, cb.stop)
        if start >= stop:
            continue
        names = f"{plates[ca.plate].name} and {plates[cb.plate].name}"
        why = f"the {ca.side} foot straddles {names} (frames {first + start}-{first + stop - 1})"
        for i, c in ((a, ca), (b, cb)):
            if out[i].reason is None:
                where = f"{plates[c.plate].name}, frames {first + c.start}-{first + c.stop - 1}"
                out[i] = Contact(c.plate, c.start, c.stop, c.side, f"{where}: {why}")
    return out
