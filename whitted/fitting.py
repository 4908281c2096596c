"""The article's model fitted to an image by gradient descent: its colors, ambient and light
colors. What remains after the fit is the model's own limit, apart from numbers that were
merely off (docs/gradients.md, "Fitting").
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from . import defaults as D
from . import interrupt
from .converter.description import material_ids
from .errors import WhittedError

FREE = ("ambient", "colors", "lights")


@dataclass
class FitResult:
    """What :func:`fit` found; ``error``, ``size`` and ``image`` at the fit's resolution."""
    model: object   # the fitted whitted.converter.Scene
    losses: list   # the relative MSE before each step
    error: float
    size: tuple
    ambient: float
    colors: dict   # by material id
    lights: list
    image: object


def fit_size(scene_size, target_size, width: int = D.FIT_WIDTH, source: str = "the target") -> tuple[int, int]:
    """The target's resolution at most ``width`` wide; the target must have the scene's aspect."""
    (w, h), (tw, th) = scene_size, target_size
    if abs(tw * h - th * w) > max(w, h, tw, th):
        raise WhittedError(f"{source} is {tw}x{th}, but the scene renders {w}x{h}: give an image of the "
                           f"scene's view (the same aspect ratio)")
    if tw <= width:
        return tw, th
    return width, max(1, round(th * width / tw))


def resampled(image: np.ndarray, size) -> np.ndarray:
    """``image`` at ``size`` (width, height) by Mitsuba's Bitmap resampling."""
    import mitsuba as mi
    if image.shape[1::-1] == tuple(size):
        return image
    bitmap = mi.Bitmap(np.ascontiguousarray(image, np.float32),
                       pixel_format=mi.Bitmap.PixelFormat.RGB)
    return np.array(bitmap.resample([int(size[0]), int(size[1])]), np.float32).reshape(size[1], size[0], 3)


def fit(scene, target, *, free=FREE, iterations: int = D.FIT_ITERATIONS, width: int = D.FIT_WIDTH,
        rate=D.FIT_RATE, spp: int | None = None, progress: bool = False, on_step=None,
        target_name: str = "the target", min_gain: float = D.FIT_MIN_GAIN) -> FitResult:
    """Fit the article's model of ``scene`` (a ``.scn`` path or model) to ``target`` (an image
    path or a linear (H, W, 3) array) by Adam steps on the relative MSE.

    ``free``: which of :data:`FREE` move. At most ``iterations`` steps (fewer once the best
    loss gained less than ``min_gain`` in ``FIT_PATIENCE`` steps; 0: never stop early), at
    most ``width`` wide, the rate falling from ``rate[0]`` to ``rate[1]``; ``spp``: the
    renders' (default: the scene's). ``on_step(k, loss)`` returning true stops the fit."""
    import drjit as dr
    import mitsuba as mi

    from .converter import parse_file
    from .converter.description import light_intensity
    from .images import read_image
    from .loading import checked_overrides, load_model_parts
    from .metrics import EPSILON, relative_mse
    from .progress import progress_bar
    from .variant import set_variant

    unknown = sorted(set(free) - set(FREE))
    if unknown:
        raise WhittedError(f"fit: unknown free parameter(s) {', '.join(unknown)}; choose from {', '.join(FREE)}")
    if not (isinstance(iterations, int) and iterations >= 1):
        raise WhittedError(f"fit: iterations must be an integer >= 1, got {iterations}")
    if not dr.is_diff_v(mi.Float):
        set_variant("llvm_ad_rgb")
    model = parse_file(scene) if isinstance(scene, (str, os.PathLike)) else scene
    if isinstance(target, (str, os.PathLike)):
        target_name = str(target)
        target = read_image(target)
    target = np.asarray(target, np.float32)
    if target.ndim != 3 or target.shape[2] != 3:
        raise WhittedError(f"{target_name}: the target must be an RGB image, got an array of shape {target.shape}")
    unusable = int((~np.isfinite(target)).any(axis=2).sum())
    if unusable:   # a NaN loss aborted the process inside Dr.Jit's optimizer
        raise WhittedError(f"{target_name}: {unusable} of its {target.shape[0] * target.shape[1]} pixels "
                           f"are NaN or infinite; a target must be finite")
    size = fit_size((model.width, model.height), target.shape[1::-1], width, target_name)
    reference = resampled(target, size)

    # The scene as the Whitted integrator loads it (grouped spheres in ellipsoids shapes:
    # a sphere shape costs ~18 KB, a million of them gigabytes), each fitted color written
    # into every BSDF of its material, each light's through the scene's own frame.
    overrides = checked_overrides({"width": size[0], "height": size[1], "spp": spp})
    loaded, bsdfs, shown = load_model_parts(model, overrides, None, "whitted", False)
    params = mi.traverse(loaded)
    params["integrator.min_weight"] = 0.0   # the exact tree: the loss is smooth
    params.update()
    # each fitted color's places: BSDFs among the scene's parameters, or a group's own
    places = {mid: bsdfs[material] for material, mid in material_ids(model).items()
              if material.texture is None}
    # each light's intensity over its article color, π d²
    scales = [light_intensity(shown, light.position, (1.0, 1.0, 1.0))[0]
              for light in shown.lights]
    shapes = {shape.id(): shape for shape in loaded.shapes()}
    own = {name: mi.traverse(shapes[name].bsdf()) for names in places.values() for name in names
           if name in shapes}
    color_slots = {mid: [(own[name], "color.value") if name in own else (params, f"{name}.color.value")
                         for name in names] for mid, names in places.items()}
    # Only what the fit writes: mi.render and params.update() walk every kept parameter
    # at each step (seconds per step with 66 431 grouped spheres' centers otherwise).
    params.keep(["integrator.ambient", *(key for slots in color_slots.values() for table, key in slots
                                         if table is params),
                 *(f"light_{k}.intensity.value" for k in range(len(scales)))])
    tables = [params, *own.values()]

    opt = mi.ad.Adam(lr=rate[0])
    if "ambient" in free:
        opt["ambient"] = mi.Float(float(params["integrator.ambient"][0]))
    if "colors" in free:
        for mid in color_slots:
            table, key = color_slots[mid][0]
            opt[mid] = mi.Color3f(table[key])
    if "lights" in free:
        for k, scale in enumerate(scales):
            opt[f"light_{k}"] = mi.Color3f(params[f"light_{k}.intensity.value"]) / scale

    def write_parameters():
        if "ambient" in opt:
            params["integrator.ambient"] = mi.Float64(opt["ambient"])
        for mid in color_slots if "colors" in free else ():
            for table, key in color_slots[mid]:
                table[key] = opt[mid]
        for k, scale in enumerate(scales if "lights" in free else ()):
            params[f"light_{k}.intensity.value"] = opt[f"light_{k}"] * scale
        for table in tables:
            table.update()

    reference_tensor = mi.TensorXf(reference)
    weight = mi.TensorXf(1.0 / (reference * reference + EPSILON))
    losses = []
    bar = progress_bar(progress, iterations, "fit", unit="step", unit_scale=False)
    try:
        for k in range(iterations):
            interrupt.check()   # a stop swallowed since the last step
            opt.set_learning_rate(rate[0] * (rate[1] / rate[0]) ** (k / max(1, iterations - 1)))
            write_parameters()
            image = mi.render(loaded, params)
            loss = dr.mean(dr.ravel(weight * dr.square(image - reference_tensor)))
            dr.backward(loss)
            opt.step()
            for name in list(opt.keys()):   # the format's ranges
                opt[name] = dr.clip(opt[name], 0.0, 1.0) if not name.startswith("light_") \
                    else dr.maximum(opt[name], 0.0)
            losses.append(float(loss[0]))
            bar.set_postfix(loss=f"{losses[-1]:.3g}", refresh=False)
            bar.update(1)
            if on_step is not None and on_step(k, losses[-1]):
                break   # the caller's word: out of time
            # settled: the best loss no better than FIT_PATIENCE steps ago, and this one at it
            best, before = min(losses), min(losses[:-D.FIT_PATIENCE], default=math.inf)
            if best > (1 - min_gain) * before and losses[-1] <= (1 + min_gain) * best:
                break
    finally:
        bar.close()

    # the fitted values, as the format writes them (float32 values, exact in a float64)
    ambient = float(opt["ambient"][0]) if "ambient" in opt else model.ambient
    colors = {mid: tuple(float(c[0]) for c in opt[mid]) for mid in color_slots if mid in opt}
    lights = [tuple(float(c[0]) for c in opt[f"light_{k}"]) if f"light_{k}" in opt else light.color
              for k, light in enumerate(model.lights)]
    with dr.suspend_grad():
        write_parameters()
    final = np.array(mi.render(loaded), np.float32)
    return FitResult(fitted_model(model, ambient, colors, lights), losses,
                     relative_mse(final, reference), size, ambient, colors, lights, final)


def fitted_model(model, ambient: float, colors: dict, lights: list):
    """``model`` with the ambient, the materials' colors (by id) and the lights' colors replaced."""
    from .converter.description import _shared
    ids = material_ids(model)
    new_material = {material: replace(material, color=colors[mid])
                    for material, mid in ids.items() if mid in colors}
    spheres = [replace(sphere, material=new_material.get(_shared(sphere.material), sphere.material))
               for sphere in model.spheres]
    return replace(model, ambient=ambient, spheres=spheres,
                   lights=[replace(light, color=tuple(color)) for light, color in zip(model.lights, lights)])


def write_fitted(result: FitResult, path, source_name: str = "", text: str | None = None) -> None:
    """Write the fitted model as ``.scn``: ``text`` (the file it was read from) with the fitted
    numbers put in place, else (or if that would not read back) the model written anew."""
    from .atomic import write_text
    from .converter import parse_text
    from .converter.scn_writer import edited_scn, scene_to_scn
    from .errors import SceneError
    note = (f"fitted by whitted fit{' from ' + source_name if source_name else ''}: relative MSE "
            f"{result.error:.4g} at {result.size[0]}x{result.size[1]} after {len(result.losses)} steps")
    folder = Path(path).resolve().parent
    written = None if text is None else edited_scn(text, result.model, folder, note)
    try:   # the edited text must read back as the fitted model
        same = written is not None and replace(parse_text(written, path), source=result.model.source) == result.model
    except SceneError:
        same = False
    write_text(path, written if same else scene_to_scn(result.model, folder, note))


def fitted_lines(model, result: FitResult) -> list[str]:
    """What a fit changed, a line each: ``line 14 (the floor): color 0.6 0.65 0.6 -> 0.52 ...``."""
    from .converter.description import line_label, material_labels

    def rgb(color):
        return " ".join(f"{c:.4g}" for c in color)
    labels = material_labels(model)
    before = {mid: material.color for material, mid in material_ids(model).items()}
    return ([f"ambient {model.ambient:.4g} -> {result.ambient:.4g}"]
            + [f"{labels[mid]}: color {rgb(before[mid])} -> {rgb(color)}"
               for mid, color in result.colors.items()]
            + [f"{line_label(model, light.line)}: light {rgb(light.color)} -> {rgb(color)}"
               for light, color in zip(model.lights, result.lights) if tuple(color) != tuple(light.color)])


def fit_command(args) -> None:
    """``whitted fit SCENE --to IMAGE -o FITTED.scn``: everything checked before the fit."""
    from .atomic import check_writable
    from .converter.parser import decode, parse_text, read_scene_file
    from .images import read_image
    if not Path(args.output).suffix.lower() == ".scn":
        raise WhittedError(f"{args.output}: the fitted scene is a .scn file")
    if args.iterations < 1:
        raise WhittedError(f"--iterations must be >= 1, got {args.iterations}")
    if args.width < 1:
        raise WhittedError(f"--width must be >= 1, got {args.width}")
    check_writable(args.output, inputs=(args.scene, args.target))
    text = decode(read_scene_file(args.scene), args.scene)
    model = parse_text(text, args.scene)
    target = read_image(args.target)
    fit_size((model.width, model.height), target.shape[1::-1], args.width, args.target)

    def step(k, loss):   # one line per step, above the progress bar
        if not args.quiet:
            from tqdm import tqdm
            tqdm.write(f"step {k + 1}: relative MSE {loss:.6g}", file=sys.stderr)
    result = fit(model, target, iterations=args.iterations, width=args.width, progress=not args.quiet,
                 on_step=step, target_name=args.target)
    write_fitted(result, args.output, Path(args.scene).name, text)
    if not args.quiet:
        print(f"whitted: wrote {args.output}: relative MSE {result.losses[0]:.4g} -> {result.error:.4g} "
              f"at {result.size[0]}x{result.size[1]}", file=sys.stderr)
        for line in fitted_lines(model, result):
            print(f"  {line}", file=sys.stderr)
