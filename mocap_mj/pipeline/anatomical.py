"""What the anatomical solve of an identification is built from: the priors' specification
(:class:`AnatomyPriors`: the subject, the prior scale, the left/right prior, T10, the hip
regression, the set's landmarks, the joints held at their construction), the choices that
weigh the data (:class:`Weighing`), and the priors themselves (:func:`anatomical_priors`,
:func:`prior_information`)."""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mocap_mj.anatomy.anatomy import landmark_prior, symmetric_prior
from mocap_mj.anatomy.axes import SILENT_AXIS_SD
from mocap_mj.anatomy.ball_centres import centre_widths
from mocap_mj.anatomy.joint_checks import hold
from mocap_mj.anatomy.partial import on_measured
from mocap_mj.anatomy.tissue import Slide
from mocap_mj.anatomy.trunk import T10Placement
from mocap_mj.capture.subject import Subject
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.priors import LinearGaussianPrior


@dataclass(frozen=True)
class AnatomyPriors:
    """What the landmark priors and the left/right prior are built from.

    Attributes
    ----------
    subject : Subject
        The subject's measurements (stature, widths, lengths).
    size : float [1]
        The prior scale: the subject's stature over the nominal model's (default 1).
    symmetric : float [m] or None
        The left/right length prior's standard deviation (default None: no such prior).
    t10 : T10Placement or None
        A T10 found misplaced (:mod:`mocap_mj.anatomy.trunk`), widening the rows that hang
        on it (default None: trusted).
    hip_centre : str
        The hip regression: ``harrington`` (default) or ``davis``.
    landmarks : dict of str to str, or None
        Marker -> the anatomical landmark it sits on (:mod:`mocap_mj.capture.landmarks`;
        default None: the model's own).
    held : collection of str
        Joints held at their construction (:func:`~mocap_mj.anatomy.joint_checks.hold`;
        default none).
    """

    subject: Subject
    size: float = 1.0
    symmetric: float | None = None
    t10: T10Placement | None = None
    hip_centre: str = "harrington"
    landmarks: Mapping[str, str] | None = None
    held: Collection[str] = ()


@dataclass(frozen=True)
class Weighing:
    """How the anatomical solve weighs the data (the recipe's choices).

    Attributes
    ----------
    slides : dict of str to Slide, or None
        The sliding landmarks (e.g. :data:`~mocap_mj.anatomy.tissue.SLIDES`; default None:
        off), weighed only where the residuals show soft tissue.
    trial_weights : bool
        Weigh several trials by the independent observations each holds (default True;
        False weighs every trial 1).
    silent_axis_sd : float [rad]
        A flexion axis whose standard deviation from the data is above this stays at its
        construction (default :data:`~mocap_mj.anatomy.axes.SILENT_AXIS_SD`, 10 deg).
    """

    slides: dict[str, Slide] | None = None
    trial_weights: bool = True
    silent_axis_sd: float = SILENT_AXIS_SD


def anatomical_priors(
    pset: ParameterSet,
    anatomy: AnatomyPriors,
    *,
    noise: float = 0.001,
    axes: dict[str, float | None] | None = None,
    centres: Mapping[str, float] | None = None,
) -> list[LinearGaussianPrior]:
    """Landmark priors and, with ``anatomy.symmetric`` [m], the left/right length prior,
    weighed against a marker noise ``noise`` [m]; without the rows on ``pset``'s frozen
    parameters (:func:`~mocap_mj.anatomy.partial.on_measured`). ``axes``: the chord-plane
    rows' widths (:func:`~mocap_mj.anatomy.axes.widths`), see
    :func:`~mocap_mj.anatomy.anatomy.landmark_prior`; ``centres``: a ball-joint centre row's
    label -> its width factor (:func:`~mocap_mj.anatomy.ball_centres.centre_widths`, decided
    by :func:`~mocap_mj.pipeline.steps.solve_anatomical`; default none)."""
    landmark = landmark_prior(
        pset,
        anatomy.subject,
        size=anatomy.size,
        noise=noise,
        t10=anatomy.t10,
        hip_centre=anatomy.hip_centre,
        axis_widths=axes,
        landmarks=anatomy.landmarks,
    )
    if anatomy.held:
        landmark = hold(landmark, pset, anatomy.landmarks, anatomy.held)
    priors = [centre_widths(landmark, centres or {})]  # fmt: skip
    if anatomy.symmetric is not None:
        priors.append(symmetric_prior(pset, anatomy.symmetric, noise=noise))
    return [on_measured(p, pset.frozen) for p in priors]


def prior_information(
    priors: Sequence[LinearGaussianPrior], settings: LMSettings, size: int
) -> np.ndarray:
    """The information (size, size) [1/m^2] the priors of a solve hold about theta: every
    row's ``a_r a_r^T / sigma_r^2`` plus the weak prior toward the initial model
    (``1 / settings.prior_sigma^2`` per parameter), as for a marker noise equal to the
    priors' ``noise`` (the weighting the solve used). For the Cramer-Rao bound with the
    priors (:meth:`Identifiability.bound_rms_with_prior`)."""
    info = np.zeros((size, size))
    for p in (settings.weak_prior(np.zeros(size)), *priors):
        info += (p.a.T / p.sigma**2) @ p.a
    return info
