"""Many subjects at once: datasets (folder tree or manifest), isolated resumable runs on Ray,
and the dataset summary. The command is :mod:`mocap_mj.commands.batch`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

if TYPE_CHECKING:
    from .dataset import OPTION_KEYS, Entry, content_hash, load_dataset
    from .run import Cluster, Outcome, run_batch

#: The names imported on first use (PEP 562): ``mocap-mj batch --help`` reads
#: :data:`~mocap_mj.batch.dataset.OPTION_KEYS` without loading the runner.
_LAZY = {
    "OPTION_KEYS": ".dataset",
    "Entry": ".dataset",
    "content_hash": ".dataset",
    "load_dataset": ".dataset",
    "Cluster": ".run",
    "Outcome": ".run",
    "run_batch": ".run",
}


__getattr__ = lazy_names(__name__, _LAZY, globals())


__all__ = [
    "OPTION_KEYS",
    "Cluster",
    "Entry",
    "Outcome",
    "content_hash",
    "load_dataset",
    "run_batch",
]
