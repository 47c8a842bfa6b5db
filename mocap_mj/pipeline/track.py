"""One trial's motion with a given model, as ``mocap-mj ik`` and ``batch`` compute it.

:func:`checked_trial` takes the recording through the marker checks (the excluded markers
dropped, the frame-rejection floor, the quality check with its relabelling, the ghosts and
jumps it finds dropped) and refuses a trial no frame of which can be solved, before anything
is written; :func:`track` then solves every frame
(:func:`~mocap_mj.pipeline.robust_ik.solve_motion`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from mocap_mj.capture.checks import check_markers, recorded_floor
from mocap_mj.capture.marker_quality import exclude_markers
from mocap_mj.pipeline.motion import Motion
from mocap_mj.pipeline.quality import Checked, Policy, check_trials, without_ghosts
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.pipeline.robust_ik import solve_motion
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSettings
from mocap_mj.solve.losses import LossName
from mocap_mj.solve.problem import TrialData


@dataclass(frozen=True)
class TrackOptions:
    """The choices of a trial's IK with a given model.

    ``rows``: the recording's rows to solve (default every row); ``excluded``: markers whose
    data are dropped before anything else; ``settings``: the per-frame IK's (its
    ``min_markers`` None: :func:`~mocap_mj.capture.checks.recorded_floor` of the rows, the
    markers the trial records); ``loss`` of the marker distances; ``sliding``: weigh the
    landmarks as the model's identification did, when its model.xml records it; ``policy``
    of the quality check (a single trial: judged against its own model).
    """

    rows: slice = field(default_factory=lambda: slice(None))
    excluded: tuple[str, ...] = ()
    settings: IKSettings = field(default_factory=IKSettings)
    loss: LossName = "l2"
    sliding: bool = True
    policy: Policy = field(default_factory=lambda: Policy(one_model=False))


@dataclass(frozen=True)
class CheckedTrial:
    """A trial ready to solve: ``trial`` its rows' markers (T, M, 3) [m] in the model's order
    (corrected, excluded markers and ghosts dropped) and times (T,) [s]; ``first_frame`` the
    recording's number of its first row; ``quality`` the quality check's (findings,
    corrections, excluded markers); ``min_markers`` the frame-rejection floor applied."""

    trial: TrialData
    first_frame: int
    quality: MarkerQuality
    min_markers: int


@dataclass(frozen=True)
class Tracked:
    """A trial's motion: ``motion`` (poses (T, nq), times (T,) [s], markers (T, M, 3) [m],
    ``motion.ik`` each frame's status, iterations and marker RMSE), its ``first_frame``, the
    checks' ``quality`` and the IK's wall time ``seconds`` [s]."""

    motion: Motion
    first_frame: int
    quality: MarkerQuality
    seconds: float


def checked_trial(
    pset: ParameterSet,
    path: str,
    recording: TrialData,
    first_frame: int,
    rate: float,
    options: TrackOptions,
) -> CheckedTrial:
    """``recording`` (markers (N, M, 3) [m] in ``pset``'s marker order, times (N,) [s]; row 0
    the file's frame ``first_frame``, ``rate`` [Hz]) of the file ``path`` through the marker
    checks: :class:`~mocap_mj.errors.MocapError` naming ``path`` when no frame of
    ``options.rows`` can be solved, or under a strict policy when the check finds a fault."""
    rows = options.rows
    markers = exclude_markers(recording.markers, pset.marker_names, options.excluded)
    floor = options.settings.min_markers
    if floor is None:
        floor = recorded_floor(markers[rows])
    check_markers(path, pset.marker_names, markers[rows], floor)
    first = first_frame + (rows.start or 0)
    checked = Checked(path, markers[rows], rate, first)  # corrections land in ``markers``
    found, quality = check_trials(pset, [checked], options.excluded, options.policy)
    markers = without_ghosts(markers, pset, found, path, first_frame)
    times = np.asarray(recording.times)[rows]
    return CheckedTrial(TrialData(path, markers[rows], times), first, quality, floor)


def track(
    pset: ParameterSet,
    checked: CheckedTrial,
    options: TrackOptions,
    progress: Callable[[int], None] | None = None,
) -> Tracked:
    """The motion of ``checked``'s frames with ``pset``'s nominal model (an identified
    model.xml's), each frame solved by the IK of ``options``; ``progress`` is called with the
    frames done."""
    settings = replace(options.settings, min_markers=checked.min_markers)
    t0 = time.perf_counter()
    motion = solve_motion(
        pset, checked.trial, loss=options.loss, settings=settings, sliding=options.sliding,
        progress=progress,
    )  # fmt: skip
    return Tracked(motion, checked.first_frame, checked.quality, time.perf_counter() - t0)


__all__ = ["CheckedTrial", "TrackOptions", "Tracked", "checked_trial", "track"]
