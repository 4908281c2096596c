"""Rendering many scenes in one process, or on a Dask cluster (docs/cluster.md): Mitsuba's
import, the variant and the kernels are paid for once, not per scene. ``X.scn`` becomes
``OUT/X.png`` (the converter's rule, :func:`whitted.converter.batch.plan`); a scene whose
images are newer than what it reads is skipped, so a stopped run goes on where it stopped.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator

from . import defaults as D
from .errors import WhittedError, first_line

SCENE_SUFFIXES = (".scn", ".xml")


@dataclass(frozen=True)
class Settings:
    """``whitted render``'s options for every scene of a batch (None: the scene's own), plain
    data for a cluster's workers."""
    integrator: str = D.INTEGRATOR
    spp: int | None = None
    max_depth: int | None = None
    ambient: float | None = None
    lighting: str | None = None
    min_weight: float | None = None
    without: tuple | None = None
    variant: str | None = None
    exposure: float = 0.0
    view: str | None = None

    def check(self) -> None:
        from .images import check_exposure
        from .rendering import check_settings
        check_settings(self.spp, self.max_depth, self.lighting, self.integrator, self.min_weight,
                       self.without, self.ambient)
        check_exposure(self.exposure)


@dataclass
class SceneRender:
    """What became of one scene of a batch."""
    scene: Path
    outputs: tuple[Path, ...] = ()   # none when rendering to memory
    status: str = "rendered"   # or "skipped" (up to date) or "failed"
    error: str | None = None   # FILE:LINE: message lines
    image: object = None   # the linear RGB image when kept
    stats: dict | None = None
    seconds: float = 0.0   # loading, rendering, writing
    worker: str = D.IN_PROCESS   # or a Dask worker's address

    def summary(self) -> dict:
        entry = {"scene": str(self.scene), "outputs": [str(p) for p in self.outputs],
                 "status": self.status, "seconds": self.seconds, "worker": self.worker}
        if self.error is not None:
            entry["error"] = self.error
        if self.stats is not None:
            entry["stats"] = self.stats
        return entry


def up_to_date(scene: Path, outputs: tuple[Path, ...]) -> bool:
    """Whether every image of ``scene`` is newer than what it reads: itself, its textures, an
    XML's meshes (a bad .scn: never)."""
    from .converter import parse_file
    from .loading import named_files
    if not outputs:
        return False
    try:
        oldest = min(p.stat().st_mtime_ns for p in outputs)
        files = [scene]
        if scene.suffix.lower() == ".xml":
            with contextlib.suppress(OSError):
                files += [scene.parent / name for name in named_files(scene)]
        else:
            materials = parse_file(scene).sphere_arrays().materials
            files.extend(sorted({Path(m.texture) for m in materials if m.texture is not None}))
        return all(p.stat().st_mtime_ns < oldest for p in files)
    except (OSError, WhittedError):
        return False


def render_file(scene, settings: Settings, progress: bool = False):
    """The render of the scene file ``scene`` (settings checked) and its PNG view."""
    from .images import default_view
    from .loading import load_scene
    from .rendering import quiet_mitsuba, render_checked, whitted_settings
    with quiet_mitsuba():
        loaded = load_scene(scene, variant=settings.variant, integrator=settings.integrator,
                            meshes=settings.integrator != "whitted", spp=settings.spp,
                            max_depth=settings.max_depth, ambient=settings.ambient,
                            lighting=settings.lighting)
    try:
        result = render_checked(loaded, integrator=settings.integrator, progress=progress,
                                min_weight=settings.min_weight, spp=settings.spp,
                                without=settings.without)
    except WhittedError as error:
        raise WhittedError(f"{scene}: {error}") from None
    view = settings.view or default_view(settings.integrator,
                                         settings.lighting or whitted_settings(loaded)["lighting"])
    return result, view


def render_one(scene: Path, outputs: tuple[Path, ...], settings: Settings,
               keep_image: bool = False) -> SceneRender:
    """Load, render and write one scene here; a user error makes a failed :class:`SceneRender`."""
    from . import interrupt
    from .images import write_image
    from .rendering import peak_resident_bytes

    start = time.perf_counter()
    item = SceneRender(scene, outputs)
    try:
        result, view = render_file(scene, settings)
        for output in outputs:
            write_image(output, result.image, exposure=settings.exposure, view=view)
    except WhittedError as error:
        item.status, item.error = "failed", str(error)
    except RuntimeError as error:   # Mitsuba's or Dr.Jit's, for this scene
        if interrupt.requested(error):
            raise
        item.status, item.error = "failed", f"{scene}: {first_line(error)}"
    else:
        result.stats["peak_resident_bytes"] = peak_resident_bytes()
        item.stats = result.stats
        item.image = result.image if keep_image else None
    item.seconds = time.perf_counter() - start
    return item


def render_scenes(scenes: Iterable[str | os.PathLike], out: str | os.PathLike | None = None,
                  formats: Iterable[str] = ("png",), *, force: bool = False,
                  keep_images: bool | None = None, workers: int | None = None,
                  scheduler: str | None = None, **options) -> Iterator[SceneRender]:
    """Render scene files (a folder stands for its scenes), yielding a :class:`SceneRender` for
    each as it is done; a failed one does not stop the others (docs/CONTRACTS.md)."""
    from .cluster import check_where
    settings = Settings(**options)
    settings.check()
    check_where(workers, scheduler)
    _, skipped, todo = plan_batch(scenes, out, formats, force)
    yield from skipped
    yield from render_planned(todo, settings, out is None if keep_images is None else keep_images,
                              workers, scheduler)


def plan_batch(scenes: Iterable[str | os.PathLike], out: str | os.PathLike | None,
               formats: Iterable[str] = ("png",), force: bool = False):
    """``(plan, skipped, todo)``: every scene (files, or folders' scenes) with its images in
    ``out``, one per format, in input order; the up-to-date scenes; and the pairs to render.
    The output folders are checked and made first."""
    from .converter.batch import expand_folders, plan as plan_files, prepare_folders
    inputs = [os.fspath(s) for s in scenes]
    formats = tuple(dict.fromkeys(formats))
    for name in formats:
        if name not in D.IMAGE_FORMATS:
            raise WhittedError(f"unknown image format '{name}'; "
                               f"choose from {', '.join(D.IMAGE_FORMATS)}")
    if out is None:
        found = expand_folders(inputs, SCENE_SUFFIXES, ".scn or .xml files")
        plan = [(scene, ()) for scene in found]
    else:
        folder = str(out) if str(out).endswith(("/", os.sep)) else f"{out}{os.sep}"
        plans = [plan_files(list(inputs), folder, f".{name}", SCENE_SUFFIXES) for name in formats]
        plan = [(pairs[0][0], tuple(target for _, target in pairs)) for pairs in zip(*plans)]
        prepare_folders([target for _, targets in plan for target in targets], out)
    skipped, todo = [], []
    for scene, outputs in plan:
        if not force and up_to_date(scene, outputs):
            skipped.append(SceneRender(scene, outputs, "skipped"))
        else:
            todo.append((scene, outputs))
    return plan, skipped, todo


def render_planned(todo: list[tuple[Path, tuple[Path, ...]]], settings: Settings, keep_images: bool = False,
                   workers: int | None = None, scheduler: str | None = None) -> Iterator[SceneRender]:
    if workers is not None or scheduler is not None:
        yield from _on_cluster(todo, settings, keep_images, workers, scheduler)
    else:
        for scene, outputs in todo:
            yield render_one(scene, outputs, settings, keep_images)


def _on_cluster(todo, settings: Settings, keep: bool, workers: int | None,
                scheduler: str | None) -> Iterator[SceneRender]:
    import uuid
    from dataclasses import replace

    from .cluster import available_cores, cancel, connect, on_worker, task_result, worker_threads
    from .variant import default_variant

    if not todo:
        return
    # The workers may start elsewhere: paths absolute, the variant decided here.
    settings = replace(settings, variant=settings.variant or default_variant())
    with connect(workers, scheduler) as client:
        from distributed import as_completed
        threads = worker_threads(client.run(available_cores))
        run = uuid.uuid4().hex[:8]
        tasks = {}
        for k, (scene, outputs) in enumerate(todo):
            future = client.submit(on_worker, render_one, settings.variant, threads,
                                   Path(scene).resolve(), tuple(Path(p).resolve() for p in outputs),
                                   settings, keep, key=f"whitted-render-{k}-{Path(scene).stem}-{run}",
                                   pure=False)
            tasks[future] = (scene, outputs)
        try:
            for future in as_completed(list(tasks), loop=client.loop):
                scene, outputs = tasks.pop(future)
                try:
                    item = task_result(future, str(scene))
                except WhittedError as error:   # every worker that tried it died
                    item = SceneRender(scene, outputs, "failed", str(error))
                else:
                    item.scene, item.outputs = scene, outputs   # the user's paths
                yield item
        except BaseException:
            cancel(client, tasks)
            raise
    # every task has ended: what a killed worker was writing is litter
    from .atomic import leftovers
    for litter in (path for _, outputs in todo for image in outputs for path in leftovers(image)):
        with contextlib.suppress(OSError):
            litter.unlink()


@dataclass
class Totals:
    """A batch's counts and times, for the summary line and the ``--stats`` JSON."""
    planned: int = 0
    items: list = field(default_factory=list)
    start: float = field(default_factory=time.perf_counter)

    def count(self, status: str) -> int:
        return sum(item.status == status for item in self.items)

    def line(self, out) -> str:
        rendered, skipped, failed = self.count("rendered"), self.count("skipped"), self.count("failed")
        parts = [f"rendered {rendered} of {self.planned} scenes"]
        if skipped:
            parts.append(f"{skipped} up to date")
        if failed:
            parts.append(f"{failed} failed")
        where = f" into {out}" if out is not None else ""
        return f"whitted: {', '.join(parts)} in {time.perf_counter() - self.start:.1f} s{where}"

    def json(self, interrupted: bool = False) -> dict:
        rendered = [item for item in self.items if item.stats is not None]
        rays = Counter()
        for item in rendered:
            rays.update(item.stats.get("rays", {}))
        totals = {"scenes": self.planned, "rendered": self.count("rendered"),
                  "skipped": self.count("skipped"), "failed": self.count("failed"),
                  "not_done": self.planned - len(self.items), "interrupted": interrupted,
                  "wall_seconds": time.perf_counter() - self.start,
                  "render_seconds": sum(item.stats["seconds"] for item in rendered),
                  "compile_seconds": sum(item.stats["compile_seconds"] for item in rendered),
                  "scene_seconds": sum(item.seconds for item in self.items),
                  "rays": dict(rays)}
        return {"scenes": [item.summary() for item in self.items], "totals": totals}
