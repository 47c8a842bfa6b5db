"""Exports of a result for other tools: OpenSim model and motion, TRC, C3D, CSV tables.

One module per format (``osim``, ``mot``, ``trc``, ``c3d``, ``tables``, ``ik_setup``), the
OpenSim coordinates of the MJCF joints (``coordinates``), Plug-in Gait's angles of the model
(``clinical``), the result loader (``result``), the exporter registry of ``mocap-mj export``
(``registry``), and running OpenSim's IK on an export (``opensim_ik``, needs the ``[opensim]``
extra). The writers need no OpenSim. Conventions: docs/opensim.md.
"""

from mocap_mj.export.read_result import ExportSource, load_result

from .c3d import write_c3d
from .clinical import angles_table_text, clinical_angles
from .coordinates import Coordinate, coordinate_values, model_coordinates, qpos_from_coordinates
from .ik_setup import ik_setup_xml, write_ik_setup
from .mot import read_mot, write_mot
from .osim import osim_xml, write_osim
from .registry import Exporter
from .tables import (
    marker_residuals,
    scale_table_text,
    write_angles_csv,
    write_residuals_csv,
)
from .trc import write_trc

__all__ = [
    "Coordinate",
    "ExportSource",
    "Exporter",
    "angles_table_text",
    "clinical_angles",
    "coordinate_values",
    "ik_setup_xml",
    "load_result",
    "marker_residuals",
    "model_coordinates",
    "osim_xml",
    "qpos_from_coordinates",
    "read_mot",
    "scale_table_text",
    "write_angles_csv",
    "write_c3d",
    "write_ik_setup",
    "write_mot",
    "write_osim",
    "write_residuals_csv",
    "write_trc",
]
