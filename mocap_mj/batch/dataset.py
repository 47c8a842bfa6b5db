"""A dataset of subjects for ``mocap-mj batch``: a folder tree or a manifest (CSV or YAML).

Folder tree: ``DATASET/<subject>/<trial files>``; every ``.c3d``, ``.trc`` and ``.csv`` file in
a subject's folder is a trial, and an optional ``subject.yaml`` (or ``.yml``) beside them is the
subject file (measurements; passed to ``identify --subject-file`` when that option exists, and
its ``height`` [m] is used by the report). Folders starting with ``.`` or ``_`` are ignored.

Manifest CSV: a header with ``subject`` and ``trial`` columns, one row per trial, optional
``subject_file`` and option columns (:data:`OPTION_KEYS`); a subject's options must agree on
all its rows. Manifest YAML::

    options: {recipe: recipe.yaml}   # defaults of every subject (optional)
    subjects:
      - name: S01
        trials: [S01/walk.c3d, S01/rom.c3d]
        subject_file: S01/subject.yaml   # optional
        options: {recipe: robust.yaml}   # optional, overrides the defaults

Relative paths are relative to the manifest's folder. The options are those of ``identify``
that make sense per subject (``recipe``: a recipe file, ``identify --recipe``, which holds
the identification's choices: initial model, loss, iterations, priors; ``loss`` and
``no_sliding_landmarks: true`` replace its fields, as identify's flags do); ``up``, ``units``,
``marker_map``, ``file_subject`` and ``exclude_markers``
(``RELB,RUPA``: markers whose data are dropped) also apply to the IK.
"""

from __future__ import annotations

import csv
import hashlib
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputFileError, MocapError

if TYPE_CHECKING:
    from ..capture.subject import Subject

#: Per-subject options a manifest (or the ``batch`` command line) may set, with their type;
#: each is the identify flag of its name (``no_sliding_landmarks``: true gives the flag).
OPTION_KEYS: dict[str, type] = {
    "frames": str,
    "up": str,
    "units": str,
    "marker_map": str,
    "file_subject": str,
    "model": str,
    "exclude_markers": str,
    "recipe": str,
    "loss": str,
    "no_sliding_landmarks": bool,
}
#: Command-line flag of each option (``file_subject``: which subject of a multi-subject file,
#: ``--subject`` of identify and ik; named apart from the dataset's subject).
FLAGS = {k: "--" + k.replace("_", "-") for k in OPTION_KEYS} | {"file_subject": "--subject"}
#: The values an option may take, where they are a few (identify's choices).
CHOICES: dict[str, tuple[str, ...]] = {
    "up": ("x", "y", "z", "-x", "-y", "-z"),
    "units": ("mm", "cm", "m"),
    "loss": ("l2", "huber", "cauchy"),
}
#: Options naming a file: resolved against the manifest's folder; their content is hashed.
PATH_OPTIONS = ("marker_map", "model", "recipe")
#: Options that are now a recipe's fields (option -> recipe field): refused, naming it.
RECIPE_OPTIONS = {"init": "init", "max_iterations": "max_iterations"}
#: Trial file suffixes of a folder-tree dataset.
TRIAL_SUFFIXES = (".c3d", ".trc", ".csv")
SUBJECT_FILES = ("subject.yaml", "subject.yml")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
#: The files a batch writes into its ``--out`` beside the subjects' folders: no subject may
#: bear one of these names (compared without case, as some file systems do).
BATCH_FILES = ("summary.csv", "summary.json", "report.md", "segments.png", "rmse_per_trial.png")


@dataclass(frozen=True)
class Entry:
    """One subject's entry in a dataset: its name (a folder name), trial files, subject file
    (whose measurements are a :class:`mocap_mj.capture.subject.Subject`, :meth:`measurements`)
    and options."""

    name: str
    trials: tuple[str, ...]
    subject_file: str | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def measurements(self) -> Subject | None:
        """The subject file's measurements (YAML or a Vicon subject file), None without one
        or when it cannot be read (identify then refuses it, naming it)."""
        if self.subject_file is None:
            return None
        from mocap_mj.capture.vicon_subject import from_file  # PyYAML, loaded when read

        try:
            return from_file(self.subject_file)
        except (MocapError, OSError):
            return None

    @property
    def height(self) -> float | None:
        """Standing height [m] from the subject file's ``height``, if given."""
        found = self.measurements()
        return None if found is None else found.get("height")


def load_dataset(path: str | Path, defaults: Mapping[str, Any] | None = None) -> list[Entry]:
    """The subjects of a folder tree or a manifest (``.csv``, ``.yaml``, ``.yml``), by name.

    ``defaults`` are options of every subject (the command line's); a manifest's options
    override them. Raises :class:`InputFileError` naming the file and row on bad input.
    """
    root = Path(path)
    base = _checked_options("command line", defaults or {}, Path.cwd())
    if root.is_dir():
        subjects = _from_tree(root, base)
    elif not root.exists():
        raise InputFileError(f"{root}: no such folder or manifest")
    elif root.suffix.lower() == ".csv":
        subjects = _from_csv(root, base)
    elif root.suffix.lower() in (".yaml", ".yml"):
        subjects = _from_yaml(root, base)
    else:
        raise InputFileError(f"{root}: expected a folder, a .csv or a .yaml manifest")
    if not subjects:
        raise InputFileError(f"{root}: no subject found")
    check_files(subjects)
    return sorted(subjects, key=lambda s: s.name)


def check_files(subjects: list[Entry]) -> None:
    """Read every recipe, marker map and YAML subject file the subjects name, each once,
    before any work: a bad file is refused up front with its one line (naming it), not in
    every subject it would fail."""
    from mocap_mj.capture.subject import from_yaml
    from mocap_mj.io.names import load_marker_map
    from mocap_mj.pipeline.recipe import Recipe

    readers: dict[str, Any] = {"recipe": Recipe.load, "marker_map": load_marker_map}
    seen: set[tuple[str, str]] = set()
    for subject in subjects:
        files = [(key, subject.options.get(key)) for key in readers]
        if subject.subject_file and Path(subject.subject_file).suffix.lower() in (".yaml", ".yml"):
            files.append(("subject_file", subject.subject_file))
        for key, path in files:
            if path and (key, str(path)) not in seen:
                seen.add((key, str(path)))
                (from_yaml if key == "subject_file" else readers[key])(path)


def _from_tree(root: Path, base: dict[str, Any]) -> list[Entry]:
    subjects = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        if folder.name.startswith((".", "_")):
            continue
        trials = sorted(
            str(p.resolve())
            for p in folder.iterdir()
            if p.is_file() and p.suffix.lower() in TRIAL_SUFFIXES
        )
        if not trials:
            continue
        sfile = next((folder / n for n in SUBJECT_FILES if (folder / n).is_file()), None)
        name = _name(folder.name, str(folder))
        subjects.append(Entry(name, tuple(trials), _str(sfile), base))
    return subjects


def _from_csv(path: Path, base: dict[str, Any]) -> list[Entry]:
    try:
        with open(path, newline="") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputFileError(f"{path}: cannot read the manifest ({exc})") from None
    if not rows or not {"subject", "trial"} <= set(rows[0]):
        raise InputFileError(f"{path}: expected a header with 'subject' and 'trial' columns")
    trials: dict[str, list[str]] = {}
    sfiles: dict[str, str | None] = {}
    options: dict[str, dict[str, Any]] = {}
    for i, row in enumerate(rows, start=2):
        where = f"{path}: row {i}"
        name = _name((row.get("subject") or "").strip(), where)
        trial = (row.get("trial") or "").strip()
        if not trial:
            raise InputFileError(f"{where}: empty 'trial'")
        raw = {
            k: v.strip()
            for k, v in row.items()
            if (k in OPTION_KEYS or k in RECIPE_OPTIONS) and v and v.strip()
        }
        unknown = set(row) - {"subject", "trial", "subject_file", *OPTION_KEYS, *RECIPE_OPTIONS}
        if unknown:
            raise InputFileError(
                f"{where}: unknown column(s) {', '.join(sorted(unknown))}; "
                f"expected subject, trial, subject_file, {', '.join(OPTION_KEYS)}"
            )
        opts = {**base, **_checked_options(where, raw, path.parent)}
        sfile = _resolve(path.parent, (row.get("subject_file") or "").strip() or None)
        if name in trials and (options[name] != opts or sfiles[name] != sfile):
            raise InputFileError(f"{where}: options of subject {name!r} differ from its first row")
        trials.setdefault(name, []).append(str(_resolve(path.parent, trial)))
        options[name] = opts
        sfiles[name] = sfile
    return [Entry(n, tuple(t), sfiles[n], options[n]) for n, t in trials.items()]


def _from_yaml(path: Path, base: dict[str, Any]) -> list[Entry]:
    from ..io.yaml_file import read_yaml  # PyYAML, loaded when a file is read

    data = read_yaml(path, "manifest")
    if not isinstance(data, dict) or not isinstance(data.get("subjects"), list):
        raise InputFileError(f"{path}: expected a mapping with a 'subjects' list")
    given = data.get("options") or {}
    common = {**base, **_checked_options(f"{path}: options", given, path.parent)}
    subjects = []
    for i, entry in enumerate(data["subjects"]):
        where = f"{path}: subjects[{i}]"
        if not isinstance(entry, dict) or not isinstance(entry.get("trials"), list):
            raise InputFileError(f"{where}: expected a mapping with 'name' and a 'trials' list")
        name = _name(str(entry.get("name", "")), where)
        trials = tuple(str(_resolve(path.parent, str(t))) for t in entry["trials"])
        opts = {**common, **_checked_options(where, entry.get("options") or {}, path.parent)}
        sfile = _resolve(path.parent, entry.get("subject_file"))
        subjects.append(Entry(name, trials, sfile, opts))
    names = [s.name for s in subjects]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputFileError(f"{path}: subject(s) listed twice: {', '.join(dup)}")
    return subjects


def _name(name: str, where: str) -> str:
    if not _NAME.match(name):
        raise InputFileError(
            f"{where}: subject name {name!r} must be a folder name (letters, digits, '_.-')"
        )
    if name.lower() in BATCH_FILES:
        raise InputFileError(
            f"{where}: subject name {name!r} is the name of a file the batch writes into --out "
            f"({', '.join(BATCH_FILES)}); rename the subject"
        )
    return name


def _str(path: Path | None) -> str | None:
    return None if path is None else str(path.resolve())


def _resolve(base: Path, path: str | None) -> str | None:
    if path is None:
        return None
    p = Path(path).expanduser()
    return str((p if p.is_absolute() else base / p).resolve())


def _checked_options(where: str, options: Mapping[str, Any], base: Path) -> dict[str, Any]:
    if not isinstance(options, Mapping):
        raise InputFileError(f"{where}: options must be a mapping")
    out: dict[str, Any] = {}
    for key, value in options.items():
        if key in RECIPE_OPTIONS:
            raise InputFileError(
                f"{where}: option {key!r} removed; put {RECIPE_OPTIONS[key]} in a recipe file "
                "and name it with the option 'recipe'"
            )
        if key not in OPTION_KEYS:
            raise InputFileError(
                f"{where}: unknown option {key!r}; expected one of {', '.join(OPTION_KEYS)}"
            )
        if value is None:
            continue
        try:
            out[key] = _typed(key, value)
        except (TypeError, ValueError):
            kind = OPTION_KEYS[key].__name__
            raise InputFileError(f"{where}: option {key!r} expects {kind}, got {value!r}") from None
        if key in PATH_OPTIONS:
            out[key] = _resolve(base, out[key])
        _check_value(where, key, out[key])
    return out


def _typed(key: str, value: Any) -> Any:
    """``value`` as option ``key``'s type; a boolean from true/false (YAML's or a CSV cell's)."""
    kind = OPTION_KEYS[key]
    if kind is bool:
        text = str(value).strip().lower()
        if text not in ("true", "false"):
            raise ValueError(value)
        return text == "true"
    return kind(value)


def _check_value(where: str, key: str, value: Any) -> None:
    """Refuse a ``frames`` text that is not ``A:B``, or a value outside an option's
    :data:`CHOICES`, before any subject runs (a range's bounds are checked against each
    trial)."""
    if key in CHOICES and value not in CHOICES[key]:
        raise InputFileError(
            f"{where}: option {key!r}: expected one of {', '.join(CHOICES[key])}, got {value!r}"
        )
    if key == "frames":
        from mocap_mj.outputs.write_fit import frame_range

        try:
            frame_range(value, 1 << 62)
        except MocapError as exc:
            raise InputFileError(f"{where}: {exc}") from None


# ----------------------------------------------------------------------------- hashing
def _file_digest(path: str) -> str:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                h.update(block)
    except OSError as exc:
        return f"unreadable: {type(exc).__name__}"
    return h.hexdigest()


def content_hash(subject: Entry, settings: Mapping[str, Any] | None = None) -> str:
    """SHA-256 of everything a subject's result depends on: the bytes of its trial files,
    subject file and option files, its options, ``settings`` (the batch's own, e.g. the
    package version) and the trials' names. Paths themselves are not hashed (by name only),
    so a dataset moved to another folder still resumes."""
    options = {
        k: (_file_digest(v) if k in PATH_OPTIONS else v) for k, v in sorted(subject.options.items())
    }
    doc = {
        "name": subject.name,
        "trials": [[Path(t).name, _file_digest(t)] for t in subject.trials],
        "subject_file": subject.subject_file and _file_digest(subject.subject_file),
        "options": options,
        "settings": dict(settings or {}),
    }
    text = json.dumps(doc, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()
