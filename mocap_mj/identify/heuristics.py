"""The joint LM's safeguards, each a named piece the solver calls (and tests check alone).

- :func:`refit_frames`: every trial's IK solved afresh under the current theta, keeping each
  frame's better pose (frames stuck in a wrong configuration since the initial IK);
- :class:`RefitSchedule`: when to refit (the fit improved markedly, progress settled, at a
  stop), at most ``max_refits`` times;
- :class:`StallMonitor`: once settled, stop when the marker RMSE no longer changes measurably.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..ik import IKSolver


def frame_rmse(dist: np.ndarray, present: np.ndarray) -> np.ndarray:
    """Marker RMSE (n,) [m] of each frame from distances dist (n, M) [m] (0 where missing)."""
    return np.sqrt(
        np.sum(np.where(present, dist, 0.0) ** 2, axis=1) / np.maximum(present.sum(axis=1), 1)
    )


def refit_frames(
    solver: IKSolver, markers: np.ndarray, qpos: np.ndarray, segments: Sequence[slice]
) -> np.ndarray:
    """Solve every trial's IK afresh with the solver's current theta; keep each frame's better
    pose (in place in qpos (n, nq)) and return the indices of the frames replaced.

    A frame is replaced when the fresh IK fits at least 2 % better (RMSE): below that the
    difference is convergence noise, not another configuration. The initial IK, under a model
    far from the subject, can settle whole stretches of frames in a wrong configuration (an
    arm twisted about itself, a foot flipped) that joint iterations and warm starts never
    leave; with the model improved, a fresh IK (new chain starts, repair) finds the right one.
    """
    present = np.all(np.isfinite(markers), axis=2)
    x = solver.kin.site_positions(qpos)
    before = frame_rmse(np.linalg.norm(np.nan_to_num(markers) - x, axis=2), present)
    changed = [np.zeros(0, dtype=int)]
    for seg in segments:
        r = solver.solve_trial(markers[seg])
        rows = np.arange(seg.start, seg.stop)
        better = np.nan_to_num(r.marker_rmse, nan=np.inf) < 0.98 * before[rows]
        qpos[rows[better]] = r.qpos[better]
        changed.append(rows[better])
    return np.concatenate(changed)


@dataclass
class RefitSchedule:
    """When :func:`refit_frames` runs in the joint LM.

    After an accepted step, when the marker RMSE fell by ``factor`` since the last refit
    (the model changed enough for a fresh IK to find other configurations) or when the step
    lowered F by less than ``settle_gain`` of F for the first time (progress settled); at a
    stop, unless a refit ran within the last 3 iterations. At most ``max_refits`` in all.
    """

    factor: float
    settle_gain: float
    max_refits: int
    last_rmse: float
    refits: int = 0
    last_iteration: int = -10
    settled: bool = False

    def improved(self, accepted: bool, rmse: float) -> bool:
        """An accepted step brought the RMSE [m] ``factor`` below the last refit's."""
        return accepted and rmse < self.last_rmse / self.factor

    def settling(self, accepted: bool, gain: float, cost: float) -> bool:
        """An accepted step lowered F [m^2] by less than ``settle_gain`` of F, not yet settled."""
        return accepted and gain < self.settle_gain * cost and not self.settled

    def take(self, it: int) -> bool:
        """Count a refit at iteration ``it`` if any is left."""
        if self.refits >= self.max_refits:
            return False
        self.refits += 1
        self.last_iteration = it
        return True

    def take_at_stop(self, it: int) -> bool:
        """As :meth:`take`, unless a refit ran within the last 3 iterations."""
        return it - self.last_iteration > 3 and self.take(it)


@dataclass
class StallMonitor:
    """Stop once settled when the marker RMSE fell by less than ``rel`` (relative) over the last
    ``window`` accepted steps: heavily damped crawling along a curved valley of weakly informed
    directions, which changes nothing measurable."""

    window: int
    rel: float
    history: list[float] = field(default_factory=list)

    def accepted(self, rmse: float) -> None:
        self.history.append(rmse)

    def stalled(self, rmse: float) -> bool:
        h = self.history
        return len(h) > self.window and h[-self.window - 1] - rmse < self.rel * rmse


__all__ = ["RefitSchedule", "StallMonitor", "frame_rmse", "refit_frames"]
