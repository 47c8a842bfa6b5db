"""Setup file of OpenSim's InverseKinematicsTool for an exported model and TRC (XML, no OpenSim).

Run from the setup file's folder (``opensim-cmd run-tool ik_setup.xml``, or
``opensim.InverseKinematicsTool("ik_setup.xml").run()``), OpenSim's IK fits the exported
``.osim`` to the ``.trc`` as ``mocap-mj ik`` does: every marker with weight 1. Paths are
written as given; the Python tool reads relative ones from the working directory.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from xml.etree import ElementTree as ET

from ..io.atomic import atomic_write_text

#: OpenSim's default IK accuracy (the tool's convergence setting).
DEFAULT_ACCURACY = 1e-5


def ik_setup_xml(
    *,
    model_file: str,
    marker_file: str,
    marker_names: Sequence[str],
    time_range: tuple[float, float],
    output_motion_file: str = "ik.mot",
    accuracy: float = DEFAULT_ACCURACY,
    name: str = "mocap_mj_ik",
) -> str:
    """The setup XML; time_range (2,) [s] is the first and last frame's time."""
    doc = ET.Element("OpenSimDocument", Version="40600")
    tool = ET.SubElement(doc, "InverseKinematicsTool", name=name)
    fields = {
        "results_directory": ".",
        "model_file": model_file,
        "constraint_weight": "Inf",
        "accuracy": repr(float(accuracy)),
    }
    for key, value in fields.items():
        ET.SubElement(tool, key).text = value
    tasks = ET.SubElement(ET.SubElement(tool, "IKTaskSet", name="ik_tasks"), "objects")
    for marker in marker_names:
        task = ET.SubElement(tasks, "IKMarkerTask", name=marker)
        ET.SubElement(task, "apply").text = "true"
        ET.SubElement(task, "weight").text = "1"
    more = {
        "marker_file": marker_file,
        "coordinate_file": "Unassigned",
        "time_range": f"{time_range[0]!r} {time_range[1]!r}",
        "report_errors": "false",
        "output_motion_file": output_motion_file,
        "report_marker_locations": "false",
    }
    for key, value in more.items():
        ET.SubElement(tool, key).text = value
    ET.indent(doc, space="  ")
    return '<?xml version="1.0" encoding="UTF-8" ?>\n' + ET.tostring(doc, encoding="unicode") + "\n"


def write_ik_setup(path: str | Path, **kwargs: object) -> None:
    """Write :func:`ik_setup_xml` (same keyword arguments) to ``path``, atomically."""
    atomic_write_text(path, ik_setup_xml(**kwargs))  # type: ignore[arg-type]
