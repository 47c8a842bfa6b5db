"""What every identification solver returns: :class:`IdentificationResult` and its trace."""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal, NamedTuple, Protocol

import numpy as np

Method = Literal["lm", "paper"]


class Status(enum.Enum):
    """Why a solver stopped (the value is the message shown to users)."""

    NOISE = "cost change below tol_noise * sigma^2"
    STALL = "sqrt(F) changed by less than stall_rel over stall_window accepted steps"
    COST = "relative cost change below tol_cost"
    STEP = "step below tol_theta and tol_q"
    NO_DESCENT = "no descent direction found (damping exhausted)"
    MAX_ITERATIONS = "iteration limit reached"


class TraceEntry(Protocol):
    """One solver iteration as the reports and progress displays see it."""

    @property
    def iteration(self) -> int: ...  # 1-based
    @property
    def cost(self) -> float: ...  # the solver's objective [m^2]
    @property
    def rmse(self) -> float: ...  # marker RMSE [m]
    @property
    def theta(self) -> np.ndarray: ...  # (P,) [m] after the iteration


#: Called once per iteration with its trace entry (a progress display, a test's probe).
ProgressCallback = Callable[[TraceEntry], None]


class IterationLog(NamedTuple):
    """One joint-LM iteration: F, marker RMSE, damping, step and timing; theta (P,) [m] after."""

    iteration: int
    cost: float  # F [m^2]
    rmse: float  # marker RMSE [m]
    mu: float
    accepted: bool
    step_theta: float  # max |dtheta| [m]
    seconds: float  # this iteration's wall time [s]
    theta: np.ndarray
    frames: int = 0  # frames the iteration solved over (the coarse phase: its subset's)


@dataclass
class IdentificationResult:
    """Outcome of an identification solver (joint LM or Algorithm 1).

    Attributes
    ----------
    theta, theta0 : (P,) [m], the estimate and the initial (prior) model
    qpos : list of (T_i, nq) per trial; NaN rows for frames not used
    used : list of (T_i,) bool per trial: frames in the problem (enough markers)
    marker_rmse : float [m], over present samples of used frames (weights ignored)
    frame_rmse : list of (T_i,) [m]
    reduced_information : (P, P) [1], the Schur complement of the poses without damping and
        prior at the solution (free parameters only; rows/cols of frozen ones are zero)
    free : (P,) bool, the parameters identified
    sigma : float [m], per-axis noise estimated from the fit: RMSE / sqrt(3 (1 - p / n))
    n_residuals, n_unknowns : int
    iterations : int
    status : Status, why the solver stopped
    trace : list of the solver's per-iteration entries (:class:`TraceEntry`)
    seconds : float [s], init_seconds : float [s] (IK before the first iteration)
    weights : list of (T_i, M) [1], final IRLS weights per trial
    at_bound : (P,) bool, parameters that ended on a bound of the problem's box (within
        1e-12 relative)
    method : "lm" or "paper"
    """

    theta: np.ndarray
    theta0: np.ndarray
    qpos: list[np.ndarray]
    used: list[np.ndarray]
    marker_rmse: float
    frame_rmse: list[np.ndarray]
    reduced_information: np.ndarray
    free: np.ndarray
    sigma: float
    n_residuals: int
    n_unknowns: int
    iterations: int
    status: Status
    trace: Sequence[TraceEntry] = field(default_factory=list)
    seconds: float = 0.0
    init_seconds: float = 0.0
    weights: list[np.ndarray] = field(default_factory=list)
    at_bound: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    method: Method = "lm"

    @property
    def termination(self) -> Status:
        """Alias of :attr:`status` (the name the joint LM's result used)."""
        return self.status


__all__ = [
    "IdentificationResult",
    "IterationLog",
    "Method",
    "ProgressCallback",
    "Status",
    "TraceEntry",
]
