"""The model-parameter vector theta = (kappa, marker offsets) and its maps onto an ``MjModel``.

theta has P = K + 3 M entries: K = 34 kinematic parameters kappa [m] (segment lengths, widths
and depths, and the frontal-plane alignment of the knee and ankle centres), then the M = 39
marker offsets, each the site's ``pos`` (x, y, z) [m] in the frame of the body that carries
it, in model site order.

Every kinematic parameter is a documented linear map onto ``body_pos`` entries:
``body_pos[b] = body_pos_nominal[b] + sum_k D[k, b] (kappa_k - kappa_nominal_k)`` with one
direction vector ``D[k, b]`` (3,) per (parameter, body) pair, given in the parent body's frame.
A direction is a signed axis ("-z": the length grows downwards) or ``along`` (the unit vector of
the body's nominal ``pos``: a length measured along the segment).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import mujoco
import numpy as np

from mocap_mj.arguments import array, kind, optional, path_like, sequence, validated
from mocap_mj.errors import (
    ArgumentError,
    InputFileError,
    MocapError,
    UnknownNameError,
    check_shape,
    excerpt,
)
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.strict_json import read_object
from mocap_mj.skeleton import exported, rolling
from mocap_mj.skeleton.mjcf import load_model, model_path

_AXES = {"x": 0, "y": 1, "z": 2}


#: A target's direction: a signed parent-frame axis, or along the body's offset.
DIRECTION_SPECS = ("x", "-x", "y", "-y", "z", "-z", "along")


@dataclass(frozen=True)
class KinematicParameter:
    """One named kinematic parameter and the body positions it moves.

    Attributes
    ----------
    name : str
        Identifier, e.g. ``"thigh_length_l"``.
    description : str
        What it measures, anatomically.
    targets : tuple of (body name, direction spec)
        Direction spec: ``"x"``, ``"-z"``, ... (a signed parent-frame axis) or ``"along"``.
    """

    name: str
    description: str
    targets: tuple[tuple[str, str], ...]

    def __post_init__(self) -> None:
        kind("KinematicParameter name", self.name, str, "a text")
        kind("KinematicParameter description", self.description, str, "a text")
        for i, target in enumerate(sequence("KinematicParameter targets", self.targets, "pairs")):
            if (
                not isinstance(target, tuple | list)
                or len(target) != 2
                or not isinstance(target[0], str)
                or target[1] not in DIRECTION_SPECS
            ):
                raise ArgumentError(
                    f"KinematicParameter targets[{i}]: expected (body name, one of "
                    f"{', '.join(DIRECTION_SPECS)}), got {excerpt(target)}"
                )


def _p(name: str, description: str, *targets: tuple[str, str]) -> KinematicParameter:
    return KinematicParameter(name, description, tuple(targets))


#: The 34 kinematic parameters of the bundled humanoid.
KINEMATIC_PARAMETERS: tuple[KinematicParameter, ...] = (
    # pelvis (root): hip joint centres and the lumbosacral joint relative to mid-ASIS
    _p("hip_depth_l", "left hip joint centre, posterior of mid-ASIS", ("thigh_l", "-x")),
    _p("hip_depth_r", "right hip joint centre, posterior of mid-ASIS", ("thigh_r", "-x")),
    _p("hip_width_l", "left hip joint centre, lateral of the midline", ("thigh_l", "y")),
    _p("hip_width_r", "right hip joint centre, lateral of the midline", ("thigh_r", "-y")),
    _p("hip_height_l", "left hip joint centre, below the ASIS plane", ("thigh_l", "-z")),
    _p("hip_height_r", "right hip joint centre, below the ASIS plane", ("thigh_r", "-z")),
    _p("lumbar_depth", "L5/S1 joint, posterior of mid-ASIS", ("lumbar", "-x")),
    _p("lumbar_height", "L5/S1 joint, above the ASIS plane", ("lumbar", "z")),
    # trunk
    _p("lumbar_length", "L5/S1 to T12/L1 (lumbar spine length)", ("thorax", "z")),
    _p("thorax_length", "T12/L1 to C7/T1 (thoracic spine length)", ("head", "z")),
    _p("neck_depth", "C7/T1 joint, anterior of T12/L1", ("head", "x")),
    _p("sc_depth", "sternoclavicular joints, anterior of T12/L1", ("clavicle_l", "x"),
       ("clavicle_r", "x")),
    _p("sc_height_l", "left sternoclavicular joint, above T12/L1", ("clavicle_l", "z")),
    _p("sc_height_r", "right sternoclavicular joint, above T12/L1", ("clavicle_r", "z")),
    _p("sc_width_l", "left sternoclavicular joint, lateral of the midline", ("clavicle_l", "y")),
    _p("sc_width_r", "right sternoclavicular joint, lateral of the midline", ("clavicle_r", "-y")),
    # arms
    _p("clavicle_length_l", "left sternoclavicular to glenohumeral joint", ("upperarm_l", "along")),
    _p("clavicle_length_r", "right sternoclavicular to glenohumeral joint",
       ("upperarm_r", "along")),
    _p("upperarm_length_l", "left glenohumeral to elbow joint", ("ulna_l", "-z")),
    _p("upperarm_length_r", "right glenohumeral to elbow joint", ("ulna_r", "-z")),
    _p("forearm_length_l", "left elbow to wrist joint", ("hand_l", "-z")),
    _p("forearm_length_r", "right elbow to wrist joint", ("hand_r", "-z")),
    # legs
    _p("thigh_length_l", "left hip to knee joint", ("shank_l", "-z")),
    _p("thigh_length_r", "right hip to knee joint", ("shank_r", "-z")),
    _p("shank_length_l", "left knee to ankle joint", ("foot_l", "-z")),
    _p("shank_length_r", "right knee to ankle joint", ("foot_r", "-z")),
    # frontal-plane alignment: a joint centre lateral (+) or medial (-) of its parent's origin
    # along the flexion axis, so that hip, knee and ankle centres need not lie in one plane
    # normal to the knee axis (the femur's and tibia's mechanical axes against the
    # transepicondylar axis: the subject's static valgus/varus, docs/model.md)
    _p("knee_lateral_l", "left knee centre, lateral of the hip centre along the knee axis",
       ("shank_l", "y")),
    _p("knee_lateral_r", "right knee centre, lateral of the hip centre along the knee axis",
       ("shank_r", "-y")),
    _p("ankle_lateral_l", "left ankle centre, lateral of the knee centre along the knee axis",
       ("foot_l", "y")),
    _p("ankle_lateral_r", "right ankle centre, lateral of the knee centre along the knee axis",
       ("foot_r", "-y")),
    _p("foot_length_l", "left ankle to MTP joint, forward", ("toes_l", "x")),
    _p("foot_length_r", "right ankle to MTP joint, forward", ("toes_r", "x")),
    _p("foot_height_l", "left ankle to MTP joint, downward", ("toes_l", "-z")),
    _p("foot_height_r", "right ankle to MTP joint, downward", ("toes_r", "-z")),
)  # fmt: skip

#: The frontal-plane alignment parameters (nominal 0): a parameters file without them (written
#: before they existed) reads with them at 0.
ALIGNMENT_NAMES = frozenset(
    f"{a}_{s}" for a in ("knee_lateral", "ankle_lateral") for s in ("l", "r")
)

#: Bounds of kappa: nominal -/+ max(KAPPA_REL_BOUND * |nominal|, KAPPA_ABS_BOUND) [m].
KAPPA_REL_BOUND = 0.35
KAPPA_ABS_BOUND = 0.04
#: Bounds of the alignment parameters (nominal 0): -/+ ALIGNMENT_BOUND [m], wider than their
#: anatomical range (:mod:`mocap_mj.anatomy.ranges`, 110 mm for the tallest adults).
ALIGNMENT_BOUND = 0.12
#: Bounds of each marker-offset component: nominal -/+ OFFSET_BOUND [m].
OFFSET_BOUND = 0.08


class ParameterSet:
    """Names, nominal values, bounds and frozen flags of theta, and its maps onto a model.

    Parameters
    ----------
    path : str or Path, optional
        MJCF file of a model with the bundled humanoid's bodies and sites (an exported model
        works); its ``body_pos``/``site_pos`` are the nominal values. The bundled humanoid by
        default. ``apply`` writes into the models you pass it, never into ``self.model``.

    Attributes
    ----------
    names : tuple of str, (P,)
        ``kappa`` names, then ``"<MARKER>.x"``, ``".y"``, ``".z"`` per marker.
    nominal, lower, upper : (P,) float [m]
    frozen : (P,) bool
        Entries a solver must keep at their current value (settable).
    direction : (K, nbody, 3) float
        ``D[k, b]``: the change of ``body_pos[b]`` per metre of ``kappa_k`` (parent frame).
    """

    @validated(path=optional(path_like))
    def __init__(self, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else model_path()
        model = load_model(self.path)
        self.model = model
        self.marker_names: tuple[str, ...] = tuple(model.site(i).name for i in range(model.nsite))
        self.kinematic: tuple[KinematicParameter, ...] = KINEMATIC_PARAMETERS
        self.n_kappa = len(self.kinematic)
        self.n_markers = model.nsite
        self.size = self.n_kappa + 3 * self.n_markers
        self.site_body = np.array(model.site_bodyid, dtype=int)

        direction = np.zeros((self.n_kappa, model.nbody, 3))
        kappa0 = np.zeros(self.n_kappa)
        for k, par in enumerate(self.kinematic):
            values = []
            for body_name, spec in par.targets:
                try:
                    b = model.body(body_name).id
                except KeyError:
                    bodies = ", ".join(model.body(i).name for i in range(1, model.nbody))
                    raise InputFileError(
                        f"{self.path}: no body {body_name!r}, which the parameter {par.name} "
                        "needs (the model must have the bundled humanoid's bodies); its "
                        f"bodies: {bodies}"
                    ) from None
                pos = np.array(model.body_pos[b], dtype=float)
                if spec == "along":
                    d = pos / np.linalg.norm(pos)
                else:
                    d = np.zeros(3)
                    d[_AXES[spec[-1]]] = -1.0 if spec.startswith("-") else 1.0
                direction[k, b] = d
                values.append(float(pos @ d))
            if max(values) - min(values) > 1e-12:
                raise InputFileError(
                    f"{self.path}: the bodies of the parameter {par.name} disagree on its "
                    f"nominal value {values}"
                )
            kappa0[k] = values[0]
        self.direction = direction
        self.body_pos_nominal = np.array(model.body_pos, dtype=float)
        self.site_pos_nominal = np.array(model.site_pos, dtype=float)

        self.names: tuple[str, ...] = tuple(p.name for p in self.kinematic) + tuple(
            f"{m}.{a}" for m in self.marker_names for a in "xyz"
        )
        self._index = {n: i for i, n in enumerate(self.names)}
        self.nominal = np.concatenate([kappa0, self.site_pos_nominal.ravel()])
        half_kappa = np.maximum(KAPPA_REL_BOUND * np.abs(kappa0), KAPPA_ABS_BOUND)
        aligned = [k for k, p in enumerate(self.kinematic) if p.name in ALIGNMENT_NAMES]
        half_kappa[aligned] = ALIGNMENT_BOUND
        half = np.concatenate([half_kappa, np.full(3 * self.n_markers, OFFSET_BOUND)])
        self.lower = self.nominal - half
        self.upper = self.nominal + half
        self.frozen = np.zeros(self.size, dtype=bool)
        # Bodies a kappa moves, as (k, body) pairs, for Jacobians.
        self.kappa_targets: tuple[tuple[int, int], ...] = tuple(
            (k, int(b))
            for k in range(self.n_kappa)
            for b in np.flatnonzero(np.any(direction[k], 1))
        )

    # ----------------------------------------------------------------- naming
    def index(self, name: str) -> int:
        """Position of ``name`` in theta; an unknown name lists the valid ones."""
        try:
            return self._index[name]
        except KeyError:
            raise UnknownNameError("parameter", name, self.names) from None

    def marker_index(self, name: str) -> int:
        """Model site index of marker ``name``."""
        try:
            return self.marker_names.index(name)
        except ValueError:
            raise UnknownNameError("marker", name, self.marker_names) from None

    @property
    def kappa_names(self) -> tuple[str, ...]:
        return self.names[: self.n_kappa]

    def split(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """theta (P,) -> (kappa (K,) [m], offsets (M, 3) [m]) as views."""
        theta = self.check(theta)
        return theta[: self.n_kappa], theta[self.n_kappa :].reshape(self.n_markers, 3)

    def join(self, kappa: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """(kappa (K,), offsets (M, 3)) [m] -> theta (P,)."""
        check_shape("kappa", kappa, (self.n_kappa,))
        check_shape("offsets", offsets, (self.n_markers, 3))
        return np.concatenate([kappa, np.asarray(offsets, float).ravel()])

    def check(self, theta: np.ndarray) -> np.ndarray:
        """Return theta as a float array (P,) [m], finite; else an
        :class:`~mocap_mj.errors.ArgumentError` naming the shape or value received."""
        return array("theta", theta, (self.size,))

    # ------------------------------------------------------------ model maps
    def body_pos(self, theta: np.ndarray) -> np.ndarray:
        """``body_pos`` (nbody, 3) [m] for theta: the nominal positions moved by kappa."""
        kappa, _ = self.split(theta)
        dk = kappa - self.nominal[: self.n_kappa]
        return self.body_pos_nominal + np.einsum("k,kbi->bi", dk, self.direction)

    def apply(self, model: mujoco.MjModel, theta: np.ndarray) -> None:
        """Write theta into ``model.body_pos`` and ``model.site_pos`` in place (no recompile)."""
        _, offsets = self.split(theta)
        model.body_pos[:] = self.body_pos(theta)
        model.site_pos[:] = offsets

    def read(self, model: mujoco.MjModel) -> np.ndarray:
        """theta (P,) of a model with this structure (inverse of :meth:`apply`)."""
        moved = np.array(model.body_pos) - self.body_pos_nominal
        kappa = self.nominal[: self.n_kappa].copy()
        for k in range(self.n_kappa):
            b = np.flatnonzero(np.any(self.direction[k], 1))[0]
            kappa[k] += moved[b] @ self.direction[k, b]
        theta = self.join(kappa, np.array(model.site_pos))
        if not np.allclose(model.body_pos, self.body_pos(theta), atol=1e-12):
            raise MocapError("model body positions are not reachable by the kinematic parameters")
        return theta

    def model_for(self, theta: np.ndarray) -> mujoco.MjModel:
        """A copy of the model with theta applied."""
        import copy

        model = copy.copy(self.model)
        self.apply(model, theta)
        return model

    def with_rolling_scaled(self, theta: np.ndarray) -> ParameterSet:
        """This parameter set with its model's knee rolling (:mod:`mocap_mj.skeleton.rolling`)
        scaled to theta's segments: each coupling's reference length L becomes the distance of
        its body from the parent's origin (hip to knee centre) at theta, as OpenSim's scaling scales
        the femur's translation functions with the femur. A copy (its own model); ``self``
        when the model has no coupling.

        The identification calls it once with its initial model and keeps the result for the
        whole solve: L is then a constant, so a kinematic parameter's Jacobian stays
        ``R_parent d`` (scaling with the moving thigh length would add a term through t(q)).
        """
        import copy

        roll = rolling.read(self.model)
        if roll is None:
            return self
        new = copy.copy(self)
        new.model = copy.copy(self.model)
        lengths = np.linalg.norm(self.body_pos(theta)[roll.bodies], axis=1)
        rolling.set_lengths(
            new.model,
            {new.model.body(b).name: float(v) for b, v in zip(roll.bodies, lengths, strict=True)},
        )
        return new

    def within_bounds(self, theta: np.ndarray) -> bool:
        theta = self.check(theta)
        return bool(np.all(theta >= self.lower) and np.all(theta <= self.upper))

    # ------------------------------------------------------------------- I/O
    def to_dict(self, theta: np.ndarray) -> dict[str, Any]:
        """``{"kappa": {name: m}, "offsets": {marker: [x, y, z]}}`` in metres."""
        kappa, offsets = self.split(theta)
        return {
            "units": "m",
            "kappa": {n: float(v) for n, v in zip(self.kappa_names, kappa, strict=True)},
            "offsets": {
                n: [float(c) for c in o] for n, o in zip(self.marker_names, offsets, strict=True)
            },
        }

    def from_dict(self, data: Mapping[str, Any], *, source: str = "theta") -> np.ndarray:
        """Inverse of :meth:`to_dict`; every name must be known and present (the alignment
        parameters may be absent: :data:`ALIGNMENT_NAMES`)."""
        try:
            kappa_d, off_d = data["kappa"], data["offsets"]
        except (KeyError, TypeError):
            raise MocapError(f"{source}: expected keys 'kappa' and 'offsets'") from None
        for key, value in (("kappa", kappa_d), ("offsets", off_d)):
            if not isinstance(value, Mapping):
                raise MocapError(
                    f"{source}: {key}: expected a mapping of names to metres, got {excerpt(value)}"
                )
        unknown = [n for n in kappa_d if n not in self.kappa_names]
        unknown += [n for n in off_d if n not in self.marker_names]
        if unknown:
            raise MocapError(f"{source}: unknown names {excerpt(unknown)}")
        # A file written before the alignment parameters existed held them at 0 by
        # construction (the knee centre below the hip centre, the ankle below the knee).
        kappa_d = {**{n: 0.0 for n in ALIGNMENT_NAMES if n in self._index}, **kappa_d}
        missing = [n for n in self.kappa_names if n not in kappa_d]
        missing += [n for n in self.marker_names if n not in off_d]
        if missing:
            raise MocapError(f"{source}: missing names {missing}")
        for name in self.kappa_names:
            _check_length(source, f"kappa {name}", kappa_d[name])
        for name in self.marker_names:
            value = off_d[name]
            if not isinstance(value, list) or len(value) != 3:
                raise MocapError(
                    f"{source}: offsets {name}: expected 3 numbers [m], got {excerpt(value)}"
                )
            for c in value:
                _check_length(source, f"offsets {name}", c)
        kappa = np.array([float(kappa_d[n]) for n in self.kappa_names])
        offsets = np.array([[float(c) for c in off_d[n]] for n in self.marker_names])
        return self.check(self.join(kappa, offsets))

    @validated(path=path_like)
    def save_json(
        self, path: str | Path, theta: np.ndarray, extra: Mapping[str, Any] | None = None
    ) -> None:
        """Write theta (and ``extra`` keys) as JSON, atomically."""
        data = dict(extra or {})
        data.update(self.to_dict(theta))
        atomic_write_text(path, json.dumps(data, indent=2) + "\n")

    @validated(path=path_like)
    def load_json(self, path: str | Path) -> np.ndarray:
        """Read theta from a JSON file written by :meth:`save_json`."""
        data = read_object(path, "the parameters (a JSON object with kappa and offsets)")
        return self.from_dict(data, source=str(path))

    def to_spec(self, theta: np.ndarray, *, joint_range: np.ndarray | None = None) -> mujoco.MjSpec:
        """An ``MjSpec`` of the model with theta written into its bodies and sites.

        ``joint_range`` (njnt, 2) [rad or m], as ``MjModel.jnt_range``: the joint limits to
        write instead of the file's (only the joints whose range differs are rewritten, in
        the file's angle unit); default: the file's limits. An identification that solved
        with other limits (``Tolerances.ball_limit_scale``) passes them so that the written
        model reproduces its fit.
        """
        spec = exported.internal_spec(self.path)
        if joint_range is not None:
            self._write_joint_range(spec, joint_range)
        body_pos = self.body_pos(theta)
        _, offsets = self.split(theta)
        for b in range(1, self.model.nbody):
            spec.body(self.model.body(b).name).pos = body_pos[b]
        for s, name in enumerate(self.marker_names):
            spec.site(name).pos = offsets[s]
        return spec

    def _write_joint_range(self, spec: mujoco.MjSpec, joint_range: np.ndarray) -> None:
        model = self.model
        rng = np.asarray(joint_range, dtype=float)
        check_shape("joint_range", rng, (model.njnt, 2))
        angular = (int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_HINGE))
        for j in range(model.njnt):
            if np.allclose(rng[j], model.jnt_range[j], rtol=0.0, atol=1e-12):
                continue
            value = rng[j]
            if spec.compiler.degree and int(model.jnt_type[j]) in angular:
                value = np.degrees(value)
            spec.joint(model.joint(j).name).range = value

    def to_xml(self, theta: np.ndarray, *, joint_range: np.ndarray | None = None) -> str:
        """MJCF text of the model with theta (via ``MjSpec``), positions at full precision.

        ``MjSpec.to_xml`` prints about 6 significant digits; the body and site positions and
        the joint ranges (the file's, or ``joint_range``, see :meth:`to_spec`) are rewritten
        with ``repr`` so that the file reloads to the same forward kinematics and limits (a
        cone rounded to 6 digits is narrower than the solver's by up to 5e-6 rad). The knee
        rolling is written as this set's model holds it (scaled by
        :meth:`with_rolling_scaled`), so the file reproduces the solve's kinematics: as its
        ``<custom>`` record for this tool, and as slide joints coupled to the knee hinges by
        equality constraints for plain MuJoCo (:func:`mocap_mj.skeleton.exported.with_slides`).
        """
        spec = self.to_spec(theta, joint_range=joint_range)
        spec.compile()
        root = ElementTree.fromstring(spec.to_xml())
        body_pos = self.body_pos(theta)
        _, offsets = self.split(theta)
        exact = {("body", self.model.body(b).name): body_pos[b] for b in range(1, self.model.nbody)}
        exact.update({("site", n): offsets[s] for s, n in enumerate(self.marker_names)})
        rng = self.model.jnt_range if joint_range is None else joint_range
        # MjSpec.to_xml writes angles in radians, as jnt_range holds them.
        ranges = {self.model.joint(j).name: rng[j] for j in range(self.model.njnt)}
        for elem in root.iter():
            value = exact.get((elem.tag, elem.get("name", "")))
            if value is not None:
                elem.set("pos", " ".join(repr(float(v)) for v in value))
            if elem.tag == "joint" and elem.get("name", "") in ranges and elem.get("range"):
                elem.set("range", " ".join(repr(float(v)) for v in ranges[elem.get("name", "")]))
        ElementTree.indent(root, space="  ")
        xml = rolling.record(ElementTree.tostring(root, encoding="unicode") + "\n", self.model)
        return exported.with_slides(xml, self.model, joint_range)

    @validated(path=path_like)
    def export_mjcf(
        self, path: str | Path, theta: np.ndarray, *, joint_range: np.ndarray | None = None
    ) -> None:
        """Write an MJCF file of the model with theta, atomically (see :meth:`to_xml`)."""
        atomic_write_text(path, self.to_xml(theta, joint_range=joint_range))


#: Largest magnitude of a parameter read from a file [m]: no segment or marker offset of a
#: body is 10 m long; a larger value is a damaged or foreign file.
THETA_LIMIT = 10.0


def _check_length(source: str, name: str, value: Any) -> None:
    """Refuse a parameter value that is not a number within :data:`THETA_LIMIT` [m]."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not -THETA_LIMIT <= value <= THETA_LIMIT
    ):
        raise MocapError(
            f"{source}: {name}: expected a number within +-{THETA_LIMIT:g} m, got {excerpt(value)}"
        )
