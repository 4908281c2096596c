"""``whitted compare`` on a Dask cluster: the same results as in one process, whatever
happens to the workers.

The expectation is independent of the cluster code: the results.csv of the plain,
in-process run. A run on a local cluster (``--workers``), and one on a cluster of
``dask scheduler`` and ``dask worker`` processes started here, one of them killed
with SIGKILL mid-run, must write the same rows, the time columns and ``worker``
aside. That holds because every render's image depends on its seed alone, which
the first tests check on their own. Every server listens on 127.0.0.1 only and is
stopped by the test that started it; the scenes are tiny.
"""

from __future__ import annotations

import csv
import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from whitted import compare as cmp
from whitted.cli import main

pytest.importorskip("distributed")
psutil = pytest.importorskip("psutil")  # a dependency of distributed

from test_compare import MIRROR_SCENE  # noqa: E402  (the same small scene as the in-process tests)
from conftest import session_left, without_headline_rounds, without_report_pictures  # noqa: E402

DASK = Path(sys.executable).parent / "dask"
#: what each Dask worker of these runs preloads (their comparisons' rows are compared without times)
PRELOAD = str(Path(__file__).with_name("dask_worker_rounds.py"))

SCENES = {
    "mirror": MIRROR_SCENE,
    "diffuse": """\
size 32 24
eye 0 0 6
light 3 4 5
background 0.1 0.1 0.2
sphere 0 0 0 1.2 color 0.3 0.8 0.3
""",
    "glass": """\
size 32 24
eye 0 0.5 6
light 2 6 4
background 0.2 0.2 0.3
depth 4
sphere 0 0 0 1 color 1 1 1 refract 0.9 1.5
sphere 0 -101 0 100 color 0.8 0.8 0.8
""",
}
#: One reference is 4 chunks of 64 spp: on a cluster they run on several workers.
OPTIONS = ["--reference-spp", "256", "--reference-chunk-spp", "64", "--depths", "1,2",
           "--spp", "1", "--path-spp", "1,16", "--rounds", "1", "-q"]
#: the columns that may differ between runs: times, how many rounds timed them (more while a
#: headline is unsettled), and who rendered
VARYING = {"seconds", "seconds_min", "seconds_max", "seconds_each", "compile_seconds", "repeats", "worker"}


def read_rows(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def comparable(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in VARYING} for r in rows]


def children() -> set[int]:
    """This process's descendants, but multiprocessing's resource tracker (which
    lives as long as this process once a process has been spawned)."""
    return {p.pid for p in psutil.Process().children(recursive=True)
            if "resource_tracker" not in " ".join(p.cmdline())}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("scenes")
    for name, text in SCENES.items():
        (folder / f"{name}.scn").write_text(text)
    return folder


@pytest.fixture(scope="module")
def in_process(scenes, tmp_path_factory) -> Path:
    """The expectation: the comparison run in this process, as without a cluster (its plots
    and contact sheet left out: the tests compare the CSV and the references)."""
    out = tmp_path_factory.mktemp("in-process")
    with pytest.MonkeyPatch.context() as patch:
        without_report_pictures(patch)
        without_headline_rounds(patch)   # the rounds are among the VARYING columns
        assert main(["compare", str(scenes), "--out", str(out), "--cache", str(out / "references"),
                     *OPTIONS]) == 0
    return out


def reference_images(out: Path) -> dict[str, np.ndarray]:
    """The cache's entries (``NAME-KEY.exr``), not the hidden temporary file of a write that
    a worker killed mid-run left behind (``.NAME-KEY.exr.XXXX.exr``, never read as an entry)."""
    from whitted.images import read_image
    return {p.stem.rsplit("-", 1)[0]: read_image(p) for p in (out / "references").glob("*.exr")
            if not p.name.startswith(".")}


# --------------------------------------------------------------------------- the premise


def test_a_path_traced_image_depends_on_its_seed_alone(llvm, write_scene):
    """The same seed, another thread count: the same bits. With 10 spp over 400×250
    pixels in one pass, some pixels' samples straddle the blocks of lanes that threads
    take, and Mitsuba's own render differed in the last bit from run to run (see
    rendering.path_passes)."""
    import drjit as dr

    from whitted import load_scene, render
    scene = load_scene(write_scene(SCENES["mirror"].replace("size 32 24", "size 400 250")))
    threads = dr.thread_count()
    try:
        images = []
        for count in (threads, 1, threads):
            dr.set_thread_count(count)
            images.append(render(scene, integrator="path", spp=10, seed=5).image)
    finally:
        dr.set_thread_count(threads)
    assert all(np.array_equal(images[0], other) for other in images[1:])


def test_path_passes_are_powers_of_two_that_add_up():
    from whitted.rendering import PATH_SAMPLES_PER_PASS, path_passes
    for spp, pixels in [(10, 100_000), (1024, 768), (5, PATH_SAMPLES_PER_PASS // 2),
                        (7, PATH_SAMPLES_PER_PASS), (3, 4 * PATH_SAMPLES_PER_PASS), (4096, 256_000)]:
        passes = path_passes(spp, pixels)
        assert sum(passes) == spp
        assert all(n & (n - 1) == 0 for n in passes)                      # powers of two
        assert all(n * pixels <= PATH_SAMPLES_PER_PASS or n == 1 for n in passes)


def test_reference_chunks_follow_the_options_alone():
    """Two halves of chunks of at most the chunk's spp, each chunk its own seed, far from
    the sweep's seed 0 and the small seeds of its passes."""
    from whitted.compare.reference import REFERENCE_SEED, reference_chunks
    chunks = reference_chunks(4096, 1024)
    assert [(spp, half) for spp, _, half in chunks] == [(1024, 0)] * 2 + [(1024, 1)] * 2
    seeds = [seed for _, seed, _ in chunks]
    assert len(set(seeds)) == 4 and min(seeds) >= REFERENCE_SEED > 1 << 20
    assert [spp for spp, _, _ in reference_chunks(300, 128)] == [128, 22, 128, 22]
    assert set(reference_chunks(256, 128)) < set(reference_chunks(512, 128))  # more extends


def test_reference_chunks_complete_what_is_done():
    """Chunks already rendered (the budget's probe, in the first half) count: the rest of each
    half is planned after them, their seeds continuing the half's count."""
    from whitted.compare.reference import chunk_seed, reference_chunks
    probes = [(1, chunk_seed(0, 0), 0), (2, chunk_seed(0, 1), 0), (4, chunk_seed(0, 2), 0)]
    rest = reference_chunks(40, 8, probes)
    assert rest == [(8, chunk_seed(0, 3), 0), (5, chunk_seed(0, 4), 0),
                    (8, chunk_seed(1, 0), 1), (8, chunk_seed(1, 1), 1), (4, chunk_seed(1, 2), 1)]
    assert reference_chunks(40, 8) == reference_chunks(40, 8, [])
    assert len({seed for _, seed, _ in probes + rest}) == len(probes + rest)
    assert [half for _, _, half in reference_chunks(8, 8, probes)] == [1]  # half 0 is full


@pytest.mark.parametrize("per_spp", [1e-4, 2.0])
def test_a_budgeted_reference_is_the_same_in_process_and_in_chunks(llvm, write_scene, tmp_path,
                                                                    monkeypatch, per_spp):
    """Under --budget, a plan made on one worker (its probe renders there), its chunks
    rendered elsewhere (here: in reverse order, from scenes loaded apart, as the cluster's
    chunk tasks do) and put together by a third make the reference of a run in one process,
    bit for bit: all of it asked for (cheap samples), or scaled down (dear ones)."""
    import json

    import whitted.compare.reference as reference
    from whitted.compare.scenes import plan_scene
    monkeypatch.setattr(reference, "COMPARE_PROBE_SECONDS", math.inf)  # the probe's spp alone decide
    monkeypatch.setattr(reference, "fit_cost", lambda points: (0.0, per_spp))
    scene = cmp.SceneFile.read(write_scene(MIRROR_SCENE), "mirror")
    options = cmp.Options(out=tmp_path, reference_spp=64, reference_chunk_spp=8, budget=200.0,
                          quiet=True)

    def made(folder: str, apart: bool):
        loaded = scene.load()
        entry, _ = plan_scene(scene, loaded, options, "llvm_ad_rgb")
        cache = reference.ReferenceCache(tmp_path / folder)
        if not apart:
            image = reference.reference_image(scene, loaded, entry, cache, options, seconds=100.0)
        else:
            plan = reference.plan_reference(scene, scene.load(), entry, cache, options, 100.0)
            planned = plan.chunks(options.reference_chunk_spp)
            rendered = {c: reference.render_chunk(scene.load(), *c, entry.path_depth)
                        for c in reversed(planned)}
            image = reference.reference_image(scene, None, entry, cache, options, plan=plan,
                                              chunks=[rendered[c] for c in planned])
        (info,) = (tmp_path / folder).glob("*.json")
        return image, entry, json.loads(info.read_text())["chunks"]

    (image, entry, chunks), (image_apart, entry_apart, chunks_apart) = made("one", False), made("apart", True)
    assert np.array_equal(image, image_apart)
    assert entry.reference_spp == entry_apart.reference_spp == (64 if per_spp < 1 else 32)
    assert entry.reference_noise == entry_apart.reference_noise
    assert [note.split(" (")[0] for note in entry.notes] == [note.split(" (")[0] for note in entry_apart.notes]
    assert ("scaled down from 64 to 32 spp" in " ".join(entry.notes)) == (per_spp >= 1)
    seeds = [(c["spp"], c["seed"], c["half"]) for c in chunks]
    assert seeds == [(c["spp"], c["seed"], c["half"]) for c in chunks_apart]
    assert [spp for spp, _, _ in seeds[:4]] == [1, 2, 4, 8]   # the probe: the first chunks
    assert len({seed for _, seed, _ in seeds}) == len(seeds) and max(spp for spp, _, _ in seeds) <= 8
    assert sum(spp for spp, _, _ in seeds) == entry.reference_spp


def test_threads_are_the_host_cores_shared_among_its_workers():
    from whitted.cluster import MIN_THREADS, worker_threads
    cores = {"tcp://10.0.0.1:1": 32, "tcp://10.0.0.1:2": 32, "tcp://10.0.0.1:3": 32,
             "tcp://10.0.0.2:1": 8, "tcp://10.0.0.3:7": 2, "tcp://10.0.0.3:8": 2}
    assert worker_threads(cores) == {"10.0.0.1": 10, "10.0.0.2": 8, "10.0.0.3": MIN_THREADS}


# --------------------------------------------------------------------------- a local cluster


@pytest.fixture
def preloaded_workers():
    """A local cluster's workers preload :data:`PRELOAD` (Dask hands its config to them)."""
    import dask
    with dask.config.set({"distributed.worker.preload": [PRELOAD]}):
        yield


def test_local_cluster_writes_the_in_process_results(scenes, in_process, tmp_path, monkeypatch,
                                                     preloaded_workers):
    without_report_pictures(monkeypatch)
    out = tmp_path / "out"
    before = children()
    assert main(["compare", str(scenes), "--out", str(out), "--cache", str(out / "references"), "--workers", "2", *OPTIONS]) == 0
    rows, expected = read_rows(out / "results.csv"), read_rows(in_process / "results.csv")
    assert comparable(rows) == comparable(expected)
    assert {r["worker"] for r in expected} == {"in-process"}
    for name in SCENES:  # all of a scene's settings on one worker
        workers = {r["worker"] for r in rows if r["scene"] == name}
        assert len(workers) == 1 and workers.pop().startswith("tcp://127.0.0.1:")
    ours, theirs = reference_images(out), reference_images(in_process)
    assert ours.keys() == theirs.keys() == set(SCENES)
    assert all(np.array_equal(ours[k], theirs[k]) for k in ours)   # bit for bit
    # the cluster is stopped: none of its processes is left
    assert children() <= before


def test_local_cluster_chunks_a_reference_under_a_budget(scenes, tmp_path, monkeypatch,
                                                        preloaded_workers):
    """Under --budget a worker probes each reference and the rest of it runs as chunk tasks:
    each cache entry lists the probe's renders first (1, 2, ... spp), then chunks of at most
    --reference-chunk-spp, all rendered by the cluster's workers."""
    import json
    without_report_pictures(monkeypatch)
    out = tmp_path / "out"
    before = children()
    assert main(["compare", str(scenes), "--out", str(out), "--cache", str(out / "references"), "--workers", "2", "--budget", "300",
                 *OPTIONS]) == 0
    assert {r["scene"] for r in read_rows(out / "results.csv")} == set(SCENES)
    infos = [json.loads(p.read_text()) for p in (out / "references").glob("*.json")]
    assert len(infos) == len(SCENES)
    for info in infos:
        chunks = info["chunks"]
        assert [c["spp"] for c in chunks[:2]] == [1, 2] and max(c["spp"] for c in chunks) <= 64
        assert sum(c["spp"] for c in chunks) == info["settings"]["spp"]
        assert all(c["worker"].startswith("tcp://127.0.0.1:") for c in chunks)
    assert children() <= before


# --------------------------------------------------------------------------- dask CLI cluster


def _stop(processes: list[subprocess.Popen]) -> None:
    """Kill: the processes hold nothing that needs a clean exit."""
    for process in processes:
        if process.poll() is None:
            process.kill()
        process.wait()


@pytest.fixture
def dask_cluster(tmp_path):
    """A scheduler and three workers (``dask`` CLI, no nanny: a worker is one process),
    all on 127.0.0.1 and free ports, without dashboards; stopped at the end.
    Yields (scheduler address, {worker address: its process})."""
    from distributed import Client

    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = open(tmp_path / "dask.log", "wb")
    processes = [subprocess.Popen(
        [DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard",
         "--dashboard-address", f"127.0.0.1:{free_port()}"], stdout=logs, stderr=logs)]
    workers = {}
    try:
        for _ in range(3):
            worker_port = free_port()
            process = subprocess.Popen(
                [DASK, "worker", address, "--host", "127.0.0.1", "--worker-port", str(worker_port),
                 "--nthreads", "1", "--no-nanny", "--no-dashboard", "--dashboard-address",
                 "127.0.0.1:0", "--death-timeout", "60", "--preload", PRELOAD],
                stdout=logs, stderr=logs)
            processes.append(process)
            workers[f"tcp://127.0.0.1:{worker_port}"] = process
        with Client(address, timeout=60, set_as_default=False) as client:
            client.wait_for_workers(3, timeout=60)
        yield address, workers
    finally:
        _stop(processes)
        logs.close()


def test_cluster_with_a_worker_killed_mid_run_writes_the_in_process_results(
        scenes, in_process, dask_cluster, tmp_path):
    from distributed import Client

    address, workers = dask_cluster
    out = tmp_path / "out"
    run = subprocess.Popen([sys.executable, "-m", "whitted", "compare", str(scenes), "--out", str(out), "--cache", str(out / "references"),
                            "--scheduler", address, *OPTIONS],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = sweep = None
    try:
        with Client(address, timeout=30, set_as_default=False) as client:
            deadline = time.monotonic() + 600   # a loaded machine: the references come first
            while killed is None and time.monotonic() < deadline and run.poll() is None:
                for worker, keys in client.processing().items():
                    sweeps = [k for k in keys if str(k).startswith("whitted-sweep-")]
                    if sweeps:
                        workers[worker].send_signal(signal.SIGKILL)
                        killed, sweep = worker, str(sweeps[0])
                        break
                time.sleep(0.02)
        stdout, stderr = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert killed is not None, f"no worker was seen sweeping a scene: {run.returncode} {stderr[-2000:]}"
    assert workers[killed].wait(timeout=10) == -signal.SIGKILL
    assert run.returncode == 0, stderr
    rows = read_rows(out / "results.csv")
    assert comparable(rows) == comparable(read_rows(in_process / "results.csv"))
    # the scene the dead worker was sweeping was swept again, whole, by another
    name = sweep[len("whitted-sweep-"):].rsplit("-", 1)[0]
    assert {r["worker"] for r in rows if r["scene"] == name} <= set(workers) - {killed}
    assert reference_images(out).keys() == set(SCENES)


# --------------------------------------------------------------------------- failures


@pytest.fixture
def busy_machine():
    """A process spinning on the CPU beside the test (CI's machine may be busy): on two cores,
    the run's two workers share what it leaves."""
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    yield
    hog.kill()
    hog.wait()


#: A scene whose renders last long enough that Ctrl-C finds a worker in the middle of one.
SLOW_SCENE = SCENES["glass"].replace("size 32 24", "size 240 180")


def test_ctrl_c_stops_the_local_cluster_in_one_line(scenes, tmp_path, busy_machine):
    """SIGINT to the command's process group, as a terminal's Ctrl-C, on a loaded machine,
    while a worker is busy rendering: exit status 130, one line on stderr (no worker's
    traceback, no resource tracker's warning about what a killed worker left), the scenes
    that finished are in results.csv, and no process of the run is left."""
    folder = tmp_path / "scenes"
    folder.mkdir()
    for scene in scenes.glob("*.scn"):
        (folder / scene.name).write_text(scene.read_text())
    (folder / "slow.scn").write_text(SLOW_SCENE)
    out = tmp_path / "out"
    run = subprocess.Popen([sys.executable, "-m", "whitted", "compare", str(folder), "--out", str(out), "--cache", str(out / "references"),
                            "--workers", "2", *OPTIONS[:-1], "--path-spp", "1,64", "--rounds", "3",
                            "-q"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True,
                           env={**os.environ, "DASK_DISTRIBUTED__WORKER__PRELOAD": repr([PRELOAD])})
    try:
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline and run.poll() is None:
            if (out / "results.csv").exists() and read_rows(out / "results.csv"):
                break
            time.sleep(0.05)
        assert run.poll() is None, run.communicate()[1]
        os.killpg(run.pid, signal.SIGINT)
        _, stderr = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    assert run.returncode == 130, stderr
    lines = stderr.splitlines()
    assert len(lines) == 1 and "interrupted" in lines[0], stderr
    rows = read_rows(out / "results.csv")
    assert rows and {r["scene"] for r in rows} < set(SCENES) | {"slow"}
    assert not session_left(run.pid)



def test_unreachable_scheduler_is_one_line_before_any_work(scenes, tmp_path, capsys, monkeypatch):
    import whitted.cluster as cluster
    monkeypatch.setattr(cluster, "COMPARE_CONNECT_TIMEOUT", 0.5)
    for address, message in [(f"tcp://127.0.0.1:{free_port()}", "cannot reach the Dask scheduler"),
                             ("127.0.0.1", "not a Dask scheduler address")]:
        out = tmp_path / "out"
        assert main(["compare", str(scenes), "--out", str(out), "--cache", str(out / "references"), "--scheduler", address, "-q"]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"whitted: error: {address}: {message}") and err.count("\n") == 1
        assert not out.exists()


def test_workers_and_scheduler_exclude_each_other(scenes, tmp_path):
    with pytest.raises(SystemExit) as exit_info:
        main(["compare", str(scenes), "--out", str(tmp_path / "out"), "--workers", "2",
              "--scheduler", "tcp://127.0.0.1:1"])
    assert exit_info.value.code == 2
    assert main(["compare", str(scenes), "--out", str(tmp_path / "out"), "--workers", "0"]) == 2
    assert not (tmp_path / "out").exists()


def test_a_plan_s_chunks_complete_the_spp_it_promises():
    """Under --budget the probe fills part of the first half: the chunks left are those of
    the spp the budget affords, and with the probe's they add up to the plan's spp (the cache
    key's), half by half as reference_chunks splits it."""
    from whitted.compare.reference import Chunk, ReferencePlan, reference_chunks
    done = [(1, 11, 0), (2, 12, 0), (4, 13, 0)]       # a probe of 1, 2 and 4 spp
    fitted = 8                                       # what the budget affords
    spp = sum(n for n, _, _ in done + reference_chunks(fitted, 4, done))
    probes = [Chunk(n, seed, half, np.zeros((1, 1, 3), np.float32), 0.0, 0.0) for n, seed, half in done]
    plan = ReferencePlan(fitted, spp, "key", None, probes)
    chunks = plan.chunks(4)
    assert spp == 11 and sum(n for n, _, _ in chunks) == spp - 7
    assert [n for n, _, h in chunks if h == 1] == [4]   # the second half: fitted - fitted // 2
