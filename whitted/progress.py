"""Progress on stderr: tqdm's bar on a terminal, a whole line every :data:`LOG_INTERVAL`
seconds in a log (a redrawn bar would be one unreadable line); ``-q`` turns it off.
"""

from __future__ import annotations

import contextlib
import sys
import threading

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


def progress_bar(enabled: bool, total: int | None, what: str, unit: str = "sample", unit_scale: bool = True,
                 **options):
    """A tqdm bar on stderr (``enabled=False``: a silent one that still counts)."""
    from tqdm import tqdm
    terminal = sys.stderr.isatty()
    # 'delay': short work finishes before a bar would appear.
    return tqdm(total=total, desc=f"whitted: {what}", unit=unit, unit_scale=unit_scale,
                file=sys.stderr if terminal else _Lines(sys.stderr), disable=not enabled,
                delay=0.5 if terminal else 2.0, mininterval=0.1 if terminal else LOG_INTERVAL,
                leave=not terminal, ascii=not terminal, dynamic_ncols=terminal, **options)


@contextlib.contextmanager
def elapsed(enabled: bool, what: str):
    """Show how long ``what`` has been running, for work that tells no progress of its own."""
    terminal = sys.stderr.isatty()
    with progress_bar(enabled, None, what, bar_format="{desc}: {elapsed}") as bar:
        stop = threading.Event()

        def tick():
            while not stop.wait(0.5 if terminal else LOG_INTERVAL):
                bar.refresh()
        ticker = threading.Thread(target=tick, daemon=True)
        if enabled:
            ticker.start()
        try:
            yield
        finally:
            stop.set()
            if enabled:
                ticker.join()
