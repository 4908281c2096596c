"""The caches whitted keeps on disk stay bounded and clean (whitted/defaults.py says where
and how much): the mesh cache of giant spheres (converter/giants.py) drops the meshes used
least recently beyond its bound, and a writer killed outright leaves no lasting temporary
file, in the mesh cache or in compare's reference cache (whitted/compare/reference.py)."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from whitted import atomic
from whitted.compare.reference import ReferenceCache
from whitted.converter import giants

HOUR = 3600.0


def aged(path, seconds):
    """``path``, its time of last use set ``seconds`` ago."""
    then = time.time() - seconds
    os.utime(path, (then, then))
    return path


def killed_writer(target):
    """The temporary file a writer of ``target`` killed outright leaves behind (atomic_path's
    own: it is removed when the writer is stopped any other way)."""
    with pytest.raises(KeyboardInterrupt), atomic.atomic_path(target) as tmp:
        tmp.write_bytes(b"half")
        os.link(tmp, tmp.with_name(tmp.name + ".kept"))   # what SIGKILL would leave
        raise KeyboardInterrupt
    kept = next(target.parent.glob(f".{target.name}.*.kept"))
    return kept.rename(kept.with_name(kept.name[:-len(".kept")]))


def test_stale_leftovers_go_and_live_writers_files_stay(tmp_path):
    old = aged(killed_writer(tmp_path / "a.exr"), HOUR)
    fresh = killed_writer(tmp_path / "b.exr")                 # a writer may still be at work
    entry, other = tmp_path / "a.exr", tmp_path / ".hidden"
    entry.write_bytes(b"entry")
    other.write_text("not a writer's")
    aged(entry, HOUR), aged(other, HOUR)
    assert atomic.leftovers(tmp_path / "a.exr") == [old]
    assert atomic.remove_stale_leftovers(tmp_path, 600) == [old]
    assert not old.exists() and fresh.exists() and entry.exists() and other.exists()
    assert atomic.leftovers(tmp_path / "b.exr") == [fresh]


def test_the_mesh_cache_keeps_the_meshes_used_last_within_its_bound(tmp_path):
    sizes = {name: 400 for name in "abcdef"}
    for k, name in enumerate(sizes):             # a: used 6 hours ago ... f: just now
        (tmp_path / f"{name}.ply").write_bytes(bytes(sizes[name]))
        aged(tmp_path / f"{name}.ply", (6 - k) * HOUR if name != "f" else 0)
    left = aged(killed_writer(tmp_path / "g.ply"), HOUR)
    removed = giants.prune(tmp_path, limit=1000, stale=600)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.ply", "f.ply"]
    assert set(removed) == {left, *(tmp_path / f"{n}.ply" for n in "abcd")}
    # meshes in use (touched within `stale`) stay even above the bound
    assert giants.prune(tmp_path, limit=0, stale=3 * HOUR) == []


def test_a_reused_mesh_is_marked_as_used(tmp_path, monkeypatch):
    monkeypatch.setattr(giants, "cache_folder", lambda: tmp_path)
    path = giants.cached(b"ply mesh")
    aged(path, HOUR)
    assert giants.cached(b"ply mesh") == path
    assert time.time() - path.stat().st_mtime < 60


def test_the_mesh_cache_is_pruned_when_a_mesh_is_written(tmp_path, monkeypatch):
    monkeypatch.setattr(giants, "cache_folder", lambda: tmp_path)
    monkeypatch.setattr(giants, "MESH_CACHE_BYTES", 10)
    old = aged(giants.cached(b"an old mesh"), HOUR)
    new = giants.cached(b"a new mesh")
    assert new.exists() and not old.exists()


def test_the_reference_cache_removes_what_a_killed_writer_left(tmp_path):
    cache = ReferenceCache(tmp_path)
    image_file, _ = cache.entry("scene", "0" * 64)
    left = aged(killed_writer(image_file), HOUR)
    assert cache.load("scene", "0" * 64, (2, 3)) is None
    assert not left.exists()
    cache = ReferenceCache(tmp_path)
    left = aged(killed_writer(image_file), HOUR)
    cache.store("scene", "0" * 64, np.ones((2, 3, 3), np.float32), {})
    assert not left.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
