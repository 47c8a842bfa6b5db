"""How the compiled kernels are compiled: numba's options, entry kernels (:func:`_kernel`),
kernel-only helpers (:func:`_jit`, :func:`_inline`) and, for tests, a helper with a Python
entry point (:func:`python_callable`). Every kernel is cached on disk
(:mod:`mocap_mj.kernels._kernel_cache`)."""

from __future__ import annotations

import types
from collections.abc import Callable
from functools import cache
from typing import Any

import numba as nb
from numba.core.registry import CPUDispatcher

from mocap_mj.kernels._kernel_cache import share_cache

#: Options of every kernel: cached on disk (:mod:`mocap_mj.kernels._kernel_cache`), releasing the
# GIL
#: (Python threads run kernels side by side, see :func:`run_blocks`), and numpy's error model
#: (a division by zero gives inf/nan instead of raising: no exception paths to compile).
_OPTIONS: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}
_INNER_OPTIONS: dict[str, Any] = {**_OPTIONS, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


def _kernel(fn: Callable[..., Any]) -> Any:
    """An entry kernel: compiled with the wrapper that Python calls it through."""
    return share_cache(nb.njit(**_OPTIONS)(fn))


class _KernelOnly(CPUDispatcher):  # type: ignore[misc]
    """A :func:`_jit` helper's dispatcher: a call from Python raises instead of crashing."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise TypeError(
            f"{self.py_func.__qualname__} is compiled for calls from kernels only "
            "(no Python entry point): use mocap_mj.kernels._jit.python_callable"
        )


def _jit(fn: Callable[..., Any]) -> Any:
    """A kernel called only from other kernels: compiled without the Python and C wrappers.

    Numba gives every compiled function a wrapper that unboxes its arguments from Python
    objects (for a :class:`Tree` and a :class:`Work`, 38 arrays) and a C-callable one, and
    compiles and optimises them with the function; a helper never called from Python does not
    need them, and leaving them out shortens the first run's compile
    (docs/validation.md#first-run). Without its wrapper a call from Python would crash the
    interpreter, so the dispatcher raises :class:`TypeError` instead: use
    :func:`python_callable` (tests do).
    """
    disp = share_cache(nb.njit(**_INNER_OPTIONS)(fn))
    disp.__class__ = _KernelOnly
    return disp


@cache
def python_callable(helper: Any) -> Any:
    """A :func:`_jit` helper compiled again with a Python entry point (for tests).

    A copy of the function under its own name, so the two compilations have separate entries
    in the on-disk cache (numba keys them by qualified name, not by options).
    """
    fn = helper.py_func
    copy = types.FunctionType(
        fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__
    )
    copy.__qualname__ = f"{fn.__qualname__}_from_python"
    copy.__doc__ = fn.__doc__
    return _kernel(copy)


#: Small helpers are compiled like any kernel and LLVM inlines them where it pays. Numba's
#: ``inline="always"`` would copy their IR into every caller before type inference, which
#: lengthens the first run's compile (docs/validation.md#first-run).
_inline = _jit
