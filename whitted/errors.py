"""The errors a user sees: one line, no traceback (the CLI prints them)."""

from __future__ import annotations

import os
import sys


def report(error: BaseException) -> None:
    """Each line of a user error as ``whitted: error: LINE`` on stderr (the CLI's one format)."""
    for line in (str(error).splitlines() or [type(error).__name__]):
        print(f"whitted: error: {line}", file=sys.stderr)


class WhittedError(Exception):
    """An error caused by the user's input or machine, reported as one clean line."""


class SceneError(WhittedError):
    """A problem in a scene file, located as ``FILE:LINE: message`` (or ``FILE: message``)."""

    def __init__(self, path: str | os.PathLike, line: int | None, message: str):
        self.path = os.fspath(path)
        self.line = line
        self.message = message
        where = self.path if line is None else f"{self.path}:{line}"
        super().__init__(f"{where}: {message}")
