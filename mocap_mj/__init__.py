"""mocap-mj: subject-specific human models from optical motion capture, on MuJoCo.

Symbols used in every docstring: T frames, M markers (39 for the bundled humanoid), nq and nv
the model's position and velocity sizes (55 and 48; a written model.xml has 59 and 52 in
plain MuJoCo, the knees' slide joints included: ``mocap_mj.exported``), K = 34 kinematic
parameters, P = K + 3 M = 151 model parameters. Units are SI everywhere inside: metres,
radians, seconds; conversion happens only at the file boundary (``mocap_mj.io``).
"""

from __future__ import annotations

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
