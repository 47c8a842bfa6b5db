"""Where the compiled kernels are cached: one folder per user, keyed by the source's content.

Numba caches a kernel beside its module (``__pycache__``) by default, so every install and
every checkout compiles the kernels again: a new virtual environment, a reinstall of the same
version, and ``python -m pytest`` run from a checkout next to an installed copy each paid the
whole first-run compile. Here the cache of a module lives in
``$XDG_CACHE_HOME/mocap-mj/numba/<module>-<sha256 of its source>`` (``~/.cache`` without
``XDG_CACHE_HOME``), so any copy of the same source finds it; numba's own index still checks
the source, the numba and Python versions and the CPU before it uses an entry. A set
``NUMBA_CACHE_DIR`` is the user's choice and is left to numba, as is any case where the folder
cannot be written (numba then falls back to its own locations).
"""

from __future__ import annotations

import hashlib
import os
from functools import cache
from pathlib import Path
from typing import Any

from numba.core import caching, config

__all__ = ["cache_root", "share_cache"]


def cache_root() -> Path:
    """``$XDG_CACHE_HOME/mocap-mj/numba`` (``~/.cache/mocap-mj/numba`` by default)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mocap-mj" / "numba"


@cache
def _folder(py_file: str) -> str:
    digest = hashlib.sha256(Path(py_file).read_bytes()).hexdigest()[:16]
    return str(cache_root() / f"{Path(py_file).stem}-{digest}")


class _ContentLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):  # type: ignore[misc]
    """Numba cache locator: the folder named by the module and its source's hash."""

    def __init__(self, py_func: Any, py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = _folder(py_file)

    def get_cache_path(self) -> str:
        return self._cache_path


class _Impl(caching.CompileResultCacheImpl):  # type: ignore[misc]
    _locator_classes = [  # noqa: RUF012 (numba's attribute, read only)
        _ContentLocator,
        *caching.CompileResultCacheImpl._locator_classes,
    ]


class _FunctionCache(caching.FunctionCache):  # type: ignore[misc]
    _impl_class = _Impl


def share_cache(dispatcher: Any) -> Any:
    """Point a ``cache=True`` dispatcher at :func:`cache_root`; return it.

    Left as numba made it when ``NUMBA_CACHE_DIR`` is set or numba's internals differ.
    """
    if getattr(config, "CACHE_DIR", ""):
        return dispatcher
    try:
        dispatcher._cache = _FunctionCache(dispatcher.py_func)
    except Exception:  # another numba's internals, or an unwritable folder: numba's default
        pass
    return dispatcher
