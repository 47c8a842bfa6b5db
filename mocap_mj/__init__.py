"""mocap-mj: subject-specific human models from optical motion capture, on MuJoCo.

Symbols used in every docstring: T frames, M markers (39 for the bundled humanoid), nq and nv
the model's position and velocity sizes (55 and 48), K = 34 kinematic parameters, P = K + 3 M
= 151 model parameters. Units are SI everywhere inside: metres, radians, seconds; conversion
happens only at the file boundary (``mocap_mj.io``).
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
    from .kinematics import Frames, Kinematics
    from .markers import MARKER_NAMES
    from .model import load_model, model_path
    from .parameters import KINEMATIC_PARAMETERS, KinematicParameter, ParameterSet

#: The names imported on first use (PEP 562), so that ``import mocap_mj`` (and the command
#: line's start, which must answer Ctrl-C from its first moment) does not load MuJoCo and
#: the compiled kernels before they are needed.
_LAZY = {
    "Frames": ".kinematics",
    "Kinematics": ".kinematics",
    "MARKER_NAMES": ".markers",
    "load_model": ".model",
    "model_path": ".model",
    "KINEMATIC_PARAMETERS": ".parameters",
    "KinematicParameter": ".parameters",
    "ParameterSet": ".parameters",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


__version__ = "0.1.0"

__all__ = [
    "KINEMATIC_PARAMETERS",
    "MARKER_NAMES",
    "Frames",
    "InputFileError",
    "KinematicParameter",
    "Kinematics",
    "MocapError",
    "ParameterSet",
    "ShapeError",
    "SolverError",
    "UnknownNameError",
    "__version__",
    "load_model",
    "model_path",
]
