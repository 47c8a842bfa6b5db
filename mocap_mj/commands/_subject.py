"""The subject's measurements of a command (:mod:`mocap_mj.capture.subject`): the C3D files',
a ``--subject-file`` holding any of them (YAML, or Vicon's ``.vsk`` / ``.mp``), and the two
that a person knows by heart, ``--height`` and ``--mass`` (the flags: :mod:`.options`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from mocap_mj.capture.subject import Subject, from_c3d, from_values
from mocap_mj.capture.vicon_subject import from_file


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
        ("--height", "height", getattr(args, "height", None)),  # [m]: options.HEIGHT
        ("--mass", "mass", getattr(args, "mass", None)),
    ]
    for flag, name, value in flags:  # each checked against its human range, named by its flag
        subject = subject.update(from_values([(name, value)], flag))
    return subject
