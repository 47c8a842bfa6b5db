"""``mocap-mj synth``: write a synthetic experiment (truth model, truth motion, markers)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mocap_mj.commands._removed import add_removed_flags
from mocap_mj.commands.common import add_force_flag, add_json_flag, finish

from .config import MOTIONS, ConfigError, SynthConfig
from .experiment import synthesize, write_experiment

#: Options taking a value: flag, SynthConfig field, type, help. Values are parsed here rather
#: than by argparse, so that a bad value is one line on stderr (exit 2) like every other error.
_OPTIONS: tuple[tuple[str, str, type, str], ...] = (
    ("--frame-count", "frames", int, "number of frames to make (default: 500)"),
    ("--rate", "rate", float, "frame rate in Hz (default: 100)"),
    ("--movement", "motion", str, f"truth motion: {', '.join(MOTIONS)} (default: rom)"),
    ("--noise-mm", "noise_mm", float, "white noise standard deviation per axis, mm (default: 1)"),
    (
        "--sta-mm",
        "sta_mm",
        float,
        "soft-tissue artefact, mm per radian of joint motion (default: 0)",
    ),
    ("--gaps", "gaps", float, "fraction of samples missing in occlusion gaps, [0, 1) (default: 0)"),
    (
        "--outliers",
        "outliers",
        float,
        "fraction of samples displaced as outliers, [0, 1) (default: 0)",
    ),
    ("--outlier-mm", "outlier_mm", float, "outlier displacement, mm (default: 50)"),
    (
        "--swaps",
        "swaps",
        int,
        "left/right marker pairs with swapped labels for a while (default: 0)",
    ),
    ("--seed", "seed", int, "random seed (default: 0)"),
    (
        "--kappa-scale",
        "kappa_scale",
        float,
        "kinematic parameters scaled by 1 -/+ this (default: 0.1)",
    ),
    ("--offset-mm", "offset_mm", float, "marker offsets moved by up to -/+ this, mm (default: 20)"),
    (
        "--marker-placement",
        "marker_placement",
        str,
        "anatomical: landmark markers follow the perturbed skeleton; uniform: every marker "
        "at its nominal offset -/+ --offset-mm, whatever the skeleton (default: anatomical)",
    ),
)


def register(sub: Any) -> None:
    p = sub.add_parser(
        "synth",
        help="write a synthetic experiment: truth model, truth motion, noisy markers",
        description="Synthesize a subject (perturbed model), a truth motion and measured "
        "markers with noise and corruptions; write markers.csv/.trc and the truth files.",
    )
    p.add_argument(
        "--out", required=True, metavar="FOLDER", help="output folder (must be new or empty)"
    )
    for flag, field, _, text in _OPTIONS:
        metavar = "N" if flag == "--frame-count" else flag.lstrip("-").split("-")[0].upper()
        p.add_argument(flag, dest=field, metavar=metavar, help=text)
    p.add_argument(
        "--symmetric", action="store_true", help="perturb left and right alike (mirror images)"
    )
    p.add_argument(
        "--plates",
        action="store_true",
        help="the subject leans onto its right foot, and plates.c3d holds the markers and a "
        "type-2 force plate under that foot with the ground reaction the truth motion needs "
        "(the truth model's inverse dynamics, de Leva's segments for --mass): a ground truth "
        "for the kinetics of ik and identify (default: no plates)",
    )
    p.add_argument(
        "--mass",
        metavar="KG",
        help="body mass of the truth model for --plates, written as PROCESSING:Bodymass "
        "(default: 75)",
    )
    add_force_flag(p)
    add_json_flag(p)
    add_removed_flags(p, "synth")
    p.set_defaults(func=run)


def _parse(flag: str, kind: type, text: str) -> Any:
    if kind is str:
        return text
    try:
        return kind(text)
    except ValueError:
        what = "an integer" if kind is int else "a number"
        raise ConfigError(f"{flag}: expected {what}, got {text!r}") from None


def config_from_args(args: argparse.Namespace) -> SynthConfig:
    """The SynthConfig of the command-line options (unset options keep their defaults)."""
    values: dict[str, Any] = {}
    for flag, field, kind, _ in _OPTIONS:
        text = getattr(args, field)
        if text is not None:
            values[field] = _parse(flag, kind, text)
    try:
        return SynthConfig(symmetric=bool(args.symmetric), **values)
    except ConfigError as exc:
        # name the flag, not the field: "noise_mm: ..." -> "--noise-mm: ..."
        msg = str(exc)
        for flag, field, _, _ in _OPTIONS:
            if msg.startswith(f"{field}:"):
                msg = flag + msg[len(field) :]
                break
        raise ConfigError(msg) from None


def run(args: argparse.Namespace) -> int:
    cfg = config_from_args(args)
    mass = 75.0 if args.mass is None else _parse("--mass", float, args.mass)
    if not 0 < mass < 500:
        raise ConfigError(f"--mass: expected a body mass in (0, 500) kg, got {args.mass}")
    exp = synthesize(cfg)
    if args.plates:
        from .plates import leaning

        exp = leaning(exp, mass)

    def extra(out: Path) -> list[str]:
        from .gait_truth import write_gait_truth  # a walk's events and gait truth

        files = write_gait_truth(exp, out)
        if args.plates:
            from .plates import write_plate_c3d

            files.append(
                write_plate_c3d(out / "plates.c3d", exp, out / "truth_model.xml", mass).name
            )
        return files

    summary = write_experiment(exp, args.out, force=args.force, extra=extra)
    lines = [
        f"wrote {args.out}: {', '.join(summary['files'])}",
        f"motion {cfg.motion}: {cfg.frames} frames at {cfg.rate:g} Hz ({cfg.duration:.2f} s), "
        f"{summary['markers']} markers, seed {cfg.seed}",
        f"truth model: kinematic parameters within {100 * summary['kappa_change_max_rel']:.1f} %,"
        f" marker offsets within {summary['offset_change_max_mm']:.1f} mm of nominal",
        f"noise sigma {cfg.noise_mm:g} mm (measured {summary['noise_std_mm']:.3f} mm), "
        f"soft tissue rms {summary['sta_rms_mm']:.2f} mm",
        f"gaps {100 * summary['gap_fraction']:.2f} % of samples, "
        f"{summary['outlier_count']} outliers of {cfg.outlier_mm:g} mm, "
        f"{len(summary['swapped'])} label swaps",
    ]
    return finish(args, summary, "\n".join(lines))
