"""Marker-file input and output.

Read any supported marker file (C3D, OpenSim TRC, mocap-mj CSV, Vicon Nexus CSV, OptiTrack
Motive CSV) with :func:`load_markers`; write with :func:`save_csv` or :func:`save_trc`; every
write in the project goes through :func:`atomic_write_text`, :func:`atomic_write_bytes` or
:func:`atomic_path`.
"""

from __future__ import annotations

from mocap_mj.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text
from mocap_mj.io.formats.mocap_csv import save_csv
from mocap_mj.io.formats.trc import save_trc
from mocap_mj.io.load import load_markers
from mocap_mj.io.orientation import UP_AXES, rotation_to_z_up
from mocap_mj.io.trajectory import MarkerReport, MarkerTrajectory

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
