"""How an identification runs, apart from what it identifies: :class:`Tuning` (the solver's
tolerances and performance options) and :class:`Hooks` (what it reports to and writes into
while it runs). Neither changes the problem; both are checked where they enter
(:mod:`mocap_mj.pipeline.arguments`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

from mocap_mj.solve.settings import Performance, Tolerances
from mocap_mj.solve.solver_result import ProgressCallback


class Tuning(NamedTuple):
    """The solver's ``tolerances`` and ``performance`` options (default: theirs); they change
    when the joint LM stops and how it computes, not the problem."""

    tolerances: Tolerances | None = None
    performance: Performance | None = None


class Hooks(NamedTuple):
    """What an identification reports to and writes into while it runs: ``progress`` (each
    LM iteration's trace entry), ``motion_progress`` (the frames done of every frame's
    motion), ``motion_sink`` (a folder for a long recording's motion, chunk by chunk)."""

    progress: ProgressCallback | None = None
    motion_progress: Callable[[int], None] | None = None
    motion_sink: Path | None = None
