"""Render the pictures of docs/lessons.md into docs/images/lessons/ (``make images``).

Each ``whitted render`` line of the page's ``sh`` blocks is run as written, in this
process (``whitted.cli.main``), from the repository's folder, but writing its PNG here
instead of under ``out/lessons/``: the pictures are the commands' own, kept at half their
size (each 2×2 block of pixels averaged) to keep the repository small.

Usage: ``python docs/images/lessons.py``
"""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
PAGE = REPO / "docs" / "lessons.md"
FOLDER = HERE / "lessons"


def commands() -> list[list[str]]:
    """The arguments of every ``whitted render`` line of the page's ``sh`` blocks."""
    found = []
    for block in re.findall(r"^```sh\n(.*?)^```", PAGE.read_text(encoding="utf-8"), re.S | re.M):
        for line in block.splitlines():
            words = shlex.split(line, comments=True)
            if words[:2] == ["whitted", "render"]:
                found.append(words[1:])
    return found


def main() -> None:
    from PIL import Image

    from whitted.cli import main as whitted

    FOLDER.mkdir(exist_ok=True)
    os.chdir(REPO)
    for args in commands():
        out = args.index("-o") + 1
        args[out] = str(FOLDER / Path(args[out]).name)
        if whitted([*args, "-q"]) != 0:
            raise SystemExit(f"failed: whitted {' '.join(args)}")
        with Image.open(args[out]) as image:
            half = image.convert("RGB").reduce(2)
        half.save(args[out], optimize=True)
        print(f"wrote {args[out]}")


if __name__ == "__main__":
    main()
