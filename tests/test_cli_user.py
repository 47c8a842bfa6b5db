"""The command line as a user runs it: progress bars on, no --json, Ctrl-C at any moment.

Each promise: an interrupt is one line and exit status 130 (also while the modules load,
the first second or so), no traceback or "Exception ignored" anywhere, and the README's
commands run as written.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mocap_mj.commands import progress
from mocap_mj.io.plots import held_interrupts, plot_residual_per_marker
from mocap_synth import SynthConfig, synthesize, write_experiment


@pytest.fixture(scope="module")
def markers(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("user")
    write_experiment(synthesize(SynthConfig(frames=40, seed=5)), root / "synth")
    return root / "synth" / "markers.csv"


def _program() -> list[list[str]]:
    """How a user starts the command: the installed script (when on PATH) and ``-m``."""
    script = shutil.which("mocap-mj")
    return ([[script]] if script else []) + [[sys.executable, "-m", "mocap_mj"]]


def _interrupted_run(program: list[str], args: list[str], delay: float) -> tuple[int, str]:
    """Start the command, send SIGINT ``delay`` s after its package began loading; (exit
    status, stderr). The moment is taken from the interpreter's import log
    (``PYTHONPROFILEIMPORTTIME``, its lines left out of the stderr returned): what happens
    before, the interpreter's own start-up, runs no line of mocap-mj."""
    env = {**os.environ, "PYTHONPROFILEIMPORTTIME": "1"}
    proc = subprocess.Popen(
        [*program, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env
    )
    assert proc.stderr is not None
    lines: list[str] = []
    started = threading.Event()

    def drain() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append(line)
            if line.rstrip().endswith("| mocap_mj"):
                started.set()
        started.set()

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    assert started.wait(600)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=600)
    reader.join(timeout=60)
    return proc.returncode, "".join(x for x in lines if not x.startswith("import time:"))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_ctrl_c_while_the_modules_load_is_one_line(
    markers: Path, tmp_path: Path, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    programs = _program()
    for k, delay in enumerate(rng.uniform(0.0, 1.5, size=6)):
        out = tmp_path / f"out{k}"
        args = ["identify", "--markers", str(markers), "--out", str(out)]
        code, err = _interrupted_run(programs[k % len(programs)], args, delay)
        assert "Traceback" not in err and "Exception ignored" not in err, (delay, err)
        if code == 130:
            assert err.strip().splitlines()[-1].endswith(": interrupted"), (delay, err)
            assert not out.exists()
        else:  # the run finished before the signal
            assert code == 0, (delay, code, err)


def test_ctrl_c_inside_a_ctypes_call_is_one_line(
    markers: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    """A Ctrl-C that lands while ctypes converts an argument (MuJoCo's EGL binding calls
    one as it loads) reaches the command line as ctypes's ArgumentError, which keeps only
    the interrupt's text: it is still an interrupt, 130 and one line."""
    import ctypes

    import mocap_mj.commands.identify as identify
    from mocap_mj.cli import main

    class Interrupting:
        @classmethod
        def from_param(cls, value: object) -> object:
            raise KeyboardInterrupt

    call = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int)(lambda value: 0)
    call.argtypes = [Interrupting]
    monkeypatch.setattr(identify, "run", lambda args: call(1))
    out = tmp_path / "out"
    code = main(["identify", "--markers", str(markers), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 130, err
    assert err.strip() == "mocap-mj identify: interrupted"
    assert not out.exists()


@pytest.mark.slow
def test_experiment_paper_as_the_readme_writes_it(tmp_path: Path) -> None:
    """``mocap-mj experiment paper --out DIR`` (here ``--quick``), progress bars on."""
    proc = subprocess.run(
        [sys.executable, "-m", "mocap_mj", "experiment", "paper", "--out", str(tmp_path / "p"),
         "--quick"],
        capture_output=True, text=True, timeout=1200,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr and "on [" not in proc.stderr
    assert (tmp_path / "p" / "summary.json").is_file()


def test_progress_bar_counts_sampled_frames(monkeypatch: pytest.MonkeyPatch) -> None:
    """Algorithm 1's trace entries list their sampled frames; the LM's count them."""
    shown: list[str] = []

    class Bar:
        def __init__(self, **_: object) -> None:
            pass

        def set_postfix_str(self, text: str, refresh: bool = True) -> None:
            shown.append(text)

        def update(self, n: int) -> None:
            pass

        def close(self) -> None:
            pass

    monkeypatch.setattr("tqdm.tqdm", Bar)
    with progress.progress_bar("x") as update:
        assert update is not None
        update(SimpleNamespace(cost=1.0, rmse=0.001, frames=np.array([81])))
        update(SimpleNamespace(cost=1.0, rmse=0.001, frames=np.arange(50)))
        update(SimpleNamespace(cost=1.0, rmse=0.001, frames=500))
    assert [s.split(", ")[0] for s in shown] == [
        "F 1.0000e+00 m^2 on 1 frames",
        "F 1.0000e+00 m^2 on 50 frames",
        "F 1.0000e+00 m^2 on 500 frames",
    ]


def test_ctrl_c_while_a_figure_is_drawn_acts_after_it(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """Matplotlib runs Python callbacks as its objects are freed; an interrupt raised inside
    one is printed as "Exception ignored" and lost. It is held until the figure is written."""
    names = [f"M{i}" for i in range(39)]
    path = tmp_path / "r.png"

    @held_interrupts
    def draw() -> None:
        signal.raise_signal(signal.SIGINT)  # Ctrl-C in the middle of the drawing
        plot_residual_per_marker(path, names, np.linspace(1e-3, 5e-3, 39))

    # Python's own Ctrl-C handler, whatever this process inherited (a shell starts a
    # background job with SIGINT ignored).
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            draw()
        assert path.is_file()  # the figure was completed first
        with pytest.raises(KeyboardInterrupt):
            with_interrupt = held_interrupts(lambda: signal.raise_signal(signal.SIGINT))
            with_interrupt()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, inherited)
    assert "Exception ignored" not in capfd.readouterr().err
