"""What an identification returns: :class:`Fit`, in memory and in SI units.

:func:`mocap_mj.pipeline.api.identify` computes it; :func:`mocap_mj.outputs.write_fit.write_result`
writes it as a result folder, and :meth:`Fit.summary` is the folder's ``summary.json``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.plausibility import kappa_outside_bounds
from mocap_mj.anatomy.segments import SegmentRow
from mocap_mj.anatomy.tissue import SlidingModel
from mocap_mj.capture.marker_quality import Finding
from mocap_mj.capture.subject import Subject
from mocap_mj.pipeline.motion import Motion
from mocap_mj.pipeline.recipe import Recipe
from mocap_mj.pipeline.report import Report
from mocap_mj.skeleton.joint_centres import joint_centre_trajectories
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.identifiability import Identifiability
from mocap_mj.solve.lm import LMSettings
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.solver_result import IdentificationResult


@dataclass(frozen=True, eq=False)
class Fit:
    """An identification: the subject's model, the motion of every frame, how well the data
    determine them and what the checks found.

    Attributes
    ----------
    pset : ParameterSet
        The parameters solved for (unmeasured ones frozen, the knee rolling scaled to the
        initial model): ``pset.names`` name theta's entries.
    recipe : Recipe
        The choices it was made with.
    settings : LMSettings
        The solver's settings (the recipe's choices, tolerances, performance).
    result : IdentificationResult
        The solve: theta (P,) [m], the fitted frames' poses, sigma [m], trace, status.
    identifiability : Identifiability
        Observable directions and Cramer-Rao standard deviations of theta.
    trials : tuple of TrialData
        The frames identified on (for a long recording: those selected).
    motion : tuple of Motion, or None
        Every frame's motion per trial: poses (T_i, nq), times (T_i,) [s], markers
        (T_i, M, 3) [m]; None when it was streamed to ``motion_files`` (a long recording
        identified with a motion sink, see :func:`~mocap_mj.pipeline.api.identify`).
    motion_files : tuple of Path
        The streamed motion files (motion*.npz, joint_centres*.csv), else empty.
    first_frames : tuple of int
        Each trial's first frame in its file (the frame column of joint_centres.csv).
    segments : tuple of SegmentRow
        The segment table (lengths and their standard deviations).
    sliding : SlidingModel or None
        The soft-tissue sliding model the fit was weighed with (recorded in model.xml).
    subject : Subject
        The measurements used, with the stature estimated when not measured.
    ranges : tuple of two (K,) arrays [m], or None
        The anatomical range of each kinematic parameter the fit was checked against (lower,
        upper); None: ``pset``'s bounds.
    report : Report
        What the fit reports beside the arrays above, typed and in SI: the marker-data
        quality, the checks, the wall times, the joint centres against their constructions.
    summary_fields : dict
        summary.json's content (:meth:`summary`): the report and the solver's, priors' and
        checks' figures in summary.json's units (mm, s; names ending ``_mm``); see
        docs/outputs.md. Written, not read: the library reads ``report``.
    """

    pset: ParameterSet
    recipe: Recipe
    settings: LMSettings
    result: IdentificationResult
    identifiability: Identifiability
    trials: tuple[TrialData, ...]
    motion: tuple[Motion, ...] | None
    first_frames: tuple[int, ...]
    segments: tuple[SegmentRow, ...]
    sliding: SlidingModel | None
    subject: Subject
    report: Report
    summary_fields: dict[str, Any]
    motion_files: tuple[Path, ...] = field(default=())
    ranges: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def theta(self) -> np.ndarray:
        """The identified parameters (P,) [m], named by ``pset.names``."""
        return self.result.theta

    @property
    def theta_std(self) -> np.ndarray:
        """Cramer-Rao standard deviation of each parameter (P,) [m]."""
        return np.asarray(self.identifiability.param_std)

    @property
    def sigma(self) -> float:
        """Per-axis marker noise estimated from the fit [m]."""
        return float(self.result.sigma)

    @property
    def marker_rmse(self) -> float:
        """Marker RMSE of the fitted frames [m]."""
        return float(self.result.marker_rmse)

    @property
    def findings(self) -> tuple[Finding, ...]:
        """The marker-data quality findings (the check before the fit and T10's placement)."""
        return self.report.quality.findings

    @property
    def timings(self) -> dict[str, float]:
        """Wall times [s] of the parts of the identification (those measured), by summary.json's
        names (:meth:`~mocap_mj.pipeline.report.Timings.as_dict`)."""
        return self.report.timings.as_dict()

    @property
    def implausible(self) -> tuple[str, ...]:
        """The reasons the tool's own checks call the result implausible (empty: plausible),
        one sentence each."""
        return self.report.checks.implausible

    def kappa_outside_bounds(self) -> dict[str, list[float]]:
        """The kinematic parameters that ended outside their anatomical range (``ranges``):
        ``{name: [value, lower, upper]}`` [m]."""
        lower, upper = self.ranges if self.ranges is not None else (None, None)
        return kappa_outside_bounds(self.pset, self.theta, lower, upper)

    def kappa(self) -> dict[str, float]:
        """The kinematic parameters by name [m]."""
        return {n: float(v) for n, v in zip(self.pset.kappa_names, self.theta, strict=False)}

    def joint_centres(self, trial: int = 0) -> np.ndarray:
        """World positions (T, J, 3) [m] of the joint centres
        (:data:`mocap_mj.skeleton.joint_centres.JOINT_CENTRE_NAMES`) in every frame of ``trial``'s
        motion (refused when the motion was streamed to files)."""
        if self.motion is None:
            raise ValueError("the motion was streamed to files: read joint_centres*.csv")
        model = self.pset.model_for(self.theta)
        return joint_centre_trajectories(model, self.motion[trial].qpos)

    def summary(self) -> dict[str, Any]:
        """summary.json's content (JSON values; millimetres and seconds as named)."""
        return dict(self.summary_fields)
