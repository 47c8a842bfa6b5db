"""``mocap-mj view``, ``render`` and the GLB exporter: registered through the ``mocap_mj.commands``
entry point (``view = "mocap_viewer.cli:register"``), so the library never imports the viewer.

``view``     interactive playback in MuJoCo's viewer (needs a display).
``render``   offscreen PNG / MP4 / GIF (needs EGL or OSMesa without a display).
``export --to glb`` (or the older ``export DIR --glb F``): GLB scene of one frame or a range
(no OpenGL), through :data:`GLB_EXPORTER` in the ``mocap_mj.exporters`` entry-point group.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mocap_mj.commands._inputs import refuse_replacing_file
from mocap_mj.commands._removed import add_removed_flags
from mocap_mj.commands.common import add_force_flag, add_json_flag, add_trial_flag, finish
from mocap_mj.errors import MocapError
from mocap_mj.export.registry import Exporter

if TYPE_CHECKING:
    from .playback import Ghost, Playback

# The playback (MuJoCo, NumPy) is imported when a command runs, not for --help.

__all__ = ["register"]


def _add_source(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "result",
        nargs="?",
        metavar="RESULT_DIR",
        help="result folder (model.xml + motion.npz), synthetic-truth folder, or a demo "
        "folder (its result/ is shown)",
    )
    add_trial_flag(p)
    _add_source_options(p)


def _add_source_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--model",
        metavar="MJCF",
        help="MJCF file, instead of a result folder (default: the bundled humanoid)",
    )
    p.add_argument(
        "--motion",
        metavar="FILE",
        help="motion .npz for --model (poses and markers; default: none)",
    )
    p.add_argument(
        "--markers",
        metavar="FILE",
        help="marker file for --model; without --motion the model stands at its reference pose "
        "(default: none)",
    )
    p.add_argument(
        "--ghost",
        metavar="MJCF",
        help="second model drawn translucent in the same poses: an MJCF file, 'nominal' "
        "(the bundled humanoid) or 'truth' (truth_model.xml in RESULT_DIR, RESULT_DIR/synth or "
        "the synth/ beside it) (default: none)",
    )


def _add_frames(p: argparse.ArgumentParser) -> None:
    group = p.add_mutually_exclusive_group()
    group.add_argument(
        "--frame",
        metavar="K",
        help="one frame: its row in the motion, 0 its first (negative from the end), or "
        "'worst'; a frame not solved (too few markers) has no pose and is refused (default: "
        "the first solved frame for a .png or .glb, every frame for .mp4/.gif, those not "
        "solved drawn as 'no data')",
    )
    group.add_argument(
        "--frames",
        metavar="A:B[:S]",
        help="frames from A up to but excluding B, every S-th (a Python slice, e.g. 0:100; "
        "default: as --frame)",
    )


def _load(args: argparse.Namespace) -> tuple[Playback, Ghost | None]:
    from .playback import load_ghost, load_playback

    playback = load_playback(
        args.result,
        model=args.model,
        motion=args.motion,
        markers=args.markers,
        trial=getattr(args, "trial", None),
    )
    ghost = None
    if args.ghost:
        ghost = load_ghost(args.ghost, playback.model, args.result)
    return playback, ghost


def _frames(args: argparse.Namespace, playback: Playback, default_all: bool) -> list[int]:
    from .playback import parse_frame, parse_frames

    if args.frame is not None:
        return [parse_frame(args.frame, playback)]
    if args.frames is not None:
        return parse_frames(args.frames, playback.n_frames)
    return list(range(playback.n_frames)) if default_all else [playback.first_solved()]


def _image_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> (width, height) in pixels, both positive."""
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WxH in pixels, e.g. 640x480, got {text!r}"
        ) from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"expected positive pixels, got {text!r}")
    return width, height


def _positive(kind: type) -> Any:
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
        return value

    return parse


# ------------------------------------------------------------------------------- view
def _run_view(args: argparse.Namespace) -> int:
    from .interactive import run_viewer
    from .playback import parse_frame

    playback, ghost = _load(args)
    start = parse_frame(args.frame, playback) if args.frame is not None else 0
    summary = run_viewer(
        playback,
        ghost=ghost,
        duration=args.duration,
        speed=args.speed,
        start=start,
        paused=args.paused,
        camera=args.camera,
    )
    summary = {"source": playback.source, "frames": playback.n_frames, **summary}
    text = f"viewer closed after {summary['seconds']:.1f} s ({summary['updates']} updates)"
    return finish(args, summary, text)


# ----------------------------------------------------------------------------- render
def _run_render(args: argparse.Namespace) -> int:
    from .output import FORMATS, render_to_file
    from .render import View
    from .scene import Layers

    out = Path(args.out)
    if out.suffix.lower() not in FORMATS:
        raise MocapError(f"--out {out}: expected a {', '.join(FORMATS)} file")
    refuse_replacing_file(out, force=args.force)
    playback, ghost = _load(args)
    frames = _frames(args, playback, default_all=out.suffix.lower() != ".png")
    layers = Layers(markers=not args.no_markers, residuals=not args.no_residuals)
    view = View(args.size[0], args.size[1], args.camera, layers=layers, fast=args.fast)
    summary = render_to_file(
        playback,
        out,
        frames,
        backend=args.backend,
        view=view,
        ghost=ghost,
        fps=args.fps,
        text=not args.no_text,
    )
    what = "frame" if summary["frames"] == 1 else "frames"
    text = (
        f"wrote {summary['out']}: {summary['frames']} {what} "
        f"({summary['width']} x {summary['height']}, {summary['backend']})"
    )
    return finish(args, summary, text)


# ----------------------------------------------------------------------------- export
def _export_glb(args: argparse.Namespace) -> dict[str, Any]:
    from .glb import export_glb

    if Path(args.out).suffix.lower() != ".glb":
        raise MocapError(f"--out {args.out}: expected a .glb file")
    playback, ghost = _load(args)
    frames = _frames(args, playback, default_all=False)
    return export_glb(
        playback, args.out, frames, markers=args.with_markers, ghost=ghost, floor=args.floor
    )


class _LegacyGlb(argparse.Action):
    """``--glb F``: the old spelling of ``--to glb --out F``."""

    def __call__(self, parser: Any, namespace: Any, values: Any, option: Any = None) -> None:
        namespace.to, namespace.out = "glb", values


def _add_glb_arguments(p: argparse.ArgumentParser) -> None:
    _add_source_options(p)
    p.add_argument(
        "--glb",
        action=_LegacyGlb,
        metavar="FILE",
        help="same as --to glb --out FILE (default: none)",
    )
    _add_frames(p)
    p.add_argument(
        "--with-markers",
        action="store_true",
        help="glb: add markers and residuals, one mesh per frame",
    )
    p.add_argument("--floor", action="store_true", help="glb: add the world's geoms (the floor)")


#: ``mocap-mj export --to glb``: the posed model of one frame (default: frame 0) or a range as
#: a GLB scene, one node set per frame (trimesh writes no glTF animation). Registered in the
#: ``mocap_mj.exporters`` entry-point group.
GLB_EXPORTER = Exporter(
    name="glb",
    suffix=".glb",
    help="GLB scene of posed frames (--frame/--frames, --with-markers, --floor, --ghost)",
    run=_export_glb,
    add_arguments=_add_glb_arguments,
)


def register(sub: Any) -> None:
    """Add the ``view`` and ``render`` subcommands to ``mocap-mj`` (``export --to glb`` is
    :data:`GLB_EXPORTER`)."""
    p = sub.add_parser(
        "view",
        help="play a result in MuJoCo's interactive viewer",
        description="Play a fitted motion at real time with its markers and residuals (needs a "
        "display). Keys: "
        "space play/pause, Left/Right step, Up/Down speed, W worst frame, M markers, "
        "R residuals, G ghost.",
    )
    _add_source(p)
    p.add_argument("--frame", metavar="K", help="first frame shown: index or 'worst' (default: 0)")
    p.add_argument(
        "--duration",
        type=_positive(float),
        metavar="S",
        help="close by itself after S seconds (default: when the window is closed)",
    )
    p.add_argument(
        "--speed",
        type=_positive(float),
        default=1.0,
        metavar="X",
        help="playback speed, 1 = real time (default: 1)",
    )
    p.add_argument("--paused", action="store_true", help="start paused")
    p.add_argument(
        "--camera",
        metavar="NAME",
        help="look through this model camera (default: free, tracking)",
    )
    add_json_flag(p)
    p.set_defaults(func=_run_view)
    _register_render(sub)


def _register_render(sub: Any) -> None:
    """The ``render`` subcommand."""
    p = sub.add_parser(
        "render",
        help="render a result offscreen to PNG, MP4 or GIF",
        description="Offscreen rendering of the posed model, markers and residuals. Without a "
        "display, set MUJOCO_GL=egl (or osmesa) and PYOPENGL_PLATFORM alike.",
    )
    _add_source(p)
    p.add_argument(
        "--out",
        required=True,
        metavar="FILE",
        help="output .png (one frame; default frame 0), .mp4 or .gif (default: all frames)",
    )
    _add_frames(p)
    p.add_argument(
        "--size",
        type=_image_size,
        default=(640, 480),
        metavar="WxH",
        help="image width and height in pixels, e.g. 1280x720 (default: 640x480)",
    )
    p.add_argument(
        "--camera",
        metavar="NAME",
        help="model camera or 'free' (default: 'front' if the model has it)",
    )
    p.add_argument(
        "--backend",
        choices=("mujoco", "pyrender"),
        default="mujoco",
        help="renderer (default: mujoco)",
    )
    p.add_argument(
        "--fps",
        type=_positive(float),
        metavar="HZ",
        help="video frame rate (default: the motion's rate, real time)",
    )
    p.add_argument("--no-markers", action="store_true", help="do not draw markers")
    p.add_argument("--no-residuals", action="store_true", help="do not draw residuals")
    p.add_argument("--no-text", action="store_true", help="no frame/time/RMSE label")
    p.add_argument(
        "--fast",
        action="store_true",
        help="no antialiasing, shadows or reflections (much faster on software OpenGL)",
    )
    add_force_flag(p)
    add_json_flag(p)
    add_removed_flags(p, "render")
    p.set_defaults(func=_run_render)
