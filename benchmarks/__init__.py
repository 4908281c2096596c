"""The benchmarks of whitted, as a small library and the programs that use it.

Run each program as a module from the repository root, e.g.
``python -m benchmarks.run --quick``; ``make bench`` runs the three that
record benchmarks/RESULTS.md (run, vs_povray, frames).

One-off studies that ``make bench`` does not run (ellipsoids, giants, portable, scene
building) are kept at the git tag ``studies`` (commit 932610f):
``git checkout studies -- benchmarks/studies``, then ``python -m benchmarks.studies.NAME``.
"""

import sys


def run_main(main) -> int:
    """``main()``'s exit status, as ``whitted`` runs its commands (whitted/cli.py): Ctrl-C or
    SIGTERM ends it with one line, ``whitted: interrupted``, and the shell's status, 130 or 143
    (whitted/interrupt.py), not a traceback."""
    from whitted import interrupt
    interrupt.install()
    try:
        status = main()
    except BaseException as error:
        if not interrupt.requested(error):
            raise
    else:
        if not interrupt.requested():   # (a stop swallowed in a finalizer still ends as one)
            return status
    print(interrupt.message(), file=sys.stderr)
    return interrupt.exit_status()
