"""The folder ``ik`` writes for one trial (``batch`` writes the same under ``<subject>/ik``):
model.xml, motion.npz, motion.csv, joint_centres.csv, angles.csv and summary.json's fields
of the motion (:func:`ik_fields`), from a :class:`~mocap_mj.pipeline.track.Tracked` motion."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.plausibility import joints_at_limit
from mocap_mj.anatomy.tissue import recorded_sliding_model
from mocap_mj.export.tables import write_angles_csv
from mocap_mj.outputs.ik_out import fit_fields, write_motion_csv
from mocap_mj.pipeline.motion import save_motion
from mocap_mj.pipeline.summary import quality_fields
from mocap_mj.pipeline.track import Tracked, TrackOptions
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.joint_centre_table import write_joint_centres_csv
from mocap_mj.skeleton.mjcf import load_written
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import Status


def write_ik_files(pset: ParameterSet, tracked: Tracked, out: Path) -> None:
    """model.xml (``pset``'s nominal model), motion.npz, motion.csv, joint_centres.csv and
    angles.csv of ``tracked``'s poses into ``out``, frames numbered from its first frame."""
    model, motion, first = pset.model, tracked.motion, tracked.first_frame
    qpos, times = motion.qpos, motion.times
    pset.export_mjcf(out / "model.xml", pset.nominal)
    written = Layout.of(model).written(qpos)
    save_motion(out / "motion.npz", replace(motion, qpos=written, first_frame=first))
    write_motion_csv(out / "motion.csv", load_written(out / "model.xml"), times, written, first)
    write_joint_centres_csv(out / "joint_centres.csv", model, times, qpos, first_frame=first)
    write_angles_csv(out / "angles.csv", model, times, qpos, first_frame=first)


def ik_fields(
    pset: ParameterSet, tracked: Tracked, options: TrackOptions, sliding: list[str] | None
) -> dict[str, Any]:
    """summary.json's fields of ``tracked`` (mm, s): frames solved and skipped (numbered as
    the recording numbers them), the fit's figures, convergence, speed, the IK's choices
    (``sliding``: the landmarks weighed down, None: every marker alike) and the joints held
    at a limit of their range."""
    result = tracked.motion.ik
    assert result is not None  # a tracked motion carries its IK
    n, first = len(tracked.motion.times), tracked.first_frame
    skipped = np.flatnonzero(result.status == Status.TOO_FEW_MARKERS)
    seconds = tracked.seconds
    return {
        "frames": n,
        "frames_range": [first, first + n],
        "frames_solved": int(n - skipped.size),
        "frames_skipped": [first + int(i) for i in skipped],
        **fit_fields(result.rmse(), float(np.nanmax(result.marker_rmse))),
        "iterations_mean": float(result.iterations.mean()),
        "converged_fraction": float(np.mean(result.status == Status.CONVERGED)),
        "seconds": seconds,
        "frames_per_second": n / seconds,
        "damping": options.settings.damping,
        "loss": options.loss,
        "sliding_landmarks": sliding,
        "marker_quality": quality_fields(tracked.quality),
        "joints_at_limit": joints_at_limit(pset.model, pset.model.jnt_range, [result.qpos]),
    }


def ik_summary(
    pset: ParameterSet,
    tracked: Tracked,
    options: TrackOptions,
    head: dict[str, Any],
    kinetics: dict[str, Any] | None,
) -> dict[str, Any]:
    """``ik``'s summary.json of ``tracked`` with ``pset`` (whose model.xml may record the
    landmarks' sliding model): ``head`` (the markers file, the model, the marker set),
    :func:`ik_fields`, the set's markers the file lacks (``head["markers_missing"]``), the
    model's markers without a valid sample in the solved frames, and the ``kinetics``
    section (None: no kinetics)."""
    sliding = recorded_sliding_model(pset.model) if options.sliding else None
    seen = np.any(np.all(np.isfinite(tracked.motion.markers), axis=2), axis=0)
    return {
        **{k: v for k, v in head.items() if k != "markers_missing"},
        **ik_fields(pset, tracked, options, None if sliding is None else sorted(sliding.slides)),
        "markers_missing": list(head.get("markers_missing", [])),
        "markers_without_data": [
            n for n, ok in zip(pset.marker_names, seen, strict=True) if not ok
        ],
        "kinetics": kinetics,
    }


__all__ = ["ik_fields", "ik_summary", "write_ik_files"]
