"""Progress on stderr: tqdm's bar on a terminal, plain lines in a log.

Long work (a render, a sweep) shows progress, but a bar redrawn with carriage
returns turns a log file or a CI transcript into one unreadable line. So when
stderr is not a terminal the same tqdm bar writes a whole line every
:data:`LOG_INTERVAL` seconds instead. ``-q`` turns progress off and nothing else.
"""

from __future__ import annotations

import sys

#: seconds between two progress lines when stderr is not a terminal
LOG_INTERVAL = 10.0


class _Lines:
    """A stream for tqdm that turns its in-place updates into whole lines."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text: str) -> None:
        text = text.replace("\r", "").replace("\x1b[A", "").strip()
        if text:
            self.stream.write(text + "\n")

    def flush(self) -> None:
        self.stream.flush()


def progress_bar(enabled: bool, total: int, what: str, unit: str = "sample", unit_scale: bool = True):
    """A tqdm bar on stderr (``enabled=False``: a silent one that still counts)."""
    from tqdm import tqdm
    terminal = sys.stderr.isatty()
    # 'delay': short work finishes before a bar would appear.
    return tqdm(total=total, desc=f"whitted: {what}", unit=unit, unit_scale=unit_scale,
                file=sys.stderr if terminal else _Lines(sys.stderr), disable=not enabled,
                delay=0.5 if terminal else 2.0, mininterval=0.1 if terminal else LOG_INTERVAL,
                leave=not terminal, ascii=not terminal, dynamic_ncols=terminal)
