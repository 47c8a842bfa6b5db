"""mocap-mj: subject-specific human models from optical motion capture, on MuJoCo.

Symbols used in every docstring: T frames, M markers (39 for the bundled humanoid), nq and nv
the model's position and velocity sizes (55 and 48; a written model.xml has 59 and 52 in
plain MuJoCo, the knees' slide joints included: ``mocap_mj.skeleton.exported``), K = 34 kinematic
parameters, P = K + 3 M = 151 model parameters. Units are SI everywhere inside: metres,
radians, seconds; conversion happens only at the file boundary (``mocap_mj.io``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import (
    InputFileError,
    MocapError,
    ShapeError,
    SolverError,
    UnknownNameError,
)
from .lazy import lazy_names

if TYPE_CHECKING:
    from mocap_mj.io.marker_names import MARKER_NAMES
    from mocap_mj.outputs.write_fit import write_result
    from mocap_mj.pipeline.api import identify
    from mocap_mj.pipeline.fit import Fit
    from mocap_mj.pipeline.motion import Motion
    from mocap_mj.pipeline.prepare import Recording
    from mocap_mj.pipeline.recipe import Recipe
    from mocap_mj.pipeline.robust_ik import solve_motion
    from mocap_mj.pipeline.run_options import Hooks, Tuning
    from mocap_mj.skeleton.kinematics import Frames, Kinematics
    from mocap_mj.skeleton.mjcf import load_model, model_path
    from mocap_mj.skeleton.parameters import KINEMATIC_PARAMETERS, KinematicParameter, ParameterSet
    from mocap_mj.solve.problem import TrialData

__version__ = "0.1.0"

#: The names imported on first use (PEP 562), so that ``import mocap_mj`` (and the command
#: line's start, which must answer Ctrl-C from its first moment) does not load MuJoCo and
#: the compiled kernels before they are needed. The identification API among them:
#: ``mocap_mj.identify(recordings, recipe, subject) -> Fit``
#: (:func:`mocap_mj.pipeline.api.identify`), ``write_result(fit, folder)``,
#: ``solve_motion(model, trial) -> Motion``.
_LAZY = {
    "Frames": ".skeleton.kinematics",
    "Kinematics": ".skeleton.kinematics",
    "MARKER_NAMES": ".io.marker_names",
    "load_model": ".skeleton.mjcf",
    "model_path": ".skeleton.mjcf",
    "KINEMATIC_PARAMETERS": ".skeleton.parameters",
    "KinematicParameter": ".skeleton.parameters",
    "ParameterSet": ".skeleton.parameters",
    "Fit": ".pipeline.fit",
    "identify": ".pipeline.api",
    "Motion": ".pipeline.motion",
    "Recipe": ".pipeline.recipe",
    "Recording": ".pipeline.prepare",
    "Hooks": ".pipeline.run_options",
    "Tuning": ".pipeline.run_options",
    "TrialData": ".solve.problem",
    "solve_motion": ".pipeline.robust_ik",
    "write_result": ".outputs.write_fit",
}


__getattr__ = lazy_names(__name__, _LAZY, globals())


__all__ = [
    "KINEMATIC_PARAMETERS",
    "MARKER_NAMES",
    "Fit",
    "Frames",
    "Hooks",
    "InputFileError",
    "KinematicParameter",
    "Kinematics",
    "MocapError",
    "Motion",
    "ParameterSet",
    "Recipe",
    "Recording",
    "ShapeError",
    "SolverError",
    "TrialData",
    "Tuning",
    "UnknownNameError",
    "__version__",
    "identify",
    "load_model",
    "model_path",
    "solve_motion",
    "write_result",
]
