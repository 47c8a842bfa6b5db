"""Bad input on the command line: exit status, one line on stderr, no traceback, no result.

Each case runs ``python -m mocap_mj`` in a subprocess on one small synthetic trial shared by
the module (40 frames). Every refusal must leave ``--out`` absent: nothing that looks like a
result.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mocap_mj.errors import MocapError
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv
from mocap_synth import SynthConfig, synthesize, write_experiment

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

FRAMES = 40


def run(*args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mocap_mj", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def stderr_lines(proc: subprocess.CompletedProcess[str]) -> list[str]:
    """stderr without notices unrelated to the case (add-ons, the one-time compile notice)."""
    return [
        line
        for line in proc.stderr.splitlines()
        if line.strip()
        and not line.startswith("mocap-mj: command ")
        and not line.startswith("mocap-mj: compiling")
    ]


def assert_refused(proc: subprocess.CompletedProcess[str], out: Path, *needles: str) -> str:
    """Exit 2, exactly one stderr line containing every needle, no traceback, no ``out``."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = stderr_lines(proc)
    assert len(lines) == 1, lines
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert not out.exists()
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]
    return lines[0]


def strict_json(text: str) -> Any:
    def refuse(name: str) -> None:
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("cli")
    write_experiment(synthesize(SynthConfig(frames=FRAMES, seed=3)), root / "synth")
    traj = load_markers(root / "synth" / "markers.csv")
    nan = MarkerTrajectory(traj.times, np.full_like(traj.positions, np.nan), traj.names, traj.rate)
    save_csv(root / "all_nan.csv", nan)
    three = MarkerTrajectory(traj.times, traj.positions[:, :3], traj.names[:3], traj.rate)
    save_csv(root / "three.csv", three)
    (root / "bad.xml").write_text(
        '<mujoco>\n<worldbody>\n<body name="a">\n<geom size="0.1"/>\n'
        '<joint type="bogus"/>\n</body>\n</worldbody>\n</mujoco>\n'
    )
    return {
        "root": root,
        "synth": root / "synth",
        "markers": root / "synth" / "markers.csv",
        "all_nan": root / "all_nan.csv",
        "three": root / "three.csv",
        "bad_xml": root / "bad.xml",
    }


@pytest.mark.parametrize("command", ["ik", "identify"])
@pytest.mark.parametrize(
    ("case", "needle"),
    [("all_nan", "all NaN"), ("three", "only 3 of the model's 39 markers")],
)
def test_markers_a_solver_cannot_use(
    data: dict[str, Path], tmp_path: Path, command: str, case: str, needle: str
) -> None:
    out = tmp_path / "out"
    proc = run(command, "--markers", str(data[case]), "--out", str(out))
    assert_refused(proc, out, str(data[case]), needle, "--min-markers")


def test_identify_refuses_one_frame(data: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = run("identify", "--markers", str(data["markers"]), "--frames", "0:1", "--out", str(out))
    # 1 frame: 39 markers x 3 = 117 coordinates for 46 joint dofs (the toes carry no marker)
    # + 151 parameters.
    assert_refused(proc, out, str(data["markers"]), "117 marker coordinates", "197 unknowns")


def test_malformed_mjcf_keeps_mujocos_line_and_element(
    data: dict[str, Path], tmp_path: Path
) -> None:
    out = tmp_path / "out"
    proc = run("ik", "--markers", str(data["markers"]), "--model", str(data["bad_xml"]),
               "--out", str(out))  # fmt: skip
    assert_refused(proc, out, str(data["bad_xml"]), "bogus", "Element 'joint'", "line 5")


@pytest.mark.parametrize("kind", ["under_a_file", "is_a_file"])
def test_unwritable_out_is_refused_before_the_work(
    data: dict[str, Path], tmp_path: Path, kind: str
) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x")
    out = afile / "out" if kind == "under_a_file" else afile
    proc = run("identify", "--markers", str(data["markers"]), "--out", str(out))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = stderr_lines(proc)
    assert len(lines) == 1 and str(out) in lines[0] and "--out" in lines[0], lines
    assert afile.read_text() == "x"


def test_read_only_out_is_refused(data: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "ro"
    out.mkdir()
    out.chmod(0o555)
    try:
        if _writable(out):
            pytest.skip("this user can write into read-only folders (root)")
        proc = run("identify", "--markers", str(data["markers"]), "--out", str(out))
        assert proc.returncode == 2 and "Traceback" not in proc.stderr
        lines = stderr_lines(proc)
        assert len(lines) == 1 and "read-only" in lines[0], lines
        assert list(out.iterdir()) == []
    finally:
        out.chmod(0o755)


def _writable(folder: Path) -> bool:
    try:
        (folder / "probe").write_text("")
    except OSError:
        return False
    (folder / "probe").unlink()
    return True


@pytest.fixture(scope="module")
def result(data: dict[str, Path]) -> Path:
    """An identification of the shared trial (strict JSON checked on the way)."""
    out = data["root"] / "result"
    proc = run("identify", "--markers", str(data["markers"]), "--out", str(out), "--json")
    assert proc.returncode == 0, proc.stderr
    assert strict_json(proc.stdout) == strict_json((out / "summary.json").read_text())
    strict_json((out / "identifiability.json").read_text())
    return out


def test_ik_summary_is_strict_json_and_names_missing_markers(
    data: dict[str, Path], tmp_path: Path
) -> None:
    traj = load_markers(data["markers"])
    pos = traj.positions.copy()
    pos[:, 0] = np.nan  # one marker never seen
    pos[: FRAMES // 2, :] = np.nan  # half the frames without any marker
    save_csv(tmp_path / "half.csv", MarkerTrajectory(traj.times, pos, traj.names, traj.rate))
    out = tmp_path / "out"
    proc = run("ik", "--markers", str(tmp_path / "half.csv"), "--out", str(out), "--json")
    assert proc.returncode == 0, proc.stderr
    summary = strict_json((out / "summary.json").read_text())
    assert summary["frames_solved"] == FRAMES - FRAMES // 2
    assert summary["frames_skipped"] == list(range(FRAMES // 2))
    assert summary["markers_without_data"] == [traj.names[0]]
    assert strict_json(proc.stdout) == summary


def test_score_refuses_a_truth_of_another_length(data: dict[str, Path], result: Path) -> None:
    shorter = data["root"] / "shorter"
    write_experiment(synthesize(SynthConfig(frames=FRAMES // 2, seed=3)), shorter)
    proc = run("score", "--truth", str(shorter), "--result", str(result))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = stderr_lines(proc)
    assert len(lines) == 1 and f"has {FRAMES} frames" in lines[0], lines
    assert not (result / "score.json").exists()


def test_score_refuses_another_subject(data: dict[str, Path], result: Path) -> None:
    other = data["root"] / "other"
    write_experiment(synthesize(SynthConfig(frames=FRAMES, seed=4)), other)
    proc = run("score", "--truth", str(other), "--result", str(result))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = stderr_lines(proc)
    assert len(lines) == 1 and "different subject or trial" in lines[0], lines
    assert not (result / "score.json").exists()


def test_score_of_its_own_truth_is_strict_json(data: dict[str, Path], result: Path) -> None:
    proc = run("score", "--truth", str(data["synth"]), "--result", str(result), "--json")
    assert proc.returncode == 0, proc.stderr
    assert strict_json(proc.stdout)["frames_fitted"] == FRAMES
    strict_json((result / "score.json").read_text())


def test_demo_folder_opens_as_its_result_with_truth_ghost(
    data: dict[str, Path], result: Path, tmp_path: Path
) -> None:
    from mocap_viewer.playback import load_ghost, load_playback

    demo = tmp_path / "demo-result"
    shutil.copytree(result, demo / "result")
    shutil.copytree(data["synth"], demo / "synth")
    for folder in (demo, demo / "result"):  # docs/viewer.md: `view out/demo --ghost truth`
        playback = load_playback(folder)
        assert Path(playback.source) == demo / "result"
        ghost = load_ghost("truth", playback.model, folder)
        assert ghost.path == demo / "synth" / "truth_model.xml"
    (demo / "result" / "motion.npz").unlink()
    with pytest.raises(MocapError, match="demo folder's result/"):
        load_playback(demo)
