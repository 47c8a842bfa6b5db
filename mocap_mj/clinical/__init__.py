"""Clinical gait models: Plug-in Gait (the Conventional Gait Model 1.0).

``plug_in_gait(trajectory, subject, static=None) -> PigResult``: joint centres, segment
frames, Vicon's angles and bone points; see ``docs/clinical.md``.
"""

from .model import PigResult, calibrate, plug_in_gait
from .subject import PigSubject, pig_from_c3d, pig_from_yaml

__all__ = ["PigResult", "PigSubject", "calibrate", "pig_from_c3d", "pig_from_yaml", "plug_in_gait"]
