"""Soft-tissue sliding of landmark markers with their joint's angle: per-sample weights.

A landmark marker on a joint's axis (KNE on the lateral femoral epicondyle, on the knee flexion
axis) is placed, and its prior rows (:mod:`mocap_mj.anatomy.anatomy`) are written, in the pose
that defines it: the static standing pose, the model's zero angles. As the joint turns away
from that pose, the skin under the marker slides over the bone: the marker moves against its
segment by an amount that grows with the angle and that no rigid offset can follow, and the
fit bends the skeleton (joint centres, segment lengths) to follow it
(docs/method.md#weighing-priors-trials-and-sliding-markers).

The model here is heteroscedastic noise: a landmark's sample at joint angle q has, beyond the
artefact every marker carries (per-axis standard deviation ``base``), a slide of per-axis
standard deviation ``rate * |q - q_def|`` (``q_def`` = 0, the defining pose). Its weight in
the loss is the ratio of variances ``base^2 / (base^2 + (rate |q - q_def|)^2)``: 1 in the
defining pose, where the landmark rows hold, falling with the angle, so the frames far from
that pose no longer pull the segment's offsets and lengths, and the other markers decide
there. The slide's direction and size vary between subjects and tasks, so it is taken as
noise, not as a correction of known sign.

Rates (:data:`SLIDES`), per-axis standard deviation per radian from the defining pose:

* KNE, knee flexion, 10 mm/rad (15 mm at 90 degrees): skin markers over the distal thigh
  move 10-30 mm against the femur, most in deep flexion (Leardini et al. 2005, a review of
  bone-pin and fluoroscopy studies).

The acromion marker (SHO) slides too: its skin moves against the scapula as the arm rises,
and the scapula turns under it about the acromioclavicular joint, which the model's rigid
shoulder girdle (sternoclavicular joint to glenohumeral centre) lacks; acromion-based
scapular tracking errors grow with humeral elevation (Karduna et al. 2001; van Andel et al.
2009; review: Cereatti et al. 2017), and Plug-in Gait defines SHO and the shoulder offset
with the arm at the side. :data:`SHOULDER_SLIDE` models it against humerothoracic elevation
(the upper arm's tilt from the thorax, however the clavicle and the glenohumeral ball share
it; :class:`Slide`'s ``reference``), 10 mm/rad. It is not in :data:`SLIDES`: SHO is the
only marker on the clavicle, so weighing it down in the raised-arm frames leaves the
girdle's pose there to the arm markers: on synthetic range-of-motion trials with SHO slid
that way it brings the glenohumeral centres closer but not the clavicle lengths, and on the
shared trials it moved no agreement figure (``benchmarks/sho_slide.py``). The library's
``slides=`` takes it.

The ankle (ANK) and elbow (ELB) markers sit on bone under thin skin: their sliding is not
modelled (weighting them alike helped no real-data figure; the ankle and
the elbow are convention joints instead, :mod:`mocap_mj.anatomy.anatomy`).

``mocap-mj identify`` weighs with :data:`SLIDES` by default (the recipe's ``sliding_landmarks``)
and records the model it weighed with in model.xml (:func:`with_sliding_model`); ``mocap-mj
ik`` reads it back (:func:`recorded_sliding_model`) and weighs its own poses alike, so that
the exported model reproduces the fit (docs/outputs.md#modelxml-reproduces-the-fit).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from xml.etree import ElementTree

import mujoco
import numpy as np

from mocap_mj.skeleton.parameters import ParameterSet


@dataclass(frozen=True)
class Slide:
    """A landmark's slide: the ``joint`` (name without the side suffix) whose angle [rad]
    from ``angle0`` [rad] (the defining pose) moves the skin, at ``rate`` [m/rad] (per-axis
    standard deviation per radian).

    The angle of a hinge is its coordinate. With ``reference`` (a body name without the side
    suffix, e.g. "thorax") the angle is instead the tilt of the joint's child body's long
    axis (its z) from that body's z: for the shoulder ball and the thorax, humerothoracic
    elevation, whatever shoulder-girdle and glenohumeral angles make it up."""

    joint: str
    rate: float
    angle0: float = 0.0
    reference: str = ""


#: Landmark marker (name without the side prefix) -> its slide. See the module docstring.
SLIDES: dict[str, Slide] = {"KNE": Slide("knee_flex", 0.010)}

#: SHO's slide with humerothoracic elevation (module docstring): not in :data:`SLIDES`.
SHOULDER_SLIDE = Slide("shoulder", 0.010, reference="thorax")


def _body(model: mujoco.MjModel, name: str, side: str) -> int:
    """Id of the body ``name`` or ``name_side`` (-1 when the model has neither)."""
    for n in (name, f"{name}_{side}"):
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)
        if bid >= 0:
            return bid
    return -1


def _sliding_markers(
    pset: ParameterSet, slides: dict[str, Slide]
) -> list[tuple[int, int, int, Slide]]:
    """(marker index, joint id, reference body id or -1, slide) of every marker of ``pset``
    named L/R + a key of ``slides`` whose side's joint (``joint_l`` / ``joint_r``) is a hinge,
    or any joint when the slide names a ``reference`` body the model has (``reference`` or
    ``reference_l`` / ``_r``)."""
    out = []
    model = pset.model
    for i, name in enumerate(pset.marker_names):
        slide = slides.get(name[1:])
        if slide is None or name[:1] not in ("L", "R"):
            continue
        side = name[0].lower()
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"{slide.joint}_{side}")
        if jid < 0:
            continue
        if slide.reference:
            ref = _body(model, slide.reference, side)
            if ref >= 0:
                out.append((i, jid, ref, slide))
        elif model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_HINGE:
            out.append((i, jid, -1, slide))
    return out


def _tilts(
    model: mujoco.MjModel, q: np.ndarray, pairs: set[tuple[int, int]]
) -> dict[tuple[int, int], np.ndarray]:
    """Per (body, reference body) pair: the angle (T,) [rad] between the two bodies' z axes
    in the poses q (T, nq) (NaN for frames without a pose). Orientations do not depend on
    the lengths in theta, so any model of the parameter set gives the same angles."""
    out = {p: np.full(len(q), np.nan) for p in pairs}
    data = mujoco.MjData(model)
    for t, row in enumerate(q):
        if not np.all(np.isfinite(row)):
            continue
        data.qpos[:] = row
        mujoco.mj_kinematics(model, data)
        for b, r in pairs:
            cos = data.xmat[b].reshape(3, 3)[:, 2] @ data.xmat[r].reshape(3, 3)[:, 2]
            out[(b, r)][t] = np.arccos(np.clip(cos, -1.0, 1.0))
    return out


def slide_angles(pset: ParameterSet, qpos: np.ndarray, slides: dict[str, Slide]) -> np.ndarray:
    """Each sliding landmark's angle from its slide's defining pose, ``|q - angle0|`` (T, M)
    [rad], in the poses qpos (T, nq): a hinge's coordinate, or the tilt of the joint's child
    body from the slide's ``reference`` body (:class:`Slide`). NaN for the other markers
    and for frames without a pose."""
    model = pset.model
    q = np.asarray(qpos, dtype=float)
    angles = np.full((len(q), pset.n_markers), np.nan)
    found = _sliding_markers(pset, slides)
    pairs = {(int(model.jnt_bodyid[j]), ref) for _, j, ref, _ in found if ref >= 0}
    tilts = _tilts(model, q, pairs) if pairs else {}
    for i, jid, ref, slide in found:
        if ref >= 0:
            a = tilts[(int(model.jnt_bodyid[jid]), ref)]
        else:
            a = q[:, int(model.jnt_qposadr[jid])]
        angles[:, i] = np.abs(a - slide.angle0)
    return angles


#: Humerothoracic elevation [rad] above which the arm counts as raised for
#: :func:`raised_arms_note`: SHO's distance to CLAV held within 2 mm between trials at 13-29
#: degrees and was 13-20 mm shorter at 72-79 degrees on the shared trials
#: (docs/validation.md#real-recordings); 45 degrees lies between.
RAISED_ARMS = np.radians(45.0)
#: Frames (evenly spaced) over which :func:`arm_elevation` takes its percentiles.
_ELEVATION_FRAMES = 2000


def arm_elevation(
    pset: ParameterSet, qpos: Sequence[np.ndarray]
) -> dict[str, tuple[float, float, float]]:
    """Each side's humerothoracic elevation (the upper arm's tilt from the thorax, as
    :data:`SHOULDER_SLIDE` measures it) over the frames of every trial's poses qpos
    (T_k, nq): ``{"l" | "r": (p5, median, p95)}`` [rad], over at most 2000 evenly spaced
    frames with a pose; a side whose SHO or bodies the model lacks is left out."""
    q = np.concatenate([np.asarray(x, dtype=float) for x in qpos], axis=0)
    q = q[np.all(np.isfinite(q), axis=1)]
    if len(q) > _ELEVATION_FRAMES:
        q = q[np.linspace(0, len(q) - 1, _ELEVATION_FRAMES).astype(int)]
    out: dict[str, tuple[float, float, float]] = {}
    if len(q) == 0:
        return out
    angles = slide_angles(pset, q, {"SHO": SHOULDER_SLIDE})
    for side in ("l", "r"):
        name = ("L" if side == "l" else "R") + "SHO"
        if name not in pset.marker_names:
            continue
        a = angles[:, pset.marker_index(name)]
        a = a[np.isfinite(a)]
        if a.size:
            p5, p50, p95 = np.percentile(a, [5, 50, 95])
            out[side] = (float(p5), float(p50), float(p95))
    return out


def raised_arms_note(elevation: dict[str, tuple[float, float, float]]) -> str | None:
    """A one-line note when an arm is raised above :data:`RAISED_ARMS` in 95 % of the
    fitted frames, every trial's pooled (``elevation`` from :func:`arm_elevation`), else
    None. SHO places the shoulder centre (a convention joint), and the skin over the
    acromion carries SHO toward the sternum as the arm rises: with the arms raised
    throughout, no frame shows SHO where Plug-in Gait defines it (the arm at the side)."""
    raised = {s: v for s, v in elevation.items() if v[0] > RAISED_ARMS}
    if not raised:
        return None
    sides = ", ".join(
        f"{'left' if s == 'l' else 'right'} {np.degrees(v[0]):.0f}-{np.degrees(v[2]):.0f} deg"
        for s, v in raised.items()
    )
    return (
        f"the arms are raised from the trunk in every frame ({sides}, p5-p95): the shoulder "
        "centres are placed from SHO, which the skin over the acromion carries toward the "
        "sternum as the arm rises, so the clavicles come out short and the upper arms long; "
        "identify with a trial where the arms hang or move as well "
        "(docs/recordings.md#other-lines-on-stderr)"
    )


def sliding_weights(
    pset: ParameterSet,
    qpos: np.ndarray,
    base: float,
    slides: dict[str, Slide] | None = None,
) -> np.ndarray:
    """Per-sample weights (T, M) [1] of the poses qpos (T, nq): ``base^2 / (base^2 +
    (rate |q - angle0|)^2)`` for the sliding landmarks of ``slides`` (default :data:`SLIDES`;
    the angle as :func:`slide_angles`), 1 for every other marker and for frames without a
    pose (NaN rows). ``base`` [m] is the per-axis artefact every marker carries (the
    pipeline's soft-tissue floor or the fit's noise, whichever is larger)."""
    slides = SLIDES if slides is None else slides
    angles = slide_angles(pset, qpos, slides)
    w = np.ones(angles.shape)
    for i, _, _, slide in _sliding_markers(pset, slides):
        sd = slide.rate * angles[:, i]
        w[:, i] = np.where(np.isfinite(sd), base**2 / (base**2 + np.nan_to_num(sd) ** 2), 1.0)
    return w


#: Prefix of the MJCF ``<custom><numeric>`` entries that record the sliding model in model.xml.
RECORD_PREFIX = "mocap_mj_slide"


@dataclass(frozen=True)
class SlidingModel:
    """The sliding model an identification weighed its fit with: ``slides`` (landmark ->
    :class:`Slide`) against a per-axis artefact ``base`` [m]. ``identify`` records it in
    model.xml (:func:`with_sliding_model`) and ``ik --model`` reads it back
    (:func:`recorded_sliding_model`) to weigh its poses alike: the exported model then
    reproduces the fit (docs/outputs.md#modelxml-reproduces-the-fit)."""

    slides: dict[str, Slide]
    base: float

    def weights(self, pset: ParameterSet, qpos: np.ndarray) -> np.ndarray:
        """Per-sample weights (T, M) [1] of the poses qpos (T, nq): :func:`sliding_weights`."""
        return sliding_weights(pset, qpos, self.base, self.slides)


def with_sliding_model(xml: str, sliding: SlidingModel) -> str:
    """MJCF text ``xml`` with ``sliding`` recorded as ``<custom><numeric>`` entries (which
    MuJoCo keeps and ignores in the kinematics): ``mocap_mj_slide_base`` = base [m], and per
    landmark ``mocap_mj_slide:MARKER:JOINT`` (``...:JOINT:REFERENCE`` for a tilt from a
    reference body, :class:`Slide`) = (rate [m/rad], angle0 [rad])."""
    root = ElementTree.fromstring(xml)
    custom = root.find("custom")
    if custom is None:
        custom = ElementTree.SubElement(root, "custom")
    entries = {f"{RECORD_PREFIX}_base": [sliding.base]}
    for marker, s in sliding.slides.items():
        ref = f":{s.reference}" if s.reference else ""
        entries[f"{RECORD_PREFIX}:{marker}:{s.joint}{ref}"] = [s.rate, s.angle0]
    for name, data in entries.items():
        ElementTree.SubElement(
            custom, "numeric", name=name, data=" ".join(repr(float(v)) for v in data)
        )
    ElementTree.indent(root, space="  ")
    return ElementTree.tostring(root, encoding="unicode") + "\n"


def recorded_sliding_model(model: mujoco.MjModel) -> SlidingModel | None:
    """The sliding model recorded in ``model`` by :func:`with_sliding_model`, or None (a model
    not identified with it, e.g. the bundled humanoid)."""
    base = None
    slides: dict[str, Slide] = {}
    for i in range(model.nnumeric):
        name, data = model.numeric(i).name, np.asarray(model.numeric(i).data, dtype=float)
        if name == f"{RECORD_PREFIX}_base" and data.size == 1:
            base = float(data[0])
        elif name.startswith(f"{RECORD_PREFIX}:") and name.count(":") in (2, 3) and data.size == 2:
            _, marker, joint, *ref = name.split(":")
            slides[marker] = Slide(joint, float(data[0]), float(data[1]), *ref)
    if base is None or not slides:
        return None
    return SlidingModel(slides, base)


__all__ = [
    "RECORD_PREFIX",
    "SHOULDER_SLIDE",
    "SLIDES",
    "Slide",
    "SlidingModel",
    "recorded_sliding_model",
    "slide_angles",
    "sliding_weights",
    "with_sliding_model",
]
