"""References from the prose to the code resolve: docs/*.md, README.md and the package's
docstrings name no module, file or function that does not exist.

What is checked, where it is written:

* a file path under one of the repository's folders (``plugins/hits.py``,
  ``benchmarks/RESULTS.md``), or under one of the package's folders from inside it
  (``shading/hits.py`` in a plugin's docstring): the file exists;
* a dotted name of the package (``whitted.atomic.leftovers``, ``converter.giants.cached``):
  the module imports and has that attribute;
* a file and a name (``converter/giants.py: float32_error``): the file defines the name;
* in docstrings, Sphinx's cross references (``:func:`name```, ``:mod:`.x```,
  ``:meth:`Class.name```): the name is defined in the module, in one it imports from,
  or (for a bare name) anywhere in the package.

Names are read from the source with :mod:`ast` (what a module defines or imports, its
classes' methods and attributes), so that a reference to a private helper counts too.
"""

from __future__ import annotations

import ast
import importlib
import re
from functools import cache
from pathlib import Path

import pytest

import whitted  # noqa: F401  (selects a variant: the plugins import)

REPO = Path(__file__).resolve().parent.parent
#: the package's folders and the module names they hold (pyproject.toml's package-dir)
PACKAGE_DIRS = {"whitted": "whitted", "converter": "whitted.converter", "plugins": "whitted.plugins"}
#: the repository's top folders a path may start with
TOP = ("whitted", "converter", "plugins", "benchmarks", "tests", "docs", "scenes", "scenes_xml")
EXTENSIONS = r"py|md|scn|xml|png|json|toml|j2|exr|txt"

_PATH = re.compile(rf"(?<![\w./-])((?:[\w-]+/)+[\w.-]+\.(?:{EXTENSIONS}))\b")
_DOTTED = re.compile(r"(?<![\w.])((?:whitted|converter|plugins)(?:\.[A-Za-z_]\w*)+)")
_FILE_NAME = re.compile(r"((?:[\w-]+/)+[\w-]+\.py):\s*`?([A-Za-z_]\w*)")
_ROLE = re.compile(r":(?:func|mod|class|meth|data|attr|exc):`~?([^`<>]+?)`")


def documents() -> list[Path]:
    return sorted((REPO / "docs").glob("*.md")) + [REPO / "README.md"]


def modules() -> dict[str, Path]:
    """Every module of the package -> its source."""
    found = {}
    for folder, package in PACKAGE_DIRS.items():
        for path in sorted((REPO / folder).rglob("*.py")):
            parts = path.relative_to(REPO / folder).with_suffix("").parts
            name = ".".join((package, *parts))
            found[name[:-len(".__init__")] if name.endswith(".__init__") else name] = path
    return found


@cache
def tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"))


@cache
def defined(path: Path) -> frozenset[str]:
    """The names a module defines or imports, with ``Class.member`` for its classes' members
    and the members alone (a method is cited by its name inside its class's docstrings)."""
    names = set()
    module = tree(path)
    for node in ast.walk(module):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)           # self.x = ...: an attribute
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
    for node in [*module.body, *(n for c in ast.walk(module) if isinstance(c, ast.ClassDef) for n in c.body)]:
        for statement in ast.walk(node) if isinstance(node, (ast.If, ast.Try)) else [node]:
            targets = statement.targets if isinstance(statement, ast.Assign) else \
                [statement.target] if isinstance(statement, (ast.AnnAssign, ast.AugAssign)) else []
            names.update(n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name))
    for node in ast.walk(tree(path)):
        if isinstance(node, ast.ClassDef):
            for member in ast.walk(node):
                if isinstance(member, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    names.add(f"{node.name}.{member.name}")
                elif isinstance(member, ast.AnnAssign) and isinstance(member.target, ast.Name):
                    names.add(f"{node.name}.{member.target.id}")
                elif isinstance(member, ast.Attribute) and isinstance(member.ctx, ast.Store):
                    names.add(f"{node.name}.{member.attr}")
    return frozenset(names)


@cache
def everywhere() -> frozenset[str]:
    return frozenset(n for path in modules().values() for n in defined(path))


def dotted_exists(name: str) -> bool:
    """``whitted.a.b.c`` (or ``converter.`` / ``plugins.`` for the package's folders): the
    longest prefix that is a module of the package, then names it defines."""
    first, _, rest = name.partition(".")
    if first != "whitted":
        name = f"{PACKAGE_DIRS[first]}.{rest}"
    parts = name.split(".")
    known = modules()
    for cut in range(len(parts), 0, -1):
        module = ".".join(parts[:cut])
        if module in known:
            remainder = parts[cut:]
            if not remainder:
                return True
            if ".".join(remainder) in defined(known[module]) or remainder[0] in defined(known[module]) \
                    and len(remainder) == 1:
                return True
            try:   # what a package re-exports, or an attribute made at import
                value = importlib.import_module(module)
                for part in remainder:
                    value = getattr(value, part)
                return True
            except (ImportError, AttributeError):
                return False
    return False


def path_exists(text: str, anchor: Path | None = None) -> bool:
    """A path from the repository's root, from the package's folders, or from the folder of
    the file citing it (a sibling module or a subpackage)."""
    bases = [REPO, *(REPO / d for d in PACKAGE_DIRS)]
    if anchor is not None:
        bases += [anchor.parent, anchor.parent.parent]
    return any((base / text).exists() for base in bases)


def checked_path(text: str) -> bool:
    """Whether a path-like text is the project's to check (not a user's file in an example)."""
    first = text.split("/")[0]
    return first in TOP or first in ("shading", "scene", "tree", "compare", "templates", "hard_cases")


def role_exists(target: str, path: Path, module: str) -> bool:
    target = target.strip().rstrip("()")
    if target.startswith("."):      # relative to the module's package
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        dots = len(target) - len(target.lstrip("."))
        for _ in range(dots - 1):
            package = package.rpartition(".")[0]
        target = f"{package}.{target.lstrip('.')}"
    if target.split(".")[0] in PACKAGE_DIRS:
        return dotted_exists(target)
    if target in defined(path) or target.split(".")[-1] in defined(path):
        return True
    try:   # what a package makes on import (a lazy ``__getattr__``)
        value = importlib.import_module(module)
        for part in target.split("."):
            value = getattr(value, part)
        return True
    except (ImportError, AttributeError):
        pass
    if target.split(".")[0] in ("mi", "dr", "np", "os", "math", "tempfile", "ast", "json", "re",
                                "subprocess", "dataclasses", "concurrent", "mitsuba", "drjit", "numpy",
                                "distributed", "dask", "tqdm", "imageio", "matplotlib", "PIL", "jinja2",
                                "pathlib", "functools", "contextlib", "signal", "threading", "time",
                                "statistics", "hashlib", "shutil", "decimal", "struct", "csv",
                                "OpenImageIO", "OpenEXR", "PyOpenColorIO", "flip_evaluator", "Imath",
                                "logging", "typing", "collections", "itertools", "argparse", "sys"):
        return True
    head, _, member = target.partition(".")
    # Class.member of a class the module defines or imports
    return bool(member) and head in defined(path) and member.split(".")[-1] in everywhere()


def _docstrings(path: Path):
    """(line, text) of every docstring of a module."""
    for node in ast.walk(tree(path)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                first = node.body[0]
                yield first.lineno, doc


def problems_in_text(text: str, where: str, anchor: Path | None = None) -> list[str]:
    found = []
    for match in _PATH.finditer(text):
        ref = match.group(1)
        if checked_path(ref) and not path_exists(ref, anchor):
            found.append(f"{where}: no file {ref}")
    for match in _DOTTED.finditer(text):
        ref = match.group(1).rstrip(".")
        if not dotted_exists(ref):
            found.append(f"{where}: no {ref}")
    for match in _FILE_NAME.finditer(text):
        ref, name = match.groups()
        file = next((base / ref for base in (REPO, *(REPO / d for d in PACKAGE_DIRS))
                     if (base / ref).is_file()), None)
        if file is not None and name not in defined(file):
            found.append(f"{where}: {ref} defines no {name}")
    return found


#: Dangling references inside plugins/, left for now to whoever changes plugins/ (issue 31):
#: each must still be found (fixing one means taking it off this list).
PENDING: set[str] = set()


def test_the_documents_cite_what_exists():
    """Prose and inline code; not the commands of fenced blocks (they name the files they
    write; tests/test_readme.py runs them)."""
    found = []
    for path in documents():
        fenced = False
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if line.lstrip().startswith("```"):
                fenced = not fenced
            elif not fenced:
                found += problems_in_text(line, f"{path.relative_to(REPO)}:{number}")
    assert not found, "\n".join(found)


@pytest.mark.parametrize("folder", sorted(PACKAGE_DIRS))
def test_the_docstrings_cite_what_exists(folder):
    found = []
    for module, path in modules().items():
        if path.relative_to(REPO).parts[0] != folder:
            continue
        for line, doc in _docstrings(path):
            where = f"{path.relative_to(REPO)}:{line}"
            found += problems_in_text(doc, where, path)
            for match in _ROLE.finditer(doc):
                if not role_exists(match.group(1), path, module):
                    found.append(f"{where}: no {match.group(0)}")
    pending = {p for p in PENDING if p.startswith(f"{folder}/")}
    assert not set(found) - pending, "\n".join(sorted(set(found) - pending))
    assert not pending - set(found), f"fixed, take off PENDING: {sorted(pending - set(found))}"


def test_a_dangling_reference_is_found():
    """The checks themselves: each kind of reference, resolved and dangling."""
    assert problems_in_text("see whitted.atomic.leftovers and plugins/hits.py", "x") == []
    assert problems_in_text("converter/giants.py: cached", "x") == []
    assert problems_in_text("converter/giants.py: no_such_function", "x") == \
        ["x: converter/giants.py defines no no_such_function"]
    assert problems_in_text("see whitted.atomic.no_such_thing", "x") == ["x: no whitted.atomic.no_such_thing"]
    assert problems_in_text("see plugins/shading/nothing.py", "x") == ["x: no file plugins/shading/nothing.py"]
    assert problems_in_text("converter/giants.py: float32_error", "x") == \
        ["x: converter/giants.py defines no float32_error"]   # dead, removed (issue 31)
    hits = REPO / "plugins" / "hits.py"
    assert role_exists("spawn_ray", hits, "whitted.plugins.hits")
    assert not role_exists("no_such_function_anywhere", hits, "whitted.plugins.hits")
    assert role_exists(".hits", REPO / "plugins" / "__init__.py", "whitted.plugins")
