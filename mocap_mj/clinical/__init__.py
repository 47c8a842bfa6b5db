"""Clinical gait models: Plug-in Gait (the Conventional Gait Model 1.0).

``plug_in_gait(trajectory, subject, static=None) -> PigResult``: joint centres, segment
frames, Vicon's angles and bone points; ``model_angles(model, qpos)``: the same angles of
an identified MuJoCo model (:mod:`.from_model`); see ``docs/clinical.md``.
"""

from .from_model import model_angles
from .model import PigResult, calibrate, plug_in_gait
from .subject import pig_from_c3d, pig_from_file, pig_from_yaml

__all__ = [
    "PigResult",
    "calibrate",
    "model_angles",
    "pig_from_c3d",
    "pig_from_file",
    "pig_from_yaml",
    "plug_in_gait",
]
