"""The in-memory marker trajectory that every reader returns and every writer takes."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocap_mj.errors import ShapeError, check_shape
from mocap_mj.io.marker_names import MARKER_NAMES

__all__ = ["MarkerReport", "MarkerTrajectory", "first_frame"]


def first_frame(source: Mapping[str, Any]) -> int:
    """The recording's own number of its first frame, from a reader's ``source`` record
    (``first_frame``: the C3D header's, a TRC's or CSV's first frame number), or 0 when the
    source numbers none."""
    return int(source.get("first_frame") or 0)


@dataclass(frozen=True, eq=False)
class MarkerTrajectory:
    """Marker positions over time, in metres, in the model's Z-up world.

    The arrays are copied on construction and made read-only.

    Parameters
    ----------
    times : (T,) float [s]
        Time of each frame.
    positions : (T, M, 3) float [m]
        Marker positions; NaN where a marker was not seen in a frame.
    names : tuple of str, length M
        Marker names, unique, in the order of ``positions``' second axis.
    rate : float [Hz]
        Frame rate.
    source : dict
        Where the data came from and what the reader did to it (path, format, units, up axis,
        dropped non-marker points, extras...). Free-form, for people and reports.
    """

    times: np.ndarray
    positions: np.ndarray
    names: tuple[str, ...]
    rate: float
    source: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=np.float64)
        positions = np.array(self.positions, dtype=np.float64)
        names = tuple(self.names)
        check_shape("times", times, (None,))
        check_shape("positions", positions, (times.shape[0], len(names), 3))
        if not all(isinstance(n, str) and n for n in names):
            raise ShapeError(f"names: expected non-empty strings, got {names!r}")
        if len(set(names)) != len(names):
            dupes = sorted({n for n in names if names.count(n) > 1})
            raise ShapeError(f"names: expected unique names, got duplicates {dupes}")
        if not np.all(np.isfinite(times)):
            raise ShapeError("times: expected finite values, got NaN or inf")
        if np.any(np.isinf(positions)):
            raise ShapeError("positions: expected finite values or NaN, got inf")
        rate = float(self.rate)
        if not (math.isfinite(rate) and rate > 0):
            raise ShapeError(f"rate: expected a positive frame rate in Hz, got {self.rate!r}")
        times.setflags(write=False)
        positions.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "rate", rate)
        object.__setattr__(self, "source", dict(self.source))

    def __repr__(self) -> str:
        where = self.source.get("path", "memory")
        return (
            f"MarkerTrajectory({self.n_frames} frames, {self.n_markers} markers, "
            f"{self.rate:g} Hz, from {where})"
        )

    @property
    def first_frame(self) -> int:
        """The recording's own number of frame 0 (the C3D header's first frame, a TRC's or
        CSV's first frame number; 0 when the source numbers none): frame i is
        ``first_frame + i`` in every table the tool writes."""
        return first_frame(self.source)

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return int(self.positions.shape[0])

    @property
    def n_markers(self) -> int:
        """Number of markers M."""
        return int(self.positions.shape[1])

    def select(self, names: Sequence[str]) -> np.ndarray:
        """Positions of the markers ``names``, in that order.

        Parameters
        ----------
        names : sequence of str, length K
            Marker names; a single string is taken as one name.

        Returns
        -------
        (T, K, 3) float [m]
            A new array; all-NaN columns for names the trajectory does not have.
        """
        wanted = (names,) if isinstance(names, str) else tuple(names)
        index = {name: i for i, name in enumerate(self.names)}
        out = np.full((self.n_frames, len(wanted), 3), np.nan)
        for k, name in enumerate(wanted):
            i = index.get(name)
            if i is not None:
                out[:, k] = self.positions[:, i]
        return out

    def slice(self, start: int | None, stop: int | None) -> MarkerTrajectory:
        """Frames ``start:stop`` (Python slice rules), with their original times."""
        frames = range(self.n_frames)[start:stop]
        lo, hi = frames.start, frames.stop
        source = dict(self.source)
        source["frames"] = (lo, max(lo, hi))
        source["first_frame"] = self.first_frame + lo
        return MarkerTrajectory(
            times=self.times[lo:hi],
            positions=self.positions[lo:hi],
            names=self.names,
            rate=self.rate,
            source=source,
        )

    def marker_report(self, model_names: Sequence[str] = MARKER_NAMES) -> MarkerReport:
        """Which model markers the trajectory has, which it lacks, and how often each is seen.

        Parameters
        ----------
        model_names : sequence of str
            The markers the model expects (default: the 39 Plug-in Gait markers).
        """
        present = np.all(np.isfinite(self.positions), axis=2)  # (T, M)
        absent = (~present).sum(axis=0)
        return marker_report(self.names, self.n_frames, absent, self.source, model_names)


def marker_report(
    names: Sequence[str],
    n_frames: int,
    absent: np.ndarray,
    source: dict[str, Any],
    model_names: Sequence[str] = MARKER_NAMES,
) -> MarkerReport:
    """:meth:`MarkerTrajectory.marker_report` from the frames each marker ``names`` lacks
    (absent (M,) int of ``n_frames``): also for a file read chunk by chunk."""
    model = tuple(model_names)
    model_set = set(model)
    seen = (n_frames - np.asarray(absent)) / n_frames if n_frames else np.zeros(len(names))
    by_name = {name: float(seen[i]) for i, name in enumerate(names)}
    found = tuple(n for n in model if n in by_name)
    missing = tuple(n for n in model if n not in by_name)
    extras = tuple(n for n in names if n not in model_set)
    fraction = {n: by_name.get(n, 0.0) for n in model}
    fraction.update({n: by_name[n] for n in extras})
    return MarkerReport(
        found=found,
        missing=missing,
        extras=extras,
        fraction_present=fraction,
        n_frames=n_frames,
        missing_samples={n: int(absent[i]) for i, n in enumerate(names) if absent[i]},
        zero_samples=dict(source.get("zero_samples", {})),
    )


@dataclass(frozen=True)
class MarkerReport:
    """How a trajectory's markers match the model's marker set.

    Attributes
    ----------
    found : tuple of str
        Model markers present in the trajectory, in model order.
    missing : tuple of str
        Model markers the trajectory does not have at all.
    extras : tuple of str
        Trajectory markers the model does not use.
    fraction_present : Mapping[str, float]
        For every model marker (0.0 when missing) then every extra: the fraction of frames in
        which it was seen, in [0, 1].
    n_frames : int
        Number of frames of the trajectory.
    missing_samples : Mapping[str, int]
        Per trajectory marker with gaps: its missing samples (any cause of the one
        missing-data rule: NaN, empty cell, all-zero sample, negative C3D residual).
    zero_samples : Mapping[str, int]
        Of those, the samples the file wrote as 0 0 0.
    undetermined : tuple of str
        Model bodies no marker found determines (set by the caller that knows the model, see
        :func:`mocap_mj.capture.marker_set.undetermined_segments`); empty by default.
    set_name : str or None
        The marker set the recording uses when it is part of the model's markers (e.g. a
        lower-body set on the full-body model; set by the caller that chose the set): the
        text then counts and lists the set's markers, and names the model's others once as
        outside the set. None: the model's markers are the set.
    set_markers : tuple of str
        That set's markers (empty with ``set_name`` None).
    """

    found: tuple[str, ...]
    missing: tuple[str, ...]
    extras: tuple[str, ...]
    fraction_present: Mapping[str, float]
    n_frames: int
    missing_samples: Mapping[str, int] = field(default_factory=dict)
    zero_samples: Mapping[str, int] = field(default_factory=dict)
    undetermined: tuple[str, ...] = ()
    set_name: str | None = None
    set_markers: tuple[str, ...] = ()

    @property
    def complete(self) -> bool:
        """True when every model marker is present in every frame."""
        return not self.missing and all(self.fraction_present[n] == 1.0 for n in self.found)

    def __str__(self) -> str:
        if self.set_name is not None:
            ours = set(self.set_markers)
            missing = [n for n in self.missing if n in ours]
            outside = len([n for n in (*self.found, *self.missing) if n not in ours])
            lines = [
                f"{len([n for n in self.found if n in ours])} of the {len(ours)} markers of the "
                f"set {self.set_name!r} found, {len(self.extras)} extra, {self.n_frames} frames"
            ]
            lines.append("missing: " + (" ".join(missing) if missing else "none"))
            if outside:
                lines.append(f"the model's {outside} other markers are not of the set: not fitted")
        else:
            n_model = len(self.found) + len(self.missing)
            lines = [
                f"{len(self.found)} of {n_model} model markers found, {len(self.extras)} extra, "
                f"{self.n_frames} frames"
            ]
            lines.append("missing: " + (" ".join(self.missing) if self.missing else "none"))
        if self.undetermined:
            lines.append(
                "segments no marker found determines (their joint angles and the lengths "
                "leading to them stay at the prior): " + " ".join(self.undetermined)
            )
        if self.extras:
            lines.append("extras (not in the model, ignored by fitting): " + " ".join(self.extras))
        gaps = [n for n in self.found if self.fraction_present[n] < 1.0]
        if gaps:
            lines.append("markers with gaps (% of frames seen, samples missing):")
            lines.extend(
                f"  {n:<8} {100.0 * self.fraction_present[n]:6.1f}%  "
                f"{self.missing_samples.get(n, 0)} missing{self._zeros(n)}"
                for n in gaps
            )
        elif self.found:
            lines.append("every marker found is seen in every frame")
        return "\n".join(lines)

    def _zeros(self, name: str) -> str:
        zeros = self.zero_samples.get(name, 0)
        return f" ({zeros} written as 0 0 0)" if zeros else ""
