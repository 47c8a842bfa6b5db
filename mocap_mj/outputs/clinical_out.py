"""The identified model's angles in Plug-in Gait's conventions, for a result folder:
a trial's angles.csv and, when its C3D holds Vicon Nexus' Plug-in Gait angles, the
comparison section of report.md and its figure (:mod:`mocap_mj.clinical.compare`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mocap_mj.pipeline.motion import Motion

from ..clinical.compare import FIGURE, c3d_angles, comparison_section, numbered_like
from ..clinical.from_model import model_angles
from ..clinical.tables import series_table
from ..errors import MocapError
from ..io.atomic import atomic_write_text


def write_model_angles(
    out: Path,
    model: mujoco.MjModel,
    motion: Sequence[Motion],
    source: str,
    first_frame: int,
    *,
    trial: int = 0,
    folder: str = "",
) -> tuple[list[str], dict[str, Any] | None]:
    """angles.csv of ``motion[trial]`` (internal qpos of ``model``; frames from
    ``first_frame``, the recording's frame number or the sample's index in the file) into
    ``out / folder`` (the trial's folder, :mod:`mocap_mj.pipeline.trials`); returns (report
    lines, summary entry) of the comparison with the Nexus angles in ``source`` (a C3D; its
    figure beside angles.csv, named in the lines relative to ``out``), or ([], None) when it
    holds none."""
    if trial >= len(motion):
        return [], None
    m = motion[trial]
    frames = first_frame + np.arange(len(m.times))
    angles = model_angles(model, m.qpos)
    where = out / folder
    where.mkdir(parents=True, exist_ok=True)
    atomic_write_text(where / "angles.csv", series_table(frames, m.times, angles, 180 / np.pi))
    path = Path(source)
    if path.suffix.lower() != ".c3d" or not path.is_file():
        return [], None
    try:
        ref = c3d_angles(path)
        if not ref.angles:
            return [], None
        ref = numbered_like(frames, ref)
        figure = f"{folder}/{FIGURE}" if folder else FIGURE
        lines, rows = comparison_section(out, frames, m.times, angles, ref, figure=figure)
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
