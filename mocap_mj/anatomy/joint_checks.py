"""Anatomical checks of an identified skeleton: every joint centre inside the body.

A fit can end with a small marker RMSE and a joint on the wrong side of its marker: the
knee centre lateral of KNE, the elbow centre in front of ELB, the hip centres outside the
pelvis. The markers fit either way (a marker offset and a joint centre can trade places
along an axis the motion hardly excites), so the RMSE cannot tell. These checks compare
the identified model ``theta`` with Plug-in Gait's constructions and the pelvis's
geometry, in each joint's parent segment frame at the reference pose (the knee extended,
where its rolling is zero; the markers of these checks sit on the parent segment, so the
ankle, elbow, wrist and hip figures hold in every frame):

* knee and ankle: the centre medial of its lateral marker (KNE, ANK or the set's marker of
  that role) along the flexion axis by width/2 + marker radius, the width measured (a
  caliper's or the medial marker's, :mod:`mocap_mj.capture.landmarks`) or regressed on the
  segment's length (:data:`~mocap_mj.anatomy.anatomy.WIDTH_RATIO`), within the larger of
  :data:`MIN_TOLERANCE` and :data:`TOLERANCE_SD` standard deviations of that width/2
  (:data:`~mocap_mj.anatomy.anatomy.SIGMA_MEASURED`,
  :data:`~mocap_mj.anatomy.anatomy.SIGMA_REGRESSED`); between the lateral and the medial
  marker where the set has both (its projection on their line inside the pair);
* elbow: medial of ELB likewise, and not anterior of it by more than
  :data:`MIN_TOLERANCE` (Plug-in Gait's centre lies medial of ELB in the arm's plane
  normal, at or behind the marker in the humerus frame); wrist: between WRA and WRB (the
  centre's projection on the bar inside the bar);
* flexion axes (knee, ankle, elbow, wrist): within :data:`AXIS_LIMIT_DEG` of Plug-in Gait's
  construction (:func:`~mocap_mj.anatomy.axes.angle_to_pig`) unless the data determine the
  axis (its decision ``functional``, :func:`~mocap_mj.anatomy.axes.axis_decisions`, or the
  markers' own standard deviation within :data:`AXIS_DETERMINED_DEG`), which is then
  reported only;
* hips: inside the pelvis (medial of the ASIS marker, behind the ASIS line and in front of
  the PSIS markers' midpoint, below the ASIS plane), and their distance that of Harrington
  et al. (2007) on the ASIS markers' distance PW, 0.66 PW + 14.6 mm, within the larger of
  :data:`MIN_TOLERANCE` and :data:`TOLERANCE_SD` standard deviations (two hips of
  :data:`~mocap_mj.anatomy.anatomy.SIGMA_HJC` each);
* left and right: the hip centres in the pelvis frame, the right one mirrored, within
  :data:`TOLERANCE_SD` standard deviations of the difference of two Harrington centres
  (per axis); the knee and ankle centres' lateral place in their parent frames likewise,
  against the frontal-plane alignment's spread (:data:`~mocap_mj.anatomy.anatomy.ALIGNMENT`,
  3 degrees of the segment each side: some 95 mm at the knee, so this catches a centre
  thrown to one side, not a subject's asymmetry; lengths differing left to right are a
  subject's, and :func:`~mocap_mj.anatomy.plausibility.left_right_differences` reports them).

A check the set's markers cannot make (no KNE, no medial marker, no decision) is left out.
A joint that fails is re-solved once with its construction rows narrowed (:func:`hold`,
:func:`held_joints`; :func:`mocap_mj.pipeline.steps.solve_trials` keeps the re-solve when
the joint then passes and the markers fit as well, :data:`HOLD_RMSE_RATIO`). Each violation
that persists is one line naming the joint, side, the figure and its limit
(:func:`violations`), among the fit's implausible reasons (exit status 3) beside those of
:func:`mocap_mj.anatomy.plausibility.implausible_reasons`.
"""

from __future__ import annotations

import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mocap_mj.anatomy.anatomy import (
    ALIGNMENT,
    SIGMA_HJC,
    SIGMA_MEASURED,
    SIGMA_REGRESSED,
    WIDTH_RATIO,
)
from mocap_mj.anatomy.axes import angle_to_pig
from mocap_mj.anatomy.axis_rows import MEDIAL_LANDMARKS
from mocap_mj.capture.roles import medial_markers, roles
from mocap_mj.capture.subject import Subject
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.priors import LinearGaussianPrior

#: The least tolerance [m] of a centre's distance from its marker: soft tissue moves a skin
#: marker by 5-15 mm against the bone (Cappozzo et al. 1996), and a marker placed on the
#: epicondyle by palpation varies by some 10 mm between examiners.
MIN_TOLERANCE = 0.015
#: Standard deviations of the expected figure a check allows (3: one fit in some 400
#: outside by chance where the prior is right).
TOLERANCE_SD = 3.0
#: A flexion axis the data leave to the construction ends within this angle [deg] of it:
#: the construction's row holds it to 4-8 degrees (:data:`~mocap_mj.anatomy.axes.SIGMA_PIG_AXIS`,
#: :data:`~mocap_mj.anatomy.axis_rows.SIGMA_WAND_ANGLE`), so beyond 30 the axis is another.
AXIS_LIMIT_DEG = 30.0
#: The data determine a flexion axis when they place it to this standard deviation [deg] or
#: better (``data_sd_deg`` of :func:`~mocap_mj.anatomy.axes.axis_decisions`, the markers'
#: own, the construction's row taken out): :data:`TOLERANCE_SD` of them fit inside
#: :data:`AXIS_LIMIT_DEG`, so such an axis far from the construction is the markers' finding
#: (a wand placed off the plane, on the jump of the shared Movement_trial 39-59 degrees),
#: reported, not refused.
AXIS_DETERMINED_DEG = AXIS_LIMIT_DEG / TOLERANCE_SD
#: Harrington et al. (2007)'s hip centre's lateral offset from mid-ASIS: 0.33 PW + 7.3 mm.
HARRINGTON_WIDTH = (0.33, 0.0073)
#: Joint (side removed) -> (lateral marker role, width, parent body, child body).
WIDTH_JOINTS: dict[str, tuple[str, str, str, str]] = {
    "knee": ("KNE", "knee_width", "thigh", "shank"),
    "ankle": ("ANK", "ankle_width", "shank", "foot"),
    "elbow": ("ELB", "elbow_width", "upperarm", "ulna"),
}
#: Joint (side removed) -> (child body, the alignment parameter placing its centre along
#: the flexion axis, :data:`~mocap_mj.anatomy.anatomy.ALIGNMENT`) of the mirror check. The
#: elbow and wrist centres have no lateral parameter: mirror images by construction.
MIRRORED: dict[str, tuple[str, str]] = {
    "knee": ("shank", "knee_lateral"),
    "ankle": ("foot", "ankle_lateral"),
}
_MIRROR = np.array([1.0, -1.0, 1.0])


@dataclass(frozen=True)
class Check:
    """One check: ``joint`` (``knee_l``...), what is measured, its ``value`` and the limits
    ``low``, ``high`` (None: open) in ``unit`` ("m" or "deg"); ``enforced`` False for a
    figure reported only (an axis the data determine)."""

    joint: str
    what: str
    value: float
    low: float | None
    high: float | None
    unit: str = "m"
    enforced: bool = True

    @property
    def margin(self) -> float:
        """The distance [m or deg] to the nearer limit, negative when outside."""
        gaps = [self.value - self.low if self.low is not None else np.inf,
                self.high - self.value if self.high is not None else np.inf]  # fmt: skip
        return float(min(gaps))

    @property
    def violated(self) -> bool:
        return self.enforced and not self.margin >= 0.0  # NaN counts as violated

    def line(self) -> str:
        """``knee_l: centre -12 mm medial of LKNE (limits 59..89 mm)``."""
        scale, unit = (1e3, "mm") if self.unit == "m" else (1.0, "deg")
        lo = "-inf" if self.low is None else f"{self.low * scale:.0f}"
        hi = "inf" if self.high is None else f"{self.high * scale:.0f}"
        return (
            f"{self.joint}: {self.what} {self.value * scale:.0f} {unit} (limits {lo}..{hi} {unit})"
        )

    def to_json(self) -> dict[str, Any]:
        """summary.json's entry, millimetres or degrees."""
        scale = 1e3 if self.unit == "m" else 1.0
        key = "mm" if self.unit == "m" else "deg"

        def s(v: float | None) -> float | None:
            return None if v is None else float(v) * scale

        return {
            "what": self.what,
            f"value_{key}": s(self.value),
            f"low_{key}": s(self.low),
            f"high_{key}": s(self.high),
            f"margin_{key}": s(self.margin),
            "enforced": self.enforced,
            "violated": self.violated,
        }


def joint_checks(
    pset: ParameterSet,
    theta: np.ndarray,
    subject: Subject,
    landmarks: Mapping[str, str] | None = None,
    decisions: Mapping[str, Mapping[str, Any]] | None = None,
) -> list[Check]:
    """The checks (module docstring) of the model ``theta`` (P,) [m] with the subject's
    measurements, the set's ``landmarks`` (marker -> landmark; default none: Plug-in Gait's
    names) and the flexion axes' ``decisions`` (summary.json ``joint_axes``; default none:
    no axis check)."""
    theta = np.asarray(theta, dtype=float)
    alias = roles(pset, landmarks)
    out: list[Check] = []
    for side in ("l", "r"):
        for joint in WIDTH_JOINTS:
            out += _width_checks(pset, theta, subject, landmarks, alias, joint, side)
        out += _wrist_checks(pset, theta, alias, side)
        out += _hip_checks(pset, theta, alias, side)
    out += _inter_hip_check(pset, theta, alias)
    out += _axis_checks(pset, theta, decisions or {})
    out += _mirror_checks(pset, theta)
    return out


def violations(checks: list[Check], note: str = "") -> list[str]:
    """One line per violated check (:meth:`Check.line`), for the implausible reasons;
    ``note`` (default: a question on the markers) ends each."""
    end = note or " (markers misplaced or the fit flipped?)"
    return ["joint outside the body: " + c.line() + end for c in checks if c.violated]


def checks_summary(checks: list[Check]) -> dict[str, list[dict[str, Any]]]:
    """summary.json's ``anatomy_checks``: per joint, its checks' entries."""
    out: dict[str, list[dict[str, Any]]] = {}
    for c in checks:
        out.setdefault(c.joint, []).append(c.to_json())
    return out


#: A held joint's construction rows are this many times narrower than in the first solve.
HOLD_FACTOR = 0.1
#: A re-solve with a joint held at its construction is kept when every check of the joint
#: then passes and the marker RMSE grows by at most this factor: the markers fit the held
#: model as well (they were silent on where the joint lies), so the construction places it.
HOLD_RMSE_RATIO = 1.1
#: Joint (side removed) -> the roles whose rows (any row naming the marker: its offset's
#: rows, the chord plane's, a landmark pair's) are the joint's construction.
HOLD_ROLES: dict[str, tuple[str, ...]] = {
    "knee": ("KNE",), "ankle": ("ANK",), "elbow": ("ELB",), "wrist": ("WRA", "WRB"),
}  # fmt: skip


def held_joints(checks: list[Check]) -> list[str]:
    """The joints (``knee_l``, ``hip_r``...) whose construction a re-solve holds for the
    violated ``checks``: the joint of a violated check; both hips for their distance; both
    sides of a mirror check (which side is wrong, the check cannot tell)."""
    out: set[str] = set()
    for c in checks:
        if not c.violated:
            continue
        if c.joint == "hips":
            out |= {"hip_l", "hip_r"}
        elif c.joint.endswith("_lr"):
            out |= {c.joint[:-3] + "_l", c.joint[:-3] + "_r"}
        else:
            out.add(c.joint)
    return sorted(out)


def hold(
    prior: LinearGaussianPrior,
    pset: ParameterSet,
    landmarks: Mapping[str, str] | None,
    joints: Collection[str],
) -> LinearGaussianPrior:
    """``prior`` with the construction rows of ``joints`` (:func:`held_joints`) narrowed by
    :data:`HOLD_FACTOR`: for a knee, ankle, elbow or wrist every row whose label names its
    lateral marker (:data:`HOLD_ROLES`, or the set's marker of that role), for a hip its
    centre's rows (``hip_depth_l``...)."""
    alias = roles(pset, landmarks)
    words = []
    for joint in joints:
        name, side = joint[:-2], joint[-1]
        if name == "hip":
            words += [f"hip_{axis}_{side}" for axis in ("depth", "width", "height")]
            continue
        for role in HOLD_ROLES.get(name, ()):
            marker = _marker(pset, alias, side.upper() + role)
            words += [side.upper() + role] + ([marker] if marker else [])
    if not words or len(prior.labels) != len(prior.sigma):
        return prior
    pattern = re.compile(r"\b(" + "|".join(re.escape(w) for w in sorted(set(words))) + r")\b")
    held = np.array([bool(pattern.search(label)) for label in prior.labels], dtype=bool)
    if not held.any():
        return prior
    sigma = np.where(held, np.asarray(prior.sigma, dtype=float) * HOLD_FACTOR, prior.sigma)
    return replace(prior, sigma=sigma)


def report_line(entries: Mapping[str, list[Mapping[str, Any]]] | None) -> str:
    """report.md's line on summary.json's ``anatomy_checks`` (:func:`checks_summary`): the
    violated checks, else how many passed and the least margin of the distances and of the
    angles; "" without checks."""
    flat = [(j, e) for j, es in (entries or {}).items() for e in es if e.get("enforced")]
    if not flat:
        return ""
    bad = [f"{j} {e['what']}" for j, e in flat if e.get("violated")]
    if bad:
        return "- joints outside the body (exit status 3): " + "; ".join(bad)
    least = []
    for unit in ("mm", "deg"):
        some = [
            (float(e[f"margin_{unit}"]), j, e["what"]) for j, e in flat if f"margin_{unit}" in e
        ]
        if some:
            value, joint, what = min(some)
            least.append(f"{value:.1f} {unit} ({joint}: {what})")
    return (
        f"- joints against the body (docs/model.md#flexion-axes): {len(flat)} checks pass; "
        f"least margin {', '.join(least)}"
    )


def _marker(pset: ParameterSet, alias: Mapping[str, str], role: str) -> str | None:
    """The marker of ``pset`` filling ``role`` (``LKNE``...), None when none does."""
    if role in pset.marker_names:
        return role
    return alias.get(role)


def _offset(pset: ParameterSet, theta: np.ndarray, marker: str) -> np.ndarray:
    return pset.split(theta)[1][pset.marker_index(marker)]


def _on(pset: ParameterSet, marker: str, body: str) -> bool:
    return bool(pset.site_body[pset.marker_index(marker)] == pset.model.body(body).id)


def _centre(pset: ParameterSet, theta: np.ndarray, body: str) -> np.ndarray:
    """The origin (3,) [m] of ``body`` (a joint centre) in its parent's frame."""
    return np.asarray(pset.body_pos(theta)[pset.model.body(body).id], dtype=float)


def half_width(
    pset: ParameterSet, theta: np.ndarray, subject: Subject, width: str, side: str
) -> tuple[float, float, str]:
    """(width / 2 + marker radius [m], its standard deviation [m], "measured" or
    "regressed"): the measurement, else the regression on the segment's length."""
    measured = subject.get(f"{width}_{side}")
    r = subject.marker_radius
    if measured is not None:
        return measured / 2 + r, SIGMA_MEASURED, "measured"
    kappa, ratio = WIDTH_RATIO[width]
    return ratio / 2 * float(theta[pset.index(f"{kappa}_{side}")]) + r, SIGMA_REGRESSED, "regressed"


def _width_checks(
    pset: ParameterSet,
    theta: np.ndarray,
    subject: Subject,
    landmarks: Mapping[str, str] | None,
    alias: Mapping[str, str],
    joint: str,
    side: str,
) -> list[Check]:
    role, width, parent, child = WIDTH_JOINTS[joint]
    p, sign = side.upper(), (1.0 if side == "l" else -1.0)
    lateral = _marker(pset, alias, p + role)
    parent_body = f"{parent}_{side}"
    if lateral is None or not _on(pset, lateral, parent_body):
        return []
    centre = _centre(pset, theta, f"{child}_{side}")
    k = _offset(pset, theta, lateral)
    half, sd, how = half_width(pset, theta, subject, width, side)
    tol = max(MIN_TOLERANCE, TOLERANCE_SD * sd)
    name = f"{joint}_{side}"
    out = [
        Check(name, f"centre medial of {lateral} (expected {width}/2 + r, {how})",
              float(sign * (k[1] - centre[1])), half - tol, half + tol)
    ]  # fmt: skip
    if joint == "elbow":
        out.append(Check(name, f"centre anterior of {lateral}", float(centre[0] - k[0]),
                         None, MIN_TOLERANCE))  # fmt: skip
    found = medial_markers(pset, landmarks, MEDIAL_LANDMARKS[role][0], p)
    if found and _on(pset, found[0], parent_body):
        out.append(_between(name, lateral, found[0], k, _offset(pset, theta, found[0]), centre))
    return out


def _between(
    joint: str, a_name: str, b_name: str, a: np.ndarray, b: np.ndarray, centre: np.ndarray
) -> Check:
    """The centre's projection on the line a-b (3,) [m], from their midpoint [m], inside
    half their distance."""
    d = b - a
    length = float(np.linalg.norm(d))
    along = float(np.dot(centre - 0.5 * (a + b), d / length)) if length > 0 else np.nan
    return Check(joint, f"centre along {a_name}-{b_name} from their midpoint", along,
                 -0.5 * length, 0.5 * length)  # fmt: skip


def _wrist_checks(
    pset: ParameterSet, theta: np.ndarray, alias: Mapping[str, str], side: str
) -> list[Check]:
    p = side.upper()
    wra, wrb = _marker(pset, alias, p + "WRA"), _marker(pset, alias, p + "WRB")
    body = f"radius_{side}"
    if wra is None or wrb is None or not (_on(pset, wra, body) and _on(pset, wrb, body)):
        return []
    centre = _centre(pset, theta, f"hand_{side}")
    a, b = _offset(pset, theta, wra), _offset(pset, theta, wrb)
    return [_between(f"wrist_{side}", wra, wrb, a, b, centre)]


def _pelvis_markers(
    pset: ParameterSet, theta: np.ndarray, alias: Mapping[str, str]
) -> dict[str, np.ndarray]:
    """The offsets (3,) [m] of the ASIS and PSIS roles on the pelvis (those present)."""
    out = {}
    for role in ("LASI", "RASI", "LPSI", "RPSI"):
        m = _marker(pset, alias, role)
        if m is not None and _on(pset, m, "pelvis"):
            out[role] = _offset(pset, theta, m)
    return out


def _hip_checks(
    pset: ParameterSet, theta: np.ndarray, alias: Mapping[str, str], side: str
) -> list[Check]:
    pelvis = _pelvis_markers(pset, theta, alias)
    if not {"LASI", "RASI"} <= set(pelvis):
        return []
    p, sign = side.upper(), (1.0 if side == "l" else -1.0)
    hip = _centre(pset, theta, f"thigh_{side}")
    mid = 0.5 * (pelvis["LASI"] + pelvis["RASI"])
    name = f"hip_{side}"
    out = [
        Check(name, f"centre medial of {p}ASI", float(sign * (pelvis[p + "ASI"][1] - hip[1])),
              0.0, None),
        Check(name, "centre behind the ASIS line", float(mid[0] - hip[0]), 0.0, None),
        Check(name, "centre below the ASIS plane", float(mid[2] - hip[2]), 0.0, None),
    ]  # fmt: skip
    if {"LPSI", "RPSI"} <= set(pelvis):
        back = 0.5 * (pelvis["LPSI"] + pelvis["RPSI"])
        out.append(Check(name, "centre in front of the PSIS midpoint", float(hip[0] - back[0]),
                         0.0, None))  # fmt: skip
    return out


def _inter_hip_check(
    pset: ParameterSet, theta: np.ndarray, alias: Mapping[str, str]
) -> list[Check]:
    pelvis = _pelvis_markers(pset, theta, alias)
    if not {"LASI", "RASI"} <= set(pelvis):
        return []
    pw = float(np.linalg.norm(pelvis["LASI"] - pelvis["RASI"]))
    expected = 2 * (HARRINGTON_WIDTH[0] * pw + HARRINGTON_WIDTH[1])
    tol = max(MIN_TOLERANCE, TOLERANCE_SD * np.sqrt(2.0) * SIGMA_HJC)
    dist = float(np.linalg.norm(_centre(pset, theta, "thigh_l") - _centre(pset, theta, "thigh_r")))
    return [Check("hips", f"distance between the hip centres (Harrington on PW {pw * 1e3:.0f} mm)",
                  dist, expected - tol, expected + tol)]  # fmt: skip


def _axis_checks(
    pset: ParameterSet, theta: np.ndarray, decisions: Mapping[str, Mapping[str, Any]]
) -> list[Check]:
    out = []
    for joint, d in decisions.items():
        angle = abs(angle_to_pig(pset, theta, d))
        placed = d.get("source") == "functional" or (
            float(d.get("data_sd_deg", np.inf)) <= AXIS_DETERMINED_DEG
        )
        what = "flexion axis from Plug-in Gait's construction" + (
            " (the data determine it: reported only)" if placed else ""
        )
        out.append(Check(joint, what, angle, None, AXIS_LIMIT_DEG, "deg", not placed))
    return out


def _mirror_checks(pset: ParameterSet, theta: np.ndarray) -> list[Check]:
    def centre(body: str, side: str) -> np.ndarray:
        return _centre(pset, theta, f"{body}_{side}")

    gap = np.abs(centre("thigh", "l") - _MIRROR * centre("thigh", "r"))
    out = [Check("hip_lr", "left centre from the mirrored right one (largest axis)",
                 float(gap.max()), None, _mirror_tolerance(SIGMA_HJC))]  # fmt: skip
    for joint, (child, parameter) in MIRRORED.items():
        length, _, sd_deg = ALIGNMENT[parameter]
        mean = 0.5 * sum(float(theta[pset.index(f"{length}_{s}")]) for s in "lr")
        lateral = abs(float(centre(child, "l")[1] + centre(child, "r")[1]))  # y mirrored
        limit = _mirror_tolerance(float(np.tan(np.radians(sd_deg))) * mean)
        out.append(Check(f"{joint}_lr", "left centre from the mirrored right one (lateral)",
                         lateral, None, limit))  # fmt: skip
    return out


def _mirror_tolerance(sd_side: float) -> float:
    """The limit [m] of a left-right difference of two figures of standard deviation
    ``sd_side`` [m] each: :data:`TOLERANCE_SD` sd of their difference, at least
    :data:`MIN_TOLERANCE`."""
    return max(MIN_TOLERANCE, TOLERANCE_SD * float(np.sqrt(2.0)) * sd_side)
