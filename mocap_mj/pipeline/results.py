"""What the steps of an identification pass on, typed and in SI units (m, s): the priors'
weighting (:class:`Weighting`), the re-solve with joints held at their construction
(:class:`HeldAtConstruction`) and the refinement on every frame (:class:`Refined`).
:mod:`mocap_mj.pipeline.summary` writes them in summary.json's units."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mocap_mj.long.chunks import Robust


@dataclass(frozen=True)
class HeldAtConstruction:
    """A re-solve with joints held at their construction
    (:func:`~mocap_mj.pipeline.steps.solve_trials`): the ``joints``, the marker RMSE [m] as
    first fitted and held, whether it was kept."""

    joints: list[str]
    marker_rmse: tuple[float, float]
    kept: bool


@dataclass(frozen=True)
class Weighting:
    """How the anatomical solve weighed its priors, trials and sliding landmarks
    (:func:`~mocap_mj.pipeline.steps.solve_anatomical`).

    Attributes
    ----------
    sigma : float [m]
        The first solve's per-axis marker noise.
    tau_frames : float [frames]
        The residuals' pooled correlation time.
    noise : float [m]
        The marker noise the priors are weighed against (the nominal one on white noise).
    trial_tau_frames : list of float [frames]
        Each trial's residual correlation time about zero.
    trial_weights : list of float [1]
        Each trial's weight.
    centre_widths : dict of str to float [1], or None
        A ball-joint centre row's label -> its width factor (with soft tissue only).
    slide_weight_min : float [1] or None
        The sliding landmarks' smallest weight (None: not weighed).
    slide_base : float [m] or None
        The per-axis artefact the sliding landmarks are weighed against (None: not weighed).
    joint_axes : dict of str to dict
        The flexion axes' decisions (:func:`~mocap_mj.anatomy.axes.axis_decisions`), joint ->
        its fields (angles [deg], ``row_sigma_m`` and ``rmse_m`` [m]).
    held_joints : list of str
        Joints held at their construction in the solve kept.
    held_at_construction : HeldAtConstruction or None
        The re-solve with joints held, when one ran.
    """

    sigma: float
    tau_frames: float
    noise: float
    trial_tau_frames: list[float]
    trial_weights: list[float]
    centre_widths: dict[str, float] | None = None
    slide_weight_min: float | None = None
    slide_base: float | None = None
    joint_axes: dict[str, dict[str, Any]] = field(default_factory=dict)
    held_joints: list[str] = field(default_factory=list)
    held_at_construction: HeldAtConstruction | None = None


def via_millimetres(value: float) -> float:
    """``value`` [m] to millimetres and back (``value * 1e3 * 1e-3``, within one ulp of it):
    as the weighting's noise and sliding base reach the steps after the second solve (the
    centre widths, the refinement, the sliding model, the report), whose arithmetic, and so
    theta, it keeps bit for bit."""
    return value * 1e3 * 1e-3


def prior_noise(weighting: Weighting | None, nominal: float) -> float:
    """The marker noise [m] the priors are weighed against after the weighting's solve:
    ``weighting``'s, else ``nominal`` [m] (a solve without the anatomical priors), through
    millimetres (:func:`via_millimetres`)."""
    return via_millimetres(nominal if weighting is None else weighting.noise)


def sliding_base(weighting: Weighting | None) -> float | None:
    """The per-axis artefact [m] the sliding landmarks are weighed against (None: not
    weighed), through millimetres (:func:`via_millimetres`)."""
    if weighting is None or weighting.slide_base is None:
        return None
    return via_millimetres(weighting.slide_base)


def joint_axes(weighting: Weighting | None) -> dict[str, dict[str, Any]]:
    """The flexion axes' decisions of ``weighting`` (empty without one)."""
    return {} if weighting is None else weighting.joint_axes


@dataclass(frozen=True, eq=False)
class Refined:
    """The refinement on every frame of a selected recording
    (:func:`~mocap_mj.pipeline.steps.refine_on_every_frame`).

    Attributes
    ----------
    steps_std : list of float [1]
        Each refinement step's size in standard deviations.
    seconds : dict of str to float [s]
        The wall times of its parts.
    subset_kappa : (K,) float [m]
        The kinematic parameters the selected frames' solve found, before the refinement.
    qpos : list of (T_i, nq) arrays
        Every frame's pose under the subset's estimate, per motion trial: the start of the
        motion's IK.
    robust : Robust or None
        The robust loss's threshold of the refinement (None: l2), for the motion's IK.
    """

    steps_std: Any
    seconds: dict[str, float]
    subset_kappa: np.ndarray
    qpos: list[np.ndarray]
    robust: Robust | None


__all__ = [
    "HeldAtConstruction",
    "Refined",
    "Weighting",
    "joint_axes",
    "prior_noise",
    "sliding_base",
    "via_millimetres",
]
