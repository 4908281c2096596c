"""One-off studies: measurements behind a design decision, not run by ``make bench``.

Each is a program (``python -m benchmarks.studies.NAME``) that records its
findings in a section of benchmarks/RESULTS.md or prints them:

* :mod:`.ellipsoids`: Mitsuba's ``ellipsoids`` shape as a fast path for many spheres;
* :mod:`.giants`: what the exact path for giant spheres costs;
* :mod:`.portable`: how far stock Mitsuba's BSDFs are from the article's model;
* :mod:`.scene_building`: ways of building a Mitsuba scene of many spheres;
* :mod:`.scene_setup`: the integrator's per-scene setup for many spheres.
"""
