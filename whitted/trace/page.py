"""The ray trees drawn: a page to project (``whitted trace -o PAGE.html``: the 1 spp image
with the pixels marked, a plotly 3D view of the rays and each tree as a table, offline) and
a notebook's view (the 3D view and the tables).
"""

from __future__ import annotations

import base64
import io
import math

import numpy as np

from ..atomic import write_text
from ..defaults import VERSION
from .nodes import KINDS, xyz

#: each kind of ray's colour, in the view and the tables
COLORS = {"camera": "#222222", "reflection": "#1f77b4", "refraction": "#2ca02c",
          "total internal reflection": "#b03cc8", "shadow": "#e0a800", "blocked": "#888888",
          "background": "#d62728"}
#: the most spheres drawn whole; a larger scene shows only the spheres its rays meet
MAX_SPHERES = 200
#: the image is enlarged by a whole factor (pixels stay square) to at least this width
IMAGE_WIDTH = 560


def _box(view, points) -> tuple[np.ndarray, np.ndarray]:
    eye = [view.eye] if view.eye is not None else []
    points = np.array([*points, *(p for p, _, _ in view.lights), *eye], np.float64)
    return points.min(axis=0), points.max(axis=0)


def _sphere_mesh(center, radius, toward, reach):
    """A sphere as a triangle mesh: whole when small against ``reach``, else its cap facing ``toward``."""
    center = np.asarray(center, np.float64)
    axis = np.asarray(toward, np.float64) - center
    norm = np.linalg.norm(axis)
    axis = axis / norm if norm > 0 else np.array([0.0, 1.0, 0.0])
    cap = math.pi if radius <= reach else min(math.pi, 1.5 * reach / radius)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    rings, segments = (12, 24) if cap == math.pi else (16, 32)
    theta = np.linspace(0.0, cap, rings + 1)
    phi = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    directions = (np.cos(t)[..., None] * axis + np.sin(t)[..., None] *
                  (np.cos(p)[..., None] * u + np.sin(p)[..., None] * v))
    vertices = (center + radius * directions).reshape(-1, 3)
    r, s = np.divmod(np.arange(rings * segments), segments)
    a, b = r * segments + s, r * segments + (s + 1) % segments
    i, j, k = np.stack([a, b], 1), np.stack([a + segments] * 2, 1), np.stack([b, b + segments], 1)
    return vertices, (i.ravel().tolist(), j.ravel().tolist(), k.ravel().tolist())


def _color(rgb) -> str:
    r, g, b = (int(round(255 * min(1.0, max(0.0, float(c))) ** (1 / 2.2))) for c in rgb)
    return f"rgb({r},{g},{b})"


def figure(view, trees):
    """The plotly figure of the scene and the trees' rays (shadow rays dashed where blocked)."""
    import plotly.graph_objects as go

    low, high = _box(view, [p for tree in trees for node in tree.root.walk()
                            for p in (node.origin, node.position) if p is not None])
    center, size = (low + high) / 2, max(float(np.max(high - low)), 1e-9)
    reach = 2.0 * size
    fig = go.Figure()
    used = {ref.index for tree in trees for node in tree.root.walk()
            for ref in (node.sphere, *(term.blocker for term in node.lights)) if ref is not None}
    shown = range(len(view.radii)) if len(view.radii) <= MAX_SPHERES else sorted(used)
    for k in shown:
        ref = view.sphere(k)
        vertices, (i, j, kk) = _sphere_mesh(ref.center, ref.radius, center, reach)
        color = ("rgb(140,190,225)" if view.glass is not None and view.glass[k]   # glass, so that it shows
                 else _color(view.colors[k]) if view.colors is not None else "rgb(190,190,190)")
        fig.add_trace(go.Mesh3d(x=vertices[:, 0], y=vertices[:, 1], z=vertices[:, 2], i=i, j=j, k=kk,
                                color=color, opacity=0.3 if k in used else 0.15,
                                name=ref.short(), hovertext=ref.short(), hoverinfo="text",
                                showlegend=False, flatshading=True))
    if view.lights:
        spots = np.array([p for p, _, _ in view.lights])
        fig.add_trace(go.Scatter3d(x=spots[:, 0], y=spots[:, 1], z=spots[:, 2], mode="markers+text",
                                   marker=dict(size=7, color="#ffcc00", symbol="diamond",
                                               line=dict(color="#8a6d00", width=1)),
                                   text=[f"light {k + 1}" for k in range(len(view.lights))],
                                   textposition="top center", name="lights", hoverinfo="text"))
    if view.eye is not None:
        fig.add_trace(go.Scatter3d(x=[view.eye[0]], y=[view.eye[1]], z=[view.eye[2]], mode="markers+text",
                                   marker=dict(size=5, color="#222222"), text=["eye"], name="eye",
                                   textposition="top center", hoverinfo="text"))
    segments: dict = {kind: ([], []) for kind in (*KINDS, "background", "shadow", "blocked")}

    def add(kind, a, b, label):
        xs, labels = segments[kind]
        xs += [a, b, (None, None, None)]
        labels += [label, label, None]

    escape = 0.5 * size
    for number, tree in enumerate(trees, start=1):
        for node in tree.root.walk():
            label = f"pixel {number} ({tree.x}, {tree.y}): {node.kind}, level {node.level}, weight {node.weight:.3g}"
            if node.hit:
                add(node.kind, node.origin, node.position, label + f", hits {node.sphere.short() if node.sphere else ''}")
                for term in (term for term in node.lights if term.shadow is not None):
                    ray = term.shadow
                    end = np.asarray(ray["origin"]) + np.asarray(ray["direction"]) * ray["length"]
                    add("blocked" if term.blocked else "shadow", node.position, tuple(end),
                        f"pixel {number}: shadow ray to light {term.index + 1}, {term.state()[0]}")
            else:
                end = tuple(np.asarray(node.origin) + np.asarray(node.direction) * escape)
                add("background", node.origin, end, label + ", missed: background")
    names = {"background": "missed (to the background)", "shadow": "shadow ray, lit",
             "blocked": "shadow ray, blocked"}
    for kind, (xs, labels) in segments.items():
        if not xs:
            continue
        points = np.array([(np.nan,) * 3 if p[0] is None else p for p in xs], np.float64)
        dash = "dash" if kind in ("blocked", "background") else "solid"
        width = 2 if kind in ("shadow", "blocked") else 5
        fig.add_trace(go.Scatter3d(x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="lines",
                                   line=dict(color=COLORS[kind], width=width, dash=dash),
                                   name=names.get(kind, kind), hovertext=labels, hoverinfo="text",
                                   connectgaps=False))
    blockers = [term.blocker_point for tree in trees for node in tree.root.walk() for term in node.lights
                if term.blocked and term.blocker_point is not None]
    if blockers:
        b = np.array(blockers)
        fig.add_trace(go.Scatter3d(x=b[:, 0], y=b[:, 1], z=b[:, 2], mode="markers", name="where blocked",
                                   marker=dict(size=4, color="#555555", symbol="x"), hoverinfo="name"))
    low, high = _box(view, [p for xs, _ in segments.values() for p in xs if p[0] is not None])
    pad = 0.08 * float(np.max(high - low)) + 1e-9
    low, high = low - pad, high + pad
    span = np.maximum(high - low, 1e-3 * float(np.max(high - low)))
    aspect = span / float(span.max())
    fig.update_layout(
        scene=dict(aspectmode="manual", aspectratio=dict(x=aspect[0], y=aspect[1], z=aspect[2]),
                   xaxis=dict(range=[low[0], high[0]], title="x"), yaxis=dict(range=[low[1], high[1]], title="y"),
                   zaxis=dict(range=[low[2], high[2]], title="z"),
                   camera=_camera(view, trees, (low + high) / 2, span, aspect)),
        margin=dict(l=0, r=0, t=0, b=0), height=560,
        legend=dict(x=1, xanchor="right", y=1, bgcolor="rgba(255,255,255,.75)", font=dict(size=11)),
        uirevision="keep")
    return fig


def _camera(view, trees, middle, span, aspect):
    """Plotly's camera: behind the eye, a little above and aside so that depth shows, ``y`` up."""
    if view.eye is None:
        return {}

    def normalized(p):
        return (np.asarray(p, np.float64) - middle) / span * aspect
    focus = [view.eye] + [node.position for tree in trees for node in tree.root.walk() if node.hit]
    focus = np.array(focus, np.float64)
    target = normalized((focus.min(axis=0) + focus.max(axis=0)) / 2)
    back = normalized(view.eye) - target
    n = np.linalg.norm(back)
    direction = back / n if n > 0 else np.array([0.0, 0.0, 1.0])
    direction = direction + np.array([0.45, 0.55, 0.0])
    direction /= np.linalg.norm(direction)
    position = target + 1.7 * direction
    return dict(eye=dict(x=float(position[0]), y=float(position[1]), z=float(position[2])),
                center=dict(x=float(target[0]), y=float(target[1]), z=float(target[2])), up=dict(x=0, y=1, z=0))


def _render(view, trees, div_id: str, **parts) -> str:
    from ..templates import environment

    return environment("whitted.trace").get_template("trace.html.j2").render(
        trees=trees, version=VERSION, kinds=KINDS, colors=COLORS, css=_color, xyz=xyz,
        gap=lambda tree: float(np.abs(np.subtract(tree.total(), tree.color)).max()),
        figure=figure(view, trees).to_html(full_html=False, include_plotlyjs=True, div_id=div_id,
                                           config={"displaylogo": False, "responsive": True}),
        **parts)


def fragment(view, trees) -> str:
    """The 3D view and the tables, for a notebook (no image: nothing is rendered)."""
    return _render(view, trees, f"trace-3d-{id(trees):x}", page=False, image=None)


def _image(traces) -> dict:
    """The 1 spp image as a PNG data URI, its size and its zoom."""
    from PIL import Image

    from ..images import default_view, to_srgb
    from ..rendering import render_checked
    s = traces.settings
    result = render_checked(traces.scene, spp=1, max_depth=s["max_depth"], lighting=s["lighting"],
                            min_weight=s["min_weight"], ambient=s["ambient"])
    srgb = to_srgb(result.image, view=default_view("whitted", s["lighting"]))
    buffer = io.BytesIO()
    Image.fromarray(srgb).save(buffer, "PNG")
    height, width = srgb.shape[:2]
    return {"uri": "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii"),
            "width": width, "height": height, "zoom": max(1, math.ceil(IMAGE_WIDTH / width))}


def write_page(path, traces, scene) -> None:
    """The page of ``traces`` of the scene file ``scene`` at ``path``."""
    from pathlib import Path
    write_text(path, _render(traces.view, list(traces), "trace-3d", page=True, scene=Path(scene).name,
                             settings=traces.settings, image=_image(traces)))
