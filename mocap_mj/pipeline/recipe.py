"""The choices of an identification, as one value: :class:`Recipe`, read from and written to YAML.

A recipe states what ``mocap-mj identify`` (and :func:`mocap_mj.identify`) solves: the model and
its marker set, the markers excluded, the frames, the correction of exchanged labels and the
refusal of suspect data, the initial model, the anatomical priors and ranges, the left/right
prior, the soft-tissue sliding model, the trials' weights, the loss, the frames it identifies on
for a long recording and the refinement on every frame, the iterations, the weak prior and the
segments' inertial parameters of the kinetics (de Leva's regression, or their masses fitted to
the force plates). Every
result folder holds the recipe it was made with (``recipe.yaml``); ``mocap-mj identify --recipe
DIR/recipe.yaml`` on the same trials gives the same theta. How the solver gets there (its
:class:`~mocap_mj.solve.settings.Tolerances`, the command's are the defaults) and how it uses
memory (:class:`~mocap_mj.solve.settings.Performance`) are not part of a recipe, nor how the
marker files are read (their vertical axis, units, label map and subject prefix: flags of the
commands).

Lengths are in metres in the file as in the code.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, get_args

import yaml

from mocap_mj.solve.lm import LMSettings, Performance, Tolerances
from mocap_mj.solve.losses import LossName

from ..errors import ArgumentError, ArgumentTypeError, InputFileError, MocapError, excerpt
from ..io.atomic import atomic_write_text
from ..io.yaml_file import read_yaml

Init = Literal["constructed", "placed", "scaled", "nominal"]
#: Initial models (:attr:`Recipe.init`).
INITS: tuple[str, ...] = get_args(Init)
HipCentre = Literal["harrington", "davis"]
#: Hip-centre regressions (:attr:`Recipe.hip_centre`).
HIP_CENTRES: tuple[str, ...] = get_args(HipCentre)
Inertia = Literal["regression", "fit"]
#: Where the segments' masses come from (:attr:`Recipe.inertia`).
INERTIAS: tuple[str, ...] = get_args(Inertia)
#: The choices :class:`LMSettings` holds (the solver's share of a recipe).
_SETTINGS_CHOICES = (
    "max_iterations", "prior_sigma", "prior_noise", "loss", "loss_scale", "observable_std"
)  # fmt: skip
#: ``select``'s words besides a number of frames.
SELECT_WORDS = ("auto", "all")
#: The range of every numeric field, (low, high, what it is), both ends included: beyond them
#: a solve is meaningless or its arithmetic fails (a weak prior of 1e-300 m overflows its
#: weight (prior_noise / prior_sigma)^2; a noise of 0 divides by zero). A width below 0.1 mm
#: is finer than any marker system measures, a noise above 10 cm is not a marker's.
NUMERIC_RANGES: dict[str, tuple[float, float, str]] = {
    "loss_scale": (0.1, 100.0, "a threshold in noise sigmas"),
    "max_iterations": (1, 100_000, "a number of iterations"),
    "prior_sigma": (1e-4, 10.0, "a width in m"),
    "prior_noise": (1e-5, 0.1, "a marker noise in m"),
    "observable_std": (1e-5, 1.0, "a standard deviation in m"),
    "symmetric": (1e-4, 1.0, "a width in m"),
    "select": (1, 10**9, "a number of frames"),
    "silent_axis_sd": (1e-3, 3.2, "a standard deviation in rad"),
}


@dataclass(frozen=True)
class Recipe:
    """The choices of an identification (defaults: those of ``mocap-mj identify``).

    Attributes
    ----------
    init : "constructed", "placed", "scaled" or "nominal"
        Initial model and prior mean: constructed = the joint centres, segment lengths and
        the offsets of the markers on the thighs, shanks, upper arms and forearms from
        the anatomical constructions on the recording (:mod:`~mocap_mj.anatomy.constructed`;
        any posture), the other markers placed by IK; placed = the nominal model scaled to
        the subject from marker distances, the marker offsets then placed by IK; scaled =
        scaled only; nominal = the bundled model as it is.
    anatomy : bool
        Anatomical ranges as bounds and the landmark priors (:mod:`~mocap_mj.anatomy.anatomy`,
        :mod:`~mocap_mj.anatomy.ranges`).
    symmetric : float or None [m]
        With anatomy: a prior tying every left length to the right one with this standard
        deviation, in place of the population asymmetry prior (None: not used).
    asymmetry_prior : bool
        With anatomy and no ``symmetric``: the population asymmetry prior (``ASYMMETRY_SIGMA``).
    sliding_landmarks : bool
        With anatomy: the landmarks' soft-tissue sliding model (:mod:`~mocap_mj.anatomy.tissue`),
        applied only where the residuals show soft tissue.
    trial_weights : bool
        With anatomy and several trials: weigh each trial by the independent observations it
        holds (:func:`~mocap_mj.solve.noise.trial_weights`); False weighs every trial 1.
    loss : "l2", "huber" or "cauchy"
        Loss on each marker distance.
    loss_scale : float [1]
        Robust threshold in units of the estimated per-axis noise sigma.
    select : int, "auto" or "all"
        Frames to identify on, chosen for pose diversity (then refined on every frame when
        ``refine``): a number, "auto" (``AUTO_SELECT_COUNT`` frames when the trials hold more
        than ``AUTO_SELECT_ABOVE``, else every frame) or "all".
    refine : bool
        After identifying on selected frames, refine the model on every frame.
    max_iterations : int
        LM iterations at most.
    prior_sigma : float [m]
        Width of the weak prior toward the initial model (for a marker noise ``prior_noise``).
    prior_noise : float [m]
        The marker noise the priors are first weighed against.
    observable_std : float [m]
        A direction of theta counts as observable when its standard deviation is below this
        (reporting only).
    hip_centre : "harrington" or "davis"
        With anatomy: the hip centres' regression, Harrington et al. 2007 (closer to
        imaging) or Davis et al. 1991 (Plug-in Gait's; needs both leg lengths).
    model : str or None
        The base MJCF file (None: the bundled humanoid).
    marker_set : str or None
        A bundled marker set's name or a set's YAML file, whose markers replace the model's
        sites and whose landmarks (epicondyles, malleoli) measure joint widths and give
        joint axes (None: the bundled set the labels fit, without ``model``; the model's own
        sites with it). A fit records the set it used.
    exclude_markers : tuple of str
        Model markers whose data are dropped (missing in every frame).
    frames : str or None
        The frames fitted of every trial, ``"A:B"`` as ``--frames`` (None: all).
    relabel : bool
        Correct labels exchanged by mistake in the pipeline's copy of the markers (False:
        only warn).
    strict : bool
        Refuse the data when the quality check finds anything, a label needs correcting or
        T10's placement is suspect (False: warn and carry on).
    silent_axis_sd : float [rad]
        With anatomy: a flexion axis whose direction the markers determine to a standard
        deviation (their Cramer-Rao bound, the construction's row taken out) above this stays
        at its construction, and report.md says so; below it the motion places it
        (:func:`~mocap_mj.anatomy.axes.axis_decisions`). Default 10 degrees, the joint
        checks' limit of a determined axis.
    inertia : "regression" or "fit"
        The segments' inertial parameters of the kinetics (force plates and a body mass):
        regression = de Leva's for the body mass (:mod:`~mocap_mj.anatomy.inertia`); fit =
        their masses fitted over the stance frames of every trial with plates, de Leva's as
        the prior (:func:`~mocap_mj.pipeline.inertial_fit.fit_masses`; without a stance frame
        the regression's, with a notice). The kinematic fit (theta) is the same either way.
    """

    init: Init = "constructed"
    anatomy: bool = True
    symmetric: float | None = None
    asymmetry_prior: bool = True
    sliding_landmarks: bool = True
    trial_weights: bool = True
    loss: LossName = "l2"
    loss_scale: float = 3.0
    select: int | str = "auto"
    refine: bool = True
    max_iterations: int = 100
    prior_sigma: float = 0.05
    prior_noise: float = 0.001
    observable_std: float = 0.005
    hip_centre: HipCentre = "harrington"
    model: str | None = None
    marker_set: str | None = None
    exclude_markers: tuple[str, ...] = ()
    frames: str | None = None
    relabel: bool = True
    strict: bool = False
    silent_axis_sd: float = 0.17453292519943295  # 10 deg: anatomy.axes.SILENT_AXIS_SD
    inertia: Inertia = "regression"

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            _check_kind("Recipe", field.name, getattr(self, field.name), field.default)
        names = self.exclude_markers
        if isinstance(names, str) or not all(isinstance(n, str) and n for n in names):
            raise ArgumentError(f"exclude_markers: expected a list of marker names, got {names!r}")
        object.__setattr__(self, "exclude_markers", tuple(names))
        for name in ("model", "marker_set", "frames"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, str) and value):
                raise ArgumentError(f"{name}: expected a text or none, got {value!r}")
        if self.frames is not None:
            frame_range(self.frames, 1 << 62)  # its form; its frames are checked per trial
        if self.marker_set is not None:
            from mocap_mj.capture.marker_sets import resolve

            try:
                resolve(self.marker_set)  # a bundled set's name or a file's path
            except MocapError as exc:
                raise ArgumentError(f"marker_set: {exc}") from None
        if self.model is not None and not (
            self.model.lower().endswith(".xml") or Path(self.model).is_file()
        ):
            raise ArgumentError(f"model: expected an MJCF file (.xml), got {self.model!r}")
        if self.init not in INITS:
            raise ArgumentError(f"init must be one of {', '.join(INITS)}; got {self.init!r}")
        if isinstance(self.select, str) and self.select not in SELECT_WORDS:
            raise ArgumentError(
                f"select: expected a number of frames, auto or all, got {self.select!r}"
            )
        if not isinstance(self.select, str) and (isinstance(self.select, bool) or self.select < 1):
            raise ArgumentError(f"select: expected at least 1 frame, got {self.select!r}")
        if self.inertia not in INERTIAS:
            raise ArgumentError(
                f"inertia must be one of {', '.join(INERTIAS)}; got {self.inertia!r}"
            )
        if self.hip_centre not in HIP_CENTRES:
            raise ArgumentError(
                f"hip_centre must be one of {', '.join(HIP_CENTRES)}; got {self.hip_centre!r}"
            )
        for name, (low, high, what) in NUMERIC_RANGES.items():
            value = getattr(self, name)
            if value is None or isinstance(value, str):
                continue  # symmetric not used; select's words
            whole = name in ("max_iterations", "select")
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or (whole and not float(value).is_integer())
                or not low <= value <= high  # NaN fails too
            ):
                raise ArgumentError(
                    f"{name}: expected {what} within {low:g}..{high:g}, got {value!r}"
                )
        self.settings()  # the solver's own checks (loss, prior widths, iterations)

    def settings(
        self, tolerances: Tolerances | None = None, performance: Performance | None = None
    ) -> LMSettings:
        """The joint LM's settings: this recipe's choices with ``tolerances`` and
        ``performance`` (default: theirs)."""
        return LMSettings(
            max_iterations=self.max_iterations,
            prior_sigma=self.prior_sigma,
            prior_noise=self.prior_noise,
            loss=self.loss,
            loss_scale=self.loss_scale,
            observable_std=self.observable_std,
            tolerances=tolerances or Tolerances(),
            performance=performance or Performance(),
        )

    @classmethod
    def of_settings(cls, settings: LMSettings, **choices: Any) -> Recipe:
        """The recipe whose :meth:`settings` hold ``settings``' choices (iterations, loss,
        weak prior, reporting threshold), with the other ``choices`` given."""
        mine = {k: getattr(settings, k) for k in _SETTINGS_CHOICES}
        return cls(**{**mine, **choices})

    def to_yaml(self) -> str:
        """The recipe as YAML (every field, lengths in metres), with a header line."""
        fields = dataclasses.asdict(self)
        fields["exclude_markers"] = list(self.exclude_markers)
        body = yaml.safe_dump(fields, sort_keys=False)
        return "# mocap-mj recipe: the choices of an identification (lengths in m)\n" + body

    def save(self, path: str | Path) -> None:
        """Write :meth:`to_yaml` to ``path`` (atomically)."""
        atomic_write_text(path, self.to_yaml())

    @classmethod
    def load(cls, path: str | Path) -> Recipe:
        """The recipe in the YAML file ``path``: a mapping of field names to values; fields
        not named keep their defaults. Raises :class:`InputFileError` naming the file and
        the field for an unknown field or a value of the wrong kind."""
        data = read_yaml(path, "recipe")
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise InputFileError(
                f"{path}: expected a mapping of recipe fields, got {excerpt(data)}"
            )
        return cls.from_dict(data, source=str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "recipe") -> Recipe:
        """The recipe of ``data`` (field name -> value); ``source`` names it in errors."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        for name, value in data.items():
            if name not in fields:
                raise InputFileError(
                    f"{source}: unknown recipe field {excerpt(name)} "
                    f"(expected one of {', '.join(fields)})"
                )
            try:
                _check_kind(source, name, value, cls.__dataclass_fields__[name].default)
            except ArgumentTypeError as exc:
                raise InputFileError(str(exc)) from None
        try:
            return cls(**data)
        except MocapError as exc:
            raise InputFileError(f"{source}: {exc}") from None


def _check_kind(source: str, name: str, value: Any, default: Any) -> None:
    """Refuse a value whose kind differs from the field's default (bool, number, text):
    :class:`ArgumentTypeError` naming ``source`` and the field (a file's: ``from_dict``)."""
    if name == "select":
        ok = isinstance(value, str) or (isinstance(value, int) and not isinstance(value, bool))
    elif name == "symmetric":
        ok = value is None or (isinstance(value, int | float) and not isinstance(value, bool))
    elif name == "exclude_markers":
        ok = isinstance(value, list | tuple) and all(isinstance(v, str) for v in value)
    elif default is None:
        ok = value is None or isinstance(value, str)
    elif isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(default, float):
        ok = isinstance(value, int | float) and not isinstance(value, bool)
    elif isinstance(default, str):
        ok = isinstance(value, str)
    else:  # a field of another kind (a default factory's) checks its own values
        ok = True
    if not ok:
        raise ArgumentTypeError(
            f"{source}: recipe field {name!r}: expected a value like {default!r}, "
            f"got {excerpt(value)}"
        )


def frame_range(
    text: str | None, n: int, source: str = "the recording", *, stride: bool = False
) -> slice:
    """The frames of a ``--frames`` text over ``n`` frames: the one parser of every command.

    ``"A:B"`` is a Python slice of frames, B exclusive, negative from the end, an empty part
    the slice's default (``":"`` every frame); with ``stride``, ``"A:B:S"`` also takes every
    S-th frame (S positive). None or "" -> every frame. Returns the slice with its bounds
    resolved (0 <= start <= stop <= n). A bound past the ``n`` frames of ``source`` is
    refused, naming its frame count: a range silently shortened would use other frames than
    the ones asked for.
    """
    if not text:
        return slice(0, n)
    form = "A:B or A:B:S" if stride else "A:B"
    parts = text.split(":")
    try:
        if len(parts) not in ((2, 3) if stride else (2,)):
            raise ValueError
        a, b, *s = (int(p) if p.strip() else None for p in parts)
    except ValueError:
        raise MocapError(f"--frames: expected {form} (e.g. 0:500), got {text!r}") from None
    step = s[0] if s else None
    if step is not None and step <= 0:
        raise MocapError(f"--frames {text}: the step S must be positive, got {step}")
    if any(v is not None and not -n <= v <= n for v in (a, b)):
        raise MocapError(
            f"{source}: --frames {text}: past the end, the recording has {n} frames (0 to {n - 1})"
        )
    start, stop, _ = slice(a, b).indices(n)
    return slice(start, max(start, stop), step)


def check_select(select: int | str, n_trials: int) -> int | None:
    """``Recipe.select``'s number of frames (None for its words), refused below one frame
    per trial of the ``n_trials``."""
    if isinstance(select, str):
        return None
    count = int(select)
    if count < n_trials:
        raise MocapError(f"select: expected at least one frame per trial ({n_trials}), got {count}")
    return count
