"""What the data can and cannot tell: observable subspace, Cramer-Rao bound, null directions.

The Fisher information of theta, with every frame's pose a nuisance parameter, is the reduced
(Schur-complement) information ``S / sigma^2`` (see :mod:`mocap_mj.solve.lm`). With the
eigen-decomposition ``S = V diag(lambda) V^T``, direction ``v_i`` of theta is determined to a
standard deviation ``sigma / sqrt(lambda_i)``:

- *observable*: at most ``observable_std`` (default 5 mm);
- *weakly observable*: up to ``weak_std`` (default 50 mm, the prior's width: the estimate there
  is a compromise between data and prior);
- *unobservable*: beyond (exact null directions have lambda = 0).

The Cramer-Rao lower bound on the observable subspace is ``sigma^2 V_o diag(1/lambda_o) V_o^T``;
errors are compared with it after projection onto that subspace (``project``), and the parts
in the other directions are reported separately.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from mocap_mj.capture.marker_set import marked_bodies
from mocap_mj.kernels._threads import one_blas_thread
from mocap_mj.skeleton.parameters import ParameterSet

from ..errors import InputFileError, check_shape, excerpt

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Direction:
    """A weakly or un-observable direction of theta.

    Attributes
    ----------
    std : float [m], sigma / sqrt(lambda) (inf for an exact null direction)
    kind : "weak" or "unobservable"
    description : str, in words
    components : list of (name, weight): the largest parts, weights sum of squares <= 1
    vector : (P,) unit vector
    """

    std: float
    kind: str
    description: str
    components: list[tuple[str, float]]
    vector: np.ndarray


class Identifiability:
    """Eigen-analysis of the reduced information of theta.

    Parameters
    ----------
    pset : ParameterSet
    information : (P, P) reduced information S (unit weights; frozen rows/cols zero)
    sigma : float [m], per-axis marker noise
    observable_std, weak_std : float [m]
    """

    def __init__(
        self,
        pset: ParameterSet,
        information: np.ndarray,
        sigma: float,
        *,
        observable_std: float = 0.005,
        weak_std: float = 0.05,
        theta: np.ndarray | None = None,
    ) -> None:
        check_shape("information", information, (pset.size, pset.size))
        self.pset = pset
        self.sigma = float(sigma)
        self.observable_std = observable_std
        self.weak_std = weak_std
        self.theta = pset.nominal if theta is None else pset.check(theta)
        sym = 0.5 * (information + information.T)
        if not np.all(np.isfinite(sym)):
            # A fit that overflowed informs nothing: every direction is reported unobservable
            # (and the fit's own checks call it implausible) rather than failing to report.
            _log.warning("the reduced information is not finite: no direction is observable")
            sym = np.zeros_like(sym)
        with one_blas_thread():
            lam, vec = np.linalg.eigh(sym)
        self.eigenvalues = lam
        self.eigenvectors = vec
        with np.errstate(divide="ignore"):
            self.direction_std = np.where(lam > 0, self.sigma / np.sqrt(np.abs(lam)), np.inf)
        self.observable = self.direction_std <= observable_std
        vo = vec[:, self.observable]
        self.basis = vo  # (P, r)
        self.crlb = (vo / lam[self.observable]) @ vo.T * self.sigma**2  # (P, P) [m^2]
        self.param_std = np.sqrt(np.maximum(np.diag(self.crlb), 0.0))  # (P,) [m]

    @property
    def rank(self) -> int:
        return int(self.observable.sum())

    def project(self, error: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Split a theta error (P,) [m] into its observable part and the rest."""
        e = np.asarray(error, dtype=float)
        check_shape("error", e, (self.pset.size,))
        eo = self.basis @ (self.basis.T @ e)
        return eo, e - eo

    def bound_rms(self) -> tuple[float, float]:
        """RMS over parameters of the CRLB standard deviations: (kappa, offsets) [m]."""
        k = self.pset.n_kappa
        d = np.diag(self.crlb)
        return float(np.sqrt(np.mean(d[:k]))), float(np.sqrt(np.mean(d[k:])))

    def bound_rms_with_prior(self, prior_information: np.ndarray) -> tuple[float, float]:
        """(kappa, offsets) [m]: RMS CRLB standard deviations on the observable subspace when
        a Gaussian prior adds ``prior_information`` (P, P) [1/m^2] to the data's ``S /
        sigma^2`` (the Bayesian bound: a prior centred on the truth's distribution informs
        directions the data leave loose, and an estimator using it can beat
        :meth:`bound_rms`). The prior must make the total information invertible (the LM's
        weak prior toward the initial model does).
        """
        check_shape("prior_information", prior_information, (self.pset.size, self.pset.size))
        total = self._info() / self.sigma**2 + prior_information
        with one_blas_thread():
            cov = self.basis.T @ np.linalg.solve(total, self.basis)
        d = np.einsum("pi,ij,pj->p", self.basis, cov, self.basis)
        k = self.pset.n_kappa
        return float(np.sqrt(np.mean(d[:k]))), float(np.sqrt(np.mean(d[k:])))

    # ------------------------------------------------------------- in words
    def directions(self) -> list[Direction]:
        """Weak and unobservable directions, least determined first.

        Eigenvectors of (nearly) equal eigenvalues are an arbitrary basis of their subspace, so
        each group (unobservable, weak) is rotated to simple structure (varimax) first: every
        reported direction then involves as few parameters as possible.
        """
        out = []
        for kind in ("unobservable", "weak"):
            if kind == "unobservable":
                sel = self.direction_std > self.weak_std
            else:
                sel = ~self.observable & (self.direction_std <= self.weak_std)
            if not np.any(sel):
                continue
            basis = _varimax(self.eigenvectors[:, sel])
            info = self._info()
            for v in basis.T:
                lam = float(v @ info @ v)
                std = self.sigma / np.sqrt(lam) if lam > 0 else float("inf")
                comps = _components(self.pset, v)
                desc = _describe(self.pset, self.theta, v, comps)
                out.append(Direction(float(std), kind, desc, comps, v))
        return sorted(out, key=lambda d: -d.std)

    def to_json(self) -> dict[str, Any]:
        k = self.pset.n_kappa
        bk, bo = self.bound_rms()
        return {
            "units": "m",
            "sigma_m": self.sigma,
            "observable_std_m": self.observable_std,
            "weak_std_m": self.weak_std,
            "parameters": self.pset.size,
            "observable_directions": self.rank,
            "kappa_crlb_rms_m": bk,
            "offset_crlb_rms_m": bo,
            "parameter_std_m": {
                n: float(s) for n, s in zip(self.pset.names, self.param_std, strict=True)
            },
            "kappa_std_m": dict(
                zip(self.pset.names[:k], map(float, self.param_std[:k]), strict=True)
            ),
            "directions": [
                {
                    "kind": d.kind,
                    "std_m": d.std if np.isfinite(d.std) else None,
                    "description": d.description,
                    "components": [[n, w] for n, w in d.components],
                }
                for d in self.directions()
            ],
            "eigenvalues": [float(x) for x in self.eigenvalues],
            "information": [[float(x) for x in row] for row in self._info()],
        }

    def _info(self) -> np.ndarray:
        v, lam = self.eigenvectors, self.eigenvalues
        return (v * lam) @ v.T

    @classmethod
    def from_json(
        cls, pset: ParameterSet, data: dict[str, Any], source: str = "identifiability"
    ) -> Identifiability:
        """The identifiability ``identifiability.json`` holds (:meth:`to_json`), each field
        checked: ``information`` (P, P) finite numbers, ``sigma_m``, ``observable_std_m`` and
        ``weak_std_m`` [m] numbers within 0..10 m (0 excluded);
        :class:`~mocap_mj.errors.InputFileError` naming ``source`` and the field otherwise."""
        widths = {}
        for key in ("sigma_m", "observable_std_m", "weak_std_m"):
            value = data.get(key)
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= 10:
                raise InputFileError(
                    f"{source}: {key}: expected a width in m within 0..10, got {excerpt(value)}"
                )
            widths[key] = float(value)
        raw = data.get("information")
        try:
            info = np.array(raw, dtype=float)
        except (TypeError, ValueError):
            info = np.zeros(0)
        if info.shape != (pset.size, pset.size) or not np.all(np.isfinite(info)):
            raise InputFileError(
                f"{source}: information: expected ({pset.size}, {pset.size}) finite numbers, "
                f"got {excerpt(raw) if info.size == 0 else f'shape {info.shape}'}"
            )
        return cls(
            pset,
            info,
            widths["sigma_m"],
            observable_std=widths["observable_std_m"],
            weak_std=widths["weak_std_m"],
        )

    def report_lines(self) -> list[str]:
        """A readable section for ``report.md``."""
        bk, bo = self.bound_rms()
        lines = [
            "## Identifiability",
            "",
            f"Noise sigma (per axis, from the fit): {self.sigma * 1e3:.3f} mm. "
            f"{self.rank} of {self.pset.size} directions of theta are observable "
            f"(standard deviation <= {self.observable_std * 1e3:.0f} mm); the Cramer-Rao "
            f"bound there is {bk * 1e3:.3f} mm RMS for the kinematic parameters and "
            f"{bo * 1e3:.3f} mm RMS for the marker offsets.",
            "",
            "| direction | std (mm) | in words |",
            "|---|---|---|",
        ]
        held, listed = self.pset.frozen, 0
        for d in self.directions():
            if float(np.sum(d.vector[~held] ** 2)) < 0.5:  # a parameter not measured
                continue
            listed += 1
            std = "inf" if not np.isfinite(d.std) or d.std > 1e3 else f"{d.std * 1e3:.1f}"
            lines.append(f"| {d.kind} | {std} | {d.description} |")
        if held.any():
            lines += [
                "",
                f"The {int(held.sum())} parameters not measured (no marker of the recording moves "
                "them; summary.json's `parameters_not_measured`) are held at the prior and not "
                "listed.",
            ]
        lines += [
            "",
            "Weak and unobservable directions are held near the initial model by a weak prior "
            f"({self.weak_std * 1e3:.0f} mm for a 1 mm noise: the `std white` of segments.csv "
            "for a parameter the markers do not determine) and excluded from the headline errors.",
            "",
        ]
        return lines

    def undetermined(self) -> np.ndarray:
        """(P,) bool: the parameters mostly (over half their unit vector's square) in the
        unobservable directions (std above ``weak_std``): the data alone do not place them."""
        sel = self.direction_std > self.weak_std
        return np.asarray(np.sum(self.eigenvectors[:, sel] ** 2, axis=1) > 0.5)


def _varimax(basis: np.ndarray, iterations: int = 100, tol: float = 1e-8) -> np.ndarray:
    """Orthogonal rotation of the columns of basis (P, r) to simple structure (Kaiser 1958)."""
    p, r = basis.shape
    if r < 2 or not np.all(np.isfinite(basis)):
        return basis
    rot = np.eye(r)
    last = 0.0
    for _ in range(iterations):
        lam = basis @ rot
        try:
            u, s, vt = np.linalg.svd(basis.T @ (lam**3 - lam @ np.diag(np.sum(lam**2, axis=0)) / p))
        except np.linalg.LinAlgError:  # the rotation so far: still an orthonormal basis
            break
        rot = u @ vt
        if s.sum() < last * (1 + tol):
            break
        last = s.sum()
    return basis @ rot


def _components(pset: ParameterSet, v: np.ndarray, share: float = 0.9) -> list[tuple[str, float]]:
    """Largest parts of v grouped by kinematic parameter or marker offset (weights: |v|^2)."""
    k = pset.n_kappa
    groups: dict[str, float] = {}
    for i in range(k):
        groups[pset.names[i]] = float(v[i] ** 2)
    off = v[k:].reshape(-1, 3)
    for m, name in enumerate(pset.marker_names):
        groups[f"{name} offset"] = float(off[m] @ off[m])
    out, total = [], 0.0
    for name, w in sorted(groups.items(), key=lambda kv: -kv[1]):
        if total >= share or w < 1e-4:
            break
        out.append((name, round(w, 4)))
        total += w
    return out


def _moves_a_marker(pset: ParameterSet, name: str) -> bool:
    """Whether kinematic parameter ``name`` moves a body that some marker follows
    (:func:`mocap_mj.capture.marker_set.marked_bodies`)."""
    moved = np.any(pset.direction[pset.index(name)] != 0.0, axis=1)
    return bool(np.any(moved & marked_bodies(pset.model)))


def _describe(
    pset: ParameterSet, theta: np.ndarray, v: np.ndarray, comps: list[tuple[str, float]]
) -> str:
    """Words for a direction: a lone marker turning about its joint axes, or its parts."""
    model = pset.model
    k = pset.n_kappa
    off = v[k:].reshape(-1, 3)
    _, offsets = pset.split(theta)
    top_name, top_w = comps[0]
    if top_name in pset.kappa_names and top_w > 0.8 and not _moves_a_marker(pset, top_name):
        return f"{top_name}: moves no marker (its prior rows alone decide it)"
    if top_name.endswith(" offset") and top_w > 0.8:
        marker = top_name.removesuffix(" offset")
        s = pset.marker_index(marker)
        body = int(model.site_bodyid[s])
        axes = []
        for j in range(model.njnt):
            if model.jnt_bodyid[j] != body or model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                continue
            u = np.cross(model.jnt_axis[j], offsets[s] - model.jnt_pos[j])
            if np.linalg.norm(u) > 1e-9:
                axes.append((model.joint(j).name, u / np.linalg.norm(u)))
        if axes:
            basis, _ = np.linalg.qr(np.array([a for _, a in axes]).T)
            vm = off[s] / np.linalg.norm(off[s])
            if np.linalg.norm(basis.T @ vm) > 0.9:
                names = "/".join(n for n, _ in axes)
                return f"{marker} offset: rotation about the {names} axis (absorbed by the angle)"
        return f"{marker} offset alone"
    # Several markers of one body turning together about one of its joints.
    body_of = {n: int(model.site_bodyid[pset.marker_index(n)]) for n in pset.marker_names}
    marker_w: dict[int, float] = {}
    for n, w in comps:
        if n.endswith(" offset"):
            b = body_of[n.removesuffix(" offset")]
            marker_w[b] = marker_w.get(b, 0.0) + w
    if marker_w:
        body, w = max(marker_w.items(), key=lambda kv: kv[1])
        if w > 0.8:
            idx = [i for i, n in enumerate(pset.marker_names) if body_of[n] == body]
            joints = [j for j in range(model.njnt) if model.jnt_bodyid[j] == body]
            names = "/".join(model.joint(j).name for j in joints) or "parent"
            # Fit v_m = omega x (o_m - c): a rigid rotation of the markers about the joint.
            centre = model.jnt_pos[joints[0]] if joints else np.zeros(3)
            rows = []
            for i in idx:
                rvec = offsets[i] - centre
                rows.append(-np.array([[0, -rvec[2], rvec[1]], [rvec[2], 0, -rvec[0]],
                                       [-rvec[1], rvec[0], 0]]))  # fmt: skip
            lhs = np.concatenate(rows)
            rhs = off[idx].ravel()
            omega = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
            fit = float(np.linalg.norm(lhs @ omega - rhs)) / max(float(np.linalg.norm(rhs)), 1e-12)
            bname = model.body(body).name
            members = ", ".join(pset.marker_names[i] for i in idx)
            if fit < 0.1:
                return f"{bname} markers ({members}): rotation about the {names} joint"
            return f"{bname} markers ({members}) together"
    slide = _along_knee_axis(comps)
    if slide:
        return slide
    pelvis = {"LASI", "RASI", "LPSI", "RPSI"}
    pel_w = sum(w for n, w in comps if n.removesuffix(" offset") in pelvis)
    if pel_w > 0.3:
        return "pelvis frame vs its markers (absorbed by the free joint): " + ", ".join(
            f"{n} {w:.0%}" for n, w in comps[:5]
        )
    return "combination: " + ", ".join(f"{n} {w:.0%}" for n, w in comps[:5])


#: Alignment parameter (side removed) -> what sliding it along the knee axis is, in words.
_ALONG_AXIS = {
    "knee_lateral": "the knee centre and the shank below it sliding along the knee axis",
    "ankle_lateral": "the ankle centre and the foot sliding along the knee and ankle axes",
}


def _along_knee_axis(comps: list[tuple[str, float]]) -> str:
    """Words for a direction led by a frontal-plane alignment parameter, else "".

    A body origin sliding along its hinge axis, with its markers sliding back, leaves the
    markers unchanged while the axial rotation below it (tibial rotation, subtalar) is
    still: the data see the alignment only through those rotations, and the KNE or ANK
    width row (the joint centre half a width medial of its marker) decides the rest.
    """
    for name, w in comps:
        base = name[:-2] if name.endswith(("_l", "_r")) else name
        if base in _ALONG_AXIS and w >= 0.2:
            parts = ", ".join(f"{n} {x:.0%}" for n, x in comps[:4])
            return (
                f"{name}: {_ALONG_AXIS[base]} (seen through tibial/subtalar rotation only; "
                f"its marker's width row decides it): {parts}"
            )
        if not name.endswith(" offset"):  # a larger kinematic part leads: not this case
            break
    return ""
