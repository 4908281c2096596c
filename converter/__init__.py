"""Legacy text scenes (``.scn``) -> scene model -> scene description -> Mitsuba 3 XML (or ``mi.load_dict``)."""

from .description import Description, describe
from .parser import parse_file, parse_text
from .scene import Light, Material, Scene, Sphere
from .xml_writer import scene_to_xml

__all__ = ["Description", "Light", "Material", "Scene", "Sphere", "describe", "parse_file", "parse_text", "scene_to_xml"]
