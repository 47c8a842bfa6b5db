"""The subject's measurements of a command (:mod:`mocap_mj.capture.subject`): the C3D files',
a ``--subject-file`` holding any of them (YAML, or Vicon's ``.vsk`` / ``.mp``), and the two
that a person knows by heart, ``--height`` and ``--mass`` (the flags: :mod:`.options`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from mocap_mj.capture.landmarks import disagreements, measured_widths
from mocap_mj.capture.marker_set import load_marker_set
from mocap_mj.capture.marker_sets import on_bundled_model
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


def with_measured_widths(
    args: argparse.Namespace, names: Sequence[str], trials: Sequence[Any], subject: Subject
) -> Subject:
    """``subject`` with the joint widths that ``--marker-set``'s landmark pairs measure in
    ``trials`` (each with ``markers`` (T, M, 3) [m] in the order ``names``) where none is
    given (:func:`mocap_mj.capture.landmarks.measured_widths`); a given width that differs by more
    than 10 mm is kept and warned about on stderr."""
    subject = with_set_radius(args, subject)
    landmarks, bodies = set_landmarks(args)
    if not landmarks:
        return subject
    found = measured_widths(
        landmarks, bodies, list(names), [t.markers for t in trials], 2 * subject.marker_radius
    )
    given = {m.name: v for m in found if (v := subject.get(m.name)) is not None}
    for line in disagreements(found, given):
        print(f"mocap-mj {args.command}: warning: {line}", file=sys.stderr)
    for m in found:
        if m.name not in given:
            subject.set(m.name, m.value, m.source)
    return subject


def with_set_radius(args: argparse.Namespace, subject: Subject) -> Subject:
    """``subject`` with the marker diameter of the command's marker set (twice its
    ``marker_radius``) when the subject's measurements give none and the set's radius is
    not the default's (Plug-in Gait's 14 mm markers, which ``Subject.marker_radius`` assumes)."""
    from ._markers import set_file

    path = set_file(args)
    if path is None or subject.get("marker_diameter") is not None:
        return subject
    marker_set = load_marker_set(path)
    if marker_set.marker_radius == subject.marker_radius:
        return subject
    out = subject.update(Subject())
    out.set("marker_diameter", 2 * marker_set.marker_radius, f"marker set {path.name}")
    return out


def set_landmarks(args: argparse.Namespace) -> tuple[dict[str, str], dict[str, str]]:
    """``--marker-set``'s landmarks (marker -> landmark) and bodies (marker -> body); empty
    without the flag."""
    from ._markers import set_file

    path = set_file(args)
    if path is None:
        return {}, {}
    marker_set = load_marker_set(path)
    if getattr(args, "model", None) is None and on_bundled_model(marker_set):
        return {}, {}  # the bundled humanoid's own sites, run as the default set
    landmarks = {m.name: m.landmark for m in marker_set.markers if m.landmark}
    return landmarks, {m.name: m.body for m in marker_set.markers}
