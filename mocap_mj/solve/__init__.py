"""The identification problem (residuals, losses, priors, bounds) and its solvers: the joint
Levenberg-Marquardt, the per-frame IK, and what the data determine (identifiability, bounds).

Its face: :class:`IdentificationProblem` with its :class:`ProblemOptions` and
:class:`Bounds`, and :class:`TrialData` (:mod:`.problem`), the losses (:mod:`.losses`) and
priors (:mod:`.priors`) it sums, the joint LM (:func:`identify_lm` with
:class:`InitialPoses`, :func:`solve_lm`, :class:`LMSettings` with :class:`Tolerances` and
:class:`Performance`; :mod:`.lm`, :mod:`.settings`) and what a solver returns
(:class:`IdentificationResult`, :mod:`.solver_result`).
"""

from __future__ import annotations

from .lm import InitialPoses, LMResult, Termination, identify_lm, solve_lm
from .losses import Loss, loss_named
from .priors import LinearGaussianPrior, Prior, weak_prior
from .problem import Bounds, IdentificationProblem, ProblemOptions, TrialData, build_problem
from .settings import LMSettings, Performance, Tolerances
from .solver_result import IdentificationResult, IterationLog, ProgressCallback, Status

__all__ = [
    "Bounds",
    "IdentificationProblem",
    "IdentificationResult",
    "InitialPoses",
    "IterationLog",
    "LMResult",
    "LMSettings",
    "LinearGaussianPrior",
    "Loss",
    "Performance",
    "Prior",
    "ProblemOptions",
    "ProgressCallback",
    "Status",
    "Termination",
    "Tolerances",
    "TrialData",
    "build_problem",
    "identify_lm",
    "loss_named",
    "solve_lm",
    "weak_prior",
]
