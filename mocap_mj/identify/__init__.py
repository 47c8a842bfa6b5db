"""Identification of theta (segment lengths and marker offsets) with the motion.

Layers (``docs/architecture.md``): :mod:`.problem` (the residual model: pooled trials, loss,
priors, bounds, Schur blocks), :mod:`.losses` and :mod:`.priors` (its pieces), the solvers
:mod:`.lm` (joint LM) and :mod:`.paper` (Algorithm 1 of Zou & Sugihara), which return one
:class:`IdentificationResult` (:mod:`.result`), and :mod:`.heuristics` (the LM's safeguards).
"""

from __future__ import annotations

from .lm import LMResult, LMSettings, Performance, Termination, Tolerances, identify_lm, solve_lm
from .losses import Loss, loss_named
from .priors import LinearGaussianPrior, Prior, weak_prior
from .problem import IdentificationProblem, TrialData, build_problem
from .result import IdentificationResult, IterationLog, ProgressCallback, Status

__all__ = [
    "IdentificationProblem",
    "IdentificationResult",
    "IterationLog",
    "LMResult",
    "LMSettings",
    "LinearGaussianPrior",
    "Loss",
    "Performance",
    "Prior",
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
