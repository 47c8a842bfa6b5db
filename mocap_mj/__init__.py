"""mocap-mj: subject-specific human models from optical motion capture, on MuJoCo.

Symbols used in every docstring: T frames, M markers (39 for the bundled humanoid), nq and nv
the model's position and velocity sizes (55 and 48; a written model.xml has 59 and 52 in
plain MuJoCo, the knees' slide joints included: ``mocap_mj.exported``), K = 34 kinematic
parameters, P = K + 3 M = 151 model parameters. Units are SI everywhere inside: metres,
radians, seconds; conversion happens only at the file boundary (``mocap_mj.io``).
"""

from __future__ import annotations

import importlib
from typing import Any

from .errors import (
    InputFileError,
    MocapError,
    ShapeError,
    SolverError,
    UnknownNameError,
)
from .kinematics import Frames, Kinematics
from .markers import MARKER_NAMES
from .model import load_model, model_path
from .parameters import KINEMATIC_PARAMETERS, KinematicParameter, ParameterSet

__version__ = "0.1.0"

#: The identification API, imported on first use (``import mocap_mj`` stays light):
#: ``mocap_mj.identify(trials, recipe, subject) -> Fit`` (the package :mod:`mocap_mj.identify`
#: is callable), ``write_result(fit, folder)``, ``solve_motion(model, trial) -> Motion``.
_LAZY = {
    "Fit": "mocap_mj.identify.fit",
    "Motion": "mocap_mj.results",
    "Recipe": "mocap_mj.identify.recipe",
    "TrialData": "mocap_mj.identify.problem",
    "solve_motion": "mocap_mj.identify.robust_ik",
    "write_result": "mocap_mj.identify.output",
}


def __getattr__(name: str) -> Any:
    if name == "identify":
        return importlib.import_module("mocap_mj.identify")
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'mocap_mj' has no attribute {name!r}")


__all__ = [
    "KINEMATIC_PARAMETERS",
    "MARKER_NAMES",
    "Fit",
    "Frames",
    "InputFileError",
    "KinematicParameter",
    "Kinematics",
    "MocapError",
    "Motion",
    "ParameterSet",
    "Recipe",
    "ShapeError",
    "SolverError",
    "TrialData",
    "UnknownNameError",
    "__version__",
    "identify",
    "load_model",
    "model_path",
    "solve_motion",
    "write_result",
]
