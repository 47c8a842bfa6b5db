"""Hinge joints' centres against their construction: how far the fit moved each one.

The initial model places every knee, ankle and elbow centre by its construction on the
recording (:mod:`mocap_mj.anatomy.constructed`: Plug-in Gait's chord, a landmark pair's
midpoint, Plug-in Gait's elbow centre). Where the data are silent the priors hold it there;
where the motion places it, it moves. :func:`hinge_report` measures the move in a frame of
the parent segment's own markers, as the construction is built: origin the proximal joint
centre, x towards the lateral marker (KNE, ANK, ELB), z normal to the plane of it and a second
marker of the segment (THI, TIB, UPA). The centre's coordinates in that frame at the initial
and at the identified model differ by the move: a centre turned about the segment's long
axis with its flexion axis (the turn that puts a knee centre in front of KNE) counts, a turn
of the model's frame with the markers does not. Its standard deviation is that of the move's
length under the fit's covariance with its priors (the ``with priors`` figure of
segments.csv; the map linearised at the identified model), so ``moved_by_data`` (distance
above :data:`MOVED_SD` of them) says whether the move is more than the uncertainty of where
the centre is.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mocap_mj.anatomy.segments import _prior_weighted_tau
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import parameter_covariance
from mocap_mj.solve.lm import LMResult

#: Joint -> (its lateral marker and the parent segment's second marker, side prefix added;
#: the child body whose origin is the centre, the side appended).
HINGES = {"knee": ("KNE", "THI", "shank"), "ankle": ("ANK", "TIB", "foot"),
          "elbow": ("ELB", "UPA", "ulna")}  # fmt: skip
#: Step [m] of the central differences of the centre's coordinates in theta.
STEP = 1e-6
#: A centre moved by more than this many standard deviations was moved by the data.
MOVED_SD = 2.0


def _coordinates(
    pset: ParameterSet, theta: np.ndarray, markers: tuple[int, int], child: int
) -> np.ndarray:
    """The centre (``child``'s origin) in the frame of the parent's origin and ``markers``
    (lateral, second), (3,) [m] (module docstring)."""
    offsets = pset.split(theta)[1]
    lateral, second = offsets[markers[0]], offsets[markers[1]]
    x = lateral / np.linalg.norm(lateral)
    z = np.cross(lateral, second)
    z = z / np.linalg.norm(z)
    return np.stack([x, np.cross(z, x), z]) @ pset.body_pos(theta)[child]


def _jacobian(
    pset: ParameterSet, theta: np.ndarray, markers: tuple[int, int], child: int
) -> np.ndarray:
    """d coordinates / d theta (3, P) by central differences of :data:`STEP` (zero but for
    the kinematic parameters and the two markers' offsets)."""
    jac = np.zeros((3, pset.size))
    k = pset.n_kappa
    for i in [*range(k), *(k + 3 * m + c for m in markers for c in range(3))]:
        step = np.zeros(pset.size)
        step[i] = STEP
        jac[:, i] = (_coordinates(pset, theta + step, markers, child)
                     - _coordinates(pset, theta - step, markers, child)) / (2 * STEP)  # fmt: skip
    return jac


@dataclass(frozen=True)
class HingeCentre:
    """A constructed hinge centre against its construction (:func:`hinge_report`), in the
    frame of the parent segment's markers (module docstring).

    Attributes
    ----------
    construction : str
        The construction in words (summary.json ``init_centres``).
    constructed, identified : (3,) float [m]
        The centre at the initial and at the identified model.
    distance, distance_sd : float [m]
        The move's length and its standard deviation.
    moved_by_data : bool
        The distance is above :data:`MOVED_SD` standard deviations.
    """

    construction: str
    constructed: np.ndarray
    identified: np.ndarray
    distance: float
    distance_sd: float
    moved_by_data: bool


def hinge_report(
    pset: ParameterSet,
    result: LMResult,
    prior_information: np.ndarray,
    tau: float,
    sources: Mapping[str, str],
) -> dict[str, HingeCentre]:
    """Per constructed hinge centre (``sources``: joint -> its construction in words,
    summary.json ``init_centres``) whose two markers ``pset`` has, its move from the
    construction (:class:`HingeCentre`, at ``result.theta0`` and ``result.theta``), the
    standard deviation from ``result``'s covariance with ``prior_information`` (P, P)
    [1/m^2], the data's inflated by the residuals' correlation time ``tau`` [frames] as
    segments.csv's."""
    cov = parameter_covariance(
        result, tau=_prior_weighted_tau(result.sigma, tau), prior_information=prior_information
    )
    out: dict[str, HingeCentre] = {}
    for joint, source in sources.items():
        kind, side = joint[:-2], joint[-1]
        if kind not in HINGES:
            continue
        names = [side.upper() + m for m in HINGES[kind][:2]]
        if not all(n in pset.marker_names for n in names):
            continue
        markers = (pset.marker_index(names[0]), pset.marker_index(names[1]))
        body = pset.model.body(f"{HINGES[kind][2]}_{side}").id
        before = _coordinates(pset, result.theta0, markers, body)
        after = _coordinates(pset, result.theta, markers, body)
        move = after - before
        distance = float(np.linalg.norm(move))
        u = move / distance if distance > 0 else np.zeros(3)
        a = u @ _jacobian(pset, result.theta, markers, body)
        sd = float(np.sqrt(max(a @ cov @ a, 0.0)))
        out[joint] = HingeCentre(
            source, before, after, distance, sd, bool(distance > MOVED_SD * sd)
        )
    return out
