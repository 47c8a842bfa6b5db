"""Markers, residuals and the ghost model as drawable primitives, shared by every renderer.

:func:`frame_primitives` describes what to add to the posed model at one frame, independent of
any renderer: spheres for the measured markers and for the model's marker sites, and a thin
capsule (segment) from each measured marker to its site, coloured by its length. The MuJoCo
paths (offscreen :class:`mujoco.Renderer` and the interactive viewer) turn them into user
``mjvGeom`` with :func:`add_primitives`; the pyrender and GLB paths turn them into trimesh meshes
(:mod:`mocap_viewer.meshes`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from .playback import Ghost, Playback

__all__ = [
    "Layers",
    "Segment",
    "Sphere",
    "Style",
    "add_ghost",
    "add_primitives",
    "decorate",
    "frame_primitives",
    "residual_rgba",
]


@dataclass(frozen=True)
class Style:
    """Colours (RGBA in 0..1) and sizes [m] of the added primitives.

    ``residual_full_scale`` [m] is the residual length drawn fully red; shorter ones go from
    green (0) through yellow (half of it).
    """

    measured_rgba: tuple[float, float, float, float] = (1.0, 0.15, 0.75, 1.0)
    model_rgba: tuple[float, float, float, float] = (0.1, 0.45, 1.0, 1.0)
    ghost_rgba: tuple[float, float, float, float] = (0.45, 0.85, 1.0, 0.3)
    measured_radius: float = 0.012
    model_radius: float = 0.009
    residual_radius: float = 0.004
    residual_full_scale: float = 0.03


@dataclass
class Layers:
    """Which of the added layers are shown (the viewer's M, R and G keys toggle them)."""

    markers: bool = True
    residuals: bool = True
    ghost: bool = True


@dataclass(frozen=True)
class Sphere:
    """A sphere at ``pos`` (3,) [m] of ``radius`` [m] and colour ``rgba`` (4,)."""

    pos: np.ndarray
    radius: float
    rgba: tuple[float, float, float, float]


@dataclass(frozen=True)
class Segment:
    """A capsule of ``radius`` [m] from ``start`` (3,) to ``end`` (3,) [m], colour ``rgba``."""

    start: np.ndarray
    end: np.ndarray
    radius: float
    rgba: tuple[float, float, float, float]


Primitive = Sphere | Segment


def residual_rgba(length: float, full_scale: float) -> tuple[float, float, float, float]:
    """Colour of a residual of ``length`` [m]: green at 0, yellow at half scale, red beyond."""
    x = float(np.clip(length / full_scale, 0.0, 1.0)) if full_scale > 0 else 1.0
    red = min(1.0, 2.0 * x)
    green = min(1.0, 2.0 * (1.0 - x))
    return (red, green, 0.1, 1.0)


def frame_primitives(
    playback: Playback, frame: int, layers: Layers, style: Style | None = None
) -> list[Primitive]:
    """Markers and residuals to draw at ``frame``, in world coordinates [m].

    Measured markers that are missing (NaN) draw nothing. Residuals are drawn only for a fitted
    motion (``playback.fitted``) and only when their length is above 0.1 mm.
    """
    style = style or Style()
    out: list[Primitive] = []
    measured = playback.measured[frame]
    predicted = playback.predicted[frame]
    seen = np.all(np.isfinite(measured), axis=1)
    if layers.markers:
        out.extend(Sphere(p, style.model_radius, style.model_rgba) for p in predicted)
        out.extend(Sphere(p, style.measured_radius, style.measured_rgba) for p in measured[seen])
    if layers.residuals and playback.fitted:
        for a, b in zip(measured[seen], predicted[seen], strict=True):
            length = float(np.linalg.norm(a - b))
            if length > 1e-4:
                rgba = residual_rgba(length, style.residual_full_scale)
                out.append(Segment(a, b, style.residual_radius, rgba))
    return out


def _free_slots(scn: mujoco.MjvScene, wanted: int) -> int:
    return max(0, min(wanted, scn.maxgeom - scn.ngeom))


def _mark_user(geom: mujoco.MjvGeom) -> None:
    # Not an object of the model: no selection or segmentation id that could point at a body.
    geom.objtype = mujoco.mjtObj.mjOBJ_UNKNOWN
    geom.objid = -1
    geom.category = mujoco.mjtCatBit.mjCAT_DECOR


def add_primitives(scn: mujoco.MjvScene, primitives: Sequence[Primitive]) -> int:
    """Append ``primitives`` to ``scn`` as user geoms; return how many fitted.

    Call after ``mjv_updateScene`` (a renderer's ``update_scene``), which resets the scene's
    geoms, or on a viewer's ``user_scn`` after setting its ``ngeom`` to 0. Primitives beyond
    ``scn.maxgeom`` are dropped.
    """
    n = _free_slots(scn, len(primitives))
    eye = np.eye(3).ravel()
    for prim in primitives[:n]:
        geom = scn.geoms[scn.ngeom]
        rgba = np.asarray(prim.rgba, dtype=np.float32)
        if isinstance(prim, Sphere):
            size = np.array([prim.radius, prim.radius, prim.radius])
            pos = np.asarray(prim.pos, dtype=float)
            mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_SPHERE, size, pos, eye, rgba)
        else:
            mujoco.mjv_initGeom(
                geom, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), eye, rgba
            )
            mujoco.mjv_connector(
                geom,
                mujoco.mjtGeom.mjGEOM_CAPSULE,
                prim.radius,
                np.asarray(prim.start, dtype=float),
                np.asarray(prim.end, dtype=float),
            )
        _mark_user(geom)
        scn.ngeom += 1
    return n


#: Geom types a ghost can draw with the main model's render context (no mesh/height-field data).
_GHOST_TYPES = {
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
}


def add_ghost(
    scn: mujoco.MjvScene,
    ghost: Ghost,
    qpos: np.ndarray,
    rgba: Iterable[float] = Style.ghost_rgba,
) -> int:
    """Pose ``ghost`` at ``qpos`` (nq,) and append its body geoms to ``scn``, translucent.

    The geoms come from ``mjv_addGeoms`` (dynamic category: the world's own geoms such as the
    floor are left out) and are recoloured ``rgba``. Mesh and height-field geoms are dropped:
    their data live in the ghost model, not in the render context of the shown model.
    Returns the number of geoms added.
    """
    ghost.pose(qpos)
    start = scn.ngeom
    mujoco.mjv_addGeoms(
        ghost.model,
        ghost.data,
        mujoco.MjvOption(),
        mujoco.MjvPerturb(),
        mujoco.mjtCatBit.mjCAT_DYNAMIC,
        scn,
    )
    colour = np.asarray(tuple(rgba), dtype=np.float32)
    keep = start
    for i in range(start, scn.ngeom):
        src = scn.geoms[i]
        if int(src.type) not in _GHOST_TYPES:
            continue
        if keep != i:
            mujoco.mjv_initGeom(
                scn.geoms[keep],
                int(src.type),
                np.array(src.size, dtype=float),
                np.array(src.pos, dtype=float),
                np.array(src.mat, dtype=float).ravel(),
                colour,
            )
        dst = scn.geoms[keep]
        dst.rgba[:] = colour
        dst.matid = -1
        dst.emission = 0.2
        dst.specular = 0.2
        _mark_user(dst)
        keep += 1
    scn.ngeom = keep
    return keep - start


def decorate(
    scn: mujoco.MjvScene,
    playback: Playback,
    frame: int,
    layers: Layers,
    style: Style | None = None,
    ghost: Ghost | None = None,
) -> None:
    """Add the ghost (if shown) and the markers and residuals of ``frame`` to ``scn``."""
    style = style or Style()
    if ghost is not None and layers.ghost:
        add_ghost(scn, ghost, playback.qpos[frame], style.ghost_rgba)
    add_primitives(scn, frame_primitives(playback, frame, layers, style))
