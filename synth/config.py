"""The settings of one synthetic experiment, validated on construction."""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass
from typing import Any

from mocap_mj.errors import MocapError

__all__ = ["MARKER_PLACEMENTS", "MOTIONS", "POSES", "ConfigError", "SynthConfig"]

#: Names of the truth-motion presets (see :mod:`mocap_synth.motion`).
MOTIONS: tuple[str, ...] = ("rom", "walk", "static")
#: How the truth model's markers are placed (see :func:`mocap_synth.perturb.perturb_theta`).
MARKER_PLACEMENTS: tuple[str, ...] = ("anatomical", "uniform")
#: Postures a trial holds or starts in (see :mod:`mocap_synth.postures`), the default first.
POSES: tuple[str, ...] = ("neutral", "t-pose", "arms-up", "seated", "crouched")


class ConfigError(MocapError, ValueError):
    """A synthesizer setting out of its valid range (one-line message naming it)."""


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigError(f"{name}: expected a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ConfigError(f"{name}: expected a finite number, got {value!r}")
    return out


def _integer(name: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ConfigError(f"{name}: expected an integer, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class SynthConfig:
    """Settings of a synthetic experiment: truth model, truth motion, measurement model.

    Attributes
    ----------
    frames : int
        Number of frames T (>= 1).
    rate : float
        Frame rate [Hz] (> 0).
    motion : str
        Truth-motion preset: ``"rom"`` (range of motion), ``"walk"`` or ``"static"``.
    noise_mm : float
        Standard deviation of the white Gaussian noise per axis [mm] (>= 0).
    sta_mm : float
        Soft-tissue artefact gain [mm per rad of the driving joints] (>= 0; 0 = off).
    gaps : float
        Fraction of the T x M samples removed in occlusion gaps, in [0, 1).
    outliers : float
        Fraction of the T x M samples displaced as outliers, in [0, 1).
    outlier_mm : float
        Displacement of an outlier [mm] (>= 0).
    swaps : int
        Number K of left/right marker pairs whose labels are swapped over a time window (>= 0).
    seed : int
        Seed of every random draw (>= 0); the same settings give the same experiment.
    kappa_scale : float
        Each kinematic parameter is scaled by a factor uniform in ``1 -/+ kappa_scale``,
        in [0, 1).
    offset_mm : float
        Each marker-offset component moves by up to ``-/+ offset_mm`` [mm] (>= 0).
    symmetric : bool
        Perturb left and right alike (mirror images) instead of independently.
    marker_placement : str
        ``"anatomical"`` (default): the landmark markers follow the perturbed skeleton, each
        where the marker set's anatomy puts it plus a placement error at its prior's width
        (:func:`mocap_synth.perturb.place_landmarks`), as on a real subject; ``"uniform"``:
        every marker keeps its nominal offset plus its ``offset_mm`` shift whatever the
        skeleton does (the truth of the paper's experiment).
    pose : str
        The posture a static holds and a dynamic trial starts in (:data:`POSES`, default
        ``"neutral"``: standing, arms at the sides; :mod:`mocap_synth.postures`).
    heading_deg : float
        Rotation [deg] of the whole capture about the vertical through the origin (default 0:
        the subject faces +x).
    """

    frames: int = 500
    rate: float = 100.0
    motion: str = "rom"
    noise_mm: float = 1.0
    sta_mm: float = 0.0
    gaps: float = 0.0
    outliers: float = 0.0
    outlier_mm: float = 50.0
    swaps: int = 0
    seed: int = 0
    kappa_scale: float = 0.10
    offset_mm: float = 20.0
    symmetric: bool = False
    marker_placement: str = "anatomical"
    pose: str = "neutral"
    heading_deg: float = 0.0

    def __post_init__(self) -> None:
        frames = _integer("frames", self.frames)
        if frames < 1:
            raise ConfigError(f"frames: expected at least 1 frame, got {frames}")
        rate = _number("rate", self.rate)
        if rate <= 0:
            raise ConfigError(f"rate: expected a positive frame rate [Hz], got {self.rate!r}")
        if self.motion not in MOTIONS:
            raise ConfigError(
                f"motion: unknown preset {self.motion!r}; expected one of {', '.join(MOTIONS)}"
            )
        if self.marker_placement not in MARKER_PLACEMENTS:
            raise ConfigError(
                f"marker_placement: unknown placement {self.marker_placement!r}; expected one "
                f"of {', '.join(MARKER_PLACEMENTS)}"
            )
        if self.pose not in POSES:
            raise ConfigError(
                f"pose: unknown posture {self.pose!r}; expected one of {', '.join(POSES)}"
            )
        values: dict[str, Any] = {"frames": frames, "rate": rate}
        values["heading_deg"] = _number("heading_deg", self.heading_deg)
        for name in ("noise_mm", "sta_mm", "outlier_mm", "offset_mm"):
            value = _number(name, getattr(self, name))
            if value < 0:
                raise ConfigError(f"{name}: expected a value >= 0, got {value:g}")
            values[name] = value
        for name in ("gaps", "outliers", "kappa_scale"):
            value = _number(name, getattr(self, name))
            if not 0.0 <= value < 1.0:
                raise ConfigError(f"{name}: expected a fraction in [0, 1), got {value:g}")
            values[name] = value
        if values["gaps"] + values["outliers"] >= 1.0:
            raise ConfigError(
                f"gaps + outliers: expected a total below 1, got "
                f"{values['gaps']:g} + {values['outliers']:g}"
            )
        for name in ("swaps", "seed"):
            value = _integer(name, getattr(self, name))
            if value < 0:
                raise ConfigError(f"{name}: expected an integer >= 0, got {value}")
            values[name] = value
        if not isinstance(self.symmetric, bool | numbers.Integral) or self.symmetric not in (0, 1):
            raise ConfigError(f"symmetric: expected True or False, got {self.symmetric!r}")
        values["symmetric"] = bool(self.symmetric)
        for name, value in values.items():
            object.__setattr__(self, name, value)

    @property
    def duration(self) -> float:
        """Length of the trial [s]: ``(frames - 1) / rate``."""
        return (self.frames - 1) / self.rate

    def to_dict(self) -> dict[str, Any]:
        """Every setting, JSON-ready; ``pose`` and ``heading_deg`` only when not their defaults
        (a neutral capture facing +x writes the same files as before they existed)."""
        out = asdict(self)
        for name, default in (("pose", "neutral"), ("heading_deg", 0.0)):
            if out[name] == default:
                del out[name]
        return out
