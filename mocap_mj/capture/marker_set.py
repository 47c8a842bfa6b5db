"""Marker sets as data: which markers a protocol places, on which body, where, and how firmly.

A marker-set file is YAML::

    name: Plug-in Gait full body
    source: Vicon, Plug-in Gait Reference Guide (2017)
    marker_radius: 0.007
    markers:
      - {name: LASI, body: pelvis, offset: [0.0, 0.125, 0.0], class: landmark}
      - {name: LTHI, body: thigh_l, offset: [0.0, 0.08, -0.25], class: cluster}
      - {name: LKNM, body: thigh_l, offset: [0.0, -0.05, -0.43], class: free,
         landmark: medial_femoral_epicondyle}

``offset`` is the marker's initial position [m] in the frame of ``body`` (a body of the
model); ``class`` is its prior class: ``landmark`` (placed on a palpated bony landmark, so its
offset is known to a few millimetres), ``cluster`` (on a wand or plate whose placement is
arbitrary: its offset is for identification to find) or ``free`` (no prior at all);
``landmark`` (optional) names the bony landmark it sits on (:mod:`mocap_mj.capture.landmarks`: two
landmarks of a joint width measure it from the data). ``marker_radius`` [m] (optional,
default :data:`DEFAULT_MARKER_RADIUS`, Plug-in Gait's 14 mm markers) is the radius of the
set's markers, used wherever a marker's centre is placed off the skin (joint centres from a
lateral landmark, widths from a landmark pair) when the subject's measurements give no
marker diameter; ``source`` (optional) is one line naming where the set comes from. The
bundled sets live in ``models/marker_sets/`` (:mod:`mocap_mj.capture.marker_sets`); the Plug-in
Gait set (``plug_in_gait.yaml``) is the model's own sites in this format.
:func:`model_with_marker_set` builds a model whose sites are a set's markers (via MjSpec), so
that :class:`~mocap_mj.skeleton.parameters.ParameterSet` works on any marker set.
"""

from __future__ import annotations

import math
import os
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
import yaml

from mocap_mj.capture.landmarks import LANDMARKS
from mocap_mj.errors import InputFileError, UnknownNameError, excerpt
from mocap_mj.io.atomic import atomic_write_text
from mocap_mj.io.yaml_file import read_yaml
from mocap_mj.skeleton.exported import internal_spec
from mocap_mj.skeleton.mjcf import load_model, model_path

__all__ = [
    "DEFAULT_MARKER_RADIUS",
    "MARKER_CLASSES",
    "MarkerSet",
    "SetMarker",
    "load_marker_set",
    "marked_bodies",
    "marker_class",
    "measured_dofs",
    "model_with_marker_set",
    "plug_in_gait",
    "save_marker_set",
    "undetermined_segments",
    "unmeasured_bodies",
]

#: The prior classes, from most to least constrained.
MARKER_CLASSES = ("landmark", "cluster", "free")
MarkerClass = Literal["landmark", "cluster", "free"]

#: File name of the bundled Plug-in Gait marker set (in ``models/``).
PLUG_IN_GAIT = "marker_sets/plug_in_gait.yaml"

#: Marker radius [m] of a set that declares none: Plug-in Gait's 14 mm markers.
DEFAULT_MARKER_RADIUS = 0.007


@dataclass(frozen=True)
class SetMarker:
    """One marker of a set: ``name``, the ``body`` carrying it, ``offset`` (3,) [m] in that
    body's frame, its prior class ``kind`` (one of :data:`MARKER_CLASSES`) and the
    anatomical ``landmark`` it sits on (:data:`mocap_mj.capture.landmarks.LANDMARKS`; None: not
    said)."""

    name: str
    body: str
    offset: tuple[float, float, float]
    kind: MarkerClass
    landmark: str | None = None


@dataclass(frozen=True)
class MarkerSet:
    """An ordered marker set (the order of the model sites built from it)."""

    name: str
    markers: tuple[SetMarker, ...]
    #: Radius of the set's markers [m].
    marker_radius: float = DEFAULT_MARKER_RADIUS
    #: Where the set comes from (one line; empty: not said).
    source: str = ""

    @property
    def names(self) -> tuple[str, ...]:
        """Marker names, in set order."""
        return tuple(m.name for m in self.markers)

    def marker(self, name: str) -> SetMarker:
        """The marker ``name``; an unknown name lists the set's markers."""
        for m in self.markers:
            if m.name == name:
                return m
        raise UnknownNameError("marker", name, self.names)

    def marker_class(self, name: str) -> MarkerClass:
        """Prior class of marker ``name``: "landmark", "cluster" or "free"."""
        return self.marker(name).kind

    def subset(self, names: Sequence[str]) -> MarkerSet:
        """The markers ``names`` (each must be in the set), in set order."""
        for name in names:
            self.marker(name)
        wanted = set(names)
        kept = tuple(m for m in self.markers if m.name in wanted)
        return MarkerSet(self.name, kept, self.marker_radius, self.source)

    @property
    def bodies(self) -> tuple[str, ...]:
        """The bodies carrying the set's markers, in order of their first marker."""
        return tuple(dict.fromkeys(m.body for m in self.markers))


def load_marker_set(path: str | os.PathLike[str], *, packaged: bool = False) -> MarkerSet:
    """Read a marker-set YAML file (see the module docstring for the format); ``packaged``:
    a bundled set's file (:func:`~mocap_mj.io.yaml_file.read_yaml`).

    Raises
    ------
    InputFileError
        Unreadable or unparsable file, or an entry that is not a marker (the message names
        the file, the entry's position and name, and what was expected).
    """
    file = Path(path)
    data = read_yaml(file, "marker set", packaged=packaged)
    if not isinstance(data, dict) or not isinstance(data.get("markers"), list):
        raise InputFileError(
            f"{file}: expected a mapping with a 'markers' list, got {excerpt(data)}"
        )
    markers = tuple(_marker(file, k, entry) for k, entry in enumerate(data["markers"]))
    names = [m.name for m in markers]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise InputFileError(f"{file}: expected unique marker names, got {', '.join(dupes)} twice")
    if not markers:
        raise InputFileError(f"{file}: expected at least one marker, got none")
    radius = data.get("marker_radius", DEFAULT_MARKER_RADIUS)
    if not (
        isinstance(radius, int | float)
        and not isinstance(radius, bool)
        and 0.001 <= float(radius) <= 0.02
    ):
        raise InputFileError(
            f"{file}: marker_radius: expected metres within 0.001..0.02, got {radius!r}"
        )
    source = " ".join(str(data.get("source") or "").split())
    return MarkerSet(str(data.get("name") or file.stem), markers, float(radius), source)


def _marker(file: Path, k: int, entry: Any) -> SetMarker:
    where = f"{file}: marker {k + 1}"
    if not isinstance(entry, Mapping):
        raise InputFileError(f"{where}: expected {{name, body, offset, class}}, got {entry!r:.60}")
    name, body = entry.get("name"), entry.get("body")
    if not (isinstance(name, str) and name.strip()):
        raise InputFileError(f"{where}: expected a non-empty name, got {name!r}")
    where = f"{where} ({name})"
    if not (isinstance(body, str) and body.strip()):
        raise InputFileError(f"{where}: expected a body name, got {body!r}")
    offset = entry.get("offset")
    if not (
        isinstance(offset, list)
        and len(offset) == 3
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in offset)
        and all(math.isfinite(float(v)) for v in offset)
    ):
        raise InputFileError(f"{where}: expected offset [x, y, z] in metres, got {offset!r}")
    kind = entry.get("class", "free")
    if kind not in MARKER_CLASSES:
        raise InputFileError(f"{where}: expected class {' / '.join(MARKER_CLASSES)}, got {kind!r}")
    landmark = entry.get("landmark")
    if landmark is not None and landmark not in LANDMARKS:
        raise InputFileError(
            f"{where}: expected a landmark of docs/model.md#landmarks ({', '.join(LANDMARKS)}), "
            f"got {landmark!r}"
        )
    x, y, z = (float(v) for v in offset)
    return SetMarker(name.strip(), body.strip(), (x, y, z), kind, landmark)


def save_marker_set(path: str | os.PathLike[str], marker_set: MarkerSet) -> None:
    """Write ``marker_set`` as YAML (one flow mapping per marker), atomically."""
    lines = [f"name: {yaml.safe_dump(marker_set.name).splitlines()[0]}"]
    if marker_set.source:
        lines.append(f"source: {yaml.safe_dump(marker_set.source).splitlines()[0]}")
    lines += [f"marker_radius: {marker_set.marker_radius!r}", "markers:"]
    for m in marker_set.markers:
        offset = ", ".join(repr(float(v)) for v in m.offset)
        landmark = "" if m.landmark is None else f", landmark: {m.landmark}"
        lines.append(
            f"  - {{name: {m.name}, body: {m.body}, offset: [{offset}], class: {m.kind}{landmark}}}"
        )
    atomic_write_text(Path(path), "\n".join(lines) + "\n")


def plug_in_gait() -> MarkerSet:
    """The bundled Plug-in Gait full-body set: the humanoid's 39 sites, with prior classes."""
    return load_marker_set(model_path(PLUG_IN_GAIT), packaged=True)


def marker_class(name: str, marker_set: MarkerSet | None = None) -> MarkerClass:
    """Prior class of marker ``name`` in ``marker_set`` (default: Plug-in Gait)."""
    return (marker_set if marker_set is not None else plug_in_gait()).marker_class(name)


def model_with_marker_set(
    marker_set: MarkerSet, base: str | os.PathLike[str] | None = None
) -> mujoco.MjSpec:
    """An MjSpec of ``base`` (the bundled humanoid by default) whose sites are the set's
    markers at their offsets; the base's own sites are removed. The compiled model orders its
    sites by body (depth first), in set order within a body.

    Write it with ``spec.to_xml()`` and pass that file to ``ParameterSet``.

    Raises
    ------
    UnknownNameError
        A marker's body is not a body of the model (the message lists the bodies).
    """
    path = model_path() if base is None else Path(base)
    load_model(path)  # a clear error for a missing or invalid file
    spec = internal_spec(path)  # a written model's knee slides removed, as load_model does
    bodies = [b.name for b in spec.bodies]
    for marker in marker_set.markers:
        if marker.body not in bodies:
            raise UnknownNameError("body", marker.body, bodies)
    for site in list(spec.sites):
        spec.delete(site)
    for marker in marker_set.markers:
        body = spec.body(marker.body)
        body.add_site(name=marker.name, pos=np.array(marker.offset, dtype=float))
    return spec


def marked_bodies(model: mujoco.MjModel, present: Collection[str] | None = None) -> np.ndarray:
    """(nbody,) bool: the bodies that carry one of the markers ``present`` (default: every
    marker site of ``model``) or have a descendant that does, i.e. whose pose those markers
    follow."""
    wanted = None if present is None else set(present)
    seen = np.zeros(model.nbody, dtype=bool)
    for i in range(model.nsite):
        if wanted is None or model.site(i).name in wanted:
            b = int(model.site_bodyid[i])
            while b > 0 and not seen[b]:
                seen[b] = True
                b = int(model.body_parentid[b])
    return seen


def undetermined_segments(model: mujoco.MjModel, present: Collection[str]) -> tuple[str, ...]:
    """Bodies of ``model`` whose motion the markers ``present`` cannot determine.

    A moving body (one with a joint) is determined only if a present marker sits on it or on
    a body below it in the tree; otherwise its joint angles, and the segment lengths leading
    to it, are left to the prior. Identification then still runs, and this list says which
    segments its result does not measure (e.g. hand_l, hand_r without wrist and finger
    markers). A body no marker of the model's set could determine (the toes: Plug-in Gait
    puts TOE on the foot) is not listed: no trial measures it, and identifiability names its
    parameters. Returns body names in model order.
    """
    seen = marked_bodies(model, present)
    markable = marked_bodies(model)
    return tuple(
        model.body(b).name
        for b in range(1, model.nbody)
        if model.body_jntnum[b] > 0 and markable[b] and not seen[b]
    )


def unmeasured_bodies(model: mujoco.MjModel, present: Collection[str]) -> np.ndarray:
    """(nbody,) bool: the bodies whose pose and position the markers ``present`` leave to the
    prior: a body some marker site of ``model`` could determine (:func:`marked_bodies`) that
    no present marker does (:func:`undetermined_segments`), and a body no site could
    determine (the toes) whose parent is unmeasured. The toes of a foot with markers are
    measured as far as the model ever measures them (their dof and lengths stay with the
    weak prior, as on the full set), so that the full marker set has no unmeasured body."""
    seen = marked_bodies(model, present)
    markable = marked_bodies(model)
    out = np.zeros(model.nbody, dtype=bool)
    for b in range(1, model.nbody):  # parents come before their children
        out[b] = (markable[b] and not seen[b]) or (
            not markable[b] and bool(out[model.body_parentid[b]])
        )
    return out


def measured_dofs(model: mujoco.MjModel, present: np.ndarray) -> np.ndarray:
    """(n,) int: per frame, the joint dofs the present markers determine, for present (n, M)
    bool over the model's marker sites in site order: the dofs of the bodies that carry a
    present marker or have a descendant that does (:func:`marked_bodies`). Any other dof
    moves no present marker (the arms' of a lower-body set, a hand's whose markers dropped
    out in that frame, the toes' that Plug-in Gait never marks): its Jacobian is zero, a
    solver holds it where it starts, and it is not an unknown of that frame (nor counted in
    the noise estimate's degrees of freedom). Frames are grouped by their pattern of present
    markers (a handful in a real trial), so this is cheap."""
    present = np.atleast_2d(np.asarray(present, dtype=bool))
    if present.size == 0:
        return np.zeros(len(present), dtype=int)
    names = [model.site(i).name for i in range(model.nsite)]
    # One key per frame (its row of bits), so that the patterns are found by a 1-D unique.
    packed = np.ascontiguousarray(np.packbits(present, axis=1))
    keys = packed.view(np.dtype((np.void, packed.shape[1]))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    counts = np.empty(len(first), dtype=int)
    for k, row in enumerate(present[first]):
        seen = marked_bodies(model, [n for n, p in zip(names, row, strict=True) if p])
        counts[k] = int(seen[model.dof_bodyid].sum())
    return counts[np.ravel(inverse)]
