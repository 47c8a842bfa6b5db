"""Vicon's subject files: the ``.vsk`` (XML) and the ``.mp`` text file Nexus keeps beside it.

Vicon Nexus keeps a subject's Plug-in Gait parameters in the subject's ``.vsk`` file
(``<KinematicModel><Parameters><Parameter NAME="LeftKneeWidth" VALUE="105" .../>``) and in a
``.mp`` file beside it (one ``$LeftKneeWidth = 105`` per line), and copies them into the
``PROCESSING`` group of every C3D file it writes. Both files are read into the same (where,
name, value) numbers as that group (:func:`mocap_mj.capture.subject.c3d_numbers`), so the one
name mapping of the C3D files (``Bodymass``, ``Height``, ``LeftKneeWidth`` / ``LKneeWidth``,
...; :func:`mocap_mj.capture.subject.subject_from_numbers`, and
:func:`mocap_mj.clinical.subject.pig_from_numbers` for Plug-in Gait's static offsets and
tibial torsion) applies to all three, in the units of the ``PROCESSING`` group: millimetres,
kilograms, and radians for the angles. Parameters that are not measurements (the model's
outputs, ``ThighRotation``...) are ignored; a measurement whose value is not a number is a
one-line error naming the file and the parameter (the ``.mp`` line too).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

from mocap_mj.capture.subject import Subject, from_yaml, is_known_number, subject_from_numbers
from mocap_mj.errors import InputFileError

#: The suffixes (lower case) of Vicon's subject files.
VICON_SUFFIXES = (".vsk", ".mp")
#: A ``.mp`` line: ``$Name = value`` (the value is checked apart, so a bad one is named).
_MP_LINE = re.compile(r"\s*\$\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.*?)\s*")
#: A ``.mp`` comment line, BodyLanguage's ``{* ... *}``.
_MP_COMMENT = re.compile(r"\s*\{\*.*\*\}\s*")

Numbers = list[tuple[str, str, float]]


def is_vicon_file(path: str | Path) -> bool:
    """Whether ``path`` names a Vicon subject file (by its suffix, :data:`VICON_SUFFIXES`)."""
    return Path(path).suffix.lower() in VICON_SUFFIXES


def vicon_numbers(path: str | Path, known: Callable[[str], bool] = is_known_number) -> Numbers:
    """(file kind, parameter name, value) of every parameter of a ``.vsk`` or ``.mp`` file
    whose name ``known`` accepts (default: the measurements' Nexus names,
    :func:`~mocap_mj.capture.subject.is_known_number`), in the file's units (mm, kg, rad);
    the file kind (``vsk`` or ``mp``) stands where a C3D file's group stands. A parameter
    whose value is not a finite number, a file that is not XML (``.vsk``) or a line that is
    not ``$Name = value`` (``.mp``) is an :class:`~mocap_mj.errors.InputFileError` naming
    the file and the parameter or line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig", errors="replace")
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read the subject file: {exc}") from None
    if path.suffix.lower() == ".vsk":
        pairs = _vsk_pairs(path, text, known)
    else:
        pairs = _mp_pairs(path, text)
    kind = path.suffix.lower().lstrip(".")
    out: Numbers = []
    for name, raw, where in pairs:
        if not known(name):
            continue
        try:
            value = float(raw)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise InputFileError(
                f"{path}: {where}parameter {name}: expected a number (mm, kg or rad), got {raw!r}"
            )
        out.append((kind, name, value))
    return out


def _vsk_pairs(path: Path, text: str, known: Callable[[str], bool]) -> list[tuple[str, str, str]]:
    """(name, raw value, "") of every ``Parameter`` element of a ``.vsk``'s
    ``KinematicModel/Parameters``."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputFileError(f"{path}: expected a Vicon .vsk (XML) subject file: {exc}") from None
    model = root if root.tag == "KinematicModel" else root.find(".//KinematicModel")
    if model is None:
        raise InputFileError(
            f"{path}: expected a Vicon .vsk subject file with a <KinematicModel> element"
        )
    pairs = []
    for element in model.iterfind("./Parameters/Parameter"):
        name = element.get("NAME")
        if not name:
            raise InputFileError(f"{path}: a <Parameter> without a NAME attribute")
        value = element.get("VALUE")
        if value is None:
            if known(name):
                raise InputFileError(f"{path}: parameter {name}: expected a VALUE attribute")
            continue
        pairs.append((name, value, ""))
    return pairs


def _mp_pairs(path: Path, text: str) -> list[tuple[str, str, str]]:
    """(name, raw value, "line N: ") of every ``$Name = value`` line of a ``.mp`` file
    (blank and ``{* ... *}`` comment lines skipped)."""
    pairs = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or _MP_COMMENT.fullmatch(line):
            continue
        m = _MP_LINE.fullmatch(line)
        if m is None:
            raise InputFileError(
                f"{path}: line {number}: expected '$Name = value' (a Vicon .mp subject "
                f"file), got {line.strip()[:60]!r}"
            )
        pairs.append((m.group(1), m.group(2), f"line {number}: "))
    return pairs


def from_vicon(path: str | Path) -> Subject:
    """The measurements of a Vicon ``.vsk`` or ``.mp`` subject file (module docstring),
    each with its source (``FILE: vsk:LeftKneeWidth``)."""
    return subject_from_numbers(vicon_numbers(path), path)


def from_file(path: str | Path) -> Subject:
    """A ``--subject-file``'s measurements: a Vicon ``.vsk`` or ``.mp`` file (by its suffix),
    else a YAML mapping (:func:`~mocap_mj.capture.subject.from_yaml`)."""
    return from_vicon(path) if is_vicon_file(path) else from_yaml(path)
