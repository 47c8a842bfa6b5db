"""Command-line options for the subject's measurements (:mod:`mocap_mj.capture.subject`): a
``--subject-file`` holding any of them (YAML, or Vicon's ``.vsk`` / ``.mp``), and the two
that a person knows by heart, ``--height`` and ``--mass``."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from mocap_mj.capture.subject import Subject, from_c3d, from_values
from mocap_mj.capture.vicon_subject import from_file


def add_subject_options(p: Any) -> None:
    """``--subject-file``, ``--height`` and ``--mass``."""
    g = p.add_argument_group(
        "subject measurements (override those in the C3D files' PROCESSING/SUBJECTS groups)"
    )
    g.add_argument(
        "--subject-file",
        metavar="FILE",
        help="subject measurements: a YAML file, name: value in SI units or with a unit "
        "('knee_width_l: 105 mm'), names as in summary.json's 'measurements'; or Vicon's "
        ".vsk or .mp subject file (Plug-in Gait's names, mm and kg, as in the C3D's "
        "PROCESSING group); docs/cli.md#subject-file (default: none)",
    )
    g.add_argument(
        "--height",
        type=float,
        metavar="MM",
        help="standing height [mm] (default: from the subject file or the C3D, else none)",
    )
    g.add_argument(
        "--mass",
        type=float,
        metavar="KG",
        help="body mass [kg] (default: from the subject file or the C3D, else none)",
    )


def subject_from_args(args: argparse.Namespace, c3d_paths: Sequence[str]) -> Subject:
    """Measurements of the C3D files (first file that has each), the YAML file, then flags."""
    subject = Subject()
    for path in c3d_paths:
        if str(path).lower().endswith(".c3d"):
            found = from_c3d(path)
            subject = found.update(subject)  # earlier files win
    if getattr(args, "subject_file", None):
        subject = subject.update(from_file(args.subject_file))
    flags: list[tuple[str, str, float | None]] = [
        (
            "--height",
            "height",
            None if getattr(args, "height", None) is None else args.height * 1e-3,
        ),
        ("--mass", "mass", getattr(args, "mass", None)),
    ]
    for flag, name, value in flags:  # each checked against its human range, named by its flag
        subject = subject.update(from_values([(name, value)], flag))
    return subject
