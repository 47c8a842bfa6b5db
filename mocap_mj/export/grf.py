"""OpenSim's external loads of a result: its ``grf.csv`` as a ground-reaction ``.mot`` and the
``ExternalLoads`` ``.xml`` that applies it to the exported model's feet.

``grf.csv`` (what ``ik`` and ``identify`` write for a trial with force plates) holds per foot
the force [N] the plates exert on it, its centre of pressure [m] and its free moment about the
vertical [N m], in the MJCF world (z up), empty off the plates. The ``.mot`` holds the same in
OpenSim's ground (:func:`mocap_mj.export.osim.up_rotation`: y up by default, as the exported
model, motion and markers), with OpenSim's column names per foot (``l``, ``r``):
``ground_force_<s>_vx, _vy, _vz`` [N], ``ground_force_<s>_px, _py, _pz`` [m] and
``ground_torque_<s>_x, _y, _z`` [N m]; a frame off the plates holds a zero force and moment at
the origin, which loads nothing. The ``.xml`` applies each foot's force at its point and its
torque to the foot body (``foot_l``, ``foot_r``), all three expressed in ground, as
OpenSim's InverseDynamicsTool reads them (:mod:`mocap_mj.export.opensim_id`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from ..errors import InputFileError
from ..io.atomic import atomic_write_text
from .osim import OSIM_VERSION, up_rotation

#: The exported model's foot bodies, per side: where each foot's ground reaction acts.
FOOT_BODIES: dict[str, str] = {"left": "foot_l", "right": "foot_r"}
SIDES = ("left", "right")


@dataclass(frozen=True)
class GroundReactions:
    """The loads of ``grf.csv``: ``times`` (T,) [s] and per side (``left``, ``right``) the
    ``force`` (T, 3) [N], the centre of pressure ``cop`` (T, 3) [m] and the ``moment`` (T, 3)
    [N m] (the free moment, vertical), MJCF world; zero force and moment and a NaN centre of
    pressure where the foot is on no counted plate."""

    times: np.ndarray
    force: dict[str, np.ndarray]
    cop: dict[str, np.ndarray]
    moment: dict[str, np.ndarray]


def read_grf_csv(path: str | Path) -> GroundReactions:
    """``grf.csv`` (:mod:`mocap_mj.outputs.kinetics_out`'s) read back; a file that is not
    one is refused in one line naming it and what was expected."""
    file = Path(path)
    try:
        lines = file.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{file}: cannot read the ground reactions ({exc})") from None
    header = lines[0].split(",") if lines else []
    sides = [s for s in SIDES if f"{s}_force_X_N" in header]
    if not header or header[0] != "time_s" or not sides:
        raise InputFileError(
            f"{file}: expected grf.csv's columns time_s, left_force_X_N ... (ik's and "
            f"identify's), got {','.join(header[:4])!r}"
        )
    rows = []
    for i, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        try:
            rows.append([float(c) if c else np.nan for c in cells])
        except ValueError:
            rows = []
        if len(cells) != len(header) or not rows:
            raise InputFileError(f"{file}: line {i}: expected {len(header)} numbers or empty cells")
    table = np.array(rows, dtype=float).reshape(-1, len(header))
    col = {n: table[:, k] for k, n in enumerate(header)}
    force, cop, moment = {}, {}, {}
    for s in sides:
        f = np.stack([col[f"{s}_force_{a}_N"] for a in "XYZ"], axis=1)
        on = col.get(f"{s}_on_plate", np.ones(len(table))) > 0.5
        force[s] = np.where(on[:, None] & np.isfinite(f), f, 0.0)
        cop[s] = np.stack([col[f"{s}_cop_{a}_m"] for a in "XYZ"], axis=1)
        cop[s][~on] = np.nan
        free = np.nan_to_num(col.get(f"{s}_free_moment_Z_Nm", np.zeros(len(table))))
        moment[s] = np.stack([np.zeros(len(table)), np.zeros(len(table)), free * on], axis=1)
    return GroundReactions(col["time_s"], force, cop, moment)


def grf_mot_text(loads: GroundReactions, *, up: str = "y", name: str = "grf") -> str:
    """The ground-reaction ``.mot`` of ``loads`` in OpenSim's ground of ``up`` (module doc)."""
    rot = up_rotation(up)
    names, cols = [], []
    for side in loads.force:
        s = side[0]
        point = np.where(np.isfinite(loads.cop[side]), loads.cop[side], 0.0)
        names += [f"ground_force_{s}_v{a}" for a in "xyz"]
        names += [f"ground_force_{s}_p{a}" for a in "xyz"]
        names += [f"ground_torque_{s}_{a}" for a in "xyz"]
        cols += [loads.force[side] @ rot.T, point @ rot.T, loads.moment[side] @ rot.T]
    values = np.concatenate(cols, axis=1) if cols else np.zeros((len(loads.times), 0))
    header = [name, "version=1", f"nRows={len(values)}", f"nColumns={len(names) + 1}",
              "inDegrees=no", "endheader", "\t".join(["time", *names])]  # fmt: skip
    rows = ["\t".join([f"{t:.6f}", *(f"{v:.8g}" for v in row)])
            for t, row in zip(loads.times, values, strict=True)]  # fmt: skip
    return "\n".join(header + rows) + "\n"


def external_loads_xml(
    mot_file: str, sides: tuple[str, ...] = SIDES, bodies: dict[str, str] | None = None
) -> str:
    """The ``ExternalLoads`` document applying ``mot_file``'s forces (:func:`grf_mot_text`) of
    ``sides`` to their foot bodies (default :data:`FOOT_BODIES`), expressed in ground."""
    chosen = FOOT_BODIES if bodies is None else bodies
    doc = ET.Element("OpenSimDocument", Version=OSIM_VERSION)
    loads = ET.SubElement(doc, "ExternalLoads", name="externalloads")
    objects = ET.SubElement(loads, "objects")
    for side in sides:
        s = side[0]
        force = ET.SubElement(objects, "ExternalForce", name=f"ground_reaction_{s}")
        for tag, text in (
            ("applied_to_body", chosen[side]),
            ("force_expressed_in_body", "ground"),
            ("point_expressed_in_body", "ground"),
            ("force_identifier", f"ground_force_{s}_v"),
            ("point_identifier", f"ground_force_{s}_p"),
            ("torque_identifier", f"ground_torque_{s}_"),
            ("data_source_name", "Unassigned"),
        ):
            ET.SubElement(force, tag).text = text
    ET.SubElement(loads, "groups")
    ET.SubElement(loads, "datafile").text = mot_file
    ET.indent(doc, space="  ")
    return '<?xml version="1.0" encoding="UTF-8" ?>\n' + ET.tostring(doc, encoding="unicode") + "\n"


def loads_path(mot: str | Path) -> Path:
    """The ``ExternalLoads`` file written beside the ``.mot`` ``mot``: ``<stem>_loads.xml``."""
    mot = Path(mot)
    return mot.with_name(f"{mot.with_suffix('').name}_loads.xml")


def write_grf(path: str | Path, loads: GroundReactions, *, up: str = "y") -> tuple[Path, Path]:
    """Write the ``.mot`` ``path`` and its ``ExternalLoads`` :func:`loads_path` (which names
    the ``.mot`` by its file name: keep the two together), each atomically; their paths."""
    mot = Path(path)
    atomic_write_text(mot, grf_mot_text(loads, up=up, name=mot.with_suffix("").name))
    xml = loads_path(mot)
    atomic_write_text(xml, external_loads_xml(mot.name, tuple(loads.force)))
    return mot, xml


__all__ = [
    "FOOT_BODIES",
    "GroundReactions",
    "external_loads_xml",
    "grf_mot_text",
    "loads_path",
    "read_grf_csv",
    "write_grf",
]
