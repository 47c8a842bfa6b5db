"""The truth model: the nominal parameters theta perturbed at random, within their bounds."""

from __future__ import annotations

import numpy as np

from mocap_mj.errors import MocapError
from mocap_mj.parameters import ParameterSet

__all__ = ["mirror_pairs", "perturb_theta"]


def _partner(name: str, names: set[str]) -> str | None:
    """The other side of a sided name (``*_l``/``*_r``, ``L*``/``R*``) if it exists."""
    for left, right in (("_l", "_r"), ("_r", "_l")):
        if name.endswith(left) and name[: -len(left)] + right in names:
            return name[: -len(left)] + right
    if name[:1] in ("L", "R"):
        other = ("R" if name[0] == "L" else "L") + name[1:]
        if other in names:
            return other
    return None


def mirror_pairs(names: tuple[str, ...] | list[str]) -> list[tuple[int, int]]:
    """(left index, right index) pairs of sided names, in the order of the left names.

    Kinematic parameters pair as ``<name>_l``/``<name>_r``; markers as ``L<name>``/``R<name>``.
    """
    known = set(names)
    index = {n: i for i, n in enumerate(names)}
    pairs = []
    for i, n in enumerate(names):
        other = _partner(n, known)
        if other is not None and (n.endswith("_l") or (n.startswith("L") and not n.endswith("_r"))):
            pairs.append((i, index[other]))
    return pairs


def perturb_theta(
    pset: ParameterSet,
    rng: np.random.Generator,
    kappa_scale: float = 0.10,
    offset_mm: float = 20.0,
    symmetric: bool = False,
) -> np.ndarray:
    """A random subject: theta (P,) [m] around ``pset.nominal``, clipped to the bounds.

    Each kinematic parameter is multiplied by a factor uniform in ``[1 - kappa_scale,
    1 + kappa_scale]``; each marker-offset component moves by a shift uniform in
    ``[-offset_mm, +offset_mm]`` [mm]. With ``symmetric``, every right-side parameter takes the
    factor of its left partner and every right marker the mirror image ``(dx, -dy, dz)`` of
    its left partner's shift (midline markers and unpaired parameters are drawn on their
    own); otherwise all are independent. The result is clipped to ``[pset.lower, pset.upper]``
    (which the defaults never reach).

    Parameters
    ----------
    pset : ParameterSet
    rng : numpy.random.Generator
        The draws: K factors, then M x 3 shifts (the same number whatever ``symmetric``).
    kappa_scale : float
        Relative half-width of the kappa factors, in [0, 1).
    offset_mm : float
        Half-width of the marker-offset shifts [mm], >= 0.
    symmetric : bool

    Returns
    -------
    theta : (P,) float [m]
    """
    if not 0.0 <= kappa_scale < 1.0:
        raise MocapError(f"kappa_scale: expected a fraction in [0, 1), got {kappa_scale:g}")
    if not offset_mm >= 0.0:
        raise MocapError(f"offset_mm: expected a value >= 0, got {offset_mm:g}")
    kappa0, offsets0 = pset.split(pset.nominal)
    factor = rng.uniform(1.0 - kappa_scale, 1.0 + kappa_scale, pset.n_kappa)
    shift = rng.uniform(-offset_mm, offset_mm, (pset.n_markers, 3)) / 1000.0
    if symmetric:
        for left, right in mirror_pairs(pset.kappa_names):
            factor[right] = factor[left]
        for left, right in mirror_pairs(pset.marker_names):
            shift[right] = shift[left] * np.array([1.0, -1.0, 1.0])
    theta = pset.join(kappa0 * factor, offsets0 + shift)
    return np.clip(theta, pset.lower, pset.upper)
