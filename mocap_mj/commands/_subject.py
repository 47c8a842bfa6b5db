"""Command-line options for the subject's measurements (:mod:`mocap_mj.subject`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from ..errors import MocapError
from ..landmarks import disagreements, measured_widths
from ..marker_set import load_marker_set
from ..subject import Subject, from_c3d, from_values, from_yaml

#: Flag -> measurement base name; sided ones take one value (both sides) or two (left right).
_SIDED = {
    "leg-length": "leg_length",
    "knee-width": "knee_width",
    "ankle-width": "ankle_width",
    "elbow-width": "elbow_width",
    "wrist-width": "wrist_width",
    "hand-thickness": "hand_thickness",
    "shoulder-offset": "shoulder_offset",
}


def add_subject_options(p: Any) -> None:
    """``--subject-file``, measurement flags, ``--symmetric`` and ``--no-anatomy``."""
    g = p.add_argument_group(
        "subject measurements (override those in the C3D files' PROCESSING/SUBJECTS groups)"
    )
    g.add_argument(
        "--subject-file",
        metavar="FILE",
        help="YAML file of measurements, name: value in SI units or with a unit "
        "('144 mm'); names as in summary.json's 'measurements' (default: none)",
    )
    g.add_argument(
        "--height",
        type=float,
        metavar="MM",
        help="standing height [mm] (default: from the C3D, else none)",
    )
    g.add_argument(
        "--mass", type=float, metavar="KG", help="body mass [kg] (default: from the C3D, else none)"
    )
    g.add_argument(
        "--asis-distance",
        type=float,
        metavar="MM",
        help="inter-ASIS distance [mm] (default: from the C3D, else the markers)",
    )
    g.add_argument(
        "--marker-diameter",
        type=float,
        metavar="MM",
        help="marker diameter [mm] (default: from the C3D, else 14)",
    )
    for flag, name in _SIDED.items():
        g.add_argument(
            f"--{flag}",
            type=float,
            nargs="+",
            metavar="MM",
            help=f"{name.replace('_', ' ')} [mm]: one value for both sides, or LEFT RIGHT "
            "(default: from the C3D, else regressed from the markers)",
        )
    g.add_argument(
        "--symmetric",
        type=float,
        nargs="?",
        const=2.0,
        metavar="WIDTH_MM",
        help="tie every left segment length to the right one with this standard deviation "
        "[mm] (default: off; 2 when given without a value)",
    )
    g.add_argument(
        "--no-asymmetry-prior",
        action="store_true",
        help="no population prior on left/right length differences (5 mm; for subjects "
        "with a known asymmetry, e.g. a limb-length discrepancy; default: the prior is on)",
    )
    g.add_argument(
        "--hip-centre",
        choices=("harrington", "davis"),
        default="harrington",
        help="hip centres from the pelvis markers: harrington (Harrington et al. 2007, "
        "closer to imaging; default) or davis (Davis et al. 1991 from the leg lengths, "
        "as Plug-in Gait places them)",
    )
    g.add_argument(
        "--no-sliding-landmarks",
        action="store_true",
        help="weigh the knee epicondyle markers (KNE) alike at every knee angle (default: "
        "weigh them down as the knee flexes, their skin sliding on the femur, 10 mm per rad "
        "per axis, where the residuals show soft tissue; recorded in model.xml for ik; "
        "docs/method.md#weighing-priors-trials-and-sliding-markers)",
    )
    g.add_argument(
        "--no-anatomy",
        action="store_true",
        help="no anatomical priors and ranges: the plain joint LM (default: priors and ranges on)",
    )


def subject_from_args(args: argparse.Namespace, c3d_paths: Sequence[str]) -> Subject:
    """Measurements of the C3D files (first file that has each), the YAML file, then flags."""
    subject = Subject()
    for path in c3d_paths:
        if str(path).lower().endswith(".c3d"):
            found = from_c3d(path)
            subject = found.update(subject)  # earlier files win
    if args.subject_file:
        subject = subject.update(from_yaml(args.subject_file))
    pairs: list[tuple[str, float | None]] = [
        ("height", None if args.height is None else args.height * 1e-3),
        ("mass", args.mass),
        ("asis_distance", None if args.asis_distance is None else args.asis_distance * 1e-3),
        ("marker_diameter", None if args.marker_diameter is None else args.marker_diameter * 1e-3),
    ]
    for flag, name in _SIDED.items():
        values = getattr(args, flag.replace("-", "_"))
        if values is None:
            continue
        if len(values) > 2:
            raise MocapError(f"--{flag}: expected one value or LEFT RIGHT, got {len(values)}")
        left, right = values[0], values[-1]
        pairs += [(f"{name}_l", left * 1e-3), (f"{name}_r", right * 1e-3)]
    return subject.update(from_values(pairs, "command line"))


def with_measured_widths(
    args: argparse.Namespace, names: Sequence[str], trials: Sequence[Any], subject: Subject
) -> Subject:
    """``subject`` with the joint widths that ``--marker-set``'s landmark pairs measure in
    ``trials`` (each with ``markers`` (T, M, 3) [m] in the order ``names``) where none is
    given (:func:`mocap_mj.landmarks.measured_widths`); a given width that differs by more
    than 10 mm is kept and warned about on stderr."""
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


def set_landmarks(args: argparse.Namespace) -> tuple[dict[str, str], dict[str, str]]:
    """``--marker-set``'s landmarks (marker -> landmark) and bodies (marker -> body); empty
    without the flag."""
    path = getattr(args, "marker_set", None)
    if not path:
        return {}, {}
    marker_set = load_marker_set(path)
    landmarks = {m.name: m.landmark for m in marker_set.markers if m.landmark}
    return landmarks, {m.name: m.body for m in marker_set.markers}
