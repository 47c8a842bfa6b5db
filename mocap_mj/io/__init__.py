"""Marker-file input and output.

Read any supported marker file (C3D, OpenSim TRC, mocap-mj CSV, Vicon Nexus CSV, OptiTrack
Motive CSV) with :func:`load_markers`; write with :func:`save_csv` or :func:`save_trc`; every
write in the project goes through :func:`atomic_write_text`, :func:`atomic_write_bytes` or
:func:`atomic_path`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

if TYPE_CHECKING:
    from .atomic import atomic_path, atomic_write_bytes, atomic_write_text
    from .formats.mocap_csv import save_csv
    from .formats.trc import save_trc
    from .load import load_markers
    from .orientation import UP_AXES, rotation_to_z_up
    from .trajectory import MarkerReport, MarkerTrajectory

#: The names imported on first use (PEP 562), so that importing one module of the package
#: (``yaml_file``, for ``mocap-mj batch --help``) loads no reader, NumPy or ezc3d.
_LAZY = {
    "atomic_path": ".atomic",
    "atomic_write_bytes": ".atomic",
    "atomic_write_text": ".atomic",
    "save_csv": ".formats.mocap_csv",
    "save_trc": ".formats.trc",
    "load_markers": ".load",
    "UP_AXES": ".orientation",
    "rotation_to_z_up": ".orientation",
    "MarkerReport": ".trajectory",
    "MarkerTrajectory": ".trajectory",
}


__getattr__ = lazy_names(__name__, _LAZY, globals())


__all__ = [
    "UP_AXES",
    "MarkerReport",
    "MarkerTrajectory",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "load_markers",
    "rotation_to_z_up",
    "save_csv",
    "save_trc",
]
