"""The flags several commands share, each defined once so that it means one thing everywhere.

Every command that reads markers takes the same input flags (:func:`add_input_options`:
``--markers``, ``--subject``, ``--marker-map``, ``--up``, ``--units``, ``--frames``); those
that fit a model to them take :func:`add_model_options`; a flag that is also a recipe field
(``--loss``, ``--no-sliding-landmarks``) overrides the recipe in every command that reads
one (:func:`add_recipe_options`). This module imports nothing but argparse, so that
``--help`` answers at once (no NumPy, MuJoCo or numba loaded).
"""

from __future__ import annotations

import argparse
from typing import Any

from .common import length

#: ``--up``: the vertical axis of the input markers, rotated onto the model's +Z.
UP_AXES = ("x", "y", "z", "-x", "-y", "-z")
#: ``--units``: the length unit of the marker coordinates.
MARKER_UNITS = ("mm", "cm", "m")
#: ``--loss``: the loss on each marker distance (:data:`mocap_mj.solve.losses.LossName`).
LOSSES = ("l2", "huber", "cauchy")
#: ``--height``: a person's standing height [m], a bare number in mm (the range of
#: :data:`mocap_mj.capture.subject.HUMAN_RANGES`, which the measurement is checked against too).
HEIGHT = length("a standing height", "mm", least=0.5, most=2.75, example=1.75)

_FORMATS = "C3D, TRC, mocap-mj CSV, Vicon Nexus or OptiTrack Motive CSV"


def add_input_options(
    p: argparse.ArgumentParser, *, several: bool = False, frames: str = "to use"
) -> None:
    """How a command reads its markers: ``--markers`` (one file, or ``several``), ``--subject``,
    ``--marker-map``, ``--up``, ``--units`` and ``--frames`` (the frames ``frames``)."""
    p.add_argument(
        "--markers",
        required=True,
        nargs="+" if several else None,
        metavar="FILE",
        help=(
            "marker files, one or more (--markers A B is --markers A --markers B)"
            if several
            else "marker file"
        )
        + f": {_FORMATS}",
    )
    add_label_options(p)
    p.add_argument(
        "--up", choices=UP_AXES, help="vertical axis of the marker coordinates (default: detect)"
    )
    p.add_argument(
        "--units",
        choices=MARKER_UNITS,
        help="length unit of the marker coordinates, overriding the file's (default: as stated "
        "in the file, else mm)",
    )
    p.add_argument(
        "--frames",
        metavar="A:B",
        help=f"frames {frames}, from A up to but excluding B, counted from 0 in every trial, "
        "negative from the end (default: all)",
    )


def add_label_options(p: argparse.ArgumentParser) -> None:
    """How labels are read: ``--subject`` (a label prefix) and ``--marker-map``."""
    p.add_argument(
        "--subject",
        metavar="NAME",
        help="subject to keep when labels carry several subject prefixes (default: the only "
        "one; required when there are several)",
    )
    p.add_argument(
        "--marker-map",
        metavar="FILE",
        help="YAML/JSON file mapping lab names to model names (default: none)",
    )


def add_model_options(p: argparse.ArgumentParser, *, model: str) -> None:
    """``--model`` (``model``: what it is to the command) and ``--marker-set``."""
    p.add_argument("--model", metavar="MJCF", help=f"{model} (default: the bundled humanoid)")
    p.add_argument(
        "--marker-set",
        metavar="SET",
        help="marker set replacing the model's own marker sites: SET is a bundled set's name "
        "(mocap-mj marker-sets lists them) or a YAML file (markers, bodies, offsets, prior "
        "classes, landmarks; docs/recordings.md#marker-sets) (default: the bundled set the "
        "labels fit, detected when --model is not given, else Plug-in Gait)",
    )


def add_recipe_options(p: Any, *, recipe: bool) -> None:
    """The identification's choices: ``--recipe`` (when ``recipe``), and the flags that
    override its fields, given or not: ``--loss`` and ``--no-sliding-landmarks``."""
    if recipe:
        p.add_argument(
            "--recipe",
            metavar="FILE",
            help="YAML recipe: the identification's choices (initial model, anatomical priors "
            "and ranges, left/right prior, frame selection, iterations, weak prior; "
            "docs/cli.md#recipe); every result folder holds the recipe.yaml it was made with, "
            "so --recipe DIR/recipe.yaml re-runs it (default: the defaults listed there)",
        )
    p.add_argument(
        "--loss",
        choices=LOSSES,
        help="loss on each marker distance; huber and cauchy down-weight outliers; given, it "
        "replaces the recipe's loss (default: the recipe's, l2)",
    )
    p.add_argument(
        "--no-sliding-landmarks",
        action="store_true",
        default=None,
        help="weigh every marker alike, the knee epicondyle markers too; given, it replaces "
        "the recipe's sliding_landmarks with false (default: the recipe's, true: those "
        "markers weighed down with knee flexion)",
    )


class _Quality(argparse.Action):
    """``--quality``: sets ``strict`` and ``no_relabel``, the two switches it stands for."""

    def __call__(self, parser: Any, namespace: Any, values: Any, option: Any = None) -> None:
        namespace.quality = values
        namespace.strict = values == "refuse"
        namespace.no_relabel = values == "warn"


def add_quality_options(p: argparse.ArgumentParser) -> None:
    """``--exclude-markers`` and ``--quality`` (its older spellings ``--strict`` and
    ``--no-relabel`` keep working, hidden from ``--help``)."""
    g = p.add_argument_group("marker data quality (docs/recordings.md#marker-data-quality)")
    g.add_argument(
        "--exclude-markers",
        metavar="NAMES",
        help="comma-separated model marker names, e.g. RELB,RUPA: drop these markers' data "
        "(treated as missing in every frame; their offsets are then not identified) "
        "(default: none)",
    )
    g.add_argument(
        "--quality",
        choices=("correct", "warn", "refuse"),
        action=_Quality,
        help="what the marker-data quality check's findings do: correct (default: exchanged "
        "labels corrected in the copy of the data that is fitted, the files never changed, "
        "one line each on stderr; other findings warned about), warn (labels left as they "
        "are, everything warned about) or refuse (exit 2, no output, on any finding or label "
        "needing a correction)",
    )
    p.set_defaults(quality="correct", strict=False, no_relabel=False)
    g.add_argument("--strict", action="store_true", help=argparse.SUPPRESS)  # --quality refuse
    g.add_argument("--no-relabel", action="store_true", help=argparse.SUPPRESS)  # ... warn


def add_subject_options(p: argparse.ArgumentParser) -> None:
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
        type=HEIGHT,
        metavar="LENGTH",
        help="standing height with its unit, 1750mm, 175cm or 1.75m; a bare number is mm "
        "(default: from the subject file or the C3D, else none)",
    )
    g.add_argument(
        "--mass",
        type=float,
        metavar="KG",
        help="body mass [kg] (default: from the subject file or the C3D, else none)",
    )


def add_kinetics_options(p: Any, *, several: bool) -> None:
    """``--forces``."""
    each = "one per marker file, in order" if several else "for the marker file"
    p.add_argument(
        "--forces",
        nargs="+",
        metavar="FILE",
        help=f"force-plate files, {each}: a C3D with FORCE_PLATFORM plates or an OpenSim "
        "ground-reaction .mot, frame k of the plates at marker frame k; 'none': no kinetics "
        "(default: a C3D marker file's own plates, when it has any; docs/dynamics.md)",
    )


def add_output_options(p: argparse.ArgumentParser) -> None:
    """``--out FOLDER`` (new or empty)."""
    p.add_argument(
        "--out", required=True, metavar="FOLDER", help="output folder (must be new or empty)"
    )


def add_report_options(p: Any) -> None:
    """``--normative`` and ``--events`` of the gait report (``gait-report``, ``plug-in-gait
    --report``)."""
    p.add_argument(
        "--normative",
        metavar="FILE",
        help="normative set (CSV: variable,percent,mean,sd; docs/clinical.md): its band in "
        "every plot, and the Gait Variable Scores and Gait Profile Score in scores.csv "
        "(default: none; the plots show the two sides only and the scores are omitted)",
    )
    p.add_argument(
        "--events",
        nargs="+",
        metavar="FILE",
        help="gait events, one events.csv per marker file in order (side, kind, frame, "
        "time_s, source: what ik, identify and synth write) (default: the C3D's EVENT "
        "group, else its force plates, else the kinematics; docs/clinical.md)",
    )
