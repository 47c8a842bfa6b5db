"""A tqdm progress display for the solvers' progress callbacks (command-line layer)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator

import numpy as np

from mocap_mj.solve.solver_result import ProgressCallback, TraceEntry


@contextlib.contextmanager
def progress_bar(desc: str, enabled: bool = True) -> Iterator[ProgressCallback | None]:
    """A callback that shows each iteration's cost (and the frames it sums over, where the
    entry says) and marker RMSE (None when disabled).

    The bar has no total: the solvers stop on convergence tests, not at a known iteration.
    It appears only after 2 s, so that short runs print nothing.
    """
    if not enabled:
        yield None
        return
    from tqdm import tqdm

    bar = tqdm(desc=desc, unit="it", leave=False, delay=2)

    def update(entry: TraceEntry) -> None:
        # F sums over the frames solved: it jumps when the coarse phase hands over to every
        # frame, so the bar says over how many.
        # The LM's entries count the frames, Algorithm 1's list the sampled ones (N_F,).
        frames = getattr(entry, "frames", 0)
        count = len(frames) if isinstance(frames, np.ndarray) else int(frames)
        on = f" on {count} frames" if count else ""
        bar.set_postfix_str(
            f"F {entry.cost:.4e} m^2{on}, RMSE {entry.rmse * 1e3:.3f} mm", refresh=False
        )
        bar.update(1)

    try:
        yield update
    finally:
        bar.close()


@contextlib.contextmanager
def frames_bar(
    desc: str, total: int, enabled: bool = True
) -> Iterator[Callable[[int], None] | None]:
    """A callback taking the number of frames done so far (None when disabled)."""
    if not enabled:
        yield None
        return
    from tqdm import tqdm

    bar = tqdm(total=total, desc=desc, unit="frame", leave=False, delay=2)

    def update(done: int) -> None:
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        bar.close()


__all__ = ["frames_bar", "progress_bar"]
