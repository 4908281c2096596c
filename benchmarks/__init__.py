"""The benchmarks of whitted, as a small library and the programs that use it.

Run each program as a module from the repository root, e.g.
``python -m benchmarks.run --quick``; ``make bench`` runs the three that
record benchmarks/RESULTS.md:

* :mod:`benchmarks.run`: the Whitted integrator against Mitsuba's ``direct``
  and the ray-casting floor, depth, scaling, effects, adaptive depth;
* :mod:`benchmarks.vs_povray`: whitted against POV-Ray 3.7 on the sphereflake;
* :mod:`benchmarks.frames`: a folder of frames, one process against a loop.

The library they share:

* :mod:`benchmarks.scenes`: the benchmark scenes (random spheres, every effect,
  the sphereflake lives in :mod:`benchmarks.sphereflake`) and ``.scn`` text;
* :mod:`benchmarks.timing`: medians of interleaved runs, CPU and wall time, memory;
* :mod:`benchmarks.process`: a whole program's wall time and peak memory;
* :mod:`benchmarks.machine`: what the numbers were measured on;
* :mod:`benchmarks.tables`: number formats and text/Markdown tables;
* :mod:`benchmarks.sections`: the sections of RESULTS.md each program owns.

One-off studies that ``make bench`` does not run (ellipsoids, giants, portable, scene
building) are kept at the git tag ``studies`` (commit 932610f):
``git checkout studies -- benchmarks/studies``, then ``python -m benchmarks.studies.NAME``.
"""
