"""Tests of synth.store.cache: the disk cache shared by many processes (atomic entries,
stored digests, a least-recently-used size bound) and `synth cache info|clear`."""

from __future__ import annotations

import multiprocessing
import os

import numpy as np
import pytest

from synth.cli import main
from synth.errors import ParameterError
from synth.physics import modes as P
from synth.physics.scene import Plate
from synth.sound import radiation as R
from synth.store import cache


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("SYNTH_CACHE_MAX_BYTES", raising=False)
    P.clear_memory_cache()
    R.clear_memory_cache()
    yield
    P.clear_memory_cache()
    R.clear_memory_cache()


def _plate():
    """A small free MDF plate: a Ritz solve of about a second, then cached."""
    return Plate("mdf-18", thickness=0.018, length=0.3, width=0.2, boundary="free")


def _modes_in_process(barrier, queue):
    barrier.wait()  # both processes start the same solve at once
    m = P.modes(_plate(), max_frequency=3000.0)
    queue.put(np.asarray(m.frequencies).tolist())


@pytest.mark.slow
def test_two_processes_fill_the_same_entry(tmp_path):
    # Both solve the free plate at once and write its entry: both succeed with the same
    # modes, one valid entry is left, and no temporary file.
    ctx = multiprocessing.get_context("spawn")
    barrier, queue = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_modes_in_process, args=(barrier, queue)) for _ in range(2)]
    for p in procs:
        p.start()
    results = [queue.get(timeout=240) for _ in procs]
    for p in procs:
        p.join(timeout=60)
        assert p.exitcode == 0
    assert results[0] == results[1] and len(results[0]) > 0
    entries = sorted((tmp_path / "cache").glob("plate-modes-free-*.npz"))
    assert len(entries) == 1
    assert not [p for p in (tmp_path / "cache").iterdir() if p.name.startswith(".")]
    cache.load_npz(entries[0])  # the digest matches
    here = P.modes(_plate(), max_frequency=3000.0)  # read from disk, not solved
    assert P.cache_info()["disk_hits"] == 1 and P.cache_info()["solves"] == 0
    assert np.asarray(here.frequencies).tolist() == results[0]


def _hammer(path, value, n):
    for _ in range(n):
        cache.savez_atomic(path, {"a": np.full(50_000, value, dtype=np.float64)})


@pytest.mark.slow
def test_concurrent_writers_never_show_a_mixed_entry(tmp_path):
    # Two processes rewrite one entry 20 times each with different contents while this
    # one reads it: every read is one writer's whole entry (the rename is atomic).
    path = tmp_path / "cache" / "stress-0.npz"
    ctx = multiprocessing.get_context("spawn")
    procs = [ctx.Process(target=_hammer, args=(path, v, 20)) for v in (1.0, 2.0)]
    for p in procs:
        p.start()
    reads = 0
    while any(p.is_alive() for p in procs) or reads == 0:
        try:
            a = cache.load_npz(path)["a"]
        except FileNotFoundError:
            continue
        assert a.shape == (50_000,) and a[0] in (1.0, 2.0) and np.all(a == a[0])
        reads += 1
    for p in procs:
        p.join()
        assert p.exitcode == 0
    assert not [p for p in path.parent.iterdir() if p.name.startswith(".")]


def test_altered_entry_is_recomputed(tmp_path):
    # An entry whose arrays were altered but stay consistent (frequencies 0.1 % high,
    # which the shape checks cannot see) fails its digest and is solved again.
    first = np.asarray(P.modes(_plate(), max_frequency=3000.0).frequencies)
    (entry,) = (tmp_path / "cache").glob("plate-modes-free-*.npz")
    with np.load(entry) as z:
        arrays = dict(z)
    arrays["omega"] = arrays["omega"] * 1.001
    with open(entry, "wb") as fh:
        np.savez(fh, **arrays)
    with pytest.raises(cache.CacheEntryError):
        cache.load_npz(entry)
    P.clear_memory_cache()
    again = np.asarray(P.modes(_plate(), max_frequency=3000.0).frequencies)
    assert P.cache_info()["solves"] == 1 and P.cache_info()["disk_hits"] == 0
    np.testing.assert_array_equal(again, first)
    cache.load_npz(entry)  # rewritten whole


def test_entry_without_digest_is_refused(tmp_path):
    path = tmp_path / "cache" / "old-0.npz"
    path.parent.mkdir()
    np.savez(path, a=np.arange(3.0))
    with pytest.raises(cache.CacheEntryError):
        cache.load_npz(path)


def _entry(name, nbytes=100_000):
    path = cache.cache_dir() / f"{name}.npz"
    assert cache.savez_atomic(path, {"a": np.zeros(nbytes // 8)})
    return path


def test_size_bound_evicts_least_recently_used(monkeypatch):
    # Three entries of ~100 kB under a 350 kB bound; the oldest is read (so used most
    # recently); a fourth entry evicts the least recently used one, not the one read.
    monkeypatch.setenv("SYNTH_CACHE_MAX_BYTES", "350000")
    a, b, c = _entry("kind-a"), _entry("kind-b"), _entry("kind-c")
    now = c.stat().st_mtime  # the files' own times, set back from the last one written
    for i, p in enumerate((a, b, c)):
        os.utime(p, (now - 300 + 10 * i, now - 300 + 10 * i))
    cache.load_npz(a)
    d = _entry("kind-d")
    assert a.exists() and not b.exists() and c.exists() and d.exists()
    assert cache.disk_info().bytes <= 350_000


def test_a_write_scans_the_directory_only_when_its_count_passes_the_bound(monkeypatch):
    # the process counts what it writes: ten entries under the bound cost one scan of the
    # directory (the first write's), whatever the directory holds; the write that passes
    # the bound scans and evicts; with RESCAN_SECONDS = 0 every write scans (other
    # processes' writes are seen at the next scan)
    scans = []
    real = cache._entries
    monkeypatch.setattr(cache, "_entries", lambda d: scans.append(d) or real(d))
    monkeypatch.setenv("SYNTH_CACHE_MAX_BYTES", "1050000")
    paths = [_entry(f"kind-{i}") for i in range(10)]  # ~100 kB each
    assert len(scans) == 1 and all(p.exists() for p in paths)
    _entry("kind-10")
    assert len(scans) == 2
    assert cache.disk_info().bytes <= 1_050_000  # (itself a scan)
    monkeypatch.setattr(cache, "RESCAN_SECONDS", 0.0)
    _entry("kind-11")
    _entry("kind-12")
    assert len(scans) == 5


def test_size_bound_setting(monkeypatch):
    monkeypatch.setenv("SYNTH_CACHE_MAX_BYTES", "-5")
    with pytest.raises(ParameterError, match="SYNTH_CACHE_MAX_BYTES"):
        cache.max_bytes()
    monkeypatch.setenv("SYNTH_CACHE_MAX_BYTES", "0")  # nothing kept on disk
    path = cache.cache_dir() / "kind-z.npz"
    assert cache.savez_atomic(path, {"a": np.zeros(10)}) and not path.exists()
    monkeypatch.delenv("SYNTH_CACHE_MAX_BYTES")
    assert cache.max_bytes() == cache.DEFAULT_MAX_BYTES


def test_stale_temporary_files_are_removed():
    d = cache.cache_dir()
    d.mkdir(parents=True)
    stale, fresh = d / "kind-a.x1.tmp", d / "kind-a.x2.tmp"
    stale.write_bytes(b"half")
    fresh.write_bytes(b"being written")
    old = fresh.stat().st_mtime - 2 * cache.STALE_TEMPORARY_AGE
    os.utime(stale, (old, old))
    _entry("kind-b")
    assert not stale.exists() and fresh.exists()


def test_cli_cache_info_and_clear(capsys):
    _entry("plate-modes-free-abc")
    _entry("radiation-gains-def")
    assert main(["cache", "info"]) == 0
    out = capsys.readouterr().out
    assert "2 entries" in out and "plate-modes-free" in out and "radiation-gains" in out
    assert main(["cache", "clear"]) == 0
    assert "2 files deleted" in capsys.readouterr().out
    assert cache.disk_info().entries == 0


def test_leftovers_of_killed_writers_are_cleaned_on_the_next_run():
    """A kill during a cache write leaves ``plate-modes-*.tmp`` (older versions' naming) or
    ``.synth-<pid>-<hex>.part.npz`` (synth.store.atomic): the next run that writes an entry
    removes the first once it is older than ``STALE_TEMPORARY_AGE`` (a writer may still be
    at work on a younger one) and the second at once when its process is gone; a live
    process's temporary and every other file stay."""
    import subprocess
    import sys

    d = cache.cache_dir()
    d.mkdir(parents=True)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    old_tmp = d / "plate-modes-free-0123abcd.tmp"
    killed_part = d / f".synth-{dead.pid}-0123456789ab.part.npz"
    live_part = d / f".synth-{os.getpid()}-ba9876543210.part.npz"
    other = d / "notes.txt"
    for p in (old_tmp, killed_part, live_part, other):
        p.write_bytes(b"half")
    old = live_part.stat().st_mtime - 2 * cache.STALE_TEMPORARY_AGE
    os.utime(old_tmp, (old, old))
    P.modes(_plate(), max_frequency=3000.0)  # the next run: computes and stores an entry
    assert not old_tmp.exists() and not killed_part.exists()
    assert live_part.exists() and other.exists()
    assert list(d.glob("plate-modes-*.npz"))
