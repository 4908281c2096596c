"""The benchmarks of whitted, as a small library and the programs that use it.

Run each program as a module from the repository root, e.g.
``python -m benchmarks.run --quick``; ``make bench`` runs the three that
record benchmarks/RESULTS.md (run, vs_povray, frames).

One-off studies that ``make bench`` does not run (ellipsoids, giants, portable, scene
building) are kept at the git tag ``studies`` (commit 932610f):
``git checkout studies -- benchmarks/studies``, then ``python -m benchmarks.studies.NAME``.
"""


def run_main(main) -> int:
    """``main()``'s exit status, as ``whitted`` runs its commands: Ctrl-C or SIGTERM ends it with
    one line, ``whitted: interrupted``, and the shell's status, 130 or 143, not a traceback."""
    from whitted import interrupt
    interrupt.install()
    return interrupt.run(main)
