"""``mocap-mj batch``: datasets, fault isolation, resume, and a real two-node Ray cluster.

The dataset is synthetic (mocap_synth): each subject a perturbed humanoid (its seed) with a
ROM and a walking trial of 60 frames and 1 mm noise, so a good result fits to about 1.3 mm.
"""

from __future__ import annotations

import contextlib
import csv
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from mocap_mj.batch import content_hash, load_dataset
from mocap_mj.cli import main
from mocap_mj.errors import InputFileError
from mocap_mj.io import save_csv
from mocap_mj.io.ownership import MARKER
from mocap_synth import SynthConfig, synthesize

FRAMES = 60


def make_subject(folder: Path, seed: int, motions: tuple[str, ...] = ("rom", "walk")) -> None:
    folder.mkdir(parents=True)
    for motion in motions:
        exp = synthesize(SynthConfig(frames=FRAMES, motion=motion, seed=seed))
        save_csv(folder / f"{motion}.csv", exp.trajectory())
    (folder / "subject.yaml").write_text(f"height: {1.6 + 0.05 * seed:.2f}\n")


def read_summary(out: Path) -> list[dict[str, str]]:
    with open(out / "summary.csv", newline="") as handle:
        return list(csv.DictReader(handle))


# ------------------------------------------------------------------------- datasets
def test_manifests_and_tree_give_the_same_subjects(tmp_path: Path) -> None:
    for name in ("A", "B"):
        (tmp_path / "tree" / name).mkdir(parents=True)
        for trial in ("t1.c3d", "t2.trc"):
            (tmp_path / "tree" / name / trial).write_bytes(name.encode() + trial.encode())
    (tmp_path / "tree" / "A" / "subject.yaml").write_text("height: 1.8\n")
    (tmp_path / "tree" / ".hidden").mkdir()
    tree = load_dataset(tmp_path / "tree", {"frames": "0:50"})
    assert [s.name for s in tree] == ["A", "B"]
    assert [Path(t).name for t in tree[0].trials] == ["t1.c3d", "t2.trc"]
    assert tree[0].height == 1.8 and tree[1].height is None
    assert tree[0].options == {"frames": "0:50"}

    rows = ["subject,trial,subject_file,up"]
    for s in tree:
        for t in s.trials:
            sfile = "tree/A/subject.yaml" if s.name == "A" else ""
            rows.append(f"{s.name},{os.path.relpath(t, tmp_path)},{sfile},z")
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    from_csv = load_dataset(tmp_path / "m.csv", {"frames": "0:50"})
    assert [(s.name, s.trials, s.subject_file) for s in from_csv] == [
        (s.name, s.trials, s.subject_file) for s in tree
    ]
    assert from_csv[0].options == {"frames": "0:50", "up": "z"}

    (tmp_path / "m.yaml").write_text(
        "options: {up: z}\nsubjects:\n"
        "  - {name: A, trials: [tree/A/t1.c3d, tree/A/t2.trc], subject_file: tree/A/subject.yaml,"
        " options: {frames: '0:7'}}\n"
        "  - {name: B, trials: [tree/B/t1.c3d, tree/B/t2.trc]}\n"
    )
    from_yaml = load_dataset(tmp_path / "m.yaml")
    assert [s.trials for s in from_yaml] == [s.trials for s in tree]
    assert from_yaml[0].options == {"up": "z", "frames": "0:7"}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("subject,trial,colour\nA,a.c3d,red\n", "row 2: unknown column(s) colour"),
        ("subject,trial\nA,a.c3d\nb/c,b.c3d\n", "row 3: subject name 'b/c'"),
        ("subject,trial,up\nA,a.c3d,z\nA,b.c3d,y\n", "row 3: options of subject 'A'"),
        ("subject,trial,init\nA,a.c3d,placed\n", "option 'init' removed; put init in a recipe"),
        ("name,file\nA,a.c3d\n", "expected a header with 'subject' and 'trial'"),
    ],
)
def test_bad_manifest_names_the_row(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "m.csv").write_text(text)
    with pytest.raises(InputFileError, match=r"m\.csv: .*" + re.escape(message)):
        load_dataset(tmp_path / "m.csv")


def test_content_hash_follows_bytes_and_options_not_paths(tmp_path: Path) -> None:
    for root in ("one", "two"):
        (tmp_path / root / "A").mkdir(parents=True)
        (tmp_path / root / "A" / "t.c3d").write_bytes(b"same bytes")
    [a1] = load_dataset(tmp_path / "one")
    [a2] = load_dataset(tmp_path / "two")
    assert content_hash(a1) == content_hash(a2)  # moved dataset: still resumes
    [a3] = load_dataset(tmp_path / "one", {"frames": "0:50"})
    assert content_hash(a3) != content_hash(a1)
    assert content_hash(a1, {"v": 1}) != content_hash(a1, {"v": 2})
    (tmp_path / "two" / "A" / "t.c3d").write_bytes(b"other bytes")
    assert content_hash(a2) != content_hash(a1)


# ---------------------------------------------------------------- serial, end to end
@pytest.mark.slow
def test_serial_batch_isolates_bad_files_and_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    ds, out = tmp_path / "ds", tmp_path / "out"
    make_subject(ds / "S00", 0)
    make_subject(ds / "S01", 1, ("rom",))
    (ds / "S01" / "broken.c3d").write_bytes(b"not a c3d")
    (ds / "S02").mkdir()
    (ds / "S02" / "only.trc").write_text("garbage\n")  # no readable trial: subject fails

    # Without Ray the batch runs serially and says how to get Ray.
    monkeypatch.setattr("mocap_mj.commands.batch.have_ray", lambda: False)
    rc = main(["batch", str(ds), "--out", str(out), "--json"])
    assert "pip install 'mocap-mj[cluster]'" in capsys.readouterr().err
    assert rc == 1  # failures are reported in the exit status
    rows = {(r["subject"], r["trial"]): r for r in read_summary(out)}
    assert {k: r["status"] for k, r in rows.items()} == {
        ("S00", "rom.csv"): "ok",
        ("S00", "walk.csv"): "ok",
        ("S01", "broken.c3d"): "failed",
        ("S01", "rom.csv"): "ok",
        ("S02", "only.trc"): "failed",
    }
    assert "broken.c3d" in rows["S01", "broken.c3d"]["error"]
    assert "no readable trial" in rows["S02", "only.trc"]["error"]
    for key in [("S00", "rom.csv"), ("S00", "walk.csv"), ("S01", "rom.csv")]:
        # 1 mm per-axis noise: sqrt(3) mm before the fit, less after it
        assert 1.0 < float(rows[key]["ik_rmse_mm"]) < 1.8
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["S00", "S01"]  # no S02
    for trial in ("rom.csv", "walk.csv"):
        assert (out / "S00" / "ik" / trial / "motion.csv").is_file()
    model = out / "S00" / "identify" / "model.xml"
    assert model.is_file()
    report = (out / "report.md").read_text()
    assert "S02" in report and "no readable trial" in report

    # Same command again: nothing is recomputed, the summary is the same.
    stamp = model.stat().st_mtime_ns
    rc = main(["batch", str(ds), "--out", str(out), "--serial", "--json"])
    assert rc == 1
    again = read_summary(out)
    assert {(r["subject"], r["trial"], r["status"]) for r in again} == {
        (k[0], k[1], r["status"]) for k, r in rows.items()
    }
    assert {r["resumed"] for r in again if r["subject"] != "S02"} == {"True"}
    assert model.stat().st_mtime_ns == stamp

    # A changed input redoes that subject only; a fixed subject completes.
    (ds / "S01" / "broken.c3d").unlink()
    (ds / "S02" / "only.trc").unlink()
    make_subject(ds / "S02" / "x", 2, ("rom",))  # (a subfolder is not a trial)
    for f in (ds / "S02" / "x").iterdir():
        f.rename(ds / "S02" / f.name)
    rc = main(["batch", str(ds), "--out", str(out), "--serial", "--json"])
    assert rc == 0
    final = {(r["subject"], r["trial"]): r for r in read_summary(out)}
    assert set(final) == {("S00", "rom.csv"), ("S00", "walk.csv"), ("S01", "rom.csv"),
                          ("S02", "rom.csv")}  # fmt: skip
    assert {k: r["resumed"] for k, r in final.items()} == {
        ("S00", "rom.csv"): "True",
        ("S00", "walk.csv"): "True",
        ("S01", "rom.csv"): "False",
        ("S02", "rom.csv"): "False",
    }
    assert model.stat().st_mtime_ns == stamp
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name != MARKER]


# ---------------------------------------------------------------- a real Ray cluster
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


#: A throw-away local cluster: no token (Ray >= 2.5x asks for one by default).
RAY_ENV = {**os.environ, "RAY_AUTH_MODE": "disabled"}


def _ray(*args: str) -> subprocess.Popen[bytes]:
    """``ray start ... --block`` in its own process group (ours to stop, and only ours)."""
    cmd = [sys.executable, "-c", "from ray.scripts.scripts import main; main()", "start", *args]
    cmd += ["--num-cpus", "1", "--object-store-memory", str(100 * 2**20), "--block"]
    return subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        env=RAY_ENV,
    )  # fmt: skip


def _session_pids(sessions: set[int], title: str = "") -> list[int]:
    """PIDs of processes in our sessions (Ray workers get their own process group, not
    their own session) whose title starts with ``title``."""
    ps = subprocess.run(["ps", "-eo", "pid=,sid=,args="], capture_output=True, text=True)
    pids = []
    for line in ps.stdout.splitlines():
        pid, sid, cmd = [*line.split(None, 2), ""][:3]
        if int(sid) in sessions and cmd.startswith(title):
            pids.append(int(pid))
    return pids


def _stop(procs: list[subprocess.Popen[bytes]]) -> None:
    """Stop the processes of our ``ray start`` sessions, and only those."""
    sessions = {p.pid for p in procs}
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in _session_pids(sessions):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)
        time.sleep(2)
    for p in procs:
        p.wait(timeout=10)


def _listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


@pytest.mark.slow
def test_ray_cluster_survives_a_killed_worker(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the [cluster] extra (ray) is not installed")
    ds, out = tmp_path / "ds", tmp_path / "out"
    for i in range(3):
        make_subject(ds / f"S{i:02d}", i, ("rom",))
    port = _free_port()
    ray_dir = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # short: Unix socket paths <= 107 B
    address = f"127.0.0.1:{port}"
    head = _ray(
        "--head", "--port", str(port), "--node-ip-address", "127.0.0.1",
        "--include-dashboard", "false", "--temp-dir", ray_dir,
    )  # fmt: skip
    procs = [head]
    try:
        deadline = time.monotonic() + 120
        worker = None
        batch = None
        killed: list[int] = []
        while time.monotonic() < deadline:
            if worker is None and _listening(port):  # the head's GCS is up
                worker = _ray("--address", address, "--node-ip-address", "127.0.0.1")
                procs.append(worker)
                batch = subprocess.Popen(
                    [sys.executable, "-m", "mocap_mj", "batch", str(ds), "--out", str(out),
                     "--address", address, "--json"],
                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=RAY_ENV,
                )  # fmt: skip
            if batch is not None and not killed:
                running = _session_pids({p.pid for p in procs}, "ray::execute")
                if running:
                    time.sleep(1.0)  # mid-subject
                    os.kill(running[0], signal.SIGKILL)
                    killed.append(running[0])
            if batch is not None and batch.poll() is not None:
                break
            time.sleep(0.5)
        assert batch is not None, "the Ray head did not start"
        stdout, stderr = batch.communicate(timeout=300)
        assert batch.returncode == 0, stderr.decode()[-2000:]
    finally:
        _stop(procs)
        shutil.rmtree(ray_dir, ignore_errors=True)
    assert killed, "no Ray worker ran a subject (nothing was killed)"
    summary = json.loads(stdout.decode().strip().splitlines()[-1])
    assert summary["ray"] and summary["subjects_done"] == 3 and not summary["subjects_failed"]
    rows = read_summary(out)
    assert [(r["subject"], r["status"]) for r in rows] == [(f"S{i:02d}", "ok") for i in range(3)]
    for i in range(3):
        assert (out / f"S{i:02d}" / "identify" / "model.xml").is_file()
        assert (out / f"S{i:02d}" / "ik" / "rom.csv" / "motion.npz").is_file()
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name != MARKER]
