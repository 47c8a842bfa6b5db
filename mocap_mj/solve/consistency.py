"""Segment lengths of an identified model, and how well a trial determines each of them.

Comparing models identified from different trials of one subject needs quantities that do
not depend on the arbitrary parts of theta (the pelvis frame slides against its markers along
unobservable directions, see :mod:`mocap_mj.solve.identifiability`). Distances between
joint centres are such quantities: :func:`joint_centre_lengths` returns every distance from a
body's origin (its joint centre) to its parent's, and between left/right mirrored siblings
(the two hip centres, the two sternoclavicular joints).

Whether a trial *excites* a length is decided from its data, not from a list of joints:
:func:`length_std` is the standard deviation of the length from the trial's reduced
information, with a noise level that is honest about real data. The white-noise Cramer-Rao
bound treats every frame as independent; soft-tissue artefact and model error make the
residuals of neighbouring frames alike, so the trial holds fewer independent observations.
The residuals' integrated autocorrelation time tau (frames; :func:`residual_correlation_time`)
measures how many frames make one independent observation, and the variance is inflated by
it (the effective number of frames is T / tau). The prior of the fit is included (a length
the data do not determine has the prior's width). :func:`excited_lengths` keeps the lengths
whose standard deviation is at most ``observable_std`` (5 mm, the threshold of an observable
direction) in every trial.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.lm import LMResult, LMSettings, TrialData
from mocap_mj.solve.noise import residual_correlation_time


def _length_pairs(pset: ParameterSet) -> list[tuple[str, int, int]]:
    """(name, body a, body b): adjacent joint centres and mirrored sibling centres."""
    model = pset.model
    names = [model.body(b).name for b in range(model.nbody)]
    pairs: list[tuple[str, int, int]] = []
    for b in range(1, model.nbody):
        p = int(model.body_parentid[b])
        if p == 0 or np.linalg.norm(pset.body_pos_nominal[b]) < 1e-9:
            continue  # the root, or a child at its parent's origin (no length)
        pairs.append((f"{names[p]}:{names[b]}", p, b))
    for b in range(1, model.nbody):
        if names[b].endswith("_l"):
            r = names[b][:-2] + "_r"
            if r in names:
                rb = names.index(r)
                if model.body_parentid[b] == model.body_parentid[rb] != 0:
                    pairs.append((f"{names[b]}:{r}", b, rb))
    return pairs


def _lengths(pset: ParameterSet, theta: np.ndarray) -> np.ndarray:
    pos = pset.body_pos(theta)
    out = []
    for _, a, b in _length_pairs(pset):
        pa = pset.model.body_parentid
        if pa[b] == a:
            out.append(np.linalg.norm(pos[b]))  # child in its parent's frame
        else:
            out.append(np.linalg.norm(pos[b] - pos[a]))  # siblings in their parent's frame
    return np.array(out)


def joint_centre_lengths(pset: ParameterSet, theta: np.ndarray) -> dict[str, float]:
    """Distances [m] between joint centres, keyed ``"parent:child"`` or ``"left:right"``.

    Body frames of the model are not rotated against their parents in the reference pose
    (``body_quat`` is the identity), so a child's ``body_pos`` is its offset in the parent's
    frame and its norm is the segment length whatever the pose.
    """
    names = [n for n, _, _ in _length_pairs(pset)]
    return dict(zip(names, (float(v) for v in _lengths(pset, theta)), strict=True))


def length_gradient(pset: ParameterSet, theta: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """d length / d theta (L, P) by central differences over the kinematic parameters."""
    grad = np.zeros((len(_length_pairs(pset)), pset.size))
    for k in range(pset.n_kappa):
        e = np.zeros(pset.size)
        e[k] = h
        grad[:, k] = (_lengths(pset, theta + e) - _lengths(pset, theta - e)) / (2 * h)
    return grad


def trial_residuals(
    pset: ParameterSet, result: LMResult, trials: Sequence[TrialData]
) -> list[np.ndarray]:
    """Per trial, the residual vectors (T_used, M, 3) [m] of the fit (NaN where missing)."""
    kin = Kinematics(pset)
    kin.set_theta(result.theta)
    out = []
    for trial, qpos, used in zip(trials, result.qpos, result.used, strict=True):
        x = kin.marker_positions(qpos[used])
        out.append(np.asarray(trial.markers)[used] - x)
    return out


def correlation_time(pset: ParameterSet, result: LMResult, trials: Sequence[TrialData]) -> float:
    """Residual correlation time [frames] of a fit: T / sum_i (T_i / tau_i) over its trials."""
    return pooled_correlation_time(trial_residuals(pset, result, trials))


def pooled_correlation_time(residuals: Sequence[np.ndarray]) -> float:
    """T / sum_i (T_i / tau_i) [frames] over the trials' residuals (T_i, M, 3) [m]
    (:func:`trial_residuals`)."""
    independent = sum(len(r) / residual_correlation_time(r) for r in residuals)
    return sum(len(r) for r in residuals) / max(independent, 1e-12)


def parameter_covariance(
    result: LMResult,
    *,
    tau: float = 1.0,
    settings: LMSettings | None = None,
    prior_information: np.ndarray | None = None,
) -> np.ndarray:
    """Covariance (P, P) [m^2] of theta given a fit's data and its prior (zero where frozen).

    sigma^2 (S / tau + lambda_p I)^-1 over the free parameters: S the fit's reduced
    information (unit weights), sigma its per-axis noise, tau the residuals' correlation time
    in frames (1: white noise, the Cramer-Rao bound; see :func:`correlation_time`),
    lambda_p the prior weight of ``settings`` (as in the LM's cost), so a direction the data
    do not determine keeps the prior's width sigma / sqrt(lambda_p) instead of an infinite
    one.

    With ``prior_information`` (P, P) [1/m^2] (every prior of the fit, the weak one included:
    :func:`mocap_mj.pipeline.steps.prior_information`) the covariance is instead
    ``(S / (tau sigma^2) + prior_information)^-1``: the data's information inflated by tau,
    the priors' not (a prior row is one belief, not repeated over frames).
    """
    st = settings or LMSettings()
    free = np.asarray(result.free, dtype=bool)
    data = result.reduced_information[np.ix_(free, free)] / tau
    cov = np.zeros(result.reduced_information.shape)
    if prior_information is None:
        info = data + st.prior_weight * np.eye(int(free.sum()))
        cov[np.ix_(free, free)] = result.sigma**2 * np.linalg.inv(info)
    else:
        info = data / result.sigma**2 + np.asarray(prior_information)[np.ix_(free, free)]
        cov[np.ix_(free, free)] = np.linalg.inv(info)
    return cov


def length_std(
    pset: ParameterSet,
    result: LMResult,
    *,
    tau: float = 1.0,
    settings: LMSettings | None = None,
    prior_information: np.ndarray | None = None,
) -> dict[str, float]:
    """Standard deviation [m] of every joint-centre length given a fit's data.

    sqrt(g^T C g), C the parameter covariance of :func:`parameter_covariance` (the white-noise
    bound inflated by the correlation time ``tau``, with the fit's prior) and g the length's
    gradient; ``prior_information`` as there.
    """
    cov = parameter_covariance(
        result, tau=tau, settings=settings, prior_information=prior_information
    )
    g = length_gradient(pset, result.theta)
    var = np.einsum("lp,pq,lq->l", g, cov, g)
    names = [n for n, _, _ in _length_pairs(pset)]
    return dict(zip(names, (float(v) for v in np.sqrt(np.maximum(var, 0.0))), strict=True))


def excited_lengths(
    stds: Sequence[dict[str, float]], observable_std: float = LMSettings.observable_std
) -> list[str]:
    """Names of the lengths every trial determines to ``observable_std`` [m] or better."""
    if not stds:
        return []
    return [n for n in stds[0] if all(s[n] <= observable_std for s in stds)]
