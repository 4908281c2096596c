"""Objects named as the ``.scn`` file names them: a sphere's shape and its material by the line
of the sphere (a shared material by its first sphere's) and the slug of that line's comment,
in the XML, in ``mi.traverse`` and wherever materials are found by id."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import mitsuba as mi
import pytest

import whitted
from conftest import REPO
from whitted.converter import Light, Material, Scene, Sphere, parse_file, parse_text, scene_to_xml
from whitted.converter.description import material_ids, material_labels, slug

MIRRORS = REPO / "scenes" / "mirrors.scn"


def expected_names(text: str) -> tuple[dict, dict]:
    """From a scene's text alone: each sphere's line -> its shape id, and each distinct material
    (its attributes' words) -> the id of the material of its first sphere."""
    shapes, materials = {}, {}
    for n, line in enumerate(text.splitlines(), 1):
        sphere = re.match(r"\s*sphere((?:\s+\S+){4})([^#]*)(?:#\s*(.*))?$", line)
        if sphere:
            comment = re.sub(r"[^a-z0-9]+", "_", (sphere.group(3) or "").lower()).strip("_")
            shapes[n] = f"sphere_l{n}" + (f"_{comment}" if comment else "")
            materials.setdefault(tuple(sphere.group(2).split()), shapes[n].replace("sphere_", "material_"))
    return shapes, materials


def ids_of(xml: str) -> tuple[list, list, list]:
    """The XML's shape ids, the BSDF id each shape refers to, and its BSDFs' ids."""
    root = ET.fromstring(xml)
    shapes = root.findall("shape")
    return ([s.get("id") for s in shapes], [s.find("ref").get("id") for s in shapes],
            [b.get("id") for b in root.findall("bsdf")])


def test_mirrors_objects_carry_their_lines_and_comments(tmp_path, llvm):
    text = MIRRORS.read_text()
    shapes, materials = expected_names(text)
    assert shapes[14] == "sphere_l14_the_floor" and len(materials) == 3   # the two mirrors share one
    xml = scene_to_xml(parse_file(MIRRORS), REPO / "scenes")
    shape_ids, refs, bsdf_ids = ids_of(xml)
    assert shape_ids == list(shapes.values())
    assert bsdf_ids == list(materials.values())
    words = [tuple(line.split("#")[0].split()[5:]) for n, line in enumerate(text.splitlines(), 1) if n in shapes]
    assert refs == [materials[w] for w in words]
    # the statement beside each material, as a comment
    assert "<!-- mirrors.scn:14: color 0.6 0.65 0.6  # the floor -->\n    <bsdf" in xml
    (tmp_path / "mirrors.xml").write_text(xml)
    keys = set(mi.traverse(mi.load_file(str(tmp_path / "mirrors.xml"))).keys())
    assert {f"{mid}.color.value" for mid in materials.values()} <= keys
    assert {f"{sid}.to_world" for sid in shapes.values()} <= keys
    assert keys == set(mi.traverse(whitted.load_scene(MIRRORS)).keys())   # the same from the .scn


def test_a_shared_material_is_named_by_its_first_sphere_and_equal_comments_stay_apart():
    text = ("light 5 5 5\nsphere 0 0 0 1  color 0.5 0.5 0.5  # ball\nsphere 2 0 0 1 color 0.5 0.5 0.5 # ball\n"
            "\n# a comment on its own line\nsphere 4 0 0 1  color 0.1 0.5 0.5  # ball\n")
    shapes, materials = expected_names(text)
    scenes = [parse_text(text, "balls.scn") for _ in range(2)]
    scenes[1].spheres = list(scenes[1].spheres)
    xmls = [scene_to_xml(scene, None) for scene in scenes]
    assert xmls[0] == xmls[1]   # spheres held as a list or as arrays
    shape_ids, refs, bsdf_ids = ids_of(xmls[0])
    assert shape_ids == ["sphere_l2_ball", "sphere_l3_ball", "sphere_l6_ball"] == list(shapes.values())
    assert refs == ["material_l2_ball", "material_l2_ball", "material_l6_ball"]
    assert bsdf_ids == list(materials.values())
    assert material_labels(parse_text(text, "balls.scn")) == {"material_l2_ball": "line 2 (ball)",
                                                             "material_l6_ball": "line 6 (ball)"}


@pytest.mark.parametrize("comment,expected", [
    ("the floor", "the_floor"),
    ("  A Red, half-MIRROR ball!  ", "a_red_half_mirror_ball"),
    ("a small blue ball in front of the others", "a_small_blue_ball_in"),   # cut after a word
    ("abcdefghijklmnopqrstuvwxyzabc", "abcdefghijklmnopqrstuvwx"),
    ("café crème", "cafe_creme"),
    ("球 -- !!", ""),
])
def test_slugs(comment, expected):
    assert slug(comment) == expected
    scene = parse_text(f"sphere 0 0 0 1 # {comment}\n", "s.scn")
    (mid,) = material_ids(scene).values()
    assert mid == "material_l1" + (f"_{expected}" if expected else "")
    assert re.fullmatch(r"[A-Za-z0-9_]+", mid) and len(expected) <= 24


def test_scenes_built_in_code_keep_numbered_ids():
    """No line: ``sphere_K`` and ``material_K`` as ever; a line two spheres claim names the first."""
    red, blue = Material(color=(0.9, 0.1, 0.1)), Material(color=(0.1, 0.1, 0.9))
    scene = Scene(lights=[Light((5.0, 5.0, 5.0))],
                  spheres=[Sphere((0.0, 0.0, 0.0), 1.0, red), Sphere((2.0, 0.0, 0.0), 1.0, blue),
                           Sphere((4.0, 0.0, 0.0), 1.0, red, line=7), Sphere((6.0, 0.0, 0.0), 1.0, blue, line=7)])
    shape_ids, refs, bsdf_ids = ids_of(scene_to_xml(scene, None))
    assert shape_ids == ["sphere_0", "sphere_1", "sphere_l7", "sphere_3"]
    assert refs == ["material_0", "material_1", "material_0", "material_1"] and bsdf_ids == ["material_0", "material_1"]


COMMENTED = ("# a header\nsize 8 6   # small\nlight 0 5 5 # key\nsphere 0 0 0 1 color 0.5 0.5 0.5 #  ball \n"
             "sphere 2 0 0 1 #\n  Sphere 4 0 0 1 reflect 0.5 # é\r\n")


@pytest.mark.parametrize("text", [COMMENTED, COMMENTED.replace("\n", "\r\n"), COMMENTED.replace("é", "e")])
def test_comments_are_read_alike_on_every_path(text):
    """The careful path and the fast path keep the same comments (a statement's, never one on
    a line of its own)."""
    expected = {2: "small", 3: "key", 4: "ball", 6: "é" if "é" in text else "e"}
    for careful in (True, False):
        assert parse_text(text, "c.scn", careful=careful).comments == expected, careful


def test_a_statement_over_several_lines_keeps_its_first_comment():
    scene = parse_text('sphere 0 0 0 1 \\  # first\n  color 1 0 0 # second\nlight 0 5 5\n', "c.scn")
    assert scene.comments == {1: "first"}
    assert list(material_ids(scene).values()) == ["material_l1_first"]


def test_grouped_spheres_keep_the_xml_s_material_ids(tmp_path, llvm):
    """A material whose first sphere is grouped into an ``ellipsoids`` shape when loaded
    (whitted.sealed) keeps its id on the spheres left as shapes."""
    balls = "".join(f"sphere {0.1 * i:.1f} 0.05 0 0.05 color 0.8 0.3 0.2\n" for i in range(20))
    text = "size 16 10\neye 0 1 6\nlight 3 5 4\n" + balls + "sphere 0 -1000 0 1000 color 0.8 0.3 0.2 # floor\n"
    path = tmp_path / "crowd.scn"
    path.write_text(text)
    keys = set(mi.traverse(whitted.load_scene(path, ellipsoids=True)).keys())
    assert "material_l4.color.value" in keys and any(key.startswith("sphere_l24_floor.") for key in keys)
    assert not any(key.startswith(("material_0", "sphere_l4.")) for key in keys)   # (the balls are a group)
    from whitted import sealed
    portable = sealed.described(parse_file(path), tmp_path, min_group=1).scene   # (for Mitsuba's own)
    assert {"material_l4", "sealed_material_l4"} <= set(portable)
