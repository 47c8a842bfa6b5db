"""angles.csv of a long recording, written chunk by chunk like its motion.

``identify`` with a selection writes every frame's motion chunk by chunk
(:mod:`mocap_mj.long.motion_out`); the angle table (:func:`mocap_mj.clinical.from_model.
model_angles`, Plug-in Gait's conventions) is the same table ``export --to angles`` writes
from the whole motion at once. Its progression frame depends on the whole trial (the pelvis'
displacement from the first to the last frame, else the direction it faces most), so the
written motion.npz is read twice, ``chunk`` frames at a time: once for the pelvis, once for
the angles, appended to the table under a temporary name and renamed when complete.
"""

from __future__ import annotations

import zipfile
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np

from mocap_mj.skeleton.exported import Layout

from ..clinical.angles import all_angles, progression_frame
from ..clinical.from_model import model_segments
from ..clinical.tables import series_table
from ..io.atomic import atomic_path


def npy_rows(path: Path, member: str, chunk: int) -> Iterator[np.ndarray]:
    """The rows of ``member`` (``qpos``, ...) of the npz at ``path``, ``chunk`` at a time
    (a C-order ``.npy`` member, as :func:`mocap_mj.long.motion_out.npy_member` writes)."""
    with zipfile.ZipFile(path) as zf, zf.open(f"{member}.npy") as handle:
        version = np.lib.format.read_magic(handle)
        read = np.lib.format.read_array_header_1_0
        if version != (1, 0):
            read = np.lib.format.read_array_header_2_0
        shape, fortran, dtype = read(handle)
        if fortran or len(shape) != 2:
            raise ValueError(f"{path}: {member}.npy is not a C-order table")
        width = int(shape[1])
        for s in range(0, int(shape[0]), chunk):
            n = min(chunk, int(shape[0]) - s)
            data = handle.read(n * width * dtype.itemsize)
            yield np.frombuffer(data, dtype=dtype).reshape(n, width)


def write_angle_chunks(
    path: Path, model: mujoco.MjModel, motion: Path, first_frame: int, chunk: int
) -> None:
    """angles.csv at ``path`` of the motion in ``motion`` (an npz in model.xml's layout,
    :class:`mocap_mj.skeleton.exported.Layout`, of ``model``), frames numbered from
    ``first_frame``."""
    layout = Layout.of(model)
    origins, facing = [], []
    for q in npy_rows(motion, "qpos", chunk):
        pelvis = model_segments(model, layout.internal(q))["pelvis"]
        origins.append(pelvis.origin)
        facing.append(pelvis.axes[:, :, :1])  # the direction it faces (its x)
    if not origins:
        return
    progression = progression_frame(np.concatenate(facing), np.concatenate(origins))
    del origins, facing
    times = np.load(motion)["times"]
    with atomic_path(path) as tmp, open(tmp, "w") as out:
        start = 0
        for q in npy_rows(motion, "qpos", chunk):
            angles = all_angles(model_segments(model, layout.internal(q)), progression)
            frames = first_frame + start + np.arange(len(q))
            text = series_table(frames, times[start : start + len(q)], angles, 180 / np.pi)
            out.write(text if start == 0 else text.split("\n", 1)[1])
            start += len(q)
