"""Where each trial of a result folder lives, and choosing one (``--trial NAME|INDEX``).

A result of one trial holds that trial's files (motion.npz, joint_centres.csv, angles.csv,
marker_error.png, events.csv and the kinetics tables) at the top of the folder. A result of
several trials keeps the first trial's files there too, so that a reader of one-trial results
reads its first trial unchanged, and puts each further trial's in ``trials/<name>/`` under
the same file names. A trial's name is its file's stem (``WALK`` for ``WALK.c3d``); where
two files share a stem, their folder's name and the stem (``walk_markers`` for
``walk/markers.csv``), else the stem and the trial's index (``markers_1``): a name is what a
user types. summary.json's ``trials`` lists each trial's index, name, file, folder and
frames. Results written before trials had folders hold ``motion_<i>.npz``; an index still
finds it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from mocap_mj.errors import InputFileError, MocapError
from mocap_mj.pipeline.motion import ResultDir, read_summary

#: The folder of every trial but the first, inside a result folder.
TRIALS_DIR = "trials"


def trial_names(files: Sequence[str | Path]) -> list[str]:
    """Each trial's name: its file's stem; where two files share one, ``<folder>_<stem>``,
    else ``<stem>_<i>`` (i: the trial's index)."""
    paths = [Path(str(f)) for f in files]
    names = [p.stem or f"trial_{i}" for i, p in enumerate(paths)]
    for rule in (lambda i, n: f"{paths[i].resolve().parent.name}_{n}", lambda i, n: f"{n}_{i}"):
        names = [n if names.count(n) == 1 else rule(i, n) for i, n in enumerate(names)]
    return names


def trial_folders(files: Sequence[str | Path]) -> list[str]:
    """Each trial's folder relative to the result folder: "" (the top) for the first,
    ``trials/<name>`` for the others."""
    names = trial_names(files)
    return ["" if i == 0 else f"{TRIALS_DIR}/{n}" for i, n in enumerate(names)]


def trial_entries(
    files: Sequence[str | Path], frames: Sequence[int], first_frames: Sequence[int]
) -> list[dict[str, Any]]:
    """summary.json's ``trials``: per trial its index, name, file, folder ("." for the top)
    and number of frames, and its first frame's number in the recording."""
    return [
        {
            "index": i,
            "name": name,
            "file": str(f),
            "folder": folder or ".",
            "frames": int(n),
            "first_frame": int(first),
        }
        for i, (name, folder, f, n, first) in enumerate(
            zip(trial_names(files), trial_folders(files), files, frames, first_frames, strict=True)
        )
    ]


def _entries(root: Path) -> list[Mapping[str, Any]]:
    """summary.json's ``trials`` of the result ``root`` ([] when absent), each checked."""
    path = root / "summary.json"
    if not path.is_file():
        return []
    entries = read_summary(path).get("trials", [])
    ok = isinstance(entries, list) and all(
        isinstance(e, dict) and isinstance(e.get("name"), str) and isinstance(e.get("folder"), str)
        for e in entries
    )
    if not ok:
        raise InputFileError(
            f"{path}: trials: expected a list of {{name, folder, ...}} entries, one per trial"
        )
    return entries


def open_trial(root: str | Path, trial: str | None = None) -> ResultDir:
    """The result folder ``root`` (:meth:`ResultDir.open`) with the motion of ``trial``: its
    index (0 = the first, negative from the end) or its name (summary.json's ``trials``; the
    file's name or path works too). None: the first trial. An unknown trial is refused,
    naming the result's trials."""
    rd = ResultDir.open(root)
    if trial is None:
        return rd
    entries = _entries(rd.root)
    if not entries:  # a one-trial result, or one written before trials had folders
        legacy = sorted(rd.root.glob("motion_*.npz"), key=lambda p: p.stem)
        folders = [rd.motion, *legacy]
        names = [str(i) for i in range(len(folders))]
        pick = _pick(trial, names, {}, rd.root)
        return ResultDir(rd.root, rd.model, folders[pick])
    names = [str(e["name"]) for e in entries]
    aliases = {}
    for i, e in enumerate(entries):
        file = Path(str(e.get("file", "")))
        aliases.update({file.name: i, str(file): i})
    pick = _pick(trial, names, aliases, rd.root)
    folder = str(entries[pick]["folder"])
    motion = rd.root / folder / rd.motion.name
    if Path(folder).is_absolute() or ".." in Path(folder).parts or not motion.is_file():
        raise InputFileError(f"{rd.root}: trial {names[pick]!r}: no motion at {motion}")
    return ResultDir(rd.root, rd.model, motion)


def _pick(text: str, names: Sequence[str], aliases: Mapping[str, int], root: Path) -> int:
    """The index of trial ``text`` (an index or a name) among ``names``."""
    text = text.strip()
    if text in names:
        return names.index(text)
    if text in aliases:
        return aliases[text]
    try:
        k = int(text)
    except ValueError:
        k = None
    if k is not None and -len(names) <= k < len(names):
        return k % len(names)
    listed = ", ".join(f"{i} {n}" if n != str(i) else n for i, n in enumerate(names))
    raise MocapError(
        f"--trial {text}: {root} has no such trial; expected an index or a name of its "
        f"{len(names)} trial{'s' if len(names) != 1 else ''} ({listed})"
    )
