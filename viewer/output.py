"""Rendering a playback to a file: one PNG frame, or an MP4 or GIF of a frame range.

Every file is written atomically (a temporary file beside it, renamed when complete). MP4 goes
through imageio's ffmpeg writer (imageio-ffmpeg ships its own ffmpeg binary; H.264, yuv420p, so
the image size is rounded up to even numbers); GIF through Pillow (one palette per frame).
"""

from __future__ import annotations

import io
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.errors import MocapError
from mocap_mj.io.atomic import atomic_path, atomic_write_bytes

from .playback import Ghost, Playback, frame_label
from .render import View, annotate, open_renderer

__all__ = [
    "FORMATS",
    "PROGRESS_MIN_FRAMES",
    "render_to_file",
    "write_gif",
    "write_mp4",
    "write_png",
]

FORMATS = (".png", ".mp4", ".gif")
#: A progress bar is shown when a video has more frames than this.
PROGRESS_MIN_FRAMES = 50


def write_png(path: str | Path, rgb: np.ndarray) -> None:
    """Write an RGB image (H, W, 3) uint8 as PNG, atomically."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())


def write_mp4(path: str | Path, images: Iterator[np.ndarray], fps: float) -> int:
    """Write RGB images (H, W, 3) uint8 (H and W even) as an H.264 MP4; return the count."""
    import imageio.v2 as imageio

    n = 0
    with atomic_path(path) as tmp:
        writer = imageio.get_writer(
            str(tmp),
            format="FFMPEG",
            mode="I",
            fps=fps,
            codec="libx264",
            quality=7,
            pixelformat="yuv420p",
            macro_block_size=1,
            ffmpeg_log_level="error",
        )
        try:
            for rgb in images:
                writer.append_data(rgb)
                n += 1
        finally:
            writer.close()
    return n


def write_gif(path: str | Path, images: Iterator[np.ndarray], fps: float) -> int:
    """Write RGB images (H, W, 3) uint8 as a looping GIF; return the count.

    GIF frame delays are whole centiseconds, so the rate is rounded to 100/k fps.
    """
    from PIL import Image

    frames = [Image.fromarray(rgb).quantize(colors=255, method=Image.Quantize.MEDIANCUT)
              for rgb in images]  # fmt: skip
    if not frames:
        raise MocapError(f"{path}: no frame to write")
    delay = max(10, round(100.0 / fps) * 10)
    buf = io.BytesIO()
    frames[0].save(
        buf,
        format="GIF",
        save_all=True,
        append_images=frames[1:],
        duration=delay,
        loop=0,
        disposal=1,
    )
    atomic_write_bytes(path, buf.getvalue())
    return len(frames)


def _progress(items: Sequence[int], label: str) -> Iterator[int]:
    if len(items) <= PROGRESS_MIN_FRAMES:
        yield from items
        return
    from tqdm import tqdm

    yield from tqdm(items, desc=label, unit="frame", leave=False, disable=None)


def _write(out: Path, images: Iterator[np.ndarray], fps: float) -> int:
    """Write ``images`` (each (H, W, 3) uint8) to ``out`` by its suffix (a PNG: the first
    only), the video at ``fps`` [Hz]; the number of images written."""
    suffix = out.suffix.lower()
    if suffix == ".png":
        write_png(out, next(images))
        return 1
    if suffix == ".mp4":
        return write_mp4(out, images, fps)
    return write_gif(out, images, fps)


def _checked_request(out: Path, frames: Sequence[int], rate: float, fps: float | None) -> float:
    """Refuse an unknown format, no frame, or several frames for a PNG; the video's frame
    rate [Hz]: ``fps``, by default real time (``rate`` / the frame step)."""
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise MocapError(f"{out}: unknown output format; expected one of {', '.join(FORMATS)}")
    if not frames:
        raise MocapError("no frame to render")
    if suffix == ".png" and len(frames) != 1:
        raise MocapError(f"{out}: a PNG holds one frame; use --frame K, or .mp4/.gif for a range")
    if fps is None:
        step = abs(frames[1] - frames[0]) if len(frames) > 1 else 1
        fps = rate / max(step, 1)
    if not fps > 0:
        raise MocapError(f"--fps must be positive, got {fps}")
    return fps


def render_to_file(
    playback: Playback,
    out: str | Path,
    frames: Sequence[int],
    *,
    backend: str = "mujoco",
    view: View | None = None,
    ghost: Ghost | None = None,
    fps: float | None = None,
    text: bool = True,
) -> dict[str, Any]:
    """Render ``frames`` of ``playback`` to ``out`` (``.png``: one frame; ``.mp4``, ``.gif``).

    Parameters
    ----------
    playback : Playback
    out : path
        Output file; its suffix chooses the format. Its folder is created if needed.
    frames : sequence of int
        Frame indices, in the order they are shown.
    backend : {"mujoco", "pyrender"}
    view : View, optional
        Image size (rounded up to even numbers for MP4), camera, layers, style and quality;
        by default :class:`~mocap_viewer.render.View`'s (640 x 480 px).
    ghost : Ghost, optional
        Second model drawn translucent in the same poses.
    fps : float, optional
        Video frame rate [Hz]; by default the motion's real time (frame rate / frame step).
    text : bool
        Write the frame number, time and marker RMSE in the top-left corner.

    Returns
    -------
    dict
        ``out``, ``format``, ``frames`` (count), ``first``, ``last``, ``width``, ``height``,
        ``fps`` and ``frames_without_data`` (videos: the frames drawn as "no data"),
        ``backend``, ``camera``.
    """
    out = Path(out)
    suffix = out.suffix.lower()
    fps = _checked_request(out, frames, playback.rate, fps)
    _refuse_unsolved(playback, frames)
    view = view or View()
    if suffix == ".mp4":
        view = replace(
            view, width=view.width + view.width % 2, height=view.height + view.height % 2
        )
    width, height = view.width, view.height
    out.parent.mkdir(parents=True, exist_ok=True)
    renderer = open_renderer(backend, playback, view, ghost)

    def images() -> Iterator[np.ndarray]:
        for k in _progress(frames, out.name):
            # a frame not solved has no pose: an empty image that says so, not a black one
            rgb = renderer.render(k) if playback.solved[k] else no_data_image(width, height)
            yield annotate(rgb, frame_label(playback, k)) if text or not playback.solved[k] else rgb

    try:
        count = _write(out, images(), fps)
    finally:
        renderer.close()
    summary: dict[str, Any] = {"out": str(out), "format": suffix[1:], "frames": count,
                               "first": int(frames[0]), "last": int(frames[-1]),
                               "width": width, "height": height, "backend": backend,
                               "camera": view.camera or "default"}  # fmt: skip
    if suffix != ".png":
        summary["fps"] = float(fps)
        summary["frames_without_data"] = int(np.sum(~playback.solved[list(frames)]))
    return summary


#: The grey of a frame without data (not solved), RGB.
NO_DATA_GREY = 96


def no_data_image(width: int, height: int) -> np.ndarray:
    """The image (H, W, 3) uint8 of a frame not solved: plain grey, labelled by the caller."""
    return np.full((height, width, 3), NO_DATA_GREY, dtype=np.uint8)


def _refuse_unsolved(playback: Playback, frames: Sequence[int]) -> None:
    """Refuse frames none of which was solved (a PNG of one such frame included), naming
    the nearest solved frames; a video of some is drawn, its unsolved frames as "no data"."""
    solved = playback.solved
    if any(solved[k] for k in frames):
        return
    which = np.flatnonzero(solved)
    k = frames[0]
    number = playback.first_frame + k
    if not len(which):
        raise MocapError(f"{playback.source}: no frame of the motion was solved: nothing to draw")
    near = [str(int(v)) for v in (*which[which < k][-1:], *which[which > k][:1])]
    raise MocapError(
        f"{playback.source}: frame {k} (the recording's {number}) was not solved (too few "
        f"markers): no pose to draw; nearest solved rows: {', '.join(near)} (--frame)"
        if len(frames) == 1
        else f"{playback.source}: none of the {len(frames)} frames asked for was solved"
    )
