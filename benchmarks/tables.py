"""Numbers and tables as the benchmarks print and record them (text and Markdown).

A missing number (None or NaN: a run that failed or was left out) is a dash in every format.
"""

from __future__ import annotations

import math

DASH = "—"
MIB = 2 ** 20


def _missing(*values) -> bool:
    return any(x is None or math.isnan(x) for x in values)


def ms(seconds: float | None) -> str:
    """Milliseconds, one decimal."""
    return DASH if _missing(seconds) else f"{1000 * seconds:.1f}"


def seconds(x: float | None) -> str:
    """Seconds: three decimals below 10 s, one above."""
    return DASH if _missing(x) else f"{x:.3f}" if x < 10 else f"{x:.1f}"


def mib(n: float | None, decimals: int = 1) -> str:
    """Bytes in MiB."""
    return DASH if _missing(n) else f"{n / MIB:.{decimals}f}"


def ratio(a: float | None, b: float | None) -> str:
    """``a / b``, two decimals."""
    return DASH if _missing(a, b) or b == 0 else f"{a / b:.2f}"


def cell(value) -> str:
    """A table cell: strings as they are, floats to three significant digits."""
    return value if isinstance(value, str) else f"{value:.3g}" if isinstance(value, float) else str(value)


class Table:
    """A titled table of results, with a note under it, printed as text and recorded as Markdown."""

    def __init__(self, title: str, columns: list[str], note: str = ""):
        self.title, self.columns, self.note, self.rows = title, columns, note, []

    def add(self, *cells):
        self.rows.append([cell(c) for c in cells])

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
