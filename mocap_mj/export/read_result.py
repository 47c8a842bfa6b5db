"""Reading a result folder for export: the one place that knows how results are stored.

A result is what ``mocap-mj identify`` or ``mocap-mj ik`` writes (:mod:`mocap_mj.pipeline.motion`):
``model.xml`` (the subject's MJCF) and ``motion.npz`` (qpos, times, measured markers), or the
``truth_model.xml``/``truth_motion.npz`` of a synthetic-truth folder; ``summary.json`` is read
when present.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mocap_mj.pipeline.motion import Motion, ResultDir, load_motion, read_summary
from mocap_mj.pipeline.trials import open_trial
from mocap_mj.skeleton import rolling
from mocap_mj.skeleton.mjcf import load_model

from ..errors import InputFileError


@dataclass(frozen=True)
class ExportSource:
    """A result to export.

    Attributes
    ----------
    root : Path
        The result folder.
    model_path : Path
    model : mujoco.MjModel
        The subject's model (its ``body_pos``/``site_pos`` are the identified values).
    motion : Motion
        qpos (T, nq), times (T,) [s], measured markers (T, M, 3) [m] in site order.
    summary : dict
        ``summary.json``, or empty.
    motion_path : Path or None
        The motion file read (``motion.npz``, or ``--motion``'s).
    """

    root: Path
    model_path: Path
    model: mujoco.MjModel
    motion: Motion
    summary: dict[str, Any] = field(default_factory=dict)
    motion_path: Path | None = None

    @property
    def rate(self) -> float:
        """Frame rate [Hz] from the median time step (1 Hz for a single frame)."""
        return frame_rate(self.motion.times)


def posed_frames(model: mujoco.MjModel, qpos: np.ndarray) -> Iterator[tuple[int, mujoco.MjData]]:
    """(frame index, data after ``mj_kinematics``) for each frame of qpos (T, nq) without NaN.

    The same ``MjData`` is reused: read what you need before the next frame.
    """
    yield from rolling.posed(model, qpos)


def frame_rate(times: np.ndarray) -> float:
    """Frame rate [Hz] of times (T,) [s]: 1 / median step to 10 significant digits (times
    summed in floating point make 100 Hz 99.99999999999991); 1 Hz for fewer than two
    frames."""
    steps = np.diff(np.asarray(times, dtype=float))
    if len(steps) == 0 or not np.median(steps) > 0:
        return 1.0
    return float(f"{1.0 / np.median(steps):.10g}")


def load_result(
    path: str | Path, motion_path: str | Path | None = None, trial: str | None = None
) -> ExportSource:
    """Read the result folder ``path`` (see the module doc); bad folders raise one clear line.

    ``trial``: which trial's motion of a multi-trial ``identify`` (its index or name,
    :func:`mocap_mj.pipeline.trials.open_trial`; default the first). ``motion_path``
    replaces the motion file.
    """
    rd = open_trial(path, trial)
    if motion_path is not None:
        rd = ResultDir(rd.root, rd.model, Path(motion_path))
    model = load_model(rd.model)
    motion = load_motion(rd.motion, model, rd.model)
    sites = tuple(model.site(i).name for i in range(model.nsite))
    if motion.marker_names != sites:
        raise InputFileError(f"{rd.motion}: marker names differ from the sites of {rd.model}")
    summary: dict[str, Any] = {}
    if (rd.root / "summary.json").is_file():
        summary = read_summary(rd.root / "summary.json")
    return ExportSource(rd.root, rd.model, model, motion, summary, rd.motion)
