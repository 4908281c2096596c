"""Legacy text scenes (``.scn``) -> scene model -> scene description -> Mitsuba 3 XML (or ``mi.load_dict``)."""

from .description import Description, describe
from .parser import parse_file, parse_text
from .scene import Light, Material, Scene, Sphere


def __getattr__(name):   # the XML writer only when asked for (a render needs none)
    if name == "scene_to_xml":
        from .xml_writer import scene_to_xml
        return scene_to_xml
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["Description", "Light", "Material", "Scene", "Sphere", "describe", "parse_file", "parse_text", "scene_to_xml"]
