"""The bundled marker sets: picked by name, or detected from a recording's labels.

Every YAML file in ``models/marker_sets/`` (package data ``mocap_mj.models``) is a bundled
set (:mod:`mocap_mj.capture.marker_set` describes the format), named by its file name without
``.yaml``: ``plug_in_gait`` (the default, the bundled humanoid's own sites),
``plug_in_gait_lower_body``, ``plug_in_gait_medial``, ``cmu_41``, ``opensim_full_body``...
:func:`resolve` turns ``--marker-set NAME|FILE`` into a file: a path to an existing file is
the user's set, a bare name a bundled one.

Detection (:func:`detect`) matches a recording's labels (subject prefix removed, non-marker
points dropped, the marker map applied, then each set's built-in aliases:
:func:`mocap_mj.io.labels.names_in_set`) against every bundled set:

* a set **fits** when at least :data:`FIT_FRACTION` (75 %) of its markers are among the
  labels: most of the set was placed, and a few lost markers do not hide it;
* of the sets that fit, the one that explains **the most labels** is chosen: a set that is
  another's superset and whose extra markers are present (Plug-in Gait with medial markers
  over Plug-in Gait when LKNEM... are there; the CMU set, with its fifth metatarsal markers,
  over Plug-in Gait) wins; between sets that explain as many labels, the one that **misses
  fewer** of its own markers (Plug-in Gait over Plug-in Gait with medial markers when the
  medial markers are absent);
* sets still tied on both counts are ambiguous: none is chosen, and the default,
  :data:`DEFAULT` (Plug-in Gait), is used as when no set fits.

With no set chosen the commands keep Plug-in Gait and say so when fewer than
:data:`FIT_FRACTION` of its markers are present.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

from mocap_mj.capture.marker_set import MarkerSet, load_marker_set, plug_in_gait
from mocap_mj.errors import MocapError
from mocap_mj.io.labels import names_in_set
from mocap_mj.skeleton.mjcf import model_path

__all__ = [
    "DEFAULT",
    "FIT_FRACTION",
    "Detection",
    "SetMatch",
    "bundled",
    "bundled_names",
    "detect",
    "match",
    "on_bundled_model",
    "resolve",
]

#: The set used when ``--marker-set`` is not given and none is detected.
DEFAULT = "plug_in_gait"

#: A set fits a recording when at least this fraction of its markers are among its labels.
FIT_FRACTION = 0.75

#: The folder of the bundled sets inside ``models/``.
FOLDER = "marker_sets"


def _folder() -> Path:
    return model_path(f"{FOLDER}/{DEFAULT}.yaml").parent


def bundled_names() -> tuple[str, ...]:
    """The bundled sets' names (file names without ``.yaml``), sorted."""
    return tuple(sorted(p.stem for p in _folder().glob("*.yaml")))


def bundled(name: str) -> MarkerSet:
    """The bundled set ``name``; an unknown name lists the bundled ones."""
    path = resolve(name)
    return load_marker_set(path, packaged=path.parent == _folder())


def resolve(name_or_file: str | os.PathLike[str]) -> Path:
    """The file of ``--marker-set NAME|FILE``: an existing file (or any value naming a
    folder or ending in ``.yaml``/``.yml``: the user's file, read as given) or the bundled
    set of that name.

    Raises
    ------
    MocapError
        A bare name that is no bundled set (the message lists the bundled names).
    """
    text = os.fspath(name_or_file)
    path = Path(text)
    if path.is_file() or os.sep in text or "/" in text or path.suffix in (".yaml", ".yml"):
        return path
    names = bundled_names()
    if text in names:
        return _folder() / f"{text}.yaml"
    raise MocapError(
        f"--marker-set: unknown marker set {text!r}: expected a bundled set "
        f"({', '.join(names)}) or a YAML file"
    )


def on_bundled_model(marker_set: MarkerSet) -> bool:
    """True when every marker of ``marker_set`` is a marker site of the bundled humanoid
    (same name, body and offset: Plug-in Gait and its lower body): the commands then run the
    bundled model itself, the set's absent sites being missing markers, so that choosing
    such a set by name or by detection gives the same result as the default."""
    own = {m.name: m for m in plug_in_gait().markers}
    return all(
        (o := own.get(m.name)) is not None and (o.body, o.offset) == (m.body, m.offset)
        for m in marker_set.markers
    )


@dataclass(frozen=True)
class SetMatch:
    """How a recording's labels match one set: ``name`` (the set's), ``mapped`` (label,
    set marker) for each label that names a marker of the set, ``missing`` (the set's
    markers no label names), ``ignored`` (labels that name none), ``size`` (markers in the
    set)."""

    name: str
    mapped: tuple[tuple[str, str], ...]
    missing: tuple[str, ...]
    ignored: tuple[str, ...]
    size: int

    @property
    def found(self) -> int:
        """How many of the set's markers the labels name."""
        return len(self.mapped)

    @property
    def fits(self) -> bool:
        """At least :data:`FIT_FRACTION` of the set's markers are present."""
        return self.found >= FIT_FRACTION * self.size


def match(
    labels: Sequence[str], marker_set: MarkerSet, name: str, renamed: Collection[str] = ()
) -> SetMatch:
    """``labels`` (a file's, :func:`mocap_mj.io.labels.file_labels`) against ``marker_set``,
    called ``name``, with the loader's aliases for that set (``renamed``: the marker map's
    targets, never aliased)."""
    names = names_in_set(list(labels), marker_set.names, renamed)
    wanted = set(marker_set.names)
    mapped = tuple((lab, n) for lab, n in zip(labels, names, strict=True) if n in wanted)
    have = {n for _, n in mapped}
    return SetMatch(
        name,
        mapped,
        tuple(n for n in marker_set.names if n not in have),
        tuple(lab for lab, n in zip(labels, names, strict=True) if n not in wanted),
        len(marker_set.names),
    )


@dataclass(frozen=True)
class Detection:
    """The outcome of :func:`detect`: ``chosen`` (a bundled name, None when no single set
    fits), ``matches`` (every bundled set's :class:`SetMatch`, best first) and ``reason``
    (one line: why that set, or why none)."""

    chosen: str | None
    matches: tuple[SetMatch, ...]
    reason: str

    def of(self, name: str) -> SetMatch:
        """The match of the set ``name``."""
        return next(m for m in self.matches if m.name == name)


def detect(labels: Sequence[str], renamed: Collection[str] = ()) -> Detection:
    """The bundled set that fits ``labels`` (module docstring: the rule)."""
    matches = [match(labels, bundled(n), n, renamed) for n in bundled_names()]
    matches.sort(key=lambda m: (-m.found, len(m.missing), m.name))
    fitting = [m for m in matches if m.fits]
    if not fitting:
        return Detection(None, tuple(matches), "no bundled set fits the labels")
    top = fitting[0]
    tied = [m.name for m in fitting if (m.found, len(m.missing)) == (top.found, len(top.missing))]
    if len(tied) > 1:
        return Detection(None, tuple(matches), f"the labels fit {' and '.join(tied)} equally")
    return Detection(top.name, tuple(matches), "detected from the labels")


@dataclass(frozen=True)
class Check:
    """What ``marker-sets --check`` reports on a recording: the set (``name``, ``how`` it
    was chosen: given, detected or default, and the set itself) and how the recording's
    labels match it (:class:`SetMatch`)."""

    name: str
    how: str
    reason: str
    marker_set: MarkerSet
    match: SetMatch


def check(
    labels: Sequence[str], name_or_file: str | None = None, renamed: Collection[str] = ()
) -> Check:
    """``labels`` against the set ``name_or_file`` (a bundled name or a YAML file), or,
    without one, against the set :func:`detect` chooses (else :data:`DEFAULT`)."""
    if name_or_file is not None:
        path = resolve(name_or_file)
        marker_set = load_marker_set(path)
        name = name_or_file if name_or_file in bundled_names() else str(path)
        matched = match(labels, marker_set, name, renamed)
        return Check(name, "given", "--marker-set", marker_set, matched)
    found = detect(labels, renamed)
    name = found.chosen or DEFAULT
    how = "detected" if found.chosen else "default"
    return Check(name, how, found.reason, bundled(name), found.of(name))
