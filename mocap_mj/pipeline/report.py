"""What a fit reports beside its arrays, typed and in SI units: :class:`Report` and its
sections (the marker-data quality, the checks, the wall times, the joint centres against
their constructions). :mod:`mocap_mj.pipeline.summary` writes them into summary.json, in
millimetres; nothing in the library reads them back from there."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from mocap_mj.anatomy.ball_centres import BallCentre
from mocap_mj.anatomy.hinge_centres import HingeCentre
from mocap_mj.capture.marker_quality import Finding, suspects
from mocap_mj.pipeline.relabel import Relabel
from mocap_mj.pipeline.results import Refined


@dataclass(frozen=True)
class MarkerQuality:
    """The marker-data quality of a fit's or a trial's recordings.

    Attributes
    ----------
    relabelled : tuple of Relabel
        The corrections of the labels (``applied`` false where they were only reported).
    findings : tuple of Finding
        The check's findings (value [m]), T10's placement among them when it is misplaced.
    excluded : tuple of str
        The markers whose data were dropped before anything else.
    """

    relabelled: tuple[Relabel, ...] = ()
    findings: tuple[Finding, ...] = ()
    excluded: tuple[str, ...] = ()

    @property
    def suspects(self) -> dict[str, int]:
        """The markers the findings name, with how many name them, most named first."""
        return suspects(self.findings)

    @property
    def samples_dropped(self) -> int:
        """The samples the findings drop from the fit (ghosts, jumps), each counted once."""
        return len({(f.file, f.markers[0], t) for f in self.findings for t in f.samples})

    def with_finding(self, finding: Finding) -> MarkerQuality:
        """This quality with ``finding`` added."""
        return replace(self, findings=(*self.findings, finding))

    def of_file(self, path: str) -> tuple[Finding, ...]:
        """The findings of the file ``path``."""
        return tuple(f for f in self.findings if f.file == path)


@dataclass(frozen=True)
class Checks:
    """What the tool's own checks found of a fit.

    Attributes
    ----------
    marker_rmse_by_marker : dict of str to float [m]
        Each marker's RMSE over the fitted frames (NaN: never seen), in the model's order.
    worst_markers : dict of str to float [m]
        The markers fitting worst, worst first, with their RMSE.
    kappa_outside_bounds : dict of str to list of float [m]
        The kinematic parameters that ended outside their anatomical range:
        ``[value, lower, upper]``.
    kappa_at_bound : dict of str to str
        The kinematic parameters the solve left at a bound: ``lower`` or ``upper``.
    parameters_flagged : dict of str to str
        The kinematic parameters the segment table flags, with their flag (``at_lower``,
        ``below_range``, ...).
    implausible : tuple of str
        The reasons the checks call the result implausible, one sentence each (empty:
        plausible; the command then exits non-zero).
    """

    marker_rmse_by_marker: dict[str, float]
    worst_markers: dict[str, float]
    kappa_outside_bounds: dict[str, list[float]]
    kappa_at_bound: dict[str, str] = field(default_factory=dict)
    parameters_flagged: dict[str, str] = field(default_factory=dict)
    implausible: tuple[str, ...] = ()


@dataclass(frozen=True)
class Timings:
    """Wall times [s] of the parts of an identification (None: not run).

    ``seconds`` the solve, ``init_seconds`` its initial model, ``select_seconds`` the choice of
    a long recording's frames, ``motion_ik_seconds`` and ``motion_seconds`` the IK of every
    frame's motion and the whole of that motion's step."""

    seconds: float
    init_seconds: float | None = None
    select_seconds: float | None = None
    motion_ik_seconds: float | None = None
    motion_seconds: float | None = None

    def as_dict(self) -> dict[str, float]:
        """The measured times by summary.json's names (``seconds``, ``init_seconds``,
        ``select_seconds``, ``motion_ik_seconds``, ``motion_all_seconds``) [s]."""
        named = {
            "select_seconds": self.select_seconds,
            "seconds": self.seconds,
            "init_seconds": self.init_seconds,
            "motion_ik_seconds": self.motion_ik_seconds,
            "motion_all_seconds": self.motion_seconds,
        }
        return {k: float(v) for k, v in named.items() if v is not None}


@dataclass(frozen=True)
class Report:
    """Everything a fit reports beside its arrays, in SI units.

    Attributes
    ----------
    quality : MarkerQuality
        The marker-data quality of the recordings fitted.
    checks : Checks
        The checks of the result (marker fit, ranges, bounds, plausibility).
    timings : Timings
        The wall times of its parts.
    centres_vs_regression : dict of str to BallCentre
        Each regression-placed ball joint's identified centre against its regression
        (empty without the anatomical priors).
    centres_vs_construction : dict of str to HingeCentre
        Each hinge centre's identified position against Plug-in Gait's construction.
    refinement : Refined or None
        The refinement on every frame of a selected recording (None: not run).
    motion_marker_rmse : float or None
        The marker RMSE [m] of every frame's motion (None: the fitted frames are the motion).
    """

    quality: MarkerQuality
    checks: Checks
    timings: Timings
    centres_vs_regression: Mapping[str, BallCentre] = field(default_factory=dict)
    centres_vs_construction: Mapping[str, HingeCentre] = field(default_factory=dict)
    refinement: Refined | None = None
    motion_marker_rmse: float | None = None


__all__ = ["Checks", "MarkerQuality", "Report", "Timings"]
