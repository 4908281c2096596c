"""The Jinja environment of a package's ``templates`` folder: ``whitted trace``'s page and
``whitted compare``'s outputs, HTML escaped and text as written.
"""

from __future__ import annotations


def environment(package: str):
    """Templates of ``package`` (``whitted.trace``): ``*.html.j2`` autoescaped, undefined names
    an error, block tags leaving no blank lines."""
    import jinja2

    return jinja2.Environment(loader=jinja2.PackageLoader(package, "templates"),
                              autoescape=jinja2.select_autoescape(["html.j2"]),
                              undefined=jinja2.StrictUndefined, trim_blocks=True,
                              lstrip_blocks=True)
