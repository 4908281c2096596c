"""The package's import graph: no module imports itself back, and every package
folder is installed.

The graph is read from the source with :mod:`ast` (no module is executed), over
the ``whitted.*`` modules as pyproject.toml maps them (``converter/`` is
``whitted.converter``, ``plugins/`` is ``whitted.plugins``). Every import
statement counts, also those inside functions and under ``TYPE_CHECKING``: a lazy
import hides a cycle from Python, not from the design. Imports by name
(``importlib.import_module("...")``) are not seen.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _setuptools() -> dict:
    with open(ROOT / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["tool"]["setuptools"]


def package_modules() -> dict[str, Path]:
    """Every module of the installed namespace -> its source file."""
    package_dir = _setuptools()["package-dir"]
    folders = {ROOT / folder: name for name, folder in package_dir.items()}
    modules: dict[str, Path] = {}
    for folder, package in folders.items():
        for file in sorted(folder.rglob("*.py")):
            # a folder mapped on its own (whitted.converter) is not also a part of its parent
            if any(other != folder and other in file.parents and folder in other.parents
                   for other in folders):
                continue
            parts = list(file.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join([package, *parts])] = file
    return modules


def _imported(module: str, file: Path, node: ast.AST, known: set[str]) -> set[str]:
    """The package modules one import statement depends on."""
    if isinstance(node, ast.Import):
        targets = [alias.name for alias in node.names]
    else:
        if node.level:
            base = module.split(".") if file.name == "__init__.py" else module.split(".")[:-1]
            base = base[:len(base) - node.level + 1]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        # `from package import submodule` depends on the submodule; other names on the package
        targets = [f"{source}.{alias.name}" if f"{source}.{alias.name}" in known else source
                   for alias in node.names]
    found = set()
    for target in targets:
        parts = target.split(".")
        while parts and ".".join(parts) not in known:  # `import a.b.c` of a name inside a.b
            parts.pop()
        if parts:
            found.add(".".join(parts))
    return found


def import_graph() -> dict[str, set[str]]:
    modules = package_modules()
    known = set(modules)
    graph = {}
    for module, file in modules.items():
        tree = ast.parse(file.read_text(encoding="utf-8"), filename=str(file))
        edges = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                edges |= _imported(module, file, node, known)
        graph[module] = edges - {module}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as [a, b, ..., a], or None (depth-first search)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for other in sorted(graph[node]):
            if state.get(other) == 1:
                return path[path.index(other):] + [other]
            if other not in state:
                cycle = visit(other)
                if cycle:
                    return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def test_find_cycle_finds_cycles_and_only_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None  # a diamond
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"x": {"a"}, "a": {"b"}, "b": {"a"}}) == ["a", "b", "a"]


def test_the_graph_sees_relative_lazy_and_type_checking_imports():
    graph = import_graph()
    assert "whitted.converter.parser" in graph and "whitted.plugins.integrator" in graph
    assert "whitted.errors" in graph["whitted.converter.parser"]       # from ..errors import
    assert "whitted.plugins.hits" in graph["whitted.plugins.recursion"]  # from .hits import ...
    assert "whitted.plugins" in graph["whitted.rendering"]         # inside a function
    assert "whitted.defaults" in graph["whitted.plugins.integrator"]    # absolute


def test_package_has_no_import_cycle():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_every_package_folder_is_installed():
    """A subpackage missing from pyproject's list works in an editable install only; a
    folder of data (the report's templates) is listed with its files as package data."""
    settings = _setuptools()
    data = set(settings.get("package-data", {}))
    listed = set(settings["packages"]) - data
    packages = {name for name, file in package_modules().items() if file.name == "__init__.py"}
    assert packages == listed
    assert data <= set(settings["packages"])


def test_converter_loads_neither_mitsuba_nor_drjit(tmp_path):
    """Importing the converter, parsing a scene with a texture (checked as an image Mitsuba
    can read: converter/textures.py) and converting it load no module of Mitsuba or Dr.Jit
    (checked in a fresh interpreter)."""
    from PIL import Image
    Image.new("RGB", (4, 2), (40, 80, 200)).save(tmp_path / "tex.png")
    (tmp_path / "tex.scn").write_text("size 8 8\nlight 1 1 1\nsphere 0 0 0 1 texture tex.png\n")
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(40))
    (tmp_path / "bad.scn").write_text("size 8 8\nsphere 0 0 0 1 texture bad.png\n")
    code = ("import sys\n"
            "import whitted.converter as c\n"
            "from whitted.cli import main\n"
            "assert c.parse_file('tex.scn').spheres[0].material.texture is not None\n"
            "status = main(['convert', 'tex.scn']), main(['convert', 'bad.scn', '--portable'])\n"
            "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('mitsuba', 'drjit'))\n"
            "print(*status, ','.join(heavy) or '-')\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert run.stdout.split() == ["0", "2", "-"], run.stderr
    assert (tmp_path / "tex.xml").is_file() and not (tmp_path / "bad.portable.xml").exists()
    assert f"bad.scn:2: sphere texture 'bad.png': {tmp_path / 'bad.png'} is not an image Mitsuba can read" \
        in run.stderr


#: what the plugins may import of the package above them: leaf modules that import nothing
#: of the package themselves (defaults, errors, float32 formulas, the giant spheres' text)
PLUGIN_FOUNDATIONS = {"whitted.defaults", "whitted.errors", "whitted.float32"}


def test_the_plugins_depend_on_nothing_above_them():
    """No arrow from plugins/ to the loader, the converter, the rendering API or the CLI
    (issue 28): the plugins are what those are built on, not the other way round."""
    graph = import_graph()
    for module, edges in graph.items():
        if module.startswith("whitted.plugins"):
            above = {m for m in edges if not m.startswith("whitted.plugins")}
            assert above <= PLUGIN_FOUNDATIONS, (module, above - PLUGIN_FOUNDATIONS)
    for module in PLUGIN_FOUNDATIONS:   # leaves: they import only each other
        assert graph[module] <= PLUGIN_FOUNDATIONS, (module, graph[module])
