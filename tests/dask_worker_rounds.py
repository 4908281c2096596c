"""Preloaded by the Dask workers of test_cluster's runs (Dask's ``distributed.worker.preload``):
``whitted compare`` stops timing after the rounds asked for, as
:func:`conftest.without_headline_rounds` makes it in the test's own process. The tests compare
rows without their times; the headlines' extra rounds, up to COMPARE_ROUNDS_SECONDS a scene
while a headline is unsettled, are what a loaded machine stretches most."""

#: whitted.compare.sweep's settings that leave out the headlines' extra rounds
WITHOUT_HEADLINE_ROUNDS = {"COMPARE_HEADLINE_ROUNDS": 0, "COMPARE_ROUNDS_SECONDS": 0.0}


def dask_setup(worker) -> None:
    """Dask calls this once in each worker that preloads this file."""
    from whitted.compare import sweep
    for name, value in WITHOUT_HEADLINE_ROUNDS.items():
        setattr(sweep, name, value)
