"""Shared CLI options for marker input, and loading markers into the model's order."""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mocap_mj.capture.marker_set import load_marker_set, undetermined_segments
from mocap_mj.capture.marker_sets import DEFAULT, bundled_names, detect, resolve
from mocap_mj.pipeline.marker_model import model_file
from mocap_mj.skeleton.mjcf import load_model

from ..errors import MocapError
from ..io import MarkerReport, MarkerTrajectory, load_markers
from ..io.labels import file_labels
from ..io.names import load_marker_map
from ..io.stream import CHUNK, open_markers

#: Frames above which ``load_trial`` with a scratch folder reads a marker file in chunks
#: into a memory map (one chunk of the reader's).
STREAM_ABOVE = CHUNK


class Trial(NamedTuple):
    """Markers of one file in model site order.

    Fields: path; times (T,) [s]; markers (T, M, 3) [m], NaN where missing; rate [Hz];
    report (which model markers were found, missing, extra, and which model segments none
    of the found markers determines); first_frame, the recording's own number of row 0.
    """

    path: str
    times: np.ndarray
    markers: np.ndarray
    rate: float
    report: MarkerReport
    first_frame: int = 0


def load_trial(
    path: str, names: tuple[str, ...], args: argparse.Namespace, scratch: Path | None = None
) -> Trial:
    """The file's markers in the model's order ``names``. With a ``scratch`` folder, a marker
    file of more than ``STREAM_ABOVE`` frames that the chunked readers read is read chunk by chunk
    (:func:`mocap_mj.io.stream.open_markers`, the same positions bit for bit) into a
    memory-mapped ``.npy`` there: ``markers`` is then that memory map, and no more than a
    chunk of the file is held at once."""
    options = {
        "subject": args.subject,
        "marker_map": args.marker_map,
        "up": getattr(args, "up", None),
        "units": getattr(args, "units", None),
        "model_names": names,
    }
    if scratch is None:
        traj = load_markers(path, **options)
        markers, file_names = traj.select(names), traj.names
        report, times, rate = traj.marker_report(names), traj.times, traj.rate
        first = traj.first_frame
    else:
        stream = open_markers(path, **options)
        file_names, times, rate = stream.names, stream.times, stream.rate
        first = stream.first_frame
        report = stream.marker_report(names)
        if stream.how == "in chunks" and stream.n_frames > STREAM_ABOVE:
            digest = hashlib.sha256(str(Path(path).resolve()).encode()).hexdigest()[:16]
            markers = stream.select_to_npy(names, scratch / f"markers_{digest}.npy")
        else:
            whole = stream.positions(0, stream.n_frames)
            markers = MarkerTrajectory(times, whole, file_names, rate, stream.source).select(names)
    model_file = model_for(args)
    model = load_model(model_file)
    report = dataclasses.replace(
        report,
        undetermined=undetermined_segments(model, [n for n in report.found if n in names]),
    )
    set_name, set_markers = _set_vocabulary(args, names)
    report = dataclasses.replace(report, set_name=set_name, set_markers=set_markers)
    if not report.found:
        which = f"the model {model_file}" if model_file else "the bundled model"
        raise MocapError(
            f"{path}: none of the markers of {which} found ({len(names)} marker sites: "
            f"{list(names[:8])}...; the file's names: {list(file_names[:8])}...)"
        )
    return Trial(path, np.asarray(times), markers, float(rate), report, first)


def _set_vocabulary(
    args: argparse.Namespace, names: tuple[str, ...]
) -> tuple[str | None, tuple[str, ...]]:
    """The marker report's set (``set_name``, ``set_markers``) when the command's set is a
    part of the model's markers ``names`` (a lower-body set on the bundled humanoid): its
    messages then count the set's markers, not the model's. (None, ()) otherwise."""
    path = set_file(args)
    if path is None:
        return None, ()
    ours = load_marker_set(path).names
    if set(ours) >= set(names) or not set(ours) <= set(names):
        return None, ()
    record = getattr(args, "marker_set_record", None) or {}
    return str(record.get("name") or path.stem), tuple(ours)


def model_for(args: argparse.Namespace) -> str | None:
    """The MJCF file the command's model comes from: ``--model`` (None: the bundled humanoid),
    its sites replaced by the markers of ``--marker-set`` when given
    (:func:`mocap_mj.pipeline.marker_model.model_file`)."""
    return model_file(set_file(args), getattr(args, "model", None))


def set_file(args: argparse.Namespace) -> Path | None:
    """The marker-set file the command uses: the one :func:`choose_marker_set` chose, else
    ``--marker-set`` resolved (a bundled name or a file), else None (the model's own
    sites)."""
    if hasattr(args, "marker_set_file"):
        chosen: Path | None = args.marker_set_file
        return chosen
    given = getattr(args, "marker_set", None)
    return None if given is None else resolve(given)


def choose_marker_set(args: argparse.Namespace, paths: list[str]) -> dict[str, object]:
    """Settle the command's marker set before the model is built, and return its record
    for summary.json (``name``, ``file``, ``how``: given, detected, default or model, and
    for a detected or default set ``markers_found`` of ``markers``). ``--marker-set`` wins;
    with ``--model`` the model's own sites are the set; otherwise the bundled set the
    labels of ``paths`` fit (:func:`mocap_mj.capture.marker_sets.detect`), else Plug-in Gait.
    Sets ``args.marker_set_file`` (None: the bundled humanoid's sites)."""
    if getattr(args, "marker_set", None) is not None:
        path = resolve(args.marker_set)
        load_marker_set(path)  # a bad file is refused before any work
        args.marker_set_file = path
        name = path.stem if args.marker_set in bundled_names() else str(path)
        return {"name": name, "file": str(path), "how": "given"}
    if getattr(args, "model", None) is not None:
        args.marker_set_file = None
        return {"name": None, "file": None, "how": "model"}
    rename = load_marker_map(args.marker_map) if args.marker_map else {}
    labels: list[str] = []
    for file in paths:
        for label in file_labels(file, subject=args.subject, marker_map=rename):
            if label not in labels:
                labels.append(label)
    found = detect(labels, renamed=set(rename.values()))
    name = found.chosen or DEFAULT
    args.marker_set_file = resolve(name) if name != DEFAULT else None
    m = found.of(name)
    return {
        "name": name,
        "file": str(resolve(name)),
        "how": "detected" if found.chosen else "default",
        "markers_found": m.found,
        "markers": m.size,
        "reason": found.reason,
    }


def print_marker_set(args: argparse.Namespace) -> None:
    """Print the detected set's line (:func:`marker_set_line`) on stderr: once the command
    has passed its bad-input checks, so that a refusal stays one line."""
    line = marker_set_line(getattr(args, "marker_set_record", {"how": "given"}))
    if line:
        print(f"{line}", file=sys.stderr)


def marker_set_line(record: dict[str, object]) -> str | None:
    """The stderr line naming a detected (or defaulted) set; None for a given one."""
    if record["how"] not in ("detected", "default"):
        return None
    return (
        f"mocap-mj: marker set {record['name']!r} ({record['markers_found']} of "
        f"{record['markers']} markers found; {record['reason']}, --marker-set to choose)"
    )
