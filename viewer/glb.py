"""Export posed frames of a playback as a GLB (binary glTF) scene with trimesh.

trimesh writes no glTF animations, so a range of frames is written as one node set per frame:
a parent node ``frame_<k>`` (k the frame index, zero-padded to 5 digits) holding one child node
``frame_<k>/<geom name>`` per visible body geom, placed by its world transform. The meshes
themselves are stored once and shared by every frame. One frame is a static scene of the same
form. The frame times [s] are in the scene's ``extras`` (``frame_times``, ``frames``), which
trimesh reads back as ``scene.metadata``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import trimesh

from mocap_mj.errors import MocapError
from mocap_mj.io.atomic import atomic_write_bytes
from mocap_mj.skeleton import rolling

from .meshes import geom_meshes, geom_poses, primitives_mesh, with_colour
from .playback import Ghost, Playback
from .scene import Layers, Style, frame_primitives

__all__ = ["export_glb", "frame_node"]


def frame_node(frame: int) -> str:
    """Name of the parent node of ``frame``."""
    return f"frame_{frame:05d}"


def _add_floor(scene: trimesh.Scene, model: mujoco.MjModel) -> int:
    """Add the world's own geoms (the floor) once, as nodes ``world/<geom name>``; their
    count."""
    base = scene.graph.base_frame
    data = mujoco.MjData(model)
    rolling.kinematics(model, data)
    statics = [g for g in geom_meshes(model) if g.static]
    for g, pose in zip(statics, geom_poses(data, [g.geom_id for g in statics]), strict=True):
        scene.geometry[f"world/{g.name}"] = with_colour(g.mesh, g.rgba, g.texture)
        scene.graph.update(
            frame_to=f"world/{g.name}", frame_from=base, matrix=pose, geometry=f"world/{g.name}"
        )
    return len(statics)


def _add_frame(
    scene: trimesh.Scene,
    playback: Playback,
    k: int,
    bodies: Sequence[Any],
    data: mujoco.MjData,
    roll: Any,
) -> int:
    """Add frame ``k``'s node and its body geoms posed at ``playback.qpos[k]``; their count."""
    parent = frame_node(k)
    scene.graph.update(frame_to=parent, frame_from=scene.graph.base_frame, matrix=np.eye(4))
    data.qpos[:] = playback.qpos[k]
    rolling.kinematics(playback.model, data, roll=roll)
    for g, pose in zip(bodies, geom_poses(data, [g.geom_id for g in bodies]), strict=True):
        scene.graph.update(
            frame_to=f"{parent}/{g.name}", frame_from=parent, matrix=pose, geometry=g.name
        )
    return len(bodies)


def _add_ghost(
    scene: trimesh.Scene, playback: Playback, k: int, ghost: Ghost, ghost_geoms: Sequence[Any]
) -> int:
    """Add the ghost's geoms in frame ``k``'s pose under frame ``k``'s node; their count."""
    parent = frame_node(k)
    ghost.pose(playback.qpos[k])
    poses = geom_poses(ghost.data, [g.geom_id for g in ghost_geoms])
    for g, pose in zip(ghost_geoms, poses, strict=True):
        name = f"ghost/{g.name}"
        scene.graph.update(
            frame_to=f"{parent}/{name}", frame_from=parent, matrix=pose, geometry=name
        )
    return len(ghost_geoms)


def _add_markers(
    scene: trimesh.Scene, playback: Playback, k: int, layers: Layers, style: Style
) -> int:
    """Add frame ``k``'s markers and residuals as one mesh ``frame_<k>/markers``; 1 node, or
    0 when nothing is drawn."""
    mesh = primitives_mesh(frame_primitives(playback, k, layers, style))
    if mesh is None:
        return 0
    parent = frame_node(k)
    name = f"{parent}/markers"
    scene.geometry[name] = mesh
    scene.graph.update(frame_to=name, frame_from=parent, matrix=np.eye(4), geometry=name)
    return 1


def export_glb(
    playback: Playback,
    path: str | Path,
    frames: Sequence[int],
    *,
    markers: bool = False,
    ghost: Ghost | None = None,
    floor: bool = False,
    style: Style | None = None,
) -> dict[str, Any]:
    """Write ``frames`` of ``playback`` as a GLB scene, atomically.

    Parameters
    ----------
    playback : Playback
    path : path
        Output ``.glb`` file (its folder is created if needed).
    frames : sequence of int
        Frame indices.
    markers : bool
        Also add, per frame, one vertex-coloured mesh ``frame_<k>/markers`` with the measured
        and model markers and the residuals (:func:`mocap_viewer.scene.frame_primitives`).
    ghost : Ghost, optional
        Add the ghost's body geoms (translucent), as ``frame_<k>/ghost/<geom name>``.
    floor : bool
        Add the world's own geoms (the floor) once, as node ``world/<geom name>``.
    style : Style, optional

    Returns
    -------
    dict
        ``out``, ``frames``, ``first``, ``last``, ``geometry_nodes`` (count), ``bytes``.
    """
    if not frames:
        raise MocapError("no frame to export")
    style = style or Style()
    path = Path(path)
    model = playback.model
    scene = trimesh.Scene()
    bodies = geom_meshes(model, static=False)
    for g in bodies:
        scene.geometry[g.name] = with_colour(g.mesh, g.rgba)
    ghost_geoms = geom_meshes(ghost.model, static=False) if ghost is not None else []
    for g in ghost_geoms:
        scene.geometry[f"ghost/{g.name}"] = with_colour(g.mesh, style.ghost_rgba)
    n_nodes = _add_floor(scene, model) if floor else 0

    data = mujoco.MjData(model)
    roll = rolling.read(model)
    layers = Layers(markers=True, residuals=True, ghost=False)
    for k in frames:
        n_nodes += _add_frame(scene, playback, k, bodies, data, roll)
        if ghost is not None:
            n_nodes += _add_ghost(scene, playback, k, ghost, ghost_geoms)
        if markers:
            n_nodes += _add_markers(scene, playback, k, layers, style)

    scene.metadata["frames"] = [int(k) for k in frames]
    scene.metadata["frame_times"] = [float(playback.times[k]) for k in frames]
    data_bytes = scene.export(file_type="glb")
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, data_bytes)
    return {
        "out": str(path),
        "frames": len(frames),
        "first": int(frames[0]),
        "last": int(frames[-1]),
        "geometry_nodes": n_nodes,
        "bytes": len(data_bytes),
    }
