"""Many subjects at once: datasets (folder tree or manifest), isolated resumable runs on Ray,
and the dataset summary. The command is :mod:`mocap_mj.commands.batch`."""

from __future__ import annotations

from .dataset import OPTION_KEYS, Subject, content_hash, load_dataset
from .run import Outcome, run_batch

__all__ = ["OPTION_KEYS", "Outcome", "Subject", "content_hash", "load_dataset", "run_batch"]
