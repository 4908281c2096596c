"""Draw docs/images/first_look.png, the README's first picture (``make images``).

``scenes/spheres.scn`` rendered the two ways a newcomer renders it first, each shown as
``whitted render`` writes its PNG: the article's model (plain sRGB, as the article
printed it) and Mitsuba's path tracer on the same converted scene (tone-mapped with
OpenColorIO's ACES 2.0 view: its physically lit floor runs far above 1 near the light).
Render times are measured here, compilation excluded, so they are this machine's.

Usage: ``python docs/images/first_look.py [-o FILE] [--spp N]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENE = HERE.parent.parent / "scenes" / "spheres.scn"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=str(HERE / "first_look.png"))
    parser.add_argument("--spp", type=int, default=256, help="the path tracer's samples per pixel")
    args = parser.parse_args()

    import whitted
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from whitted.atomic import atomic_path
    from whitted.images import default_view

    scene = whitted.load_scene(SCENE)
    whitted.render(scene)                                  # compile the kernels once, untimed
    article = whitted.render(scene)
    path = whitted.render(scene, integrator="path", spp=args.spp)
    panels = [(whitted.to_srgb(article.image, view=default_view("whitted")),
               f"the article's model: whitted render, 1 spp, {article.seconds * 1e3:.0f} ms"),
              (whitted.to_srgb(path.image, view=default_view("path")),
               f"Mitsuba's path tracer: --integrator path, {args.spp} spp, {path.seconds:.1f} s")]
    height, width = panels[0][0].shape[:2]
    fig = Figure(figsize=(2 * width / 100, height / 100 + 0.3), dpi=100)
    FigureCanvasAgg(fig)
    for k, (pixels, title) in enumerate(panels):
        ax = fig.add_axes((k / 2, 0, 0.5, height / (height + 30)))
        ax.imshow(pixels, interpolation="nearest")
        ax.set_axis_off()
        ax.set_title(title, fontsize=9)
    with atomic_path(args.output) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
