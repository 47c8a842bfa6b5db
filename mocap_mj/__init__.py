"""mocap-mj: subject-specific human models from optical motion capture, on MuJoCo.

Symbols used in every docstring: T frames, M markers (39 for the bundled humanoid), nq and nv
the model's position and velocity sizes (55 and 48; a written model.xml has 59 and 52 in
plain MuJoCo, the knees' slide joints included: ``mocap_mj.exported``), K = 34 kinematic
parameters, P = K + 3 M = 151 model parameters. Units are SI everywhere inside: metres,
radians, seconds; conversion happens only at the file boundary (``mocap_mj.io``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import (
    InputFileError,
    MocapError,
    ShapeError,
    SolverError,
    UnknownNameError,
)

if TYPE_CHECKING:
    from .identify.fit import Fit
    from .identify.output import write_result
    from .identify.problem import TrialData
    from .identify.recipe import Recipe
    from .identify.robust_ik import solve_motion
    from .kinematics import Frames, Kinematics
    from .markers import MARKER_NAMES
    from .model import load_model, model_path
    from .parameters import KINEMATIC_PARAMETERS, KinematicParameter, ParameterSet
    from .results import Motion

__version__ = "0.1.0"

#: The names imported on first use (PEP 562), so that ``import mocap_mj`` (and the command
#: line's start, which must answer Ctrl-C from its first moment) does not load MuJoCo and
#: the compiled kernels before they are needed. The identification API among them:
#: ``mocap_mj.identify(trials, recipe, subject) -> Fit`` (the package :mod:`mocap_mj.identify`
#: is callable), ``write_result(fit, folder)``, ``solve_motion(model, trial) -> Motion``.
_LAZY = {
    "Frames": ".kinematics",
    "Kinematics": ".kinematics",
    "MARKER_NAMES": ".markers",
    "load_model": ".model",
    "model_path": ".model",
    "KINEMATIC_PARAMETERS": ".parameters",
    "KinematicParameter": ".parameters",
    "ParameterSet": ".parameters",
    "Fit": ".identify.fit",
    "Motion": ".results",
    "Recipe": ".identify.recipe",
    "TrialData": ".identify.problem",
    "solve_motion": ".identify.robust_ik",
    "write_result": ".identify.output",
}


def __getattr__(name: str) -> Any:
    if name == "identify":
        return importlib.import_module(".identify", __name__)
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


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
