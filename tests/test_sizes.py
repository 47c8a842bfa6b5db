"""Size limits of the code: no function over 80 lines outside the numba kernels, no module
over 800 lines, no function over 8 parameters outside the numba kernels but those of
:data:`MANY_PARAMETERS` (a list that only shrinks, now empty), in the packages ``mocap_mj``,
``synth`` and ``viewer``.

A function's length is its lines from the ``def`` (decorators aside) to its last line,
docstring included. A numba kernel is exempt (one loop nest, which splitting would slow
down): a function decorated with numba's ``njit``/``jit``/``vectorize``/... or with the
project's wrappers of ``numba.njit`` (``_kernel``, ``_jit``, ``_inline`` in
:mod:`mocap_mj.kernels._tree`), with or without arguments.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("mocap_mj", "synth", "viewer")
MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 800
MAX_PARAMETERS = 8
#: The functions that still take more than :data:`MAX_PARAMETERS` parameters (``self`` and
#: ``cls`` aside): each is to take a typed value in place of several; a new one fails the
#: test, and so does one listed here that no longer needs its place.
MANY_PARAMETERS: frozenset[str] = frozenset()
#: Decorators that compile a function with numba.
NUMBA_DECORATORS = frozenset(
    {"njit", "jit", "vectorize", "guvectorize", "cfunc", "_kernel", "_jit", "_inline"}
)


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def _decorator_name(node: ast.expr) -> str:
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else ""


def is_numba(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    return any(_decorator_name(d) in NUMBA_DECORATORS for d in fn.decorator_list)


def function_sizes(source: str, module: str, measure: str = "lines") -> list[tuple[str, int]]:
    """(module:qualified name, lines) of every function of ``source`` but numba kernels
    (``measure="parameters"``: its parameters, ``self`` and ``cls`` aside)."""
    sizes = []
    stack: list[tuple[ast.AST, str]] = [(ast.parse(source), "")]
    while stack:
        node, prefix = stack.pop()
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                if not is_numba(child):
                    n = (
                        _parameters(child)
                        if measure == "parameters"
                        else (child.end_lineno or 0) - child.lineno + 1
                    )
                    sizes.append((f"{module}:{name}", n))
                stack.append((child, f"{name}."))
            elif isinstance(child, ast.ClassDef):
                stack.append((child, f"{prefix}{child.name}."))
            else:
                stack.append((child, prefix))
    return sizes


def _parameters(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [p.arg for p in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    return len(names) - (1 if names[:1] in (["self"], ["cls"]) else 0)


def many_parameters() -> dict[str, int]:
    """Every function over :data:`MAX_PARAMETERS` parameters, numba kernels aside."""
    return {
        name: n
        for path in _modules()
        for name, n in function_sizes(path.read_text(), str(path.relative_to(ROOT)), "parameters")
        if n > MAX_PARAMETERS
    }


def long_functions() -> list[tuple[str, int]]:
    """Every function over :data:`MAX_FUNCTION_LINES`, numba kernels aside."""
    return [
        (name, n)
        for path in _modules()
        for name, n in function_sizes(path.read_text(), str(path.relative_to(ROOT)))
        if n > MAX_FUNCTION_LINES
    ]


def long_modules() -> list[tuple[str, int]]:
    """Every module over :data:`MAX_MODULE_LINES`."""
    counts = ((p, len(p.read_text().splitlines())) for p in _modules())
    return [(str(p.relative_to(ROOT)), n) for p, n in counts if n > MAX_MODULE_LINES]


@pytest.mark.slow
def test_no_function_over_80_lines_outside_the_numba_kernels() -> None:
    over = long_functions()
    assert not over, f"over {MAX_FUNCTION_LINES} lines: " + ", ".join(f"{f} ({n})" for f, n in over)


def test_no_module_over_800_lines() -> None:
    over = long_modules()
    assert not over, f"over {MAX_MODULE_LINES} lines: " + ", ".join(f"{m} ({n})" for m, n in over)


def test_no_new_function_over_8_parameters() -> None:
    over = many_parameters()
    new = {f: n for f, n in over.items() if f not in MANY_PARAMETERS}
    assert not new, f"over {MAX_PARAMETERS} parameters (take a typed value): {new}"
    gone = sorted(MANY_PARAMETERS - set(over))
    assert not gone, f"no longer over {MAX_PARAMETERS} parameters, drop from the list: {gone}"


def test_the_parameter_count_leaves_self_aside() -> None:
    source = "def f(a, b, *, c):\n    pass\n\nclass C:\n    def m(self, a, /, b):\n        pass\n"
    assert dict(function_sizes(source, "m", "parameters")) == {"m:f": 3, "m:C.m": 2}


def test_the_measure_sees_the_code_and_a_long_function() -> None:
    """The walk finds the packages, counts a long plain function (also a method) and
    exempts a numba kernel of the same length."""
    assert len(_modules()) > 50
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    indented = body.replace("\n", "\n    ")
    source = (
        f"import numba\n\ndef plain():\n{body}\n\n@numba.njit(cache=True)\ndef kernel():\n"
        f"{body}\n\nclass C:\n    def method(self):\n    {indented}\n"
    )
    sizes = dict(function_sizes(source, "m"))
    assert sizes == {"m:plain": MAX_FUNCTION_LINES + 1, "m:C.method": MAX_FUNCTION_LINES + 1}
