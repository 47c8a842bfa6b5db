"""Offscreen rendering of a playback to numpy images: MuJoCo's renderer or pyrender.

Both backends draw the posed model, the markers and residuals of :mod:`mocap_viewer.scene` and
the optional ghost, seen from the same camera (a named model camera, or MuJoCo's default free
camera), and return (H, W, 3) uint8 RGB images.

``mujoco``
    :class:`mujoco.Renderer`; markers and residuals are user geoms appended to
    ``renderer.scene`` after ``update_scene``. The OpenGL platform is chosen by MuJoCo when
    ``mujoco`` is first imported, from ``MUJOCO_GL``: ``egl`` or ``osmesa`` without a display.
``pyrender``
    pyrender over trimesh meshes of the model's geoms (:mod:`mocap_viewer.meshes`), through
    ``PYOPENGL_PLATFORM`` (``egl`` or ``osmesa``; set to ``MUJOCO_GL``'s choice, else ``egl``,
    when unset and PyOpenGL is not loaded yet).
"""

from __future__ import annotations

import copy
import math
import os
import sys
from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np
import trimesh
from numpy.typing import ArrayLike

from mocap_mj.errors import MocapError, UnknownNameError
from mocap_mj.skeleton import rolling

from .meshes import geom_meshes, geom_poses, primitives_mesh
from .playback import Ghost, Playback
from .scene import Layers, Style, decorate, frame_primitives

__all__ = [
    "BACKENDS",
    "FrameRenderer",
    "MujocoFrameRenderer",
    "PyrenderFrameRenderer",
    "View",
    "annotate",
    "camera_id",
    "make_camera",
    "open_renderer",
]

BACKENDS = ("mujoco", "pyrender")

#: Headless set-up advice appended to every "cannot render" error.
GL_HINT = (
    "for headless rendering install Mesa (apt: libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6) "
    "and set MUJOCO_GL=egl PYOPENGL_PLATFORM=egl (or both =osmesa) before starting"
)


@dataclass(frozen=True)
class View:
    """How frames are drawn.

    Parameters
    ----------
    width, height : int
        Image size [px].
    camera : str, optional
        Model camera name, ``"free"``, or None (``front`` if the model has it).
    layers : Layers, optional
        What is drawn besides the model (default: every layer).
    style : Style, optional
        How it is drawn (default: :class:`~mocap_viewer.scene.Style`'s).
    fast : bool
        MuJoCo backend: no multisampling, shadows or reflections, several times faster on a
        software OpenGL (Mesa llvmpipe).
    """

    width: int = 640
    height: int = 480
    camera: str | None = None
    layers: Layers | None = None
    style: Style | None = None
    fast: bool = False


class FrameRenderer(Protocol):
    """Renders frames of a playback; :meth:`close` frees its OpenGL context."""

    width: int
    height: int

    def render(self, frame: int) -> np.ndarray:
        """RGB image (height, width, 3) uint8 of ``frame``."""
        ...

    def close(self) -> None: ...


def camera_id(model: mujoco.MjModel, name: str | None) -> int:
    """Model camera id for ``name``; ``None`` is ``front`` if the model has it, else free (-1)."""
    names = [model.camera(i).name for i in range(model.ncam)]
    if name is None:
        return names.index("front") if "front" in names else -1
    if name == "free":
        return -1
    if name not in names:
        raise UnknownNameError("camera", name, [*names, "free"])
    return names.index(name)


def make_camera(model: mujoco.MjModel, cam_id: int) -> mujoco.MjvCamera:
    """An ``MjvCamera`` looking through model camera ``cam_id``, or the default free camera."""
    cam = mujoco.MjvCamera()
    if cam_id < 0:
        mujoco.mjv_defaultFreeCamera(model, cam)
    else:
        cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        cam.fixedcamid = cam_id
    return cam


def annotate(rgb: np.ndarray, text: str) -> np.ndarray:
    """``rgb`` (H, W, 3) uint8 with one line of ``text`` in its top-left corner."""
    from PIL import Image, ImageDraw, ImageFont

    image = Image.fromarray(rgb)
    size = max(11, rgb.shape[0] // 36)
    try:
        font: ImageFont.ImageFont | ImageFont.FreeTypeFont = ImageFont.load_default(size=size)
    except (TypeError, OSError):  # Pillow without FreeType: the fixed bitmap font
        font = ImageFont.load_default()
    draw = ImageDraw.Draw(image)
    pad = max(4, size // 2)
    box = draw.textbbox((pad, pad), text, font=font)
    draw.rectangle((box[0] - 3, box[1] - 2, box[2] + 3, box[3] + 2), fill=(0, 0, 0))
    draw.text((pad, pad), text, fill=(255, 255, 255), font=font)
    return np.asarray(image)


class MujocoFrameRenderer:
    """Frames through :class:`mujoco.Renderer`, markers and residuals as user geoms.

    Parameters
    ----------
    playback : Playback
    view : View
        Image size (the model's offscreen buffer is enlarged if it is smaller), camera,
        layers, style and quality.
    ghost : Ghost, optional
    """

    def __init__(self, playback: Playback, view: View, ghost: Ghost | None = None) -> None:
        width, height, fast = view.width, view.height, view.fast
        self.playback, self.width, self.height = playback, width, height
        self.ghost, self.layers = ghost, view.layers or Layers()
        self.style, self.fast = view.style or Style(), fast
        model = copy.copy(playback.model)  # the buffer size and quality are set on a copy
        model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
        model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
        if fast:
            model.vis.quality.offsamples = 0
        self.model = model
        self.camera = make_camera(model, camera_id(model, view.camera))
        self.data = mujoco.MjData(model)
        try:
            self._renderer = mujoco.Renderer(model, height, width)
        except Exception as exc:  # GL stacks fail in many ways (FatalError, ImportError, OSError)
            backend = os.environ.get("MUJOCO_GL") or "glfw (default)"
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            if backend.startswith("glfw") and not os.environ.get("DISPLAY"):
                first = "glfw needs a display and there is none"
            raise MocapError(
                f"cannot render with MuJoCo (MUJOCO_GL={backend}): {first}; {GL_HINT}"
            ) from None

    def render(self, frame: int) -> np.ndarray:
        pb, d = self.playback, self.data
        d.qpos[:] = pb.qpos[frame]
        d.time = float(pb.times[frame])
        rolling.kinematics(self.model, d, mujoco.mj_forward)
        self._renderer.update_scene(d, camera=self.camera)
        scn = self._renderer.scene
        if self.fast:
            scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            scn.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        decorate(scn, pb, frame, self.layers, self.style, self.ghost)
        return self._renderer.render().copy()

    def close(self) -> None:
        self._renderer.close()


def _prepare_pyopengl() -> None:
    if "OpenGL" in sys.modules or os.environ.get("PYOPENGL_PLATFORM"):
        return
    mujoco_gl = os.environ.get("MUJOCO_GL", "").strip().lower()
    os.environ["PYOPENGL_PLATFORM"] = "osmesa" if mujoco_gl == "osmesa" else "egl"


def _look_at_pose(pos: np.ndarray, forward: np.ndarray, up: np.ndarray) -> np.ndarray:
    """4 x 4 camera pose (OpenGL convention: looks along -z, y up) from MuJoCo's GL camera."""
    f = forward / np.linalg.norm(forward)
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, f)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, true_up, -f, pos
    return pose


def _light_pose(direction: np.ndarray) -> np.ndarray:
    """Pose of a directional light shining along ``direction`` (its -z axis)."""
    z = -np.asarray(direction, dtype=float)
    z /= np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2] = x, np.cross(z, x), z
    return pose


class PyrenderFrameRenderer:
    """Frames through pyrender, from trimesh meshes of the model's geoms.

    Same parameters as :class:`MujocoFrameRenderer` (the view's ``fast`` changes nothing:
    pyrender draws no shadows or reflections here). The camera (pose and vertical field of
    view) is MuJoCo's own for the frame, read from ``mjv_updateScene`` without OpenGL. Lights:
    the model's lights as directional lights, MuJoCo's headlight, and its ambient term.
    """

    #: pyrender light intensity per unit of MuJoCo diffuse colour.
    LIGHT_GAIN = 2.5

    def __init__(self, playback: Playback, view: View, ghost: Ghost | None = None) -> None:
        _prepare_pyopengl()
        try:
            import pyrender
        except Exception as exc:  # PyOpenGL raises at import when the platform is missing
            raise MocapError(f"cannot load pyrender: {exc}; {GL_HINT}") from None
        self._pyrender = pyrender
        width, height = view.width, view.height
        self.playback, self.width, self.height = playback, width, height
        self.ghost, self.layers = ghost, view.layers or Layers()
        self.style = view.style or Style()
        model = playback.model
        self.data = mujoco.MjData(model)
        self.camera = make_camera(model, camera_id(model, view.camera))
        self._option = mujoco.MjvOption()
        self._mjv_scene = mujoco.MjvScene(model, maxgeom=model.ngeom + 10)

        ambient = np.asarray(model.vis.headlight.ambient, dtype=float)
        scene = pyrender.Scene(bg_color=[0.0, 0.0, 0.0, 1.0], ambient_light=ambient)
        self._geoms = geom_meshes(model)
        self._geom_nodes = [
            scene.add(self._mesh(g.mesh, g.rgba, smooth=not g.static, texture=g.texture))
            for g in self._geoms
        ]
        self._ghost_geoms = geom_meshes(ghost.model, static=False) if ghost is not None else []
        self._ghost_nodes = [
            scene.add(self._mesh(g.mesh, self.style.ghost_rgba, smooth=True))
            for g in self._ghost_geoms
        ]
        for i in range(model.nlight):
            diffuse = np.asarray(model.light_diffuse[i], dtype=float)
            light = pyrender.DirectionalLight(
                color=np.ones(3), intensity=self.LIGHT_GAIN * float(diffuse.mean())
            )
            scene.add(light, pose=_light_pose(model.light_dir[i]))
        self._headlight = None
        if model.vis.headlight.active:
            head = float(np.mean(model.vis.headlight.diffuse))
            self._headlight = scene.add(
                pyrender.DirectionalLight(color=np.ones(3), intensity=self.LIGHT_GAIN * head)
            )
        self._camera_node = scene.add(pyrender.PerspectiveCamera(yfov=1.0))
        self._scene = scene
        self._overlay = None
        try:
            self._renderer = pyrender.OffscreenRenderer(width, height)
        except Exception as exc:  # GL stacks fail in many ways
            platform = os.environ.get("PYOPENGL_PLATFORM", "default")
            raise MocapError(
                f"cannot render with pyrender (PYOPENGL_PLATFORM={platform}): {exc}; {GL_HINT}"
            ) from None

    def _mesh(
        self,
        mesh: trimesh.Trimesh,
        rgba: ArrayLike,
        smooth: bool,
        texture: np.ndarray | None = None,
    ) -> Any:
        pr = self._pyrender
        colour = np.asarray(rgba, dtype=float)
        image = None if texture is None else pr.Texture(source=texture, source_channels="RGB")
        material = pr.MetallicRoughnessMaterial(
            baseColorFactor=colour,
            baseColorTexture=image,
            metallicFactor=0.0,
            roughnessFactor=0.7,
            alphaMode="BLEND" if colour[3] < 1.0 else "OPAQUE",
            doubleSided=True,
        )
        return pr.Mesh.from_trimesh(mesh, material=material, smooth=smooth)

    def _update_camera(self) -> None:
        model = self.playback.model
        mujoco.mjv_updateScene(
            model,
            self.data,
            self._option,
            None,
            self.camera,
            mujoco.mjtCatBit.mjCAT_ALL,
            self._mjv_scene,
        )
        gl = self._mjv_scene.camera[0]
        pose = _look_at_pose(np.array(gl.pos), np.array(gl.forward), np.array(gl.up))
        near = float(gl.frustum_near)
        yfov = 2.0 * math.atan(0.5 * (gl.frustum_top - gl.frustum_bottom) / near)
        cam = self._pyrender.PerspectiveCamera(
            yfov=yfov, znear=near, zfar=float(gl.frustum_far), aspectRatio=self.width / self.height
        )
        self._camera_node.camera = cam
        self._scene.set_pose(self._camera_node, pose)
        if self._headlight is not None:
            self._scene.set_pose(self._headlight, pose)

    def render(self, frame: int) -> np.ndarray:
        pb, d, scene = self.playback, self.data, self._scene
        d.qpos[:] = pb.qpos[frame]
        rolling.kinematics(pb.model, d, mujoco.mj_forward)
        poses = geom_poses(d, [g.geom_id for g in self._geoms])
        for node, pose in zip(self._geom_nodes, poses, strict=True):
            scene.set_pose(node, pose)
        show_ghost = self.ghost is not None and self.layers.ghost
        if self.ghost is not None:
            self.ghost.pose(pb.qpos[frame])
            poses = geom_poses(self.ghost.data, [g.geom_id for g in self._ghost_geoms])
            for node, pose in zip(self._ghost_nodes, poses, strict=True):
                scene.set_pose(node, pose)
                node.mesh.is_visible = show_ghost
        if self._overlay is not None:
            scene.remove_node(self._overlay)
            self._overlay = None
        extra = primitives_mesh(frame_primitives(pb, frame, self.layers, self.style))
        if extra is not None:
            self._overlay = scene.add(self._pyrender.Mesh.from_trimesh(extra, smooth=False))
        self._update_camera()
        color, _ = self._renderer.render(scene)
        return np.ascontiguousarray(color[..., :3], dtype=np.uint8)

    def close(self) -> None:
        self._renderer.delete()


def open_renderer(
    backend: str, playback: Playback, view: View, ghost: Ghost | None = None
) -> FrameRenderer:
    """A frame renderer of ``backend`` (``"mujoco"`` or ``"pyrender"``) drawing ``playback``
    (and ``ghost``, when given) as ``view`` says; close it after use."""
    if view.width < 16 or view.height < 16:
        raise MocapError(f"image size {view.width} x {view.height}: at least 16 x 16 pixels")
    if backend == "mujoco":
        return MujocoFrameRenderer(playback, view, ghost)
    if backend == "pyrender":
        return PyrenderFrameRenderer(playback, view, ghost)
    raise MocapError(f"unknown backend {backend!r}; expected one of {', '.join(BACKENDS)}")
