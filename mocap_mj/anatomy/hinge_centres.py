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
from typing import Any

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


def hinge_report(
    pset: ParameterSet,
    result: LMResult,
    prior_information: np.ndarray,
    tau: float,
    sources: Mapping[str, str],
) -> dict[str, dict[str, Any]]:
    """summary.json's ``joint_centres_vs_construction``: per constructed hinge centre
    (``sources``: joint -> its construction in words, summary.json ``init_centres``) whose
    two markers ``pset`` has, ``construction`` (the words), ``construction_mm`` and
    ``identified_mm`` (x y z in the markers' frame, module docstring, at ``result.theta0``
    and ``result.theta``), ``distance_mm``, ``distance_sd_mm`` (``result``'s covariance
    with ``prior_information`` (P, P) [1/m^2], the data's inflated by the residuals'
    correlation time ``tau`` [frames] as segments.csv's), ``moved_by_data``."""
    cov = parameter_covariance(
        result, tau=_prior_weighted_tau(result.sigma, tau), prior_information=prior_information
    )
    out: dict[str, dict[str, Any]] = {}
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
        out[joint] = {
            "construction": source,
            "construction_mm": (before * 1e3).tolist(),
            "identified_mm": (after * 1e3).tolist(),
            "distance_mm": distance * 1e3,
            "distance_sd_mm": float(np.sqrt(max(a @ cov @ a, 0.0))) * 1e3,
        }
        out[joint]["moved_by_data"] = bool(
            out[joint]["distance_mm"] > MOVED_SD * out[joint]["distance_sd_mm"]
        )
    return out


def hinge_lines(centres: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """report.md's table of :func:`hinge_report` (empty without entries)."""
    if not centres:
        return []
    lines = ["", "Hinge centres against their construction (x towards the lateral marker, z normal "
             "to it and the segment's second marker, mm; "
             "docs/model.md#the-constructions-start-and-prior):", "",
             "| joint | construction | constructed | identified | distance (mm) | sd (mm) "
             "| moved by the data |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for joint, c in centres.items():
        xyz = [" ".join(f"{v:.1f}" for v in c[k]) for k in ("construction_mm", "identified_mm")]
        lines.append(f"| {joint} | {c['construction']} | {xyz[0]} | {xyz[1]} | "
                     f"{c['distance_mm']:.1f} | {c['distance_sd_mm']:.1f} | "
                     f"{'yes' if c['moved_by_data'] else 'no'} |")  # fmt: skip
    return lines
