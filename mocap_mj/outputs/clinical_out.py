"""The identified model's angles in Plug-in Gait's conventions, for a result folder:
angles.csv of the first trial and, when its C3D holds Vicon Nexus' Plug-in Gait angles, the
comparison section of report.md and its figure (:mod:`mocap_mj.clinical.compare`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mocap_mj.pipeline.motion import Motion

from ..clinical.compare import c3d_angles, comparison_section, numbered_like
from ..clinical.from_model import model_angles
from ..clinical.tables import series_table
from ..errors import MocapError
from ..io.atomic import atomic_write_text


def write_model_angles(
    out: Path, model: mujoco.MjModel, motion: Sequence[Motion], source: str, first_frame: int
) -> tuple[list[str], dict[str, Any] | None]:
    """angles.csv of ``motion[0]`` (internal qpos of ``model``; frames from
    ``first_frame``, the recording's frame number or the sample's index in the file) into
    ``out``; returns (report lines, summary entry) of the comparison
    with the Nexus angles in ``source`` (a C3D), or ([], None) when it holds none."""
    if not motion:
        return [], None
    m = motion[0]
    frames = first_frame + np.arange(len(m.times))
    angles = model_angles(model, m.qpos)
    atomic_write_text(out / "angles.csv", series_table(frames, m.times, angles, 180 / np.pi))
    path = Path(source)
    if path.suffix.lower() != ".c3d" or not path.is_file():
        return [], None
    try:
        ref = c3d_angles(path)
        if not ref.angles:
            return [], None
        ref = numbered_like(frames, ref)
        lines, rows = comparison_section(out, frames, m.times, angles, ref)
    except MocapError as exc:
        return ["## Angles against Plug-in Gait", "", f"Not compared: {exc}", ""], None
    entry = {
        r.name: {
            "rms_deg": r.rms,
            "offset_deg": r.offset,
            "correlation": r.correlation if np.isfinite(r.correlation) else None,
            "reference_range_deg": r.reference_range,
        }
        for r in rows
    }
    return lines, {"reference": ref.source, "components": entry}
