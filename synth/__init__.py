"""mocap_synth: ground-truth experiments (perturbed model, motion, noise) built on mocap_mj.

Build an experiment from its settings and write it to a folder::

    from mocap_synth import SynthConfig, synthesize, write_experiment

    exp = synthesize(SynthConfig(frames=500, rate=100.0, motion="rom", noise_mm=1.0, seed=0))
    write_experiment(exp, "out/synth")

The parts: :mod:`~mocap_synth.config` (settings), :mod:`~mocap_synth.perturb` (truth model),
:mod:`~mocap_synth.motion` (truth-motion presets), :mod:`~mocap_synth.postures` (the pose a
trial holds or starts in, its heading), :mod:`~mocap_synth.noise` (measurement model),
:mod:`~mocap_synth.experiment` (putting them together, files), :mod:`~mocap_synth.cli`
(``mocap-mj synth``). This package imports ``mocap_mj``; ``mocap_mj`` never imports it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .config import MOTIONS, POSES, ConfigError, SynthConfig

if TYPE_CHECKING:
    from . import motion
    from .experiment import FILES, Experiment, summarize, synthesize, write_experiment
    from .perturb import perturb_theta

#: The names imported on first use (PEP 562): the command line's ``--help`` loads the
#: package (its parsers in :mod:`~mocap_synth.cli`) without NumPy or MuJoCo.
_LAZY = {
    "FILES": ".experiment",
    "Experiment": ".experiment",
    "summarize": ".experiment",
    "synthesize": ".experiment",
    "write_experiment": ".experiment",
    "perturb_theta": ".perturb",
}


def __getattr__(name: str) -> Any:
    if name == "motion":
        value: Any = importlib.import_module(".motion", __name__)
    elif name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


__all__ = [
    "FILES",
    "MOTIONS",
    "POSES",
    "ConfigError",
    "Experiment",
    "SynthConfig",
    "motion",
    "perturb_theta",
    "summarize",
    "synthesize",
    "write_experiment",
]
