"""Fuzzing the readers: damaged files may only ever raise MocapError subclasses."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import ezc3d
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mocap_mj.errors import MocapError
from mocap_mj.io import MarkerTrajectory, load_markers, save_csv, save_trc

_NAMES = ("LFHD", "C7", "LASI", "LANK", "RTOE")


def _trajectory() -> MarkerTrajectory:
    rng = np.random.default_rng(1)
    pos = rng.normal(scale=0.3, size=(4, len(_NAMES), 3)) + np.array([0.0, 0.0, 1.0])
    pos[1, 2] = np.nan
    return MarkerTrajectory(np.arange(4) / 100.0, pos, _NAMES, 100.0, {})


@pytest.fixture(scope="module")
def workdir() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="mocap_mj_fuzz_") as name:
        yield Path(name)


@pytest.fixture(scope="module")
def seeds(workdir: Path) -> dict[str, str]:
    traj = _trajectory()
    save_csv(workdir / "seed.csv", traj)
    save_trc(workdir / "seed.trc", traj)
    nexus = (
        "Trajectories\n100\n,,S:LFHD,,,S:LANK,,\nFrame,Sub Frame,X,Y,Z,X,Y,Z\n"
        ",,mm,mm,mm,mm,mm,mm\n1,0,1,2,1700,4,5,60\n2,0,1,2,1701,,,\n"
    )
    motive = (
        "Format Version,1.23,Export Frame Rate,100.0,Length Units,Millimeters\n\n"
        ",Type,Marker,Marker,Marker,Rigid Body\n,Name,A:LFHD,A:LFHD,A:LFHD,RB\n"
        ",ID,1,1,1,2\n,,Position,Position,Position,Rotation\n"
        "Frame,Time (Seconds),X,Y,Z,X\n0,0.0,1,1700,3,0\n1,0.01,1,1701,,0\n"
    )
    return {
        ".csv": (workdir / "seed.csv").read_text(),
        ".trc": (workdir / "seed.trc").read_text(),
        ".nexus.csv": nexus,
        ".motive.csv": motive,
    }


# Edits to text: (position as a fraction of the length, span, replacement).
_FRAGMENTS = st.sampled_from(
    ["", ",", "\t", "\n", "\r\n", "\r", '"', "x", "-", ".", "e", "nan", "inf", "1e999", "#",
     ":", " ", "0", "9999999", "\x00", "é", "units=furlong", "PathFileType", "Trajectories",
     "Frame"]
)  # fmt: skip
_EDITS = st.lists(
    st.tuples(
        st.floats(0.0, 1.0),
        st.integers(0, 12),
        st.one_of(_FRAGMENTS, st.text(max_size=6)),
    ),
    min_size=1,
    max_size=4,
)


def _mutate(text: str, edits: list[tuple[float, int, str]]) -> str:
    for where, span, new in edits:
        i = int(where * len(text))
        text = text[:i] + new + text[i + span :]
    return text


def _load_expecting_only_mocap_errors(path: Path) -> None:
    try:
        traj = load_markers(path)
    except MocapError as exc:
        message = str(exc)
        assert "\n" not in message
        assert message.startswith(str(path)) or str(path) in message
    else:
        assert isinstance(traj, MarkerTrajectory)
        assert traj.positions.shape == (traj.n_frames, traj.n_markers, 3)


@pytest.mark.parametrize("kind", [".csv", ".trc", ".nexus.csv", ".motive.csv"])
@settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@pytest.mark.slow
@given(edits=_EDITS)
def test_mutated_text_raises_only_mocap_errors(
    workdir: Path, seeds: dict[str, str], kind: str, edits: list[tuple[float, int, str]]
) -> None:
    path = workdir / f"mutant{kind}"
    path.write_text(_mutate(seeds[kind], edits), encoding="utf-8")
    _load_expecting_only_mocap_errors(path)


@pytest.fixture(scope="module")
def c3d_seed(workdir: Path) -> bytes:
    traj = _trajectory()
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = list(traj.names)
    points = np.ones((4, traj.n_markers, traj.n_frames))
    points[:3] = (traj.positions * 1000).transpose(2, 1, 0)
    c3d["data"]["points"] = points
    c3d.write(str(workdir / "seed.c3d"))
    return (workdir / "seed.c3d").read_bytes()


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(cut=st.floats(0.0, 1.0))
def test_truncated_c3d_raises_only_mocap_errors(workdir: Path, c3d_seed: bytes, cut: float) -> None:
    path = workdir / "cut.c3d"
    data = c3d_seed[: int(cut * len(c3d_seed))]
    path.write_bytes(data)
    _load_expecting_only_mocap_errors(path)


@settings(
    max_examples=150,
    deadline=None,
    derandomize=True,  # ezc3d itself is the risk here: keep the examples reproducible
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@pytest.mark.slow
@given(flips=st.lists(st.tuples(st.integers(0, 2047), st.integers(0, 255)), min_size=1, max_size=6))
def test_corrupted_c3d_header_and_parameters_raise_only_mocap_errors(
    workdir: Path, c3d_seed: bytes, flips: list[tuple[int, int]]
) -> None:
    data = bytearray(c3d_seed)
    for where, value in flips:
        data[where % len(data)] = value
    path = workdir / "flipped.c3d"
    path.write_bytes(bytes(data))
    _load_expecting_only_mocap_errors(path)
