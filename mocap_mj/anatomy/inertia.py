"""Segment inertial parameters of the humanoid: de Leva's tables scaled to the identified model.

Source: P. de Leva, "Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters",
J Biomech 29 (1996) 1223-1230, Table 4 (young adults: 100 men of 1.741 m and 73.0 kg, 15 women
of 1.735 m and 61.9 kg). For each segment: its mass as a fraction of body mass, its centre of
mass as a fraction of its length from the table's reference endpoint, and its radii of
gyration about the centre of mass as fractions of its length, about the sagittal axis
(antero-posterior), the transverse axis (medio-lateral) and the longitudinal axis.

Mapping onto the bundled humanoid's bodies (docs/dynamics.md has the table):

* pelvis, lumbar, thorax carry de Leva's lower (omphalion to mid-hip), middle (xiphoid to
  omphalion) and upper trunk (suprasternale to xiphoid), each along the body's own joint line:
  the lower trunk from L5/S1 to the mid-point of the hip centres, the middle from T12/L1 to
  L5/S1, the upper from C7/T1 to T12/L1;
* head: de Leva's head and neck from the vertex to C7 (his second head definition), upwards
  from the neck joint, its length de Leva's scaled by the subject's legs (the model has no head
  length);
* upperarm, radius (the forearm), thigh, shank: joint centre to joint centre (shoulder to
  elbow, elbow to wrist, hip to knee, knee to ankle);
* hand: wrist to the third metacarpale, its length de Leva's scaled by the subject's forearm;
* foot: heel to toe tip along the foot's x, through the MTP joint's height, the heel
  ``HEEL_BACK`` and the toe tip ``TOE_LENGTH`` ankle-to-MTP distances behind the ankle and
  beyond the MTP joint (the bundled foot's proportions, its HEE site and toes geom);
* clavicle, ulna, toes carry no segment of their own (de Leva's upper trunk, forearm and foot
  include them): each carries ``CARRIER_FRACTION`` of that segment's mass at its origin, as a
  sphere of radius ``CARRIER_RADIUS`` (MuJoCo needs a positive mass on every moving body),
  taken from the segment so that the masses still sum to the body mass.

The principal axes: the longitudinal axis runs between the two endpoints; the sagittal axis
is the body's x made normal to it (for the foot, whose long axis is x, the body's z); the
transverse axis completes the frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal
from xml.etree import ElementTree

import mujoco
import numpy as np

from mocap_mj.errors import InputFileError, MocapError
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.skeleton.mjcf import load_model

Sex = Literal["male", "female"]

#: Share of its segment's mass that a carrier body (clavicle, ulna, toes) holds.
CARRIER_FRACTION = 1e-3
#: Radius [m] of the sphere a carrier body's inertia is that of.
CARRIER_RADIUS = 0.02
#: The foot's heel behind the ankle, per ankle-to-MTP forward distance (HEE at 70 of 140 mm).
HEEL_BACK = 0.5
#: The toe tip beyond the MTP joint, per ankle-to-MTP forward distance (the 60 mm toes geom).
TOE_LENGTH = 60.0 / 140.0


@dataclass(frozen=True)
class DeLevaSegment:
    """One row of de Leva's Table 4.

    Attributes
    ----------
    endpoints : (str, str)
        The reference endpoint (the centre of mass is measured from it) and the other one.
    length : float [m]
        The segment's mean length in de Leva's sample.
    mass : float
        Mass as a fraction of body mass.
    com : float
        Centre of mass from the reference endpoint, as a fraction of the length.
    r_sagittal, r_transverse, r_longitudinal : float
        Radii of gyration about the centre of mass, as fractions of the length.
    """

    endpoints: tuple[str, str]
    length: float
    mass: float
    com: float
    r_sagittal: float
    r_transverse: float
    r_longitudinal: float


def _row(a: str, b: str, *values: float) -> DeLevaSegment:
    length_mm, mass, com, r_sag, r_trans, r_long = values
    return DeLevaSegment(
        (a, b), length_mm / 1000, mass / 100, com / 100, r_sag / 100, r_trans / 100, r_long / 100
    )


#: de Leva (1996) Table 4, men: length [mm], mass [%], centre of mass [%], radii [%].
MALE: dict[str, DeLevaSegment] = {
    "head": _row("VERT", "CERV", 242.9, 6.94, 50.02, 30.3, 31.5, 26.1),
    "upper_trunk": _row("SUPR", "XYPH", 170.7, 15.96, 29.99, 71.6, 45.4, 65.9),
    "middle_trunk": _row("XYPH", "OMPH", 215.5, 16.33, 45.02, 48.2, 38.3, 46.8),
    "lower_trunk": _row("OMPH", "MIDH", 145.7, 11.17, 61.15, 61.5, 55.1, 58.7),
    "upper_arm": _row("SJC", "EJC", 281.7, 2.71, 57.72, 28.5, 26.9, 15.8),
    "forearm": _row("EJC", "WJC", 268.9, 1.62, 45.74, 27.6, 26.5, 12.1),
    "hand": _row("WJC", "MET3", 86.2, 0.61, 79.00, 62.8, 51.3, 40.1),
    "thigh": _row("HJC", "KJC", 422.2, 14.16, 40.95, 32.9, 32.9, 14.9),
    "shank": _row("KJC", "LMAL", 434.0, 4.33, 44.59, 25.5, 24.9, 10.3),
    "foot": _row("HEEL", "TTIP", 258.1, 1.37, 44.15, 25.7, 24.5, 12.4),
}

#: de Leva (1996) Table 4, women: length [mm], mass [%], centre of mass [%], radii [%].
FEMALE: dict[str, DeLevaSegment] = {
    "head": _row("VERT", "CERV", 243.7, 6.68, 48.41, 27.1, 29.5, 26.1),
    "upper_trunk": _row("SUPR", "XYPH", 142.5, 15.45, 20.77, 74.6, 50.2, 71.8),
    "middle_trunk": _row("XYPH", "OMPH", 205.3, 14.65, 45.12, 43.3, 35.4, 41.5),
    "lower_trunk": _row("OMPH", "MIDH", 181.5, 12.47, 49.20, 43.3, 40.2, 44.4),
    "upper_arm": _row("SJC", "EJC", 275.1, 2.55, 57.54, 27.8, 26.0, 14.8),
    "forearm": _row("EJC", "WJC", 264.3, 1.38, 45.59, 26.1, 25.7, 9.4),
    "hand": _row("WJC", "MET3", 78.0, 0.56, 74.74, 53.1, 45.4, 33.5),
    "thigh": _row("HJC", "KJC", 368.5, 14.78, 36.12, 36.9, 36.4, 16.2),
    "shank": _row("KJC", "LMAL", 432.3, 4.81, 44.16, 27.1, 26.7, 9.3),
    "foot": _row("HEEL", "TTIP", 228.3, 1.29, 40.14, 29.9, 27.9, 13.9),
}

TABLES: dict[str, dict[str, DeLevaSegment]] = {"male": MALE, "female": FEMALE}

_SIDED = {
    "upperarm": "upper_arm",
    "radius": "forearm",
    "hand": "hand",
    "thigh": "thigh",
    "shank": "shank",
    "foot": "foot",
}
_CARRIERS = {"clavicle": "upper_trunk", "ulna": "forearm", "toes": "foot"}

#: The de Leva segment each body of the bundled humanoid carries.
BODY_SEGMENTS: dict[str, str] = {
    "pelvis": "lower_trunk",
    "lumbar": "middle_trunk",
    "thorax": "upper_trunk",
    "head": "head",
    **{f"{b}_{s}": seg for b, seg in _SIDED.items() for s in "lr"},
}
#: Bodies that carry a share (``CARRIER_FRACTION``) of another body's segment.
CARRIER_SEGMENTS: dict[str, str] = {f"{b}_{s}": seg for b, seg in _CARRIERS.items() for s in "lr"}


@dataclass(frozen=True)
class BodyInertia:
    """The inertial parameters of every body of a model (B bodies, the world left out).

    Attributes
    ----------
    bodies : tuple of str, (B,)
        Body names, model order.
    segments : tuple of str, (B,)
        The de Leva segment each body carries (a carrier body: the segment it shares).
    mass : (B,) float [kg]
    com : (B, 3) float [m]
        Centre of mass in the body's frame.
    inertia : (B, 3, 3) float [kg m^2]
        Inertia tensor about the centre of mass, body frame.
    length : (B,) float [m]
        The segment length the table's fractions are scaled by (0 for a carrier).
    ends : (B, 2, 3) float [m]
        The segment's reference endpoint and other endpoint in the body's frame (both at the
        origin for a carrier).
    """

    bodies: tuple[str, ...]
    segments: tuple[str, ...]
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    length: np.ndarray
    ends: np.ndarray


def mass_total(table: dict[str, DeLevaSegment]) -> float:
    """The table's mass fractions summed over the whole body (both sides of the limbs, the
    trunk as its three parts): 1.0000 for the men, 0.9999 for the women (the printed
    percentages are rounded). :func:`segment_inertia` divides by it, so that the masses sum
    to the body mass."""
    limbs = ("upper_arm", "forearm", "hand", "thigh", "shank", "foot")
    trunk = ("head", "upper_trunk", "middle_trunk", "lower_trunk")
    return sum(table[k].mass for k in trunk) + 2 * sum(table[k].mass for k in limbs)


def _pos(model: mujoco.MjModel, name: str) -> np.ndarray:
    return np.array(model.body(name).pos, dtype=float)


def _ends(model: mujoco.MjModel, body: str, table: dict[str, DeLevaSegment]) -> np.ndarray:
    """The reference endpoint and the other endpoint (2, 3) [m] of ``body``'s segment in its
    frame, from the model's body positions (the identified segment lengths)."""
    side = body[-2:] if body[-2:] in ("_l", "_r") else ""
    zero = np.zeros(3)
    up = np.array([0.0, 0.0, 1.0])
    if body == "pelvis":
        hips = 0.5 * (_pos(model, "thigh_l") + _pos(model, "thigh_r"))
        return np.stack([_pos(model, "lumbar"), hips])
    if body == "lumbar":
        return np.stack([_pos(model, "thorax"), zero])
    if body == "thorax":
        return np.stack([_pos(model, "head"), zero])
    if body == "head":
        legs = sum(np.linalg.norm(_pos(model, f"{b}_{s}")) for b in ("shank", "foot") for s in "lr")
        scale = legs / (2 * (table["thigh"].length + table["shank"].length))
        return np.stack([table["head"].length * scale * up, zero])
    if body.startswith("hand"):
        forearm = np.linalg.norm(_pos(model, f"hand{side}"))
        length = table["hand"].length * forearm / table["forearm"].length
        return np.stack([zero, -length * up])
    if body.startswith("foot"):
        mtp = _pos(model, f"toes{side}")
        heel = np.array([-HEEL_BACK * mtp[0], 0.0, mtp[2]])
        tip = np.array([(1 + TOE_LENGTH) * mtp[0], 0.0, mtp[2]])
        return np.stack([heel, tip])
    child = {"upperarm": "ulna", "radius": "hand", "thigh": "shank", "shank": "foot"}
    return np.stack([zero, _pos(model, child[body[:-2]] + side)])


def _principal_axes(ends: np.ndarray) -> np.ndarray:
    """Rows: the sagittal (antero-posterior), transverse and longitudinal unit axes (3, 3)."""
    long = ends[1] - ends[0]
    long = long / np.linalg.norm(long)
    sag = np.array([1.0, 0.0, 0.0]) - long[0] * long
    if np.linalg.norm(sag) < 0.5:  # a segment along x (the foot): its vertical instead
        sag = np.array([0.0, 0.0, 1.0]) - long[2] * long
    sag /= np.linalg.norm(sag)
    return np.stack([sag, np.cross(long, sag), long])


def segment_inertia(model: mujoco.MjModel, mass: float, *, sex: Sex = "male") -> BodyInertia:
    """The inertial parameters of ``model``'s bodies (the bundled humanoid's, with its
    identified ``body_pos``) for a subject of ``mass`` [kg]: de Leva's fractions (module
    docstring) scaled by each segment's length in the model.

    Raises MocapError for a mass that is not positive, an unknown ``sex``, or a body the
    mapping does not know (naming it and the known ones).
    """
    if not np.isfinite(mass) or mass <= 0:
        raise MocapError(f"body mass: expected a positive number of kilograms, got {mass}")
    if sex not in TABLES:
        raise MocapError(f"sex: expected one of {', '.join(TABLES)}, got {sex!r}")
    table = TABLES[sex]
    total = mass_total(table)
    names = tuple(str(model.body(b).name) for b in range(1, model.nbody))
    known = {**BODY_SEGMENTS, **CARRIER_SEGMENTS}
    unknown = [n for n in names if n not in known]
    missing = [n for n in known if n not in names]
    if unknown or missing:
        raise MocapError(
            f"segment inertia: the model's bodies differ from the bundled humanoid's "
            f"(unknown: {', '.join(unknown) or 'none'}; missing: {', '.join(missing) or 'none'})"
        )
    b_count = len(names)
    out_mass = np.zeros(b_count)
    com = np.zeros((b_count, 3))
    inertia = np.zeros((b_count, 3, 3))
    length = np.zeros(b_count)
    ends = np.zeros((b_count, 2, 3))
    segments = []
    for i, name in enumerate(names):
        if name in CARRIER_SEGMENTS:
            seg = table[CARRIER_SEGMENTS[name]]
            m = mass * seg.mass / total * CARRIER_FRACTION
            out_mass[i] = m
            inertia[i] = 0.4 * m * CARRIER_RADIUS**2 * np.eye(3)
            segments.append(CARRIER_SEGMENTS[name])
            continue
        key = BODY_SEGMENTS[name]
        seg = table[key]
        side = name[-2:] if name[-2:] in ("_l", "_r") else ""
        carriers = [c for c, s in CARRIER_SEGMENTS.items() if s == key and c.endswith(side)]
        m = mass * seg.mass / total * (1.0 - CARRIER_FRACTION * len(carriers))
        e = _ends(model, name, table)
        seg_length = float(np.linalg.norm(e[1] - e[0]))
        if not seg_length > 0:
            raise MocapError(f"segment inertia: body {name}'s segment has zero length")
        axes = _principal_axes(e)
        radii = np.array([seg.r_sagittal, seg.r_transverse, seg.r_longitudinal]) * seg_length
        out_mass[i] = m
        com[i] = e[0] + seg.com * (e[1] - e[0])
        inertia[i] = m * np.einsum("k,ki,kj->ij", radii**2, axes, axes)
        length[i] = seg_length
        ends[i] = e
        segments.append(key)
    return BodyInertia(names, tuple(segments), out_mass, com, inertia, length, ends)


def _full(inertia: np.ndarray) -> list[float]:
    """MJCF's ``fullinertia`` order: ixx iyy izz ixy ixz iyz."""
    i = inertia
    return [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]


def apply_inertia(spec: mujoco.MjSpec, inertia: BodyInertia) -> None:
    """Write ``inertia`` into the bodies of ``spec`` as explicit ``<inertial>`` values (the
    geoms' densities then no longer set them)."""
    for i, name in enumerate(inertia.bodies):
        body = spec.body(name)
        if body is None:
            raise MocapError(f"segment inertia: the model has no body {name!r}")
        body.mass = float(inertia.mass[i])
        body.ipos = inertia.com[i]
        # a file's own <inertial> (a written model's diagonal form) gives way to the full tensor
        body.inertia = np.zeros(3)
        body.iquat = np.array([1.0, 0.0, 0.0, 0.0])
        body.fullinertia = _full(inertia.inertia[i])
        body.explicitinertial = True


def inertial_spec(path: str | Path, mass: float, *, sex: Sex = "male") -> mujoco.MjSpec:
    """``MjSpec`` of the MJCF file ``path`` as plain MuJoCo compiles it (a written model keeps
    its knees' slide joints) with de Leva's inertial parameters for ``mass`` [kg]
    (:func:`segment_inertia` of the file's body positions)."""
    spec = mujoco.MjSpec.from_file(str(path))
    apply_inertia(spec, segment_inertia(load_model(path), mass, sex=sex))
    return spec


def inertial_model(path: str | Path, mass: float, *, sex: Sex = "male") -> mujoco.MjModel:
    """The compiled :func:`inertial_spec`."""
    return inertial_spec(path, mass, sex=sex).compile()


def with_inertials(xml: str, inertia: BodyInertia) -> str:
    """MJCF text ``xml`` with an ``<inertial pos mass fullinertia>`` first in each body of
    ``inertia`` (replacing any there), at full precision; everything else as it was."""
    root = ElementTree.fromstring(xml)
    bodies = {elem.get("name"): elem for elem in root.iter("body")}
    for i, name in enumerate(inertia.bodies):
        body = bodies.get(name)
        if body is None:
            raise MocapError(f"segment inertia: the MJCF text has no body {name!r}")
        for old in body.findall("inertial"):
            body.remove(old)
        elem = ElementTree.Element(
            "inertial",
            pos=" ".join(repr(float(v)) for v in inertia.com[i]),
            mass=repr(float(inertia.mass[i])),
            fullinertia=" ".join(repr(float(v)) for v in _full(inertia.inertia[i])),
        )
        body.insert(0, elem)
    ElementTree.indent(root, space="  ")
    return ElementTree.tostring(root, encoding="unicode") + "\n"


def write_inertial_model(
    source: str | Path, dest: str | Path, mass: float, *, sex: Sex = "male"
) -> BodyInertia:
    """Write the MJCF file ``source`` with de Leva's inertial parameters for ``mass`` [kg] to
    ``dest`` (atomically; ``source`` is never modified, and ``dest`` must differ from it).
    Returns the parameters written."""
    source, dest = Path(source), Path(dest)
    if dest.resolve() == source.resolve():
        raise MocapError(f"{dest}: the inertial model must go to another file than its source")
    inertia = segment_inertia(load_model(source), mass, sex=sex)
    try:
        text = source.read_text()
    except OSError as exc:
        raise InputFileError(f"{source}: cannot read the model ({exc.strerror})") from None
    atomic_write_text(dest, with_inertials(text, inertia))
    return inertia


__all__ = [
    "BODY_SEGMENTS",
    "CARRIER_FRACTION",
    "CARRIER_RADIUS",
    "CARRIER_SEGMENTS",
    "FEMALE",
    "HEEL_BACK",
    "MALE",
    "TABLES",
    "TOE_LENGTH",
    "BodyInertia",
    "DeLevaSegment",
    "Sex",
    "apply_inertia",
    "inertial_model",
    "inertial_spec",
    "mass_total",
    "segment_inertia",
    "with_inertials",
    "write_inertial_model",
]
