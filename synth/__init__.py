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

from . import motion
from .config import MOTIONS, POSES, ConfigError, SynthConfig
from .experiment import FILES, Experiment, summarize, synthesize, write_experiment
from .perturb import perturb_theta

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
