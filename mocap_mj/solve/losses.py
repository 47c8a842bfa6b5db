"""Robust losses rho(d) of a marker's 3D distance d [m], as objects with a value and IRLS weights.

Each loss has a threshold c [m] (the solver sets it to ``loss_scale`` times the per-axis noise
estimated from the residuals); the joint LM minimises sum rho(d) by iteratively reweighted
least squares with the weights w(d) = rho'(d) / d.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol, get_args

import numpy as np

from ..errors import MocapError

LossName = Literal["l2", "huber", "cauchy"]
LOSS_NAMES: tuple[str, ...] = get_args(LossName)


class Loss(Protocol):
    """rho(d) summed over the present samples, and its IRLS weights."""

    @property
    def name(self) -> str:
        """The loss's name (one of :data:`LOSS_NAMES`)."""
        ...

    def value(self, dist: np.ndarray, present: np.ndarray, c: float) -> float:
        """sum over present samples of rho(d) [m^2]; dist (T, M) [m], present (T, M) bool."""
        ...

    def weights(self, dist: np.ndarray, present: np.ndarray, c: float) -> np.ndarray:
        """IRLS weights (T, M) [1], 0 where a sample is missing."""
        ...


@dataclass(frozen=True)
class L2:
    """rho(d) = d^2 / 2: least squares (the maximum-likelihood loss for Gaussian noise)."""

    name: str = "l2"

    def value(self, dist: np.ndarray, present: np.ndarray, c: float) -> float:
        return float(0.5 * np.sum(dist[present] ** 2))

    def weights(self, dist: np.ndarray, present: np.ndarray, c: float) -> np.ndarray:
        return present.astype(float)


@dataclass(frozen=True)
class Huber:
    """rho(d) = d^2 / 2 for d <= c, c d - c^2 / 2 beyond: linear growth for outliers."""

    name: str = "huber"

    def value(self, dist: np.ndarray, present: np.ndarray, c: float) -> float:
        d = dist[present]
        return float(np.sum(np.where(d <= c, 0.5 * d**2, c * d - 0.5 * c**2)))

    def weights(self, dist: np.ndarray, present: np.ndarray, c: float) -> np.ndarray:
        w = np.minimum(1.0, c / np.maximum(dist, 1e-300))
        return np.where(present, w, 0.0)


@dataclass(frozen=True)
class Cauchy:
    """rho(d) = c^2 / 2 log(1 + (d / c)^2): bounded influence, for gross outliers and swaps."""

    name: str = "cauchy"

    def value(self, dist: np.ndarray, present: np.ndarray, c: float) -> float:
        d = dist[present]
        return float(np.sum(0.5 * c**2 * np.log1p((d / c) ** 2)))

    def weights(self, dist: np.ndarray, present: np.ndarray, c: float) -> np.ndarray:
        w = 1.0 / (1.0 + (dist / c) ** 2)
        return np.where(present, w, 0.0)


@dataclass(frozen=True)
class Weighted:
    """``base`` applied to each sample's distance scaled by sqrt(w): sum rho(sqrt(w) d).

    ``w`` (n, M) [1] holds per-sample weights, the ratio of the nominal noise variance to the
    sample's own (a heteroscedastic noise model: a sample with standard deviation s0 / sqrt(w)
    is weighed as its residual normalised by it). For the l2 loss this is sum w d^2 / 2; for
    the robust losses the threshold applies to the normalised residual. The IRLS weights are
    ``w * base.weights(sqrt(w) d)``.
    """

    base: Loss
    w: np.ndarray

    @property
    def name(self) -> str:
        return self.base.name

    def value(self, dist: np.ndarray, present: np.ndarray, c: float) -> float:
        return self.base.value(np.sqrt(self.w) * dist, present, c)

    def weights(self, dist: np.ndarray, present: np.ndarray, c: float) -> np.ndarray:
        return self.w * self.base.weights(np.sqrt(self.w) * dist, present, c)


def loss_named(name: str) -> Loss:
    """The loss called ``name`` (one of :data:`LOSS_NAMES`); else a MocapError listing them."""
    losses: dict[str, Loss] = {"l2": L2(), "huber": Huber(), "cauchy": Cauchy()}
    if name not in losses:
        raise MocapError(f"loss must be one of {', '.join(LOSS_NAMES)}; got {name!r}")
    return losses[name]


__all__ = ["L2", "LOSS_NAMES", "Cauchy", "Huber", "Loss", "LossName", "Weighted", "loss_named"]
