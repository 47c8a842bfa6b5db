"""The Plug-in Gait subject values: measurements, static offsets and where each came from.

Sources, later ones overriding earlier ones:

1. the C3D file's ``PROCESSING`` group, as Vicon Nexus writes it: the body measurements
   through :func:`mocap_mj.capture.subject.from_c3d` (``LLegLength``, ``LKneeWidth``, ...) and the
   Plug-in Gait values that are not body measurements (``LStaticPlantFlex``,
   ``LStaticRotOff``, ``LTibialTorsion``, ``HeadOffset``: radians, as Nexus stores them;
   ``LSoleDelta`` in mm);
2. a subject file (``--subject-file``): a Vicon ``.vsk`` or ``.mp`` file, in the names and
   units of the PROCESSING group (:mod:`mocap_mj.capture.vicon_subject`), or a YAML file:
   ``name: value``, the names of :data:`mocap_mj.capture.subject.MEASUREMENTS` (SI or
   with a unit, ``"877 mm"``) and of :data:`PIG_VALUES` (metres or radians, or with a unit,
   ``"14.5 deg"``, ``"64 mm"``; Nexus' static options ``flat_foot_l``, ``head_level``: true
   or false, which no C3D records);
3. the static trial (:mod:`mocap_mj.clinical.static`): the static plantar-flexion and
   rotation offsets (flat or not: :func:`mocap_mj.clinical.model.calibrate`), the head
   offset with ``head_level``, and the inter-ASIS distance when none is given.

What is still missing takes Plug-in Gait's rule: the ASIS-trochanter distance (a
measurement, :meth:`mocap_mj.capture.subject.Subject.asis_trochanter`) from the leg length, offsets
and torsion 0, the marker diameter 14 mm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from mocap_mj.capture.subject import (
    MEASUREMENTS,
    Measurement,
    Subject,
    c3d_numbers,
    from_values,
    is_known_number,
    parse_sex,
    parse_value,
    read_mapping,
    sided,
    subject_from_numbers,
)
from mocap_mj.capture.vicon_subject import is_vicon_file, vicon_numbers

from ..errors import InputFileError, MocapError, excerpt

#: Plug-in Gait values that are not body measurements: name -> (unit inside, description).
PIG_VALUES: dict[str, tuple[str, str]] = {
    **sided(
        (
            ("static_plantar_flex", "rad", "foot plantar-flexion offset from the static trial"),
            ("static_rot_off", "rad", "foot rotation offset from the static trial"),
            ("tibial_torsion", "rad", "tibial torsion"),
            ("sole_delta", "m", "heel's sole less the toe's (a flat foot's heel rise)"),
            ("flat_foot", "flag", "the static trial's foot stands flat (1) or not (0)"),
            ("thigh_rotation", "rad", "thigh rotation offset (a KAD calibration's)"),
            ("shank_rotation", "rad", "shank rotation offset (a KAD calibration's)"),
            ("ankle_abadd", "rad", "ankle abduction offset (a KAD calibration's)"),
        )
    ),
    "head_offset": ("rad", "head pitch offset (0: the head markers' own frame)"),
    "head_level": ("flag", "the static trial's head is level (1: it gives the head offset)"),
}

#: The range of each Plug-in Gait value [rad], both ends included; a value outside is refused,
#: naming where it came from. A foot's static offsets and a tibial torsion beyond 60 degrees
#: are no person's (Nexus's static offsets are some -20 to 30 degrees, torsions 0 to 40), and
#: they catch degrees typed as radians; a head pitched more than 90 degrees is no head.
PIG_RANGES: dict[str, tuple[float, float]] = {
    **{name: (-math.pi / 3, math.pi / 3) for name, v in PIG_VALUES.items() if v[0] == "rad"},
    **{name: (0.0, 1.0) for name, v in PIG_VALUES.items() if v[0] == "flag"},
    **{name: (-0.05, 0.05) for name, v in PIG_VALUES.items() if v[0] == "m"},
    "head_offset": (-math.pi / 2, math.pi / 2),
}


def checked_pig_value(name: str, value: float, source: str) -> float:
    """``value`` [rad] of the Plug-in Gait value ``name``, or an error naming ``source``, the
    value in degrees and :data:`PIG_RANGES`' range (NaN included)."""
    low, high = PIG_RANGES[name]
    unit = PIG_VALUES[name][0]
    if unit == "flag" and value not in (0.0, 1.0):
        raise MocapError(f"{source}: expected true or false ({PIG_VALUES[name][1]}), got {value:g}")
    if unit == "m" and not low <= value <= high:
        raise MocapError(
            f"{source}: expected a {PIG_VALUES[name][1]} within {low * 1e3:g}..{high * 1e3:g} "
            f"mm, got {value * 1e3:.4g} mm (a number without a unit is in m)"
        )
    if not low <= value <= high:
        raise MocapError(
            f"{source}: expected a {PIG_VALUES[name][1]} within {math.degrees(low):g}.."
            f"{math.degrees(high):g} deg, got {math.degrees(value):.4g} deg "
            "(a number without a unit is in rad)"
        )
    return float(value)


#: Required measurements of the lower body (both sides) and of the upper body.
LOWER = ("leg_length", "knee_width", "ankle_width")
UPPER = ("shoulder_offset", "elbow_width", "wrist_width", "hand_thickness")

_C3D_PIG = {
    "STATICPLANTFLEX": ("static_plantar_flex", 1.0),
    "STATICROTOFF": ("static_rot_off", 1.0),
    "TIBIALTORSION": ("tibial_torsion", 1.0),
    "SOLEDELTA": ("sole_delta", 1e-3),
    "THIGHROTATION": ("thigh_rotation", 1.0),
    "SHANKROTATION": ("shank_rotation", 1.0),
    "ANKLEABADD": ("ankle_abadd", 1.0),
}
#: Values read and reported but not applied: a KAD static's offsets of the knee and ankle
#: chords, whose construction (Nexus's rotated chord) is not reproduced.
NOT_APPLIED = ("thigh_rotation", "shank_rotation", "ankle_abadd")
#: Plug-in Gait values without a side, by their Nexus name (upper case): name, scale to SI.
_C3D_PIG_UNSIDED = {"HEADOFFSET": ("head_offset", 1.0)}
#: Units of the Plug-in Gait values in a subject file.
_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "rad": 1.0, "deg": math.pi / 180.0}


def asis_trochanter(subject: Subject, side: str) -> float:
    """ASIS-trochanter distance [m] (:meth:`mocap_mj.capture.subject.Subject.asis_trochanter`);
    a clear error without it and without the leg length."""
    value = subject.asis_trochanter(side)
    if value is None:
        raise MocapError(
            f"Plug-in Gait needs the subject's leg_length_{side} or asis_trochanter_{side}: "
            "give it in the C3D PROCESSING group or --subject-file"
        )
    return value


def not_applied(subject: Subject) -> list[str]:
    """One line per non-zero value of :data:`NOT_APPLIED`, naming it and its source."""
    return [
        f"{name} {math.degrees(m.value):.3g} deg ({m.source}) is not applied: the "
        "KAD's rotated knee and ankle chords are not reproduced (docs/clinical.md)"
        for base in NOT_APPLIED
        for name in (f"{base}_l", f"{base}_r")
        if (m := subject.pig_values.get(name)) is not None and m.value != 0.0
    ]


def pig_dict(subject: Subject) -> dict[str, Any]:
    """Every measurement and Plug-in Gait value with its unit and source, for summary.json."""
    out: dict[str, Any] = dict(subject.to_dict())
    for name, m in sorted(subject.pig_values.items()):
        out[name] = {"value": m.value, "unit": PIG_VALUES[name][0], "source": m.source}
    return out


def pig_from_c3d(path: str | Path) -> Subject:
    """The Plug-in Gait subject values stored in a C3D file (PROCESSING, then SUBJECTS)."""
    return pig_from_numbers(list(c3d_numbers(path)), path)


def pig_from_numbers(numbers: Sequence[tuple[str, str, float]], path: str | Path) -> Subject:
    """The measurements and Plug-in Gait values among (group, name, value) numbers in
    Nexus's names and units (mm, kg, rad): a C3D file's PROCESSING group or a Vicon
    subject file's parameters (:func:`mocap_mj.capture.vicon_subject.vicon_numbers`)."""
    values: dict[str, float] = {}
    sources: dict[str, str] = {}
    for group, key, value in numbers:
        spec = _pig_name(key)
        if spec is None:
            continue  # not a Plug-in Gait value
        where = f"{path}: {group}:{key}"
        values[spec[0]] = checked_pig_value(spec[0], value * spec[1], where)
        sources[spec[0]] = where
    return replace(
        subject_from_numbers(numbers, path),
        pig_values={k: Measurement(v, sources[k]) for k, v in values.items()},
    )


def pig_from_vicon(path: str | Path) -> Subject:
    """The measurements and Plug-in Gait values of a Vicon ``.vsk`` or ``.mp`` subject file
    (:mod:`mocap_mj.capture.vicon_subject`)."""
    numbers = vicon_numbers(path, _known)
    for _, key, value in numbers:
        spec = _pig_name(key)
        if spec is not None and PIG_VALUES[spec[0]][0] == "rad" and abs(value) > math.pi:
            raise InputFileError(
                f"{path}: parameter {key}: expected an angle in radians (as Nexus stores it "
                f"in the .vsk, the .mp and the C3D's PROCESSING group), got {value:g}"
            )
    return pig_from_numbers(numbers, path)


def pig_from_file(path: str | Path) -> Subject:
    """A ``--subject-file``'s values: a Vicon ``.vsk`` or ``.mp`` file (by its suffix),
    else a YAML mapping (:func:`pig_from_yaml`)."""
    return pig_from_vicon(path) if is_vicon_file(path) else pig_from_yaml(path)


def _known(key: str) -> bool:
    """Whether ``key`` is the Nexus name of a measurement or of a Plug-in Gait value."""
    return is_known_number(key) or _pig_name(key) is not None


def _pig_name(key: str) -> tuple[str, float] | None:
    up = key.upper()
    if up in _C3D_PIG_UNSIDED:
        return _C3D_PIG_UNSIDED[up]
    for prefix, side in (("LEFT", "l"), ("RIGHT", "r"), ("L", "l"), ("R", "r")):
        spec = _C3D_PIG.get(up[len(prefix) :]) if up.startswith(prefix) else None
        if spec is not None:
            return f"{spec[0]}_{side}", spec[1]
    return None


def pig_from_yaml(path: str | Path) -> Subject:
    """Measurements and Plug-in Gait values of a YAML mapping ``name: value``."""
    measures: list[tuple[str, float | None]] = []
    values: dict[str, float] = {}
    for raw_name, raw in read_mapping(path).items():
        name = str(raw_name)
        if name in PIG_VALUES and PIG_VALUES[name][0] == "flag":
            if not isinstance(raw, bool):
                raise InputFileError(f"{path}: {name}: expected true or false, got {excerpt(raw)}")
            values[name] = float(raw)
        elif name in PIG_VALUES:
            value = parse_value(raw, name, str(path), _UNITS, kind=PIG_VALUES[name][0])
            values[name] = checked_pig_value(name, value, f"{path}: {name}")
        elif name in MEASUREMENTS:
            measures.append((name, parse_value(raw, name, str(path))))
        elif name == "sex":  # checked, not used: Plug-in Gait's Dempster table has one sex
            parse_sex(raw, str(path))
        else:
            known = ", ".join([*MEASUREMENTS, "sex", *PIG_VALUES])
            raise InputFileError(f"{path}: unknown subject value {excerpt(name)}; known: {known}")
    return replace(
        from_values(measures, str(path)),
        pig_values={k: Measurement(v, f"{path}: {k}") for k, v in values.items()},
    )
