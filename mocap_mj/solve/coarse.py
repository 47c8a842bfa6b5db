"""Coarse to fine: the joint LM's approach on a pose-diverse subset of the frames.

From the initial model the joint LM spends most of its iterations on the approach (steps of
hundreds, then tens of standard deviations) and only the last one or two near the minimum.
The approach does not need every frame: a subset of ``Tolerances.coarse_frames`` frames
spread over the recording's poses (:func:`mocap_mj.solve.selection.select_in_trials`)
determines the same directions of theta, at a fraction of the cost per iteration.
:func:`mocap_mj.solve.lm.identify_lm` therefore

1. solves the IK of the subset's frames under the initial model and runs the joint LM on
   them to convergence (its own stopping rules, with the subset's noise estimate),
2. solves the IK of every frame afresh under the subset's model (which stands in for the
   refits the LM on every frame would make along its approach), in chains headed by the
   subset's poses (:func:`subset_heads`),
3. continues the joint LM on every frame from there, with the damping the subset's LM ended
   with (the approach is done: the first steps need not be damped again).

Only step 3 decides the answer: it stops by the same rules as the LM on every frame
alone, at the same minimum (docs/method.md#the-joint-levenbergmarquardt-solver).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.selection import select_in_trials
from mocap_mj.solve.solver_result import IterationLog, TraceEntry

from ..errors import MocapError

#: Refits (``Tolerances.max_refits``) in a subset's LM: the first catches the frames the
#: initial model put in a wrong configuration; later ones cost a fresh IK of the subset each
#: (chains do not help on pose-diverse frames) and are superseded by the IK of every frame
#: under the subset's model. With none, seed 7 of the 500-frame benchmark took 4 more
#: iterations on every frame.
COARSE_REFITS = 1

#: A subset has at least a tenth of the frames it stands for: a long trial is approached
#: through subsets growing tenfold (at 50,000 frames: 500, 5,000, then every frame), each
#: starting a few iterations from its own minimum.
SUBSET_FRACTION = 10


def coarse_rows(
    trials: Sequence[TrialData], pset: ParameterSet, count: int
) -> list[np.ndarray] | None:
    """The subset's frames, sorted indices (K_i,) int per trial, or None when the coarse
    phase does not apply: ``count`` is 0 or the trials have at most 2 ``count`` frames in
    all (the subset would save little).

    The subset has ``count`` frames or a tenth of all (:data:`SUBSET_FRACTION`), whichever is
    more. Frames are chosen by pose diversity; without the pelvis markers the selection
    needs, evenly spaced frames are taken instead.
    """
    total = sum(len(t.markers) for t in trials)
    if count < 1 or total <= 2 * count or count < len(trials):
        return None
    count = max(count, total // SUBSET_FRACTION)
    markers = [np.asarray(t.markers) for t in trials]
    try:
        return select_in_trials(markers, pset.marker_names, count)
    except MocapError:
        shares = [max(1, round(count * len(m) / total)) for m in markers]
        return [np.unique(np.linspace(0, len(m) - 1, k).round().astype(int))
                for m, k in zip(markers, shares, strict=True)]  # fmt: skip


def subset_trials(trials: Sequence[TrialData], rows: Sequence[np.ndarray]) -> list[TrialData]:
    """The trials cut to the frames ``rows[i]`` (K_i,) int of each."""
    return [
        TrialData(t.name, np.asarray(t.markers)[r], np.asarray(t.times)[r])
        for t, r in zip(trials, rows, strict=True)
    ]


def subset_heads(
    trials: Sequence[TrialData], rows: Sequence[np.ndarray], qpos: Sequence[np.ndarray]
) -> list[np.ndarray]:
    """Every trial's poses (T_i, nq) [m, quaternion, rad]: the subset's solved poses qpos[i]
    (K_i, nq) at its frames ``rows[i]``, NaN elsewhere (NaN rows of qpos stay NaN).

    The heads from which the IK of every frame runs under the subset's model
    (:meth:`mocap_mj.solve.ik.IKSolver.solve_from_heads`): the subset's poses already fit that
    model, so no frame is solved cold from the arm configurations again.
    """
    out = []
    for t, r, q in zip(trials, rows, qpos, strict=True):
        heads = np.full((len(t.markers), q.shape[1]), np.nan)
        heads[r] = q
        out.append(heads)
    return out


def shifted(log: TraceEntry, k: int) -> TraceEntry:
    """A joint-LM trace entry numbered k iterations on (after the coarse phase's k)."""
    return log._replace(iteration=log.iteration + k) if isinstance(log, IterationLog) else log


def joined_trace(coarse: Sequence[TraceEntry], fine: Sequence[TraceEntry]) -> list[TraceEntry]:
    """The two phases' iterations numbered on from the coarse ones (each entry's ``frames``
    says which phase it belongs to)."""
    return [*coarse, *(shifted(log, len(coarse)) for log in fine)]


__all__ = [
    "COARSE_REFITS",
    "SUBSET_FRACTION",
    "coarse_rows",
    "joined_trace",
    "shifted",
    "subset_heads",
    "subset_trials",
]
