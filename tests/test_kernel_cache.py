"""The kernels' on-disk cache is keyed by the source's content, not by where it is installed."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest
from numba.core import config

from mocap_mj.kernels import _schur, _tree_ik
from mocap_mj.kernels._kernel_cache import cache_root


@pytest.mark.skipif(bool(config.CACHE_DIR), reason="NUMBA_CACHE_DIR set: numba's own locator")
def test_kernels_cache_under_the_user_folder_by_content() -> None:
    for module, kernel in ((_tree_ik, _tree_ik.solve_frame), (_schur, _schur._schur_range)):
        source = Path(module.__file__ or "")
        digest = hashlib.sha256(source.read_bytes()).hexdigest()[:16]
        folder = Path(kernel._cache._cache_path)
        assert folder == cache_root() / f"{source.stem}-{digest}"


def test_compile_notice_scales_with_the_load(monkeypatch: pytest.MonkeyPatch) -> None:
    """The first-run notice promises the idle figure on an idle machine and a longer, explained
    one when other work already keeps the cores busy."""
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (0.2, 0.2, 0.2))
    assert _tree_ik.compile_estimate(15) == (15, "")
    monkeypatch.setattr(os, "getloadavg", lambda: (3.0, 3.0, 3.0))
    seconds, why = _tree_ik.compile_estimate(15)
    assert seconds == 30 and "load 3.0 on 2" in why
