"""``--exclude-markers`` and ``--quality`` (``--strict``, ``--no-relabel``) of identify and ik
(the flags: :mod:`mocap_mj.commands.options`): the marker-data quality check
(:mod:`mocap_mj.pipeline.quality`) run on the loaded trials before any solve, its notices
printed on stderr (:func:`notices_to_stderr`).

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
import contextlib
import logging
import sys
from collections.abc import Iterator, Sequence

import numpy as np

from mocap_mj.capture.marker_quality import exclude_markers
from mocap_mj.capture.marker_quality import parse_marker_list as parse_marker_list
from mocap_mj.pipeline.quality import NOTICES, Policy
from mocap_mj.pipeline.quality import check_trials as check_trials
from mocap_mj.pipeline.quality import without_ghosts as without_ghosts
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.skeleton.parameters import ParameterSet


def policy_of(args: argparse.Namespace) -> Policy:
    """The quality check's policy of ``--strict`` and ``--no-relabel`` (``identify``: the
    trials are one subject's)."""
    return Policy(
        strict=args.strict, relabel=not args.no_relabel, one_model=args.command == "identify"
    )


@contextlib.contextmanager
def notices_to_stderr(command: str) -> Iterator[None]:
    """The library's notices (:data:`~mocap_mj.pipeline.quality.NOTICES`) printed on stderr
    while the block runs, one line each after ``mocap-mj COMMAND: ``."""
    handler = _StderrLines(command)
    propagate = NOTICES.propagate
    NOTICES.addHandler(handler)
    NOTICES.propagate = False
    try:
        yield
    finally:
        NOTICES.removeHandler(handler)
        NOTICES.propagate = propagate


class _StderrLines(logging.Handler):
    def __init__(self, command: str) -> None:
        super().__init__(logging.WARNING)
        self.command = command

    def emit(self, record: logging.LogRecord) -> None:
        print(f"mocap-mj {self.command}: {record.getMessage()}", file=sys.stderr)


def drop_excluded(markers: np.ndarray, pset: ParameterSet, excluded: Sequence[str]) -> np.ndarray:
    """markers (T, M, 3) [m] with the ``excluded`` markers' columns NaN (see
    :func:`~mocap_mj.capture.marker_quality.exclude_markers`)."""
    return exclude_markers(markers, pset.marker_names, excluded)


def quality_text(quality: MarkerQuality) -> str:
    """The stdout line of a command on its marker-data quality."""
    excluded = quality.excluded
    head = f"excluded markers: {', '.join(excluded)}; " if excluded else ""
    fixed = quality.relabelled
    if fixed:
        done = sum(r.applied for r in fixed)
        head += f"labels corrected: {done} of {len(fixed)} exchange(s) found; "
    n = len(quality.findings)
    if not n:
        return f"{head}marker data quality: no finding"
    return (
        f"{head}marker data quality: {n} finding(s) (warnings above), markers named: "
        f"{', '.join(quality.suspects)}"
    )
