"""The sphereflake benchmark scene (benchmarks/sphereflake.py) against its definition.

Expectations come from the SPD's description of "balls": 9^n spheres at level n,
each of a third of its parent's radius and touching it, six on the parent's
equator and three above it, no two siblings overlapping; the scene written as
``.scn`` text parses back to the same model.
"""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import pytest

from benchmarks import sphereflake
from whitted.converter import parse_text



def _sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def _norm(a):
    return math.sqrt(sum(x * x for x in a))


def _unit(a):
    n = _norm(a)
    return tuple(x / n for x in a)


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def _flake(level):
    """The flake's spheres, one record each (center, radius, axis, parent, level)."""
    f = sphereflake.flake_arrays(level)
    return [SimpleNamespace(center=tuple(c), radius=r, axis=tuple(a), parent=p, level=n) for c, r, a, p, n in
            zip(f.centers.tolist(), f.radii.tolist(), f.axes.tolist(), f.parents.tolist(), f.levels.tolist())]


@pytest.mark.parametrize("level, total", [(0, 1), (1, 10), (2, 91), (3, 820), (4, 7381)])
def test_sphere_counts_per_level(level, total):
    spheres = _flake(level)
    assert len(spheres) == total == sphereflake.count(level)
    for n in range(level + 1):
        at_n = [s for s in spheres if s.level == n]
        assert len(at_n) == 9 ** n
        assert all(math.isclose(s.radius, 0.5 / 3 ** n, rel_tol=1e-12) for s in at_n)


def test_level_5_and_6_counts_without_building_them():
    assert sphereflake.count(5) == 66430
    assert sphereflake.count(6) == 597871 and 6 in sphereflake.LEVELS


def _turn_z_to(axis, v):
    """``v`` turned by the smallest rotation that takes +Z onto the unit vector ``axis``."""
    ax, ay, az = axis
    s = math.hypot(ax, ay)                 # sin of the angle between +Z and axis
    if s == 0.0:                           # axis = +Z, or -Z: half a turn about Y
        return v if az > 0 else (-v[0], v[1], -v[2])
    kx, ky = -ay / s, ax / s               # the rotation's unit axis, +Z × axis, normalized
    c = az
    x, y, z = v
    k_dot_v = kx * x + ky * y
    # Rodrigues: v cos + (k × v) sin + k (k·v)(1 - cos), with k = (kx, ky, 0)
    return (x * c + ky * z * s + kx * k_dot_v * (1 - c),
            y * c - kx * z * s + ky * k_dot_v * (1 - c),
            z * c + (kx * y - ky * x) * s)


def _recursive_flake(level):
    """The flake as the SPD builds it, a sphere at a time (depth first): what the arrays must equal."""
    spheres = []

    def grow(center, radius, axis, parent, depth):
        index = len(spheres)
        spheres.append((center, radius, axis, parent, depth))
        if depth == level:
            return
        child_radius = radius * sphereflake.SCALE
        distance = radius + child_radius
        for direction in sphereflake.CHILDREN:
            d = _turn_z_to(axis, direction)
            grow(tuple(c + distance * e for c, e in zip(center, d)), child_radius, d, index, depth + 1)

    grow((0.0, 0.0, 0.0), sphereflake.RADIUS, (0.0, 0.0, 1.0), -1, 0)
    return spheres


@pytest.mark.parametrize("level", [0, 1, 3])
def test_arrays_are_the_recursion_bit_for_bit(level):
    built = [(s.center, s.radius, s.axis, s.parent, s.level) for s in _flake(level)]
    assert built == _recursive_flake(level)   # == on floats: the same bits, the same order


def test_children_touch_their_parent_on_its_equator_and_above():
    spheres = _flake(3)
    children = {i: [] for i in range(len(spheres))}
    for s in spheres[1:]:
        children[s.parent].append(s)
    for i, parent in enumerate(spheres):
        kids = children[i]
        assert len(kids) == (9 if parent.level < 3 else 0)
        if not kids:
            continue
        # the parent's axis: from its own parent to it (+Z for the first sphere)
        axis = (0.0, 0.0, 1.0) if parent.parent < 0 else _unit(_sub(parent.center, spheres[parent.parent].center))
        elevations = []
        for kid in kids:
            assert math.isclose(kid.radius, parent.radius / 3, rel_tol=1e-12)
            gap = _norm(_sub(kid.center, parent.center))
            assert math.isclose(gap, parent.radius + kid.radius, rel_tol=1e-12)
            elevations.append(math.degrees(math.asin(_dot(_unit(_sub(kid.center, parent.center)), axis))))
        equator = [e for e in elevations if abs(e) < 1e-9]
        above = [e for e in elevations if abs(e - math.degrees(math.asin(math.sqrt(2 / 3)))) < 1e-9]
        assert (len(equator), len(above)) == (6, 3)


def test_siblings_do_not_overlap():
    spheres = _flake(2)
    for parent in range(len(spheres)):
        kids = [s for s in spheres if s.parent == parent]
        for a, b in itertools.combinations(kids, 2):
            assert _norm(_sub(a.center, b.center)) > a.radius + b.radius


def test_scene_is_the_spd_view_and_parses_back(tmp_path):
    model = sphereflake.scene(2)
    assert (model.width, model.height, model.depth, model.samples, model.fov) == (512, 512, 5, 1, 45)
    assert model.eye == (2.1, 1.3, 1.7) and model.up == (0, 0, 1) and len(model.lights) == 3
    floor = model.spheres[-1]
    assert math.isclose(floor.center[2] + floor.radius, -0.5) and floor.material.reflect == 0
    assert all(s.material.reflect == 0.5 for s in model.spheres[:-1])

    path = sphereflake.write(2, tmp_path / "flake.scn")
    parsed = parse_text(path.read_text(), path)
    assert len(parsed.spheres) == 92
    assert [(s.center, s.radius, s.material) for s in parsed.spheres] == \
        [(s.center, s.radius, s.material) for s in model.spheres]
    assert [(l.position, l.color) for l in parsed.lights] == [(l.position, l.color) for l in model.lights]
    assert (parsed.eye, parsed.lookat, parsed.up, parsed.background, parsed.ambient) == \
        (model.eye, model.lookat, model.up, model.background, model.ambient)


def test_command_line(tmp_path):
    out = tmp_path / "f1.scn"
    assert sphereflake.main(["1", "-o", str(out)]) == 0
    assert len(parse_text(out.read_text(), out).spheres) == 11
    with pytest.raises(SystemExit):
        sphereflake.main(["7", "-o", str(out)])
    with pytest.raises(SystemExit):
        sphereflake.main(["1", "--floor-radius", "0", "-o", str(out)])


@pytest.mark.parametrize("options, message", [
    (["--floor-radius", "inf"], "--floor-radius must be positive and at most 1e12 - 0.5, got inf"),
    (["--floor-radius", "1e300"], "--floor-radius must be positive and at most 1e12 - 0.5"),
    (["--floor-radius", "nan"], "--floor-radius must be positive"),
    (["-o", "/proc/f1.scn"], "/proc/f1.scn: cannot write in /proc"),
    (["-o", "{tmp}/no/f1.scn"], "{tmp}/no/f1.scn: output folder {tmp}/no does not exist"),
    (["-o", "{tmp}"], "{tmp}: is a folder; give a file name")])
def test_a_bad_option_is_one_line_and_no_file(tmp_path, capsys, options, message):
    """A floor the scene format cannot hold (an exit status of 0 and a scene no command
    reads) and an output that cannot be written (a traceback) are usage errors; nothing is
    written."""
    words = [w.format(tmp=tmp_path) for w in options]
    with pytest.raises(SystemExit) as stop:
        sphereflake.main(["1", *words] + ([] if "-o" in words else ["-o", str(tmp_path / "f1.scn")]))
    assert stop.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert "Traceback" not in err and message.format(tmp=tmp_path) in err[-1], err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("radius", [1000.0, 1e4])
def test_floor_radius_keeps_the_floor_top_in_place(tmp_path, radius):
    out = tmp_path / "f1.scn"
    assert sphereflake.main(["1", "--floor-radius", str(radius), "-o", str(out)]) == 0
    floor = parse_text(out.read_text(), out).spheres[-1]
    assert floor.radius == radius and floor.center == (0, 0, sphereflake.FLOOR_HEIGHT - radius)
    assert floor.center[2] + floor.radius == sphereflake.FLOOR_HEIGHT
    assert sphereflake.scene(1, floor_radius=radius).spheres[-1] == sphereflake.floor(radius)
    # the default floor's scene is written as before the option existed (same title, same lines)
    default = sphereflake.write(1, tmp_path / "default.scn")
    differing = [a for a, b in zip(default.read_text().splitlines(), out.read_text().splitlines()) if a != b]
    if radius == sphereflake.FLOOR_RADIUS:
        assert differing == []
    else:
        assert len(differing) == 2 and differing[0].startswith("# ") and differing[1].startswith("sphere 0 0 -1000.5 1000 ")
