"""Ctrl-C and SIGTERM: one clean stop, whatever was running. Some places wrap a
``KeyboardInterrupt`` (Dr.Jit returns one raised in a ``custom`` operation as a
``RuntimeError``), so the handler also remembers the stop: code that reacts to one asks
:func:`requested`, not the exception's type.
"""

from __future__ import annotations

import contextlib
import signal
import sys

_received: int | None = None
_outcome: str | None = None
#: Inside :func:`deferred`: a stop is remembered (``_pending``), and raised when the block ends.
_deferring = False
_pending = False


def _handler(number, frame):
    global _received, _pending
    _received = number
    if _deferring:
        _pending = True
    elif not _in_finalizer(frame):
        raise KeyboardInterrupt
    # (in a finalizer Python would print the stop as an ignored exception, a traceback on
    # stderr, and go on: it is left to the next check())


def _in_finalizer(frame) -> bool:
    """Whether ``frame`` runs inside a ``__del__`` (tqdm's bars have one)."""
    while frame is not None:
        if frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


def _unraisable(unraisable) -> None:
    """A stop raised where Python cannot raise it (a weakref's callback, which the handler cannot
    tell from other code) is kept for the next :func:`check`, not printed as ignored."""
    if not (_received is not None and issubclass(unraisable.exc_type, KeyboardInterrupt)):
        _unraisable.previous(unraisable)


def install() -> None:
    """Route SIGINT and SIGTERM through :func:`requested` (the CLI calls this first)."""
    global _received, _outcome, _pending
    _received = _outcome = None
    _pending = False
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, _handler)
    if sys.unraisablehook is not _unraisable:
        _unraisable.previous, sys.unraisablehook = sys.unraisablehook, _unraisable


def run(main) -> int:
    """``main()``'s exit status, or after a stop (whatever ``main`` then raised or returned) the
    one line of :func:`message` and :func:`exit_status`: a program's last step, after
    :func:`install`."""
    try:
        status = main()
    except BaseException as error:
        if not requested(error):
            raise
    else:
        if not requested():   # (a stop swallowed in a finalizer still ends as one)
            return status
    print(message(), file=sys.stderr)
    return exit_status()


def check() -> None:
    """Raise a stop between units of work: the handler's may have been swallowed (in a ``__del__``)."""
    if _received is not None and not _deferring:
        raise KeyboardInterrupt


def requested(error: BaseException | None = None) -> bool:
    """Whether the user asked to stop (``error``: the exception being handled, if any)."""
    return _received is not None or isinstance(error, KeyboardInterrupt)


def exit_status() -> int:
    """The shell's convention: 128 + the signal's number (130 for Ctrl-C, 143 for SIGTERM)."""
    return 128 + (_received if _received is not None else signal.SIGINT)


def tell(outcome: str) -> None:
    global _outcome
    _outcome = outcome


def message() -> str:
    """The one line a stop prints: ``whitted: interrupted``, and what was kept."""
    return "whitted: interrupted" + (f"; {_outcome}" if _outcome else "")


@contextlib.contextmanager
def deferred():
    """Hold a stop until the block ends, then raise it: for work a ``KeyboardInterrupt`` would
    leave half done (importing Mitsuba, setting a variant)."""
    global _deferring, _pending
    outer, _deferring = _deferring, True
    try:
        yield
    finally:
        _deferring = outer
    if not outer and _pending:
        _pending = False
        raise KeyboardInterrupt
