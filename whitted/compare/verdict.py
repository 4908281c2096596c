"""The first thing a reader of a comparison sees: its verdict in plain words.

Why a module of its own: the floors and tables of :mod:`.analysis` answer a specialist's
questions in the specialist's terms ("stops improving at 0.104 (relative MSE, its best)
… d3 · 1 spp"). A first reader wants two things before those: for each method of the
article, how good it gets and at what cost, and from which time budget on the path
tracer is the better buy; and what the error numbers mean. :func:`verdict` says both
in a few sentences, read from the same :class:`~.analysis.Analysis` as everything
else (nothing is computed here), and :func:`scale_text` gives the error's scale.
"""

from __future__ import annotations

import math

from .analysis import METHOD_NAMES, Analysis, FloorStatement
from .results import seconds_text


def _capital(text: str) -> str:
    return text[0].upper() + text[1:]


def method_verdict(statement: FloorStatement) -> str:
    """One Whitted method's verdict, e.g. "The article's model is as good as it gets at
    d3 · 1 spp, 7.1 ms (error 0.104); from about 46 ms on, the path tracer is more
    accurate." """
    name = METHOD_NAMES[statement.method]
    render, floor = statement.render, statement.floor
    where = f"{render.setting.label}, {seconds_text(render.seconds)} (error {floor.error:.3g})"
    if floor.settled:
        text = f"{_capital(name)} is as good as it gets at {where}"
    else:
        text = f"{_capital(name)} is still improving at its costliest render, {where}"
    path, best = statement.path, statement.path_best
    if path is None and best is None:
        return text + "."
    if path is None:
        return (text + f"; the path tracer never got as close (its best: {best.rel_mse:.3g} at "
                f"{best.setting.label}, {seconds_text(best.seconds)}).")
    if path.how == "nearest":
        first = path.between[0]
        return (text + f"; the path tracer is more accurate from its fastest render on "
                f"({first.setting.label}, {seconds_text(first.seconds)}).")
    if path.value <= render.seconds:
        return (text + f"; the path tracer is as accurate already from about {seconds_text(path.value)} "
                f"on: faster there, and more accurate beyond.")
    return text + f"; from about {seconds_text(path.value)} on, the path tracer is more accurate."


def scale_text(reference_noise: float = math.nan) -> str:
    """What the error numbers mean."""
    noise = (f"; this reference's own noise is about {reference_noise:.2g}, and no render can "
             f"measurably score below it" if math.isfinite(reference_noise) and reference_noise > 0 else "")
    return ("Errors are relative MSE against the converged path-traced reference: 0 is identical, "
            f"1 about as far off as a black image{noise}.")


def verdict(analysis: Analysis) -> str:
    """The scene's verdict: each Whitted method's sentence, then the error's scale."""
    sentences = [method_verdict(s) for s in analysis.floors]
    if not sentences:
        sentences = ["No Whitted render was done: there is no verdict to state."]
    return " ".join(sentences + [scale_text(analysis.entry.reference_noise)])
