"""The initial model from the anatomical constructions, evaluated on the recording itself.

A nominal pose is no start for a subject standing in a T-pose, seated or facing another way:
an IK from the nominal model may turn a thigh or an upper arm about its long axis, and the
marker offsets placed in that pose put the knee centre lateral of KNE or the elbow centre in
front of ELB, which the markers then fit perfectly. The constructions need no pose: in every
frame they place each joint centre and each segment's flexion axis from the markers alone.

Per frame (:func:`construct`), in the lab:

* the pelvis frame: the rigid fit of the pelvis markers' offsets of the scaled model (their
  distances are the measured ones);
* the hip centres: the landmark prior's hip rows (Harrington et al. 2007, or Davis et al.
  1991 with the recipe's ``hip_centre: davis``) solved for the hip parameters, in that frame;
* the knee and ankle centres: the midpoint of the lateral and medial markers where the set
  has both; else the knee by Plug-in Gait's chord (:func:`mocap_mj.clinical.geometry.chord`)
  from the thigh wand, the hip centre and KNE, and the ankle on the knee's flexion axis made
  normal to the shank, each at width/2 + marker radius from its lateral marker (KNE, ANK),
  the width measured (subject file, C3D, the medial markers), else regressed on the
  segment's length (:data:`~mocap_mj.anatomy.anatomy.WIDTH_RATIO`). The ankle's chord from
  the tibial wand is left to the prior's chord-plane row: it carries the wand's placement,
  the tibia's torsion and the operator's;
* the shoulder, elbow and wrist centres: Plug-in Gait's (:mod:`mocap_mj.clinical.centres`),
  with the measured shoulder offset, elbow and wrist widths, else the landmark prior's means
  (shoulder offset 45 mm x stature / 1.75 m less the marker radius, the regressed elbow
  width and the regressed wrist width); the elbow on the frames where it bends by
  :data:`MIN_ELBOW_BEND_DEG` or more (Plug-in Gait's elbow plane is undefined in a straight
  arm, where its chord puts the centre 60-70 mm in front of or behind ELB); an arm that
  bends so in under :data:`MIN_BENT_SHARE` of the frames (a static with straight arms) gets
  :func:`straight_elbow` on every frame instead, :func:`hinge_elbow` on those that bend by
  :data:`STRAIGHT_BEND_DEG` or more;
* the model's body frames from those: thigh z from the knee to the hip centre, y towards KNE
  (the knee's flexion axis); shank z from the ankle to the knee centre, y towards ANK; upper
  arm z from the elbow to the shoulder centre, y towards ELB; radius z from the wrist to the
  elbow centre, y along the wrist bar. The foot, at the end of its chain with HEE, TOE and
  the ankle below a constructed shank, is placed by IK: a foot frame from HEE-TOE and the
  knee's axis moved the right ankle axis of the synthetic statics of tests/test_postures.py
  20-33 degrees from the truth's; placed by IK, 4-12.

Then (:func:`constructed_theta`) the segment lengths are the median distances between the
centres (the thigh, shank, upper arm, forearm, clavicle), the hip parameters the rows'
solution, and every marker carried by a constructed body gets the median of its position in
that body's frame over the frames: a robust average over a static or a movement. A body
whose markers are missing is not constructed; its markers are placed by IK afterwards
(:func:`~mocap_mj.anatomy.initial.place_markers`), with the constructed ones kept.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mocap_mj.anatomy.anatomy import WIDTH_RATIO, landmark_prior
from mocap_mj.anatomy.axis_rows import medial_pairs
from mocap_mj.capture.roles import roles
from mocap_mj.capture.subject import Subject
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.skeleton.rigid import rigid_fit

from ..clinical import centres
from ..clinical.geometry import chord, frame, frame_zy, unit
from ..clinical.segments import Markers, trunk_frames

#: The least elbow bend [deg] (of :func:`hinge_elbow`'s centre, between the upper arm and the
#: forearm) of a frame whose Plug-in Gait elbow is used: below it the arm's plane, which
#: Plug-in Gait's elbow centre lies in, turns with the noise.
MIN_ELBOW_BEND_DEG = 30.0
#: The least share of a recording's frames whose elbow bends by :data:`MIN_ELBOW_BEND_DEG`
#: for Plug-in Gait's elbow centre (on those frames only); a recording with fewer, a static
#: with straight arms, gets :func:`straight_elbow` or :func:`hinge_elbow` on every frame.
MIN_BENT_SHARE = 0.1
#: In such a recording, the bend [deg] (:func:`elbow_bend` of :func:`hinge_elbow`'s centre)
#: from which a frame's elbow is :func:`hinge_elbow`'s, below it :func:`straight_elbow`'s: a
#: straight arm reads 5-15 degrees when its width is regressed 10-20 % off, and
#: :func:`straight_elbow` misses the centre of an arm bent 15 degrees by about 35 mm.
STRAIGHT_BEND_DEG = 10.0
#: The least distance [m] of the thigh wand (THI) from the line of its joint's proximal centre and
#: lateral marker for Plug-in Gait's chord: a placement error e turns the chord's plane by
#: about atan(e / lever), 20 degrees for 10 mm at 25 mm (a Plug-in Gait wand stands 50-100 mm
#: out). Nearer, a knee is not constructed.
MIN_WAND_LEVER = 0.025
#: Shoulder offset plus marker radius [m] of a 1.75 m adult where none is measured: the
#: landmark prior's mean (:mod:`mocap_mj.anatomy.anatomy`, SHO 45 mm above the centre).
SHOULDER_ABOVE = 0.045

_SIDES = (("l", "L", 1.0), ("r", "R", -1.0))
_Frame = tuple[np.ndarray, np.ndarray]


@dataclass
class Construction:
    """What :func:`construct` found, over the stacked frames of the trials.

    ``frames``: model body -> (rotation (T, 3, 3), origin (T, 3) [m]) in the lab, NaN in a
    frame missing a marker; ``centres``: joint centre (``knee_l``...) -> (T, 3) [m];
    ``sources``: joint centre -> the construction that placed it, in words."""

    frames: dict[str, _Frame] = field(default_factory=dict)
    centres: dict[str, np.ndarray] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)


class _Recording:
    """The stacked trials (T, M, 3) [m] by role name (:func:`~mocap_mj.capture.roles.roles`)."""

    def __init__(self, pset: ParameterSet, markers: np.ndarray, landmarks: Mapping[str, str]):
        self.pset, self.markers = pset, markers
        self.alias = roles(pset, landmarks)
        self.landmarks = dict(landmarks)

    def name(self, role: str) -> str:
        return self.alias.get(role, role)

    def has(self, *roles_: str) -> bool:
        names = self.pset.marker_names
        return all(self.name(r) in names and np.any(np.isfinite(self[r][:, 0])) for r in roles_)

    def __getitem__(self, role: str) -> np.ndarray:
        name = self.name(role)
        if name not in self.pset.marker_names:
            return np.full((len(self.markers), 3), np.nan)
        return self.markers[:, self.pset.marker_index(name)]


def _offset(pset: ParameterSet, theta: np.ndarray, marker: str) -> np.ndarray:
    k = pset.n_kappa + 3 * pset.marker_index(marker)
    return np.asarray(theta[k : k + 3], dtype=float)


def _place(f: _Frame, local: np.ndarray) -> np.ndarray:
    """Point ``local`` (3,) [m] of frame ``f`` in the lab, per frame (T, 3)."""
    return f[1] + np.einsum("tij,j->ti", f[0], local)


def _half_width(
    pset: ParameterSet, theta: np.ndarray, subject: Subject, width: str, side: str
) -> tuple[float, str]:
    """Width/2 + marker radius [m] of a joint: measured, else regressed on its segment's
    length in ``theta`` (:data:`~mocap_mj.anatomy.anatomy.WIDTH_RATIO`)."""
    measured = subject.get(f"{width}_{side}")
    if measured is not None:
        return measured / 2 + subject.marker_radius, f"measured {width}"
    kappa, ratio = WIDTH_RATIO[width]
    length = float(theta[pset.index(f"{kappa}_{side}")])
    return ratio * length / 2 + subject.marker_radius, f"{width} regressed on {kappa}"


def _pelvis(rec: _Recording, theta: np.ndarray, out: Construction) -> _Frame | None:
    """The pelvis frame: the rigid fit of the pelvis markers' offsets in ``theta``."""
    pelvis = ("LASI", "RASI", "LPSI", "RPSI")
    if not rec.has(*pelvis):
        return None
    ref = np.stack([_offset(rec.pset, theta, rec.name(m)) for m in pelvis])
    f = rigid_fit(np.stack([rec[m] for m in pelvis], axis=1), ref)
    out.frames["pelvis"] = f
    return f


def _hip_theta(pset: ParameterSet, theta: np.ndarray, subject: Subject, hip_centre: str,
               landmarks: Mapping[str, str]) -> np.ndarray:  # fmt: skip
    """``theta`` with its hip parameters where the landmark prior's hip rows put them, given
    ``theta``'s pelvis markers (each row names one hip parameter)."""
    prior = landmark_prior(pset, subject, hip_centre=hip_centre, landmarks=landmarks)
    out = theta.copy()
    for side in ("l", "r"):
        for what in ("depth", "width", "height"):
            name = f"hip_{what}_{side}"
            if name not in pset.names:
                continue
            k = pset.index(name)
            for a, b, label in zip(prior.a, prior.b, prior.labels, strict=True):
                if label.startswith(name) and a[k] != 0.0:
                    out[k] = (b - (a @ out - a[k] * out[k])) / a[k]
                    break
    return out


def _lever(wand: np.ndarray, proximal: np.ndarray, lateral: np.ndarray) -> float:
    """Median distance [m] of the wand from the line of the proximal centre and the lateral
    marker: the lever with which its placement turns the chord's plane."""
    u = unit(lateral - proximal)
    d = wand - proximal
    perp = np.linalg.norm(d - np.sum(d * u, axis=-1, keepdims=True) * u, axis=-1)
    perp = perp[np.isfinite(perp)]
    return float(np.median(perp)) if perp.size else 0.0


def _pair_midpoint(rec: _Recording, p: str, lateral: str) -> tuple[np.ndarray, str] | None:
    """The midpoint (T, 3) [m] of the lateral marker and the set's medial one, else None."""
    medial = medial_pairs(rec.pset, rec.landmarks, p, rec.alias).get(p + lateral)
    if medial is None or not rec.has(p + lateral):
        return None
    m = rec.markers[:, rec.pset.marker_index(medial)]
    if not np.any(np.isfinite(m[:, 0])):
        return None
    return 0.5 * (rec[p + lateral] + m), "the midpoint of the lateral and medial markers"


def _centre(rec: _Recording, p: str, lateral: str, wand: str, proximal: np.ndarray,
            half: float) -> tuple[np.ndarray, str] | None:  # fmt: skip
    """A knee centre (T, 3) [m]: the landmark pair's midpoint, else the chord with a wand
    :data:`MIN_WAND_LEVER` or more off the line, else None."""
    pair = _pair_midpoint(rec, p, lateral)
    if pair is not None:
        return pair
    if not (rec.has(p + wand, p + lateral) and np.any(np.isfinite(proximal[:, 0]))):
        return None
    if _lever(rec[p + wand], proximal, rec[p + lateral]) < MIN_WAND_LEVER:
        return None
    return chord(rec[p + wand], proximal, rec[p + lateral], half), "Plug-in Gait's chord"


def _on_knee_axis(rec: _Recording, p: str, lat: float, thigh: np.ndarray, knee: np.ndarray,
                  half: float) -> tuple[np.ndarray, str] | None:  # fmt: skip
    """The ankle centre (T, 3) [m] half + r medial of ANK along the knee's flexion axis (the
    thigh's y, ``thigh`` (T, 3, 3)) made normal to the shank: no tibial torsion."""
    if not rec.has(p + "ANK"):
        return None
    ank = rec[p + "ANK"]
    u = unit(knee - ank)
    y = thigh[..., 1] - np.sum(thigh[..., 1] * u, axis=-1, keepdims=True) * u
    return ank - lat * half * unit(y), "on the knee's flexion axis"


def _leg(rec: _Recording, theta: np.ndarray, subject: Subject, pelvis: _Frame, side: str,
         p: str, lat: float, out: Construction) -> None:  # fmt: skip
    """One leg's centres and the thigh, shank and foot frames."""
    pset = rec.pset
    hip = _place(pelvis, pset.body_pos(theta)[pset.model.body(f"thigh_{side}").id])
    out.centres[f"hip_{side}"] = hip
    half, how = _half_width(pset, theta, subject, "knee_width", side)
    knee = _centre(rec, p, "KNE", "THI", hip, half)
    if knee is None:
        return
    out.centres[f"knee_{side}"], src = knee[0], knee[1]
    out.sources[f"knee_{side}"] = src if "midpoint" in src else f"{src}, {how}"
    out.frames[f"thigh_{side}"] = (frame_zy(hip - knee[0], lat * (rec[p + "KNE"] - knee[0])), hip)
    half, how = _half_width(pset, theta, subject, "ankle_width", side)
    thigh = out.frames[f"thigh_{side}"][0]
    ankle = _pair_midpoint(rec, p, "ANK") or _on_knee_axis(rec, p, lat, thigh, knee[0], half)
    if ankle is None:
        return
    out.centres[f"ankle_{side}"], src = ankle[0], ankle[1]
    out.sources[f"ankle_{side}"] = src if "midpoint" in src else f"{src}, {how}"
    shank = frame_zy(knee[0] - ankle[0], lat * (rec[p + "ANK"] - ankle[0]))
    out.frames[f"shank_{side}"] = (shank, knee[0])


def hinge_elbow(
    sjc: np.ndarray, elb: np.ndarray, wjc: np.ndarray, half: float, side: str
) -> np.ndarray:
    """Elbow centre (T, 3) [m] of a hinge whose flexion axis ``a`` passes through the elbow
    marker ``elb``, normal to the upper arm (to ``sjc``) and the forearm (to ``wjc``), the
    centre ``half`` (width/2 + marker radius [m]) from the marker: ``a . (sjc - elb) =
    a . (wjc - elb) = -half``, ``|a| = 1``, of the two solutions the one that bends the arm
    forward (Plug-in Gait's side). Exact for the model's elbow whatever the bend, but in a
    near-straight arm the bend it gives turns with the width: a width 10 % off bends a
    straight arm by about 7 degrees and tilts its axis by 26 (:data:`STRAIGHT_BEND_DEG`)."""
    u, v = sjc - elb, wjc - elb
    uu, uv, vv = (np.sum(x * y, axis=-1) for x, y in ((u, u), (u, v), (v, v)))
    with np.errstate(invalid="ignore", divide="ignore"):
        det = uu * vv - uv**2
        p = (-half * (vv - uv) / det)[..., None] * u + (-half * (uu - uv) / det)[..., None] * v
        norm = np.linalg.norm(p, axis=-1, keepdims=True)
        t = np.sqrt(np.clip(1.0 - norm**2, 0.0, None)) * (1.0 if side == "l" else -1.0)
        axis = np.where(norm > 1.0, p / norm, p + t * unit(np.cross(u, v)))
    return elb - half * axis


def straight_elbow(sjc: np.ndarray, elb: np.ndarray, wjc: np.ndarray) -> np.ndarray:
    """Elbow centre (T, 3) [m] of a straight arm: the point of the line from the shoulder
    centre ``sjc`` to the wrist centre ``wjc`` (T, 3) [m] nearest to the elbow marker
    ``elb`` (the flexion axis through the marker, normal to the arm). It needs no width: the
    marker's distance from the line is the recording's; a residual bend b moves the centre
    off the line by about 0.14 m sin b (7 mm at 3 degrees), normal to the axis."""
    line = unit(wjc - sjc)
    return sjc + np.sum((elb - sjc) * line, axis=-1, keepdims=True) * line


def elbow_bend(sjc: np.ndarray, ejc: np.ndarray, wjc: np.ndarray) -> np.ndarray:
    """The elbow's bend (T,) [deg]: the angle between the upper arm and the forearm."""
    cos = np.sum(unit(ejc - sjc) * unit(wjc - ejc), axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _arms(rec: _Recording, theta: np.ndarray, subject: Subject, s: float,
          out: Construction) -> None:  # fmt: skip
    """Plug-in Gait's shoulder, elbow and wrist centres, the upper arm and radius frames."""
    if not rec.has("C7", "T10", "CLAV", "STRN"):
        return
    trunk = ("C7", "T10", "CLAV", "STRN")
    m = Markers({r: rec[r] for r in trunk}, len(rec.markers))
    thorax = trunk_frames(m, subject.marker_radius, 0.0)["thorax"]
    pset, r = rec.pset, subject.marker_radius
    ref = np.stack([_offset(pset, theta, rec.name(n)) for n in trunk])
    model_thorax = rigid_fit(np.stack([rec[n] for n in trunk], axis=1), ref)
    bodies = {pset.model.body(b).name: pset.body_pos(theta)[b] for b in range(pset.model.nbody)}
    for side, p, lat in _SIDES:
        if not rec.has(p + "SHO", p + "ELB", p + "WRA", p + "WRB"):
            continue
        if f"clavicle_{side}" in bodies:
            out.centres[f"sc_{side}"] = _place(model_thorax, bodies[f"clavicle_{side}"])
        off = subject.get(f"shoulder_offset_{side}")
        off = SHOULDER_ABOVE * s - r if off is None else off
        sjc = centres.shoulder(thorax.axes, thorax.origin, rec[p + "SHO"], off, r, side)
        elb, wra, wrb = rec[p + "ELB"], rec[p + "WRA"], rec[p + "WRB"]
        wri = 0.5 * (wra + wrb)
        half, how = _half_width(rec.pset, theta, subject, "elbow_width", side)
        wrist_half, wrist_how = _half_width(rec.pset, theta, subject, "wrist_width", side)
        ejc = centres.elbow(sjc, elb, wri, 2 * (half - r), r, side)
        bend = elbow_bend(sjc, hinge_elbow(sjc, elb, wri, half, side), wri)
        bent = bend >= MIN_ELBOW_BEND_DEG
        straight = np.isfinite(bend) & (np.sum(bent) < MIN_BENT_SHARE * np.sum(np.isfinite(bend)))
        if not np.any(bent | straight):
            continue
        ejc[~bent] = np.nan
        wjc = wri
        line = straight & (bend < STRAIGHT_BEND_DEG)
        hinge = straight & ~line
        for _ in range(3 if np.any(straight) else 1):  # the wrist's centre, the elbow's
            ejc[line] = straight_elbow(sjc, elb, wjc)[line]
            ejc[hinge] = hinge_elbow(sjc, elb, wjc, half, side)[hinge]
            radius_y = frame(2, ejc - wri, 0, wra - wrb)[..., 1]
            wjc = centres.wrist(wri, radius_y, 2 * (wrist_half - r), r, side)
        out.centres.update({f"shoulder_{side}": sjc, f"elbow_{side}": ejc, f"wrist_{side}": wjc})
        out.sources[f"shoulder_{side}"] = "Plug-in Gait's shoulder centre"
        out.sources[f"elbow_{side}"] = (
            f"Plug-in Gait's elbow centre, {how}"
            if not np.any(straight)
            else "a straight arm's elbow centre (the shoulder-wrist line's, or the hinge's)"
        )
        out.sources[f"wrist_{side}"] = f"Plug-in Gait's wrist centre, {wrist_how}"
        out.frames[f"upperarm_{side}"] = (frame_zy(sjc - ejc, lat * (elb - ejc)), sjc)
        out.frames[f"radius_{side}"] = (frame_zy(ejc - wjc, lat * (wra - wrb)), ejc)


def construct(
    pset: ParameterSet,
    theta: np.ndarray,
    markers: np.ndarray,
    subject: Subject,
    *,
    hip_centre: str = "harrington",
    landmarks: Mapping[str, str] | None = None,
) -> tuple[Construction, np.ndarray]:
    """The constructions (module docstring) on ``markers`` (T, M, 3) [m] (``pset``'s order,
    NaN where missing) with the scaled model ``theta`` (P,) [m] (its pelvis markers and its
    lengths for a regressed width); returns them and ``theta`` with its hip parameters."""
    rec = _Recording(pset, markers, landmarks or {})
    out = Construction()
    theta = _hip_theta(pset, theta, subject, hip_centre, landmarks or {})
    pelvis = _pelvis(rec, theta, out)
    if pelvis is not None:
        for side, p, lat in _SIDES:
            if f"thigh_{side}" in {pset.model.body(b).name for b in range(pset.model.nbody)}:
                _leg(rec, theta, subject, pelvis, side, p, lat, out)
                out.sources[f"hip_{side}"] = (
                    "Davis et al. (1991)" if hip_centre == "davis" else "Harrington et al. (2007)"
                )
    stature = subject.stature()
    _arms(rec, theta, subject, stature[0] / 1.75 if stature else 1.0, out)
    return out, theta


def _median_distance(a: np.ndarray, b: np.ndarray) -> float:
    d = np.linalg.norm(a - b, axis=-1)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")


#: Segment length parameter (side appended) -> the two joint centres it spans.
LENGTHS: dict[str, tuple[str, str]] = {
    "clavicle_length": ("sc", "shoulder"),
    "thigh_length": ("hip", "knee"),
    "shank_length": ("knee", "ankle"),
    "upperarm_length": ("shoulder", "elbow"),
    "forearm_length": ("elbow", "wrist"),
}


def constructed_theta(
    pset: ParameterSet,
    theta: np.ndarray,
    markers: np.ndarray | Sequence[np.ndarray],
    subject: Subject,
    *,
    hip_centre: str = "harrington",
    landmarks: Mapping[str, str] | None = None,
) -> tuple[np.ndarray, tuple[str, ...], dict[str, str]]:
    """The initial model from the constructions (module docstring).

    Parameters
    ----------
    pset : ParameterSet
    theta : (P,) [m]
        The scaled model (:func:`~mocap_mj.anatomy.initial.scaled_theta`): the parameters no
        construction places keep its values.
    markers : (T, M, 3) [m] or a sequence of (T_i, M, 3) arrays, NaN where missing
    subject : Subject
        Its measured widths and offsets, its marker radius.

    Returns
    -------
    theta : (P,) [m]
    placed : the markers whose offsets the constructions placed
    sources : joint centre (``knee_l``...) -> its construction, in words
    """
    trials = [markers] if isinstance(markers, np.ndarray) else list(markers)
    stacked = np.concatenate([np.asarray(t, dtype=float) for t in trials], axis=0)
    con, out = construct(pset, theta, stacked, subject, hip_centre=hip_centre,
                         landmarks=landmarks)  # fmt: skip
    for length, (a, b) in LENGTHS.items():
        for side in ("l", "r"):
            ca, cb = con.centres.get(f"{a}_{side}"), con.centres.get(f"{b}_{side}")
            name = f"{length}_{side}"
            if ca is not None and cb is not None and name in pset.names:
                d = _median_distance(ca, cb)
                if np.isfinite(d):
                    out[pset.index(name)] = d
    for name in ("knee_lateral", "ankle_lateral"):  # the centres lie on the frames' z axes
        for side in ("l", "r"):
            child = {"knee_lateral": "shank", "ankle_lateral": "foot"}[name]
            if f"{child}_{side}" in con.frames and f"{name}_{side}" in pset.names:
                out[pset.index(f"{name}_{side}")] = 0.0
    placed = _place_offsets(pset, con, stacked, out)
    return out, placed, con.sources


def _place_offsets(
    pset: ParameterSet, con: Construction, markers: np.ndarray, theta: np.ndarray
) -> tuple[str, ...]:
    """Every marker of a constructed body placed in ``theta`` (in place) at the median of
    its position in the body's frame; the markers placed."""
    placed = []
    for j, marker in enumerate(pset.marker_names):
        body = pset.model.body(int(pset.site_body[j])).name
        f = con.frames.get(body)
        if f is None:
            continue
        local = np.einsum("tji,tj->ti", f[0], markers[:, j] - f[1])
        ok = np.all(np.isfinite(local), axis=1)
        if not np.any(ok):
            continue
        k = pset.n_kappa + 3 * j
        theta[k : k + 3] = np.median(local[ok], axis=0)
        placed.append(marker)
    return tuple(placed)
