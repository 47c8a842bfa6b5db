"""Every YAML file the tool reads, through one guarded loader: :func:`read_yaml`.

A recipe, a subject file, a marker set, a marker map or a batch manifest is a small text
file written by a person. The loader refuses, with one line naming the file, what such a file
never is, before the parser or the caller sees it:

- more than :data:`MAX_BYTES` (1 MiB: the largest bundled marker set is about 7 kB);
- binary (a NUL byte) or not UTF-8 text (a latin-1 file names its first bad byte and offset);
- collections nested deeper than :data:`MAX_DEPTH` levels (the parser's composer recurses once
  per level, so a deep file would otherwise end in Python's recursion limit);
- a document whose aliases expand to more than :data:`MAX_VALUES` values (a "billion laughs"
  file of a few hundred bytes that stands for billions of values);
- a syntax error: the parser's message as one line ``line L, column C: problem`` without the
  parser's excerpt of the text.

No message echoes the document: :func:`mocap_mj.errors.excerpt` caps any value a caller
quotes.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

from ..errors import EXCERPT, InputFileError

#: Largest YAML file read [bytes] (1 MiB).
MAX_BYTES = 1 << 20
#: Deepest nesting of mappings and sequences.
MAX_DEPTH = 64
#: Most values (scalars, sequences, mappings) a document stands for, aliases expanded.
MAX_VALUES = 200_000

__all__ = ["MAX_BYTES", "MAX_DEPTH", "MAX_VALUES", "parse_yaml", "read_text", "read_yaml"]


class _Refused(Exception):
    """A reason to refuse the document, already one line."""


class _GuardedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with a depth limit on composition."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise _Refused(
                    f"line {mark.line + 1}, column {mark.column + 1}: nested deeper than "
                    f"{MAX_DEPTH} levels"
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _expanded(node: yaml.Node) -> int:
    """How many values ``node`` stands for with its aliases expanded, counted up to
    :data:`MAX_VALUES` + 1 (each shared node once per reference; linear in the distinct
    nodes)."""
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()  # expanded, their children not yet counted
    stack: list[tuple[yaml.Node, bool]] = [(node, False)]
    while stack:
        current, done = stack.pop()
        key = id(current)
        if key in sizes:
            continue
        if not done and key in open_nodes:  # an alias inside its own anchor
            mark = current.start_mark
            raise _Refused(
                f"line {mark.line + 1}, column {mark.column + 1}: an alias refers to the "
                "collection that holds it"
            )
        children: list[yaml.Node] = []
        if isinstance(current, yaml.SequenceNode):
            children = list(current.value)
        elif isinstance(current, yaml.MappingNode):
            children = [n for pair in current.value for n in pair]
        if done:
            total = 1 + sum(sizes[id(c)] for c in children)
            sizes[key] = min(total, MAX_VALUES + 1)
            open_nodes.discard(key)
            continue
        open_nodes.add(key)
        stack.append((current, True))
        stack.extend((c, False) for c in children if id(c) not in sizes)
    return sizes[id(node)]


def _parser_problem(exc: yaml.YAMLError) -> str:
    """The parser's error as one line: ``line L, column C: problem (context)``."""
    if isinstance(exc, yaml.reader.ReaderError):
        return f"offset {exc.position}: character #x{exc.character:04x} is not allowed in YAML"
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or type(exc).__name__
    context = getattr(exc, "context", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
    text = where + " ".join(str(problem).split()) + (f" ({context})" if context else "")
    return text if len(text) <= 2 * EXCERPT else text[: 2 * EXCERPT - 3] + "..."


def parse_yaml(text: str, source: str, what: str) -> Any:
    """The document of YAML ``text`` (None when empty), ``source`` and ``what`` naming it in
    the one-line :class:`~mocap_mj.errors.InputFileError` raised for nesting, aliases or a
    syntax error (see the module docstring)."""
    try:
        loader = _GuardedLoader(text)  # checks the characters
    except yaml.YAMLError as exc:
        raise InputFileError(f"{source}: expected a YAML {what}: {_parser_problem(exc)}") from None
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        if _expanded(node) > MAX_VALUES:
            raise _Refused(f"its aliases expand to more than {MAX_VALUES} values")
        return loader.construct_document(node)
    except _Refused as exc:
        raise InputFileError(f"{source}: expected a YAML {what}: {exc}") from None
    except yaml.YAMLError as exc:
        raise InputFileError(f"{source}: expected a YAML {what}: {_parser_problem(exc)}") from None
    except RecursionError:  # a guard above missed a recursive path: still one line
        raise InputFileError(f"{source}: expected a YAML {what}: nested too deep") from None
    finally:
        loader.dispose()


def read_text(path: str | os.PathLike[str], what: str) -> str:
    """The UTF-8 text of the file ``path`` (a byte-order mark dropped), at most
    :data:`MAX_BYTES`; one-line :class:`~mocap_mj.errors.InputFileError` naming the file and
    ``what`` it should be otherwise (missing, a folder, too large, binary, not UTF-8)."""
    file = Path(path)
    try:
        size = file.stat().st_size
        if file.is_dir():
            raise InputFileError(f"{file}: expected a YAML {what}, got a folder")
        if size > MAX_BYTES:
            raise InputFileError(
                f"{file}: expected a YAML {what} of at most {MAX_BYTES // 1024} KiB, "
                f"got {size / 1024:.0f} KiB"
            )
        with file.open("rb") as handle:
            raw = handle.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputFileError(f"{file}: cannot read the {what}: {exc.strerror or exc}") from None
    if len(raw) > MAX_BYTES:  # grew since stat, or a special file
        raise InputFileError(f"{file}: expected a YAML {what} of at most {MAX_BYTES // 1024} KiB")
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise InputFileError(
            f"{file}: expected a YAML {what} (UTF-8 text), got a binary file (byte 0x00 at "
            f"offset {nul})"
        )
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        bad = raw[exc.start]
        raise InputFileError(
            f"{file}: expected a YAML {what} in UTF-8, got byte 0x{bad:02x} at offset "
            f"{exc.start} (save the file as UTF-8)"
        ) from None


def read_yaml(path: str | os.PathLike[str], what: str, *, packaged: bool = False) -> Any:
    """The document of the YAML file ``path`` (None when empty), read through every guard of
    the module docstring; ``what`` ("recipe", "subject file", "marker set"...) names the file's
    role in the one-line :class:`~mocap_mj.errors.InputFileError`.

    ``packaged``: a file shipped with the package (a bundled marker set), read by libyaml's C
    parser when PyYAML has it: the same document (a test compares every bundled file) in a
    tenth of the time (the eleven bundled sets are all read to detect a recording's set), the
    file guards kept; one that fails to parse is read again by the guarded loader for its
    message. A user's file is always read by the guarded loader."""
    text = read_text(path, what)
    if packaged and yaml.__with_libyaml__:
        try:
            return yaml.load(text, Loader=yaml.CSafeLoader)
        except yaml.YAMLError:
            pass
    return parse_yaml(text, str(path), what)
