"""Placeholder until the parser lands (issue 2)."""
from .scene import Scene


def parse_text(text, source):
    raise NotImplementedError


def parse_file(path):
    raise NotImplementedError
