"""The kernels' on-disk cache is keyed by the source's content, not by where it is installed."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from numba.core import config

from mocap_mj import _schur, _tree
from mocap_mj._kernel_cache import cache_root


@pytest.mark.skipif(bool(config.CACHE_DIR), reason="NUMBA_CACHE_DIR set: numba's own locator")
def test_kernels_cache_under_the_user_folder_by_content() -> None:
    for module, kernel in ((_tree, _tree.solve_frame), (_schur, _schur._schur_range)):
        source = Path(module.__file__ or "")
        digest = hashlib.sha256(source.read_bytes()).hexdigest()[:16]
        folder = Path(kernel._cache._cache_path)
        assert folder == cache_root() / f"{source.stem}-{digest}"
