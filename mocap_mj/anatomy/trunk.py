"""The trunk's landmarks against the stature: a misplaced T10 found from the data.

T10's spinous process is found by counting ten spinous processes down from C7; a level missed
moves the marker by a vertebra and its disc (:data:`LEVEL`, about 25 mm on a 1.75 m adult).
Nothing else on the back tells the fit where the thoracic spine ends: the T12/L1 rows of
:mod:`mocap_mj.anatomy.anatomy` hang the thorax origin below T10 in proportion to the C7-T10
distance, so a low T10 becomes a low T12/L1, a long thorax and a short lumbar spine, with the
standard deviations of a correctly placed marker.

:func:`t10_placement` compares the C7-T10 distance (median over the trials' frames) with what
the stature predicts (the nominal model's C7-T10 distance, 206 mm at 1.75 m, times stature /
1.75 m) and finds T10 misplaced when the difference exceeds :data:`FIND_SD` times its
spread: one vertebral level (placement by counting, scaled by stature), the thoracic spine's
length between adults of one stature (:data:`LENGTH_CV`) and the stature's own standard
deviation when it is estimated from the markers, added in quadrature. Found, the rows that
hang on T10 are widened by the displacement they would carry
(:func:`mocap_mj.anatomy.anatomy.landmark_prior`'s ``t10``), and a one-line
``placement`` finding joins the marker-data quality findings (stderr, summary.json's
``marker_quality``, report.md; docs/model.md#a-misplaced-t10).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from mocap_mj.anatomy.initial import median_distance, stack_trials
from mocap_mj.anatomy.ranges import NOMINAL_HEIGHT
from mocap_mj.capture.marker_quality import Finding, placement_finding
from mocap_mj.capture.subject import Subject
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData

__all__ = ["FIND_SD", "LENGTH_CV", "LEVEL", "T10Placement", "t10_placement"]

#: One thoracic vertebra and its disc [m] on a 1.75 m adult (T1-T12 about 280 mm of spine
#: over twelve levels: 23-26 mm each): the step a miscounted spinous process moves T10.
LEVEL = 0.025
#: Coefficient of variation of a trunk segment's length between adults of one stature
#: (segment lengths as fractions of stature vary by 5-8 % between adults, de Leva 1996,
#: Dumas et al. 2007 Table 2 standard deviations): 6 %.
LENGTH_CV = 0.06
#: A C7-T10 distance more than this many spreads from the stature's is a misplaced T10.
FIND_SD = 2.0


class T10Placement(NamedTuple):
    """The C7-T10 distance against the stature: ``measured`` and ``expected`` [m], their
    difference ``shift`` [m] (positive: T10 further below C7), ``spread`` [m] (its standard
    deviation) and the finding (None when the marker agrees with the stature)."""

    measured: float
    expected: float
    shift: float
    spread: float
    finding: Finding | None


def t10_placement(
    pset: ParameterSet, trials: Sequence[TrialData], subject: Subject
) -> T10Placement | None:
    """C7-T10 of the trials' markers (T, M, 3) [m] against ``subject``'s stature (measured or
    estimated); None without both markers, without data on them or without a stature."""
    names = pset.marker_names
    stature = subject.stature()
    if "C7" not in names or "T10" not in names or stature is None:
        return None
    i, j = names.index("C7"), names.index("T10")
    markers = stack_trials([t.markers for t in trials], len(names))
    measured = median_distance(markers[:, i], markers[:, j])
    if not np.isfinite(measured):
        return None
    k = pset.n_kappa
    nominal = float(np.linalg.norm(pset.nominal[k + 3 * i : k + 3 * i + 3]
                                   - pset.nominal[k + 3 * j : k + 3 * j + 3]))  # fmt: skip
    height, sd = stature
    s = height / NOMINAL_HEIGHT
    expected = nominal * s
    spread = float(np.hypot(LEVEL * s, np.hypot(LENGTH_CV, sd / height) * expected))
    shift = measured - expected
    finding = None
    if abs(shift) > FIND_SD * spread:
        levels = shift / (LEVEL * s)
        where = "further from" if shift > 0 else "closer to"
        finding = placement_finding(
            trials[0].name if len(trials) == 1 else ", ".join(t.name for t in trials),
            ("T10",),
            shift,
            f"C7-T10 {expected * 1e3:.0f} +- {spread * 1e3:.0f} mm at {height:.2f} m",
            f"T10 is {abs(shift) * 1e3:.0f} mm {where} C7 than a {height:.2f} m subject's T10 "
            f"(C7-T10 median {measured * 1e3:.0f} mm, expected {expected * 1e3:.0f} +- "
            f"{spread * 1e3:.0f}): placed {abs(levels):.0f} "
            f"{'vertebra' if round(abs(levels)) == 1 else 'vertebrae'} "
            f"{'low' if shift > 0 else 'high'}? T12/L1's rows on T10 widened by it",
        )
    return T10Placement(measured, expected, shift, spread, finding)
