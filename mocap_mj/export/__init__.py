"""Exports of a result for other tools: OpenSim model and motion, TRC, C3D, CSV tables.

One module per format (``osim``, ``mot``, ``trc``, ``c3d``, ``tables``, ``ik_setup``), the
OpenSim coordinates of the MJCF joints (``coordinates``), Plug-in Gait's angles of the model
(``clinical``), the result loader (``result``), the exporter registry of ``mocap-mj export``
(``registry``), and running OpenSim's IK on an export (``opensim_ik``, needs the ``[opensim]``
extra). The writers need no OpenSim. Conventions: docs/opensim.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

if TYPE_CHECKING:
    from .c3d import write_c3d
    from .clinical import angles_table_text, clinical_angles
    from .coordinates import Coordinate, coordinate_values, model_coordinates, qpos_from_coordinates
    from .ik_setup import ik_setup_xml, write_ik_setup
    from .mot import read_mot, write_mot
    from .osim import osim_xml, write_osim
    from .read_result import ExportSource, load_result
    from .registry import Exporter
    from .tables import marker_residuals, scale_table_text, write_angles_csv, write_residuals_csv
    from .trc import write_trc

#: The names imported on first use (PEP 562), so that importing one module of the package
#: (``registry``, for ``mocap-mj export --help``) loads no writer, NumPy or MuJoCo.
_LAZY = {
    "ExportSource": ".read_result",
    "load_result": ".read_result",
    "write_c3d": ".c3d",
    "angles_table_text": ".clinical",
    "clinical_angles": ".clinical",
    "Coordinate": ".coordinates",
    "coordinate_values": ".coordinates",
    "model_coordinates": ".coordinates",
    "qpos_from_coordinates": ".coordinates",
    "ik_setup_xml": ".ik_setup",
    "write_ik_setup": ".ik_setup",
    "read_mot": ".mot",
    "write_mot": ".mot",
    "osim_xml": ".osim",
    "write_osim": ".osim",
    "Exporter": ".registry",
    "marker_residuals": ".tables",
    "scale_table_text": ".tables",
    "write_angles_csv": ".tables",
    "write_residuals_csv": ".tables",
    "write_trc": ".trc",
}


__getattr__ = lazy_names(__name__, _LAZY, globals())


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
