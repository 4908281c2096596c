"""Output paths: a file appears complete or not at all (written beside, renamed into place),
and whether ``-o`` names one file or a folder of outputs."""

from __future__ import annotations

import contextlib
import errno
import os
import re
import tempfile
import time
from pathlib import Path

from .errors import WhittedError
from .interrupt import deferred


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike):
    """Yield a temporary path beside ``target``; on success it replaces ``target``."""
    target = Path(target)
    folder = target.parent
    if not folder.is_dir():
        raise WhittedError(f"{target}: output folder {folder} does not exist")
    tmp = None
    try:
        with deferred():   # a stop while the file is made lands once its name is known
            try:
                fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.",
                                           suffix=target.suffix or ".tmp", dir=folder)
            except OSError as error:
                raise WhittedError(f"{target}: cannot write: {error.strerror or error}") from None
            os.close(fd)
        yield Path(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException as error:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if isinstance(error, OSError):
            raise WhittedError(f"{target}: cannot write: {error.strerror or error}") from None
        raise


#: :func:`atomic_path`'s temporary file: ``.TARGET.XXXXXXXX`` + the suffix (or ``.tmp``)
_TEMPORARY = re.compile(r"\.(?P<target>.+)\.[a-z0-9_]{8}(?P<suffix>\.[^.]+)")


def _temporaries(folder: str | os.PathLike) -> list[tuple[Path, str]]:
    """The temporary files of :func:`atomic_path` in ``folder``, each with its target's name."""
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    matches = ((name, _TEMPORARY.fullmatch(name)) for name in names)
    return [(Path(folder) / name, m["target"]) for name, m in matches
            if m and (m["target"].endswith(m["suffix"]) or m["suffix"] == ".tmp")]


def leftovers(target: str | os.PathLike) -> list[Path]:
    """The temporary files of :func:`atomic_path` that killed writers left beside ``target``."""
    target = Path(target)
    return [path for path, name in _temporaries(target.parent) if name == target.name]


def remove_stale_leftovers(folder: str | os.PathLike, older_than: float) -> list[Path]:
    """Remove (and return) the temporary files in ``folder`` untouched for ``older_than`` s."""
    removed = []
    now = time.time()
    for path, _ in _temporaries(folder):
        with contextlib.suppress(OSError):
            if now - path.stat().st_mtime > older_than:
                path.unlink()
                removed.append(path)
    return removed


def check_writable(target: str | os.PathLike, inputs: tuple = ()) -> Path:
    """Fail now, naming ``target``, if it could not be written later (or is one of ``inputs``)."""
    target = Path(target)
    try:
        return _check_writable(target, inputs)
    except OSError as error:   # a name the system refuses, which stat answers with an error
        raise WhittedError(f"{target}: cannot write: {error.strerror or error}") from None


def _check_writable(target: Path, inputs: tuple) -> Path:
    if target.is_dir():
        raise WhittedError(f"{target}: is a folder; give a file name")
    if target.exists() and not target.is_file():
        raise WhittedError(f"{target}: is not a regular file; give a file name")
    for source in inputs:
        if target.exists() and Path(source).exists() and target.resolve() == Path(source).resolve():
            raise WhittedError(f"{target}: output would overwrite the input {source}")
    check_folder(target.parent, target)
    return target


def check_folder(folder: str | os.PathLike, named: str | os.PathLike) -> None:
    """``folder`` exists and accepts a new file; errors name ``named``, the user's path."""
    folder = Path(folder)
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise WhittedError(f"{named}: output folder {folder} {what}")
    _probe(folder, named)


def _probe(folder: Path, named: Path) -> None:
    with deferred():   # made and removed as one step: a stop never leaves the probe behind
        try:
            fd, probe = tempfile.mkstemp(prefix=".whitted-", suffix=".probe", dir=folder)
        except OSError as error:
            # /proc and /sys answer ENOENT for a new file in a folder that exists.
            why = ("it accepts no new files" if error.errno == errno.ENOENT
                   else error.strerror or str(error))
            raise WhittedError(f"{named}: cannot write in {folder}: {why}") from None
        os.close(fd)
        os.unlink(probe)


def check_folder_creatable(folder: str | os.PathLike) -> None:
    """Check, creating nothing, that ``folder`` accepts files or can be made."""
    folder = Path(folder)
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise WhittedError(f"{folder}: cannot create a folder under the file {existing}")
    _probe(existing, folder)


def writable_folder(folder: str | os.PathLike) -> None:
    """Create ``folder`` if needed and check it accepts files."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise WhittedError(f"{folder}: cannot create the output folder: {error.strerror or error}") from None
    if not folder.is_dir():
        raise WhittedError(f"{folder}: is not a folder")
    _probe(folder, folder)


def write_text(target: str | os.PathLike, text: str) -> None:
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")


def names_folder(inputs: list[str | os.PathLike], output: str | os.PathLike | None) -> bool:
    """Whether ``-o`` names a folder of outputs rather than one file."""
    if output is None:
        return False
    return (len(inputs) != 1 or Path(inputs[0]).is_dir() or Path(output).is_dir()
            or str(output).endswith(("/", os.sep)))
