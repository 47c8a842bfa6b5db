"""Shared CLI options for marker input, and loading markers into the model's order."""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mocap_mj.capture.marker_set import (
    load_marker_set,
    model_with_marker_set,
    undetermined_segments,
)
from mocap_mj.skeleton.mjcf import load_model

from ..errors import MocapError
from ..io import MarkerReport, MarkerTrajectory, atomic_write_text, load_markers
from ..io.stream import CHUNK, open_markers


def add_marker_options(parser: argparse.ArgumentParser, *, several: bool = False) -> None:
    parser.add_argument(
        "--markers",
        required=True,
        nargs="+" if several else None,
        metavar="FILE",
        help=("marker files, one or more" if several else "marker file")
        + ": C3D, TRC, mocap-mj CSV, Vicon Nexus or OptiTrack Motive CSV",
    )
    parser.add_argument(
        "--subject",
        metavar="NAME",
        help="subject to keep when labels carry several subject prefixes (default: the only "
        "one; required when there are several)",
    )
    parser.add_argument(
        "--marker-map",
        metavar="FILE",
        help="YAML/JSON file mapping lab names to model names (default: none)",
    )
    parser.add_argument(
        "--up", choices=["x", "y", "z", "-x", "-y", "-z"], help="vertical axis (default: detect)"
    )
    parser.add_argument(
        "--marker-set",
        metavar="FILE",
        help="YAML marker set (markers, bodies, offsets, prior classes) replacing the model's "
        "own marker sites (default: Plug-in Gait, the bundled humanoid's sites)",
    )
    parser.add_argument(
        "--units",
        choices=["mm", "cm", "m"],
        help="length unit of the marker coordinates, overriding the file's (default: as stated "
        "in the file, else mm)",
    )


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
        report, undetermined=undetermined_segments(model, [n for n in report.found if n in names])
    )
    if not report.found:
        which = f"the model {model_file}" if model_file else "the bundled model"
        raise MocapError(
            f"{path}: none of the markers of {which} found ({len(names)} marker sites: "
            f"{list(names[:8])}...; the file's names: {list(file_names[:8])}...)"
        )
    return Trial(path, np.asarray(times), markers, float(rate), report, first)


def model_for(args: argparse.Namespace) -> str | None:
    """The MJCF file the command's model comes from: ``--model`` (None: the bundled humanoid),
    its sites replaced by the markers of ``--marker-set`` when given.

    The model built from a marker set is written once, under the temporary folder, in a file
    named by a hash of the set and base model, so that ``ParameterSet`` can read it and the
    result can name it.
    """
    base = getattr(args, "model", None)
    marker_set = getattr(args, "marker_set", None)
    if marker_set is None:
        return base
    xml = model_with_marker_set(load_marker_set(marker_set), base).to_xml()
    digest = hashlib.sha256(xml.encode()).hexdigest()[:16]
    # "mocap-mj-models", not "mocap_mj": a folder named like the package in the temporary
    # folder would shadow it for any Python started there.
    folder = Path(tempfile.gettempdir()) / "mocap-mj-models"
    path = folder / f"model_{Path(marker_set).stem}_{digest}.xml"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, xml)
    return str(path)
