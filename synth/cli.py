"""The add-on's commands: ``mocap-mj synth`` (a synthetic experiment: truth model, truth motion,
markers), and the flags of ``demo`` and ``experiment``, whose work (:mod:`~mocap_synth.demo`,
:mod:`~mocap_synth.experiment_paper`) is imported when they run, so that ``--help`` loads no
NumPy or MuJoCo."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mocap_mj.commands._removed import add_removed_flags
from mocap_mj.commands.common import add_force_flag, add_json_flag, finish
from mocap_mj.commands.parsers import Lazy, description

from .config import MOTIONS, POSES, ConfigError, SynthConfig

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
        "--pose",
        "pose",
        str,
        f"posture a static holds and a rom or walk starts in: {'|'.join(POSES)} (default: "
        "neutral, standing with the arms at the sides)",
    ),
    (
        "--heading",
        "heading_deg",
        float,
        "turn the whole capture about the vertical by this many degrees, so that the subject "
        "faces another direction (default: 0, facing +x)",
    ),
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
    for flag, field, kind, text in _OPTIONS:
        # the placeholders of the other commands: MM for a length in mm, N for a count
        metavar = "MM" if flag.endswith("-mm") else "N" if kind is int else None
        metavar = metavar or {"--heading": "DEG", "--pose": "NAME"}.get(flag)
        metavar = metavar or flag.lstrip("-").split("-")[0].upper()
        p.add_argument(flag, dest=field, metavar=metavar, help=text)
    p.add_argument(
        "--symmetric", action="store_true", help="perturb left and right alike (mirror images)"
    )
    p.add_argument(
        "--with-plate",
        dest="plates",
        nargs="?",
        const="75",
        metavar="KG",
        help="the subject leans onto its right foot, and plates.c3d holds the markers and a "
        "type-2 force plate under that foot with the ground reaction the truth motion needs "
        "(the truth model's inverse dynamics, de Leva's segments for a body of KG, written as "
        "PROCESSING:Bodymass; 75 without a value): a ground truth for the kinetics of ik and "
        "identify (default: no plates)",
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
    from .experiment import synthesize, write_experiment

    cfg = config_from_args(args)
    mass = 75.0 if args.plates is None else _parse("--with-plate", float, args.plates)
    if not 0 < mass < 500:
        raise ConfigError(f"--with-plate: expected a body mass in (0, 500) kg, got {args.plates}")
    exp = synthesize(cfg)
    if args.plates is not None:
        from .plates import leaning

        exp = leaning(exp, mass)

    def extra(out: Path) -> list[str]:
        from .gait_truth import write_gait_truth  # a walk's events and gait truth

        files = write_gait_truth(exp, out)
        if args.plates is not None:
            from .plates import write_plate_c3d

            files.append(
                write_plate_c3d(out / "plates.c3d", exp, out / "truth_model.xml", mass).name
            )
        return files

    summary = write_experiment(exp, args.out, force=args.force, extra=extra)
    posed = "" if cfg.pose == "neutral" else f" from the {cfg.pose} posture"
    turned = "" if cfg.heading_deg == 0 else f", turned {cfg.heading_deg:g} deg"
    lines = [
        f"wrote {args.out}: {', '.join(summary['files'])}",
        f"motion {cfg.motion}{posed}{turned}: {cfg.frames} frames at {cfg.rate:g} Hz "
        f"({cfg.duration:.2f} s), "
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


def register_demo(sub: Any) -> None:
    p = sub.add_parser(
        "demo",
        help="synthesize, identify and score on the bundled model",
        description=description("mocap_synth.demo").split("\n\n", 1)[1].split("\n\n")[0],
    )
    p.add_argument(
        "--out",
        default="demo-result",
        metavar="FOLDER",
        help="output folder, must be new or empty (default: demo-result)",
    )
    p.add_argument(
        "--frame-count",
        dest="frames",
        type=int,
        default=500,
        metavar="N",
        help="frames of the range-of-motion trial to fit (default: 500)",
    )
    p.add_argument(
        "--holdout",
        type=int,
        default=200,
        metavar="N",
        help="frames of the held-out walking trial (default: 200)",
    )
    p.add_argument(
        "--noise-mm",
        type=float,
        default=1.0,
        metavar="MM",
        help="marker noise, standard deviation per axis in mm (default: 1)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        metavar="N",
        help="seed of the truth model, motion and noise (default: 0)",
    )
    add_force_flag(p)
    add_json_flag(p)
    add_removed_flags(p, "demo")
    p.set_defaults(func=Lazy("mocap_synth.demo"))


def register_experiment(sub: Any) -> None:
    p = sub.add_parser(
        "experiment",
        help="reproduce a published experiment on synthetic data",
        description="Reproduce a published experiment on synthetic data: `paper` (Table 1 and "
        "Figs 3-4 of Zou & Sugihara) or `paper-steps` (how Algorithm 1's step sizes were "
        "chosen). Each writes its report and figures into --out.",
    )
    kinds = p.add_subparsers(dest="experiment", metavar="EXPERIMENT", required=True)
    q = kinds.add_parser(
        "paper",
        help="Table 1 and Figs 3-4 of Zou & Sugihara (Algorithm 1's samplings vs joint LM)",
        description="Identify a synthetic 5 s trial with Algorithm 1 (batch, even, random, "
        "stochastic sampling) and the joint LM; write Table 1, Figs 3-4 and the raw numbers.",
    )
    q.add_argument(
        "--out", required=True, metavar="FOLDER", help="output folder (must be new or empty)"
    )
    q.add_argument("--quick", action="store_true", help="100 frames and few iterations (CI)")
    q.add_argument(
        "--seed",
        type=int,
        default=0,
        metavar="N",
        help="seed of the truth model, motion, noise and sampling (default: 0)",
    )
    q.add_argument(
        "--batch-iterations",
        type=int,
        metavar="N",
        help="iterations batch sampling is really run; the rest of its curve is extrapolated "
        "(default: the experiment's, all of them)",
    )
    add_force_flag(q)
    add_json_flag(q)
    q.set_defaults(func=Lazy("mocap_synth.experiment_paper"))
    t = kinds.add_parser(
        "paper-steps",
        help="how Algorithm 1's alpha, Delta and perturbed-IK iterations were chosen",
        description="Measure Algorithm 1 on a 100-frame synthetic trial for several alpha, "
        "Delta and perturbed-IK iteration counts (docs/paper.md).",
    )
    t.add_argument(
        "--out", required=True, metavar="FOLDER", help="output folder (must be new or empty)"
    )
    add_force_flag(t)
    add_json_flag(t)
    t.set_defaults(func=Lazy("mocap_synth.experiment_paper", "run_steps"))
