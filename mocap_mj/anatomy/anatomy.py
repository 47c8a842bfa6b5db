"""Anatomical priors on theta: where each Plug-in Gait marker sits on its segment.

The markers cannot determine every parameter (the position of a joint centre along a hinge
axis, the pelvis frame against its markers, a segment's origin seen through one marker):
there the prior decides, so it must be anatomy, not the nominal model. Every prior here is
linear in theta and Gaussian (:class:`LinearGaussianPrior`): ``a_r . theta = b_r`` with a
standard deviation ``sigma_r`` [m]. A row may tie a marker offset to a kinematic parameter
(KNE's offset along the thigh equals minus the thigh length: Plug-in Gait puts KNE on the
lateral epicondyle, on the knee flexion axis), a marker's lateral offset to a subject
measurement (KNE lateral of the knee centre by KneeWidth/2 + marker radius), a hip centre to
the pelvis markers (Harrington et al. 2007), or a left length to a right one (the recipe's
``symmetric``).

The rows name Plug-in Gait's markers; in another set the markers whose landmarks fill those
roles take them (:mod:`mocap_mj.capture.roles`: ``L_FLE`` on the lateral femoral epicondyle
gets LKNE's rows).

Marker classes (:func:`mocap_mj.capture.marker_set.marker_class`, from the marker-set file):
*landmark* markers sit on a palpated bony landmark that the marker set defines relative to
the joint centres: they get the rows of
:data:`LANDMARK_ROWS`; *cluster* and *free* markers (wands, free-placed THI, TIB, UPA, FRM,
RBAK) get no anatomical row, only the weak prior of the LM toward the initial placement
(``LMSettings.prior_sigma``, 50 mm).

Widths (standard deviations, per row) and their sources:

* :data:`SIGMA_LANDMARK` = 10 mm: a palpated landmark's position relative to the joint centre
  it defines (inter-examiner palpation precision of pelvis, knee and ankle landmarks 5-15 mm,
  Della Croce et al. 1999, 2005), for the along-segment and antero-posterior components;
* :data:`SIGMA_MIDLINE` = 5 mm: C7, T10, CLAV, STRN on the mid-sagittal plane, the ASIS
  markers defining the pelvis origin (mid-ASIS) and plane, and the tilt of the pelvis and
  thorax frames against their markers (mid-PSIS 20 mm above mid-ASIS; Plug-in Gait's thorax
  axis from mid(T10, STRN) to mid(C7, CLAV)): directions the data leave free, fixed so that
  the rows written in those frames mean the same on every trial;
* :data:`SIGMA_MEASURED` = 1.5 mm: a lateral offset from a caliper-measured width (caliper
  precision 1-2 mm). Plug-in Gait takes the measurement as exact; at 3 mm the jump of the
  pyCGM files pulled the knee centres 10-11 mm toward KNE;
* :data:`SIGMA_REGRESSED` = 12 mm: the same offset from a width regressed on a segment
  length (:data:`WIDTH_RATIO`; joint widths vary with body mass at a given length);
* :data:`SIGMA_HJC` = 8 mm: Harrington et al. (2007) hip centre per axis (their regression
  errors, 4-9 mm, plus the ASIS/PSIS marker placement);
* :data:`SIGMA_SOFT` = 15 mm: landmarks whose position relative to a joint varies between
  adults (HEE, FIN);
* :data:`SIGMA_CONVENTION` = 3 mm: the joints of the model that stand in for a chain of
  joints (C7/T1 for the cervical spine, T12/L1 and L5/S1 for the thoracolumbar spine, the
  sternoclavicular joints for the shoulder girdle, whose clavicle carries the acromion marker
  of the scapula; the glenohumeral centre under SHO, its front-back and lateral rows, the
  clavicle's end standing in for a glenoid that moves with the scapula). Such a joint has
  no functional centre: the point about which the data turn it moves with the motion
  (model error, not information about the subject), so these rows define it from the
  markers of its segment, as Plug-in Gait defines its segments, and must outweigh the data:
  Dumas et al. (2007) C7/T1 from C7 and CLAV and T12/L1 from T10
  and C7 with the nominal model's proportions (T12/L1's height along the spine at T10's
  placement width instead, :data:`SIGMA_T10_LEVEL`), written so that they do not depend on how
  the frame is tilted against its markers; L5/S1 as Reed et al. (1999) define it, behind
  and above mid-ASIS in proportion to the ASIS width, in the pelvis frame (whose tilt the
  pelvis-tilt row fixes, as for Harrington's hip centres; Reed's frame is the anterior pelvic
  plane, which Plug-in Gait's markers do not give): not along the ASIS-PSIS line, which
  moves L5/S1 with the PSIS markers' placement (the most variable of the pelvis's);
  the nominal model's L5/S1 is Reed's, so these rows are centred on the
  synthetic truth; the SC joints
  beside and level with CLAV; the ankle centre on the transmalleolar axis at ANK's level
  and depth (ANK's x and z rows; its lateral row stays the width's): the model's ankle is
  one point where its ankle and subtalar hinges cross, the talocrural and subtalar axes are
  skew and a centimetre or more apart (Isman & Inman 1969), so the point about which a
  jump turns the foot is not the subject's either (it sat 16-20 mm below ANK at 10 mm);
  the elbow centre likewise on the transepicondylar axis at ELB's level and depth (ELB's x
  and z rows; its lateral row stays the width's): the model's elbow is one point where a
  flexion hinge perpendicular to the forearm and the pronation hinge cross, while the
  humeroulnar axis is tilted against the forearm (the carrying angle, 10-15 degrees) and
  the pronation axis runs from the radial head to the ulnar head, so the point about which
  trials at different elbow angles turn the forearm moves with them (one model for a jump
  at 15-25 degrees and a pose at 90 put it 25-30 mm ahead of ELB at 10 mm); the
  glenohumeral centre from SHO (its rows: :mod:`~mocap_mj.anatomy.shoulders`, else under
  SHO; the height the shoulder offset's): the model's glenohumeral centre is the end
  of a clavicle turning about its SC joint, standing in for a glenoid that the scapula
  carries as it turns and glides on the thorax with the arm, so the point about which a
  trial turns the humerus depends on that trial's arm motion; Plug-in Gait defines the
  shoulder centre from SHO and the shoulder offset alone.
  At 10 mm the data moved these joints 30-60 mm between trials of one
  subject, at 3 mm they hold within a few mm (docs/model.md#convention-joints);
* :data:`SIGMA_T10_LEVEL` = 15 mm (x stature / 1.75 m): T12/L1's height above or below the
  T10 marker (the thorax frame's z row of :func:`_spine_joint_rows`; its antero-posterior
  row stays a convention row). T10's spinous process is found by counting ten spinous
  processes down from C7 and can be missed by a level (a thoracic vertebra and its disc:
  about 25 mm). At 3 mm the row made the marker's placement the skeleton's: on the shared
  Vicon trials, whose C7-T10 distance is 267-287 mm (0.16-0.17 of the 1.68 m height, the
  nominal model's 0.12), it held ``lumbar_length`` at its lower bound (the markers wanted
  84-97 mm, about 0.05 of stature); at 25 mm one subject's lumbar:thorax distance moved
  7 mm between its trials, at 15 mm 6 mm (3.5 at 3 mm);
* :data:`LUMBAR_SPREAD` = 8 % of the stature-scaled nominal: ``lumbar_length`` (T12/L1 to
  L5/S1: the five lumbar vertebrae and their discs, about a tenth of stature; the nominal
  180 mm of 1.75 m) between adults of one stature, :func:`_trunk_rows`: with the loose
  T10 row, it keeps the lumbar spine human where the marker does not place it;
* :data:`THORAX_SPREAD` = 8 % of the stature-scaled nominal: ``thorax_length`` (T12/L1 to
  C7/T1: the twelve thoracic vertebrae and their discs; the nominal 260 mm of 1.75 m, 0.149
  of stature) between adults of one stature, as for the lumbar spine (trunk segment
  lengths as fractions of stature: standard deviations 5-8 % of the mean, de Leva 1996,
  Dumas et al. 2007 Table 2): where no marker places T12/L1 well (a misplaced T10,
  :mod:`mocap_mj.anatomy.trunk`; the pelvis unmarked, so that no L5/S1 row and no
  ``lumbar_length`` row hold it either) it keeps the thorax human;
* :data:`~mocap_mj.anatomy.foot.SIGMA_FOOT_LENGTH`, ``SIGMA_FOOT_HEIGHT`` = 7, 8 mm (x
  stature / 1.75 m): the MTP joint from the stature, beside TOE's rows
  (:func:`~mocap_mj.anatomy.foot.foot_rows`), and ``SIGMA_FOOT_TURN`` = 15 deg: the foot's
  turn about an ankle axis that a landmark places;
* :data:`SIGMA_LEG` = 15 mm: the ASIS-to-medial-malleolus distance of the straight leg against
  the measured leg length (:func:`_leg_length_row`): the tape's precision (about 10 mm), the
  hip's angle in the pelvis frame while it was measured (5 degrees of pelvic tilt: 4 mm),
  the malleolus's level and the tape's path over the knee (5 mm each);
* :data:`ASYMMETRY_SIGMA` = 5 mm: left minus right length in healthy adults (anatomic
  limb-length inequality, mean 5.2 mm; Knutson 2005), :func:`symmetric_prior`.

The data and the prior are weighed against each other through ``noise``: the prior's cost is
``1/2 noise^2 sum_r ((a_r . theta - b_r) / sigma_r)^2`` next to the markers' ``1/2 sum d^2``,
so ``noise`` is the per-axis marker noise of an independent observation. On real recordings
the residuals are soft-tissue artefact correlated over tens of frames
(:func:`mocap_mj.solve.noise.residual_correlation_time`): the pipeline sets ``noise`` to
the artefact's per-axis size (at least the fit's sigma, at least
:data:`~mocap_mj.solve.noise.SOFT_TISSUE_SIGMA`) times the square root of that time.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence

import numpy as np

from mocap_mj.anatomy.arm_axes import arm_rows
from mocap_mj.anatomy.axis_rows import (
    PIG_AXIS_WANDS,
    medial_pairs,
    medial_rows,
    nominal_offset,
    pig_axis_row,
    wand_width,
)
from mocap_mj.anatomy.foot import foot_rows
from mocap_mj.anatomy.hips import davis_rows
from mocap_mj.anatomy.ranges import NOMINAL_HEIGHT
from mocap_mj.anatomy.shoulders import pig_shoulder_offsets
from mocap_mj.anatomy.trunk import T10Placement
from mocap_mj.capture.roles import renamed, roles
from mocap_mj.capture.subject import Subject
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.priors import LinearGaussianPrior

SIGMA_LANDMARK = 0.010
SIGMA_MIDLINE = 0.005
SIGMA_MEASURED = 0.0015
SIGMA_REGRESSED = 0.012
SIGMA_HJC = 0.008
SIGMA_SOFT = 0.015
SIGMA_LEG = 0.015
ASYMMETRY_SIGMA = 0.005
SIGMA_CONVENTION = 0.003
SIGMA_T10_LEVEL = 0.015
LUMBAR_SPREAD = 0.08
THORAX_SPREAD = 0.08

#: C7/T1 from the C7 marker: fraction of the C7-CLAV distance and angle [deg] above that line
#: (Dumas, Cheze, Verriest 2007, Table 2, men; after Reed, Manary, Schneider 1999).
CJC_RATIO, CJC_ANGLE = 0.55, 8.0
#: T12/L1 from the T10 marker, fractions of the C7-T10 distance along that line (downward)
#: and anterior of it: the nominal model's (T10 50 mm above and 75 mm behind T12/L1).
T12_ALONG, T12_FORWARD = 0.206, 0.386
#: L5/S1 behind and above mid-ASIS, fractions of the ASIS width (Reed, Manary, Schneider
#: 1999, men, as Dumas et al. 2007 use it), in the pelvis frame (module docstring).
L5S1_BEHIND, L5S1_ABOVE = 0.264, 0.126
#: mid-PSIS above mid-ASIS in the pelvis frame [m] on a 1.75 m adult (the nominal model's).
PSIS_ABOVE_ASIS = 0.02
#: The medial malleolus's prominence above the ankle centre [m] on a 1.75 m adult: Plug-in
#: Gait puts the ankle centre at the level of ANK on the lateral malleolus, whose tip reaches
#: about 10 mm further distally than the medial one's.
MEDIAL_MALLEOLUS_ABOVE = 0.010
#: Joint width (side removed) -> (kinematic parameter, width / parameter): the regression
#: without a measurement, centred on adults' widths at the nominal lengths (1.75 m; the nominal
#: model's markers): knee 100, elbow 70 mm across the epicondyles (Frisancho 1990), ankle 72
#: across the malleoli (Gordon et al. 1989), wrist 40 front to back (Vicon's template prior);
#: body mass spreads them more than stature (a heavy knee: 140 mm): :data:`SIGMA_REGRESSED`.
WIDTH_RATIO: dict[str, tuple[str, float]] = {
    "knee_width": ("thigh_length", 0.100 / 0.43),
    "ankle_width": ("shank_length", 0.072 / 0.43),
    "elbow_width": ("upperarm_length", 0.070 / 0.30),
    "wrist_width": ("forearm_length", 0.040 / 0.26),
}


#: Frontal-plane alignment parameter -> (the segment whose mechanical axis it tilts against
#: the joint's flexion axis, mean and standard deviation of that angle [deg]): the knee
#: centre's lateral offset from the hip centre (femur), the ankle centre's from the knee
#: centre (tibia): healthy adults' mechanical lateral distal femoral and medial proximal
#: tibial angles are 87-88 +- 2-3 degrees (Paley 2002, normal range 85-90; Bellemans et al.
#: 2012: constitutional varus in a quarter of healthy adults), here 0 +- 3 about the
#: perpendicular (docs/model.md#the-parameters-theta-151; the elbow has no carrying-angle
#: parameter: on the shared trials it moved no figure).
ALIGNMENT: dict[str, tuple[str, float, float]] = {
    "knee_lateral": ("thigh_length", 0.0, 3.0),
    "ankle_lateral": ("shank_length", 0.0, 3.0),
}
#: Joint width (measurement, side removed) -> the alignment parameter giving that joint
#: centre's lateral position in its lateral marker's frame (absent: on the frame's origin).
CENTRE_LATERAL: dict[str, str] = {"knee_width": "knee_lateral", "ankle_width": "ankle_lateral"}


class _Rows:
    """Accumulates prior rows over theta's names, skipping those naming absent parameters;
    a row's marker names are Plug-in Gait's roles, ``alias`` (role -> marker,
    :func:`~mocap_mj.capture.roles.roles`) gives the set's marker that fills each."""

    def __init__(self, pset: ParameterSet, alias: Mapping[str, str] | None = None) -> None:
        self.pset = pset
        self.alias = dict(alias or {})
        self.names = set(pset.names)
        self.a: list[np.ndarray] = []
        self.b: list[float] = []
        self.sigma: list[float] = []
        self.labels: list[str] = []

    def name(self, marker: str) -> str:
        """The set's marker filling the role ``marker`` (itself when no alias names it)."""
        return self.alias.get(marker, marker)

    def add(self, terms: dict[str, float], b: float, sigma: float, label: str) -> None:
        if self.alias:
            terms = _add(*({_aliased(n, self.alias): c} for n, c in terms.items()))
            label = renamed(label, self.alias)
        if not all(n in self.names and np.isfinite(c) for n, c in terms.items()):
            return
        row = np.zeros(self.pset.size)
        for n, c in terms.items():
            row[self.pset.index(n)] += c
        self.a.append(row)
        self.b.append(float(b))
        self.sigma.append(float(sigma))
        self.labels.append(label)

    def prior(self, noise: float) -> LinearGaussianPrior:
        return LinearGaussianPrior(
            np.array(self.a).reshape(-1, self.pset.size),
            np.array(self.b),
            np.array(self.sigma),
            noise,
            tuple(self.labels),
        )


def _aliased(name: str, alias: Mapping[str, str]) -> str:
    """Parameter ``name`` with its marker (``LKNE.y``'s ``LKNE``) renamed by ``alias``."""
    marker, dot, axis = name.rpartition(".")
    return f"{alias.get(marker, marker)}.{axis}" if dot and axis in "xyz" else name


def _add(*terms: dict[str, float]) -> dict[str, float]:
    """Sum of linear terms {name: coefficient}."""
    out: dict[str, float] = {}
    for t in terms:
        for n, c in t.items():
            out[n] = out.get(n, 0.0) + c
    return out


def _scaled(terms: dict[str, float], factor: float) -> dict[str, float]:
    return {n: factor * c for n, c in terms.items()}


def _width_rows(rows: _Rows, subject: Subject, side: str, marker: str, width: str) -> None:
    """``marker.y = +-(centre.y + width / 2 + marker radius)``: the width measured, else
    regressed on a length; ``centre.y`` the joint centre's lateral position in the marker's
    frame (:data:`CENTRE_LATERAL`'s parameter for the knee and ankle, 0 for the elbow)."""
    sign = 1.0 if side == "l" else -1.0
    r = subject.marker_radius
    measured = subject.get(f"{width}_{side}")
    name = f"{marker}.y"
    centre = {f"{CENTRE_LATERAL[width]}_{side}": -1.0} if width in CENTRE_LATERAL else {}
    at = "centre + " if centre else ""
    if measured is not None:
        rows.add({name: sign, **centre}, measured / 2 + r, SIGMA_MEASURED,
                 f"{name} = {at}{width}/2 + r")  # fmt: skip
        return
    kappa, ratio = WIDTH_RATIO[width]
    rows.add(
        {name: sign, f"{kappa}_{side}": -ratio / 2, **centre},
        r,
        SIGMA_REGRESSED,
        f"{name} = {at}{ratio:.3f} {kappa}/2 + r (regressed {width})",
    )


def _alignment_rows(rows: _Rows, side: str, s: float) -> None:
    """The frontal-plane alignment (:data:`ALIGNMENT`): each lateral offset of a joint centre
    ``tan(mean) x`` its segment's nominal length scaled by ``s``, standard deviation
    ``tan(sd) x`` that length: the spread of healthy adults' joint angles (docs/model.md)."""
    kappa0 = dict(zip(rows.pset.names, rows.pset.nominal, strict=False))
    for name, (length, mean, sd) in ALIGNMENT.items():
        base = kappa0.get(f"{length}_{side}")
        if base is None:
            continue
        b, sigma = (np.tan(np.radians(a)) * base * s for a in (mean, sd))
        rows.add({f"{name}_{side}": 1.0}, b, sigma,
                 f"{name}_{side} = {mean:.0f} +- {sd:.0f} deg of {length}")  # fmt: skip


def landmark_prior(
    pset: ParameterSet,
    subject: Subject | None = None,
    *,
    size: float = 1.0,
    noise: float = 0.001,
    t10: T10Placement | None = None,
    hip_centre: str = "harrington",
    axis_widths: Mapping[str, float | None] | None = None,
    landmarks: Mapping[str, str] | None = None,
) -> LinearGaussianPrior:
    """The landmark rows of every Plug-in Gait marker the model has (module docstring).

    ``size``: the subject's stature over the nominal 1.75 m, scaling the few constants that
    no parameter carries (a heel's distance behind the ankle, the C7 spinous process depth):
    from ``subject``'s measured height, else its stature estimate
    (:meth:`~mocap_mj.capture.subject.Subject.stature`), else this argument (default 1).
    ``t10``: the T10 marker found misplaced by :mod:`mocap_mj.anatomy.trunk` (its
    ``shift`` and ``spread`` [m]; default None: T10 trusted): the T12/L1 rows on T10 are
    widened by the displacement it carries into them (:func:`_spine_joint_rows`).
    ``hip_centre``: "harrington" (default) or "davis" (Plug-in Gait's, :mod:`.hips`).
    ``axis_widths``: wand marker (``LTHI``...) -> the width [m] of its chord-plane row
    (:func:`_pig_axis_row`), None to leave the row out (the axis functional); wands not
    named keep :data:`SIGMA_WAND_ANGLE` (:mod:`mocap_mj.anatomy.axes` decides).
    ``landmarks``: marker -> landmark (:mod:`mocap_mj.capture.landmarks`): a medial epicondyle or
    malleolus gets :func:`_medial_rows`, and its joint no chord-plane row.
    """
    subject = subject or Subject()
    stature = subject.stature()
    s = stature[0] / NOMINAL_HEIGHT if stature is not None else size
    alias = roles(pset, landmarks)
    rows = _Rows(pset, alias)
    _pelvis_rows(rows, subject, s, hip_centre)
    _trunk_rows(rows, s, t10)
    for side, p in (("l", "L"), ("r", "R")):
        _shoulder_rows(rows, pset, subject, side, p, s)
        pairs = medial_pairs(rows.pset, landmarks or {}, p, alias)
        widths = dict(axis_widths or {})
        for lateral in pairs:  # the pair gives the axis: no chord plane
            widths.update({p + w: None for w, m in PIG_AXIS_WANDS.items() if p + m == lateral})
        _limb_rows(rows, subject, side, p, s, widths, set(pairs))
        # The pair's midpoint is the ISB's definition of the centre, known to the markers'
        # placement: at SIGMA_CONVENTION the motion held Qualisys.c3d's knee centres 4-6 mm
        # off it (benchmarks/marker_sets.py), at SIGMA_MEASURED within 2.5 mm.
        for lateral, medial in pairs.items():
            for row in medial_rows(side, lateral, medial, SIGMA_MEASURED, SIGMA_MEASURED):
                rows.add(*row)
        _alignment_rows(rows, side, s)
        _hand_rows(rows, subject, side, p, s)
        _foot_rows(rows, side, p, s, _ankle_axis_placed(rows, subject, side, p, set(pairs)))
    return rows.prior(noise)


def _pelvis_rows(rows: _Rows, subject: Subject, s: float, hip_centre: str = "harrington") -> None:
    """The pelvis rows: ASIS markers and the hip joint centres (Harrington 2007, or with
    ``hip_centre`` "davis" Plug-in Gait's, :func:`~mocap_mj.anatomy.hips.davis_rows`)."""
    mid = SIGMA_MIDLINE
    # Pelvis: origin at mid-ASIS, ASIS on its y axis (the pelvis frame is defined by them).
    for m in ("LASI", "RASI"):
        rows.add({f"{m}.x": 1}, 0.0, mid, f"{m}.x = 0 (pelvis origin mid-ASIS)")
        rows.add({f"{m}.z": 1}, 0.0, mid, f"{m}.z = 0 (ASIS plane)")
    # The pelvis frame's tilt against its markers (left free by the data: the root absorbs
    # it), as on the nominal model: mid-PSIS 20 mm above mid-ASIS (7 degrees from the
    # ASIS-PSIS plane of Plug-in Gait's pelvis), so that the Harrington rows below, written
    # in the frame, mean the same on every trial.
    rows.add({"LPSI.z": 0.5, "RPSI.z": 0.5, "LASI.z": -0.5, "RASI.z": -0.5}, PSIS_ABOVE_ASIS * s,
             mid, "pelvis tilt: mid-PSIS 20 mm above mid-ASIS")  # fmt: skip
    asis = subject.get("asis_distance")
    if asis is not None:
        rows.add({"LASI.y": 1, "RASI.y": -1}, asis, SIGMA_MEASURED, "LASI-RASI = asis_distance")
    # Hip joint centres relative to mid-ASIS: Harrington et al. (2007), PW = ASIS width,
    # PD = ASIS-PSIS depth. Written relative to the markers, so that the rows do not depend
    # on where the pelvis origin sits against them (an unobservable direction).
    pd = _add({"LASI.x": 0.5, "RASI.x": 0.5}, {"LPSI.x": -0.5, "RPSI.x": -0.5})
    pw = {"LASI.y": 1.0, "RASI.y": -1.0}
    mid_x = {"LASI.x": 0.5, "RASI.x": 0.5}
    mid_y = {"LASI.y": 0.5, "RASI.y": 0.5}
    mid_z = {"LASI.z": 0.5, "RASI.z": 0.5}
    for side in ("l", "r"):
        sign = 1.0 if side == "l" else -1.0
        if hip_centre == "davis":
            kappa0 = dict(zip(rows.pset.names, rows.pset.nominal, strict=False))
            for terms, b, label in davis_rows(subject, side, kappa0):
                rows.add(terms, b, SIGMA_HJC, label)
            continue
        rows.add(
            _add({f"hip_depth_{side}": 1}, mid_x, _scaled(pd, -0.24)),
            0.0099,
            SIGMA_HJC,
            f"hip_depth_{side} = 0.24 PD + 9.9 mm (Harrington 2007)",
        )
        rows.add(
            _add({f"hip_width_{side}": 1}, _scaled(mid_y, -sign), _scaled(pw, -0.33)),
            0.0073,
            SIGMA_HJC,
            f"hip_width_{side} = 0.33 PW + 7.3 mm (Harrington 2007)",
        )
        rows.add(_add({f"hip_height_{side}": 1}, mid_z, _scaled(pw, -0.30)), 0.0109, SIGMA_HJC,
                 f"hip_height_{side} = 0.30 PW + 10.9 mm (Harrington 2007)")  # fmt: skip
    # L5/S1 from mid-ASIS in the pelvis frame, in proportion to the ASIS width (Reed 1999,
    # module docstring): not from the PSIS markers, whose placement varies most.
    rows.add(_add({"lumbar_depth": 1.0}, mid_x, _scaled(pw, -L5S1_BEHIND)), 0.0,
             SIGMA_CONVENTION, f"L5/S1.x = mid-ASIS.x - {L5S1_BEHIND} PW (Reed 1999)")  # fmt: skip
    rows.add(_add({"lumbar_height": 1.0}, _scaled(mid_z, -1.0), _scaled(pw, -L5S1_ABOVE)), 0.0,
             SIGMA_CONVENTION, f"L5/S1.z = mid-ASIS.z + {L5S1_ABOVE} PW (Reed 1999)")  # fmt: skip


def _trunk_rows(rows: _Rows, s: float, t10: T10Placement | None = None) -> None:
    """The trunk rows (``s`` the stature ratio): midline markers, the thorax frame's tilt,
    the joints around the thorax placed from its markers (C7/T1, T12/L1, SC joints; T10
    misplaced (``t10``), :func:`_spine_joint_rows`) and the lengths of the
    lumbar and thoracic spines from the stature (:data:`LUMBAR_SPREAD`,
    :data:`THORAX_SPREAD`)."""
    mid, conv = SIGMA_MIDLINE, SIGMA_CONVENTION
    for m in ("C7", "T10", "CLAV", "STRN"):
        rows.add({f"{m}.y": 1}, 0.0, mid, f"{m}.y = 0 (midline)")
    # The thorax frame's tilt against its markers (left free by the data: the thorax ball
    # absorbs it): Plug-in Gait's thorax axis, mid(T10, STRN) to mid(C7, CLAV), 3 degrees
    # forward of the frame's z axis as on the nominal model.
    rows.add({"C7.x": 0.5, "CLAV.x": 0.5, "T10.x": -0.5, "STRN.x": -0.5}, -0.01 * s, mid,
             "thorax axis: mid(C7, CLAV) 10 mm behind mid(T10, STRN)")  # fmt: skip
    # Sternoclavicular joints beside the jugular notch (CLAV), at its level.
    sc_mid = {"sc_height_l": -0.5, "sc_height_r": -0.5}
    rows.add({"CLAV.z": 1, **sc_mid}, 0.005 * s, conv, "CLAV.z = SC joints' height + 5 mm")
    rows.add({"CLAV.x": 1, "sc_depth": -1}, 0.02 * s, conv, "CLAV.x = sc_depth + 20 mm")
    for side in ("l", "r"):
        rows.add({f"sc_width_{side}": 1}, 0.025 * s, conv, f"sc_width_{side} = 25 mm")
    _spine_joint_rows(rows, s, t10)
    kappa0 = dict(zip(rows.pset.names, rows.pset.nominal, strict=False))
    for name, spread in (("lumbar_length", LUMBAR_SPREAD), ("thorax_length", THORAX_SPREAD)):
        base = kappa0.get(name)
        if base is not None:
            rows.add({name: 1.0}, base * s, spread * base * s,
                     f"{name} = {base * 1e3:.0f} mm x stature / 1.75 m")  # fmt: skip


def _rotated(v_from: str, v_to: str, along: float, up: float, c: str) -> dict[str, float]:
    """Component ``c`` ("x" or "z") of ``along (to - from) + up R90 (to - from)`` over the
    marker offsets, R90 the quarter turn in the sagittal plane taking +x to +z."""
    if c == "x":  # along dx - up dz
        return {f"{v_to}.x": along, f"{v_from}.x": -along, f"{v_to}.z": -up, f"{v_from}.z": up}
    return {f"{v_to}.z": along, f"{v_from}.z": -along, f"{v_to}.x": up, f"{v_from}.x": -up}


def _spine_joint_rows(rows: _Rows, s: float, t10: T10Placement | None = None) -> None:
    """C7/T1 and T12/L1 relative to the trunk markers, invariant to the thorax frame's tilt.

    C7/T1 (the head's origin, ``(neck_depth, thorax_length)`` in the thorax frame): on the
    line from C7 to CLAV (the jugular notch) turned 8 degrees upward, at 55 % of the C7-CLAV
    distance (Dumas et al. 2007 after Reed et al. 1999, men). T12/L1 (the thorax origin): from
    T10 along the C7-to-T10 line and anterior of it by the fractions of the C7-T10 distance
    the nominal model has (two vertebral levels down, the vertebral body's depth forward);
    its z row (the height along the thoracic spine) with the width of T10's placement,
    :data:`SIGMA_T10_LEVEL` x ``s`` (``s`` the stature ratio), its x row a convention row.

    A T10 found ``t10.shift`` [m] further from C7 than the stature puts it
    (:mod:`mocap_mj.anatomy.trunk`; along the nominal C7-to-T10 direction ``u``) carries
    T12/L1 by ``shift ((1 + T12_ALONG) u + T12_FORWARD R90 u)``: the marker moves and both
    offsets scale with the C7-T10 distance. Each row keeps its mean and its width becomes
    the root sum of squares of its own and a displacement: for the height (z row) the one
    the shift carries, so that the row sits about one standard deviation from where a
    correctly placed T10 would put T12/L1 (the shift is an estimate against the population:
    a subject may have a long thorax, so the fit neither trusts the marker nor moves the
    joint by the guess; the stature rows ``thorax_length`` and ``lumbar_length`` and, with
    the pelvis marked, L5/S1 place the height instead); for the depth (x row), whose only
    other hold is the thorax's own markers, the one the shift's uncertainty ``t10.spread``
    carries (docs/model.md#a-misplaced-t10). Measured on the shared trials:
    the depth widened by the whole shift let the thorax slide backwards (sc_depth at its
    lower bound, Static), its mean moved by the shift's forward growth put neck_depth at its
    upper bound in the upper-body fits and was 3.5-4.3 of its widths from the full fits.
    """
    along, up = CJC_RATIO * np.cos(np.radians(CJC_ANGLE)), CJC_RATIO * np.sin(np.radians(CJC_ANGLE))
    for c, joint in (("x", "neck_depth"), ("z", "thorax_length")):
        terms = _add(
            {joint: 1.0, "C7." + c: -1.0}, _scaled(_rotated("C7", "CLAV", along, up, c), -1)
        )
        rows.add(terms, 0.0, SIGMA_CONVENTION, f"C7/T1.{c} = C7 + {CJC_RATIO:.2f} (CLAV - C7) "
                 f"turned {CJC_ANGLE:.0f} deg up (Dumas 2007)")  # fmt: skip
        # The thorax origin (0) = T10 + a (T10 - C7) + b R90 (T10 - C7).
        terms = _add({"T10." + c: 1.0}, _rotated("C7", "T10", T12_ALONG, T12_FORWARD, c))
        sigma = SIGMA_T10_LEVEL * s if c == "z" else SIGMA_CONVENTION
        if t10 is not None:
            carried = _t10_carried(rows.pset, t10.shift if c == "z" else t10.spread)[c]
            sigma = float(np.hypot(sigma, carried))
        rows.add(terms, 0.0, sigma, f"T12/L1.{c} from T10 along and anterior of C7-T10")
    if not _has_data(rows.pset, rows.name("T10")):
        _depth_without_t10(rows, s)


def _has_data(pset: ParameterSet, marker: str) -> bool:
    """Whether ``marker`` is in ``pset`` with its offset measured (not frozen: a marker
    without data in the trials, :func:`mocap_mj.anatomy.partial.freeze_unmeasured`)."""
    names = pset.marker_names
    if marker not in names:
        return False
    i = pset.n_kappa + 3 * names.index(marker)
    return not bool(np.any(np.asarray(pset.frozen)[i : i + 3]))


def _depth_without_t10(rows: _Rows, s: float) -> None:
    """T12/L1's depth (the thorax origin's x row) from C7 and the sternum when T10 has no
    data: without T10 nothing else places the thorax origin front to back (the lumbar
    segment has no marker), and the depth of C7/T1 (``neck_depth``) drifts to a bound.

    The origin on the line from STRN (or, without it, CLAV) to C7 and anterior of it by
    the nominal model's fractions (:func:`_nominal_fractions`: the fractions scale with
    the chest and turn with the thorax frame, like the T10 rows), with the width
    :data:`THORAX_SPREAD` (8 %, adults of one stature) of the nominal chest's C7-to-sternum
    distance times ``s`` (the stature ratio): chest depth varies between adults of one
    stature about as much as trunk lengths do (Dumas et al. 2007 Table 2)."""
    front = next((m for m in ("STRN", "CLAV") if _has_data(rows.pset, rows.name(m))), None)
    if front is not None and _has_data(rows.pset, rows.name("C7")):
        along, up, length = _nominal_fractions(rows.pset, rows.name(front), rows.name("C7"))
        terms = _add({front + ".x": 1.0}, _rotated(front, "C7", along, up, "x"))
        rows.add(terms, 0.0, THORAX_SPREAD * length * s,
                 f"T12/L1.x from {front} and C7 (no T10)")  # fmt: skip
    # The thorax frame's tilt against its markers, which Plug-in Gait's thorax axis row
    # (on T10) fixed: the frame's z axis through T12/L1 and C7/T1 at the nominal model's
    # angle, a convention row (both joints are placed from the markers).
    kappa0 = dict(zip(rows.pset.names, rows.pset.nominal, strict=False))
    if kappa0.get("thorax_length") and "neck_depth" in kappa0:
        ratio = kappa0["neck_depth"] / kappa0["thorax_length"]
        rows.add({"neck_depth": 1.0, "thorax_length": -ratio}, 0.0, SIGMA_CONVENTION,
                 f"thorax tilt (no T10): neck_depth = {ratio:.3f} thorax_length")  # fmt: skip


def _nominal_fractions(pset: ParameterSet, v_from: str, v_to: str) -> tuple[float, float, float]:
    """(along, up, length [m]): the nominal thorax origin as ``v_from + along d + up R90 d``,
    d = ``v_to - v_from`` in the sagittal (x, z) plane (:func:`_rotated`), and |d|."""
    a, b = (nominal_offset(pset, m) for m in (v_from, v_to))
    dx, dz = b[0] - a[0], b[2] - a[2]
    # origin - a = along (dx, dz) + up (-dz, dx)
    along, up = np.linalg.solve(np.array([[dx, -dz], [dz, dx]]), -np.array([a[0], a[2]]))
    return float(along), float(up), float(np.hypot(dx, dz))


def _t10_carried(pset: ParameterSet, shift: float) -> dict[str, float]:
    """The displacement [m] per thorax-frame axis ("x", "z") that a T10 ``shift`` [m] further
    along the nominal C7-to-T10 direction carries into the T12/L1 rows
    (:func:`_spine_joint_rows`): zero without both markers or without a shift."""
    names = pset.marker_names
    if not shift or "C7" not in names or "T10" not in names:
        return {"x": 0.0, "z": 0.0}
    c7, t10 = (nominal_offset(pset, m) for m in ("C7", "T10"))
    u = (t10 - c7) / np.linalg.norm(t10 - c7)
    # _rotated(C7, T10, along, up): x = along dx - up dz, z = along dz + up dx; plus T10 itself.
    return {
        "x": shift * ((1.0 + T12_ALONG) * u[0] - T12_FORWARD * u[2]),
        "z": shift * ((1.0 + T12_ALONG) * u[2] + T12_FORWARD * u[0]),
    }


def _shoulder_rows(
    rows: _Rows, pset: ParameterSet, subject: Subject, side: str, p: str, s: float
) -> None:
    """The rows of one side's shoulder marker ``p``SHO (``p`` "L" or "R") on the acromion:
    shoulder_offset + r from the glenohumeral centre by Plug-in Gait's construction
    (:mod:`mocap_mj.anatomy.shoulders`) where the set has its thorax markers, else above it."""
    lm = SIGMA_LANDMARK
    sign = 1.0 if side == "l" else -1.0
    try:
        gh = pset.body_pos_nominal[pset.model.body(f"upperarm_{side}").id]
    except KeyError:  # a custom model without this body: no shoulder rows
        gh = np.full(3, np.nan)
    u = gh / np.linalg.norm(gh)
    off = subject.get(f"shoulder_offset_{side}")
    pig = None
    if off is not None:  # Plug-in Gait's construction, where the set has its thorax markers
        d = {side: off + subject.marker_radius}
        pig = pig_shoulder_offsets(pset, rows.name, d, s, subject.marker_radius).get(side)
    for ax, c in enumerate("xyz"):
        terms = {f"{p}SHO.{c}": 1.0, f"clavicle_length_{side}": -u[ax]}
        if pig is not None:
            sig = SIGMA_MEASURED if c == "z" else SIGMA_CONVENTION
            label = f"{p}SHO.{c} = GH.{c} {pig[ax] * 1e3:+.0f} mm (Plug-in Gait's centre)"
            rows.add(terms, float(pig[ax]), sig, label)
        elif c == "z":
            mean = (off + subject.marker_radius) if off is not None else 0.045 * s
            sig = SIGMA_MEASURED if off is not None else lm
            rows.add(terms, mean, sig, f"{p}SHO.z = GH.z + shoulder_offset + r")
        else:
            mean = (0.0, sign * 0.01 * s)[ax]
            # GH under SHO on the acromion (the clavicle's end stands in for the glenoid).
            rows.add(terms, mean, SIGMA_CONVENTION, f"{p}SHO.{c} = GH.{c} {mean * 1e3:+.0f} mm")


def _level_terms(
    rows: _Rows, subject: Subject, side: str, marker: str, length: str, width: str, s: float
) -> dict[str, float]:
    """The terms of ``marker``'s level row: Plug-in Gait's chord puts the joint centre where
    the lateral marker's offset from it is normal to the segment's long axis (proximal
    centre to joint centre). With the centre ``lateral`` along the axis from the frame's
    origin, that reads ``marker.z + length = (w/2 + r) lateral / length``, linearised about
    the measured half-width ``w/2 + r`` (else the nominal marker's) and the nominal length
    scaled by ``s``: a knee centre 15 mm medial of the hip's moves the level by 3 mm."""
    terms = {f"{marker}.z": 1.0, f"{length}_{side}": 1.0}
    lateral = CENTRE_LATERAL.get(width)
    base = dict(zip(rows.pset.names, rows.pset.nominal, strict=False)).get(f"{length}_{side}")
    if lateral is None or base is None or rows.name(marker) not in rows.pset.marker_names:
        return terms
    measured = subject.get(f"{width}_{side}")
    half = (measured / 2 + subject.marker_radius if measured is not None
            else abs(float(nominal_offset(rows.pset, rows.name(marker))[1])))  # fmt: skip
    terms[f"{lateral}_{side}"] = -half / (base * s)
    return terms


def _limb_rows(
    rows: _Rows,
    subject: Subject,
    side: str,
    p: str,
    s: float,
    axis_widths: Mapping[str, float | None],
    paired: Collection[str] = (),
) -> None:
    """The rows of one side's joint-axis markers (knee, ankle, elbow), wrist bar and leg
    length. A lateral marker in ``paired`` (its medial landmark marked too,
    :func:`~mocap_mj.anatomy.axis_rows.medial_rows`) keeps only its width row: the pair's
    midpoint defines its joint centre's level and depth, and the lateral marker's own level
    (the lateral malleolus reaches about 10 mm below the medial one) must not pull it."""
    lm = SIGMA_LANDMARK
    # Epicondyles, malleolus and styloids on their joint's axis, at the joint's level.
    for marker, length, width in (
        ("KNE", "thigh_length", "knee_width"),
        ("ANK", "shank_length", "ankle_width"),
        ("ELB", "upperarm_length", "elbow_width"),
    ):
        m = p + marker
        # The ankle and the elbow are convention joints (module docstring): the lateral
        # marker's level and depth define them.
        sig = SIGMA_CONVENTION if marker in ("ANK", "ELB") else lm
        if marker == "KNE" and axis_widths.get(p + "THI") is not None:
            sig = SIGMA_CONVENTION  # Plug-in Gait's knee axis decided: its centre's level too
        x_sig: float | None = sig
        on_axis = f"{m}.x = 0 (on the joint axis)"
        if marker == "ELB":
            # Plug-in Gait's elbow axis through ELB, decided as the chord planes (arm_axes).
            x_sig, on_axis = axis_widths.get(m, sig), f"{m}.x = 0 (Plug-in Gait's elbow axis)"
        if m not in paired:  # a landmark pair places its centre itself (medial_rows)
            if x_sig is not None:
                rows.add({f"{m}.x": 1}, 0.0, x_sig, on_axis)
            rows.add(_level_terms(rows, subject, side, m, length, width, s), 0.0, sig,
                     f"{m}.z = -{length}")  # fmt: skip
        _width_rows(rows, subject, side, m, width)
    for wand, marker in PIG_AXIS_WANDS.items():
        names = rows.pset.marker_names
        if p + wand not in names or p + marker not in names:
            continue
        sigma = axis_widths.get(p + wand, wand_width(rows.pset, p + wand, p + marker))
        if sigma is not None:
            rows.add(*pig_axis_row(rows.pset, p + wand, p + marker, sigma))
    for row in arm_rows(rows.pset, p, axis_widths):
        rows.add(*row)
    # Wrist bar on the dorsum: the wrist centre wrist_width/2 + r anterior of its midpoint.
    wra, wrb = p + "WRA", p + "WRB"
    for m in (wra, wrb):
        rows.add({f"{m}.z": 1, f"forearm_length_{side}": 1}, 0.0, lm,
                 f"{m}.z = -forearm_length")  # fmt: skip
    rows.add({f"{wra}.y": 0.5, f"{wrb}.y": 0.5}, 0.0, lm, f"{p}WRA-WRB midpoint y = 0")
    ww, (kappa, ratio) = subject.get(f"wrist_width_{side}"), WIDTH_RATIO["wrist_width"]
    reg = {f"{kappa}_{side}": ratio / 2} if ww is None else {}  # the width regressed
    name = "wrist_width" if ww is not None else f"{ratio:.3f} {kappa}"
    rows.add({f"{wra}.x": 0.5, f"{wrb}.x": 0.5, **reg}, -((ww or 0.0) / 2 + subject.marker_radius),
             SIGMA_MEASURED if ww is not None else SIGMA_REGRESSED,
             f"{p}WRA-WRB midpoint x = -({name}/2 + r)")  # fmt: skip
    leg = subject.get(f"leg_length_{side}")
    if leg is not None:
        _leg_length_row(rows, subject, side, p, leg, s)


def _leg_length_row(rows: _Rows, subject: Subject, side: str, p: str, leg: float, s: float) -> None:
    """``leg`` [m], Plug-in Gait's LegLength: the tape from the ASIS to the medial malleolus
    over the extended knee, linearised in theta at the nominal model scaled by ``s``.

    The tape's ends are the ASIS (the marker less its radius, behind it) and the medial
    malleolus (:data:`MEDIAL_MALLEOLUS_ABOVE` above the ankle centre, which Plug-in Gait puts
    at the lateral malleolus's level, and half the ankle width medial of it); the leg straight
    below the hip centre in the pelvis frame. So the tape is the length of
    ``v = (ASIS.x + hip_depth - r, ASIS.y - hip_width - knee_lateral - ankle_lateral +
    ankle_width/2, hip_height + thigh + shank - MEDIAL_MALLEOLUS_ABOVE)`` (left side; the
    right mirrors y), not ``hip_height + thigh + shank``: the ASIS lies 40-60 mm ahead of and
    lateral of the hip centre, the malleolus above the ankle centre. ``|v|`` is linearised at
    the nominal ``v0``: ``|v| ~ |v0| + (v0 / |v0|) . (v - v0)``, within 1.5 mm for skeletons
    within 15 % of the nominal one.
    """
    sign = 1.0 if side == "l" else -1.0
    kappa0 = {n: float(v) for n, v in zip(rows.pset.names, rows.pset.nominal, strict=True)}
    asis = p + "ASI"
    aw = subject.get(f"ankle_width_{side}")
    if aw is None:
        kappa, ratio = WIDTH_RATIO["ankle_width"]
        aw = ratio * kappa0.get(f"{kappa}_{side}", 0.0) * s
    comps = (  # (terms linear in theta, constant) per axis of v
        ({f"{asis}.x": 1.0, f"hip_depth_{side}": 1.0}, -subject.marker_radius),
        ({f"{asis}.y": sign, f"hip_width_{side}": -1.0,
          **{f"{a}_{side}": -1.0 for a in CENTRE_LATERAL.values() if f"{a}_{side}" in kappa0}},
         aw / 2),
        ({f"hip_height_{side}": 1.0, f"thigh_length_{side}": 1.0, f"shank_length_{side}": 1.0},
         -MEDIAL_MALLEOLUS_ABOVE * s),
    )  # fmt: skip
    if not all(n in kappa0 for terms, _ in comps for n in terms):
        return
    v0 = np.array([sum(c * kappa0[n] * s for n, c in t.items()) + k for t, k in comps])
    g = v0 / np.linalg.norm(v0)
    terms = _add(*(_scaled(t, gi) for (t, _), gi in zip(comps, g, strict=True)))
    # |v0| + g . (v - v0) = g . v, as g . v0 = |v0|: the row is g . (v - k) = leg - g . k.
    b = leg - sum(gi * k for (_, k), gi in zip(comps, g, strict=True))
    rows.add(terms, b, SIGMA_LEG, f"ASIS to medial malleolus = leg_length_{side}")


def _hand_rows(rows: _Rows, subject: Subject, side: str, p: str, s: float) -> None:
    """The rows of one side's finger marker ``p``FIN."""
    lm, soft = SIGMA_LANDMARK, SIGMA_SOFT
    sign = 1.0 if side == "l" else -1.0
    ht = subject.get(f"hand_thickness_{side}")
    fin_x = -(ht / 2 + subject.marker_radius) if ht is not None else -0.015 * s
    rows.add({f"{p}FIN.x": 1}, fin_x, SIGMA_MEASURED if ht is not None else lm,
             f"{p}FIN.x = -(hand_thickness/2 + r)")  # fmt: skip
    rows.add({f"{p}FIN.y": 1}, sign * 0.02 * s, soft, f"{p}FIN.y")
    rows.add({f"{p}FIN.z": 1}, -0.08 * s, soft, f"{p}FIN.z = 80 mm beyond the wrist")


def _ankle_axis_placed(rows: _Rows, subject: Subject, side: str, p: str, paired: set[str]) -> bool:
    """Whether a landmark places side ``p``'s ankle flexion axis: a malleolus pair, or Plug-in
    Gait's chord plane (TIB, ANK and the measured ankle width)."""
    names = rows.pset.marker_names
    chord = all(rows.name(p + m) in names for m in ("TIB", "ANK"))
    return p + "ANK" in paired or (chord and subject.get(f"ankle_width_{side}") is not None)


def _foot_rows(rows: _Rows, side: str, p: str, s: float, axis_placed: bool) -> None:
    """One side's heel and toe rows (:func:`~mocap_mj.anatomy.foot.foot_rows`)."""
    turn = axis_placed and rows.name(f"{p}TOE") in rows.pset.marker_names
    for row in foot_rows(rows.pset, side, p, s, turn, SIGMA_LANDMARK, SIGMA_SOFT):
        rows.add(*row)


#: Left/right kinematic parameter pairs tied by :func:`symmetric_prior`.
def _sided_pairs(pset: ParameterSet) -> list[tuple[str, str]]:
    names = set(pset.kappa_names)
    return [
        (n, n[:-2] + "_r") for n in pset.kappa_names if n.endswith("_l") and n[:-2] + "_r" in names
    ]


def symmetric_prior(
    pset: ParameterSet, width: float, *, noise: float = 0.001
) -> LinearGaussianPrior:
    """``kappa_l - kappa_r = 0`` with standard deviation ``width`` [m] for every sided pair."""
    rows = _Rows(pset)
    for left, right in _sided_pairs(pset):
        rows.add({left: 1.0, right: -1.0}, 0.0, width, f"{left} = {right}")
    return rows.prior(noise)


def marker_prior_table(
    pset: ParameterSet, prior: LinearGaussianPrior, theta: np.ndarray
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per marker: prior mean (3,) [m] and width (3,) [m] of its offset, the kinematic
    parameters held at ``theta``'s (rows naming only that marker's offset and kappa).

    Components without a row have mean NaN and width inf.
    """
    k = pset.n_kappa
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for i, name in enumerate(pset.marker_names):
        cols = k + 3 * i + np.arange(3)
        mean = np.full(3, np.nan)
        width = np.full(3, np.inf)
        for r in range(len(prior.b)):
            row = prior.a[r]
            nz = np.flatnonzero(row)
            offs = nz[nz >= k]
            if offs.size != 1 or offs[0] not in cols:
                continue
            ax = int(offs[0] - cols[0])
            c = row[offs[0]]
            rest = row.copy()
            rest[offs[0]] = 0.0
            mean[ax] = (prior.b[r] - rest @ theta) / c
            width[ax] = prior.sigma[r] / abs(c)
        out[name] = (mean, width)
    return out


def combined(priors: Sequence[LinearGaussianPrior]) -> LinearGaussianPrior | None:
    """All rows of several priors of one noise as one prior (None when there are none)."""
    priors = [p for p in priors if len(p.b)]
    if not priors:
        return None
    return LinearGaussianPrior(
        np.vstack([p.a for p in priors]),
        np.concatenate([p.b for p in priors]),
        np.concatenate([p.sigma for p in priors]),
        priors[0].noise,
        tuple(lab for p in priors for lab in p.labels),
    )
