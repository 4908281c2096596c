"""The errors a user sees: one line each, no traceback (the CLI prints them)."""

from __future__ import annotations

import os
import sys


def report(error: BaseException) -> None:
    """Each line of a user error as ``whitted: error: LINE`` on stderr (the CLI's one format)."""
    for line in (str(error).splitlines() or [type(error).__name__]):
        print(f"whitted: error: {line}", file=sys.stderr)


def first_line(error: BaseException) -> str:
    """An exception's first line of text, else its type's name."""
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


#: the exit status of a command that a user error stopped
EXIT_USER_ERROR = 2


class WhittedError(Exception):
    """An error caused by the user's input or machine, reported as one clean line."""


class ParameterError(WhittedError, ValueError):
    """A plugin parameter out of its range: ``PLUGIN: NAME must ..., got VALUE``."""


class SceneError(WhittedError):
    """The problems of a scene file (docs/CONTRACTS.md, "Scene errors")."""

    def __init__(self, path: str | os.PathLike, line: int | None, message: str, more=(),
                 shown: int | None = None):
        self.path = os.fspath(path)
        self.line = line
        self.message = message
        self.errors: list[tuple[str, int | None, str]] = \
            [(self.path, line, message), *((os.fspath(p), n, m) for p, n, m in more)]
        self.shown = len(self.errors) if shown is None else shown
        super().__init__(self._text())

    @classmethod
    def collected(cls, errors, shown: int | None = None) -> "SceneError":
        """One error for all of ``errors``, (path, line, message) in file order."""
        (path, line, message), *more = errors
        return cls(path, line, message, more, shown)

    def _text(self) -> str:
        lines = [f"{path}: {message}" if line is None else f"{path}:{line}: {message}"
                 for path, line, message in self.errors[:self.shown]]
        more = len(self.errors) - self.shown
        if more > 0:
            lines.append(f"... and {more} more error{'s' if more > 1 else ''}")
        return "\n".join(lines)
