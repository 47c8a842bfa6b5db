"""The marker-data quality check of the trials before any solve, with the correction of
labels exchanged by mistake (:mod:`mocap_mj.pipeline.relabel`,
:mod:`mocap_mj.capture.marker_quality`).

Findings are warnings by default: one notice each (:data:`NOTICES`), recorded in the
summary's ``marker_quality``; the check is evidence, not proof (a child's forearm, an unusual
marker set), and a fit of the remaining markers is still useful. ``strict`` refuses the data
instead (:class:`~mocap_mj.errors.MocapError`), for pipelines that must not publish a model
built on suspect markers. Labels are corrected in the pipeline's own copy of the markers (a
file is never touched), one notice each; without ``relabel`` they are left as they are and
the notices are warnings; ``strict`` refuses a recording whose labels need a correction.

The notices go to the logger ``mocap_mj.notices`` at level WARNING, one record per line,
its text the line's (``warning: ...``, ``relabelled: ...``): the command line prints each
on stderr after ``mocap-mj COMMAND: ``; without a handler Python prints them on stderr as
they are (logging's last resort).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from mocap_mj.capture.marker_quality import (
    Finding,
    check_trials_quality,
    drop_ghosts,
    marker_segments,
    suspects,
)
from mocap_mj.pipeline.relabel import (
    Relabel,
    apply_relabels,
    find_label_errors,
    reference_theta,
    track_swaps,
)
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet

from ..errors import MocapError

#: The pipeline's notices to the user (corrections, quality warnings): see the module's text.
NOTICES = logging.getLogger("mocap_mj.notices")


def notice(line: str) -> None:
    """One notice (a line such as ``warning: ...``) on :data:`NOTICES`."""
    NOTICES.warning("%s", line)


class Checked(NamedTuple):
    """One trial as the check takes it: its name (path), markers (T, M, 3) [m] in the
    model's order (the pipeline's own copy: corrections are made in it), frame rate [Hz]
    and the file's number of row 0."""

    name: str
    markers: np.ndarray
    rate: float
    first: int


class Policy(NamedTuple):
    """How the check acts: ``strict`` refuses what it finds, ``relabel`` corrects exchanged
    labels, ``one_model`` (identify) judges the trials as one subject (labels against the
    nominal model scaled to the markers, marker distances compared between the trials)."""

    strict: bool = False
    relabel: bool = True
    one_model: bool = True


def check_trials(
    pset: ParameterSet, trials: Sequence[Checked], excluded: Sequence[str], policy: Policy
) -> tuple[list[Finding], MarkerQuality]:
    """Check ``trials`` (their ``excluded`` markers already dropped) after correcting their
    labels; raise under ``policy.strict``, else one notice per finding; return the findings
    and the recordings' quality (corrections, findings, excluded markers)."""
    relabelled = relabel(pset, trials, policy)
    found = _findings(pset, trials, policy)
    swaps = [
        r
        for t in trials
        for r in act_on(
            pset, t, track_swaps(t.name, pset.marker_names, t.markers, found, first_frame=t.first),
            policy,
        )
    ]  # fmt: skip
    if any(r.applied for r in swaps):  # the corrected tracks checked again
        found = _findings(pset, trials, policy)
    relabelled += swaps
    named = suspects(found)
    if found and policy.strict:
        raise MocapError(
            f"{found[0].message} ({len(found)} finding(s) in all; markers named: "
            f"{', '.join(named)}; --strict refuses them: drop markers with --exclude-markers "
            "or run without --strict)"
        )
    for f in found:
        notice(f"warning: {f.message}")
    if named:
        top = [n for n, c in named.items() if c == max(named.values())]
        notice(
            "warning: markers named by the data-quality check "
            f"(times named): {', '.join(f'{n} ({c})' for n, c in named.items())}; the most "
            f"named first: --exclude-markers {','.join(top)} drops its data "
            "(docs/recordings.md#what-each-warning-means)"
        )
    return found, MarkerQuality(tuple(relabelled), tuple(found), tuple(excluded))


def _findings(pset: ParameterSet, trials: Sequence[Checked], policy: Policy) -> list[Finding]:
    return check_trials_quality(
        [t.name for t in trials],
        pset.marker_names,
        [t.markers for t in trials],
        [t.rate for t in trials],
        marker_segments(pset.model),
        [t.first for t in trials],
        between=policy.one_model,  # one model for every trial: markers must agree
    )


def relabel(pset: ParameterSet, trials: Sequence[Checked], policy: Policy) -> list[Relabel]:
    """The label errors of ``trials`` that a model shows
    (:func:`~mocap_mj.pipeline.relabel.find_label_errors`), acted on (:func:`act_on`): with
    ``policy.one_model`` judged with the nominal model scaled to the subject, else with
    ``pset``'s own."""
    kin = Kinematics(pset)
    if policy.one_model:
        kin.set_theta(reference_theta(pset, [t.markers for t in trials]))
    out: list[Relabel] = []
    for t in trials:
        found = find_label_errors(t.name, t.markers, t.rate, kin, first_frame=t.first)
        out += act_on(pset, t, found, policy)
    return out


def act_on(
    pset: ParameterSet, trial: Checked, found: Sequence[Relabel], policy: Policy
) -> list[Relabel]:
    """``found``'s corrections made in ``trial.markers`` (T, M, 3) [m] (the pipeline's own
    copy of the data) unless ``policy.relabel`` is off (then marked not applied); refused
    under ``policy.strict``; one notice each."""
    if found and policy.strict:
        raise MocapError(
            f"{found[0].message} ({len(found)} label correction(s) in {trial.name}; --strict "
            "refuses a recording whose labels need correcting: fix the labels or run "
            "without --strict)"
        )
    if not policy.relabel:
        found = [replace(r, applied=False) for r in found]
    apply_relabels(
        trial.markers, pset.marker_names, found, trial.name, first_frame=trial.first,
        in_place=True,
    )  # fmt: skip
    for r in found:
        verb = "relabelled" if r.applied else "warning: not relabelled (--no-relabel)"
        notice(f"{verb}: {r.message}")
    return list(found)


def without_ghosts(
    markers: np.ndarray, pset: ParameterSet, found: Sequence[Finding], path: str, first: int
) -> np.ndarray:
    """markers (T, M, 3) [m] of ``path`` (row 0 = the file's frame ``first``) with the
    samples its ``ghost`` and ``jump`` findings name missing
    (:func:`~mocap_mj.capture.marker_quality.drop_ghosts`). A long recording's markers are a
    writable memory map in a scratch folder (the command's): the samples are dropped in it,
    not in a copy of the whole recording."""
    own = isinstance(markers, np.memmap) and markers.flags.writeable
    return drop_ghosts(markers, pset.marker_names, found, path, first_frame=first, in_place=own)[0]
