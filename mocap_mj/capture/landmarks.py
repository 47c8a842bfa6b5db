"""Anatomical landmarks a marker can name, and the joint widths two of them measure.

A marker-set YAML (:mod:`mocap_mj.capture.marker_set`) may say which bony landmark a marker sits on
(``landmark: medial_femoral_epicondyle``), from the vocabulary :data:`LANDMARKS` (the
International Society of Biomechanics' landmarks, Wu et al. 2002 and 2005; Cappozzo et al.
1995), or ``technical`` for a wand, plate or cluster marker on no landmark. When a set holds
both landmarks of a joint width (:data:`WIDTH_PAIRS`: the femoral epicondyles for the knee,
the malleoli for the ankle, the humeral epicondyles for the elbow; not the wrist, whose
width in Plug-in Gait is the wrist's thickness under the bar, not the styloids' distance),
the width is measured from the data: the median over frames of the two markers'
distance minus one marker diameter (each marker's centre sits a radius off the skin), with
its source. A width measured with a caliper (the C3D file's, ``--subject-file``'s or a
flag's) wins; one that differs from the markers' by more than :data:`WIDTH_DISAGREEMENT` is
warned about.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

#: Landmark name -> what it is. ``technical``: a marker on no landmark (wand, plate, cluster).
LANDMARKS: dict[str, str] = {
    "technical": "a marker on no landmark (wand, plate, cluster, free-placed)",
    "asis": "anterior superior iliac spine",
    "psis": "posterior superior iliac spine",
    "sacrum": "sacrum, midway between the posterior superior iliac spines",
    "greater_trochanter": "greater trochanter of the femur",
    "lateral_femoral_epicondyle": "lateral femoral epicondyle",
    "medial_femoral_epicondyle": "medial femoral epicondyle",
    "fibular_head": "head of the fibula",
    "tibial_tuberosity": "tibial tuberosity",
    "lateral_malleolus": "lateral malleolus (apex)",
    "medial_malleolus": "medial malleolus (apex)",
    "calcaneus": "posterior calcaneus (heel)",
    "first_metatarsal_head": "head of the first metatarsal",
    "second_metatarsal_head": "head of the second metatarsal",
    "fifth_metatarsal_head": "head of the fifth metatarsal",
    "c2": "spinous process of the second cervical vertebra",
    "c7": "spinous process of the seventh cervical vertebra",
    "t1": "spinous process of the first thoracic vertebra",
    "t6": "spinous process of the sixth thoracic vertebra",
    "t8": "spinous process of the eighth thoracic vertebra",
    "t10": "spinous process of the tenth thoracic vertebra",
    "jugular_notch": "jugular (suprasternal) notch",
    "xiphoid": "xiphoid process",
    "acromion": "acromion (dorsal, acromioclavicular joint)",
    "lateral_humeral_epicondyle": "lateral humeral epicondyle",
    "medial_humeral_epicondyle": "medial humeral epicondyle",
    "radial_styloid": "radial styloid process",
    "ulnar_styloid": "ulnar styloid process",
    "second_metacarpal_head": "head of the second metacarpal",
    "fifth_metacarpal_head": "head of the fifth metacarpal",
    "head_front": "front of the head (temple)",
    "head_back": "back of the head",
}

#: Subject width (side removed) -> the (lateral, medial) landmarks whose distance it is.
WIDTH_PAIRS: dict[str, tuple[str, str]] = {
    "knee_width": ("lateral_femoral_epicondyle", "medial_femoral_epicondyle"),
    "ankle_width": ("lateral_malleolus", "medial_malleolus"),
    "elbow_width": ("lateral_humeral_epicondyle", "medial_humeral_epicondyle"),
}

#: A caliper width and the markers' differing by more than this [m] is warned about.
WIDTH_DISAGREEMENT = 0.010


@dataclass(frozen=True)
class MeasuredWidth:
    """A width measured from the markers: ``name`` (``knee_width_l``...), ``value`` [m],
    the two markers and the frames it is the median over."""

    name: str
    value: float
    markers: tuple[str, str]
    frames: int

    @property
    def source(self) -> str:
        """Where the value comes from, for summary.json and report.md."""
        a, b = self.markers
        return f"markers {a}-{b}: median distance over {self.frames} frames less a diameter"


def measured_widths(
    landmarks: Mapping[str, str],
    bodies: Mapping[str, str],
    names: Sequence[str],
    trials: Sequence[np.ndarray],
    diameter: float,
) -> list[MeasuredWidth]:
    """The widths two landmark markers of a set measure (module docstring).

    ``landmarks``: marker -> landmark (markers without one absent); ``bodies``: marker ->
    its body (the side is the body name's ``_l`` / ``_r``); ``names`` (M,): the order of
    the trials' markers, each trial (T_i, M, 3) [m] with NaN where missing; ``diameter``
    [m]: the markers'. A pair seen together in no frame gives no width.
    """
    out = []
    for width, (lateral, medial) in WIDTH_PAIRS.items():
        for side in ("l", "r"):
            pair = [_on(landmarks, bodies, landmark, side) for landmark in (lateral, medial)]
            a, b = pair
            if a is None or b is None or a not in names or b not in names:
                continue
            i, j = names.index(a), names.index(b)
            dist = np.concatenate(
                [np.linalg.norm(np.asarray(t)[:, i] - np.asarray(t)[:, j], axis=1) for t in trials]
            )
            dist = dist[np.isfinite(dist)]
            value = float(np.median(dist)) - diameter if dist.size else 0.0
            if value > 0:  # seen together, farther apart than a marker's diameter
                out.append(MeasuredWidth(f"{width}_{side}", value, (a, b), int(dist.size)))
    return out


def _on(
    landmarks: Mapping[str, str], bodies: Mapping[str, str], landmark: str, side: str
) -> str | None:
    """The marker on ``landmark`` of ``side`` (its body's name ends ``_side``), else None."""
    for marker, name in landmarks.items():
        if name == landmark and bodies.get(marker, "").endswith(f"_{side}"):
            return marker
    return None


def disagreements(measured: Sequence[MeasuredWidth], given: Mapping[str, float]) -> list[str]:
    """One line per measured width that differs from the ``given`` one (name -> value [m])
    by more than :data:`WIDTH_DISAGREEMENT`: the given value is kept."""
    lines = []
    for m in measured:
        value = given.get(m.name)
        if value is not None and abs(value - m.value) > WIDTH_DISAGREEMENT:
            lines.append(
                f"{m.name}: given {value * 1e3:.0f} mm, the markers {m.markers[0]}-"
                f"{m.markers[1]} measure {m.value * 1e3:.0f} mm (kept: {value * 1e3:.0f} mm; "
                "check the measurement or the markers' placement)"
            )
    return lines
