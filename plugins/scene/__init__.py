"""The scene tables: what the Whitted integrator reads from a scene, and what the scene calls for.

:mod:`.tables` owns them (built in one pass, checked at every render);
:mod:`.lights`, :mod:`.materials` and :mod:`.primitives` read each part;
:mod:`.effects` says which effects a render of the scene must simulate.
"""
