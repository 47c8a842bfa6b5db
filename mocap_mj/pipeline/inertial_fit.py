"""The segments' masses fitted to the measured loads: the root residual made small.

Inverse dynamics is linear in each body's inertial parameters. Here each segment body b keeps
its regression's centre of mass and radii of gyration (de Leva's,
:func:`mocap_mj.anatomy.inertia.segment_inertia`) and its mass, first moment and inertia are
scaled together by one factor ``s_b``: the root residual wrench (force and moment,
:class:`mocap_mj.pipeline.dynamics.Dynamics`' ``root_force``, ``root_moment``) is then
``r(t) = c(t) + sum_b s_b w_b(t)``, where ``w_b`` is the root wrench of body b alone moving
as measured (every other body massless, no loads) and ``c`` that of the loads and of the bodies
not fitted (the carriers: clavicles, ulnae, toes). A uniform scale keeps a physically consistent
body (positive mass, inertia inside the triangle inequality) whatever ``s_b > 0``.

The fit (:func:`fit_masses`) minimises, over the frames given (stance: where every load on the
body is measured), ``sum_t |r_F(t)|^2 / sigma_F^2 + |r_M(t)|^2 / sigma_M^2 + sum_b (s_b - 1)^2
/ sigma_s^2``, with ``s_b >= MIN_SCALE``: the regression as a prior of relative sd ``sigma_s``
(:data:`PRIOR_SD`, 0.2: de Leva's and Dempster's masses of one subject are off by 10-30 %
against imaging), the residual's noise ``sigma_F`` = :data:`NOISE_FORCE` of body weight and
``sigma_M`` = ``sigma_F`` times :data:`NOISE_ARM` (0.1 m). What the data determine: the
posterior sd of each ``s_b`` (the inverse of the information, data plus prior); a body whose
sd is at most :data:`DETERMINED_SD` (0.1), its scale off the bound, is determined; the
others stay near the regression (or on the bound) and are reported as undetermined, with the
information's singular values (the combinations the data fix). The sd assumes the residual's
noise independent from frame to frame: a systematic residual (a marker model that does not
fit, a plate's load on the wrong foot) is not a mass error, and the fit then moves masses to
bounds and reduces the residual little (benchmarks/inertial_fit.py on Movement_trial).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.optimize import lsq_linear

from ..errors import MocapError
from .dynamics import CUTOFF_HZ, BodyLoad, inverse_dynamics

#: Relative sd of the regression's masses, the prior.
PRIOR_SD = 0.2
#: The root residual force's noise, a fraction of body weight.
NOISE_FORCE = 0.01
#: The residual moment's noise is the force's times this arm [m].
NOISE_ARM = 0.1
#: A fitted scale's posterior sd at most this: the data determine the body's mass.
DETERMINED_SD = 0.1
#: The smallest scale allowed (a body keeps a positive mass).
MIN_SCALE = 0.05
GRAVITY = 9.80665


@dataclass(frozen=True)
class Trial:
    """One trial for the fit: qpos (T, nq) in the model's layout, times (T,) [s], the
    measured loads and the frames (T,) bool the residual is fitted on (those whose loads are
    all measured)."""

    qpos: np.ndarray
    times: np.ndarray
    loads: Sequence[BodyLoad]
    frames: np.ndarray


@dataclass(frozen=True)
class MassFit:
    """The fit's result (B fitted bodies).

    Attributes
    ----------
    bodies : tuple of str, (B,)
    scale : (B,) float
        The fitted factor of each body's mass (and first moment and inertia).
    sd : (B,) float
        Its posterior sd.
    determined : (B,) bool
        ``sd <= DETERMINED_SD`` and not ``at_bound``.
    at_bound : (B,) bool
        The scale ended on :data:`MIN_SCALE`.
    mass_before, mass_after : (B,) float [kg]
    singular_values : (B,) float
        Of the whitened data's design (the prior left out), largest first: the number of
        combinations the data fix is the count well above 1 / PRIOR_SD.
    residual_before, residual_after : (2,) float
        The root residual's RMS force [N] and moment [N m] over the fitted frames.
    """

    bodies: tuple[str, ...]
    scale: np.ndarray
    sd: np.ndarray
    determined: np.ndarray
    at_bound: np.ndarray
    mass_before: np.ndarray
    mass_after: np.ndarray
    singular_values: np.ndarray
    residual_before: np.ndarray
    residual_after: np.ndarray


def _root(model: mujoco.MjModel, trial: Trial, loads: Sequence[BodyLoad], cutoff: float | None):
    dyn = inverse_dynamics(model, trial.qpos, trial.times, loads, cutoff_hz=cutoff)
    return np.concatenate([dyn.root_force, dyn.root_moment], axis=1)  # (T, 6)


def _alone(model: mujoco.MjModel, keep: np.ndarray) -> mujoco.MjModel:
    """A copy of ``model`` whose bodies outside ``keep`` (nbody,) bool are massless."""
    out = copy.deepcopy(model)
    out.body_mass[~keep] = 0.0
    out.body_inertia[~keep] = 0.0
    return out


def root_columns(
    model: mujoco.MjModel, trial: Trial, bodies: Sequence[str], cutoff_hz: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """(c (T, 6), W (T, 6, B)) of the module docstring for ``trial`` on ``model`` (the model
    as written, its inertial parameters the regression's): root force [N] and moment [N m]."""
    ids = [model.body(b).id for b in bodies]
    rest = np.ones(model.nbody, dtype=bool)
    rest[ids] = False
    base = _root(_alone(model, rest), trial, trial.loads, cutoff_hz)
    cols = []
    for b in ids:
        keep = np.zeros(model.nbody, dtype=bool)
        keep[b] = True
        cols.append(_root(_alone(model, keep), trial, (), cutoff_hz))
    return base, np.stack(cols, axis=2)


def fit_masses(
    model: mujoco.MjModel,
    trials: Sequence[Trial],
    bodies: Sequence[str],
    *,
    prior_sd: float = PRIOR_SD,
    noise_force: float = NOISE_FORCE,
    cutoff_hz: float | None = CUTOFF_HZ,
) -> MassFit:
    """The bodies' mass scales fitted over ``trials`` (module docstring) on ``model`` (the
    model as written with the regression's parameters); raises MocapError without a fitted
    frame."""
    weight = float(np.sum(model.body_mass)) * GRAVITY
    sigma = np.array([noise_force * weight] * 3 + [noise_force * weight * NOISE_ARM] * 3)
    bases, designs = [], []
    for trial in trials:
        base, design = root_columns(model, trial, bodies, cutoff_hz)
        rows = np.asarray(trial.frames, dtype=bool) & np.isfinite(base).all(axis=1)
        rows &= np.isfinite(design).all(axis=(1, 2))
        bases.append(base[rows] / sigma)
        designs.append(design[rows] / sigma[None, :, None])
    c = np.concatenate(bases).reshape(-1)
    a = np.concatenate(designs).reshape(-1, len(bodies))
    if len(c) == 0:
        raise MocapError("mass fit: no frame with measured loads and computed dynamics")
    n = len(bodies)
    lhs = np.concatenate([a, np.eye(n) / prior_sd])
    rhs = np.concatenate([-c, np.ones(n) / prior_sd])
    scale = lsq_linear(lhs, rhs, bounds=(MIN_SCALE, np.inf)).x
    sd = np.sqrt(np.diag(np.linalg.inv(lhs.T @ lhs)))

    def rms(s: np.ndarray) -> np.ndarray:
        r = (c + a @ s).reshape(-1, 6) * sigma
        return np.array([np.sqrt(np.mean(np.sum(r[:, :3] ** 2, axis=1))),
                         np.sqrt(np.mean(np.sum(r[:, 3:] ** 2, axis=1)))])  # fmt: skip

    masses = np.array([model.body_mass[model.body(b).id] for b in bodies])
    return MassFit(
        bodies=tuple(bodies),
        scale=scale,
        sd=sd,
        determined=(sd <= DETERMINED_SD) & (scale > MIN_SCALE * (1 + 1e-6)),
        at_bound=scale <= MIN_SCALE * (1 + 1e-6),
        mass_before=masses,
        mass_after=masses * scale,
        singular_values=np.linalg.svd(a, compute_uv=False),
        residual_before=rms(np.ones(n)),
        residual_after=rms(scale),
    )


__all__ = [
    "DETERMINED_SD",
    "MIN_SCALE",
    "NOISE_ARM",
    "NOISE_FORCE",
    "PRIOR_SD",
    "MassFit",
    "Trial",
    "fit_masses",
    "root_columns",
]
