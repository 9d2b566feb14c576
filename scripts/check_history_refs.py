"""Fail when code or user-visible text names an issue or a date.

Code and the text it shows say what is and why; which issue asked for it and when belong in the
git log. Looked for in the source folders (``backend/``, ``worker/``, ``frontend/src``; the built
web UI under ``backend/alcove/static`` is generated and skipped):

* an issue number: ``issue 17``, ``issues 12 and 14``, ``#31`` (not a colour such as ``#000``);
* a date: ``2026-12-03``, ``3 December 2026``, ``December 3, 2026``.

Usage: ``python scripts/check_history_refs.py [PATH ...]`` (default: the source folders); prints
``path:line: what`` for each and exits 1 if any is found.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ROOTS = ("backend", "worker", "frontend/src")
SKIP_DIRS = {"node_modules", "__pycache__", ".mypy_cache", ".ruff_cache"}
SKIP_PATHS = ("backend/alcove/static/",)
SUFFIXES = {".py", ".ts", ".tsx", ".js", ".mjs", ".css", ".html", ".json", ".md", ".toml", ".txt", ".yaml", ".yml"}

_MONTHS = "January|February|March|April|May|June|July|August|September|October|November|December"
PATTERNS: dict[str, re.Pattern[str]] = {
    "issue number": re.compile(r"\bissues?\s+#?\d+\b|(?<![\w&#/])#\d{1,4}\b(?![\w-])", re.IGNORECASE),
    "date": re.compile(
        rf"\b(?:19|20)\d\d-[01]\d-[0-3]\d\b"
        rf"|\b[0-3]?\d\s+(?:{_MONTHS})\s+(?:19|20)\d\d\b"
        rf"|\b(?:{_MONTHS})\s+[0-3]?\d(?:st|nd|rd|th)?,?\s+(?:19|20)\d\d\b"
    ),
}
#: ``#000``, ``#333``: a colour in CSS or in a style value, not an issue.
_COLOUR = re.compile(r"#(?:\d{3}|\d{6})\b")


def findings(text: str) -> Iterator[tuple[int, str, str]]:
    """(line number, kind, matched text) for each issue number and date in ``text``."""
    for number, line in enumerate(text.splitlines(), start=1):
        for kind, pattern in PATTERNS.items():
            for match in pattern.finditer(line):
                found = match.group(0)
                if kind == "issue number" and _COLOUR.fullmatch(found):
                    continue
                yield number, kind, found


def source_files(paths: Iterable[Path]) -> Iterator[Path]:
    for path in paths:
        if path.is_file():
            yield path
            continue
        for file in sorted(path.rglob("*")):
            rel = file.relative_to(REPO).as_posix() if file.is_relative_to(REPO) else file.as_posix()
            if (
                file.is_file()
                and file.suffix in SUFFIXES
                and not SKIP_DIRS.intersection(file.parts)
                and not rel.startswith(SKIP_PATHS)
            ):
                yield file


def check(paths: Iterable[Path]) -> list[str]:
    """``path:line: kind 'text'`` for each finding under ``paths``."""
    out = []
    for file in source_files(paths):
        try:
            text = file.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        shown = file.relative_to(REPO) if file.is_relative_to(REPO) else file
        out += [f"{shown}:{n}: {kind} {found!r}" for n, kind, found in findings(text)]
    return out


def main(argv: list[str]) -> int:
    paths = [Path(a).resolve() for a in argv] or [REPO / root for root in ROOTS]
    found = check(paths)
    for line in found:
        print(line)
    if found:
        print(
            f"{len(found)} issue numbers or dates in the code: say the constraint, not the history",
            file=sys.stderr,
        )
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
