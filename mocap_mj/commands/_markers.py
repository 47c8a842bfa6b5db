"""Shared CLI options for marker input, and loading markers into the model's order."""

from __future__ import annotations

import argparse
import dataclasses
from typing import NamedTuple

import numpy as np

from ..errors import MocapError
from ..io import MarkerReport, load_markers
from ..marker_set import undetermined_segments
from ..model import load_model


def add_marker_options(parser: argparse.ArgumentParser, *, several: bool = False) -> None:
    parser.add_argument(
        "--markers",
        required=True,
        nargs="+" if several else None,
        help="marker file(s): C3D, TRC, mocap-mj CSV, Vicon Nexus or OptiTrack Motive CSV",
    )
    parser.add_argument("--subject", help="subject to keep when the file holds several")
    parser.add_argument("--marker-map", help="YAML/JSON file mapping lab names to model names")
    parser.add_argument(
        "--up", choices=["x", "y", "z", "-x", "-y", "-z"], help="vertical axis (default: detect)"
    )
    parser.add_argument(
        "--units",
        choices=["mm", "cm", "m"],
        help="length unit of the marker coordinates, overriding the file's (default: as stated "
        "in the file, else mm)",
    )


class Trial(NamedTuple):
    """Markers of one file in model site order.

    Fields: path; times (T,) [s]; markers (T, M, 3) [m], NaN where missing; rate [Hz];
    report (which model markers were found, missing, extra, and which model segments none
    of the found markers determines).
    """

    path: str
    times: np.ndarray
    markers: np.ndarray
    rate: float
    report: MarkerReport


def load_trial(path: str, names: tuple[str, ...], args: argparse.Namespace) -> Trial:
    traj = load_markers(
        path,
        subject=args.subject,
        marker_map=args.marker_map,
        up=getattr(args, "up", None),
        units=getattr(args, "units", None),
    )
    report = traj.marker_report(names)
    model = load_model(getattr(args, "model", None))
    report = dataclasses.replace(
        report, undetermined=undetermined_segments(model, [n for n in report.found if n in names])
    )
    if not report.found:
        raise MocapError(f"{path}: none of the model's markers found (names: {traj.names[:8]}...)")
    return Trial(path, np.asarray(traj.times), traj.select(names), float(traj.rate), report)
