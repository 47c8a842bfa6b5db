"""Each trial's files of an identification result, in its folder
(:mod:`mocap_mj.pipeline.trials`): motion.npz, joint_centres.csv, angles.csv (with the
comparison against the Nexus angles its C3D holds), marker_error.png; and per trial of a
multi-trial result its report.md section and summary.json's ``trials`` entry."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.io.strict_json import jsonable
from mocap_mj.outputs.clinical_out import write_model_angles
from mocap_mj.outputs.nexus_out import centres_vs_nexus
from mocap_mj.pipeline.fit import Fit
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_mj.pipeline.trials import trial_entries, trial_folders
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.joint_centre_table import write_joint_centres_csv
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.problem import TrialData
from mocap_mj.solve.solver_result import IdentificationResult

#: The files of each trial, in its folder (motion.npz and joint_centres.csv only when the
#: motion is in memory; angles.csv of a streamed motion is the first trial's alone).
TRIAL_FILES = ("motion.npz", "joint_centres.csv", "angles.csv", "marker_error.png")


def streamed_name(name: str, folders: Sequence[str]) -> str:
    """Where a streamed motion file (``motion.npz``, ``motion_<i>.npz``,
    ``joint_centres_<i>.csv``, ``angles.csv`` of :mod:`mocap_mj.long.motion_out`) goes in
    the result folder: trial i's folder, under the name without ``_<i>``."""
    path = Path(name)
    stem, _, index = path.stem.rpartition("_")
    if stem in ("motion", "joint_centres") and index.isdigit() and int(index) < len(folders):
        return f"{folders[int(index)]}/{stem}{path.suffix}".lstrip("/")
    return name


def save_motions(
    out: Path, pset: ParameterSet, trials: Sequence[TrialData], motion: Sequence[Motion]
) -> None:
    """Each trial's motion.npz in its folder (internal qpos (T_i, nq) written in model.xml's
    layout, :class:`mocap_mj.skeleton.exported.Layout`)."""
    layout = Layout.of(pset.model)
    for folder, m in zip(trial_folders([str(t.name) for t in trials]), motion, strict=False):
        (out / folder).mkdir(parents=True, exist_ok=True)
        save_motion(out / folder / "motion.npz", replace(m, qpos=layout.written(m.qpos), ik=None))


def write_trial_plots(
    out: Path, pset: ParameterSet, result: IdentificationResult, trials: Sequence[TrialData]
) -> tuple[np.ndarray, list[float | None]]:
    """Each trial's marker_error.png (per fitted frame) in its folder; returns every
    marker's residual sum of squares (M,) [m^2] and sample count (M,) over the fitted frames
    of all trials (stacked (2, M)), and each trial's marker RMSE [mm] (None without data)."""
    from mocap_mj.io.plots import plot_marker_error_per_frame

    kin = Kinematics(pset)
    kin.set_theta(result.theta)
    pooled = np.zeros((2, pset.n_markers))
    per_trial: list[float | None] = []
    folders = trial_folders([str(t.name) for t in trials])
    for i, (t, q) in enumerate(zip(trials, result.qpos, strict=True)):
        (out / folders[i]).mkdir(parents=True, exist_ok=True)
        plot_marker_error_per_frame(
            out / folders[i] / "marker_error.png",
            t.times,
            {"identified model": result.frame_rmse[i] * 1e3},
            title=f"Marker error per frame: {Path(str(t.name)).name}",
        )
        ok = np.all(np.isfinite(q), axis=1)
        d = np.linalg.norm(kin.marker_positions(q[ok]) - t.markers[ok], axis=2)
        present = np.isfinite(d)
        sq = np.sum(np.where(present, d, 0.0) ** 2, axis=0)
        pooled += [sq, present.sum(axis=0)]
        n = int(present.sum())
        per_trial.append(float(np.sqrt(sq.sum() / n) * 1e3) if n else None)
    return pooled, per_trial


def write_trial_tables(
    out: Path,
    fit: Fit,
    motion: Sequence[Motion],
    summary: dict[str, Any],
    fitted_rmse: Sequence[float | None],
) -> list[str]:
    """Each trial's joint_centres.csv and angles.csv in its folder, its angles and joint
    centres compared with the Nexus angles and bone points its C3D holds; summary.json's
    ``trials`` (and ``angles_vs_plug_in_gait``, ``joint_centres_vs_plug_in_gait``: the
    first trial's); returns report.md's lines: the comparisons for a one-trial result, else
    a section per trial."""
    files = [str(t.name) for t in fit.trials]
    folders = trial_folders(files)
    model = fit.pset.model_for(fit.theta)
    frames = (
        [len(m.times) for m in motion]
        if motion
        else summary.get("motion_frames") or [len(t.markers) for t in fit.trials]
    )
    entries = trial_entries(files, frames, list(fit.first_frames) or [0] * len(files))
    lines: list[str] = []
    for i, (entry, folder) in enumerate(zip(entries, folders, strict=True)):
        if i < len(motion):
            write_joint_centres_csv(
                out / folder / "joint_centres.csv",
                model,
                motion[i].times,
                motion[i].qpos,
                first_frame=entry["first_frame"],
            )
        angle_lines, compared = write_model_angles(
            out, model, motion, entry["file"], entry["first_frame"], trial=i, folder=folder
        )
        written = [f for f in TRIAL_FILES if (out / folder / f).is_file()]
        entry.update(files=written, fitted_marker_rmse_mm=fitted_rmse[i])
        centre_lines, centres = centres_vs_nexus(fit, summary, trial=i)
        for key, value in (("angles_vs_plug_in_gait", compared),
                           ("joint_centres_vs_plug_in_gait", jsonable(centres))):  # fmt: skip
            if value is not None:
                entry[key] = value
                if i == 0:  # the first trial's, where a one-trial result has them
                    summary[key] = value
        if len(files) == 1:
            lines += angle_lines + centre_lines
        else:
            lines += _section(entry, summary, angle_lines + centre_lines)
    summary["trials"] = entries
    return lines


def _section(entry: dict[str, Any], summary: dict[str, Any], angles: list[str]) -> list[str]:
    """report.md's section of one trial of several: its folder, files, frames, the marker
    RMSE on its fitted frames, its marker_error.png and its angle comparison."""
    folder = "" if entry["folder"] == "." else f"{entry['folder']}/"
    used = summary.get("frames_selected") or []
    fitted = len(used[entry["index"]]) if entry["index"] < len(used) else None
    rmse = entry["fitted_marker_rmse_mm"]
    last = entry["first_frame"] + entry["frames"] - 1
    lines = [
        "",
        f"## Trial {entry['index']}: {entry['name']} ({entry['file']})",
        "",
        f"- files ({folder or 'at the top of the folder'}): {', '.join(entry['files'])}; "
        f"`--trial {entry['name']}` in export, render and view",
        f"- frames: {entry['frames']} (the recording's {entry['first_frame']} to {last})"
        + (f", {fitted} of them in the fit" if fitted is not None else ""),
        "- marker RMSE on its fitted frames: " + ("no data" if rmse is None else f"{rmse:.3f} mm"),
        "",
        f"![marker error]({folder}marker_error.png)",
        "",
    ]
    return lines + ["#" + line if line.startswith("## ") else line for line in angles]
