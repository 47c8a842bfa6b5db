"""The segment table of an identification: every length and kinematic parameter with honest
uncertainty (``segments.csv``, the ``segments`` key of summary.json, report.md).

Rows, in this order:

* ``kind = "length"``: every distance between adjacent joint centres and between mirrored
  sibling centres (:func:`mocap_mj.solve.consistency.joint_centre_lengths`, named
  ``"parent:child"``, e.g. ``thigh_r:shank_r`` is the right thigh, hip to knee centre).
* ``kind = "kappa"``: every kinematic parameter of :class:`ParameterSet` (``kappa_names``).

Columns:

``name``, ``kind``
``value_mm``
    The identified value [mm].
``std_white_mm``
    Standard deviation [mm] from the fit's reduced information for white marker noise at the
    fit's sigma, with the fit's prior (a direction the data do not determine keeps the prior's
    width): the Cramer-Rao figure, right for synthetic data.
``std_mm``
    The same with the information divided by the residuals' correlation time tau
    (:func:`mocap_mj.solve.consistency.correlation_time`): on real recordings soft-tissue
    artefact and model error repeat over neighbouring frames, so a trial of T frames holds
    about T / tau independent observations. This is the data's figure to quote for real data.
``std_priors_mm``
    The same (information divided by tau) with the anatomical priors the fit used added
    (every prior row's ``a a^T / sigma_r^2``, :func:`mocap_mj.pipeline.steps.prior_information`):
    the uncertainty of the estimate itself. Where it is much smaller than ``std_mm`` the
    priors, not the motion, place the length (e.g. a joint centre set by its landmark's
    convention rows); where the two agree, the data do. Equal to ``std_mm`` without priors
    (the recipe's ``anatomy: false``). The data are weighed as the fit weighed them against
    the priors (:func:`mocap_mj.solve.noise.artefact_noise`): on correlated residuals (tau of
    ``CORRELATED_TAU`` frames or more) at the soft-tissue artefact's per-axis size, at least
    ``SOFT_TISSUE_SIGMA`` (5 mm), not at the fit's smaller residual: the part of the artefact
    the skeleton absorbed never shows in the residual, and a length placed by the rows
    (a joint centre no marker moves about, the thorax origin without pelvis markers) would
    otherwise be reported with the precision of a residual that says nothing about it.
    So it may exceed ``std_mm`` where the fit's residual is under that floor.
``nominal_mm``
    The value on the nominal (unscaled) model.
``lower_mm``, ``upper_mm``
    The plausible range of the parameter (``ParameterSet.lower`` / ``upper``); empty for
    lengths, which have no range of their own (their flag names the parameters they move with).
``flag``
    For a parameter: ``at_lower`` / ``at_upper`` (within :data:`AT_BOUND` of the bound),
    ``below_range`` / ``above_range`` (outside it), empty otherwise. For a length: the flagged
    parameters it depends on, as ``name=flag`` joined by ``;``.
    ``not_measured`` (a parameter frozen at the prior mean because no present marker moves
    it, :mod:`mocap_mj.anatomy.partial`; a length that depends on one): the value is the
    scaled prior's and the three standard deviations are empty, since the data say nothing
    about it (the prior's width is no measurement either).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from mocap_mj.anatomy.partial import NOT_MEASURED
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import (
    correlation_time,
    joint_centre_lengths,
    length_gradient,
    length_std,
    parameter_covariance,
)
from mocap_mj.solve.lm import LMResult, LMSettings, TrialData
from mocap_mj.solve.noise import artefact_noise

#: A parameter within this distance [m] of a bound is reported at it: a solver that enforces
#: its bounds by a barrier stops a fraction of a millimetre inside.
AT_BOUND = 5e-4


class SegmentRow(NamedTuple):
    """One row of the segment table (lengths in [m]; NaN where a column does not apply)."""

    name: str
    kind: str
    value: float
    std_white: float
    std: float
    std_priors: float
    nominal: float
    lower: float
    upper: float
    flag: str


def parameter_flag(value: float, lower: float, upper: float) -> str:
    """``below_range`` / ``above_range`` / ``at_lower`` / ``at_upper`` / ``""`` for a value
    [m] and its range [m] (see :data:`AT_BOUND`)."""
    if value < lower - AT_BOUND:
        return "below_range"
    if value > upper + AT_BOUND:
        return "above_range"
    if value <= lower + AT_BOUND:
        return "at_lower"
    if value >= upper - AT_BOUND:
        return "at_upper"
    return ""


def _prior_weighted_tau(sigma: float, tau: float) -> float:
    """The correlation time [frames] that weighs the data of a fit of per-axis residual
    ``sigma`` [m] as the fit weighed them against its priors: ``(artefact_noise / sigma)^2``
    (equal to ``tau`` when ``sigma`` is at least the soft-tissue floor or tau is short)."""
    return float((artefact_noise(sigma, tau) / sigma) ** 2) if sigma > 0 else tau


def segment_table(
    pset: ParameterSet,
    result: LMResult,
    tau: float,
    settings: LMSettings | None = None,
    ranges: tuple[np.ndarray, np.ndarray] | None = None,
    prior_information: np.ndarray | None = None,
) -> list[SegmentRow]:
    """The rows (lengths, then kinematic parameters) for a fit whose residuals have
    correlation time ``tau`` [frames]; ``settings`` gives the fit's prior weight, ``ranges``
    the kinematic parameters' lower and upper bounds (K,) [m] (default: ``pset``'s),
    ``prior_information`` (P, P) [1/m^2] every prior the fit used, for ``std_priors`` (default
    None: the weak prior only, ``std_priors`` equal to ``std``)."""
    kappa, _ = pset.split(result.theta)
    k = pset.n_kappa
    lower, upper = ranges if ranges is not None else (pset.lower[:k], pset.upper[:k])
    frozen = pset.frozen[:k]
    flags = [
        parameter_flag(float(kappa[i]), float(lower[i]), float(upper[i]))
        if not frozen[i]
        else NOT_MEASURED
        for i in range(k)
    ]
    white_cov = parameter_covariance(result, settings=settings)
    slow_cov = parameter_covariance(result, tau=tau, settings=settings)
    tau_post = _prior_weighted_tau(result.sigma, tau)
    post_cov = (
        slow_cov
        if prior_information is None
        else parameter_covariance(result, tau=tau_post, prior_information=prior_information)
    )
    rows = []
    values = joint_centre_lengths(pset, result.theta)
    nominal = joint_centre_lengths(pset, pset.nominal)
    std_white = length_std(pset, result, settings=settings)
    std_slow = length_std(pset, result, tau=tau, settings=settings)
    std_post = (
        std_slow
        if prior_information is None
        else length_std(pset, result, tau=tau_post, prior_information=prior_information)
    )
    grad = length_gradient(pset, result.theta)[:, :k]
    nan = (math.nan, math.nan, math.nan)
    for (name, value), g in zip(values.items(), grad, strict=True):
        moved = np.flatnonzero(np.abs(g) > 1e-9)
        if np.any(frozen[moved]):
            rows.append(SegmentRow(name, "length", value, *nan, nominal[name], math.nan,
                                   math.nan, NOT_MEASURED))  # fmt: skip
            continue
        deps = [f"{pset.kappa_names[i]}={flags[i]}" for i in moved if flags[i]]
        rows.append(
            SegmentRow(name, "length", value, std_white[name], std_slow[name], std_post[name],
                       nominal[name], math.nan, math.nan, ";".join(deps))
        )  # fmt: skip
    for i, name in enumerate(pset.kappa_names):
        stds = nan if frozen[i] else (
            math.sqrt(max(white_cov[i, i], 0.0)), math.sqrt(max(slow_cov[i, i], 0.0)),
            math.sqrt(max(post_cov[i, i], 0.0)))  # fmt: skip
        rows.append(
            SegmentRow(name, "kappa", float(kappa[i]), *stds, float(pset.nominal[i]),
                       float(lower[i]), float(upper[i]), flags[i])
        )  # fmt: skip
    return rows


class Uncertainty(NamedTuple):
    """The segment table's summary (:func:`uncertainty_summary`): the residuals'
    correlation time ``tau_frames``, the ``rows``, the kinematic parameters ``flagged``
    (name -> flag) and the ``worst`` markers by RMS distance (name -> [m], worst first)."""

    tau_frames: float
    rows: list[SegmentRow]
    flagged: dict[str, str]
    worst: dict[str, float]


def uncertainty_summary(
    pset: ParameterSet,
    result: LMResult,
    trials: Sequence[TrialData],
    per_marker: np.ndarray,
    settings: LMSettings | None = None,
    *,
    ranges: tuple[np.ndarray, np.ndarray] | None = None,
    prior_information: np.ndarray | None = None,
    worst: int = 5,
) -> Uncertainty:
    """The segment table with the residuals' correlation time, the flagged parameters and
    the ``worst`` markers by RMS distance (per_marker (M,) [m], NaN for unseen markers);
    ``prior_information`` as :func:`segment_table`'s."""
    tau = correlation_time(pset, result, trials)
    rows = segment_table(pset, result, tau, settings, ranges, prior_information)
    order = [int(i) for i in np.argsort(-np.nan_to_num(per_marker, nan=-1.0))[:worst]]
    return Uncertainty(
        tau_frames=tau,
        rows=rows,
        flagged={
            r.name: r.flag for r in rows if r.kind == "kappa" and r.flag and r.flag != NOT_MEASURED
        },
        worst={
            pset.marker_names[i]: float(per_marker[i])
            for i in order
            if math.isfinite(per_marker[i])
        },
    )
