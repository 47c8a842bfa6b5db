"""Partial marker sets: the parameters no present marker measures, held at the prior.

A lower-body Plug-in Gait capture (16 markers) says nothing about the arms, the spine or the
head; a file that lost its head markers says nothing about the head. The identification
freezes (``ParameterSet.frozen``) every parameter such a trial set cannot move:

* a kinematic parameter all of whose target bodies are unmeasured
  (:func:`mocap_mj.capture.marker_set.unmeasured_bodies` of the markers with data in any trial),
  e.g. ``lumbar_length`` without trunk markers;
* the three offsets of a marker without a single present sample in any trial.

A prior row that ties a measured parameter to a frozen one (the L5/S1 joint from the ASIS
markers, when the trunk has no marker) is dropped (:func:`on_measured`): the frozen value is
the prior's guess, not a measurement, and the row would pin the measured parameter to it
with the row's landmark precision (3 mm) instead of the guess's (the weak prior's 50 mm).

They keep their value of the initial model (the prior mean: the scaled nominal model), are
not unknowns (:func:`mocap_mj.capture.checks.check_determined`, the noise estimate's degrees of
freedom) and are reported ``not_measured`` without a standard deviation
(:mod:`mocap_mj.anatomy.segments`). The joint dofs of unmeasured bodies have a zero marker
Jacobian: the solvers hold them where they start (the neutral pose), and they are not counted
as unknowns either (:func:`mocap_mj.capture.marker_set.measured_dofs`). With every marker present
nothing is frozen and the full-set path is unchanged.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from mocap_mj.capture.marker_set import unmeasured_bodies
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.priors import LinearGaussianPrior
from mocap_mj.solve.problem import TrialData

__all__ = ["Unmeasured", "freeze_unmeasured", "on_measured", "unmeasured"]

#: Flag of an unmeasured parameter or length in segments.csv, summary.json and report.md.
NOT_MEASURED = "not_measured"


class Unmeasured(NamedTuple):
    """What a set of trials does not measure: ``frozen`` (P,) bool, the parameters held at
    the prior; ``bodies`` the unmeasured bodies' names and ``markers`` the names of the
    markers without data, both in model order."""

    frozen: np.ndarray
    bodies: tuple[str, ...]
    markers: tuple[str, ...]


def unmeasured(pset: ParameterSet, trials: Sequence[TrialData]) -> Unmeasured:
    """The parameters of ``pset`` that no present marker of ``trials`` moves (see the module
    docstring); markers (T, M, 3) [m] per trial, in ``pset``'s marker order."""
    present = np.zeros(pset.n_markers, dtype=bool)
    for t in trials:
        present |= np.any(np.all(np.isfinite(np.asarray(t.markers)), axis=2), axis=0)
    model = pset.model
    names = [n for n, p in zip(pset.marker_names, present, strict=True) if p]
    gone = unmeasured_bodies(model, names)
    frozen = np.zeros(pset.size, dtype=bool)
    for k in range(pset.n_kappa):
        targets = np.flatnonzero(np.any(pset.direction[k], axis=1))
        frozen[k] = bool(np.all(gone[targets]))
    frozen[pset.n_kappa :] = np.repeat(~present, 3)
    return Unmeasured(
        frozen,
        tuple(model.body(b).name for b in np.flatnonzero(gone)),
        tuple(n for n, p in zip(pset.marker_names, present, strict=True) if not p),
    )


def freeze_unmeasured(
    pset: ParameterSet, trials: Sequence[TrialData]
) -> tuple[ParameterSet, Unmeasured]:
    """``pset`` with the parameters ``trials`` do not measure frozen besides its own frozen
    ones (a copy sharing the model; ``pset`` itself when nothing is unmeasured), and what was
    unmeasured."""
    found = unmeasured(pset, trials)
    if not found.frozen.any():
        return pset, found
    new = copy.copy(pset)
    new.frozen = pset.frozen | found.frozen
    return new, found


def on_measured(prior: LinearGaussianPrior, frozen: np.ndarray) -> LinearGaussianPrior:
    """``prior`` without its rows on a ``frozen`` (P,) parameter (``prior`` itself when it
    has none): such a row relates a measured quantity to a value nobody measured; dropping
    it is its marginal over the frozen parameter's wide prior, to a fraction of a percent."""
    a = np.atleast_2d(np.asarray(prior.a, dtype=float))
    keep = ~np.any(a[:, frozen] != 0.0, axis=1)
    if keep.all():
        return prior
    labels = tuple(label for label, k in zip(prior.labels, keep, strict=False) if k)
    return LinearGaussianPrior(
        a[keep], np.asarray(prior.b)[keep], np.asarray(prior.sigma)[keep], prior.noise, labels
    )
