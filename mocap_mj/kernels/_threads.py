"""One BLAS thread inside the solvers.

The solvers make thousands of small LAPACK calls (48 x 48 solves and inverses batched over
frames, 147 x 147 eigen-decompositions). With OpenBLAS's default thread pool on this project's
2-core machines each call pays the pool's hand-off: measured, a 147 x 147 ``eigh`` took 149 ms
with the pool and 1.9 ms on one thread, a batched (500, 48, 48) ``eigh`` 1151 ms vs 81 ms. The
compute entry points therefore run with the BLAS pool limited to one thread
(``threadpoolctl``); the caller's setting is restored on return.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Any, TypeVar

from threadpoolctl import ThreadpoolController

F = TypeVar("F", bound=Callable[..., Any])

_controller: ThreadpoolController | None = None


def one_blas_thread() -> AbstractContextManager[Any]:
    """Context manager: BLAS limited to one thread (the loaded libraries are looked up once)."""
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")


_inside = threading.local()


def single_blas_thread(fn: F) -> F:
    """Decorator: run ``fn`` inside :func:`one_blas_thread`; a call from within another such
    function of the same thread runs as it is (the limit holds already, and each limit looks
    up and sets the libraries' settings again: the IK's entry points run inside
    ``identify_lm`` dozens of times)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if getattr(_inside, "active", False):
            return fn(*args, **kwargs)
        with one_blas_thread():
            _inside.active = True
            try:
                return fn(*args, **kwargs)
            finally:
                _inside.active = False

    return wrapper  # type: ignore[return-value]
