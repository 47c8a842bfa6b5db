"""``mocap-mj batch``: identify and track every subject of a dataset, on Ray.

Per subject: one identification from all its readable trials (:func:`mocap_mj.identify`'s
pipeline, written as ``mocap-mj identify`` writes it), then IK of each trial with the identified
model (``mocap-mj ik``), into ``OUT/<subject>/identify`` and ``OUT/<subject>/ik/<trial>``; then
``OUT/summary.csv`` and ``OUT/report.md`` over the dataset. See :mod:`mocap_mj.batch.run` for
isolation and resume, docs/batch.md for usage.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from mocap_mj.commands.common import (
    EXIT_IMPLAUSIBLE,
    finish,
    output_folder,
    with_exit_status,
    write_summary,
)
from mocap_mj.kernels._threads import one_blas_thread
from mocap_mj.outputs.batch_out import TrialRow, identify_fields, row_fields, write_summary_csv
from mocap_mj.pipeline.fit import Fit
from mocap_mj.pipeline.report import MarkerQuality
from mocap_mj.pipeline.track import Tracked
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSettings

from ..batch.dataset import OPTION_KEYS, Entry, load_dataset
from ..batch.report import summary_rows, write_report
from ..batch.run import Cluster, have_ray, one_line, prepare_out, run_batch
from ..errors import MocapError
from ._markers import load_trial


def run(args: argparse.Namespace) -> int:
    defaults = {k: getattr(args, k) for k in OPTION_KEYS if getattr(args, k) is not None}
    subjects = load_dataset(args.dataset, defaults)
    if args.serial and args.address:
        raise MocapError("--serial and --address exclude each other")
    use_ray = not args.serial
    if use_ray and not have_ray():
        if args.address:
            raise MocapError("--address needs Ray: pip install 'mocap-mj[cluster]'")
        print(
            "mocap-mj batch: Ray is not installed, running the subjects one after the other "
            "(pip install 'mocap-mj[cluster]' to run them in parallel)",
            file=sys.stderr,
        )
        use_ray = False
    from .. import __version__

    out = Path(args.out)
    prepare_out(out, subjects, args.dataset)
    t0 = time.perf_counter()
    with _stdout_to_stderr():  # Ray's processes and log lines: stdout is the summary alone
        outcomes = run_batch(
            subjects,
            out,
            process_subject,
            settings={"mocap_mj": __version__},
            cluster=Cluster(use_ray, args.address, args.workers),
            progress=not args.json,
            timeout=args.timeout,
        )
    seconds = time.perf_counter() - t0
    rows = summary_rows(outcomes)
    write_summary_csv(out / "summary.csv", rows)
    write_report(out, outcomes, seconds)
    failed = [o.name for o in outcomes if o.status == "failed"]
    bad_rows = [r for r in rows if r.status != "ok"]
    bad = [f"{r.subject}/{r.trial}" for r in bad_rows]
    summary = {
        "dataset": str(args.dataset),
        "subjects": len(outcomes),
        "subjects_done": sum(o.status == "ok" for o in outcomes),
        "subjects_resumed": sum(o.status == "resumed" for o in outcomes),
        "subjects_failed": failed,
        "trials": len(rows),
        "trials_failed": bad,
        "ray": use_ray,
        "seconds": seconds,
    }
    text = (
        f"{len(outcomes)} subjects: {summary['subjects_done']} identified, "
        f"{summary['subjects_resumed']} kept from an earlier run, {len(failed)} failed; "
        f"{len(rows)} trials, {len(bad)} failed; {seconds:.1f} s\n"
        + "".join(f"failed: {r.subject}/{r.trial}: {r.error}\n" for r in bad_rows)
        + f"wrote {out}/summary.csv, report.md, <subject>/identify, <subject>/ik/<trial>"
    )
    implausible = [o.name for o in outcomes if o.record.get("identify", {}).get("implausible")]
    status = 1 if failed or bad else EXIT_IMPLAUSIBLE if implausible else 0
    summary.update(subjects_implausible=implausible, exit_status=status)
    finish(args, summary, text, out)
    if status == EXIT_IMPLAUSIBLE:
        print(
            f"mocap-mj batch: implausible identification of {', '.join(implausible)} (exit "
            f"status {status}; see their identify/summary.json)",
            file=sys.stderr,
        )
    return status


@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """File descriptor 1 pointed at stderr in the block, for this process and every process
    it starts: Ray's driver prints the raylet's error messages (a worker that died, memory
    pressure) on stdout as ``(raylet) ...`` lines whatever ``log_to_driver`` says, and the
    local Ray's processes inherit the descriptor."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


# --------------------------------------------------------------------------- the adapter
def process_subject(subject: Entry, folder: Path) -> dict[str, Any]:
    """One subject into ``folder``: identification from its readable trials, then IK of each.

    The identification is the library's (:func:`_identify`), its folder written as
    ``identify`` writes it; the IK of each trial is the library's
    (:func:`~mocap_mj.pipeline.track.track`, through ``ik``'s reading and writing,
    :func:`_ik`). A trial that cannot be read, or whose IK
    fails, becomes a failed row; no readable trial, or a failed identification, raises.
    """
    opts = dict(subject.options)
    pset = ParameterSet(opts.get("model"))
    reader = argparse.Namespace(
        up=opts.get("up"),
        units=opts.get("units"),
        marker_map=opts.get("marker_map"),
        subject=opts.get("file_subject"),
    )
    names = _trial_folders(subject.trials)
    rows: dict[str, TrialRow] = {}
    readable = []
    for path in subject.trials:
        row = TrialRow(subject.name, Path(path).name)
        try:
            row = replace(row, frames=len(load_trial(path, pset.marker_names, reader).markers))
            readable.append(path)
        except (MocapError, OSError, ValueError) as exc:
            row = replace(row, error=one_line(exc))
        rows[path] = row
    if not readable:
        raise MocapError(f"no readable trial ({rows[subject.trials[0]].error})")
    passed = bool(subject.subject_file)
    fit = _identify(opts, readable, subject.subject_file, folder / "identify")
    at_bounds = sorted(n for n, out in zip(fit.pset.kappa_names, _outside(fit), strict=True) if out)
    quality = fit.report.quality
    model = folder / "identify" / "model.xml"
    for path in readable:
        rows[path] = replace(
            rows[path],
            identify_rmse=fit.marker_rmse,
            identify_seconds=fit.timings.get("seconds"),
            parameters_at_bounds=tuple(at_bounds),
            marker_quality=_quality_cell(quality, path),
        )
        try:
            ik = _ik(opts, path, model, folder / "ik" / names[path])
        except MocapError as exc:
            rows[path] = replace(rows[path], error=one_line(exc))
            continue
        assert ik.motion.ik is not None  # a tracked motion carries its IK
        rows[path] = replace(rows[path], status="ok", ik_rmse=ik.motion.ik.rmse(),
                             ik_seconds=ik.seconds)  # fmt: skip
    return {
        "trials": {Path(p).name: names[p] for p in subject.trials},
        "height_m": subject.height,
        "subject_file": subject.subject_file,
        "subject_file_passed_to_identify": passed,
        "identify": identify_fields(
            fit.marker_rmse,
            fit.timings.get("seconds"),
            fit.result.iterations,
            fit.result.termination.value,
            fit.kappa(),
            list(fit.implausible),
        ),
        "rows": [row_fields(rows[p]) for p in subject.trials],
    }


def _identify(opts: dict[str, Any], paths: list[str], subject_file: str | None, out: Path) -> Fit:
    """The subject's identification from the trials ``paths``: the library's
    (:func:`~mocap_mj.pipeline.api.identify_prepared`, through identify's reading and
    writing, :func:`~mocap_mj.commands.identify.checked_inputs` and
    :func:`~mocap_mj.commands.identify.identified`), with the dataset's options (vertical
    axis, label map, the file's subject prefix; the recipe, its model, frames and excluded
    markers); written into ``out`` as ``identify`` writes it, its notices on stderr."""
    from mocap_mj.io.ownership import scratch_folder

    from .identify import checked_inputs, identified, recipe_from_args

    args = identify_args(opts, paths, subject_file, out)
    recipe = recipe_from_args(args)
    with scratch_folder(prefix="mocap-mj-batch-") as scratch:
        inputs = checked_inputs(args, recipe, Path(scratch))
        with output_folder(out) as staging:
            fit, summary, _ = identified(args, inputs, staging)
            write_summary(staging, with_exit_status(summary))
    return fit


def identify_args(
    opts: dict[str, Any], paths: list[str], subject_file: str | None, out: Path
) -> argparse.Namespace:
    """identify's options of a subject of the dataset: its trials ``paths``, subject file and
    ``out`` folder, and the dataset's options ``opts`` (a recipe field's option, ``loss`` or
    ``no_sliding_landmarks``, over the recipe's field, as identify's flag)."""
    return argparse.Namespace(
        command="identify", markers=paths, out=str(out), json=True, force=False,
        subject=opts.get("file_subject"), marker_map=opts.get("marker_map"), up=opts.get("up"),
        units=opts.get("units"), model=opts.get("model"), marker_set=None,
        recipe=opts.get("recipe"), loss=opts.get("loss"), frames=opts.get("frames"),
        exclude_markers=opts.get("exclude_markers"), no_relabel=False, strict=False,
        no_sliding_landmarks=bool(opts.get("no_sliding_landmarks")), subject_file=subject_file,
        height=None, mass=None, forces=None,
    )  # fmt: skip


def _outside(fit: Fit) -> list[bool]:
    """Whether each kinematic parameter ended outside its anatomical range (with anatomy)."""
    names = set(fit.kappa_outside_bounds())
    return [n in names for n in fit.pset.kappa_names]


def _quality_cell(quality: MarkerQuality, path: str) -> str:
    """summary.csv's ``marker_quality`` of one trial: ``none`` or ``N finding(s): NAMES``
    (a ``moved`` finding may name several trials, joined by ", ")."""
    found = [f for f in quality.findings if path in (f.file, *f.file.split(", "))]
    if not found:
        return "none"
    names = dict.fromkeys(n for f in found if f.kind != "asymmetry" for n in f.markers)
    return f"{len(found)} finding(s): {' '.join(names) or 'left/right asymmetry'}"


def _ik(opts: dict[str, Any], path: str, model: Path, out: Path) -> Tracked:
    """The motion of the trial ``path`` with the identified ``model``, written into ``out`` as
    ``ik`` writes it (through :func:`~mocap_mj.commands.ik.prepared` and
    :func:`~mocap_mj.commands.ik.written`, the IK's defaults), with the dataset's reading
    options and excluded markers; its notices on stderr. summary.json names the model by
    its path from ``out`` (``../../identify/model.xml``), which holds once the subject's
    folder is in place."""
    from .ik import prepared, written

    defaults = IKSettings()
    args = argparse.Namespace(
        command="ik", markers=path, model=str(model), out=str(out), json=True, force=False,
        subject=opts.get("file_subject"), marker_map=opts.get("marker_map"), up=opts.get("up"),
        units=opts.get("units"), marker_set=None, frames=None,
        exclude_markers=opts.get("exclude_markers"), no_relabel=False, strict=False,
        damping=defaults.damping, max_iterations=defaults.max_iterations, min_markers=None,
        loss="l2", no_sliding_landmarks=False, subject_file=None, height=None, mass=None,
        forces=None,
    )  # fmt: skip
    with one_blas_thread():  # as the command line runs it
        ready = prepared(args)
    with (
        output_folder(out) as staging,
        contextlib.redirect_stdout(io.StringIO()),
        one_blas_thread(),
    ):
        summary, _, tracked = written(args, ready, staging)
        write_summary(staging, with_exit_status(summary))
    return tracked


def _trial_folders(trials: tuple[str, ...]) -> dict[str, str]:
    """Output folder name of each trial: its file name, numbered if two trials share one."""
    names = [Path(t).name for t in trials]
    return {
        t: n if names.count(n) == 1 else f"{i:02d}-{n}"
        for i, (t, n) in enumerate(zip(trials, names, strict=True))
    }
