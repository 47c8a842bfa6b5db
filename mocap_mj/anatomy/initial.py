"""An initial model scaled to the subject from robust marker distances.

The joint LM starts from an initial model theta0, which is also its weak prior's mean. The
nominal humanoid (a 1.75 m adult) can be far from a real subject (a wide pelvis, long shanks,
a small head band). :func:`scaled_theta` scales it segment by segment. Every scale is a
measured distance divided by the same distance on the nominal model in its reference pose,
the measured one the median over the frames where its markers are seen (gaps, a few wild
samples and the poses of the trial matter little). The distances are chosen to be rigid in
the model (they do not change with the joint angles), so a trial with large motion gives the
same scales as a static one:

================  ===========================================================================
scale             distance (measured / nominal)
================  ===========================================================================
pelvis_width      LASI-RASI (inter-ASIS width)
pelvis_depth      mid-ASIS to mid-PSIS
psis_width        LPSI-RPSI
thorax            RMS distance of C7, T10, CLAV, STRN from their centroid
head              RMS distance of LFHD, RFHD, LBHD, RBHD from their centroid
clavicle_l/_r     sternoclavicular joint (thorax frame) to the glenohumeral centre (GH)
upperarm_l/_r     GH to ELB
forearm_l/_r      ELB to the WRA-WRB midpoint (ELB sits on the elbow flexion axis)
thigh_l/_r        hip joint centre (HJC) to KNE
shank_l/_r        KNE to ANK (KNE sits on the knee flexion axis)
foot_l/_r         HEE to TOE
overall           median of the measured ratios above, the fallback of a scale whose
                  markers are missing (and of parameters a custom model adds)
================  ===========================================================================

Frames and joint centres behind them: the pelvis frame in every frame is the rigid (Kabsch)
fit of the pelvis-scaled nominal LASI, RASI, LPSI, RPSI to the measured ones; HJC is the
nominal one, scaled as its parameters (below), in that frame. The thorax frame is the rigid
fit of the thorax-scaled nominal C7, T10, CLAV, STRN; the sternoclavicular joints are the
thorax-scaled nominal ones in that frame. GH is SHO plus the nominal SHO-to-GH vector (4.6 cm
down) turned by the thorax frame (the clavicle's own rotation is ignored: a few millimetres).

Kinematic parameters (nominal value x scale):

* ``hip_depth/width/height_l/_r``: ``pelvis_width``, as Bell et al. (1989) predict the hip
  joint centre from the inter-ASIS distance (the nominal model uses their ratios);
* ``lumbar_depth``, ``lumbar_height``: ``pelvis_depth``;
* ``lumbar_length``, ``thorax_length``, ``neck_depth``, ``sc_depth``, ``sc_height_*``,
  ``sc_width_*``: ``thorax``. No marker distance measures the lumbar length well: mid-ASIS to
  C7 changes with trunk flexion, and a rigid fit of the thorax markers places the thorax
  origin (T12/L1) where the nominal T10 offset says, which real T10 placements miss by
  centimetres (C7-T10 is 206 mm on the nominal model, 240-290 mm on the shared real trials);
* ``clavicle_length``, ``upperarm_length``, ``forearm_length``, ``thigh_length``,
  ``shank_length``, ``foot_length``, ``foot_height``: their segment's scale, per side.

Marker offsets: the nominal offset times the scale of the segment that carries it. Pelvis:
LASI/RASI ``y`` by ``pelvis_width``, LPSI/RPSI ``x, z`` by ``pelvis_depth`` and ``y`` by
``psis_width`` (the model then reproduces the three pelvis distances); thorax markers by
``thorax``; head markers by ``head``; SHO by ``clavicle``; upper arm by ``upperarm``; ulna,
radius and hand by ``forearm``; thigh, shank, foot and toes by their segment's scale.

A measured ratio carries the markers' placement error, large on a short distance (LPSI-RPSI
is 90 mm): the scale used for the skeleton is the ratio shrunk toward the overall scale by
its reliability (:func:`shrink`), while the pelvis markers keep the measured ratios (their
distances are measured, not modelled). A scale is clipped to [``MIN_SCALE``, ``MAX_SCALE``]
so that a mislabelled marker cannot make a degenerate model; :class:`ScaleEstimate` reports
it.

Stature. Without a measured height, :func:`estimate_stature` estimates the subject's
stature from the same distances: the nominal model's long bones are Winter's (2009, fig.
4.1) fractions of a 1.75 m stature (thigh 0.245 H, shank 0.246 H, upper arm 0.186 H,
forearm 0.146 H), so each measured long-bone ratio (``thigh``, ``shank``, ``upperarm``,
``forearm``, left and right: hip joint centre to KNE, KNE-ANK, glenohumeral centre to ELB,
ELB to the wrist bar) times 1.75 m is a stature; the estimate is their median (one
mislabelled or misplaced marker moves it little). Its standard deviation combines the
spread of a long bone's fraction of stature between subjects (:data:`STATURE_SPREAD`) with
the markers' placement error on the median. The ranges
(:mod:`mocap_mj.anatomy.ranges`) and the stature-scaled priors
(:mod:`mocap_mj.anatomy.anatomy`) are centred on it, so that a child is not held to an
adult's skeleton.

Scaling fixes the skeleton, not where an operator put the markers (the thigh and tibia wands
can sit anywhere along their segment): :func:`place_markers` then places every marker offset
where the trials' IK with the scaled skeleton puts it. ``mocap-mj identify`` starts from both
(the recipe's ``init: placed``; docs/method.md#the-initial-model).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mocap_mj.anatomy.ranges import NOMINAL_HEIGHT
from mocap_mj.capture.subject import StatureEstimate, Subject
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.skeleton.rigid import rigid_fit

from ..errors import MocapError, check_shape

#: Bounds of every segment scale (dimensionless).
MIN_SCALE = 0.5
MAX_SCALE = 2.0
#: Relative spread of a segment's scale about the subject's overall scale (:func:`shrink`).
SEGMENT_SPREAD = 0.05
#: Error of a distance between two skin markers from their placement [m] (:func:`shrink`).
PLACEMENT_ERROR = 0.015

#: Scales whose measured ratio (x NOMINAL_HEIGHT) estimates the stature (:func:`estimate_stature`).
STATURE_SCALES = tuple(f"{b}_{side}" for b in ("thigh", "shank", "upperarm", "forearm")
                       for side in ("l", "r"))  # fmt: skip
#: Relative standard deviation of a long bone's fraction of stature between subjects: 4 %
#: between adults (Winter 2009's fractions are means; the leg's share of stature varies by
#: 3-5 % between adults), widened to 6 % because a young child's legs are relatively shorter
#: (sitting height is 0.55-0.57 of stature at 3-6 years against 0.52 in adults).
STATURE_SPREAD = 0.06

#: Scale names and the distance each comes from (see the module docstring).
SCALES: dict[str, str] = {
    "pelvis_width": "LASI-RASI",
    "pelvis_depth": "mid-ASIS to mid-PSIS",
    "psis_width": "LPSI-RPSI",
    "thorax": "RMS distance of C7, T10, CLAV, STRN from their centroid",
    "head": "RMS distance of LFHD, RFHD, LBHD, RBHD from their centroid",
    "clavicle_l": "left sternoclavicular joint to glenohumeral centre",
    "clavicle_r": "right sternoclavicular joint to glenohumeral centre",
    "upperarm_l": "left glenohumeral centre to LELB",
    "upperarm_r": "right glenohumeral centre to RELB",
    "forearm_l": "LELB to the LWRA-LWRB midpoint",
    "forearm_r": "RELB to the RWRA-RWRB midpoint",
    "thigh_l": "left hip joint centre to LKNE",
    "thigh_r": "right hip joint centre to RKNE",
    "shank_l": "LKNE-LANK",
    "shank_r": "RKNE-RANK",
    "foot_l": "LHEE-LTOE",
    "foot_r": "RHEE-RTOE",
}

#: Kinematic parameter (side suffix removed) -> scale (the side is appended when the scale
#: has one).
KAPPA_SCALE: dict[str, str] = {
    "hip_depth": "pelvis_width",
    "hip_width": "pelvis_width",
    "hip_height": "pelvis_width",
    "lumbar_depth": "pelvis_depth",
    "lumbar_height": "pelvis_depth",
    "lumbar_length": "thorax",
    "thorax_length": "thorax",
    "neck_depth": "thorax",
    "sc_depth": "thorax",
    "sc_height": "thorax",
    "sc_width": "thorax",
    "clavicle_length": "clavicle",
    "upperarm_length": "upperarm",
    "forearm_length": "forearm",
    "thigh_length": "thigh",
    "shank_length": "shank",
    "foot_length": "foot",
    "foot_height": "foot",
}

#: Body (side suffix removed) -> scale of the marker offsets it carries (pelvis: see above).
BODY_SCALE: dict[str, str] = {
    "lumbar": "thorax",
    "thorax": "thorax",
    "head": "head",
    "clavicle": "clavicle",
    "upperarm": "upperarm",
    "ulna": "forearm",
    "radius": "forearm",
    "hand": "forearm",
    "thigh": "thigh",
    "shank": "shank",
    "foot": "foot",
    "toes": "foot",
}

_PELVIS = ("LASI", "RASI", "LPSI", "RPSI")
_THORAX = ("C7", "T10", "CLAV", "STRN")
_HEAD = ("LFHD", "RFHD", "LBHD", "RBHD")
_SIDES = (("l", "L"), ("r", "R"))


@dataclass(frozen=True)
class ScaleEstimate:
    """One segment scale.

    Attributes
    ----------
    name : str
        Key of :data:`SCALES`, or ``"overall"``.
    value : float
        The scale used (dimensionless): the measured ratio shrunk toward the overall scale
        (:func:`shrink`) and clipped, or the overall scale when the markers are missing.
    ratio : float
        Measured / nominal distance, clipped (NaN when the markers are missing).
    measured : float
        Median measured distance [m]; NaN when its markers are missing (``value`` is then the
        overall scale).
    nominal : float
        The same distance on the nominal model [m].
    source : str
        The distance, in words.
    clipped : bool
        The measured ratio was outside [MIN_SCALE, MAX_SCALE].
    """

    name: str
    value: float
    ratio: float
    measured: float
    nominal: float
    source: str
    clipped: bool = False


def _split_side(name: str) -> tuple[str, str]:
    """``"thigh_l"`` -> (``"thigh"``, ``"l"``); no suffix -> (name, "")."""
    return (name[:-2], name[-1]) if name[-2:] in ("_l", "_r") else (name, "")


def stack_trials(markers: np.ndarray | Sequence[np.ndarray], n_markers: int) -> np.ndarray:
    """One (T, M, 3) array [m] from one trial or several (their frames concatenated)."""
    arrays = [markers] if isinstance(markers, np.ndarray) else list(markers)
    if not arrays:
        raise MocapError("scaled_theta: no marker trials given")
    out = []
    for i, a in enumerate(arrays):
        a = np.asarray(a, dtype=float)
        check_shape(f"markers[{i}]", a, (None, n_markers, 3))
        out.append(a)
    return np.concatenate(out, axis=0)


def median_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Median over frames of |a - b| [m] (NaN if no frame has both)."""
    d = np.linalg.norm(a - b, axis=-1)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")


def _rms_spread(points: np.ndarray) -> np.ndarray:
    """RMS distance [m] of points (..., n, 3) from their centroid."""
    dev = points - points.mean(axis=-2, keepdims=True)
    return np.sqrt(np.mean(np.sum(dev**2, axis=-1), axis=-1))


class _Subject:
    """The trials' markers (T, M, 3) and the nominal model's reference pose, by name.

    In the reference pose (root at the origin, every joint at qpos0) all body frames are
    aligned with the pelvis frame, so a nominal position in a body's frame is the reference
    position minus that body's origin.
    """

    def __init__(self, pset: ParameterSet, markers: np.ndarray) -> None:
        self.pset = pset
        self.data = markers
        kin = Kinematics(pset)
        q0 = np.array(kin.model.qpos0, dtype=float)
        q0[:3] = 0.0
        q0[3:7] = (1.0, 0.0, 0.0, 0.0)
        frames = kin.forward(q0[None])
        self.ref = frames.site_xpos[0]
        self.body = {pset.model.body(b).name: frames.xpos[0, b] for b in range(pset.model.nbody)}

    def has(self, *names: str) -> bool:
        return all(n in self.pset.marker_names for n in names)

    def has_bodies(self, *names: str) -> bool:
        return all(n in self.body for n in names)

    def traj(self, name: str) -> np.ndarray:
        return self.data[:, self.pset.marker_index(name)]

    def nom(self, name: str) -> np.ndarray:
        return self.ref[self.pset.marker_index(name)]

    def trajs(self, names: Sequence[str]) -> np.ndarray:
        return np.stack([self.traj(n) for n in names], axis=1)

    def noms(self, names: Sequence[str]) -> np.ndarray:
        return np.stack([self.nom(n) for n in names])


def segment_scales(
    pset: ParameterSet, markers: np.ndarray | Sequence[np.ndarray]
) -> dict[str, ScaleEstimate]:
    """Per-segment scales of the subject against the nominal model (module docstring).

    Parameters
    ----------
    pset : ParameterSet
        Its nominal model is the one scaled.
    markers : (T, M, 3) [m] or a sequence of (T_i, M, 3) arrays (trials of one subject)
        Model marker order, NaN where missing.

    Returns
    -------
    dict of ScaleEstimate
        Keys: those of :data:`SCALES`, and ``"overall"``.
    """
    d = _Distances(_Subject(pset, stack_trials(markers, pset.n_markers)))
    _marker_distances(d)
    pelvis, thorax = _trunk_frames(d)
    _joint_distances(d, pelvis, thorax)
    return _estimates(d.raw)


class _Distances:
    """The measured and nominal distances [m] behind each scale of :func:`segment_scales`."""

    def __init__(self, s: _Subject):
        self.s = s
        self.raw: dict[str, tuple[float, float]] = {}  # scale -> (measured, nominal) [m]

    def value(self, name: str) -> float:
        """Scale measured so far (clipped), else 1: used to place joint centres."""
        if name not in self.raw:
            return 1.0
        meas, nom = self.raw[name]
        return float(np.clip(meas / nom, MIN_SCALE, MAX_SCALE)) if np.isfinite(meas) else 1.0

    def distance(self, name: str, a: np.ndarray, b: np.ndarray, nominal: float) -> None:
        self.raw[name] = (median_distance(a, b), nominal)

    def pair(self, name: str, a: str, b: str) -> None:
        s = self.s
        if s.has(a, b):
            self.distance(name, s.traj(a), s.traj(b), float(np.linalg.norm(s.nom(a) - s.nom(b))))

    def spread(self, name: str, names: Sequence[str]) -> None:
        s = self.s
        if s.has(*names):
            d = _rms_spread(s.trajs(names))
            d = d[np.isfinite(d)]
            self.raw[name] = (float(np.median(d)) if d.size else float("nan"),
                              float(_rms_spread(s.noms(names))))  # fmt: skip


def _marker_distances(d: _Distances) -> None:
    """The scales measured between markers alone: pelvis, thorax, head, shanks, feet, forearms."""
    s = d.s
    d.pair("pelvis_width", "LASI", "RASI")
    d.pair("psis_width", "LPSI", "RPSI")
    if s.has(*_PELVIS):
        asis = 0.5 * (s.traj("LASI") + s.traj("RASI"))
        psis = 0.5 * (s.traj("LPSI") + s.traj("RPSI"))
        nom = 0.5 * (s.nom("LASI") + s.nom("RASI") - s.nom("LPSI") - s.nom("RPSI"))
        d.distance("pelvis_depth", asis, psis, float(np.linalg.norm(nom)))
    d.spread("thorax", _THORAX)
    d.spread("head", _HEAD)
    for side, up in _SIDES:
        d.pair(f"shank_{side}", f"{up}KNE", f"{up}ANK")
        d.pair(f"foot_{side}", f"{up}HEE", f"{up}TOE")
        if s.has(f"{up}ELB", f"{up}WRA", f"{up}WRB"):
            wrist = 0.5 * (s.traj(f"{up}WRA") + s.traj(f"{up}WRB"))
            wrist0 = 0.5 * (s.nom(f"{up}WRA") + s.nom(f"{up}WRB"))
            d.distance(f"forearm_{side}", s.traj(f"{up}ELB"), wrist,
                       float(np.linalg.norm(s.nom(f"{up}ELB") - wrist0)))  # fmt: skip


_Frame = tuple[np.ndarray, np.ndarray]


def _trunk_frames(d: _Distances) -> tuple[_Frame | None, _Frame | None]:
    """The pelvis and thorax frames per frame (rotations (T, 3, 3), origins (T, 3) [m]) fitted
    to their markers on the nominal model scaled so far; None where markers or bodies lack."""
    s = d.s
    pelvis = None
    if s.has(*_PELVIS) and s.has_bodies("pelvis"):
        ref = s.noms(_PELVIS) - s.body["pelvis"]
        ref[:2, 1] *= d.value("pelvis_width")
        ref[2:, 0::2] *= d.value("pelvis_depth")
        ref[2:, 1] *= d.value("psis_width")
        pelvis = rigid_fit(s.trajs(_PELVIS), ref)
    thorax = None
    if s.has(*_THORAX) and s.has_bodies("thorax"):
        ref = (s.noms(_THORAX) - s.body["thorax"]) * d.value("thorax")
        thorax = rigid_fit(s.trajs(_THORAX), ref)
    return pelvis, thorax


def _place(frame: _Frame, local: np.ndarray) -> np.ndarray:
    """A point ``local`` (3,) [m] of the frame, per frame (T, 3) [m]."""
    rot, pos = frame
    return pos + np.einsum("tij,j->ti", rot, local)


def _joint_distances(d: _Distances, pelvis: _Frame | None, thorax: _Frame | None) -> None:
    """The scales measured from joint centres placed in the trunk frames: thighs (from the
    hip joint centres), clavicles and upper arms (from the glenohumeral centres)."""
    s, value, distance = d.s, d.value, d.distance
    if pelvis is not None:
        for side, up in _SIDES:
            if s.has_bodies(f"thigh_{side}") and s.has(f"{up}KNE"):
                hjc = _place(pelvis, (s.body[f"thigh_{side}"] - s.body["pelvis"]) *
                             value("pelvis_width"))  # fmt: skip
                knee = s.nom(f"{up}KNE") - s.body[f"thigh_{side}"]
                distance(f"thigh_{side}", hjc, s.traj(f"{up}KNE"), float(np.linalg.norm(knee)))
    if thorax is not None:
        for side, up in _SIDES:
            clav, arm = f"clavicle_{side}", f"upperarm_{side}"
            if not (s.has_bodies(clav, arm) and s.has(f"{up}SHO")):
                continue
            to_gh = (s.body[arm] - s.nom(f"{up}SHO")) * value("thorax")
            gh = s.traj(f"{up}SHO") + np.einsum("tij,j->ti", thorax[0], to_gh)
            sc = _place(thorax, (s.body[clav] - s.body["thorax"]) * value("thorax"))
            distance(clav, sc, gh, float(np.linalg.norm(s.body[arm] - s.body[clav])))
            if s.has(f"{up}ELB"):
                distance(arm, gh, s.traj(f"{up}ELB"),
                         float(np.linalg.norm(s.nom(f"{up}ELB") - s.body[arm])))  # fmt: skip


def shrink(ratio: float, overall: float, distance: float) -> float:
    """A segment's scale: its measured ratio shrunk toward the overall scale.

    The measured distance carries the markers' placement error (``PLACEMENT_ERROR`` [m] on a
    distance, whatever its length) and segments differ from the overall proportions by about
    ``SEGMENT_SPREAD`` (relative). The estimate is the precision-weighted mean of the two::

        value = overall (1 + w (ratio / overall - 1)),  w = s^2 / (s^2 + (e / d)^2)

    with s = SEGMENT_SPREAD, e = PLACEMENT_ERROR and d the nominal distance [m]: a long
    distance (thigh, w = 0.67) is trusted, a short one (LPSI-RPSI, 90 mm, w = 0.08) hardly.
    """
    w = SEGMENT_SPREAD**2 / (SEGMENT_SPREAD**2 + (PLACEMENT_ERROR / distance) ** 2)
    return overall * (1.0 + w * (ratio / overall - 1.0))


def _estimates(raw: dict[str, tuple[float, float]]) -> dict[str, ScaleEstimate]:
    ratios = {n: m / d for n, (m, d) in raw.items() if np.isfinite(m) and d > 0}
    inside = [v for v in ratios.values() if MIN_SCALE <= v <= MAX_SCALE]
    overall = float(np.median(inside)) if inside else 1.0
    out: dict[str, ScaleEstimate] = {}
    for name, source in SCALES.items():
        meas, nom = raw.get(name, (float("nan"), float("nan")))
        if name not in ratios:
            out[name] = ScaleEstimate(name, overall, float("nan"), float("nan"), nom, source)
            continue
        r = float(np.clip(ratios[name], MIN_SCALE, MAX_SCALE))
        value = float(np.clip(shrink(r, overall, nom), MIN_SCALE, MAX_SCALE))
        clipped = not MIN_SCALE <= ratios[name] <= MAX_SCALE
        out[name] = ScaleEstimate(name, value, r, meas, nom, source, clipped)
    out["overall"] = ScaleEstimate(
        "overall", overall, overall, float("nan"), float("nan"), "median of the segment ratios"
    )
    return out


def estimate_stature(scales: dict[str, ScaleEstimate]) -> StatureEstimate | None:
    """The subject's stature [m] from the long-bone scales (module docstring), or None when
    no long bone is measured.

    Value: ``NOMINAL_HEIGHT`` x the median of the measured (unshrunk) ratios of
    :data:`STATURE_SCALES`. Standard deviation: ``value x sqrt(STATURE_SPREAD^2 +
    (PLACEMENT_ERROR / d)^2 / n)`` with d the mean nominal distance and n the number of
    bones measured (the population spread does not average out over one subject's bones;
    the placement errors do).
    """
    used = [scales[n] for n in STATURE_SCALES if n in scales and np.isfinite(scales[n].ratio)]
    if not used:
        return None
    value = NOMINAL_HEIGHT * float(np.median([e.ratio for e in used]))
    d = float(np.mean([e.nominal for e in used])) * value / NOMINAL_HEIGHT
    rel = float(np.sqrt(STATURE_SPREAD**2 + (PLACEMENT_ERROR / d) ** 2 / len(used)))
    names = ", ".join(e.name for e in used)
    source = (
        f"median of {len(used)} long-bone distances ({names}) over Winter's (2009) fractions "
        "of stature"
    )
    return StatureEstimate(value, rel * value, source)


def marker_stature(scales: dict[str, ScaleEstimate]) -> float | None:
    """The stature [m] the long-bone marker distances alone imply: ``NOMINAL_HEIGHT`` x the
    median of their measured / nominal ratios, unclipped (a unit check: a recording in
    centimetres read as millimetres gives a tenth of a person); None without a long bone."""
    ratios = [
        scales[n].measured / scales[n].nominal
        for n in STATURE_SCALES
        if n in scales and np.isfinite(scales[n].measured)
    ]
    return NOMINAL_HEIGHT * float(np.median(ratios)) if ratios else None


def scaled_theta(
    pset: ParameterSet,
    markers: np.ndarray | Sequence[np.ndarray],
    scales: dict[str, ScaleEstimate] | None = None,
) -> np.ndarray:
    """The nominal model scaled to the subject, segment by segment.

    Parameters
    ----------
    pset : ParameterSet
    markers : (T, M, 3) [m] or a sequence of (T_i, M, 3) arrays (trials of one subject)
        Model marker order, NaN where missing.
    scales : dict of ScaleEstimate, optional
        From :func:`segment_scales` (computed from ``markers`` when omitted).

    Returns
    -------
    theta0 : (P,) [m]
        Kinematic parameters and marker offsets scaled as the module docstring describes;
        parameters and markers it does not know (a custom model) are scaled by the overall
        scale.
    """
    sc = scales if scales is not None else segment_scales(pset, markers)
    overall = sc["overall"].value

    def get(base: str | None, side: str) -> float:
        if base is None:
            return overall
        key = f"{base}_{side}" if f"{base}_{side}" in sc else base
        return sc[key].value if key in sc else overall

    def ratio(key: str) -> float:
        """Pelvis markers: the measured ratio (their distances are measured, not modelled)."""
        r = sc[key].ratio if key in sc else float("nan")
        return r if np.isfinite(r) else get(key, "")

    kappa, offsets = (a.copy() for a in pset.split(pset.nominal))
    for i, name in enumerate(pset.kappa_names):
        base, side = _split_side(name)
        kappa[i] *= get(KAPPA_SCALE.get(base), side)
    for j, marker in enumerate(pset.marker_names):
        body = pset.model.body(int(pset.site_body[j])).name
        if body == "pelvis" and marker in ("LASI", "RASI"):
            offsets[j] *= (1.0, ratio("pelvis_width"), 1.0)
        elif body == "pelvis" and marker in ("LPSI", "RPSI"):
            depth = ratio("pelvis_depth")
            offsets[j] *= (depth, ratio("psis_width"), depth)
        else:
            base, side = _split_side(body)
            offsets[j] *= get(BODY_SCALE.get(base), side)
    return pset.join(kappa, offsets)


#: Markers Plug-in Gait lets the operator place anywhere along (or on) their segment: thigh and
#: tibia wands, upper-arm and forearm markers, the asymmetric back marker. Their nominal
#: offsets say nothing about a subject, so :func:`place_markers` leaves them out of its first IK.
FLOATING_MARKERS: tuple[str, ...] = (
    "LTHI", "RTHI", "LTIB", "RTIB", "LUPA", "RUPA", "LFRM", "RFRM", "RBAK",
)  # fmt: skip


def _local_medians(
    kin: Kinematics, markers: list[np.ndarray], qpos: list[np.ndarray], which: np.ndarray
) -> np.ndarray:
    """Median over frames of markers ``which`` in their body's frame (n, 3) [m].

    A marker with no data in any frame gets NaN (the caller keeps its nominal offset).
    """
    local = []
    for mk, q in zip(markers, qpos, strict=True):
        ok = np.all(np.isfinite(q), axis=1)
        if not np.any(ok):
            continue
        fr = kin.forward(q[ok])
        body = kin.pset.site_body[which]
        rel = mk[ok][:, which] - fr.xpos[:, body]
        local.append(np.einsum("tmji,tmj->tmi", fr.xmat[:, body], rel))
    if not local:
        return np.full((len(which), 3), np.nan)
    stacked = np.concatenate(local, axis=0)
    out = np.full((len(which), 3), np.nan)
    seen = np.any(np.isfinite(stacked[..., 0]), axis=0)
    out[seen] = np.nanmedian(stacked[:, seen], axis=0)
    return out


def place_markers(
    pset: ParameterSet,
    theta: np.ndarray,
    markers: np.ndarray | Sequence[np.ndarray],
    *,
    floating: Sequence[str] = FLOATING_MARKERS,
    rounds: int = 2,
    kept: Sequence[str] = (),
) -> np.ndarray:
    """Marker offsets of theta placed where the trials put them, the skeleton kept.

    Real markers sit centimetres from any nominal placement (the shared real trials: 40-50 mm
    marker RMSE after IK with the scaled model), which sends the first IK of the joint LM into
    wrong poses. This alternates, for the kinematic parameters of theta fixed: IK of every
    trial (the ``floating`` markers left out of the first one), then every marker's offset set
    to the median over frames of its measured position in its body's frame (``rounds`` times).
    Offsets of markers never seen keep their value.

    Parameters
    ----------
    pset : ParameterSet
    theta : (P,) [m]
        Initial model (e.g. :func:`scaled_theta`); its kinematic parameters are kept.
    markers : (T, M, 3) [m] or a sequence of (T_i, M, 3) arrays
    floating : sequence of str
        Markers whose nominal offset is not trusted for the first IK.
    rounds : int
        IK-and-place alternations after the first placement of the floating markers.
    kept : sequence of str
        Markers whose offsets in theta are kept and trusted from the first IK on (those the
        constructions placed, :func:`~mocap_mj.anatomy.constructed.constructed_theta`).

    Returns
    -------
    theta : (P,) [m]
    """
    from mocap_mj.solve.ik import IKSolver

    trials = [markers] if isinstance(markers, np.ndarray) else list(markers)
    trials = [np.asarray(t, dtype=float) for t in trials]
    stack_trials(trials, pset.n_markers)  # shape checks
    kin = Kinematics(pset)
    kin.set_theta(theta)
    solver = IKSolver(kin)
    k = pset.n_kappa
    weights = np.array([0.0 if n in floating and n not in kept else 1.0
                        for n in pset.marker_names])  # fmt: skip
    free = np.array([n not in kept for n in pset.marker_names])
    steps = [np.flatnonzero(weights == 0.0)] + [np.flatnonzero(free)] * rounds
    for i, which in enumerate(steps):
        if which.size == 0:
            continue
        w = weights if i == 0 else None
        qpos = [solver.solve_trial(t, w).qpos for t in trials]
        med = _local_medians(kin, trials, qpos, which)
        th = kin.theta.copy()
        for j, m in zip(which, med, strict=True):
            if np.all(np.isfinite(m)):
                th[k + 3 * j : k + 3 * j + 3] = m
        kin.set_theta(th)
    return kin.theta.copy()


def with_stature(subject: Subject, pset: ParameterSet, markers: Sequence[np.ndarray]) -> Subject:
    """``subject`` with the stature estimated from the trials' ``markers`` (each (T_i, M, 3)
    [m]; :func:`estimate_stature`) when its height is not measured: the anatomical ranges
    and the stature-scaled priors are centred on it."""
    if subject.get("height") is not None:
        return subject
    return subject.with_stature_estimate(estimate_stature(segment_scales(pset, markers)))
