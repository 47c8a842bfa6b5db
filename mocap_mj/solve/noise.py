"""How many independent observations a trial's residuals hold.

The white-noise model behind the Cramer-Rao bound treats every frame as an independent
observation. On real recordings the residuals are dominated by soft-tissue artefact and model
error, which depend on the pose and so repeat over neighbouring frames (and over the cycles of
a repeated movement): the trial holds fewer independent observations than frames.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def residual_correlation_time(residuals: np.ndarray, *, about_mean: bool = True) -> float:
    """Integrated autocorrelation time [frames] of a trial's residuals (T, ...) [m].

    tau = 1 + 2 sum_k rho_k, rho_k the lag-k autocorrelation pooled over every residual
    coordinate (NaN samples left out, each coordinate's mean removed), summed over the initial
    positive sequence (Geyer 1992: up to the first pair rho_2k-1 + rho_2k that is not
    positive). White noise gives about 1; residuals that repeat over n frames give about n. The
    effective number of independent frames is T / tau.

    ``about_mean=False`` correlates the residuals about zero instead (:func:`trial_weights`):
    a coordinate's mean over the trial is then an offset repeated in every frame, so a trial
    whose residual is one constant offset (a static pose's soft tissue) has a tau near its
    length.
    """
    r = np.asarray(residuals, dtype=float).reshape(len(residuals), -1)
    t = len(r)
    if t < 4:
        return 1.0
    ok = np.isfinite(r)
    count = np.maximum(ok.sum(axis=0), 1)
    mean = np.where(ok, r, 0.0).sum(axis=0) / count
    r = np.where(ok, r - mean if about_mean else r, 0.0)
    var = float(np.sum(r**2) / max(int(ok.sum()), 1))
    if var <= 0.0:
        return 1.0
    okf = ok.astype(float)

    def rho(k: int) -> float:
        n = float(np.sum(okf[k:] * okf[: t - k]))
        return float(np.sum(r[k:] * r[: t - k]) / n / var) if n > 0 else 0.0

    tau = 1.0
    for k in range(1, t // 2 - 1, 2):
        pair = rho(k) + rho(k + 1)
        if pair <= 0.0:
            break
        tau += 2.0 * pair
    return float(min(tau, t))


#: Per-axis soft-tissue artefact [m] assumed at least on a real recording (residuals
#: correlated over ``CORRELATED_TAU`` frames or more). The fit's residual is only the part of
#: the artefact the model could not absorb: the part that looks like joint motion or a
#: shifted joint centre is taken up by the skeleton and never appears in it. Skin markers
#: move 5-30 mm against the bone (Leardini et al. 2005, Peters et al. 2010): 5 mm per axis
#: (8.7 mm in 3-D) is the low end.
SOFT_TISSUE_SIGMA = 0.005
#: Residual correlation time [frames] from which residuals are taken as soft-tissue artefact
#: rather than white measurement noise (tau about 1).
CORRELATED_TAU = 2.0


def artefact_noise(sigma: float, tau: float) -> float:
    """The per-axis noise [m] of one independent observation that the priors are weighed
    against: ``sigma`` [m] (the fit's per-axis residual) times sqrt(``tau``) [frames], with
    ``sigma`` raised to ``SOFT_TISSUE_SIGMA`` when the residuals are correlated (``tau`` >=
    ``CORRELATED_TAU``): the fit's residual underestimates the artefact it absorbed."""
    if tau >= CORRELATED_TAU:
        sigma = max(sigma, SOFT_TISSUE_SIGMA)
    return sigma * float(np.sqrt(tau))


#: Range of a trial's weight in a multi-trial fit (:func:`trial_weights`): no trial counts
#: less than a tenth, or more than ten times, of what its frames would (the correlation time
#: of a short or near-constant residual is itself uncertain by a factor of a few; beyond a
#: factor of ten a trial would be all but dropped, or would decide alone).
TRIAL_WEIGHT_RANGE = (0.1, 10.0)


def trial_weights(taus: Sequence[float], frames: Sequence[int]) -> list[float]:
    """Each trial's weight [1] in a multi-trial fit: its frames count by the independent
    observations they hold, ``frames[k] / taus[k]`` (``taus`` [frames] the residual
    correlation times about zero, :func:`residual_correlation_time`).

    The weight is ``tau_pool / tau_k``: ``tau_k`` raised to ``CORRELATED_TAU`` (residuals
    less correlated than that are white measurement noise, never reweighed: trials of white
    noise all keep weight 1), ``tau_pool = sum n_k / sum (n_k / tau_k)``, so the weighted
    frames add up to the frames (the pooled residual's noise and the priors' weighting keep
    their scale), clipped to :data:`TRIAL_WEIGHT_RANGE`. One trial, or trials equally
    correlated, keep weight 1 exactly. Why: a static trial's soft tissue is one offset held
    over all its frames; counted frame by frame, 500 frames of one pose outvote 300 frames of
    movement that each see the artefact differently.
    """
    tau = np.maximum(np.asarray(taus, dtype=float), CORRELATED_TAU)
    n = np.asarray(frames, dtype=float)
    if len(tau) < 2 or np.all(tau == tau[0]):
        return [1.0] * len(tau)
    pooled = n.sum() / np.sum(n / tau)
    return [float(w) for w in np.clip(pooled / tau, *TRIAL_WEIGHT_RANGE)]
