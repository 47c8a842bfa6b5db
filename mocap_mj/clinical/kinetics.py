"""Plug-in Gait's kinetics of legs and arms: joint forces, moments, powers, as Nexus writes them.

The kinetic model is Plug-in Gait's (Vicon's Plug-in Gait reference guide, "Kinetic
modelling"): each segment's mass is a fraction of the body mass, its centre of mass lies a
fraction of the way from its distal joint centre (the segment's origin) towards its proximal
one, and its principal moments of inertia about the transverse axes are m (k L)^2 with the
radius of gyration k a fraction of the segment length L (none about the long axis z). The
fractions are Dempster's (1955) as Plug-in Gait tabulates them (:data:`DEMPSTER`):

========  ============  =========================  ===============  ==========================
segment   mass / body   centre of mass from distal radius of gyr.   length L (its median)
========  ============  =========================  ===============  ==========================
foot      0.0145        0.5                        0.690            toe marker to ankle centre
tibia     0.0465        0.567                      0.528            ankle to knee centre
femur     0.100         0.567                      0.540            knee to hip centre
hand      0.006         0.6205                     0.440            hand's end to wrist centre
radius    0.016         0.57                       0.526            wrist to elbow centre
humerus   0.028         0.564                      0.542            elbow to shoulder centre
========  ============  =========================  ===============  ==========================

The foot's long axis is its frame's z (after the static offsets) through the ankle centre, its
length the toe marker's distance from the ankle centre (Nexus' swing-phase ankle moment about
that axis is zero, as this makes it). The hand's far end is Plug-in Gait's hand bone origin,
twice the wrist-to-hand-centre distance beyond the wrist centre. The arms' recursion starts
from the free hand (no load).

The recursion runs bottom-up (Newton-Euler) in the lab, from the ground reaction under the
foot (force, centre of pressure, free moment) through foot, tibia and femur: for each segment
``F_prox = m (a - g) - F_dist`` and ``M_prox = dH/dt - M_dist - (p_prox - c) x F_prox -
(p_dist - c) x F_dist`` (c its centre of mass, H its angular momentum about c, g = 9.81 m/s^2
down), the next segment's distal load being the joint's reaction. Velocities and
accelerations are five-point central differences at the marker rate applied twice
(positions -> velocities -> accelerations; the frame's rotation -> angular velocity ->
angular acceleration) with no other filter: Nexus computes its kinetics from the
trajectories as stored, and its outputs start and end four frames in, as these do (a frame
whose stencil meets a missing marker is NaN).

Reported as Nexus does (determined against the Nexus outputs of a Plug-in Gait trial): the
force and moment the proximal segment exerts on the distal one at the joint, divided by the
body mass, in the distal segment's frame (the foot's for the ankle, the untorsioned tibia's
for the knee, the femur's for the hip), components and signs in :data:`MOMENT_AXES` and
:data:`FORCE_SIGNS`: X the sagittal moment, Y the frontal, Z the transverse, the right
side's Y and Z mirrored. A joint's power is its moment dotted with the distal segment's
angular velocity less the proximal's, written in Z. Where the foot stands on no counted plate
its ground reaction is zero and the moments come from the segments' motion alone, as Nexus
writes them; the ground reaction itself is written only on a counted plate.

The trunk (:func:`trunk_kinetics`; Nexus' ``WaistMoment``, ``NeckMoment``..., determined against
the Nexus outputs of a Plug-in Gait trial): Nexus carries the legs' recursion on up. The pelvis
receives both femurs' loads at the hip centres and passes the waist's load to the thorax at L5;
the thorax receives it there and the humeri's at the shoulder centres (the arms' recursion from
the free hands) and passes the neck's load at the neck point; the head enters no output. Pelvis
and thorax are Plug-in Gait's (reference guide, "Kinetic modelling", table and footnotes):
masses 0.142 and 0.355, centres of mass 0.895 of the way from the hip centres' mid-point to L5
and 0.63 from C7 to L5 (:mod:`.centre_of_mass`), radii of gyration 0.31 of those lengths (the
guide's estimates; it names no axes: Nexus' waist moments are those of the pelvis' inertia about
all three, which without z differ by 0.004 N m/kg, its neck's those of the thorax' about x and y
only, with z 0.03). The guide names no neck joint centre: the neck's moment is taken about the
C7 marker's mean position in the thorax frame, of the thorax' points (its origin, C7, C7 one
marker radius forward) the one Nexus' moments agree with (the others by 0.05-0.85 N m/kg worse).
Reported per kg as the limbs' (the upper segment's load on the lower): the waist's in the pelvis
frame, the neck's in the thorax frame turned to the pelvis' orientation (:data:`UPRIGHT`: x
forward, y left, z up), moment X the frame's y, Y its x, Z minus its z (:data:`TRUNK_AXES`), the
right side's Y and Z mirrored, force x, y, z, L and R the same loads; power in Z, the moment
dotted with the lower segment's angular velocity less the upper's.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mocap_mj.capture.contacts import as_recorded, contacts
from mocap_mj.io.plates import PlateRecord
from mocap_mj.io.trajectory import MarkerTrajectory

from ..errors import MocapError
from .segments import Segment

__all__ = [
    "DEMPSTER",
    "FORCE_SIGNS",
    "GRAVITY",
    "MOMENT_AXES",
    "TRUNK_AXES",
    "UPRIGHT",
    "Body",
    "ChainLoads",
    "Load",
    "PlateChoice",
    "angular_velocity",
    "arm_links",
    "arm_loads",
    "derivative",
    "leg_links",
    "leg_loads",
    "newton_euler",
    "pig_kinetics",
    "trial_kinetics",
    "trunk_kinetics",
    "trunk_loads",
]

#: Standard gravity [m/s^2], the value Nexus normalises the ground reaction with.
GRAVITY = 9.81


@dataclass(frozen=True)
class Body:
    """Dempster's parameters of one segment as Plug-in Gait scales them: ``mass`` (fraction of
    the body mass), ``com`` (the centre of mass's fraction of the way from the distal joint
    centre to the proximal one), ``gyration`` (radius of gyration about the transverse axes,
    fraction of the segment length)."""

    mass: float
    com: float
    gyration: float


#: Plug-in Gait's segment parameters (Dempster 1955; Vicon's Plug-in Gait reference guide).
DEMPSTER: dict[str, Body] = {
    "foot": Body(0.0145, 0.5, 0.690),
    "tibia": Body(0.0465, 0.567, 0.528),
    "femur": Body(0.100, 0.567, 0.540),
    "hand": Body(0.006, 0.6205, 0.440),
    "radius": Body(0.016, 0.57, 0.526),
    "humerus": Body(0.028, 0.564, 0.542),
    # the trunk: centres of mass from the hip centres' mid-point to L5 and from C7 to L5
    # (:mod:`.centre_of_mass`), the radii of gyration Plug-in Gait's estimates
    "pelvis": Body(0.142, 0.895, 0.31),
    "thorax": Body(0.355, 0.63, 0.31),
}


def derivative(x: np.ndarray, rate: float) -> np.ndarray:
    """Five-point central difference along axis 0: x (T, ...) -> dx/dt (T, ...) [unit/s],
    NaN in the first and last two rows (and wherever the stencil meets a NaN)."""
    x = np.asarray(x, dtype=float)
    d = np.full_like(x, np.nan)
    if len(x) >= 5:
        d[2:-2] = (x[:-4] - 8.0 * x[1:-3] + 8.0 * x[3:-1] - x[4:]) * (rate / 12.0)
    return d


def angular_velocity(axes: np.ndarray, rate: float) -> np.ndarray:
    """A frame's angular velocity in the lab, axes (T, 3, 3) (columns its x, y, z) ->
    (T, 3) [rad/s]: the axial vector of dR/dt R^T."""
    w = derivative(axes, rate) @ np.swapaxes(axes, 1, 2)
    return 0.5 * np.stack(
        [w[:, 2, 1] - w[:, 1, 2], w[:, 0, 2] - w[:, 2, 0], w[:, 1, 0] - w[:, 0, 1]], axis=1
    )


@dataclass(frozen=True)
class Load:
    """A load in the lab: the force ``force`` (T, 3) [N] and the moment ``moment`` (T, 3)
    [N m] acting at ``point`` (T, 3) [m]."""

    force: np.ndarray
    moment: np.ndarray
    point: np.ndarray


def newton_euler(
    *,
    mass: float,
    com: np.ndarray,
    inertia: np.ndarray,
    axes: np.ndarray,
    rate: float,
    proximal: np.ndarray,
    distal: Load,
) -> tuple[np.ndarray, np.ndarray]:
    """The force and moment the proximal segment exerts on this one at its proximal joint.

    ``mass`` [kg]; ``com`` (T, 3) [m] the centre of mass in the lab; ``inertia`` (3,)
    [kg m^2] the principal moments about the segment's own x, y, z through the centre of
    mass; ``axes`` (T, 3, 3) the segment's frame; ``rate`` [Hz]; ``proximal`` (T, 3) [m] the
    joint centre the result acts at; ``distal`` the load the segment receives at its distal
    end. Returns force (T, 3) [N], moment (T, 3) [N m] about ``proximal``, in the lab,
    gravity -Z.
    """
    force, moment = distal.force, distal.moment
    acc = derivative(derivative(com, rate), rate)
    omega = angular_velocity(axes, rate)
    alpha = derivative(omega, rate)
    # the inertia tensor in the lab: R diag(I) R^T
    tensor = np.einsum("tij,j,tkj->tik", axes, np.asarray(inertia, dtype=float), axes)
    h_dot = np.einsum("tij,tj->ti", tensor, alpha) + np.cross(
        omega, np.einsum("tij,tj->ti", tensor, omega)
    )
    weight = np.array([0.0, 0.0, -GRAVITY * mass])
    f_prox = mass * acc - weight - force
    m_prox = h_dot - moment - np.cross(proximal - com, f_prox) - np.cross(distal.point - com, force)
    return f_prox, m_prox


@dataclass(frozen=True)
class ChainLoads:
    """The joint loads of one limb in the lab: per joint (``ankle``, ``knee``, ``hip``;
    ``wrist``, ``elbow``, ``shoulder``) the force (T, 3) [N] and moment (T, 3) [N m] the
    proximal segment exerts on the distal one at the joint centre, and the angular velocity
    (T, 3) [rad/s] of each segment (``foot``, ``tibia``, ``femur``, ``pelvis``; ``hand``,
    ``radius``, ``humerus``, ``thorax``)."""

    force: dict[str, np.ndarray]
    moment: dict[str, np.ndarray]
    omega: dict[str, np.ndarray]


#: A link of a chain: segment, its proximal joint, its distal and proximal points (T, 3) [m].
_Link = tuple[str, str, np.ndarray, np.ndarray]


def _inertia(body: Body, mass: float, length: float) -> np.ndarray:
    """(3,) [kg m^2]: m (k L)^2 about x and y, none about the long axis z."""
    i = mass * (body.gyration * length) ** 2
    return np.array([i, i, 0.0])


def _chain(
    segs: Mapping[str, Segment],
    side: str,
    links: Sequence[_Link],
    top: str,
    *,
    body_mass: float,
    rate: float,
    load: Load,
) -> ChainLoads:
    """The recursion up ``links`` (distal first) from ``load`` on the first; ``top``: the
    segment above the last joint (for its angular velocity)."""
    out_f: dict[str, np.ndarray] = {}
    out_m: dict[str, np.ndarray] = {}
    omega: dict[str, np.ndarray] = {}
    for name, joint, distal, proximal in links:
        body = DEMPSTER[name]
        mass = body.mass * body_mass
        axes = segs[f"{name}_{side}"].axes
        length = float(np.nanmedian(np.linalg.norm(proximal - distal, axis=1)))
        f, m = newton_euler(
            mass=mass,
            com=distal + body.com * (proximal - distal),
            inertia=_inertia(body, mass, length),
            axes=axes,
            rate=rate,
            proximal=proximal,
            distal=load,
        )
        out_f[joint], out_m[joint] = f, m
        omega[name] = angular_velocity(axes, rate)
        load = Load(-f, -m, proximal)
    omega[top] = angular_velocity(segs[top].axes, rate)
    return ChainLoads(out_f, out_m, omega)


def leg_links(
    segs: Mapping[str, Segment], centres: Mapping[str, np.ndarray], side: str
) -> tuple[_Link, ...]:
    """The leg's links (foot, tibia, femur; ``side`` "l" or "r"): segment, proximal joint,
    distal and proximal points (T, 3) [m]. The foot's long axis is its frame's z (after the
    static offsets) through the ankle centre, its length the median distance of the toe
    marker (the foot's origin) from the ankle centre: the foot runs from that length ahead
    of the ankle centre (its distal end) to the ankle centre."""
    toe = segs[f"foot_{side}"].origin
    ankle, knee, hip = (centres[f"{j}_{side}"] for j in ("ankle", "knee", "hip"))
    length = float(np.nanmedian(np.linalg.norm(ankle - toe, axis=1)))
    tip = ankle - length * segs[f"foot_{side}"].axes[:, :, 2]
    return (("foot", "ankle", tip, ankle), ("tibia", "knee", ankle, knee),
            ("femur", "hip", knee, hip))  # fmt: skip


def arm_links(centres: Mapping[str, np.ndarray], side: str) -> tuple[_Link, ...]:
    """The arm's links (hand, radius, humerus), as :func:`leg_links`: the hand from its far
    end, twice the wrist-to-hand-centre distance beyond the wrist centre (Plug-in Gait's
    hand bone origin), to the wrist centre."""
    wrist, elbow, shoulder, hand = (
        centres[f"{j}_{side}"] for j in ("wrist", "elbow", "shoulder", "hand")
    )
    tip = wrist + 2.0 * (hand - wrist)
    return (("hand", "wrist", tip, wrist), ("radius", "elbow", wrist, elbow),
            ("humerus", "shoulder", elbow, shoulder))  # fmt: skip


def leg_loads(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    side: str,
    *,
    body_mass: float,
    rate: float,
    grf: np.ndarray,
    cop: np.ndarray,
    free_moment: np.ndarray,
) -> ChainLoads:
    """The bottom-up recursion of one leg (``side`` "l" or "r").

    ``segs``, ``centres``: :func:`~mocap_mj.clinical.segments.lower_body`'s segments and joint
    centres (T frames, [m]); ``body_mass`` [kg]; ``rate`` [Hz]; ``grf`` (T, 3) [N] the force
    on the foot (zero off the plates), ``cop`` (T, 3) [m] where it acts (NaN off the plates),
    ``free_moment`` (T, 3) [N m]. The segment lengths are each segment's median joint-centre
    distance over the trial (a rigid segment has one length).
    """
    toe = segs[f"foot_{side}"].origin
    return _chain(
        segs,
        side,
        leg_links(segs, centres, side),
        "pelvis",
        body_mass=body_mass,
        rate=rate,
        load=Load(
            np.asarray(grf, dtype=float),
            np.asarray(free_moment, dtype=float),
            np.where(np.isfinite(cop), cop, toe),  # no load off the plates: any point
        ),
    )


def arm_loads(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    side: str,
    *,
    body_mass: float,
    rate: float,
) -> ChainLoads:
    """The recursion of one arm from the free hand: hand (from the hand's far end, twice the
    wrist-to-hand-centre distance beyond the wrist centre, as Plug-in Gait's hand bone), radius
    and humerus, the thorax above (``segs``, ``centres``: :func:`~mocap_mj.clinical.segments.
    upper_limbs`' and the thorax)."""
    links = arm_links(centres, side)
    tip = links[0][2]
    zero = np.zeros_like(tip)
    return _chain(
        segs,
        side,
        links,
        "thorax",
        body_mass=body_mass,
        rate=rate,
        load=Load(zero, zero, tip),
    )


#: Per joint: its distal and proximal segments, then Nexus' moment components X, Y, Z as
#: (axis of the distal frame, sign); the Y and Z signs are mirrored on the right.
MOMENT_AXES: dict[str, tuple[str, str, tuple[tuple[int, float], ...]]] = {
    "Ankle": ("foot", "tibia", ((1, 1.0), (2, -1.0), (0, 1.0))),
    "Knee": ("tibia", "femur", ((1, -1.0), (0, 1.0), (2, 1.0))),
    "Hip": ("femur", "pelvis", ((1, 1.0), (0, 1.0), (2, 1.0))),
    "Wrist": ("hand", "radius", ((1, -1.0), (0, -1.0), (2, -1.0))),
    "Elbow": ("radius", "humerus", ((1, -1.0), (0, -1.0), (2, -1.0))),
    "Shoulder": ("humerus", "thorax", ((1, -1.0), (0, -1.0), (2, -1.0))),
}
#: Nexus' joint-force components in the distal frame (the same on both sides).
FORCE_SIGNS: dict[str, tuple[float, float, float]] = {
    "Ankle": (-1.0, 1.0, -1.0),
    "Knee": (1.0, 1.0, 1.0),
    "Hip": (1.0, 1.0, 1.0),
    "Wrist": (1.0, 1.0, 1.0),
    "Elbow": (1.0, 1.0, 1.0),
    "Shoulder": (1.0, 1.0, 1.0),
}


def pig_kinetics(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    loads: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    *,
    body_mass: float,
    rate: float,
    progression: np.ndarray,
    to_lab: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Plug-in Gait's kinetic outputs under Vicon's names, each (T, 3), normalised by the body
    mass as Nexus writes them.

    ``segs``, ``centres``: :func:`~mocap_mj.clinical.segments.lower_body`'s (Z-up frame);
    ``loads``: per side ("l", "r") the ground reaction under the foot: force (T, 3) [N]
    (zero off the plates), centre of pressure (T, 3) [m], free moment (T, 3) [N m] and
    on_plate (T,) bool (the frames of a counted plate); ``body_mass`` [kg]; ``rate`` [Hz];
    ``progression`` (3,) the direction of progression in the Z-up frame; ``to_lab`` (3, 3)
    the rotation back to the recording's lab frame (default identity).

    Returns ``LAnkleMoment``, ``LKneeMoment``, ``LHipMoment`` (and ``LWristMoment``,
    ``LElbowMoment``, ``LShoulderMoment`` when ``segs`` holds the arms and the thorax, the
    hand free of loads; with the trunk's points of
    :func:`~mocap_mj.clinical.centre_of_mass.trunk_points` in ``centres`` also ``LWaistMoment``,
    ``LNeckMoment``... of :func:`trunk_kinetics`) [N m/kg],
    ``LAnkleForce``...
    [N/kg] (the distal segment's frame, components in :data:`MOMENT_AXES`,
    :data:`FORCE_SIGNS`), ``LAnklePower``... [W/kg] (in Z; X and Y 0), ``LGroundReactionForce``
    [N/kg] (the lab frame), ``LNormalisedGRF`` [% body weight] (the progression frame: X
    forward, Y medial, Z up) and the right side's; a frame off the plates has NaN ground
    reactions, a frame whose derivatives cannot be taken NaN everywhere.
    """
    if not body_mass > 0:
        raise ValueError(f"body mass {body_mass!r}: expected a positive mass in kg")
    rot = np.eye(3) if to_lab is None else np.asarray(to_lab, dtype=float)
    fwd = np.asarray(progression, dtype=float).copy()
    fwd[2] = 0.0
    fwd /= np.linalg.norm(fwd)
    up = np.array([0.0, 0.0, 1.0])
    walk = np.stack([fwd, np.cross(up, fwd), up])  # rows: forward, left, up
    out: dict[str, np.ndarray] = {}
    chains: dict[str, ChainLoads] = {}
    for s, (grf, cop, free, on_plate) in loads.items():
        p, lat = s.upper(), (1.0 if s == "l" else -1.0)
        chains[f"leg_{s}"] = leg_loads(
            segs, centres, s, body_mass=body_mass, rate=rate, grf=grf, cop=cop, free_moment=free
        )
        if f"hand_{s}" in segs and "thorax" in segs:
            chains[f"arm_{s}"] = arm_loads(segs, centres, s, body_mass=body_mass, rate=rate)
        for limb in (chains[f"{k}_{s}"] for k in ("leg", "arm") if f"{k}_{s}" in chains):
            for joint, (distal, proximal, axes) in MOMENT_AXES.items():
                if joint.lower() not in limb.moment:
                    continue
                frame = segs[f"{distal}_{s}"].axes
                moment, force = limb.moment[joint.lower()], limb.force[joint.lower()]
                local_m = np.einsum("tji,tj->ti", frame, moment) / body_mass
                local_f = np.einsum("tji,tj->ti", frame, force) / body_mass
                out[f"{p}{joint}Moment"] = np.stack(
                    [sign * local_m[:, a] * (lat if c else 1.0)
                     for c, (a, sign) in enumerate(axes)],
                    axis=1,
                )  # fmt: skip
                out[f"{p}{joint}Force"] = local_f * np.asarray(FORCE_SIGNS[joint])
                relative = limb.omega[distal] - limb.omega[proximal]
                power = np.einsum("ti,ti->t", moment, relative) / body_mass
                out[f"{p}{joint}Power"] = np.stack(
                    [np.where(np.isfinite(power), 0.0, np.nan)] * 2 + [power], axis=1
                )
        mask = np.where(np.asarray(on_plate, dtype=bool)[:, None], 1.0, np.nan)
        force = np.asarray(grf, dtype=float) * mask / body_mass
        out[f"{p}GroundReactionForce"] = force @ rot.T
        normal = force @ walk.T * (100.0 / GRAVITY)
        normal[:, 1] *= -lat
        out[f"{p}NormalisedGRF"] = normal
    if "thorax_top" in centres and len(chains) == 4:
        out |= trunk_kinetics(segs, centres, chains, body_mass=body_mass, rate=rate)
    return out


#: Nexus' trunk moment components X, Y, Z as (axis of the reporting frame, sign); Y and Z
#: mirrored on the right.
TRUNK_AXES: tuple[tuple[int, float], ...] = ((1, 1.0), (0, 1.0), (2, -1.0))
#: The thorax frame's axes turned to the pelvis' orientation: x kept, y and z reversed.
UPRIGHT = np.array([1.0, -1.0, -1.0])


def _at(loads: list[Load], point: np.ndarray) -> Load:
    """The sum of ``loads`` as one load acting at ``point`` (T, 3) [m]."""
    force = sum((ld.force for ld in loads), np.zeros_like(point))
    moment = sum(
        (ld.moment + np.cross(ld.point - point, ld.force) for ld in loads), np.zeros_like(point)
    )
    return Load(force, moment, point)


def _segment(
    name: str, start: np.ndarray, end: np.ndarray, body_mass: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass [kg], centre of mass (T, 3) [m] and principal inertia (3,) [kg m^2] of the pelvis
    or the thorax, its centre of mass its fraction of the way from ``start`` to ``end``
    (T, 3) [m], its length their median distance; the pelvis' inertia about all three axes,
    the thorax' about x and y."""
    body = DEMPSTER[name]
    mass = body.mass * body_mass
    length = float(np.nanmedian(np.linalg.norm(end - start, axis=1)))
    i = mass * (body.gyration * length) ** 2
    com = start + body.com * (end - start)
    return mass, com, np.array([i, i, i if name == "pelvis" else 0.0])


def trunk_loads(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    limbs: Mapping[str, ChainLoads],
    *,
    body_mass: float,
    rate: float,
) -> ChainLoads:
    """The recursion up the trunk: the ``waist`` and ``neck`` forces (T, 3) [N] and moments
    (T, 3) [N m] (about L5 and the neck point) the upper segment exerts on the lower, in the
    lab, and the angular velocities (T, 3) [rad/s] of ``pelvis``, ``thorax``, ``head``.

    ``segs``, ``centres``: Plug-in Gait's segments and joint centres with the points of
    :func:`~.centre_of_mass.trunk_points`; ``limbs``: the legs' (``leg_l``, ``leg_r``) and
    arms' (``arm_l``, ``arm_r``) :class:`ChainLoads`; ``body_mass`` [kg]; ``rate`` [Hz].
    """
    out_f: dict[str, np.ndarray] = {}
    out_m: dict[str, np.ndarray] = {}
    mid = 0.5 * (centres["hip_l"] + centres["hip_r"])
    # joint above, segment, the ends its centre of mass is placed between (Plug-in Gait's: the
    # hip centres' mid-point to L5, C7 to L5), the joint's point, the limbs it receives
    steps = (("waist", "pelvis", mid, centres["l5"], centres["l5"], "leg", "hip"),
             ("neck", "thorax", centres["thorax_top"], centres["thorax_bottom"], centres["neck"],
              "arm", "shoulder"))  # fmt: skip
    below: list[Load] = []
    for out, name, start, end, proximal, limb, joint in steps:
        # each limb's segment acts on the trunk with the opposite of the trunk's load on it
        received = below + [
            Load(-limbs[f"{limb}_{s}"].force[joint], -limbs[f"{limb}_{s}"].moment[joint],
                 centres[f"{joint}_{s}"])
            for s in ("l", "r")
        ]  # fmt: skip
        mass, com, inertia = _segment(name, start, end, body_mass)
        f, m = newton_euler(mass=mass, com=com, inertia=inertia, axes=segs[name].axes, rate=rate,
                            proximal=proximal, distal=_at(received, proximal))  # fmt: skip
        out_f[out], out_m[out] = f, m
        below = [Load(-f, -m, proximal)]
    omega = {n: angular_velocity(segs[n].axes, rate) for n in ("pelvis", "thorax", "head")}
    return ChainLoads(out_f, out_m, omega)


def trunk_kinetics(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    limbs: Mapping[str, ChainLoads],
    *,
    body_mass: float,
    rate: float,
) -> dict[str, np.ndarray]:
    """``LWaistMoment``, ``LNeckMoment`` [N m/kg], ``LWaistForce``, ``LNeckForce`` [N/kg],
    ``LWaistPower``, ``LNeckPower`` [W/kg] (in Z; X and Y 0) and the right side's, each
    (T, 3), from :func:`trunk_loads` (the arguments its), as Nexus reports them; NaN in a frame
    whose derivatives cannot be taken."""
    loads = trunk_loads(segs, centres, limbs, body_mass=body_mass, rate=rate)
    frames = {
        "Waist": (segs["pelvis"].axes, "pelvis", "thorax"),
        "Neck": (segs["thorax"].axes * UPRIGHT, "thorax", "head"),
    }
    out: dict[str, np.ndarray] = {}
    for joint, (frame, lower, upper) in frames.items():
        moment, force = loads.moment[joint.lower()], loads.force[joint.lower()]
        local_m = np.einsum("tji,tj->ti", frame, moment) / body_mass
        local_f = np.einsum("tji,tj->ti", frame, force) / body_mass
        power = np.einsum("ti,ti->t", moment, loads.omega[lower] - loads.omega[upper]) / body_mass
        for p, lat in (("L", 1.0), ("R", -1.0)):
            out[f"{p}{joint}Moment"] = np.stack(
                [sign * local_m[:, a] * (lat if c else 1.0)
                 for c, (a, sign) in enumerate(TRUNK_AXES)],
                axis=1,
            )  # fmt: skip
            out[f"{p}{joint}Force"] = local_f.copy()
            out[f"{p}{joint}Power"] = np.stack(
                [np.where(np.isfinite(power), 0.0, np.nan)] * 2 + [power], axis=1
            )
    return out


@dataclass(frozen=True)
class PlateChoice:
    """The contacts that give loads: those of the plates numbered ``counted`` (from 1;
    default all), or with ``recorded`` (per foot, "left" and "right", the ground reaction
    (T, 3) [N/kg, the file's axes] the recording already holds,
    :func:`~mocap_mj.io.plates.recorded_ground_reactions`) the recording's choice of contacts
    (:func:`~mocap_mj.capture.contacts.as_recorded`; not with ``counted``)."""

    counted: Collection[int] | None = None
    recorded: Mapping[str, np.ndarray] | None = None


def trial_kinetics(
    segs: Mapping[str, Segment],
    centres: Mapping[str, np.ndarray],
    plates: Sequence[PlateRecord],
    trajectory: MarkerTrajectory,
    *,
    body_mass: float,
    progression: np.ndarray,
    to_lab: np.ndarray | None = None,
    choice: PlateChoice = PlateChoice(),
) -> tuple[dict[str, np.ndarray], list[str]]:
    """:func:`pig_kinetics` with the ground reactions of ``plates`` (read at ``trajectory``'s
    frames) under the foot that alone stands on each (the rules of
    :func:`~mocap_mj.capture.contacts.assign_feet`, applied to every plate). ``choice``: the
    contacts that give loads (default every plate's). Returns the outputs and one note per
    contact left out or undecided."""
    counted, recorded = choice.counted, choice.recorded
    numbers = {p.name: k + 1 for k, p in enumerate(plates)}
    if counted is not None:
        unknown = sorted(set(counted) - set(numbers.values()))
        if unknown:
            where = trajectory.source.get("path", "trial")
            raise MocapError(
                f"{where}: plates {unknown}: the trial has plates 1..{len(plates)}; expected "
                "some of those"
            )
    n = trajectory.n_frames
    loads = {s: (np.zeros((n, 3)), np.full((n, 3), np.nan), np.zeros((n, 3)),
                 np.zeros(n, dtype=bool)) for s in ("l", "r")}  # fmt: skip
    notes: list[str] = []
    # every plate takes part in the rules (two feet on one plate, a foot on two), the
    # uncounted ones' contacts then give no load
    found = contacts(plates, trajectory)
    if recorded and counted is None:
        found, notes = as_recorded(found, plates, recorded, body_mass=body_mass,
                                   first=trajectory.first_frame or 1)  # fmt: skip
    for c in found:
        if c.reason is not None:
            notes.append(f"{c.side or 'no'} foot: {c.reason}")
            continue
        if c.side is None or (counted is not None and c.plate + 1 not in counted):
            continue
        force, cop, free, on = loads[c.side[0]]
        plate, rows = plates[c.plate], slice(c.start, c.stop)
        force[rows], cop[rows], free[rows], on[rows] = (
            plate.force[rows], plate.cop[rows], plate.free_moment[rows], True
        )  # fmt: skip
    out = pig_kinetics(
        segs,
        centres,
        loads,
        body_mass=body_mass,
        rate=trajectory.rate,
        progression=progression,
        to_lab=to_lab,
    )
    return out, notes
