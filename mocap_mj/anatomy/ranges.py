"""Anatomical ranges of the kinematic parameters, enforced as bounds during the solve.

Every kinematic parameter kappa_k of the bundled humanoid is a proportion of stature: its
nominal value is that of a 1.75 m adult (:data:`NOMINAL_HEIGHT`, Winter 2009 segment
fractions, see ``models/humanoid.xml``). Its range is ``[lo_k, hi_k] x nominal_k x H / 1.75``
with H the subject's height when measured, and ``[lo_k x H_min, hi_k x H_max] x nominal_k /
1.75`` when it is not: ``H_min, H_max = H_e -/+ STATURE_K x sd_e`` about the stature H_e
estimated from the markers' long-bone distances (standard deviation sd_e, about 6 %:
:func:`mocap_mj.anatomy.initial.estimate_stature`), so that a 1.0 m child and a 2.0 m adult
both get ranges about their own size; without any estimate (no limb markers), the adult
heights :data:`ADULT_HEIGHTS`. The factors are wide
(about 3-4 standard deviations of the proportion between adults): a bound is a guard
against a non-human skeleton (a negative foot, a 320 mm clavicle, an 11 mm thorax), not a
prior; the priors of :mod:`mocap_mj.anatomy.anatomy` say where a parameter probably is.

========================================  =========  ======  ==============================
parameters                                lo         hi      why
========================================  =========  ======  ==============================
thigh, shank, upper arm, forearm lengths  0.80       1.20    long-bone proportions vary by
                                                             about 5 % (Winter 2009; Drillis
                                                             & Contini 1966)
clavicle length                           0.70       1.30    shoulder breadth varies more
foot length (ankle to MTP)                0.75       1.30    the MTP centre is not marked
hip depth, width, height                  0.50       1.60    Harrington et al. 2007: hip
                                                             centre from pelvis geometry,
                                                             pelvis widths vary by ~15 %
lumbar depth/height, lumbar and thorax    0.60       1.50    spine lengths: Winter's trunk
length, sc depth/height                                      fractions, posture-dependent
foot height (ankle above MTP)             0.60       1.60    ankle 0.039 H above the sole
sc width                                  0.40       2.00    a short distance (2.5 cm)
neck depth (C7/T1 ahead of T12/L1)        -0.5       3.0     thoracic kyphosis varies
========================================  =========  ======  ==============================

The frontal-plane alignment parameters (knee centre lateral of the hip centre, ankle centre
lateral of the knee centre, along the knee axis; nominal 0) are signed: their range is -/+
tan(12 deg) x the segment's height-scaled nominal length (:data:`ALIGNMENT_RANGES`).

Every lower bound of a length is positive (``lo > 0``): no zero or negative length can leave
the solver. Marker offsets are not bounded here (wand markers can sit anywhere; the priors
place the landmark ones).
"""

from __future__ import annotations

import numpy as np

from mocap_mj.capture.subject import Subject
from mocap_mj.skeleton.parameters import ParameterSet

from ..errors import MocapError

#: Height [m] of the adult whose proportions the nominal model has.
NOMINAL_HEIGHT = 1.75
#: Heights [m] the ranges span when the subject's height is neither measured nor estimated.
ADULT_HEIGHTS = (1.40, 2.10)
#: Standard deviations of the stature estimate the ranges span on either side of it: with
#: the factors' own 3-4 standard deviations of proportion, a 2-sigma stature error still
#: leaves every healthy subject's segment inside.
STATURE_K = 2.0


def height_span(subject: Subject | None) -> tuple[float, float]:
    """The heights [m] the ranges span (module docstring): the measured height twice, the
    estimate -/+ ``STATURE_K`` standard deviations, else :data:`ADULT_HEIGHTS`."""
    stature = subject.stature() if subject is not None else None
    if stature is None:
        return ADULT_HEIGHTS
    h, sd = stature
    return h - STATURE_K * sd, h + STATURE_K * sd


#: Kinematic parameter (side suffix removed) -> (lo, hi) factors of the height-scaled nominal.
RANGE_FACTORS: dict[str, tuple[float, float]] = {
    "thigh_length": (0.80, 1.20),
    "shank_length": (0.80, 1.20),
    "upperarm_length": (0.80, 1.20),
    "forearm_length": (0.80, 1.20),
    "clavicle_length": (0.70, 1.30),
    "foot_length": (0.75, 1.30),
    "hip_depth": (0.50, 1.60),
    "hip_width": (0.50, 1.60),
    "hip_height": (0.50, 1.60),
    "lumbar_depth": (0.60, 1.50),
    "lumbar_height": (0.60, 1.50),
    "lumbar_length": (0.60, 1.50),
    "thorax_length": (0.60, 1.50),
    "sc_depth": (0.60, 1.50),
    "sc_height": (0.60, 1.50),
    "sc_width": (0.40, 2.00),
    "foot_height": (0.60, 1.60),
    "neck_depth": (-0.50, 3.00),
}

#: Parameters that are not lengths (may be zero or negative within their range).
SIGNED = frozenset({"neck_depth"})
#: Alignment parameter (nominal 0, side removed) -> (segment length parameter, largest angle
#: [deg]): its range is -/+ tan(angle) x the height-scaled nominal length, a frontal-plane
#: angle of the femur or tibia against the knee axis beyond the healthy adult's 85-90 degree
#: joint angles (Paley 2002) by more than 3 standard deviations.
ALIGNMENT_RANGES: dict[str, tuple[str, float]] = {
    "knee_lateral": ("thigh_length", 12.0),
    "ankle_lateral": ("shank_length", 12.0),
}


def base_name(name: str) -> str:
    """Parameter or marker name without its side suffix (``thigh_length_l`` -> ``thigh_length``)."""
    return name[:-2] if name.endswith(("_l", "_r")) else name


def kappa_ranges(
    pset: ParameterSet, subject: Subject | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds (K,) [m] of the kinematic parameters (module docstring).

    A parameter this table does not know (a custom model's) gets the nominal -/+ 35 % range
    of :class:`~mocap_mj.skeleton.parameters.ParameterSet`.
    """
    h_lo, h_hi = height_span(subject)
    k = pset.n_kappa
    nominal = pset.nominal[:k]
    lower = pset.lower[:k].copy()
    upper = pset.upper[:k].copy()
    index = {n: i for i, n in enumerate(pset.kappa_names)}
    for i, name in enumerate(pset.kappa_names):
        aligned = ALIGNMENT_RANGES.get(base_name(name))
        if aligned is not None and f"{aligned[0]}{name[-2:]}" in index:
            length = nominal[index[f"{aligned[0]}{name[-2:]}"]]
            half = np.tan(np.radians(aligned[1])) * length / NOMINAL_HEIGHT * h_hi
            lower[i], upper[i] = nominal[i] - half, nominal[i] + half
            continue
        factors = RANGE_FACTORS.get(base_name(name))
        if factors is None:
            continue
        lo, hi = factors
        scale = nominal[i] / NOMINAL_HEIGHT
        lower[i] = lo * scale * (h_lo if lo > 0 else h_hi)
        upper[i] = hi * scale * h_hi
        if base_name(name) not in SIGNED and lower[i] <= 0:
            raise MocapError(f"range of {name}: lower bound {lower[i]} m is not positive")
    return lower, upper


def theta_bounds(
    pset: ParameterSet, subject: Subject | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (P,) [m] of the whole theta: the kappa ranges, marker offsets unbounded."""
    lo, hi = kappa_ranges(pset, subject)
    n = pset.size - pset.n_kappa
    return np.concatenate([lo, np.full(n, -np.inf)]), np.concatenate([hi, np.full(n, np.inf)])
