"""Run one job per subject on Ray (or serially), isolated, committed atomically, resumable.

A job is ``job(subject, folder) -> dict``: it writes the subject's results into ``folder`` (an
empty temporary folder) and returns the subject's record (JSON-serialisable, with ``rows``: one
dict per trial). :func:`run_batch` then writes the record as ``subject.json`` and renames the
folder to ``OUT/<subject>``: a subject folder is complete or absent, never half-written.

* Isolation: an exception in a job is caught in the job's process and recorded as that
  subject's failure (its one-line message); a worker process that dies (killed, out of memory)
  is retried by Ray (``max_retries``) and, if it keeps dying, recorded as failed. The other
  subjects go on in every case.
* Time limit: a job running longer than ``timeout`` seconds is stopped (``SIGALRM`` in the
  process that runs it: this one, serially, or the Ray worker) and recorded as failed, its
  trials ``timed out``; the batch goes on. A job inside compiled code is stopped when it
  returns to Python.
* Ownership: ``OUT`` carries the tool's ``batch`` marker (:mod:`mocap_mj.io.ownership`); a
  batch writes only into an absent or empty folder or one that marker names (or a batch folder
  written before the marker existed: nothing but the batch's files and subject folders), and
  never inside the dataset. Each subject folder carries a ``subject`` marker and is replaced
  only when it does; the temporary folders carry a ``staging`` marker and are removed only
  once the process that made them is gone.
* Resume: each ``subject.json`` carries the content hash of the subject's inputs and options
  (:func:`mocap_mj.batch.dataset.content_hash`); a subject whose folder holds a record with the
  same hash and status ``ok`` is not run again.
* Ray: with ``address`` the batch joins that cluster (its workers must see ``OUT`` and the
  dataset at the same paths: a shared file system); otherwise a local Ray is started on this
  machine's cores, with a small object store (the jobs pass only paths and small records).
  Without Ray installed the jobs run one after the other in this process.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from ..errors import MocapError, OutputFolderError
from ..io.atomic import atomic_write_text
from ..io.ownership import MARKER, alive, folder_mark, mark_folder, remove_stale
from .dataset import BATCH_FILES, Entry, content_hash

Job = Callable[[Entry, Path], dict[str, Any]]

#: Object store of the local Ray [bytes]: Ray's minimum is 75 MiB; the jobs exchange only
#: paths and records of a few kB, and the default (30 % of RAM) would reserve 7 GiB here.
OBJECT_STORE_BYTES = 100 * 2**20
#: Ray retries of a subject whose worker process died (not of a job that raised).
MAX_RETRIES = 3
RECORD = "subject.json"
_TMP = ".tmp-"
_OLD = ".old-"


class Outcome(NamedTuple):
    """What became of one subject: ``status`` is ok, failed or resumed (a complete
    result with the same hash was already there); ``record`` is the subject's record."""

    name: str
    status: str
    record: dict[str, Any]


def one_line(exc: BaseException) -> str:
    """An exception as one line: a MocapError's message, else ``Type: message``."""
    text = str(exc) if isinstance(exc, MocapError) else f"{type(exc).__name__}: {exc}"
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[0] if lines else type(exc).__name__


class SubjectTimeout(MocapError):
    """A subject's job ran longer than the batch's time limit."""


#: The status of the trials of a subject whose job ran out of time.
TIMED_OUT = "timed out"


@contextlib.contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`SubjectTimeout` in the block after ``seconds`` (None: no limit; outside
    the main thread, where no signal can be set, or without ``SIGALRM`` (Windows), none
    either)."""
    if (
        seconds is None
        or threading.current_thread() is not threading.main_thread()
        or not hasattr(signal, "setitimer")
    ):
        yield
        return

    def expire(signum: int, frame: object) -> None:
        raise SubjectTimeout(f"timed out after {seconds:g} s (batch --timeout)")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def failed_record(
    subject: Entry, digest: str, error: str, seconds: float, status: str = "failed"
) -> dict[str, Any]:
    """The record of a subject whose job failed; its trials' rows have ``status``."""
    rows = [
        {"subject": subject.name, "trial": Path(t).name, "status": status, "error": error}
        for t in subject.trials
    ]
    return {
        "subject": subject.name,
        "hash": digest,
        "status": "failed",
        "error": error,
        "seconds": seconds,
        "rows": rows,
    }


def execute(
    job: Job, subject: Entry, out: str, digest: str, timeout: float | None = None
) -> dict[str, Any]:
    """Run ``job`` for one subject into a temporary folder of ``out`` and commit it.

    Returns the record; an exception of the job, or its running longer than ``timeout``
    seconds (None: no limit), becomes a failed record (nothing committed). Runs in a Ray
    worker (or in the caller, serially).
    """
    t0 = time.perf_counter()
    root = Path(out)
    tmp = root / f"{_TMP}{subject.name}-p{os.getpid()}-{secrets.token_hex(4)}"
    try:
        tmp.mkdir()
        mark_folder(tmp, "staging")
        with time_limit(timeout):
            record = dict(job(subject, tmp))
        record.update(
            subject=subject.name,
            hash=digest,
            status="ok",
            seconds=time.perf_counter() - t0,
        )
        atomic_write_text(tmp / RECORD, json.dumps(record, indent=2, default=float) + "\n")
        mark_folder(tmp, "subject")
        _commit(tmp, root / subject.name)
        return record
    except Exception as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        error = one_line(exc)
        if not isinstance(exc, MocapError):
            print(f"{subject.name}: {traceback.format_exc()}", file=sys.stderr)
        status = TIMED_OUT if isinstance(exc, SubjectTimeout) else "failed"
        return failed_record(subject, digest, error, time.perf_counter() - t0, status)


def _subject_folder(folder: Path) -> bool:
    """A subject folder of a batch: its ``subject`` marker, or (written before the marker
    existed) :data:`RECORD` with nothing but ``identify`` and ``ik`` beside it."""
    if folder.is_symlink() or not folder.is_dir():
        return False
    mark = folder_mark(folder)
    if mark is not None:
        return mark["kind"] == "subject"
    names = {p.name for p in folder.iterdir()}
    return RECORD in names and names <= {RECORD, "identify", "ik"}


def _commit(tmp: Path, final: Path) -> None:
    """Rename ``tmp`` to ``final``; an older ``final`` is moved aside first, then removed.
    Only a subject folder of a batch (:func:`_subject_folder`) is replaced: anything else at
    ``final`` is the user's and is refused, kept as it is."""
    old = None
    if (final.exists() or final.is_symlink()) and not _subject_folder(final):
        raise MocapError(
            f"{final}: exists and is not a subject folder of a batch (no {MARKER}); it is "
            "kept, choose another --out or move it away"
        )
    if final.exists():
        old = final.with_name(f"{_OLD}{final.name}-{secrets.token_hex(4)}")
        os.replace(final, old)
        mark_folder(old, "staging")  # a kill now leaves it for the next run to remove
    os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def completed(out: Path, subject: Entry, digest: str) -> dict[str, Any] | None:
    """The subject's record in ``out`` if it is complete, ok and of the same inputs."""
    try:
        record = json.loads((out / subject.name / RECORD).read_text())
    except (OSError, ValueError):
        return None
    if isinstance(record, dict) and record.get("hash") == digest and record.get("status") == "ok":
        return record
    return None


def clean_leftovers(out: Path) -> None:
    """Remove the temporary folders of runs that no longer run: only folders holding the
    tool's staging marker (never results, never a folder that merely bears such a name)."""
    for prefix in (_TMP, _OLD):
        remove_stale(out, prefix)
    with contextlib.suppress(OSError):  # a run killed between mkdir and its marker
        for p in out.iterdir():
            pid = _pid_of(p.name)
            if p.name.startswith(_TMP) and pid is not None and not alive(pid):
                with contextlib.suppress(OSError):
                    half = p / f"{MARKER}.{pid}.new"  # that process's half-written marker
                    if [e.name for e in p.iterdir()] == [half.name]:
                        half.unlink()
                    p.rmdir()  # only if empty


def _pid_of(name: str) -> int | None:
    """The process id in a temporary folder's name, if it has one."""
    head = name.rsplit("-", 1)[0]
    tail = head.rsplit("-p", 1)
    return int(tail[1]) if len(tail) == 2 and tail[1].isdigit() else None


def prepare_out(out: Path, subjects: Sequence[Entry], dataset: str | Path) -> None:
    """Make ``out`` the batch's folder, refusing one the batch may not write into.

    Refused (one line, nothing touched): an empty name; a file; a folder inside the dataset
    (a tree's root, or the folder of any subject's trial or subject file); a folder holding a
    trial; a non-empty folder that is not a batch's (its marker, or the batch's files and
    subject folders only). Otherwise ``out`` is created if needed and marked.
    """
    if not str(out).strip():
        raise OutputFolderError("--out: expected a folder, got an empty name")
    target = Path(os.path.realpath(out))
    if target.exists() and not target.is_dir():
        raise OutputFolderError(f"{out}: exists and is not a folder; choose another --out")
    roots = [Path(os.path.realpath(dataset))] if Path(dataset).is_dir() else []
    for s in subjects:
        for f in (*s.trials, *([s.subject_file] if s.subject_file else [])):
            real = Path(os.path.realpath(f))
            if real == target or target in real.parents:
                raise OutputFolderError(
                    f"--out {out} holds the input {f}; an input is never replaced or deleted, "
                    "so choose another --out"
                )
            roots.append(real.parent)
    for root in roots:
        if target == root or root in target.parents:
            raise OutputFolderError(
                f"--out {out} lies inside the dataset ({root}); the batch writes its results "
                "outside the dataset, so choose another --out"
            )
    if target.is_dir() and not _batch_folder(target):
        first = min(p.name for p in target.iterdir())
        raise OutputFolderError(
            f"{out}: not a folder a batch wrote (no {MARKER}; holds {first!r}, ...); a batch "
            "writes into an empty folder or resumes its own, so choose another --out"
        )
    target.mkdir(parents=True, exist_ok=True)
    mark = folder_mark(target)
    if mark is None:
        mark_folder(target, "batch")


def _legacy_summary(path: Path) -> bool:
    """``path`` is a batch's summary.json (its ``dataset`` and ``subjects_done`` fields)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and {"dataset", "subjects_done"} <= data.keys()


def _batch_folder(folder: Path) -> bool:
    """Empty, marked ``batch``, or a batch folder written before the marker: a batch's
    summary.json and nothing but the batch's files, subject folders and the temporaries of
    its runs."""
    mark = folder_mark(folder)
    if mark is not None:
        return mark["kind"] == "batch"
    entries = list(folder.iterdir())
    if entries and not _legacy_summary(folder / "summary.json"):
        return False
    for entry in entries:
        if entry.is_symlink():
            return False
        if entry.is_dir():
            if not (_subject_folder(entry) or entry.name.startswith((_TMP, _OLD))):
                return False
        elif entry.name not in BATCH_FILES:
            return False
    return True


def have_ray() -> bool:
    try:
        import ray  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class Cluster:
    """Where :func:`run_batch` runs the jobs.

    Fields
    ------
    use_ray : on Ray (default True); False: serially in this process
    address : the Ray cluster to join (default None: a local Ray on this machine)
    workers : the local Ray's CPUs (default None: all)
    """

    use_ray: bool = True
    address: str | None = None
    workers: int | None = None


def run_batch(
    subjects: Sequence[Entry],
    out: Path,
    job: Job,
    *,
    settings: Mapping[str, Any] | None = None,
    cluster: Cluster = Cluster(),
    progress: bool = True,
    on_outcome: Callable[[Outcome], None] | None = None,
    timeout: float | None = None,
) -> list[Outcome]:
    """Run ``job`` for every subject not already complete in ``out``; outcomes by subject.

    ``settings`` enter every subject's content hash (what else the results depend on).
    ``cluster``: where the jobs run (:class:`Cluster`; default: a local Ray on every CPU).
    ``on_outcome`` is called as each subject finishes. ``timeout``: seconds a subject's job
    may run (None: no limit; see :func:`execute`).
    """
    out.mkdir(parents=True, exist_ok=True)
    if folder_mark(out) is None:
        mark_folder(out, "batch")
    clean_leftovers(out)
    todo: list[tuple[Entry, str]] = []
    outcomes: dict[str, Outcome] = {}
    bar = _bar(len(subjects), progress)

    def done(o: Outcome) -> None:
        outcomes[o.name] = o
        bar.update(1)
        failed = sum(v.status == "failed" for v in outcomes.values())
        rows = [r for v in outcomes.values() for r in v.record.get("rows", [])]
        bad = sum(r.get("status") != "ok" for r in rows)
        bar.set_postfix(failed=failed, failed_trials=bad, refresh=False)
        if on_outcome is not None:
            on_outcome(o)

    for s in subjects:
        digest = content_hash(s, settings)
        record = completed(out, s, digest)
        if record is not None:
            done(Outcome(s.name, "resumed", record))
        else:
            todo.append((s, digest))
    try:
        if todo and cluster.use_ray:
            for o in _ray_outcomes(todo, out, job, cluster, timeout):
                done(o)
        else:
            for s, digest in todo:
                rec = execute(job, s, str(out), digest, timeout)
                done(Outcome(s.name, rec["status"], rec))
    finally:
        bar.close()
        clean_leftovers(out)
    return [outcomes[s.name] for s in subjects]


def _ray_outcomes(
    todo: Sequence[tuple[Entry, str]],
    out: Path,
    job: Job,
    cluster: Cluster,
    timeout: float | None = None,
) -> Iterator[Outcome]:
    import ray
    from ray.exceptions import RayError

    with _ray_session(cluster.address, cluster.workers):
        task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(execute)
        pending = {
            task.remote(job, s, str(out.resolve()), digest, timeout): (s, digest)
            for s, digest in todo
        }
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            s, digest = pending.pop(ready[0])
            try:
                rec = ray.get(ready[0])
            except RayError as exc:  # the worker died more than MAX_RETRIES times
                msg = f"worker failed {MAX_RETRIES + 1} times: {one_line(exc)}"
                rec = failed_record(s, digest, msg, 0.0)
            yield Outcome(s.name, rec["status"], rec)


@contextlib.contextmanager
def _ray_session(address: str | None, workers: int | None) -> Iterator[None]:
    import ray

    kwargs: dict[str, Any] = {"log_to_driver": False, "configure_logging": False}
    if address:
        kwargs["address"] = address
    else:
        kwargs.update(
            num_cpus=workers or os.cpu_count() or 1,
            object_store_memory=OBJECT_STORE_BYTES,
            include_dashboard=False,
        )
    try:
        ray.init(**kwargs)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        where = f"the Ray cluster at {address}" if address else "a local Ray"
        raise MocapError(f"cannot start or join {where}: {one_line(exc)}") from None
    try:
        yield
    finally:
        ray.shutdown()


def _bar(total: int, progress: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, desc="subjects", unit="subject", file=sys.stderr, disable=not progress)
