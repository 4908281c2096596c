"""What the benchmarks print and record: numbers and tables (text and Markdown), the machine
they were measured on, and their sections of benchmarks/RESULTS.md.

A missing number (None or NaN: a run that failed or was left out) is a dash in every format.
Numbers mean little without the processor, the cores and the commit measured: every program
prints and records :func:`machine`. A section of RESULTS.md, the text between ``<!-- begin
NAME -->`` and ``<!-- end NAME -->``, belongs to one benchmark and is rewritten alone, so
that re-running one keeps the others' results.
"""

from __future__ import annotations

import contextlib
import datetime
import math
import os
import platform
import re
import subprocess
import sys
from pathlib import Path

from whitted.atomic import check_writable, write_text
from whitted.errors import WhittedError

DASH = "—"
MIB = 2 ** 20


def _missing(*values) -> bool:
    return any(x is None or math.isnan(x) for x in values)


def ms(seconds: float | None) -> str:
    return DASH if _missing(seconds) else f"{1000 * seconds:.1f}"


def seconds(x: float | None) -> str:
    return DASH if _missing(x) else f"{x:.3f}" if x < 10 else f"{x:.1f}"


def mib(n: float | None, decimals: int = 1) -> str:
    return DASH if _missing(n) else f"{n / MIB:.{decimals}f}"


def ratio(a: float | None, b: float | None) -> str:
    return DASH if _missing(a, b) or b == 0 else f"{a / b:.2f}"


class Table:
    """A titled table of results, with a note under it, printed as text and recorded as Markdown."""

    def __init__(self, title: str, columns: list[str], note: str = ""):
        self.title, self.columns, self.note, self.rows = title, columns, note, []

    def add(self, *cells):
        """A row: strings as they are, floats to three significant digits."""
        self.rows.append([c if isinstance(c, str) else f"{c:.3g}" if isinstance(c, float) else str(c) for c in cells])

    def text(self) -> str:
        """Columns padded to their widest cell, two spaces apart."""
        rows = [self.columns] + self.rows
        widths = [max(len(row[i]) for row in rows) for i in range(len(self.columns))]
        lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
        return "\n".join([f"\n== {self.title}", *lines] + ([self.note] if self.note else []))

    def markdown(self) -> str:
        lines = ["| " + " | ".join(row) + " |" for row in [self.columns] + self.rows]
        lines.insert(1, "|" + "---|" * len(self.columns))
        return "\n".join([f"### {self.title}", "", *lines] + (["", self.note] if self.note else []))


def _cpu() -> str:
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine() or "unknown CPU"


def _git(*args) -> str:
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=True,
                              cwd=Path(__file__).resolve().parent).stdout
    except (OSError, subprocess.CalledProcessError):
        return ""


def source() -> str:
    """The commit measured, with the files changed since it named."""
    described = _git("describe", "--always", "--dirty").strip() or "unknown"
    changed = [line[3:] for line in _git("status", "--porcelain", "--untracked-files=no").splitlines() if line]
    return described + (f" (uncommitted changes in {', '.join(changed)})" if changed else "")


def machine() -> dict:
    """The processor, cores, Python, OS, source and date; with Mitsuba and Dr.Jit's versions,
    variant and thread count where this process has imported Mitsuba (not imported here:
    programs that only time subprocesses stay small)."""
    now = datetime.datetime.now(datetime.timezone.utc)
    info = {"source": source(), "cpu": _cpu(), "cores": len(os.sched_getaffinity(0)),
            "python": platform.python_version(), "os": platform.platform(),
            "date": now.strftime("%Y-%m-%d %H:%M UTC")}
    if "mitsuba" in sys.modules:
        import drjit as dr
        import mitsuba as mi
        llvm = dr.detail.llvm_version() if dr.backend_v(mi.Float) == dr.JitBackend.LLVM else None
        info.update({"drjit_threads": dr.thread_count(), "variant": mi.variant(), "mitsuba": mi.__version__,
                     "drjit": dr.__version__, "llvm": ".".join(map(str, llvm)) if llvm else None})
    return info


def summary(info: dict) -> str:
    """The machine in one line: processor, cores, Python, OS, and Mitsuba's set-up where imported."""
    mitsuba = (f" ({info['drjit_threads']} Dr.Jit threads), variant {info['variant']}, Mitsuba {info['mitsuba']}, "
               f"Dr.Jit {info['drjit']}, LLVM {info['llvm']}" if "variant" in info else "")
    return f"{info['cpu']}, {info['cores']} cores{mitsuba}, Python {info['python']}, {info['os']}"


def _pattern(name: str = r"[\w-]+") -> re.Pattern:
    return re.compile(rf"<!-- begin ({name}) -->\n.*?<!-- end \1 -->\n?", re.S)


def marked_sections(text: str) -> list[str]:
    """Every marked section of ``text``, markers included, in order."""
    return [m.group(0).rstrip("\n") + "\n" for m in _pattern().finditer(text)]


def check_markdown(path: str | Path) -> Path:
    """Fail now (:class:`WhittedError`, naming ``path``) if the Markdown file a run records its
    results in could not be read and written once the run is over."""
    path = check_writable(path)
    if path.exists():
        try:
            path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise WhittedError(f"{path}: is not a text file (not UTF-8)") from None
        except OSError as error:
            raise WhittedError(f"{path}: cannot read: {error.strerror or error}") from None
    return path


def replace_section(path: str | Path, name: str, body: str) -> None:
    """Make ``body`` the section ``name`` of the Markdown file ``path`` (appended when new); the
    file is written whole or not at all."""
    path = Path(path)
    text = path.read_text(encoding="utf-8") if path.exists() else ""
    section = f"<!-- begin {name} -->\n{body.rstrip()}\n<!-- end {name} -->\n"
    text, found = _pattern(re.escape(name)).subn(lambda _: section, text, count=1)
    if not found:
        text = text.rstrip("\n") + "\n\n" + section if text else section
    write_text(path, text)
