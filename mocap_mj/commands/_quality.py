"""``--exclude-markers`` and ``--strict`` of identify and ik: the marker-data quality check
(:mod:`mocap_mj.capture.marker_quality`) run on the loaded trials before any solve.

Findings are warnings by default (one line each on stderr, recorded in summary.json's
``marker_quality`` and in report.md), and the exit status stays 0: the check is evidence,
not proof (a child's forearm, an unusual marker set), and a fit of the remaining markers is
still useful. ``--strict`` refuses the data instead (exit 2, nothing written), for pipelines
that must not publish a model built on suspect markers.

Before the check, labels exchanged by mistake are corrected (:mod:`mocap_mj.pipeline.relabel`): in
the command's own copy of the markers (the files are never touched), one line each on stderr,
listed in summary.json's ``marker_quality.relabelled`` and in report.md. ``--no-relabel``
leaves the labels as they are and prints the same lines as warnings; ``--strict`` refuses a
recording whose labels need a correction.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from mocap_mj.capture.marker_quality import (
    Finding,
    check_trials_quality,
    drop_ghosts,
    exclude_markers,
    marker_segments,
    quality_entry,
    suspects,
)
from mocap_mj.capture.marker_quality import parse_marker_list as parse_marker_list
from mocap_mj.pipeline.relabel import (
    Relabel,
    apply_relabels,
    find_label_errors,
    reference_theta,
    track_swaps,
)
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet

from ..errors import MocapError


def check_trials(
    args: argparse.Namespace,
    pset: ParameterSet,
    trials: Sequence[tuple[str, np.ndarray, float, int]],
    excluded: Sequence[str],
) -> tuple[list[Finding], dict[str, Any]]:
    """Check each (path, markers (T, M, 3) [m], rate [Hz], file's frame of row 0), the
    ``excluded`` markers already dropped; raise under ``--strict``, else print the findings
    on stderr; return them and the summary's ``marker_quality`` entry."""
    relabelled = relabel(args, pset, trials)
    found = _findings(args, pset, trials)
    swaps = [
        r
        for path, markers, _, first in trials
        for r in act_on(
            args, pset, path, markers, first,
            track_swaps(path, pset.marker_names, markers, found, first_frame=first),
        )
    ]  # fmt: skip
    if any(r.applied for r in swaps):  # the corrected tracks checked again
        found = _findings(args, pset, trials)
    relabelled += swaps
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
    entry = {"relabelled": [r.to_json() for r in relabelled], **quality_entry(found, excluded)}
    return found, entry


def _findings(
    args: argparse.Namespace,
    pset: ParameterSet,
    trials: Sequence[tuple[str, np.ndarray, float, int]],
) -> list[Finding]:
    return check_trials_quality(
        [t[0] for t in trials],
        pset.marker_names,
        [t[1] for t in trials],
        [t[2] for t in trials],
        marker_segments(pset.model),
        [t[3] for t in trials],
        between=args.command == "identify",  # one model for every trial: markers must agree
    )


def relabel(
    args: argparse.Namespace,
    pset: ParameterSet,
    trials: Sequence[tuple[str, np.ndarray, float, int]],
) -> list[Relabel]:
    """The label errors of each (path, markers (T, M, 3) [m], rate [Hz], file's frame of
    row 0) that a model shows (:func:`~mocap_mj.pipeline.relabel.find_label_errors`): ``identify``
    judges them with the nominal model scaled to the subject, ``ik`` with its model."""
    kin = Kinematics(pset)
    if args.command == "identify":
        kin.set_theta(reference_theta(pset, [t[1] for t in trials]))
    out: list[Relabel] = []
    for path, markers, rate, first in trials:
        found = find_label_errors(path, markers, rate, kin, first_frame=first)
        out += act_on(args, pset, path, markers, first, found)
    return out


def act_on(
    args: argparse.Namespace,
    pset: ParameterSet,
    path: str,
    markers: np.ndarray,
    first: int,
    found: Sequence[Relabel],
) -> list[Relabel]:
    """``found``'s corrections made in ``markers`` (T, M, 3) [m] (the command's own copy of
    the data) unless ``--no-relabel`` (then marked not applied); refused under ``--strict``;
    one line each on stderr."""
    if found and args.strict:
        raise MocapError(
            f"{found[0].message} ({len(found)} label correction(s) in {path}; --strict "
            "refuses a recording whose labels need correcting: fix the labels or run "
            "without --strict)"
        )
    if args.no_relabel:
        found = [replace(r, applied=False) for r in found]
    apply_relabels(markers, pset.marker_names, found, path, first_frame=first, in_place=True)
    for r in found:
        verb = "relabelled" if r.applied else "warning: not relabelled (--no-relabel)"
        print(f"mocap-mj {args.command}: {verb}: {r.message}", file=sys.stderr)
    return list(found)


def without_ghosts(
    markers: np.ndarray, pset: ParameterSet, found: Sequence[Finding], path: str, first: int
) -> np.ndarray:
    """markers (T, M, 3) [m] of ``path`` (row 0 = the file's frame ``first``) with the
    samples its ``ghost`` and ``jump`` findings name missing
    (:func:`~mocap_mj.capture.marker_quality.drop_ghosts`). A long recording's markers are a memory
    map in the command's scratch folder (:func:`~mocap_mj.commands._markers.load_trial`),
    the command's own: the samples are dropped in it, not in a copy of the whole recording."""
    own = isinstance(markers, np.memmap) and markers.flags.writeable
    return drop_ghosts(markers, pset.marker_names, found, path, first_frame=first, in_place=own)[0]


def drop_excluded(markers: np.ndarray, pset: ParameterSet, excluded: Sequence[str]) -> np.ndarray:
    """markers (T, M, 3) [m] with the ``excluded`` markers' columns NaN (see
    :func:`~mocap_mj.capture.marker_quality.exclude_markers`)."""
    return exclude_markers(markers, pset.marker_names, excluded)


def quality_text(entry: dict[str, Any]) -> str:
    """The stdout line of a command on its marker-data quality."""
    excluded = entry["excluded"]
    head = f"excluded markers: {', '.join(excluded)}; " if excluded else ""
    fixed = entry.get("relabelled") or []
    if fixed:
        done = sum(r["applied"] for r in fixed)
        head += f"labels corrected: {done} of {len(fixed)} exchange(s) found; "
    n = len(entry["findings"])
    if not n:
        return f"{head}marker data quality: no finding"
    return (
        f"{head}marker data quality: {n} finding(s) (warnings above), markers named: "
        f"{', '.join(entry['suspects'])}"
    )
