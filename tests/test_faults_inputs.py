"""Faults of the inputs a user writes or a command reads back, each class driven by a generator.

1. Hostile YAML (binary, latin-1, nested thousands deep, alias bombs, oversized, syntax
   errors) against every command that reads a YAML file.
2. Hostile numbers (0, 1e-300, inf, NaN, negative, out of range, of another unit) in every
   numeric recipe field, every subject measurement and Plug-in Gait value; malformed
   ``batch --frames``.
3. Corrupted result folders (truncated or foreign model.xml, motion.npz with bad dtypes,
   shapes, non-finite or huge values, bad times, no frames; summary.json and the other JSON
   files truncated or of wrong types) against ``export``, ``score`` and ``render``.
4. Repeated options: refused, or accumulated when the option takes one or more values.
5. A static trial given as the dynamic one and the other way round (``plug-in-gait``).

Every refusal is held to the command line's rule: exit status 2, exactly one line on stderr
shorter than 500 characters naming the file, no traceback, and nothing written. The generators
are derandomised (hypothesis with a fixed seed), so a run is the same run every time.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pytest
import yaml
from _cli import cli
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from mocap_mj.capture.subject import HUMAN_RANGES, MEASUREMENTS, from_yaml
from mocap_mj.clinical.subject import PIG_RANGES, pig_from_yaml
from mocap_mj.commands.registry import build_parser
from mocap_mj.errors import MocapError
from mocap_mj.io.yaml_file import MAX_BYTES, MAX_DEPTH, MAX_VALUES, parse_yaml
from mocap_mj.pipeline.motion import npz_bytes
from mocap_mj.pipeline.recipe import NUMERIC_RANGES, Recipe
from mocap_synth import SynthConfig, synthesize, write_experiment

pytestmark = pytest.mark.slow  # module fixtures run whole identifications

FRAMES = 30
REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
#: Generators are derandomised: the same examples on every run.
FUZZ = settings(
    max_examples=12,
    phases=[Phase.explicit, Phase.generate],  # a failure is reported as found, not shrunk
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


# ------------------------------------------------------------------------------ helpers
def refused(code: int, lines: list[str], *needles: str | Path) -> str:
    """Exit 2 with exactly one stderr line (< 500 characters) holding one of the needles."""
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert len(lines[0]) < 500, lines[0][:600]
    assert any(str(n) in lines[0] for n in needles), (needles, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def data() -> Iterator[dict[str, Path]]:
    """A synthetic trial (``synth``: markers.csv and its truth) and its identification
    (``result``), made once for the module."""
    with tempfile.TemporaryDirectory(prefix="mocap_mj_faults_") as name:
        root = Path(name)
        write_experiment(synthesize(SynthConfig(frames=FRAMES, seed=3)), root / "synth")
        result = root / "result"
        proc = subprocess.run(
            [sys.executable, "-m", "mocap_mj", "identify", "--markers",
             str(root / "synth" / "markers.csv"), "--out", str(result)],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        dataset = root / "dataset" / "S01"
        dataset.mkdir(parents=True)
        shutil.copy(root / "synth" / "markers.csv", dataset / "walk.csv")
        yield {"root": root, "synth": root / "synth", "result": result,
               "markers": root / "synth" / "markers.csv", "dataset": dataset.parent}  # fmt: skip


# ----------------------------------------------------------- 1. hostile YAML documents
def _laughs(levels: int, width: int) -> str:
    """A billion-laughs document: ``width ** levels`` values through aliases."""
    lines = ["l0: &l0 [" + ", ".join(["lol"] * width) + "]"]
    for k in range(1, levels + 1):
        lines.append(f"l{k}: &l{k} [" + ", ".join([f"*l{k - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


_SYNTAX = [
    "a: [1, 2\n", "a: {b: 1\n", "a: 'open\n", "a:\n\t- 1\n", "a: b: c\n", "- a\nb: c\n",
    "*nowhere\n", "a: !!python/object:os.system x\n", "a: &x 1\nb: &x 2\nc: *y\n", "a: @b\n",
    "? [a, b]\n: c\n", "a: 1\n a: 2\n", "%YAML 9.9\n---\na: 1\n", "a: \x01\n", "&r [*r]\n",
]  # fmt: skip


@dataclass(frozen=True)
class Hostile:
    """A YAML file the loader must refuse: its kind and what makes it (short, for a repr);
    ``content`` builds its bytes."""

    kind: str
    detail: Any

    @property
    def content(self) -> bytes:
        kind, detail = self.kind, self.detail
        if kind in ("binary", "syntax", "latin-1", "bom-bad"):
            return detail if isinstance(detail, bytes) else str(detail).encode()
        if kind == "oversized":
            return b"# padding\n" * (detail // 10 + 1)
        if kind == "laughs":
            return _laughs(*detail).encode()
        depth, style = detail
        if style == "flow-list":
            return ("[" * depth + "]" * depth).encode()
        if style == "flow-map":
            return ("{a: " * depth + "1" + "}" * depth).encode()
        return "".join("  " * i + "- \n" for i in range(depth)).encode()


@st.composite
def hostile_yaml(draw: st.DrawFn) -> Hostile:
    """A YAML file the loader must refuse: binary, latin-1, nested deeper than the limit, an
    alias bomb, oversized, or a syntax error after some good lines."""
    kind = draw(
        st.sampled_from(["binary", "latin-1", "deep", "laughs", "syntax", "oversized", "bom-bad"])
    )
    if kind == "binary":
        return Hostile(kind, draw(st.binary(max_size=32)) + b"\x00" + draw(st.binary(max_size=32)))
    if kind == "latin-1":
        word = draw(st.text(st.characters(min_codepoint=0xC0, max_codepoint=0xFF), min_size=1))
        return Hostile(kind, f"name: {word}\nheight: 1.7\n".encode("latin-1"))
    if kind == "deep":
        style = draw(st.sampled_from(["flow-list", "flow-map", "block"]))
        top = 3000 if style == "block" else 10_000  # indented: the file grows as depth squared
        return Hostile(kind, (draw(st.integers(MAX_DEPTH + 1, top)), style))
    if kind == "laughs":
        width = draw(st.integers(5, 12))
        levels = draw(st.integers(math.ceil(math.log(MAX_VALUES + 1, width)) + 1, 14))
        return Hostile(kind, (levels, width))
    if kind == "oversized":
        return Hostile(kind, draw(st.integers(MAX_BYTES + 1, 2 * MAX_BYTES)))
    if kind == "bom-bad":
        return Hostile(kind, b"\xef\xbb\xbfname: caf\xe9\n")
    prefix = draw(st.lists(st.from_regex(r"[a-z]{1,8}: [0-9]{1,4}\n", fullmatch=True), max_size=5))
    return Hostile(kind, "".join(prefix) + draw(st.sampled_from(_SYNTAX)))


#: Each command that reads a YAML file: argv given the hostile file and the module's data.
YAML_COMMANDS: dict[str, Callable[[Path, dict[str, Path], Path], list[str | Path]]] = {
    "identify --recipe": lambda f, d, o: ["identify", "--markers", d["markers"], "--recipe", f,
                                          "--out", o],
    "identify --subject-file": lambda f, d, o: ["identify", "--markers", d["markers"],
                                                "--subject-file", f, "--out", o],
    "identify --marker-set": lambda f, d, o: ["identify", "--markers", d["markers"],
                                              "--marker-set", f, "--out", o],
    "identify --marker-map": lambda f, d, o: ["identify", "--markers", d["markers"],
                                              "--marker-map", f, "--out", o],
    "ik --marker-map": lambda f, d, o: ["ik", "--markers", d["markers"], "--marker-map", f,
                                        "--out", o],
    "batch manifest": lambda f, d, o: ["batch", f, "--out", o, "--serial"],
    "batch --recipe": lambda f, d, o: ["batch", d["dataset"], "--recipe", f, "--out", o,
                                       "--serial"],
    "plug-in-gait --subject-file": lambda f, d, o: ["plug-in-gait", "--markers", d["markers"],
                                                    "--subject-file", f, "--out", o],
    "marker-sets --marker-set": lambda f, d, o: ["marker-sets", "--check", d["markers"],
                                                 "--marker-set", f],
    "marker-sets --marker-map": lambda f, d, o: ["marker-sets", "--check", d["markers"],
                                                 "--marker-map", f],
}  # fmt: skip


@pytest.mark.parametrize("command", sorted(YAML_COMMANDS))
@FUZZ
@given(doc=hostile_yaml())
def test_hostile_yaml_is_one_line_and_exit_2(
    command: str, doc: Hostile, data: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    kind, content = doc.kind, doc.content
    work = data["root"] / "yaml"
    work.mkdir(exist_ok=True)
    path = work / "hostile.yaml"
    path.write_bytes(content)
    out = work / "out"
    code, lines = cli(capsys, *YAML_COMMANDS[command](path, data, out))
    line = refused(code, lines, path)
    assert not out.exists(), kind
    assert path.read_bytes() == content  # never changed
    if kind == "syntax" and "offset" not in line:
        assert "line " in line and ", column " in line, line


@FUZZ
@given(doc=hostile_yaml())
def test_the_loader_refuses_what_the_commands_refuse(doc: Hostile) -> None:
    """The same documents straight through :func:`parse_yaml` (the text ones): one line."""
    kind, content = doc.kind, doc.content
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError:
        return  # read_text refuses it (the commands' test above)
    if "\x00" in text or len(content) > MAX_BYTES:
        return
    with pytest.raises(MocapError) as info:
        parse_yaml(text, "doc.yaml", "recipe")
    message = str(info.value)
    assert "\n" not in message and len(message) < 500 and message.startswith("doc.yaml: "), kind


def test_good_yaml_with_aliases_is_read() -> None:
    """The guards refuse hostile documents only: shared options through an alias are fine."""
    doc = "opts: &o {frames: '0:10', up: z}\na: *o\nb: {<<: *o, up: y}\n"
    assert parse_yaml(doc, "m.yaml", "manifest") == {
        "opts": {"frames": "0:10", "up": "z"},
        "a": {"frames": "0:10", "up": "z"},
        "b": {"frames": "0:10", "up": "y"},
    }
    nested = "[" * MAX_DEPTH + "]" * MAX_DEPTH
    assert parse_yaml(nested, "m.yaml", "manifest") is not None


# ------------------------------------------------------------- 2. hostile numbers
_HOSTILE = [0, 0.0, 1e-300, -1e-300, math.inf, -math.inf, math.nan, -1, -0.5, 1e300, 10**12,
            True, "3", [1.0]]  # fmt: skip


@st.composite
def hostile_recipe_value(draw: st.DrawFn) -> tuple[str, Any]:
    """(recipe field, a value outside its range or of another kind)."""
    name = draw(st.sampled_from(sorted(NUMERIC_RANGES)))
    low, high, _ = NUMERIC_RANGES[name]
    value = draw(
        st.one_of(
            st.sampled_from(_HOSTILE),
            st.floats(max_value=low, exclude_max=True, allow_nan=False),
            st.floats(min_value=high, exclude_min=True),
        )
    )
    return name, value


@settings(FUZZ, max_examples=200)
@given(case=hostile_recipe_value())
def test_recipe_numbers_out_of_range_are_refused_naming_the_field(case: tuple[str, Any]) -> None:
    name, value = case
    with pytest.raises(MocapError) as info:
        Recipe.from_dict({name: value}, source="r.yaml")
    message = str(info.value)
    assert message.startswith("r.yaml: ") and name in message and "\n" not in message, message
    assert len(message) < 500


@pytest.mark.parametrize("name", sorted(NUMERIC_RANGES))
def test_recipe_numbers_within_range_are_kept(name: str) -> None:
    low, high, _ = NUMERIC_RANGES[name]
    for value in (low, high, math.sqrt(low * high)):
        if name in ("max_iterations", "select"):
            value = round(value)
        assert getattr(Recipe.from_dict({name: value}), name) == value


@FUZZ
@given(case=hostile_recipe_value())
def test_a_hostile_recipe_number_through_identify(
    case: tuple[str, Any], data: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    name, value = case
    work = data["root"] / "numbers"
    work.mkdir(exist_ok=True)
    path = work / "recipe.yaml"
    path.write_text(yaml.safe_dump({name: value}))
    out = work / "out"
    code, lines = cli(capsys, "identify", "--markers", data["markers"], "--recipe", path,
                      "--out", out)  # fmt: skip
    line = refused(code, lines, path)
    assert name in line
    assert not out.exists()


@FUZZ
@given(
    frames=st.one_of(
        st.sampled_from(["abc", "1", "1:2:3", "a:b", "1.5:3", "0:10:2", "--1", "0;10"]),
        st.from_regex(r"[a-z]{1,6}(:[a-z0-9]{0,3})?", fullmatch=True),
    )
)
def test_batch_refuses_bad_frames_before_any_subject(
    frames: str, data: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    out = data["root"] / "batch-frames"
    code, lines = cli(capsys, "batch", data["dataset"], f"--frames={frames}", "--out", out,
                      "--serial")  # fmt: skip
    refused(code, lines, "--frames")
    assert not out.exists()


@st.composite
def hostile_measurement(draw: st.DrawFn) -> tuple[str, Any]:
    """(measurement, a YAML value no person has: out of range, NaN, inf, a unit of another
    kind)."""
    name = draw(st.sampled_from(sorted(MEASUREMENTS)))
    low, high = HUMAN_RANGES[name]
    unit = MEASUREMENTS[name][0]
    wrong_unit = "mm" if unit == "kg" else "kg"
    return name, draw(
        st.one_of(
            st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e300]),
            st.floats(0, low, exclude_max=True),
            st.floats(high, 1e6, exclude_min=True),
            st.floats(low, high).map(lambda v: f"{v:.6g} {wrong_unit}"),
            st.sampled_from(["tall", "1.7 furlong", "nan mm"]),
        )
    )


@settings(FUZZ, max_examples=150)
@given(case=hostile_measurement())
def test_subject_measurements_no_person_has_are_refused(case: tuple[str, Any]) -> None:
    name, value = case
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "subject.yaml"
        path.write_text(yaml.safe_dump({name: value}))
        with pytest.raises(MocapError) as info:
            from_yaml(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message and len(message) < 500
    named = name in message or MEASUREMENTS[name][1] in message
    assert named, message


@pytest.mark.parametrize("name", sorted(MEASUREMENTS))
def test_subject_measurements_of_a_person_are_kept(name: str, tmp_path: Path) -> None:
    low, high = HUMAN_RANGES[name]
    value = math.sqrt(low * high)
    unit = "kg" if MEASUREMENTS[name][0] == "kg" else "mm"
    given = f"{value:.6g} kg" if unit == "kg" else f"{value * 1e3:.6g} mm"
    path = tmp_path / "subject.yaml"
    path.write_text(yaml.safe_dump({name: given}))
    assert from_yaml(path).get(name) == pytest.approx(value, rel=1e-5)


@pytest.mark.parametrize("value", [14.5, "100 mm", math.nan, "300 deg", -2.0, "14.5 kg"], ids=str)
@pytest.mark.parametrize("name", sorted(PIG_RANGES))
def test_plug_in_gait_values_out_of_range_are_refused(
    name: str, value: Any, tmp_path: Path
) -> None:
    path = tmp_path / "pig.yaml"
    path.write_text(yaml.safe_dump({name: value}))
    with pytest.raises(MocapError) as info:
        pig_from_yaml(path)
    assert str(info.value).startswith(f"{path}: ") and name in str(info.value)


def test_plug_in_gait_values_in_degrees_are_kept(tmp_path: Path) -> None:
    path = tmp_path / "pig.yaml"
    path.write_text("static_plantar_flex_l: 14.5 deg\ntibial_torsion_r: 0.2\n")
    subject = pig_from_yaml(path)
    assert subject.pig("static_plantar_flex_l") == pytest.approx(math.radians(14.5))
    assert subject.pig("tibial_torsion_r") == pytest.approx(0.2)


# ------------------------------------------------------- 3. corrupted result folders
def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as d:
        return {k: d[k] for k in d.files}


@st.composite
def motion_fault(draw: st.DrawFn, good: dict[str, np.ndarray]) -> tuple[str, bytes]:
    """(what was done, the bytes of a damaged motion.npz) made from ``good``'s arrays (the
    root's free joint first: its quaternion in qpos columns 3-6)."""
    a = {k: v.copy() for k, v in good.items()}
    n = len(a["times"])
    kind = draw(
        st.sampled_from(
            ["nan-partial", "inf", "huge", "dtype", "rows", "cols", "times-const",
             "times-decreasing", "times-nan", "no-frames", "no-solved-frame", "names",
             "first-frame", "missing", "quaternion"]
        )
    )  # fmt: skip
    key = draw(st.sampled_from(["qpos", "markers"]))
    row = draw(st.integers(0, n - 1))
    if kind == "nan-partial":
        a["qpos"][row, draw(st.integers(0, a["qpos"].shape[1] - 1))] = np.nan
    elif kind == "inf":
        a[key][row].flat[0] = draw(st.sampled_from([np.inf, -np.inf]))
    elif kind == "huge":
        a[key] = a[key] * draw(st.sampled_from([1e30, 1e6, -1e9]))
    elif kind == "dtype":
        a[key] = a[key].astype(draw(st.sampled_from(["U32", "complex128", "bool"])))
    elif kind == "rows":
        a[key] = a[key][: draw(st.integers(0, n - 1))]
    elif kind == "cols":
        columns = a["qpos"].shape[1]
        a["qpos"] = a["qpos"][:, : draw(st.sampled_from([0, 1, 7, columns - 1]))]
    elif kind == "times-const":
        a["times"] = np.full(n, draw(st.floats(0, 100)))
    elif kind == "times-decreasing":
        a["times"] = a["times"][::-1].copy()
    elif kind == "times-nan":
        a["times"][row] = np.nan
    elif kind == "no-frames":
        a["qpos"], a["times"], a["markers"] = a["qpos"][:0], a["times"][:0], a["markers"][:0]
    elif kind == "no-solved-frame":
        a["qpos"][:] = np.nan
    elif kind == "names":
        a["marker_names"] = np.arange(len(a["marker_names"]))
    elif kind == "first-frame":
        a["first_frame"] = np.array(draw(st.sampled_from([-1, 1.5, "ten"])))
    elif kind == "missing":
        del a[draw(st.sampled_from(["qpos", "times", "markers", "marker_names"]))]
    else:
        a["qpos"][row, 3:7] *= draw(st.sampled_from([0.0, 2.0, 1.01]))
    return kind, npz_bytes(a)


class Fault(NamedTuple):
    """A damaged file of a result folder: its name, what was done, its bytes (not shown)."""

    name: str
    how: str
    content: bytes

    def __repr__(self) -> str:
        return f"Fault({self.name!r}, {self.how!r}, {len(self.content)} bytes)"


def _truncated(raw: bytes, fraction: float) -> bytes:
    return raw[: int(len(raw) * fraction)]


@st.composite
def folder_fault(draw: st.DrawFn, folder: Path, reads: tuple[str, ...]) -> Fault:
    """(file, what was done, its damaged bytes) for one of the files ``reads`` of ``folder``."""
    name = draw(st.sampled_from(reads))
    raw = (folder / name).read_bytes()
    cut = draw(st.floats(0.0, 0.95))
    if name.endswith(".npz"):
        how = draw(st.sampled_from(["truncated", "arrays"]))
        if how == "truncated":
            return Fault(name, "truncated", _truncated(raw, cut))
        kind, content = draw(motion_fault(_arrays(folder / name)))
        return Fault(name, kind, content)
    if name.endswith(".xml"):
        how = draw(st.sampled_from(["truncated", "other model", "binary"]))
        if how == "truncated":
            return Fault(name, how, _truncated(raw, cut))
        if how == "binary":
            return Fault(name, how, b"\x00\x01\xff" * draw(st.integers(1, 100)))
        other = (
            '<mujoco><worldbody><body name="b"><freejoint/><geom size="0.1"/>'
            '<site name="s"/></body></worldbody></mujoco>'
        )
        return Fault(name, how, other.encode())
    how = draw(st.sampled_from(["truncated", "wrong types", "not an object"]))
    if how == "truncated":
        return Fault(name, how, _truncated(raw, cut))
    if how == "not an object":
        return Fault(name, how, draw(st.sampled_from([b"[]", b"1", b'"x"', b"null"])))
    value = draw(st.sampled_from(["x", [1], None, 1e30, True]))
    return Fault(name, how, json.dumps(dict.fromkeys(json.loads(raw), value)).encode())


def _render(result: Path) -> subprocess.CompletedProcess[str]:
    """``render`` of frame 0 of ``result`` in its own process, offscreen (MUJOCO_GL=egl unless
    set: the platform is chosen when MuJoCo's renderer first loads)."""
    gl = os.environ.get("MUJOCO_GL", "egl")
    env = {**os.environ, "MUJOCO_GL": gl, "PYOPENGL_PLATFORM": gl}
    with tempfile.TemporaryDirectory() as folder:
        return subprocess.run(
            [sys.executable, "-m", "mocap_mj", "render", str(result), "--frame", "0",
             "--out", str(Path(folder) / "x.png")],
            capture_output=True, text=True, timeout=300, env=env,
        )  # fmt: skip


def _render_runs(result: Path) -> bool:
    """Whether ``render`` works here on the good result; False only when no OpenGL context
    opens (any other failure fails the calling test)."""
    proc = _render(result)
    if proc.returncode != 0:
        assert "cannot render" in proc.stderr, proc.stderr
    return proc.returncode == 0


#: Each command reading a result folder: (the folder damaged, "result" or the synthetic truth
#: "synth"; the files of it the command reads; argv given the result, the truth and an output
#: folder).
RESULT_COMMANDS: dict[
    str, tuple[str, tuple[str, ...], Callable[[Path, Path, Path], list[Any]]]
] = {
    "export mot": ("result", ("model.xml", "motion.npz", "summary.json"),
                   lambda r, s, o: ["export", r, "--to", "mot", "--out", o / "x.mot"]),
    "export trc": ("result", ("model.xml", "motion.npz", "summary.json"),
                   lambda r, s, o: ["export", r, "--to", "trc", "--out", o / "x.trc"]),
    "export c3d": ("result", ("model.xml", "motion.npz", "summary.json"),
                   lambda r, s, o: ["export", r, "--to", "c3d", "--out", o / "x.c3d"]),
    "score": ("result", ("motion.npz", "summary.json", "theta.json", "identifiability.json"),
              lambda r, s, o: ["score", "--truth", s, "--result", r]),
    "score truth": ("synth", ("truth.json", "truth_motion.npz"),
                    lambda r, s, o: ["score", "--truth", s, "--result", r]),
    "render": ("result", ("model.xml", "motion.npz"),
               lambda r, s, o: ["render", r, "--frame", "0", "--out", o / "x.png"]),
}  # fmt: skip


@pytest.mark.parametrize("command", sorted(RESULT_COMMANDS))
def test_corrupted_result_folders_are_refused(
    command: str, data: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    damaged, reads, argv = RESULT_COMMANDS[command]
    if command == "render":
        if not _render_runs(data["result"]):
            pytest.skip("render cannot open an OpenGL context here (MUJOCO_GL=egl)")
    work = data["root"] / "corrupt"

    @FUZZ
    @given(fault=folder_fault(data[damaged], reads))
    def check(fault: Fault) -> None:
        name, how, content = fault.name, fault.how, fault.content
        shutil.rmtree(work, ignore_errors=True)
        result, truth = work / "result", work / "synth"
        shutil.copytree(data["result"], result)
        shutil.copytree(data["synth"], truth)
        (work / damaged / name).write_bytes(content)
        out = work / "out"
        out.mkdir()
        code, lines = cli(capsys, *argv(result, truth, out))
        line = refused(code, lines, work / damaged / name)
        if how == "other model":  # named beside the motion that does not fit it
            assert str(result / "motion.npz") in line, line
        assert list(out.iterdir()) == [], how
        assert not (result / "score.json").exists(), how

    check()


@pytest.mark.parametrize("command", sorted(RESULT_COMMANDS))
def test_the_good_result_folder_is_read(
    command: str, data: dict[str, Path], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """The control: the folder the faults are made from passes every command (render in its
    own process, which chooses the OpenGL platform)."""
    if command == "render":
        if not _render_runs(data["result"]):
            pytest.skip("render cannot open an OpenGL context here (MUJOCO_GL=egl)")
        return
    result = tmp_path / "result"
    shutil.copytree(data["result"], result)
    out = tmp_path / "out"
    out.mkdir()
    code, lines = cli(capsys, *RESULT_COMMANDS[command][2](result, data["synth"], out))
    assert code == 0, lines


# --------------------------------------------------------------- 4. repeated options
def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _value(action: argparse.Action) -> str:
    """A value ``action`` accepts."""
    if action.choices:
        return str(next(iter(action.choices)))
    for candidate in ("1", "0:10", "640x480", "x", "a.yaml", "1.75m"):
        try:
            convert = action.type
            if convert is None or (callable(convert) and convert(candidate) is not None):
                return candidate
        except (ValueError, TypeError, argparse.ArgumentTypeError, MocapError):
            continue
    pytest.fail(f"no value for {action.option_strings}")


def _store_options() -> list[tuple[str, argparse.Action]]:
    out = []
    for command, parser in sorted(_subparsers().items()):
        for action in parser._actions:
            if action.option_strings and type(action).__name__ == "_StoreOnce":
                out.append((command, action))
    return out


STORE_OPTIONS = _store_options()


def test_every_plain_option_is_guarded() -> None:
    """Every command's value options go through the guard (no option escapes it)."""
    plain = [
        (c, a.option_strings[0])
        for c, p in _subparsers().items()
        for a in p._actions
        if a.option_strings and type(a) is argparse._StoreAction
    ]
    assert plain == []
    assert len(STORE_OPTIONS) > 40


@pytest.mark.parametrize(
    "command,action", STORE_OPTIONS, ids=[f"{c} {a.option_strings[0]}" for c, a in STORE_OPTIONS]
)
def test_a_repeated_option_is_refused_or_accumulates(
    command: str, action: argparse.Action, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = _subparsers()[command]
    flag, value = action.option_strings[0], _value(action)
    if action.nargs in ("+", "*"):
        others = [
            part
            for a in parser._actions
            if a.required and a.option_strings and a.dest != action.dest
            for part in (a.option_strings[0], _value(a))
        ]
        args, _ = parser.parse_known_args([*others, flag, value, flag, value, value])
        assert getattr(args, action.dest) == [action.type(value) if action.type else value] * 3
        return
    with pytest.raises(SystemExit) as info:
        parser.parse_known_args([flag, value, flag, value])
    assert info.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"argument {'/'.join(action.option_strings)}: given twice" in last, last


def test_identify_markers_twice_fits_both_trials(
    data: dict[str, Path], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    shutil.copy(data["markers"], first)
    shutil.copy(data["markers"], second)
    out = tmp_path / "out"
    code, lines = cli(capsys, "identify", "--markers", first, "--markers", second, "--out", out,
                      "--recipe", _fast_recipe(tmp_path))  # fmt: skip
    assert code == 0, lines
    summary = json.loads((out / "summary.json").read_text())
    named = json.dumps(summary)
    assert str(first) in named and str(second) in named


def _fast_recipe(folder: Path) -> Path:
    path = folder / "fast.yaml"
    path.write_text("max_iterations: 3\nrefine: false\n")
    return path


# ------------------------------------------------------ 5. static and walk swapped
STATIC, WALK = REAL / "Static_trial.c3d", REAL / "Movement_trial.c3d"
needs_real = pytest.mark.skipif(
    not (STATIC.is_file() and WALK.is_file()), reason=f"shared Vicon trials absent from {REAL}"
)


@needs_real
@pytest.mark.parametrize(
    "markers,static,words",
    [(STATIC, WALK, "swapped"), (WALK, WALK, "expected a standing trial")],
    ids=["swapped", "walk-as-static"],
)
def test_plug_in_gait_refuses_a_moving_static(
    markers: Path, static: Path, words: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    code, lines = cli(capsys, "plug-in-gait", "--markers", markers, "--static", static,
                      "--out", out)  # fmt: skip
    line = refused(code, lines, static)
    assert str(markers) in line and words in line
    assert not out.exists()


@needs_real
def test_plug_in_gait_takes_the_walk_with_its_static(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    code, lines = cli(capsys, "plug-in-gait", "--markers", WALK, "--static", STATIC, "--out", out)
    assert code == 0, lines
    assert (out / "angles.csv").is_file()
