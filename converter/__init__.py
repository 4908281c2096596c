"""Legacy text scenes (``.scn``) -> scene model -> Mitsuba 3 XML."""

from .parser import parse_file, parse_text
from .scene import Light, Material, Scene, Sphere
from .xml_writer import scene_to_xml

__all__ = ["Light", "Material", "Scene", "Sphere", "parse_file", "parse_text", "scene_to_xml"]
