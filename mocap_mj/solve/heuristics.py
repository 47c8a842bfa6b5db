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

from mocap_mj.solve.ik import IKSolver


def frame_rmse(
    dist: np.ndarray, present: np.ndarray, weights: np.ndarray | None = None
) -> np.ndarray:
    """Marker RMSE (n,) [m] of each frame from distances dist (n, M) [m] (0 where missing);
    with ``weights`` (n, M) [1] the weighted RMSE sqrt(sum w d^2 / sum w) over present markers
    (the per-frame objective of a fit that weighs its samples)."""
    w = present if weights is None else np.where(present, weights, 0.0)
    num = np.sum(w * np.where(present, dist, 0.0) ** 2, axis=1)
    den = np.sum(w, axis=1)
    return np.sqrt(num / np.where(den > 0, den, 1.0))


def refit_frames(
    solver: IKSolver,
    markers: np.ndarray,
    qpos: np.ndarray,
    segments: Sequence[slice],
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """Solve every trial's IK afresh with the solver's current theta; keep each frame's better
    pose (in place in qpos (n, nq)) and return the indices of the frames replaced.

    A frame is replaced when the fresh IK fits at least 2 % better (RMSE): below that the
    difference is convergence noise, not another configuration. The initial IK, under a model
    far from the subject, can settle whole stretches of frames in a wrong configuration (an
    arm twisted about itself, a foot flipped) that joint iterations and warm starts never
    leave; with the model improved, a fresh IK (new chain starts, repair) finds the right one.

    ``weights`` (n, M) [1] (default None: all 1) are the fit's per-sample weights: the fresh
    IK weighs the markers alike and the RMSE compared is the weighted one, the objective the
    fit minimises. Judged unweighted, a pose the weighted fit moved away from on purpose (a
    sliding landmark weighed down) would look worse than a fresh unweighted IK's, be swapped
    back at every refit and moved away again by the next steps.
    """
    present = np.all(np.isfinite(markers), axis=2)
    target = np.nan_to_num(markers)

    def rmse(q: np.ndarray, rows: slice | np.ndarray) -> np.ndarray:
        dist = np.linalg.norm(target[rows] - solver.kin.site_positions(q), axis=2)
        return frame_rmse(dist, present[rows], None if weights is None else weights[rows])

    before = rmse(qpos, slice(None))
    changed = [np.zeros(0, dtype=int)]
    for seg in segments:
        r = solver.solve_trial(markers[seg], None if weights is None else weights[seg])
        rows = np.arange(seg.start, seg.stop)
        fresh = r.marker_rmse if weights is None else rmse(r.qpos, seg)
        better = np.nan_to_num(fresh, nan=np.inf) < 0.98 * before[rows]
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
    """Stop once settled when a level (the solver passes sqrt(F), in the marker RMSE's units)
    fell by less than ``rel`` (relative) over the last ``window`` accepted steps: heavily damped
    crawling along a curved valley of weakly informed directions, which changes nothing
    measurable."""

    window: int
    rel: float
    history: list[float] = field(default_factory=list)

    def accepted(self, level: float) -> None:
        self.history.append(level)

    def stalled(self, level: float) -> bool:
        h = self.history
        return len(h) > self.window and h[-self.window - 1] - level < self.rel * level


__all__ = ["RefitSchedule", "StallMonitor", "frame_rmse", "refit_frames"]
