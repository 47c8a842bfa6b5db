"""Subject measurements (height, mass, joint widths, ...) and where each came from.

A measurement sharpens the anatomical priors of :mod:`mocap_mj.anatomy.anatomy` (the knee
centre half a knee width plus a marker radius medial to KNE, ...) and scales the ranges of
:mod:`mocap_mj.anatomy.ranges`. Three sources, later ones overriding earlier ones:

1. the C3D file: Vicon Nexus writes the Plug-in Gait subject measurements into the
   ``PROCESSING`` group (``Height``, ``Bodymass``, ``LKneeWidth``, ... in mm and kg; pyCGM2
   and the Vicon VSK spell them ``LeftKneeWidth``, also accepted), other software into
   ``SUBJECTS`` (same names). A value of 0 means "not entered" in Nexus and is ignored;
2. a subject file (``--subject-file``): a YAML file, ``name: value`` with the names of
   :data:`MEASUREMENTS`, a number in SI units (m, kg) or a string with a unit (``"144 mm"``,
   ``"1.68 m"``); or Vicon's ``.vsk`` or ``.mp`` file, in the C3D group's names and units
   (:mod:`mocap_mj.capture.vicon_subject`);
3. command-line flags (mm and kg, as Nexus shows them).

When the height is not measured, the identification estimates the stature from the markers
(:func:`mocap_mj.anatomy.initial.estimate_stature`) and records it as
:attr:`Subject.stature_estimate`, apart from the measurements: a measured height always wins.

Inside, every length is in metres and the mass in kilograms.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.errors import InputFileError, MocapError, excerpt
from mocap_mj.io.yaml_file import read_yaml


def sided(rows: Sequence[tuple[str, str, str]]) -> dict[str, tuple[str, str]]:
    """``name_l`` and ``name_r`` -> (unit, description with the side) of each (name, unit,
    description) row: the table layout of :data:`MEASUREMENTS`."""
    return {
        f"{base}_{side}": (unit, f"{text} ({word})")
        for base, unit, text in rows
        for side, word in (("l", "left"), ("r", "right"))
    }


#: Measurement name -> (unit inside, description). ``_l``/``_r`` are the sides.
MEASUREMENTS: dict[str, tuple[str, str]] = {
    "height": ("m", "standing height"),
    "mass": ("kg", "body mass"),
    "asis_distance": ("m", "distance between the anterior superior iliac spines"),
    "marker_diameter": ("m", "diameter of the reflective markers"),
    **sided(
        (
            ("leg_length", "m", "ASIS to medial malleolus, through the knee"),
            ("asis_trochanter", "m", "ASIS to greater trochanter (Davis hip centre)"),
            ("knee_width", "m", "distance between the femoral epicondyles"),
            ("ankle_width", "m", "distance between the malleoli"),
            ("elbow_width", "m", "distance between the humeral epicondyles"),
            ("wrist_width", "m", "wrist width where the wrist bar sits"),
            ("hand_thickness", "m", "hand thickness at the metacarpal heads"),
            ("shoulder_offset", "m", "acromion marker to glenohumeral centre, vertical"),
        )
    ),
}

#: The range of each measurement a person can have [m or kg]; a value outside is refused,
#: naming where it came from (a unit slip such as millimetres typed as metres, or a typo).
#: Generous on purpose: the height spans the shortest and the tallest adults on record
#: (0.55 m, Chandra Bahadur Dangi; 2.72 m, Robert Wadlow; Guinness World Records), which also
#: covers every child old enough to walk (about 0.75 m at one year); the mass, a walking
#: infant (about 9 kg) to the heaviest person on record (about 635 kg, Jon Brower Minnoch).
#: The other lengths are bounded at about half a toddler's and twice a large adult's value
#: (an adult's knee width is some 90-150 mm, ankle and elbow widths 60-100 mm, the
#: inter-ASIS distance 200-320 mm, the Plug-in Gait leg length 0.75-1.05 m, the ASIS to
#: trochanter distance 40-100 mm); the marker
#: diameter spans the marker sizes sold (3-40 mm).
HUMAN_RANGES: dict[str, tuple[float, float]] = {
    "height": (0.5, 2.75),
    "mass": (2.0, 650.0),
    "asis_distance": (0.05, 0.6),
    "marker_diameter": (0.002, 0.05),
    **{
        f"{base}_{side}": bounds
        for base, bounds in (
            ("leg_length", (0.2, 1.6)),
            ("asis_trochanter", (0.01, 0.2)),
            ("knee_width", (0.03, 0.3)),
            ("ankle_width", (0.02, 0.2)),
            ("elbow_width", (0.02, 0.2)),
            ("wrist_width", (0.01, 0.15)),
            ("hand_thickness", (0.005, 0.08)),
            ("shoulder_offset", (0.005, 0.15)),
        )
        for side in ("l", "r")
    },
}

#: Default marker diameter [m] when none is given (the common 14 mm Vicon marker).
DEFAULT_MARKER_DIAMETER = 0.014

# C3D parameter names (PROCESSING / SUBJECTS groups) -> measurement, with the factor to SI.
_C3D_NAMES: dict[str, tuple[str, float]] = {
    "HEIGHT": ("height", 1e-3),
    "BODYMASS": ("mass", 1.0),
    "INTERASISDISTANCE": ("asis_distance", 1e-3),
    "MARKERDIAMETER": ("marker_diameter", 1e-3),
}
for _base, _nexus in (
    ("leg_length", "LegLength"),
    ("asis_trochanter", "AsisTrocanterDistance"),
    ("knee_width", "KneeWidth"),
    ("ankle_width", "AnkleWidth"),
    ("elbow_width", "ElbowWidth"),
    ("wrist_width", "WristWidth"),
    ("hand_thickness", "HandThickness"),
    ("shoulder_offset", "ShoulderOffset"),
):
    for _side, _prefixes in (("l", ("L", "LEFT")), ("r", ("R", "RIGHT"))):
        for _p in _prefixes:
            _C3D_NAMES[(_p + _nexus).upper()] = (f"{_base}_{_side}", 1e-3)

_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "kg": 1.0}
#: What each unit measures, by its SI unit: a length given in kg (or a mass in mm) is refused.
UNIT_KINDS = {"mm": "m", "cm": "m", "m": "m", "kg": "kg", "rad": "rad", "deg": "rad"}


@dataclass(frozen=True)
class Measurement:
    """One measurement: value [m or kg] and where it came from (file and field, or flag)."""

    value: float
    source: str


@dataclass(frozen=True)
class StatureEstimate:
    """A stature estimated from the markers: value and standard deviation [m], and how."""

    value: float
    sd: float
    source: str

    def to_dict(self) -> dict[str, Any]:
        return {"value": self.value, "sd": self.sd, "unit": "m", "source": self.source}


@dataclass
class Subject:
    """The subject's measurements by name (:data:`MEASUREMENTS`); absent ones are unknown.

    ``stature_estimate``: the stature estimated from the markers when the height is not
    measured (None: not estimated); :meth:`stature` prefers the measured height.
    """

    values: dict[str, Measurement] = field(default_factory=dict)
    stature_estimate: StatureEstimate | None = None
    #: (``"male"`` or ``"female"``, where it came from): which of de Leva's tables scales the
    #: segments' masses and inertias (:mod:`mocap_mj.anatomy.inertia`); None: not given.
    sex: tuple[str, str] | None = None
    #: Plug-in Gait's values that are not body measurements, by name (static offsets, tibial
    #: torsion, head offset [rad], sole delta [m], the static options as 1 or 0): their
    #: names, units and ranges are :data:`mocap_mj.clinical.subject.PIG_VALUES`'.
    pig_values: dict[str, Measurement] = field(default_factory=dict)

    def get(self, name: str) -> float | None:
        """The value [m or kg] of ``name``, or None when not measured."""
        _check_name(name, "measurement")
        m = self.values.get(name)
        return None if m is None else m.value

    def set(self, name: str, value: float, source: str) -> None:
        """Record ``name`` = ``value`` [SI]; a value outside :data:`HUMAN_RANGES` (NaN
        included) is an error naming ``source`` and the range."""
        _check_name(name, source)
        low, high = HUMAN_RANGES[name]
        if not low <= value <= high:  # NaN included
            unit, per = ("kg", 1.0) if MEASUREMENTS[name][0] == "kg" else ("mm", 1e3)
            raise MocapError(
                f"{source}: expected a {MEASUREMENTS[name][1]} within {low * per:g}.."
                f"{high * per:g} {unit} (any person), got {value * per:.4g} {unit}"
            )
        self.values[name] = Measurement(float(value), source)

    def require(self, name: str, who: str = "Plug-in Gait") -> float:
        """The value [m or kg] of ``name``; an error saying that ``who`` needs it and where
        it may be given when it is not measured."""
        v = self.get(name)
        if v is None:
            raise MocapError(
                f"{who} needs the subject's {name} ({MEASUREMENTS[name][1]}): "
                "give it in the C3D PROCESSING group or --subject-file"
            )
        return v

    def pig(self, name: str, default: float = 0.0) -> float:
        """A Plug-in Gait value (:attr:`pig_values`) [m or rad], ``default`` when not given."""
        m = self.pig_values.get(name)
        return default if m is None else m.value

    def flag(self, name: str) -> bool | None:
        """A static option of Plug-in Gait (``flat_foot_l``, ``head_level``): True or False
        when given, else None."""
        m = self.pig_values.get(name)
        return None if m is None else bool(m.value)

    def with_pig(self, values: Mapping[str, float], source: str) -> Subject:
        """A copy with the Plug-in Gait ``values`` (checked by the caller) from ``source``."""
        given = {k: Measurement(float(v), source) for k, v in values.items()}
        return replace(self, pig_values={**self.pig_values, **given})

    def update(self, other: Subject) -> Subject:
        """A copy with ``other``'s measurements and Plug-in Gait values overriding these."""
        return Subject(
            {**self.values, **other.values},
            other.stature_estimate or self.stature_estimate,
            other.sex or self.sex,
            {**self.pig_values, **other.pig_values},
        )

    def with_stature_estimate(self, estimate: StatureEstimate | None) -> Subject:
        """A copy carrying ``estimate`` (kept beside, never over, a measured height)."""
        return Subject(dict(self.values), estimate, self.sex, dict(self.pig_values))

    @property
    def table(self) -> str:
        """The de Leva table of the subject's segments: its ``sex``, else ``"male"`` (the
        tool's default, as Plug-in Gait's single table)."""
        return "male" if self.sex is None else self.sex[0]

    def stature(self) -> tuple[float, float] | None:
        """(stature, its standard deviation) [m]: the measured height with 0, else the
        estimate from the markers, else None."""
        h = self.get("height")
        if h is not None:
            return h, 0.0
        e = self.stature_estimate
        return None if e is None else (e.value, e.sd)

    def asis_trochanter(self, side: str) -> float | None:
        """The ASIS-trochanter distance [m] of ``side`` ("l", "r"), one definition for the
        anatomical priors' Davis rows and for Plug-in Gait: the measurement
        (``AsisTrocanterDistance``) when given, else Plug-in Gait's regression on the
        side's leg length, 0.1288 leg length - 48.56 mm (Davis et al. 1991); None without
        either."""
        given = self.get(f"asis_trochanter_{side}")
        if given is not None:
            return given
        leg = self.get(f"leg_length_{side}")
        return None if leg is None else 0.1288 * leg - 0.04856

    def leg_length(self) -> float:
        """The mean of the two leg lengths [m] (Davis' regression takes the mean); an error
        naming the one missing."""
        return 0.5 * (self.require("leg_length_l") + self.require("leg_length_r"))

    @property
    def marker_radius(self) -> float:
        """Half the marker diameter [m] (``DEFAULT_MARKER_DIAMETER`` when not given)."""
        d = self.get("marker_diameter")
        return 0.5 * (DEFAULT_MARKER_DIAMETER if d is None else d)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{name: {"value": v, "unit": u, "source": s}}`` for the summary and report."""
        return {
            n: {"value": m.value, "unit": MEASUREMENTS[n][0], "source": m.source}
            for n, m in sorted(self.values.items())
        }

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> Subject:
        """The measurements and stature estimate a result's summary.json records (its
        ``measurements`` as :meth:`to_dict` writes them, ``stature_estimate``): the subject
        an ``identify`` run used."""
        values = {
            n: Measurement(float(v["value"]), str(v["source"]))
            for n, v in summary.get("measurements", {}).items()
        }
        est = summary.get("stature_estimate")
        estimate = StatureEstimate(est["value"], est["sd"], est["source"]) if est else None
        sex = summary.get("sex")
        given = (str(sex["value"]), str(sex["source"])) if isinstance(sex, Mapping) else None
        return cls(values, estimate, given)


def _check_name(name: str, source: str) -> None:
    if name not in MEASUREMENTS:
        raise MocapError(
            f"{source}: unknown measurement {excerpt(name)}; known: {', '.join(MEASUREMENTS)}"
        )


def from_c3d(path: str | Path) -> Subject:
    """Measurements stored in a C3D file's PROCESSING or SUBJECTS group (mm and kg there).

    PROCESSING wins over SUBJECTS where both hold a value; zeros (Nexus' "not entered") and
    names that are not measurements (model outputs such as ``UpperLegLength``) are ignored.
    """
    return subject_from_numbers(c3d_numbers(path), path)


def subject_from_numbers(numbers: Iterable[tuple[str, str, float]], path: str | Path) -> Subject:
    """The measurements among (group, name, value) numbers in Nexus's names and units (mm,
    kg), later ones winning: a C3D file's (:func:`c3d_numbers`) or a Vicon subject file's
    (:func:`mocap_mj.capture.vicon_subject.vicon_numbers`); each recorded with the source
    ``FILE: GROUP:NAME``. Zeros (Nexus' "not entered") and names that are not measurements
    are ignored."""
    subject = Subject()
    for group, key, value in numbers:
        spec = _C3D_NAMES.get(key.upper())
        if spec is not None and value > 0:
            subject.set(spec[0], value * spec[1], f"{path}: {group}:{key}")
    return subject


def is_known_number(key: str) -> bool:
    """Whether ``key`` (any case) is the Nexus name of a measurement (``LKneeWidth``,
    ``LeftKneeWidth``, ``Bodymass``...)."""
    return key.upper() in _C3D_NAMES


def c3d_numbers(path: str | Path) -> Iterator[tuple[str, str, float]]:
    """(group, name, value) of every finite number in a C3D file's SUBJECTS, then
    PROCESSING group (the first value of each parameter), so that PROCESSING comes last."""
    from mocap_mj.io.formats.c3d import read_parameters

    try:
        params = read_parameters(Path(path))
    except Exception as exc:  # ezc3d raises plain RuntimeError/IOError
        raise InputFileError(f"{path}: cannot read the C3D parameters: {exc}") from None
    for group in ("SUBJECTS", "PROCESSING"):
        for key, entry in params.get(group, {}).items():
            if not isinstance(entry, dict) or "value" not in entry:
                continue
            try:
                value = float(np.asarray(entry["value"], dtype=float).ravel()[0])
            except (ValueError, IndexError, TypeError):
                continue
            if np.isfinite(value):
                yield group, str(key), value


def parse_value(
    raw: Any,
    name: str,
    source: str,
    units: Mapping[str, float] = _UNITS,
    kind: str | None = None,
) -> float:
    """A number, or a string ``"<number> <unit>"`` with a unit of ``units`` (unit -> factor
    to SI), in SI units; a clear error otherwise. ``kind`` ("m", "kg", "rad"; default: the
    measurement's own unit when ``name`` is one of :data:`MEASUREMENTS`) is what the value
    measures: a unit of another kind ("1.7 kg" for a height) is refused."""
    if kind is None and name in MEASUREMENTS:
        kind = MEASUREMENTS[name][0]
    if isinstance(raw, bool) or not isinstance(raw, int | float | str):
        raise MocapError(f"{source}: {name}: expected a number, got {excerpt(raw)}")
    if isinstance(raw, int | float):
        return float(raw)
    allowed = [u for u in units if kind is None or UNIT_KINDS.get(u) == kind]
    m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*([a-z]+)\s*", raw)
    if m is None or m.group(2) not in allowed:
        raise MocapError(
            f"{source}: {name}: expected a number in SI units or "
            f"'<number> {'|'.join(allowed)}', got {excerpt(raw)}"
        )
    try:
        return float(m.group(1)) * units[m.group(2)]
    except ValueError:
        raise MocapError(f"{source}: {name}: {m.group(1)!r} is not a number") from None


def read_mapping(path: str | Path) -> Mapping[Any, Any]:
    """A YAML file's top-level mapping; one-line errors for an unreadable file or another
    shape."""
    data = read_yaml(path, "subject file")
    if not isinstance(data, Mapping):
        raise InputFileError(f"{path}: expected a mapping of measurement names to values")
    return data


#: The subject file's ``sex`` values and the table each names.
SEXES = {"female": "female", "f": "female", "male": "male", "m": "male"}


def parse_sex(raw: Any, source: str) -> str:
    """``"male"`` or ``"female"`` from a subject file's ``sex`` (any case, or ``f``/``m``);
    one-line :class:`~mocap_mj.errors.MocapError` naming ``source`` otherwise."""
    found = SEXES.get(raw.strip().lower()) if isinstance(raw, str) else None
    if found is None:
        raise MocapError(f"{source}: sex: expected female or male, got {excerpt(raw)}")
    return found


def from_yaml(path: str | Path) -> Subject:
    """Measurements of a YAML mapping ``name: value`` (:data:`MEASUREMENTS`, SI or with unit)
    and the subject's ``sex`` (:func:`parse_sex`)."""
    subject = Subject()
    for name, raw in read_mapping(path).items():
        if name == "sex":
            subject.sex = (parse_sex(raw, str(path)), f"{path}: sex")
            continue
        _check_name(str(name), str(path))
        value = parse_value(raw, str(name), str(path))
        try:
            subject.set(str(name), value, f"{path}: {name}")
        except MocapError as exc:
            if not isinstance(raw, int | float):
                raise
            raise MocapError(f"{exc} (a number without a unit is in m or kg)") from None
    return subject


def from_values(values: Iterable[tuple[str, float | None]], source: str) -> Subject:
    """Measurements from (name, value [SI]) pairs, None values skipped."""
    subject = Subject()
    for name, value in values:
        if value is not None:
            subject.set(name, value, source)
    return subject
