"""The truth model: the nominal parameters theta perturbed at random, within their bounds."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mocap_mj.anatomy.anatomy import ALIGNMENT, landmark_prior
from mocap_mj.errors import MocapError
from mocap_mj.skeleton.parameters import ParameterSet

from .config import MARKER_PLACEMENTS

__all__ = ["mirror_pairs", "perturb_theta", "place_landmarks"]

#: The ``kappa_scale`` at which the alignment parameters are drawn with their prior's spread.
DEFAULT_KAPPA_SCALE = 0.10


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
    placement: str = "uniform",
    landmarks: Mapping[str, str] | None = None,
) -> np.ndarray:
    """A random subject: theta (P,) [m] around ``pset.nominal``, clipped to the bounds.

    Each kinematic parameter of non-zero nominal value is multiplied by a factor uniform in
    ``[1 - kappa_scale, 1 + kappa_scale]``; each marker-offset component moves by a shift
    uniform in ``[-offset_mm, +offset_mm]`` [mm]. With ``symmetric``, every right-side
    parameter takes the factor of its left partner and every right marker the mirror image
    ``(dx, -dy, dz)`` of its left partner's shift (midline markers and unpaired parameters
    are drawn on their own); otherwise all are independent. With ``placement="anatomical"``
    the landmark markers are then moved onto the perturbed skeleton
    (:func:`place_landmarks`, further draws from ``rng``); the default ``"uniform"`` leaves
    every marker at its nominal offset plus its shift, so a landmark does not follow the
    joint it marks. Each frontal-plane alignment parameter (nominal 0, which a factor cannot
    move) is drawn from its prior, its spread scaled by ``kappa_scale`` / 0.10
    (:func:`_draw_alignment`), before the placement (KNE and ANK follow it), from a child
    stream (``rng.spawn``): every draw of ``rng`` is the one the same seed gave before these
    parameters existed, and the skeleton is the same whatever the placement. The result is
    clipped to ``[pset.lower, pset.upper]`` (which the defaults never reach).

    Parameters
    ----------
    pset : ParameterSet
    rng : numpy.random.Generator
        The draws: one factor per non-zero kinematic parameter, M x 3 shifts, then the
        landmark placement's (``"anatomical"``), the same number whatever ``symmetric``; the
        alignment parameters' from ``rng.spawn(1)[0]``.
    kappa_scale : float
        Relative half-width of the kappa factors, in [0, 1).
    offset_mm : float
        Half-width of the marker-offset shifts [mm], >= 0.
    symmetric : bool
    placement : str
        One of :data:`mocap_synth.config.MARKER_PLACEMENTS`.
    landmarks : mapping, optional
        Marker -> the landmark it sits on (a marker set's ``landmark:`` entries): a medial
        epicondyle or malleolus is then placed as the identification's rows expect it
        (its pair's midpoint on the joint centre), passed to :func:`place_landmarks`.

    Returns
    -------
    theta : (P,) float [m]
    """
    if not 0.0 <= kappa_scale < 1.0:
        raise MocapError(f"kappa_scale: expected a fraction in [0, 1), got {kappa_scale:g}")
    if not offset_mm >= 0.0:
        raise MocapError(f"offset_mm: expected a value >= 0, got {offset_mm:g}")
    if placement not in MARKER_PLACEMENTS:
        raise MocapError(
            f"placement: expected one of {', '.join(MARKER_PLACEMENTS)}, got {placement!r}"
        )
    kappa0, offsets0 = pset.split(pset.nominal)
    scaled = kappa0 != 0.0
    factor = np.ones(pset.n_kappa)
    factor[scaled] = rng.uniform(1.0 - kappa_scale, 1.0 + kappa_scale, int(scaled.sum()))
    shift = rng.uniform(-offset_mm, offset_mm, (pset.n_markers, 3)) / 1000.0
    if symmetric:
        for left, right in mirror_pairs(pset.kappa_names):
            factor[right] = factor[left]
        for left, right in mirror_pairs(pset.marker_names):
            shift[right] = shift[left] * np.array([1.0, -1.0, 1.0])
    theta = pset.join(kappa0 * factor, offsets0 + shift)
    # From a child stream: the parent's draws stay those the seed gave before the alignment
    # parameters existed, and the skeleton is the same whatever the placement.
    _draw_alignment(pset, rng.spawn(1)[0], theta, symmetric, kappa_scale / DEFAULT_KAPPA_SCALE)
    if placement == "anatomical":
        theta = place_landmarks(pset, theta, rng, landmarks)
    return np.clip(theta, pset.lower, pset.upper)


def _draw_alignment(
    pset: ParameterSet, rng: np.random.Generator, theta: np.ndarray, symmetric: bool, scale: float
) -> None:
    """Draw the frontal-plane alignment parameters into ``theta`` (P,) [m] in place, each from
    its prior (:data:`mocap_mj.anatomy.anatomy.ALIGNMENT`): normal with mean ``tan(mean)``
    and standard deviation ``scale x tan(sd)`` x its segment's nominal length; at ``scale``
    1 (the default ``kappa_scale``) the spread of healthy adults that the prior rows
    describe, so a demo tests the rows as well as the data; at 0 none, as for the lengths."""
    index = {n: i for i, n in enumerate(pset.kappa_names)}
    for name, (length, mean, sd) in ALIGNMENT.items():
        drawn: dict[str, float] = {}
        for side in ("l", "r"):
            k, seg = index.get(f"{name}_{side}"), index.get(f"{length}_{side}")
            if k is None or seg is None:
                continue
            draw = np.tan(np.radians(mean)) + scale * np.tan(np.radians(sd)) * rng.normal()
            drawn[side] = draw * pset.nominal[seg]
        if symmetric and "l" in drawn and "r" in drawn:
            drawn["r"] = drawn["l"]
        for side, value in drawn.items():
            theta[index[f"{name}_{side}"]] = pset.nominal[index[f"{name}_{side}"]] + value


def place_landmarks(
    pset: ParameterSet,
    theta: np.ndarray,
    rng: np.random.Generator,
    landmarks: Mapping[str, str] | None = None,
) -> np.ndarray:
    """theta (P,) [m] with its landmark markers where the marker set's anatomy puts them.

    The rows of :func:`mocap_mj.anatomy.anatomy.landmark_prior` (no subject measurements,
    nominal stature) say where each Plug-in Gait landmark sits relative to the skeleton, as
    ``a_r . theta = b_r`` with a placement width ``sigma_r`` per row. Each row draws a
    placement error ``e_r ~ N(0, sigma_r^2)``, and the marker offsets the rows name are moved
    by the least-squares correction ``d`` (rows weighted by ``1 / sigma_r``) that makes
    ``a_r . (theta + d) = b_r + e_r``; where the rows leave a combination of offsets free
    (a WRA-WRB bar's own width, PSIS heights) ``d`` is the minimum-norm one, so that
    combination keeps its draw from ``theta``. Rows that cannot all hold at once (the left and
    right Harrington rows share the PSIS depth) are met in the weighted least-squares sense.
    The kinematic parameters and the markers no row names (free-placed markers, head
    markers) are unchanged; a wand moves only by its joint's chord plane. Why: a real
    subject's KNE sits on the knee's axis whatever the thigh's length; moving the skeleton
    alone would place landmarks where no subject has them, and priors centred on anatomy
    would be biased against such a truth (docs/synth.md).
    ``landmarks`` (marker -> landmark, default none) adds the rows of a marker set's medial
    epicondyles and malleoli (``landmark_prior(..., landmarks=)``), for the same reason.
    """
    prior = landmark_prior(pset, landmarks=landmarks)
    k = pset.n_kappa
    a_off = prior.a[:, k:]
    rows = np.flatnonzero(np.any(a_off != 0.0, axis=1))
    cols = np.flatnonzero(np.any(a_off[rows] != 0.0, axis=0))
    sigma = prior.sigma[rows]
    target = prior.b[rows] + rng.normal(0.0, sigma) - prior.a[rows] @ theta
    d, *_ = np.linalg.lstsq(a_off[np.ix_(rows, cols)] / sigma[:, None], target / sigma, rcond=None)
    out = np.array(theta, dtype=float, copy=True)
    out[k + cols] += d
    return out
