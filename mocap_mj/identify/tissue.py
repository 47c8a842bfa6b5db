"""Soft-tissue sliding of landmark markers with their joint's angle: per-sample weights.

A landmark marker on a joint's axis (KNE on the lateral femoral epicondyle, on the knee flexion
axis) is placed, and its prior rows (:mod:`mocap_mj.identify.anatomy`) are written, in the pose
that defines it: the static standing pose, the model's zero angles. As the joint turns away
from that pose, the skin under the marker slides over the bone: the marker moves against its
segment by an amount that grows with the angle and that no rigid offset can follow, and the
fit bends the skeleton (joint centres, segment lengths) to follow it (measured:
docs/real-data.md "Soft-tissue sliding").

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

The ankle (ANK) and elbow (ELB) markers sit on bone under thin skin: their sliding is not
modelled (weighting them alike helped no real-data figure, docs/real-data.md).

``mocap-mj identify`` weighs with :data:`SLIDES` by default (``--no-sliding-landmarks``: off)
and records the model it weighed with in model.xml (:func:`with_sliding_model`); ``mocap-mj
ik`` reads it back (:func:`recorded_sliding_model`) and weighs its own poses alike, so that
the exported model reproduces the fit (docs/ik.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from xml.etree import ElementTree

import mujoco
import numpy as np

from ..parameters import ParameterSet


@dataclass(frozen=True)
class Slide:
    """A landmark's slide: the hinge ``joint`` (name without the side suffix) whose angle
    [rad] from ``angle0`` [rad] (the defining pose) moves the skin, at ``rate`` [m/rad]
    (per-axis standard deviation per radian)."""

    joint: str
    rate: float
    angle0: float = 0.0


#: Landmark marker (name without the side prefix) -> its slide. See the module docstring.
SLIDES: dict[str, Slide] = {"KNE": Slide("knee_flex", 0.010)}


def _sliding_markers(pset: ParameterSet, slides: dict[str, Slide]) -> list[tuple[int, int, Slide]]:
    """(marker index, qpos address of its joint, slide) of every marker of ``pset`` named
    L/R + a key of ``slides`` whose side's joint (``joint_l`` / ``joint_r``) is a hinge."""
    out = []
    model = pset.model
    for i, name in enumerate(pset.marker_names):
        slide = slides.get(name[1:])
        if slide is None or name[:1] not in ("L", "R"):
            continue
        jid = mujoco.mj_name2id(
            model, mujoco.mjtObj.mjOBJ_JOINT, f"{slide.joint}_{name[0].lower()}"
        )
        if jid >= 0 and model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_HINGE:
            out.append((i, int(model.jnt_qposadr[jid]), slide))
    return out


def sliding_weights(
    pset: ParameterSet,
    qpos: np.ndarray,
    base: float,
    slides: dict[str, Slide] | None = None,
) -> np.ndarray:
    """Per-sample weights (T, M) [1] of the poses qpos (T, nq): ``base^2 / (base^2 +
    (rate |q - angle0|)^2)`` for the sliding landmarks of ``slides`` (default :data:`SLIDES`),
    1 for every other marker and for frames without a pose (NaN rows). ``base`` [m] is the
    per-axis artefact every marker carries (the pipeline's soft-tissue floor or the fit's
    noise, whichever is larger)."""
    q = np.asarray(qpos, dtype=float)
    w = np.ones((len(q), pset.n_markers))
    for i, adr, slide in _sliding_markers(pset, SLIDES if slides is None else slides):
        sd = slide.rate * np.abs(q[:, adr] - slide.angle0)
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
    reproduces the fit (docs/ik.md)."""

    slides: dict[str, Slide]
    base: float

    def weights(self, pset: ParameterSet, qpos: np.ndarray) -> np.ndarray:
        """Per-sample weights (T, M) [1] of the poses qpos (T, nq): :func:`sliding_weights`."""
        return sliding_weights(pset, qpos, self.base, self.slides)


def with_sliding_model(xml: str, sliding: SlidingModel) -> str:
    """MJCF text ``xml`` with ``sliding`` recorded as ``<custom><numeric>`` entries (which
    MuJoCo keeps and ignores in the kinematics): ``mocap_mj_slide_base`` = base [m], and per
    landmark ``mocap_mj_slide:MARKER:JOINT`` = (rate [m/rad], angle0 [rad])."""
    root = ElementTree.fromstring(xml)
    custom = root.find("custom")
    if custom is None:
        custom = ElementTree.SubElement(root, "custom")
    entries = {f"{RECORD_PREFIX}_base": [sliding.base]}
    for marker, s in sliding.slides.items():
        entries[f"{RECORD_PREFIX}:{marker}:{s.joint}"] = [s.rate, s.angle0]
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
        elif name.startswith(f"{RECORD_PREFIX}:") and name.count(":") == 2 and data.size == 2:
            _, marker, joint = name.split(":")
            slides[marker] = Slide(joint, float(data[0]), float(data[1]))
    if base is None or not slides:
        return None
    return SlidingModel(slides, base)


__all__ = [
    "RECORD_PREFIX",
    "SLIDES",
    "Slide",
    "SlidingModel",
    "recorded_sliding_model",
    "sliding_weights",
    "with_sliding_model",
]
