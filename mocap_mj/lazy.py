"""Names a package imports on first use (PEP 562), so that ``--help`` loads no numerics.

A package lists ``{name: module}`` (the module relative to the package) and sets
``__getattr__ = lazy_names(__name__, table, globals())``; the first access of a name imports
its module and keeps the value in the package's namespace, so later accesses cost nothing.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_names(
    package: str, table: Mapping[str, str], namespace: dict[str, Any]
) -> Callable[[str], Any]:
    """The module-level ``__getattr__`` of ``package``: ``table`` maps each name to the module
    (relative to ``package``) that defines it; ``namespace`` is the package's ``globals()``."""

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    return __getattr__
