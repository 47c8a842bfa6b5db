"""Size limits of the code: no function over 80 lines outside the numba kernels, no module
over 800 lines, in the packages ``mocap_mj``, ``synth`` and ``viewer``.

A function's length is its source lines from the ``def`` (decorators excluded) to its last
line, docstring included. A numba kernel (a function decorated with ``numba.njit``, ``njit``,
``jit`` or ``numba.jit``, with or without arguments) is exempt: a kernel is one loop nest that
splitting would slow down.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("mocap_mj", "synth", "viewer")
MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 800
_NUMBA_DECORATORS = {"njit", "jit", "vectorize", "guvectorize", "cfunc", "generated_jit"}


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def _decorator_name(node: ast.expr) -> str:
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Name):
        return node.id
    return ""


def _is_numba(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    return any(_decorator_name(d) in _NUMBA_DECORATORS for d in fn.decorator_list)


def long_functions() -> list[tuple[str, int]]:
    """(module:qualified name, lines) of every function over the limit, numba kernels aside."""
    over = []
    for path in _modules():
        tree = ast.parse(path.read_text(), filename=str(path))

        def visit(node: ast.AST, prefix: str) -> None:
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                    name = f"{prefix}{child.name}"
                    assert child.end_lineno is not None
                    lines = child.end_lineno - child.lineno + 1
                    if lines > MAX_FUNCTION_LINES and not _is_numba(child):
                        over.append((f"{path.relative_to(ROOT)}:{name}", lines))
                    visit(child, f"{name}.")
                elif isinstance(child, ast.ClassDef):
                    visit(child, f"{prefix}{child.name}.")
                else:
                    visit(child, prefix)

        visit(tree, "")
    return over


def long_modules() -> list[tuple[str, int]]:
    """(module, lines) of every module over the limit."""
    counts = ((p, len(p.read_text().splitlines())) for p in _modules())
    return [(str(p.relative_to(ROOT)), n) for p, n in counts if n > MAX_MODULE_LINES]


def test_the_packages_are_found() -> None:
    assert len(_modules()) > 50  # the walk sees the code, so the limits below can fail


def test_no_function_over_the_limit() -> None:
    over = long_functions()
    assert not over, "functions over %d lines: %s" % (
        MAX_FUNCTION_LINES,
        ", ".join(f"{n} ({k})" for n, k in over),
    )


def test_no_module_over_the_limit() -> None:
    over = long_modules()
    assert not over, "modules over %d lines: %s" % (
        MAX_MODULE_LINES,
        ", ".join(f"{n} ({k})" for n, k in over),
    )


def test_a_long_function_is_measured(tmp_path: Path) -> None:
    """The measure counts a long plain function and exempts a numba kernel of the same size."""
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    src = (
        f"import numba\n\ndef plain():\n{body}\n\n@numba.njit(cache=True)\ndef kernel():\n{body}\n"
    )
    tree = ast.parse(src)
    fns = [n for n in tree.body if isinstance(n, ast.FunctionDef)]
    assert [_is_numba(f) for f in fns] == [False, True]
    assert all(f.end_lineno - f.lineno + 1 > MAX_FUNCTION_LINES for f in fns)  # type: ignore[operator]


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__])
