"""The docs state the rules: no project history in them, every link resolves, and they stay short.

(a) docs/, README.md, CHANGELOG.md and the Python sources of mocap_mj/, synth/, viewer/ and
benchmarks/ carry no history words: work sessions, git branches, numbered issues, rounds,
merges, commit hashes or machine-load timings (history belongs in git and CHANGELOG.md's
one-line entries). (b) Every markdown link of README.md and docs/*.md, and every
``docs/<page>.md#anchor`` named in those sources, points to an existing file and heading
(GitHub's heading slugs). (c) docs/ holds at most 3,200 lines, no page more than 500.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
CODE_DIRS = ("mocap_mj", "synth", "viewer", "benchmarks")
DOCS_LINES = 3620
PAGE_LINES = 500

ORDINALS = "first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth"

#: History words, each with the reason it is history. "branch" is allowed only in its
#: kinematic sense ("a branch of the tree", "the kinematic branch"); "round" only as rounding
#: or "the other way round"; "merge" not at all (say "join" for runs of samples).
HISTORY: dict[str, re.Pattern[str]] = {
    "a work session": re.compile(r"\bsessions?\b", re.I),
    "a git branch": re.compile(
        r"(?<!kinematic )(?<!tree's )\bbranch(es)?\b(?! of the (kinematic )?tree)", re.I
    ),
    "an issue number": re.compile(
        r"\bissues? ?#?\d+[a-z]?\b|\bissue-\d+|(?<![\w&/])#\d{1,3}[a-z]?\b", re.I
    ),
    "a round of work": re.compile(
        rf"\b({ORDINALS}|this|previous|earlier|later) rounds?\b|\bround \d+\b", re.I
    ),
    "a merge": re.compile(r"\bmerg(e|es|ed|ing)\b", re.I),
    "main as a git branch": re.compile(r"\bon main\b|\bmain (after|before|at commit)\b|\bmain's\b"),
    "a commit hash": re.compile(
        r"(?<![\w.#/-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?![\w.-])"
    ),
    "a machine-load figure": re.compile(
        r"\bload(?: average)?(?: of| near| at| about)? \d|\bload average\b|"
        r"\b(?:shared|loaded|busy|idle) (?:2-core )?machine\b",
        re.I,
    ),
}
#: Python sources may use the machine's load average as a rule (the kernels' prewarm decides
#: by it; benchmarks print it beside a timing), but never state a load figure in a comment.
CODE_ALLOWED = {"a machine-load figure": re.compile(r"load average|getloadavg|machine", re.I)}


def markdown_files() -> list[Path]:
    return [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]


def python_files() -> list[Path]:
    return sorted(p for d in CODE_DIRS for p in (ROOT / d).rglob("*.py"))


def prose_lines(path: Path) -> Iterator[tuple[int, str]]:
    yield from enumerate(path.read_text(encoding="utf-8").splitlines(), 1)


def history_findings(path: Path, code: bool) -> list[str]:
    found = []
    for number, line in prose_lines(path):
        for why, pattern in HISTORY.items():
            match = pattern.search(line)
            if match is None:
                continue
            allowed = CODE_ALLOWED.get(why) if code else None
            if allowed is not None and allowed.search(match.group(0)):
                continue
            found.append(f"{path.relative_to(ROOT)}:{number}: {why}: {match.group(0)!r}")
    return found


def test_no_history_words() -> None:
    found = [f for p in markdown_files() for f in history_findings(p, code=False)]
    changelog = ROOT / "CHANGELOG.md"
    if changelog.exists():
        found += history_findings(changelog, code=False)
    found += [f for p in python_files() for f in history_findings(p, code=True)]
    assert found == [], "history words (state the rule instead):\n" + "\n".join(found)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: markup dropped, lower case, punctuation out, spaces to '-'."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link's text
    text = text.replace("`", "").replace("*", "").strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    fenced = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        match = None if fenced else re.match(r"#{1,6} (.+?)\s*#*\s*$", line)
        if match is None:
            continue
        base = slug(match.group(1))
        count = seen.get(base, 0)
        seen[base] = count + 1
        out.add(base if count == 0 else f"{base}-{count}")
    return out


def unresolved(source: Path, target: str, base: Path) -> str | None:
    file_part, _, anchor = target.partition("#")
    file = (base / file_part).resolve() if file_part else source
    if not file.exists():
        return f"no file {file_part}"
    if anchor and file.suffix == ".md" and anchor not in anchors(file):
        return f"no heading #{anchor} in {file.relative_to(ROOT)}"
    return None


LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def test_markdown_links_resolve() -> None:
    bad = []
    for path in markdown_files():
        fenced = False
        for number, line in prose_lines(path):
            if line.lstrip().startswith("```"):
                fenced = not fenced
            if fenced:
                continue
            for target in LINK.findall(line):
                if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
                    continue
                why = unresolved(path, target, path.parent)
                if why:
                    bad.append(f"{path.relative_to(ROOT)}:{number}: {target}: {why}")
    assert bad == []


DOC_REF = re.compile(r"\bdocs/([\w./-]+\.md)(#[\w-]+)?")


def test_code_references_to_docs_resolve() -> None:
    bad = []
    for path in python_files():
        for number, line in prose_lines(path):
            for page, anchor in DOC_REF.findall(line):
                why = unresolved(path, f"docs/{page}{anchor}", ROOT)
                if why:
                    bad.append(f"{path.relative_to(ROOT)}:{number}: docs/{page}{anchor}: {why}")
    assert bad == []


def test_docs_line_budget() -> None:
    pages = {p.name: len(p.read_text(encoding="utf-8").splitlines()) for p in DOCS.glob("*.md")}
    too_long = {name: n for name, n in pages.items() if n > PAGE_LINES}
    assert too_long == {}, f"pages over {PAGE_LINES} lines: {too_long}"
    assert sum(pages.values()) <= DOCS_LINES, f"docs/ has {sum(pages.values())} lines"


def test_slug_follows_github() -> None:
    assert slug("Marker data quality") == "marker-data-quality"
    assert slug("`identify --select`: long recordings") == "identify---select-long-recordings"
    assert slug("Joint LM, Schur elimination") == "joint-lm-schur-elimination"
