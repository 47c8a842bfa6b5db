"""The stature estimate from the markers and the anatomical ranges centred on it
(:func:`mocap_mj.anatomy.initial.estimate_stature`, :mod:`mocap_mj.anatomy.ranges`)."""

from __future__ import annotations

import numpy as np
import pytest

from mocap_mj import Kinematics, ParameterSet
from mocap_mj.anatomy.initial import STATURE_SPREAD, estimate_stature, segment_scales
from mocap_mj.anatomy.ranges import (
    ADULT_HEIGHTS,
    NOMINAL_HEIGHT,
    SIGNED,
    STATURE_K,
    base_name,
    kappa_ranges,
)
from mocap_mj.capture.marker_quality import _HEIGHTS, BONE_FRACTIONS
from mocap_mj.capture.subject import StatureEstimate, Subject, from_values
from mocap_synth.motion import generate
from mocap_synth.perturb import perturb_theta


@pytest.fixture(scope="module")
def pset() -> ParameterSet:
    return ParameterSet()


def subject_markers(
    pset: ParameterSet, height: float, seed: int, frames: int = 120, perturb: float = 0.05
) -> tuple[np.ndarray, np.ndarray]:
    """A synthetic subject of stature ``height`` [m]: the nominal model with every kinematic
    parameter perturbed by up to ``perturb`` (relative) and the landmarks placed on it
    (mocap_synth), then the whole model (skeleton and marker offsets) scaled by ``height /
    1.75 m``; its markers (T, M, 3) [m] over a range-of-motion trial with 1 mm white noise,
    and its theta (P,) [m]."""
    rng = np.random.default_rng(seed)
    theta = pset.nominal.copy()
    if perturb > 0:
        theta = perturb_theta(pset, rng, perturb, 5.0, placement="anatomical")
    theta = theta * (height / NOMINAL_HEIGHT)
    kin = Kinematics(pset.with_rolling_scaled(theta))  # the knee's rolling scaled too
    kin.set_theta(theta)
    qpos = generate("rom", kin.model, frames, 100.0, rng)
    markers = np.array(kin.forward(qpos).site_xpos)
    return markers + rng.normal(0.0, 0.001, markers.shape), theta


#: The estimate's error [1, relative]: on the nominal proportions scaled (0.02 % measured:
#: the method itself), and on subjects whose bones are each up to 5 % off the nominal
#: proportions with the landmarks placed at their priors' widths (up to 3.3 % measured on
#: these four: the median of the eight long bones' own ratios).
EXACT_TOLERANCE, PERTURBED_TOLERANCE = 0.005, 0.05


@pytest.mark.parametrize("height", [1.0, 1.4, 1.75, 2.0])
def test_stature_estimate_on_synthetic_subjects(pset: ParameterSet, height: float) -> None:
    exact, _ = subject_markers(pset, height, seed=1, frames=40, perturb=0.0)
    est = estimate_stature(segment_scales(pset, exact))
    assert est is not None
    assert est.value == pytest.approx(height, rel=EXACT_TOLERANCE)
    markers, _ = subject_markers(pset, height, seed=int(height * 100))
    est = estimate_stature(segment_scales(pset, markers))
    assert est is not None
    assert est.value == pytest.approx(height, rel=PERTURBED_TOLERANCE)
    # Its standard deviation is about STATURE_SPREAD of it (the placement term is small).
    assert STATURE_SPREAD * est.value <= est.sd <= 1.2 * STATURE_SPREAD * est.value
    assert "thigh_l" in est.source and "Winter" in est.source


def test_no_long_bone_no_estimate(pset: ParameterSet) -> None:
    markers, _ = subject_markers(pset, 1.75, seed=1, frames=20)
    limbs = [i for i, n in enumerate(pset.marker_names) if n[1:] in ("KNE", "ELB", "ANK")]
    markers[:, limbs] = np.nan
    assert estimate_stature(segment_scales(pset, markers)) is None


def _bounds(pset: ParameterSet, subject: Subject | None, name: str) -> tuple[float, float]:
    lo, hi = kappa_ranges(pset, subject)
    i = pset.kappa_names.index(name)
    return float(lo[i]), float(hi[i])


def _estimated(height: float) -> Subject:
    return Subject().with_stature_estimate(StatureEstimate(height, STATURE_SPREAD * height, "test"))


@pytest.mark.parametrize("height", [1.0, 1.3, 1.6, 2.0])
def test_ranges_hold_every_size_and_exclude_non_human(pset: ParameterSet, height: float) -> None:
    """Ranges about an estimated stature contain the nominal proportions at that stature
    (and 5 % either side) for a 1.0-1.3 m child, a 1.6 m and a 2.0 m adult."""
    subject = _estimated(height)
    lo, hi = kappa_ranges(pset, subject)
    k = pset.n_kappa
    nominal = pset.nominal[:k] * height / NOMINAL_HEIGHT
    lengths = nominal > 0
    assert np.all(lo[lengths] < 0.95 * nominal[lengths])
    assert np.all(hi[lengths] > 1.05 * nominal[lengths])
    signed = np.array([base_name(n) in SIGNED for n in pset.kappa_names])
    assert np.all(lo[lengths & ~signed] > 0)  # no zero or negative length


def test_non_human_skeletons_stay_excluded(pset: ParameterSet) -> None:
    """A 320 mm clavicle and an 11 mm thorax stay outside the ranges of a 1.7 m adult, measured
    or estimated; the estimate's ranges are narrower than the adult span used without one."""
    for subject in (_estimated(1.7), from_values([("height", 1.7)], "test")):
        assert _bounds(pset, subject, "clavicle_length_l")[1] < 0.320
        assert _bounds(pset, subject, "thorax_length")[0] > 0.011
        assert _bounds(pset, subject, "foot_length_r")[0] > 0.0
    lo_e, hi_e = _bounds(pset, _estimated(1.7), "thigh_length_l")
    lo_a, hi_a = _bounds(pset, None, "thigh_length_l")
    assert lo_a < lo_e and hi_e < hi_a
    # The estimate's span: -/+ STATURE_K standard deviations.
    nominal = pset.nominal[pset.kappa_names.index("thigh_length_l")] / NOMINAL_HEIGHT
    assert lo_e == pytest.approx(0.8 * nominal * 1.7 * (1 - STATURE_K * STATURE_SPREAD))


def test_measured_height_wins_over_the_estimate(pset: ParameterSet) -> None:
    measured = from_values([("height", 1.8)], "test")
    both = measured.with_stature_estimate(StatureEstimate(1.0, 0.06, "test"))
    assert both.stature() == (1.8, 0.0)
    np.testing.assert_array_equal(kappa_ranges(pset, both)[0], kappa_ranges(pset, measured)[0])
    # Neither measured nor estimated: the adult heights.
    assert Subject().stature() is None
    nominal = pset.nominal[pset.kappa_names.index("shank_length_l")] / NOMINAL_HEIGHT
    lo, hi = _bounds(pset, None, "shank_length_l")
    assert lo == pytest.approx(0.8 * nominal * ADULT_HEIGHTS[0])
    assert hi == pytest.approx(1.2 * nominal * ADULT_HEIGHTS[1])


def test_bone_distance_check_keeps_a_small_child() -> None:
    """marker_quality's landmark distances: a healthy 0.95 m child (limbs 15 % shorter for
    its stature than Winter's adult fractions) is inside the allowed range; a distance 30 %
    of a 1.75 m adult's is not."""
    for fraction in BONE_FRACTIONS.values():
        assert fraction * _HEIGHTS[0] < fraction * 0.95 * 0.85
        assert fraction * 1.75 * 0.3 < fraction * _HEIGHTS[0]
