"""Giant spheres (docs/numerics.md, hazard 14): floors of radius 10^4 to 10^7 under small
balls, smallpt's Cornell box of six radius-10^5 walls, the eye inside a sky dome of radius
10^5. The Whitted integrator must match the float64 reference in both variants, with the
hazard suite's thresholds, at one sample per pixel.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import hazard_scenes as hs
import whitted
from float64_reference import Reference, assert_matches
from whitted.cli import main
from whitted.converter import Light, Material, Scene, Sphere, scene_to_xml
from whitted.converter.description import clip_range, describe, meshes
from whitted.converter.giants import MESH_TOLERANCE, coarse_spheres, parse_exact_spheres, sphere_mesh
from whitted.converter.xml_writer import xml_of
from whitted.metrics import relative_mse


@pytest.fixture(scope="module")
def giants():
    """``giants(name, what)``: the model, its reference image ("reference") or its render in
    a variant, each computed once."""
    cache = {}

    def get(name: str, what: str, **options):
        key = (name, what, tuple(sorted(options.items())))
        if (name, "model") not in cache:
            cache[(name, "model")] = hs.GIANTS[name]()
        model = cache[(name, "model")]
        if key not in cache:
            if what == "reference":
                cache[key] = Reference(model).render()
            else:
                previous = mi.variant()
                whitted.set_variant(what)
                try:
                    scene = mi.load_string(scene_to_xml(model, base_dir=None), **options)
                    cache[key] = whitted.render(scene).image
                finally:
                    whitted.set_variant(previous)
        return cache[key]
    return get


#: the scenes whose ``.scn`` file :func:`loaded` reads: the giants and the hazard scene with one
SCN_SCENES = {**hs.GIANTS, "large_floor": hs.large_floor}


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    """``loaded(name, meshes)``: the image of :data:`SCN_SCENES`' scene ``name`` written as a
    ``.scn`` file and read by ``whitted.load_scene(path, meshes=meshes)`` in the current
    variant, each rendered once (the loading paths' test and the meshes' test share it)."""
    folder = tmp_path_factory.mktemp("loaded")
    cache = {}

    def get(name: str, meshes: bool):
        key = (name, mi.variant(), meshes)
        if key not in cache:
            path = folder / f"{name}.scn"
            if not path.exists():
                path.write_text(_written(SCN_SCENES[name](), folder)[1])
            cache[key] = _rendered(whitted.load_scene(path, meshes=meshes))
        return cache[key]
    return get


@pytest.mark.parametrize("name", list(hs.GIANTS))
def test_giant_scene_matches_the_reference(giants, name, variant):
    assert_matches(giants(name, variant), giants(name, "reference"))


@functools.lru_cache(maxsize=None)
def _lit_floor(name: str) -> tuple[Scene, np.ndarray]:
    """The giant floor ``name`` with two more lights on it, and its reference image."""
    model = hs.GIANTS[name]()
    lit = dataclasses.replace(model, lights=[*model.lights[:1], Light((0.0, 0.0, 0.0), (0.6, 0.6, 0.6)),
                                             Light((-2.5, 0.0, 0.9), (0.3, 0.3, 0.3))])
    return lit, Reference(lit).render()


@pytest.mark.parametrize("name", ["floor_1e4", "floor_1e7"])
def test_lights_on_a_giant_floor_light_the_scene_as_in_the_reference(giants, name, variant):
    """Lights on a giant floor: one exactly on its top, one 7.06 / 2R above it, which is
    within the float64 bound of a floor of radius 10^7. A light lying on the floor starts
    its shadow rays off that floor's exact surface, not Mitsuba's float32 surface, which is
    ulps of R away. The two lights change more than half the pixels, so a black or unlit
    floor could not pass."""
    lit, reference = _lit_floor(name)
    assert (np.abs(reference - giants(name, "reference")).max(axis=2) > 0.02).mean() > 0.5
    assert_matches(whitted.render(mi.load_string(scene_to_xml(lit, base_dir=None))).image, reference)


def test_a_floor_of_the_largest_radius_leaves_the_camera_rays_at_the_eye(variant):
    """A floor of radius 10^12, the format's largest number, sets the far clip to 8·10^12: a
    near clip of 10^-12 of it (8 units) started the camera rays past the eye, 1 unit above the
    floor, and inside it (a quarter of the pixels unlit). The near clip stays under a
    thousandth of the nearest surface, and the image matches the float64 reference."""
    model = Scene(width=32, height=20, eye=(0.0, 1.0, 10.0), lookat=(0.0, 1.0, 0.0),
                  lights=[Light((0.0, 5.0, 10.0), (1.0, 1.0, 1.0))],
                  spheres=[Sphere((0.0, -1e12, 0.0), 1e12, Material((0.5, 0.5, 0.5))),
                           Sphere((0.0, 1.0, 0.0), 1.0, Material((1.0, 0.0, 0.0)))])
    near, far = clip_range(model)
    assert far > 8e12 and 1e-16 * far <= near <= 1e-3
    reference = Reference(model).render()
    assert (reference[-5:].max(axis=2) > 0.15).all()   # the floor's near rows are lit
    assert_matches(whitted.render(mi.load_string(scene_to_xml(model, base_dir=None))).image, reference)


def test_the_scenes_show_what_they_test(giants):
    """The floors are seen with their contact shadows and reflections, smallpt's box with
    its colored walls: not black images that would match anything."""
    for name in hs.GIANTS:
        image = giants(name, "reference")
        assert image.mean() > 0.15 and image.std() > 0.05, name
    box = giants("smallpt_box", "reference")
    left, right = box[:, :4].mean(axis=(0, 1)), box[:, -4:].mean(axis=(0, 1))
    assert left[0] > 2 * left[2] and right[2] > 2 * right[0]   # red wall left, blue right


def test_which_spheres_are_giant():
    """Floors from 10^4 on under balls of 0.3; not the sky dome, nor smallpt's walls (float32
    places them to 0.07, 4e-3 of its balls' radius 16.5, and renders them right), nor the
    floors of radius 100 to 1000 of the other hazard scenes (but large_floor's 10^4), nor
    the sky dome scene's floor of radius 10^3."""
    for name in ("floor_1e4", "floor_1e5", "floor_1e6", "floor_1e7"):
        model = hs.GIANTS[name]()
        assert coarse_spheres(model, model.lookat)[0] == [0], name
    box = hs.smallpt_box()
    assert coarse_spheres(box, box.lookat)[0] == []
    dome = hs.sky_dome()
    assert coarse_spheres(dome, dome.lookat)[0] == []   # 0.07 is nothing 10^5 away from everything
    for name in hs.HAZARDS:
        if name not in ("texture_poles", "arccos_range"):
            model = hs.HAZARDS[name]()
            giant = "exact_spheres" in describe(model, None).scene["integrator"]
            assert giant == (name == "large_floor"), name   # its floor has radius 10^4


def test_the_integrator_gets_the_exact_values():
    """The XML's ``exact_spheres`` holds the file's center minus lookat and radius in float64
    (float32 would hold the floor's center -10000000.5 as -10000000)."""
    model = hs.giant_floor(1e7)
    integrator = describe(model, None).scene["integrator"]
    [(key, center, radius)] = parse_exact_spheres(integrator["exact_spheres"])
    assert key == "sphere_0" and center == (0.0, -10000000.5, 0.0) and radius == 1e7
    assert float(np.float32(center[1])) != center[1]


def test_without_the_exact_values_the_floor_breaks_up(giants, variant):
    """The same XML with ``exact_spheres`` emptied is what the integrator did before: on a
    floor of radius 10^6 its offsets lift shadow and reflection rays over the balls."""
    model = hs.giant_floor(1e6)
    xml = scene_to_xml(model, base_dir=None)
    start = xml.index('<string name="exact_spheres"')
    xml = xml[:start] + xml[xml.index("/>", start) + 2:]
    previous = mi.variant()
    whitted.set_variant(variant)
    try:
        image = whitted.render(mi.load_string(xml)).image
    finally:
        whitted.set_variant(previous)
    off = (np.abs(image - giants("floor_1e6", "reference")).max(axis=2) > 0.02).mean()
    assert off > 0.05


@pytest.mark.parametrize("text, message", [
    ("sphere_0 0 0 0 1", "expected 'id: x y z r'"),
    ("sphere_0: 0 0 1", "expected 'id: x y z r'"),
    ("sphere_0: 0 0 zero 1", "four numbers"),
    ("sphere_0: 0 0 0 -1", "positive"),
])
def test_a_malformed_exact_spheres_property_is_refused(text, message):
    with pytest.raises(ValueError, match=message):
        parse_exact_spheres(text)


# -- the meshes Mitsuba's own integrators get ---------------------------------------------------------

def _deviation(positions, faces, center, radius):
    """Per triangle, how far its plane lies inside the sphere (bounds its distance off it)."""
    p0, p1, p2 = (np.asarray(positions, np.float64)[faces[:, k]] for k in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return radius - np.abs(np.einsum("ij,ij->i", normal, p0 - np.asarray(center, np.float64)))


def _point_triangle_distance(point, triangles):
    """The exact distance from ``point`` to each triangle (T×3×3): to the plane where the
    foot lies inside, else to the nearest edge."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    height = np.einsum("ij,ij->i", point - a, normal)
    foot = point - height[:, None] * normal

    def left_of(p0, p1):
        return np.einsum("ij,ij->i", np.cross(p1 - p0, foot - p0), normal) >= 0

    def to_segment(p0, p1):
        e = p1 - p0
        t = np.clip(np.einsum("ij,ij->i", point - p0, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        return np.linalg.norm(point - (p0 + t[:, None] * e), axis=1)
    inside = left_of(a, b) & left_of(b, c) & left_of(c, a)
    edges = np.minimum(np.minimum(to_segment(a, b), to_segment(b, c)), to_segment(c, a))
    return np.where(inside, np.abs(height), edges)


MESHED = {   # (center, radius, eye, distance from the eye to the lookat), in the frame
    "floor 1e4": ((0.0, -1e4 - 0.5, 0.0), 1e4, (0.0, 1.0, 8.0), 8.1),
    "floor 1e7": ((0.0, -1e7 - 0.5, 0.0), 1e7, (0.0, 1.0, 8.0), 8.1),
    "sky dome 1e5": ((0.0, -0.5, 0.0), 1e5, (0.0, 1.0, 8.0), 8.1),
    "smallpt's left wall, from inside": ((1e5 - 49.0, 0.0, 0.0), 1e5, (0.0, 5.2, 74.0), 74.2),
}


@pytest.mark.parametrize("case", list(MESHED))
def test_the_mesh_keeps_to_the_sphere_within_its_bound(case):
    """Vertices on the sphere, every point of every triangle (sampled on a grid of its
    barycentric coordinates) within MESH_TOLERANCE of its distance from the eye off the
    sphere's equation |x − C| = r, closed (every edge in exactly two triangles) and wound
    outwards."""
    center, radius, eye, view = MESHED[case]
    positions, normals, faces = sphere_mesh(center, radius, eye, view)
    c, e = np.asarray(center), np.asarray(eye)
    assert np.abs(np.linalg.norm(positions - c, axis=1) - radius).max() <= 1e-12 * radius
    np.testing.assert_allclose(normals, (positions - c) / radius, atol=1e-12)
    triangles = positions[faces]
    distance = _point_triangle_distance(e, triangles)
    grid = np.array([(i, j, 8 - i - j) for i in range(9) for j in range(9 - i)], np.float64) / 8
    for weights in grid:
        x = np.einsum("k,tkj->tj", weights, triangles)
        off = radius - np.linalg.norm(x - c, axis=1)
        assert off.min() >= -1e-12 * radius                    # inscribed
        assert (off / distance).max() <= MESH_TOLERANCE
    # the planes' own bound, the one sphere_mesh's docstring derives
    assert (_deviation(positions, faces, center, radius) / distance).max() <= MESH_TOLERANCE
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()
    outward = np.einsum("ij,ij->i", np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]),
                        triangles.mean(axis=1) - c)
    assert (outward > 0).all()


def test_the_mesh_bound_is_below_a_pixel():
    """MESH_TOLERANCE is an angle seen from the eye: below a pixel of a 2048-pixel-wide image
    at 45° (the default image is 640 wide), the finest the format's default fov is viewed."""
    assert MESH_TOLERANCE < math.radians(45.0) / 2048


def test_both_routes_give_mitsuba_the_same_mesh(tmp_path, llvm):
    """``whitted convert`` writes the mesh beside the XML; ``load_scene`` of the .scn reads the
    same bytes from the cache: the same scene, parameter by parameter (the meshes' vertices
    too), with the same exact spheres for the Whitted integrator."""
    from test_scene_building import assert_same_scene
    source = tmp_path / "floor.scn"
    source.write_text("size 48 32\neye 0 1.5 8\nlookat 0 0.5 0\nlight 3 6 4\n"
                      "sphere 0 -100000 0 100000\nsphere 0 1 0 1\n")
    assert main(["convert", str(source)]) == 0
    # the floor is the sphere of line 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["floor.scn", "floor.sphere_l5.ply", "floor.xml"]
    from_xml = whitted.load_scene(tmp_path / "floor.xml")
    from_scn = whitted.load_scene(source)
    assert_same_scene(from_xml, from_scn)
    floor = {shape.id(): shape for shape in from_xml.shapes()}["sphere_l5"]
    assert "Mesh" in floor.class_name()
    assert from_xml.integrator().exact_spheres == from_scn.integrator().exact_spheres != []


def _path_against_whitted(scene):
    """(relative MSE, share of pixels off by more than 0.1): Mitsuba's path tracer with direct
    light only (512 spp) against the physically lit Whitted render at depth 1 (64 spp)."""
    whitted_image = whitted.render(scene, lighting="physical", max_depth=1, spp=64).image
    path_image = whitted.render(scene, integrator="path", max_depth=1, spp=512).image
    off = (np.abs(path_image - whitted_image).max(axis=2) > 0.1).mean()
    return relative_mse(path_image, whitted_image), off


@pytest.mark.slow
@pytest.mark.parametrize("route", ["scn", "xml"])
@pytest.mark.parametrize("name", list(hs.GIANTS))
def test_mitsubas_path_tracer_is_free_of_acne(tmp_path, llvm, name, route):
    """On a black background, direct light only, Mitsuba's path tracer computes what the
    physically lit Whitted integrator does at depth 1: acne would darken the giant spheres
    (before the meshes: 31 % of the pixels off by more than 0.1 on the floor of radius 10^4,
    60 % at 10^7, 2 % in smallpt's box at this size)."""
    model = dataclasses.replace(hs.GIANTS[name](), background=(0.0, 0.0, 0.0), source=tmp_path / f"{name}.scn")
    if route == "scn":   # the model stands for the parsed file (load_scene's model=)
        model.source.write_text("# see hazard_scenes.GIANTS\n")
        scene = whitted.load_scene(model.source, model=model)
    else:
        description = describe(model, base_dir=tmp_path)
        for mesh in meshes(description):
            (tmp_path / mesh.filename).write_bytes(mesh.data)
        (tmp_path / f"{name}.xml").write_text(xml_of(description))
        scene = whitted.load_scene(tmp_path / f"{name}.xml")
    error, off = _path_against_whitted(scene)
    assert error <= 2e-3 and off <= 0.01, f"relative MSE {error:.2e}, {off:.2%} of pixels off by > 0.1"


@pytest.mark.parametrize("radius", [1e4, 1e7])
def test_rays_leaving_a_giant_floor_do_not_meet_it_again(variant, radius):
    """test_acne.py's experiment on the float64 finder: hits on a floor of radius 10^4 or
    10^7 near the balls, found by camera rays; a ray leaving each hit upwards must miss the
    floor, one leaving downwards must meet it again (its far side), and the shadow segment
    to a light above must be clear, all with the offsets of the point's own error bound."""
    from whitted.plugins.scene_tables import scene_tables
    from whitted.plugins.hits import scene_hits
    from whitted.plugins.hits import spawn_ray, spawn_ray_to
    model = Scene(eye=(0.0, 1.5, 8.0), lookat=(0.0, 0.5, 0.0), lights=[Light((0.0, 10.0, 0.0))],
                  spheres=[Sphere((0.0, -radius, 0.0), radius), Sphere((40.0, 0.3, -40.0), 0.3)])
    scene = mi.load_string(scene_to_xml(model, None))
    hits = scene_hits(scene, scene_tables(scene), False, scene.integrator().exact_spheres)
    rng = np.random.default_rng(7)
    count = 2000 if dr.is_jit_v(mi.Float) else 300
    target = np.stack([rng.uniform(-6, 6, count), np.full(count, -0.5), rng.uniform(-6, 6, count)], axis=1)
    eye = np.array(model.eye) - np.array(model.lookat)
    direction = target - eye
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    light = mi.Point3f(0.0, 9.5, 0.0)
    escaped = shadowed = 0
    for k in range(1 if dr.is_jit_v(mi.Float) else count):
        d = direction if dr.is_jit_v(mi.Float) else direction[k:k + 1]
        ray = mi.Ray3f(mi.Point3f(*(float(c) for c in eye)),
                       mi.Vector3f(*(d.T.astype(np.float32) if dr.is_jit_v(mi.Float) else map(float, d[0]))))
        hit, si, _, error = hits.intersect(ray, False)
        up = mi.Vector3f(0.0, 1.0, 0.0)
        again, _, _, _ = hits.intersect(spawn_ray(si, error, up), False)
        down, _, _, _ = hits.intersect(spawn_ray(si, error, -up), False)
        blocked = hits.blocked(spawn_ray_to(si, error, light), hit)
        assert np.all(np.array(hit))
        escaped += int(np.sum(np.array(~down if dr.is_jit_v(mi.Float) else not down)))
        shadowed += int(np.sum(np.array(again | blocked if dr.is_jit_v(mi.Float) else again or blocked)))
    assert escaped == 0 and shadowed == 0


# -- every way a scene reaches the Whitted integrator ----------------------------------------------

def _written(model, folder):
    """``model`` as a ``.scn`` file in ``folder`` (``folder/NAME.scn``) and its text."""
    from whitted.converter.scn_writer import scene_to_scn
    text = scene_to_scn(model, folder)
    path = folder / "scene.scn"
    path.write_text(text)
    return path, text


def _rendered(scene):
    return whitted.render(scene).image


def _cli_render(path, folder):
    out = folder / "cli.exr"
    assert main(["render", str(path), "-o", str(out), "--variant", mi.variant(), "-q"]) == 0
    return whitted.read_image(out)


def _cli_folder(path, folder):
    out = folder / "frames"
    assert main(["render", str(path.parent), "-o", f"{out}/", "--format", "exr", "--variant", mi.variant(), "-q"]) == 0
    return whitted.read_image(out / f"{path.stem}.exr")


def _converted(path, folder):
    assert main(["convert", str(path), "-o", str(folder / "scene.xml")]) == 0
    return _rendered(mi.load_file(str(folder / "scene.xml")))


def _fit_scene(path, folder):
    from whitted.loading import load_model_parts
    from whitted.converter import parse_file
    model = parse_file(path)
    return _rendered(load_model_parts(model, {}, None, "whitted", False)[0])


def _compare_scene(path, folder):
    from whitted.compare.scenes import SceneFile
    return _rendered(SceneFile.read(path).load())


#: name -> image of the scene file ``path`` (written in ``folder``) by that way of loading it,
#: in the current variant: the command line (one scene, a folder), the XML through Mitsuba,
#: the Python API, the fit's scene and compare's
LOADING_PATHS = {
    "whitted render": _cli_render,
    "whitted render FOLDER/": _cli_folder,
    "whitted convert, mi.load_file": _converted,
    "whitted.load_scene": lambda path, folder: _rendered(whitted.load_scene(path)),
    "whitted.load_scene, grouped": lambda path, folder: _rendered(whitted.load_scene(path, ellipsoids=True)),
    "whitted.loads": lambda path, folder: _rendered(whitted.loads(path.read_text(), base_dir=folder)),
    "whitted fit": _fit_scene,
    "whitted compare": _compare_scene,
}


#: the loading paths' cases: every giant scene in llvm_ad_rgb; in scalar_rgb, whose scenes are
#: loaded by the same code, the floor of radius 10^7, where a float32 sphere is farthest off
LOADED_CASES = [*(("llvm_ad_rgb", name) for name in hs.GIANTS), ("scalar_rgb", "floor_1e7")]


@pytest.mark.parametrize("variant, name", LOADED_CASES, indirect=["variant"])
def test_every_loading_path_matches_the_reference(giants, loaded, tmp_path, name, variant):
    """Each way a scene is loaded (:data:`LOADING_PATHS`) gives the Whitted integrator the
    exact giant spheres: floors of radius 10^4 to 10^7, smallpt's walls, the sky dome, all
    against the float64 reference. A way that hands over Mitsuba's float32 sphere where the
    integrator expects the exact one (a light 3 units above a floor of radius 10^7 lies
    within that sphere's error bound of 7) moves the shadows."""
    model = hs.GIANTS[name]()
    path, _ = _written(model, tmp_path)
    failures = []
    for way, load in LOADING_PATHS.items():
        folder = tmp_path / way.replace(" ", "_").replace("/", "").replace(",", "")
        folder.mkdir()
        try:
            image = loaded(name, True) if way == "whitted.load_scene" else load(path, folder)
            assert_matches(image, giants(name, "reference"))
        except AssertionError as error:
            failures.append(f"{way}: {error}".splitlines()[0])
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("name", list(SCN_SCENES))
def test_meshes_or_spheres_the_whitted_image_is_the_same(loaded, name, variant):
    """``whitted render`` loads a ``.scn`` with its giant spheres as Mitsuba spheres, not the
    meshes Mitsuba's own integrators get (``load_scene(meshes=False)``): the Whitted
    integrator intersects them itself, so the images are the same bit for bit, on every giant
    scene and the hazard scene that holds a giant."""
    assert loaded(name, True).tobytes() == loaded(name, False).tobytes()


def test_an_exact_sphere_the_scene_lacks_is_refused(llvm):
    """An ``exact_spheres`` entry whose shape is missing (an XML edited by hand, meshes merged
    by Mitsuba) would leave that sphere to Mitsuba's float32 test: refused, naming it."""
    xml = scene_to_xml(hs.giant_floor(1e7), base_dir=None).replace('"sphere_0: ', '"sphere_9: ')
    with pytest.raises(whitted.WhittedError, match="exact_spheres names shapes the scene lacks: sphere_9"):
        whitted.render(mi.load_string(xml))


def test_a_render_keeps_the_shapes_names(llvm):
    """The scene of the other shapes the integrator traces holds the same shape objects:
    their ids, and so ``mi.traverse``'s keys, stay those of the file."""
    scene = mi.load_string(scene_to_xml(hs.smallpt_box(), base_dir=None))
    before = [shape.id() for shape in scene.shapes()]
    keys = set(mi.traverse(scene).keys())
    whitted.render(scene)
    assert [shape.id() for shape in scene.shapes()] == before
    assert set(mi.traverse(scene).keys()) == keys
    assert sorted(before) == [f"sphere_{k}" for k in range(8)]   # no walls merged into one mesh
