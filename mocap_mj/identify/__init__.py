"""Identification of theta (segment lengths and marker offsets) with the motion.

The package is callable: ``mocap_mj.identify(trials, recipe, subject)`` is
:func:`mocap_mj.identify.api.identify`, the whole identification of ``mocap-mj identify`` in
memory, returning a :class:`~mocap_mj.identify.fit.Fit`
(:func:`~mocap_mj.identify.output.write_result` writes it as a result folder).

Layers (``docs/architecture.md``): :mod:`.problem` (the residual model: pooled trials, loss,
priors, bounds, Schur blocks), :mod:`.losses` and :mod:`.priors` (its pieces), the solvers
:mod:`.lm` (joint LM) and :mod:`.paper` (Algorithm 1 of Zou & Sugihara), which return one
:class:`IdentificationResult` (:mod:`.result`), and :mod:`.heuristics` (the LM's safeguards).
"""

from __future__ import annotations

import sys
import types
from typing import Any

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


class _Callable(types.ModuleType):
    """This package, callable as :func:`mocap_mj.identify.api.identify`."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        from .api import identify

        return identify(*args, **kwargs)


sys.modules[__name__].__class__ = _Callable
