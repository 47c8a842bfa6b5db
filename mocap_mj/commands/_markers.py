"""Shared CLI options for marker input, and loading markers into the model's order."""

from __future__ import annotations

import argparse
from typing import NamedTuple

import numpy as np

from ..errors import MocapError
from ..io import MarkerReport, load_markers


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


class Trial(NamedTuple):
    """Markers of one file in model site order.

    Fields: path; times (T,) [s]; markers (T, M, 3) [m], NaN where missing; rate [Hz];
    report (which model markers were found, missing, extra).
    """

    path: str
    times: np.ndarray
    markers: np.ndarray
    rate: float
    report: MarkerReport


def load_trial(path: str, names: tuple[str, ...], args: argparse.Namespace) -> Trial:
    traj = load_markers(
        path, subject=args.subject, marker_map=args.marker_map, up=getattr(args, "up", None)
    )
    report = traj.marker_report(names)
    if not report.found:
        raise MocapError(f"{path}: none of the model's markers found (names: {traj.names[:8]}...)")
    return Trial(path, np.asarray(traj.times), traj.select(names), float(traj.rate), report)
