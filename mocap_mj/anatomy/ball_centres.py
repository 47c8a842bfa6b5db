"""Ball-joint centres placed by a regression, and how far a trial's data may move them.

A hip centre's regression (Harrington et al. 2007, or Davis et al. 1991 for Plug-in Gait)
places it relative to the pelvis markers with an error of about 8 mm per axis
(:data:`~mocap_mj.anatomy.anatomy.SIGMA_HJC`); the data place it where the thigh turns
about it (a functional centre). Counted frame by frame, the data hold far more information
about the centre than they do: soft-tissue artefact that grows with the joint's angle
displaces the thigh markers by ``[w]x d``-like amounts, the signature of a centre moved by
``d`` (``w`` the joint's rotation), so it does not average out over frames or cycles. Its
effect on the centre is about ``sigma_sta / angle`` per direction, whatever the number of
frames: a walk turns the hip by a few degrees in abduction and rotation, so 5 mm of
artefact can move the lateral centre by several centimetres; a functional trial turning it
30 degrees every way, by about 10 mm (Camomilla et al. 2006 and Ehrig et al. 2006: the
functional centre's error grows as the range shrinks). The shoulders' centres are
convention rows (:data:`~mocap_mj.anatomy.anatomy.SIGMA_CONVENTION`), not regressions:
they already outweigh the data and get no floor.

So each regression row of a ball-joint centre (a row whose label names a regression of
:data:`REGRESSION_TAGS` and whose kinematic terms move one ball joint's child body along one
axis ``u`` of the parent frame) is weighed against the data honestly counted: the data's
variance of the row, ``var_n = a^T H^-1 a`` (``H`` the reduced information over the
effective noise plus every other prior), plus the artefact's floor
``var_f = sigma_sta^2 u^T K^-1 u``, ``K = mean_t (|w_t|^2 I - w_t w_t^T)`` [rad^2] over the
joint's rotations ``w_t`` about their mean (parent frame). The solve, which counts the data
as ``1 / var_n``, keeps the weighted mean of data and regression that ``1 / (var_n +
var_f)`` gives when the row's width is multiplied by ``sqrt(var_n / (var_n + var_f))``
(:func:`centre_widths`; never below :data:`WIDTH_FLOOR`). White noise (no artefact) leaves
every width as it is. :func:`centre_report` states per joint the regression centre, the
identified one, their distance and its standard deviation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.priors import LinearGaussianPrior

#: Row labels of the regressions that place a ball joint's centre (:mod:`.anatomy`, :mod:`.hips`).
REGRESSION_TAGS = ("(Harrington 2007)", "(Davis 1991)")
#: Narrowest width factor of a centre row: the data then weigh less than 1e-4 of the row,
#: numerically as if left out, and the solve stays well conditioned.
WIDTH_FLOOR = 0.01
#: Rotation spread [rad^2] added to K's diagonal: a joint that does not turn gives its
#: centre a finite (metres-wide) floor rather than a singular K.
SPREAD_EPS = 1e-6


@dataclass(frozen=True)
class CentreRow:
    """One regression row of a ball joint's centre.

    Attributes
    ----------
    joint, body : str, the ball joint and its child body (e.g. "hip_l", "thigh_l")
    row : int, the row's index in the prior
    label : str, the row's label
    axis : (3,) [1], the row's direction in the parent body's frame: the centre moves by
        ``axis`` per metre of the row's value ``a . theta``
    """

    joint: str
    body: str
    row: int
    label: str
    axis: np.ndarray


def centre_rows(pset: ParameterSet, prior: LinearGaussianPrior) -> list[CentreRow]:
    """The rows of ``prior`` that place a ball joint's centre by a regression (module
    docstring): labelled with a :data:`REGRESSION_TAGS` entry, kinematic terms moving one
    body attached to its parent by a ball joint."""
    model, k = pset.model, pset.n_kappa
    balls = {int(model.jnt_bodyid[j]): j for j in range(model.njnt)
             if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL}  # fmt: skip
    out = []
    for r, label in enumerate(prior.labels):
        if not any(tag in label for tag in REGRESSION_TAGS):
            continue
        moved = np.einsum("k,kbi->bi", np.asarray(prior.a)[r, :k], pset.direction)
        bodies = np.flatnonzero(np.linalg.norm(moved, axis=1) > 1e-12)
        if len(bodies) != 1 or int(bodies[0]) not in balls:
            continue
        b = int(bodies[0])
        out.append(CentreRow(model.joint(balls[b]).name, model.body(b).name, r, label,
                             moved[b] / np.linalg.norm(moved[b]) ** 2))  # fmt: skip
    return out


def rotation_spread(pset: ParameterSet, qpos: Sequence[np.ndarray], joint: str) -> np.ndarray:
    """K (3, 3) [rad^2]: ``mean_t (|w_t|^2 I - w_t w_t^T)`` over the frames of every trial
    in ``qpos`` ((T_i, nq) each; NaN rows skipped), ``w_t`` the rotation vector of the ball
    ``joint``'s rotation against its mean rotation, in the parent frame. A centre moved by
    ``d`` moves the child's markers by ``-w_t x d`` (the mean absorbed by their offsets), of
    mean square ``d^T K d``."""
    adr = int(pset.model.jnt_qposadr[pset.model.joint(joint).id])
    q = np.concatenate([np.asarray(x)[:, adr : adr + 4] for x in qpos])
    q = q[np.all(np.isfinite(q), axis=1)]
    if len(q) < 2:
        return np.full((3, 3), 0.0) + SPREAD_EPS * np.eye(3)
    rot = Rotation.from_quat(q[:, [1, 2, 3, 0]])
    w = (rot * rot.mean().inv()).as_rotvec()  # R_t R_mean^T: parent frame
    k = np.mean(np.sum(w**2, axis=1)) * np.eye(3) - (w.T @ w) / len(w)
    return np.asarray(k + SPREAD_EPS * np.eye(3))


@dataclass(frozen=True)
class RowSpread:
    """What the data say of one centre row: ``data_m`` the standard deviation [m] of the
    row's value from the data counted as the solve counts them, ``floor_m`` the artefact's
    floor [m] (0 on white noise), ``prior_m`` the regression's own width [m]."""

    data_m: float
    floor_m: float
    prior_m: float

    @property
    def factor(self) -> float:
        """The width factor :func:`centre_widths` applies: sqrt(data^2 / (data^2 + floor^2))."""
        total = self.data_m**2 + self.floor_m**2
        return max(WIDTH_FLOOR, float(np.sqrt(self.data_m**2 / total))) if total > 0 else 1.0

    @property
    def posterior_m(self) -> float:
        """Standard deviation [m] of the centre along the row: the regression and the data
        honestly counted, ``(1 / prior^2 + 1 / (data^2 + floor^2))^-1/2``."""
        return float((1.0 / self.prior_m**2 + 1.0 / (self.data_m**2 + self.floor_m**2)) ** -0.5)


def row_spreads(
    pset: ParameterSet,
    information: np.ndarray,
    free: np.ndarray,
    qpos: Sequence[np.ndarray],
    landmark: LinearGaussianPrior,
    others: Sequence[LinearGaussianPrior],
    noise: float,
    sta_sigma: float,
) -> dict[str, RowSpread]:
    """Per centre row of ``landmark`` (:func:`centre_rows`): its :class:`RowSpread` by
    label. ``information`` (P, P) [1] the reduced information of unit weights, ``free``
    (P,) bool the parameters solved for, ``qpos`` the fitted poses per trial, ``others``
    the solve's other priors (each row weighing ``(p.noise / sigma)^2`` against a marker
    coordinate, as in the solve), ``noise`` [m] the per-axis noise of one independent
    observation, ``sta_sigma`` [m] the per-axis soft-tissue artefact (0: white noise)."""
    rows = centre_rows(pset, landmark)
    if not rows:
        return {}
    f = np.asarray(free, dtype=bool)
    h = np.array(np.asarray(information)[np.ix_(f, f)], dtype=float)
    for p in (landmark, *others):
        keep = np.ones(len(p.b), dtype=bool)
        if p is landmark:
            keep[[c.row for c in rows]] = False
        a = np.asarray(p.a)[keep][:, f]
        h += (a.T * (p.noise / np.asarray(p.sigma)[keep]) ** 2) @ a
    cov = noise**2 * np.linalg.pinv(h, hermitian=True)
    spread = {j: rotation_spread(pset, qpos, j) for j in {c.joint for c in rows}}
    spreads = {}
    for c in rows:
        a = np.asarray(landmark.a)[c.row, f]
        u = c.axis / np.linalg.norm(c.axis)
        floor2 = sta_sigma**2 * float(u @ np.linalg.solve(spread[c.joint], u))
        data = float(np.sqrt(max(a @ cov @ a, 0.0)))
        spreads[c.label] = RowSpread(data, float(np.sqrt(floor2)), float(landmark.sigma[c.row]))
    return spreads


def centre_widths(prior: LinearGaussianPrior, factors: Mapping[str, float]) -> LinearGaussianPrior:
    """``prior`` with the widths of the rows named in ``factors`` (label -> factor) multiplied
    by their factor (:attr:`RowSpread.factor`); other rows unchanged."""
    if not factors:
        return prior
    scale = np.array([factors.get(lab, 1.0) for lab in prior.labels])
    return replace(prior, sigma=np.asarray(prior.sigma) * scale)


@dataclass(frozen=True)
class CentreRowReport:
    """One regression row of a ball joint's centre at the identified model: ``distance``
    [m] its value's distance from the regression, ``regression_sd`` [m] the regression's
    width, ``spread`` what the data say of it (None: the row was not weighed against them)."""

    distance: float
    regression_sd: float
    spread: RowSpread | None


@dataclass(frozen=True)
class BallCentre:
    """A regression-placed ball joint's centre against its regression
    (:func:`centre_report`), in the parent body's frame.

    Attributes
    ----------
    body : str
        The child body whose origin is the centre.
    identified : (3,) float [m]
        The identified centre.
    regression : str
        The regression's name (e.g. ``Harrington 2007``).
    regression_centre : (3,) float [m]
        The regression's centre.
    distance, distance_sd : float [m]
        Their distance and its standard deviation.
    moved_by_data : bool
        The distance is above twice its standard deviation.
    rows : dict of str to CentreRowReport
        Each regression row by its label.
    others : dict of str to (3,) float [m] or None
        Another regression's name -> its centre (None: its rows cannot be built).
    """

    body: str
    identified: np.ndarray
    regression: str
    regression_centre: np.ndarray
    distance: float
    distance_sd: float
    moved_by_data: bool
    rows: dict[str, CentreRowReport]
    others: dict[str, np.ndarray | None]


def centre_report(
    pset: ParameterSet,
    theta: np.ndarray,
    prior: LinearGaussianPrior,
    spreads: Mapping[str, RowSpread],
    others: Mapping[str, LinearGaussianPrior | None] | None = None,
) -> dict[str, BallCentre]:
    """Per ball joint with regression rows in ``prior`` (the landmark prior of the solve, its
    original widths; ``theta`` (P,) [m]): the identified centre against its regression
    (:class:`BallCentre`; the distance's standard deviation from :attr:`RowSpread.posterior_m`
    per row, combined along the displacement). ``others``: name -> a prior of another
    regression's rows (e.g. Davis's beside Harrington's), its centre also given."""
    body_pos = pset.body_pos(theta)
    out: dict[str, BallCentre] = {}
    for joint, rows in _by_joint(centre_rows(pset, prior)).items():
        centre = body_pos[pset.model.body(rows[0].body).id]
        d = np.array([prior.a[c.row] @ theta - prior.b[c.row] for c in rows])
        regression = centre - sum((di * c.axis for di, c in zip(d, rows, strict=True)),
                                  np.zeros(3))  # fmt: skip
        sds = np.array([spreads[c.label].posterior_m if c.label in spreads
                        else prior.sigma[c.row] for c in rows])  # fmt: skip
        dist = float(np.linalg.norm(d))
        sd = float(np.sqrt(np.sum((d / dist) ** 2 * sds**2))) if dist > 0 else float(sds.max())
        alt: dict[str, np.ndarray | None] = {}
        for name, other in (others or {}).items():
            o = [] if other is None else [c for c in centre_rows(pset, other) if c.joint == joint]
            shift = sum((float(other.a[c.row] @ theta - other.b[c.row]) * c.axis for c in o),  # type: ignore[union-attr]
                        np.zeros(3))  # fmt: skip
            alt[name] = centre - shift if o else None
        out[joint] = BallCentre(
            body=rows[0].body, identified=centre, regression=_regression_name(rows[0].label),
            regression_centre=regression, distance=dist, distance_sd=sd,
            moved_by_data=bool(dist > 2 * sd),
            rows={c.label: CentreRowReport(float(di), float(prior.sigma[c.row]),
                                           spreads.get(c.label))
                  for c, di in zip(rows, d, strict=True)}, others=alt,
        )  # fmt: skip
    return out


def _by_joint(rows: Sequence[CentreRow]) -> dict[str, list[CentreRow]]:
    out: dict[str, list[CentreRow]] = {}
    for c in rows:
        out.setdefault(c.joint, []).append(c)
    return out


def _regression_name(label: str) -> str:
    return next((t.strip("()") for t in REGRESSION_TAGS if t in label), label)


__all__ = [
    "BallCentre",
    "CentreRow",
    "CentreRowReport",
    "RowSpread",
    "centre_report",
    "centre_rows",
    "centre_widths",
    "rotation_spread",
    "row_spreads",
]
