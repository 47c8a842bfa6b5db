"""Trimesh meshes of a model's geoms and of the added primitives, for pyrender and GLB export.

Each visible geom becomes one mesh in its own geom frame (built once); a pose places it in the
world with the 4 x 4 transform of ``geom_xpos``/``geom_xmat``. Supported geom types: sphere,
capsule, ellipsoid, cylinder, box, plane (a finite quad; an infinite plane is drawn 20 m wide)
and mesh. Height fields and SDF geoms are skipped.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh
from numpy.typing import ArrayLike
from trimesh.visual.material import PBRMaterial

from .scene import Primitive, Sphere

__all__ = ["GeomMesh", "geom_meshes", "geom_poses", "primitives_mesh", "with_colour"]

#: Geom groups shown by default, as in MuJoCo's default ``mjvOption.geomgroup``.
DEFAULT_GROUPS = (0, 1, 2)


@dataclass(frozen=True, eq=False)
class GeomMesh:
    """One geom as a mesh in its own frame.

    Attributes
    ----------
    geom_id : int
    name : str
        The geom's name, or ``geom<id>`` if it has none.
    mesh : trimesh.Trimesh
        Vertices [m] in the geom frame.
    rgba : (4,) float
        Colour in 0..1 (the geom's material colour, if it has a material).
    static : bool
        True for geoms of the world body (floor...), which never move.
    texture : (H, W, 3) uint8, optional
        RGB texture of a textured plane (the floor's checker); the mesh then has UV
        coordinates (``mesh.visual.uv``) that repeat it as MuJoCo does, and ``rgba`` is the
        material's colour that multiplies it.
    """

    geom_id: int
    name: str
    mesh: trimesh.Trimesh
    rgba: np.ndarray
    static: bool
    texture: np.ndarray | None = None


def _plane(size: np.ndarray) -> trimesh.Trimesh:
    hx = size[0] if size[0] > 0 else 10.0
    hy = size[1] if size[1] > 0 else 10.0
    vertices = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], dtype=float)
    return trimesh.Trimesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]), process=False)


def _geom_mesh(model: mujoco.MjModel, g: int) -> trimesh.Trimesh | None:
    gtype = int(model.geom_type[g])
    size = np.array(model.geom_size[g], dtype=float)
    t = mujoco.mjtGeom
    if gtype == t.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if gtype == t.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[16, 16])
    if gtype == t.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
        return mesh
    if gtype == t.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
    if gtype == t.mjGEOM_BOX:
        return trimesh.creation.box(extents=2 * size)
    if gtype == t.mjGEOM_PLANE:
        return _plane(size)
    if gtype == t.mjGEOM_MESH:
        m = int(model.geom_dataid[g])
        va, vn = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        fa, fn = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        return trimesh.Trimesh(
            np.array(model.mesh_vert[va : va + vn], dtype=float),
            np.array(model.mesh_face[fa : fa + fn]),
            process=False,
        )
    return None


def _geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    mat = int(model.geom_matid[g])
    if mat < 0:
        return np.array(model.geom_rgba[g], dtype=float)
    return np.array(model.mat_rgba[mat], dtype=float)


def _plane_texture(model: mujoco.MjModel, g: int, mesh: trimesh.Trimesh) -> np.ndarray | None:
    """The RGB texture of a plane's material (2D textures only), setting the mesh's UVs."""
    mat = int(model.geom_matid[g])
    if mat < 0:
        return None
    tex = int(model.mat_texid[mat, int(mujoco.mjtTextureRole.mjTEXROLE_RGB)])
    if tex < 0 or int(model.tex_type[tex]) != int(mujoco.mjtTexture.mjTEXTURE_2D):
        return None
    adr, nc = int(model.tex_adr[tex]), int(model.tex_nchannel[tex])
    h, w = int(model.tex_height[tex]), int(model.tex_width[tex])
    image = np.array(model.tex_data[adr : adr + h * w * nc], dtype=np.uint8).reshape(h, w, nc)
    repeat = np.array(model.mat_texrepeat[mat], dtype=float)
    xy = mesh.vertices[:, :2]
    if model.mat_texuniform[mat]:
        uv = xy * repeat  # repeats per metre
    else:
        half = np.abs(xy).max(axis=0)
        uv = (xy / (2 * half) + 0.5) * repeat  # repeats over the whole plane
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv)
    return np.ascontiguousarray(image[..., :3])


def geom_meshes(
    model: mujoco.MjModel, *, groups: Sequence[int] = DEFAULT_GROUPS, static: bool = True
) -> list[GeomMesh]:
    """Meshes of the model's visible geoms (in ``groups``, alpha > 0), in their own frames.

    Parameters
    ----------
    model : mujoco.MjModel
    groups : sequence of int
        Geom groups to include (MuJoCo shows 0, 1 and 2 by default).
    static : bool
        Include the world body's geoms (the floor).
    """
    out = []
    for g in range(model.ngeom):
        if int(model.geom_group[g]) not in groups:
            continue
        is_static = int(model.geom_bodyid[g]) == 0
        if is_static and not static:
            continue
        rgba = _geom_rgba(model, g)
        if rgba[3] <= 0:
            continue
        mesh = _geom_mesh(model, g)
        if mesh is None:
            continue
        name = model.geom(g).name or f"geom{g}"
        texture = None
        if int(model.geom_type[g]) == mujoco.mjtGeom.mjGEOM_PLANE:
            texture = _plane_texture(model, g, mesh)
        out.append(GeomMesh(g, name, mesh, rgba, is_static, texture))
    return out


def geom_poses(data: mujoco.MjData, geom_ids: Sequence[int]) -> np.ndarray:
    """World transforms (N, 4, 4) of the geoms ``geom_ids`` (after ``mj_kinematics``)."""
    ids = np.asarray(geom_ids, dtype=int)
    out = np.zeros((len(ids), 4, 4))
    out[:, :3, :3] = np.asarray(data.geom_xmat)[ids].reshape(-1, 3, 3)
    out[:, :3, 3] = np.asarray(data.geom_xpos)[ids]
    out[:, 3, 3] = 1.0
    return out


def with_colour(
    mesh: trimesh.Trimesh, rgba: ArrayLike, texture: np.ndarray | None = None
) -> trimesh.Trimesh:
    """A copy of ``mesh`` with a PBR material of colour ``rgba`` (0..1; alpha < 1 blends).

    With ``texture`` (H, W, 3) uint8, the mesh's UV coordinates map it (times ``rgba``).
    """
    from PIL import Image

    out = mesh.copy()
    colour = np.clip(np.asarray(rgba, dtype=float), 0.0, 1.0)
    uv = getattr(mesh.visual, "uv", None) if texture is not None else None
    image = Image.fromarray(texture) if texture is not None and uv is not None else None
    material = PBRMaterial(
        baseColorFactor=np.round(255 * colour).astype(np.uint8),
        baseColorTexture=image,
        metallicFactor=0.0,
        roughnessFactor=0.8,
        alphaMode="BLEND" if colour[3] < 1.0 else "OPAQUE",
        doubleSided=True,
    )
    out.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    return out


_SPHERE = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
_CYLINDER = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=10)


def primitives_mesh(primitives: Sequence[Primitive]) -> trimesh.Trimesh | None:
    """All ``primitives`` as one vertex-coloured mesh in world coordinates (None if empty).

    Segments are drawn as cylinders (their round ends are left out).
    """
    parts = []
    for prim in primitives:
        if isinstance(prim, Sphere):
            vertices = _SPHERE.vertices * prim.radius + np.asarray(prim.pos)
            faces = _SPHERE.faces
        else:
            start, end = np.asarray(prim.start, float), np.asarray(prim.end, float)
            axis = end - start
            length = float(np.linalg.norm(axis))
            if length <= 0:
                continue
            transform = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis / length)
            local = _CYLINDER.vertices * np.array([prim.radius, prim.radius, length])
            vertices = local @ transform[:3, :3].T + (start + end) / 2
            faces = _CYLINDER.faces
        colour = np.round(255 * np.clip(np.asarray(prim.rgba), 0, 1)).astype(np.uint8)
        parts.append((vertices, faces, np.tile(colour, (len(vertices), 1))))
    if not parts:
        return None
    offsets = np.cumsum([0] + [len(v) for v, _, _ in parts[:-1]])
    vertices = np.concatenate([v for v, _, _ in parts])
    faces = np.concatenate([f + o for (_, f, _), o in zip(parts, offsets, strict=True)])
    colours = np.concatenate([c for _, _, c in parts])
    return trimesh.Trimesh(vertices, faces, vertex_colors=colours, process=False)
