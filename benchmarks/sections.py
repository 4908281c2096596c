"""Sections of benchmarks/RESULTS.md that belong to one benchmark each: the text between
``<!-- begin NAME -->`` and ``<!-- end NAME -->``, rewritten alone, so that re-running one
benchmark keeps the others' results.
"""

from __future__ import annotations

import re
from pathlib import Path


def _pattern(name: str = r"[\w-]+") -> re.Pattern:
    return re.compile(rf"<!-- begin ({name}) -->\n.*?<!-- end \1 -->\n?", re.S)


def marked(text: str) -> list[str]:
    """Every marked section of ``text``, markers included, in order."""
    return [m.group(0).rstrip("\n") + "\n" for m in _pattern().finditer(text)]


def replace(path: str | Path, name: str, body: str) -> None:
    """Make ``body`` the section ``name`` of the Markdown file ``path`` (appended when new)."""
    path = Path(path)
    text = path.read_text() if path.exists() else ""
    section = f"<!-- begin {name} -->\n{body.rstrip()}\n<!-- end {name} -->\n"
    text, found = _pattern(re.escape(name)).subn(lambda _: section, text, count=1)
    if not found:
        text = text.rstrip("\n") + "\n\n" + section if text else section
    path.write_text(text)
