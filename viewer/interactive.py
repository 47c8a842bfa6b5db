"""Interactive playback in MuJoCo's passive viewer (``mujoco.viewer.launch_passive``).

The viewer window runs in a thread of its own; this module's loop (in the calling thread) sets
the pose of the current frame, rebuilds the user scene (markers, residuals, ghost) and the text
overlay, and calls ``sync`` about 60 times a second. Keys reach :meth:`Controls.on_key` on the
viewer's thread: it only changes :class:`Controls` under their own lock, so it never waits for
the viewer. On exit the viewer is closed and its threads are joined (a passive viewer left to
the interpreter's exit can crash it).

Keys: space play/pause, Left/Right one frame back/forward (and pause), Up/Down playback speed
x2 / /2, W jump to the worst frame (largest marker RMSE), M markers, R residuals, G ghost.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass, field, replace
from typing import Any

import mujoco
import numpy as np

from mocap_mj.errors import MocapError
from mocap_mj.skeleton import rolling

from .playback import Ghost, Playback
from .render import camera_id
from .scene import Layers, Style, decorate

__all__ = ["KEYS", "Controls", "run_viewer"]

# GLFW key codes (what the viewer's key callback receives).
KEY_SPACE, KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP = 32, 262, 263, 264, 265
KEY_G, KEY_M, KEY_R, KEY_W = 71, 77, 82, 87

#: Key help shown in the overlay and in docs/viewer.md.
KEYS = (
    ("space", "play / pause"),
    ("Left/Right", "one frame back / forward"),
    ("Up/Down", "speed x2 / /2"),
    ("W", "worst frame"),
    ("M", "markers on/off"),
    ("R", "residuals on/off"),
    ("G", "ghost on/off"),
)

SPEED_MIN, SPEED_MAX = 1.0 / 16.0, 16.0
TICK = 1.0 / 60.0


@dataclass
class Controls:
    """Playback state changed by keys and advanced by the clock.

    Attributes
    ----------
    times : (T,) float [s]
        Frame times of the motion.
    worst : int
        The frame a W jumps to.
    frame : int
        Current frame.
    clock : float [s]
        Current motion time (between frame times while playing).
    playing : bool
    speed : float
        Playback speed, 1 = real time.
    layers : Layers
    """

    times: np.ndarray
    worst: int
    frame: int = 0
    clock: float = 0.0
    playing: bool = True
    speed: float = 1.0
    layers: Layers = field(default_factory=Layers)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    _pressed: list[int] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        self.frame = int(np.clip(self.frame, 0, len(self.times) - 1))
        self.clock = float(self.times[self.frame])

    def _goto(self, frame: int) -> None:
        self.frame = frame % len(self.times)
        self.clock = float(self.times[self.frame])

    def on_key(self, key: int) -> None:
        """Handle one key press (GLFW key code); unknown keys are ignored."""
        with self._lock:
            self._pressed.append(key)
            if key == KEY_SPACE:
                self.playing = not self.playing
            elif key in (KEY_RIGHT, KEY_LEFT):
                self.playing = False
                self._goto(self.frame + (1 if key == KEY_RIGHT else -1))
            elif key == KEY_UP:
                self.speed = min(SPEED_MAX, self.speed * 2.0)
            elif key == KEY_DOWN:
                self.speed = max(SPEED_MIN, self.speed / 2.0)
            elif key == KEY_W:
                self.playing = False
                self._goto(self.worst)
            elif key == KEY_M:
                self.layers.markers = not self.layers.markers
            elif key == KEY_R:
                self.layers.residuals = not self.layers.residuals
            elif key == KEY_G:
                self.layers.ghost = not self.layers.ghost

    def advance(self, wall_dt: float) -> None:
        """Move the clock by ``wall_dt`` [s] of wall time x speed if playing (loops at the end)."""
        with self._lock:
            if not self.playing or len(self.times) < 2:
                return
            t0, t1 = float(self.times[0]), float(self.times[-1])
            span = t1 - t0 + float(np.median(np.diff(self.times)))
            self.clock += wall_dt * self.speed
            if self.clock > t1:
                self.clock = t0 + (self.clock - t0) % span
            self.frame = int(np.searchsorted(self.times, self.clock, side="right") - 1)
            self.frame = max(0, min(self.frame, len(self.times) - 1))

    def take_pressed(self) -> list[int]:
        """The keys pressed since the last call."""
        with self._lock:
            keys, self._pressed = self._pressed, []
            return keys

    def snapshot(self) -> tuple[int, bool, float, Layers]:
        """(frame, playing, speed, a copy of the layers), read consistently."""
        with self._lock:
            return self.frame, self.playing, self.speed, replace(self.layers)


class ShortcutGuard:
    """Undo what the viewer's own shortcuts do for the letters this module uses.

    MuJoCo's viewer also binds W (wireframe), R (reflection), G (fog) and M (centre of mass).
    After such a key, the visualisation flag (``handle.opt.flags``) is toggled back, and the
    rendering flag is restored through ``handle.user_scn.flags``, which the viewer applies only
    when it changes: set to the other value for one update, then back to the original.
    """

    def __init__(self, handle: Any) -> None:
        ours = {chr(k) for k in (KEY_G, KEY_M, KEY_R, KEY_W)}
        self.rnd = {ord(c): i for i, (_, _, c) in enumerate(mujoco.mjRNDSTRING) if c in ours}
        self.vis = {ord(c): i for i, (_, _, c) in enumerate(mujoco.mjVISSTRING) if c in ours}
        self.original = np.array(handle.user_scn.flags, dtype=np.uint8)
        self.stage: dict[int, int] = {}

    def pressed(self, handle: Any, keys: list[int]) -> None:
        """Call under ``handle.lock()`` with the keys pressed since the last update."""
        for key in keys:
            if key in self.vis:
                flags = handle.opt.flags
                flags[self.vis[key]] = 1 - flags[self.vis[key]]
            if key in self.rnd:
                self.stage[self.rnd[key]] = 2

    def update(self, handle: Any) -> None:
        """Call under ``handle.lock()`` before every ``sync``."""
        flags = handle.user_scn.flags
        for i, stage in list(self.stage.items()):
            flags[i] = 1 - self.original[i] if stage == 2 else self.original[i]
            if stage == 2:
                self.stage[i] = 1
            else:
                del self.stage[i]


def _overlay(pb: Playback, frame: int, playing: bool, speed: float, ghost: bool) -> list[Any]:
    rmse = pb.frame_rmse[frame] if pb.fitted else np.nan
    labels = ["frame", "time", "marker RMSE", "speed", ""]
    number = pb.first_frame + frame  # the recording's; --frame counts rows
    values = [
        f"{number} (row {frame} / {pb.n_frames - 1})"
        if number != frame
        else f"{frame} / {pb.n_frames - 1}",
        f"{pb.times[frame]:.3f} s",
        "no data (not solved)"
        if not pb.solved[frame]
        else "-"
        if np.isnan(rmse)
        else f"{1000 * rmse:.1f} mm",
        f"x{speed:g}",
        "playing" if playing else "paused",
    ]
    keys = [k for k in KEYS if ghost or k[0] != "G"]
    return [
        (
            mujoco.mjtFontScale.mjFONTSCALE_150,
            mujoco.mjtGridPos.mjGRID_TOPLEFT,
            "\n".join(labels),
            "\n".join(values),
        ),
        (
            mujoco.mjtFontScale.mjFONTSCALE_100,
            mujoco.mjtGridPos.mjGRID_BOTTOMLEFT,
            "\n".join(k for k, _ in keys),
            "\n".join(v for _, v in keys),
        ),
    ]


def _set_camera(handle: Any, model: mujoco.MjModel, camera: str | None) -> None:
    cam = handle.cam
    if camera is not None:
        cid = camera_id(model, camera)
        if cid >= 0:
            cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
            cam.fixedcamid = cid
            return
    # Default: follow the root body, seen from the front-left and slightly above.
    cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    cam.trackbodyid = 1 if model.nbody > 1 else 0
    cam.distance = 1.5 * float(model.stat.extent)
    cam.azimuth = 150.0
    cam.elevation = -15.0


def _viewer_module(playback: Playback, camera: str | None) -> Any:
    """``mujoco.viewer``, after refusing no display and an unknown ``camera`` (before a
    window opens)."""
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise MocapError(
            "no display for the viewer: run it on a desktop, under xvfb-run, "
            "or render a file with 'mocap-mj render'"
        )
    if camera is not None:
        camera_id(playback.model, camera)  # unknown names fail before a window opens
    try:
        from mujoco import viewer as mj_viewer
    except Exception as exc:  # glfw missing or without its library
        raise MocapError(f"the MuJoCo viewer is unavailable: {exc}") from None
    return mj_viewer


def _controls(
    playback: Playback, start: int, speed: float, paused: bool, ghost: Ghost | None
) -> Controls:
    """The keyboard's state at the start: frame ``start``, ``speed``, playing unless
    ``paused`` or a single frame, the ghost layer off without a ghost."""
    controls = Controls(playback.times, playback.worst_frame, frame=start, speed=speed)
    controls.playing = not paused and playback.n_frames > 1
    if ghost is None:
        controls.layers.ghost = False
    return controls


def _launch(
    mj_viewer: Any, model: mujoco.MjModel, data: mujoco.MjData, controls: Controls
) -> tuple[Any, list[threading.Thread]]:
    """Open the passive viewer window; its handle and the threads it started (joined when
    it closes)."""
    before = set(threading.enumerate())
    try:
        handle = mj_viewer.launch_passive(
            model, data, key_callback=controls.on_key, show_left_ui=False, show_right_ui=False
        )
    except Exception as exc:
        raise MocapError(f"cannot open the viewer window: {exc}") from None
    return handle, [t for t in threading.enumerate() if t not in before]


def _pose(
    handle: Any,
    data: mujoco.MjData,
    playback: Playback,
    frame: int,
    layers: Any,
    style: Style,
    ghost: Ghost | None,
) -> None:
    """Pose the viewer's model at ``frame`` and draw its markers, residuals and ghost (the
    caller holds the viewer's lock). A frame not solved has no pose: the body is hidden (its
    geoms transparent, at the model's reference pose) and the overlay says "no data"."""
    solved = bool(playback.solved[frame])
    playback.show_body(solved)
    data.qpos[:] = playback.qpos[frame] if solved else playback.model.qpos0
    data.time = float(playback.times[frame])
    rolling.kinematics(playback.model, data, mujoco.mj_forward)
    scn = handle.user_scn
    scn.ngeom = 0
    decorate(scn, playback, frame, layers, style, ghost if layers.ghost and solved else None)


def run_viewer(
    playback: Playback,
    *,
    ghost: Ghost | None = None,
    duration: float | None = None,
    speed: float = 1.0,
    start: int = 0,
    paused: bool = False,
    camera: str | None = None,
    style: Style | None = None,
) -> dict[str, Any]:
    """Play ``playback`` in MuJoCo's passive viewer until the window closes or ``duration``.

    Parameters
    ----------
    playback : Playback
    ghost : Ghost, optional
        Second model drawn translucent in the same poses (G toggles it).
    duration : float, optional
        Close the viewer by itself after this many seconds [s] of wall time.
    speed : float
        Initial playback speed (1 = real time).
    start : int
        First frame shown.
    paused : bool
        Start paused.
    camera : str, optional
        A model camera to look through; by default a free camera tracking the root body.
    style : Style, optional

    Returns
    -------
    dict
        ``seconds`` (wall time open), ``updates`` (scene updates), ``last_frame``.

    Raises
    ------
    MocapError
        Without a display (use ``xvfb-run``, or ``mocap-mj render``), or if the window cannot
        be opened.
    """
    mj_viewer = _viewer_module(playback, camera)
    style = style or Style()
    model = playback.model
    data = mujoco.MjData(model)
    controls = _controls(playback, start, speed, paused, ghost)

    handle, threads = _launch(mj_viewer, model, data, controls)
    updates = 0
    opened = time.monotonic()
    last = opened
    frame = start
    try:
        with handle.lock():
            _set_camera(handle, model, camera)
            guard = ShortcutGuard(handle)
        while handle.is_running():
            now = time.monotonic()
            if duration is not None and now - opened >= duration:
                break
            controls.advance(now - last)
            last = now
            frame, playing, spd, layers = controls.snapshot()
            pressed = controls.take_pressed()
            with handle.lock():
                guard.pressed(handle, pressed)
                guard.update(handle)
                _pose(handle, data, playback, frame, layers, style, ghost)
            handle.set_texts(_overlay(playback, frame, playing, spd, ghost is not None))
            handle.sync()
            updates += 1
            time.sleep(max(0.0, TICK - (time.monotonic() - now)))
    finally:
        handle.close()
        for thread in threads:
            thread.join(timeout=10.0)
    return {"seconds": round(time.monotonic() - opened, 3), "updates": updates, "last_frame": frame}
