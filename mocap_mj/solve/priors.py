"""Priors on theta: penalties added to the marker cost F, in the units of F [m^2].

A prior is anything with ``cost``, ``gradient`` and a constant Gauss-Newton ``hessian``
(:class:`Prior`); the identification problem sums the priors it is given. The default is
:func:`weak_prior`: an isotropic Gaussian toward the initial model, 50 mm wide against a 1 mm
marker noise, which pins the directions of theta the markers cannot determine.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import MocapError, check_shape


@runtime_checkable
class Prior(Protocol):
    """A penalty on theta added to the marker cost F (same units as F: m^2)."""

    def cost(self, theta: np.ndarray) -> float:
        """Penalty [m^2] at theta (P,) [m]."""
        ...

    def gradient(self, theta: np.ndarray) -> np.ndarray:
        """(P,) dcost/dtheta [m] at theta (P,) [m]."""
        ...

    def hessian(self) -> np.ndarray:
        """(P, P) [1], Gauss-Newton, constant."""
        ...


@dataclass(frozen=True)
class LinearGaussianPrior:
    """cost = 1/2 noise^2 sum_r ((a_r . theta - b_r) / sigma_r)^2

    A Gaussian belief about R linear combinations of theta, each with a width sigma_r stated
    against the marker noise ``noise`` (so that a prior row weighs as much as a marker
    coordinate measured with accuracy sigma_r).

    Attributes
    ----------
    a : (R, P) [1]
    b : (R,) [m]
    sigma : (R,) [m], positive
    noise : float [m], the marker noise the widths are stated against (default 1 mm)
    labels : (R,) str, what each row says (for reports; default none)
    """

    a: np.ndarray
    b: np.ndarray
    sigma: np.ndarray
    noise: float = 0.001
    labels: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        a = np.atleast_2d(np.asarray(self.a, dtype=float))
        r = a.shape[0]
        check_shape("prior b", np.asarray(self.b), (r,))
        check_shape("prior sigma", np.asarray(self.sigma), (r,))
        if not np.all(np.asarray(self.sigma) > 0) or not self.noise > 0:
            raise MocapError("prior widths sigma and noise must be positive")

    @property
    def _w(self) -> np.ndarray:
        """Row weights (noise / sigma_r)^2 [1]."""
        return (self.noise / np.asarray(self.sigma, dtype=float)) ** 2

    def _residual(self, theta: np.ndarray) -> np.ndarray:
        return np.asarray(self.a, dtype=float) @ theta - np.asarray(self.b, dtype=float)

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """(a theta - b) / sigma (R,) [1]: each row's misfit in its own widths."""
        return self._residual(theta) / np.asarray(self.sigma, dtype=float)

    def with_noise(self, noise: float) -> LinearGaussianPrior:
        """The same rows weighed against another marker noise [m]."""
        return replace(self, noise=float(noise))

    def cost(self, theta: np.ndarray) -> float:
        r = self._residual(theta)
        return float(0.5 * np.sum(self._w * r**2))

    def gradient(self, theta: np.ndarray) -> np.ndarray:
        a = np.asarray(self.a, dtype=float)
        return np.asarray(a.T @ (self._w * self._residual(theta)))

    def hessian(self) -> np.ndarray:
        a = np.asarray(self.a, dtype=float)
        return np.asarray(a.T @ (self._w[:, None] * a))


def weak_prior(
    theta0: np.ndarray, sigma: float = 0.05, noise: float = 0.001
) -> LinearGaussianPrior:
    """The isotropic prior toward theta0 (P,) [m] with width ``sigma`` [m] for every parameter.

    Its weight (noise / sigma)^2 is negligible in every direction the data determine to better
    than a few millimetres, and pins the others (a lone marker turning about its joint, the
    pelvis frame against its markers) to theta0.
    """
    p = len(theta0)
    b = np.asarray(theta0, dtype=float).copy()
    return LinearGaussianPrior(np.eye(p), b, np.full(p, float(sigma)), noise)


def total_prior(
    priors: Sequence[Prior],
    theta: np.ndarray,
    free: np.ndarray,
    hessian: np.ndarray | None = None,
) -> tuple[float, np.ndarray, np.ndarray]:
    """Summed cost [m^2], gradient (Pf,) [m] and Hessian (Pf, Pf) over the free parameters.

    ``hessian``: the summed Hessian of an earlier call with the same priors, returned as it
    is (it does not depend on theta; default None: formed, a (P, P) product per prior).
    """
    pf = free.size
    cost, grad = 0.0, np.zeros(pf)
    for prior in priors:
        cost += prior.cost(theta)
        grad += prior.gradient(theta)[free]
    if hessian is None:
        hessian = np.zeros((pf, pf))
        for prior in priors:
            hessian += prior.hessian()[np.ix_(free, free)]
    return cost, grad, hessian


__all__ = ["LinearGaussianPrior", "Prior", "total_prior", "weak_prior"]
