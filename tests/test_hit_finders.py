"""The hit finders keep to their declared protocol (plugins/hits.py: ``HitFinder``).

The shader holds one finder, often one wrapping others (``GiantHits(LayeredHits(SphereHits |
MitsubaHits))``), and calls it by name only: a finder whose method is renamed, or whose
arguments drift from the protocol's, would fail only in the scenes that reach it. These
tests read the classes and the shader's source, so that the drift fails here.
"""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest

import whitted  # noqa: F401  (selects a variant: the plugins import)
from whitted.plugins import hits, recursion

#: the protocol's methods, as the shader calls them
METHODS = ("intersect", "blocked", "surface_at")


def protocol_methods() -> dict[str, inspect.Signature]:
    """The methods :class:`HitFinder` declares, with their signatures."""
    return {name: inspect.signature(member) for name, member in vars(hits.HitFinder).items()
            if inspect.isfunction(member) and not name.startswith("_")}


def finder_classes() -> list[type]:
    """Every public ``…Hits`` class of the hit finding module."""
    return [cls for name, cls in vars(hits).items()
            if inspect.isclass(cls) and name.endswith("Hits") and not name.startswith("_")
            and cls.__module__ == hits.__name__]


def parameters(signature: inspect.Signature) -> list[tuple[str, object, bool]]:
    """Each parameter's name, kind and whether it has a default (annotations aside)."""
    return [(p.name, p.kind, p.default is not p.empty) for p in signature.parameters.values()]


def test_the_protocol_declares_what_the_shader_calls():
    assert set(protocol_methods()) == set(METHODS)
    source = Path(inspect.getsourcefile(recursion)).read_text(encoding="utf-8")
    called = {node.attr for node in ast.walk(ast.parse(source))
              if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute)
              and node.value.attr == "hits"}
    assert called == set(METHODS)


def test_the_four_finders_are_checked():
    assert {cls.__name__ for cls in finder_classes()} == {"MitsubaHits", "SphereHits", "LayeredHits", "GiantHits"}


@pytest.mark.parametrize("cls", finder_classes(), ids=lambda cls: cls.__name__)
def test_each_finder_has_the_protocol_methods_with_its_signatures(cls):
    for name, signature in protocol_methods().items():
        method = inspect.getattr_static(cls, name, None)
        assert inspect.isfunction(method), f"{cls.__name__} has no method {name}"
        assert parameters(inspect.signature(method)) == parameters(signature), f"{cls.__name__}.{name}"
