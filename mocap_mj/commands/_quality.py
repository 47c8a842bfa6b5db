"""``--exclude-markers`` and ``--strict`` of identify and ik: the marker-data quality check
(:mod:`mocap_mj.marker_quality`) run on the loaded trials before any solve.

Findings are warnings by default (one line each on stderr, recorded in summary.json's
``marker_quality`` and in report.md), and the exit status stays 0: the check is evidence,
not proof (a child's forearm, an unusual marker set), and a fit of the remaining markers is
still useful. ``--strict`` refuses the data instead (exit 2, nothing written), for pipelines
that must not publish a model built on suspect markers.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import MocapError
from ..marker_quality import (
    Finding,
    check_trials_quality,
    drop_ghosts,
    exclude_markers,
    marker_segments,
    quality_entry,
    suspects,
)
from ..marker_quality import parse_marker_list as parse_marker_list
from ..parameters import ParameterSet


def add_quality_options(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("marker data quality (docs/recordings.md#marker-data-quality)")
    g.add_argument(
        "--exclude-markers",
        metavar="NAMES",
        help="comma-separated model marker names, e.g. RELB,RUPA: drop these markers' data "
        "(treated as missing in every frame; their offsets are then not identified) "
        "(default: none)",
    )
    g.add_argument(
        "--strict",
        action="store_true",
        help="refuse the data (exit 2, no output) when the marker-data quality check finds "
        "anything (default: warn on stderr and carry on)",
    )


def check_trials(
    args: argparse.Namespace,
    pset: ParameterSet,
    trials: Sequence[tuple[str, np.ndarray, float, int]],
    excluded: Sequence[str],
) -> tuple[list[Finding], dict[str, Any]]:
    """Check each (path, markers (T, M, 3) [m], rate [Hz], file's frame of row 0), the
    ``excluded`` markers already dropped; raise under ``--strict``, else print the findings
    on stderr; return them and the summary's ``marker_quality`` entry."""
    found = check_trials_quality(
        [t[0] for t in trials],
        pset.marker_names,
        [t[1] for t in trials],
        [t[2] for t in trials],
        marker_segments(pset.model),
        [t[3] for t in trials],
        between=args.command == "identify",  # one model for every trial: markers must agree
    )
    named = suspects(found)
    if found and args.strict:
        raise MocapError(
            f"{found[0].message} ({len(found)} finding(s) in all; markers named: "
            f"{', '.join(named)}; --strict refuses them: drop markers with --exclude-markers "
            "or run without --strict)"
        )
    for f in found:
        print(f"mocap-mj {args.command}: warning: {f.message}", file=sys.stderr)
    if named:
        top = [n for n, c in named.items() if c == max(named.values())]
        print(
            f"mocap-mj {args.command}: warning: markers named by the data-quality check "
            f"(times named): {', '.join(f'{n} ({c})' for n, c in named.items())}; the most "
            f"named first: --exclude-markers {','.join(top)} drops its data "
            "(docs/recordings.md#what-each-warning-means)",
            file=sys.stderr,
        )
    entry = quality_entry(found, excluded)
    return found, entry


def without_ghosts(
    markers: np.ndarray, pset: ParameterSet, found: Sequence[Finding], path: str, first: int
) -> np.ndarray:
    """markers (T, M, 3) [m] of ``path`` (row 0 = the file's frame ``first``) with the
    samples its ``ghost`` and ``jump`` findings name missing
    (:func:`~mocap_mj.marker_quality.drop_ghosts`). A long recording's markers are a memory
    map in the command's scratch folder (:func:`~mocap_mj.commands._markers.load_trial`),
    the command's own: the samples are dropped in it, not in a copy of the whole recording."""
    own = isinstance(markers, np.memmap) and markers.flags.writeable
    return drop_ghosts(markers, pset.marker_names, found, path, first_frame=first, in_place=own)[0]


def drop_excluded(markers: np.ndarray, pset: ParameterSet, excluded: Sequence[str]) -> np.ndarray:
    """markers (T, M, 3) [m] with the ``excluded`` markers' columns NaN (see
    :func:`~mocap_mj.marker_quality.exclude_markers`)."""
    return exclude_markers(markers, pset.marker_names, excluded)


def quality_text(entry: dict[str, Any]) -> str:
    """The stdout line of a command on its marker-data quality."""
    excluded = entry["excluded"]
    head = f"excluded markers: {', '.join(excluded)}; " if excluded else ""
    n = len(entry["findings"])
    if not n:
        return f"{head}marker data quality: no finding"
    return (
        f"{head}marker data quality: {n} finding(s) (warnings above), markers named: "
        f"{', '.join(entry['suspects'])}"
    )
