"""Caches of expensive results (plate modes, radiation gains) under a key (canonical JSON
of all that determines them): :class:`MemoryCache`, least recently used dropped first; on
disk, ``.npz`` files in :func:`cache_dir` shared by every process, written atomically with
the SHA-256 of their arrays (a damaged file is recomputed), bounded by :func:`max_bytes`."""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import sys
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth import checks
from synth.store.atomic import write_atomically

#: Default bound of the disk cache, bytes (a plate's modes to 20 kHz take 1-30 MB).
DEFAULT_MAX_BYTES = 512 * 1024 * 1024
#: Name of the array holding the SHA-256 of the others in every entry.
DIGEST_ARRAY = "__sha256__"
#: Age (s) past which a temporary was left by a writer that died.
STALE_TEMPORARY_AGE = 3600.0
#: How long a process trusts its count of the disk cache's size before scanning again, s.
RESCAN_SECONDS = 30.0


def cache_dir() -> Path:
    """``$SYNTH_CACHE_DIR`` if set (a file there raises ``ParameterError``), else the
    platform's user cache directory + ``synth``."""
    env = checks.environment_directory("SYNTH_CACHE_DIR")
    if env is not None:
        return env
    home = Path.home()
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA")
        return (Path(base) if base else home / "AppData" / "Local") / "synth" / "Cache"
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "synth"
    base = os.environ.get("XDG_CACHE_HOME")
    return (Path(base) if base else home / ".cache") / "synth"


def check_environment() -> None:
    """Raise ``ParameterError`` for a bad ``$SYNTH_CACHE_DIR`` or ``$SYNTH_CACHE_MAX_BYTES``
    before any work."""
    checks.environment_directory("SYNTH_CACHE_DIR")
    max_bytes()


def max_bytes() -> int:
    """``$SYNTH_CACHE_MAX_BYTES`` (0 keeps nothing on disk) or :data:`DEFAULT_MAX_BYTES`."""
    return checks.environment_integer("SYNTH_CACHE_MAX_BYTES", DEFAULT_MAX_BYTES, 0, "bytes")


def cache_path(prefix: str, key: str) -> Path:
    """The file of ``key`` in :func:`cache_dir`: ``{prefix}-{digest}.npz``."""
    digest = hashlib.sha256(key.encode()).hexdigest()[:24]
    return cache_dir() / f"{prefix}-{digest}.npz"


def arrays_digest(arrays: dict) -> str:
    """SHA-256 (hex) of named arrays: each name, dtype, shape and bytes, by name."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        if name == DIGEST_ARRAY:
            continue
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def savez_atomic(path: Path, arrays: dict) -> bool:
    """Write ``arrays`` and their digest to ``path`` atomically (concurrent writers of one
    entry all succeed), then evict beyond :func:`max_bytes`. False, having written nothing,
    if the file cannot be written (the cache is then skipped)."""
    digest = np.array(arrays_digest(arrays))
    limit = max_bytes()  # a bad $SYNTH_CACHE_MAX_BYTES is the user's error, never a silent "off"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(path, lambda tmp: np.savez(tmp, **arrays, **{DIGEST_ARRAY: digest}))
    except (OSError, RuntimeError):  # unwritable, no home: no disk cache
        return False
    _SIZE_COUNT.after_write(path, limit)
    return True


class _SizeCount:
    """This process's count of the disk cache's total size, bytes: the last scan's total
    plus the sizes written since; past the bound or :data:`RESCAN_SECONDS` the directory is
    scanned and evicted again (other processes write too)."""

    def __init__(self):
        self._lock = threading.Lock()
        self._directory: Path | None = None
        self._total, self._scanned = 0, -math.inf

    def after_write(self, path: Path, limit: int) -> None:
        try:
            size = path.stat().st_size
        except OSError:  # evicted meanwhile by another process
            size = 0
        with self._lock:
            recent = time.monotonic() - self._scanned < RESCAN_SECONDS
            if self._directory == path.parent and recent and self._total + size <= limit:
                self._total += size
                return
        remaining = _evict(limit, keep=path)
        with self._lock:
            self._directory, self._total, self._scanned = path.parent, remaining, time.monotonic()


_SIZE_COUNT = _SizeCount()


class CacheEntryError(ValueError):
    """A disk cache entry whose stored digest does not match its arrays (or has none)."""


class VerifiedArrays(dict, contextlib.AbstractContextManager):
    """The arrays of a cache entry whose digest matched, opened in ``with`` as numpy's
    ``NpzFile`` is."""


def load_npz(path: Path) -> VerifiedArrays:
    """The arrays of the cache entry ``path``, checked against its digest, and the entry
    marked as used (mtime now). Raises OSError, ValueError or :class:`CacheEntryError`:
    the caller recomputes."""
    with np.load(path, allow_pickle=False) as z:
        arrays = {name: z[name] for name in z.files}
    stored = arrays.pop(DIGEST_ARRAY, None)
    if stored is None or str(stored[()]) != arrays_digest(arrays):
        raise CacheEntryError(f"{path}: the arrays do not match the stored digest")
    with contextlib.suppress(OSError):  # evicted meanwhile or read-only: the arrays are good
        os.utime(path)
    return VerifiedArrays(arrays)


@dataclass(frozen=True)
class DiskEntry:
    """A file of the disk cache: ``size`` bytes, ``used`` at (Unix time, s)."""

    path: Path
    size: int
    used: float


def _is_temporary(p: Path) -> bool:
    """A file being written, or left by a writer that died (:mod:`synth.store.atomic`)."""
    return p.name.startswith(".") or p.suffix == ".tmp"


def _entries(directory: Path) -> list[DiskEntry]:
    out = []
    for p in directory.glob("*.npz"):
        with contextlib.suppress(FileNotFoundError):  # evicted by another process meanwhile
            if not _is_temporary(p):
                st = p.stat()
                out.append(DiskEntry(p, st.st_size, st.st_mtime))
    return out


def _evict(limit: int, *, keep: Path | None = None) -> int:
    """Delete the least recently used entries until their total is at most ``limit``
    bytes (``keep``, the entry just written, last), and dead writers' temporaries; the
    bytes remaining."""
    try:
        directory = cache_dir()
        if not directory.is_dir():
            return 0
        now = time.time()
        for p in filter(_is_temporary, directory.iterdir()):
            with contextlib.suppress(OSError):  # removed meanwhile by another process
                if now - p.stat().st_mtime > STALE_TEMPORARY_AGE:
                    p.unlink()
        entries = sorted(_entries(directory), key=lambda e: (e.path == keep, e.used))
    except (OSError, RuntimeError):
        return 0
    total = sum(e.size for e in entries)
    for e in entries:
        if total <= limit:
            break
        with contextlib.suppress(OSError):  # gone meanwhile (another process) or not removable
            e.path.unlink()
        total -= e.size
    return total


@dataclass(frozen=True)
class DiskInfo:
    """The disk cache: its ``entries``, their ``bytes``, the bound ``max_bytes`` and
    ``by_kind`` (entries and bytes per file prefix)."""

    directory: Path
    entries: int
    bytes: int
    max_bytes: int
    by_kind: dict


def disk_info() -> DiskInfo:
    """What the disk cache holds (``synth cache info``)."""
    directory = cache_dir()
    entries = _entries(directory) if directory.is_dir() else []
    kinds: dict = {}
    for e in sorted(entries, key=lambda e: e.path.stem):
        n, b = kinds.get(kind := e.path.stem.rsplit("-", 1)[0], (0, 0))
        kinds[kind] = (n + 1, b + e.size)
    size = sum(e.size for e in entries)
    return DiskInfo(directory, len(entries), size, max_bytes(), dict(sorted(kinds.items())))


def clear_disk() -> tuple[int, int]:
    """Delete every entry and temporary of the disk cache: (files deleted, bytes freed)."""
    directory = cache_dir()
    if not directory.is_dir():
        return 0, 0
    n = freed = 0
    for p in [p for p in directory.iterdir() if p.suffix in (".npz", ".tmp")]:
        with contextlib.suppress(OSError):  # gone meanwhile (another process) or not removable
            size = p.stat().st_size
            p.unlink()
            n, freed = n + 1, freed + size
    return n, freed


class MemoryCache:
    """Results held in memory, least recently used dropped beyond ``max_entries`` or
    ``max_bytes`` (``value.nbytes``; the newest is kept); ``computed`` names the counter
    of results computed that :meth:`info` gives with the hits and writes."""

    def __init__(
        self, computed: str, *, max_entries: int | None = None, max_bytes: int | None = None
    ):
        self.max_entries, self.max_bytes, self._computed = max_entries, max_bytes, computed
        self._items: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self._stats = {computed: 0, "memory_hits": 0, "disk_hits": 0, "disk_writes": 0}

    def info(self) -> dict:
        """The counters since start-up or :meth:`clear`, and ``entries``."""
        with self._lock:
            return dict(self._stats, entries=len(self._items))

    def clear(self) -> None:
        """Forget the results held and reset the counters."""
        with self._lock:
            self._items.clear()
            self._stats = dict.fromkeys(self._stats, 0)

    def count(self, name: str) -> None:
        """Add one to the counter ``name`` (``computed``, ``disk_writes``)."""
        with self._lock:
            self._stats[self._computed if name == "computed" else name] += 1

    def get(self, key: str, usable=None):
        """The result held for ``key`` if ``usable(result)`` (counted as a memory hit)."""
        with self._lock:
            value = self._items.get(key)
            if value is None or (usable is not None and not usable(value)):
                return None
            self._stats["memory_hits"] += 1
            self._items.move_to_end(key)
            return value

    def fetch(self, key: str | None, compute, *, load=None, save=None, usable=None):
        """The result of ``key``: held (if ``usable``), else ``load(key)`` from disk (None:
        absent), else ``compute()``, held and ``save(result, key)``; ``key`` None: computed,
        nothing held nor stored."""
        value = None if key is None else self.get(key, usable)
        if value is None and key is not None and load is not None:
            value = load(key)
            if value is not None and (usable is None or usable(value)):
                self.put(key, value, source="disk")
                return value
            value = None
        if value is None:
            value = compute()
            if key is None:
                self.count("computed")
            else:
                self.put(key, value, source="computed")
                if save is not None:
                    save(value, key)
        return value

    def put(self, key: str, value, *, source: str) -> None:
        """Hold ``value`` for ``key`` from ``source`` ("computed" or "disk", counted)."""
        with self._lock:
            self._stats[self._computed if source == "computed" else "disk_hits"] += 1
            self._items[key] = value
            self._items.move_to_end(key)
            while self.max_entries is not None and len(self._items) > self.max_entries:
                self._items.popitem(last=False)
            total = 0 if self.max_bytes is None else sum(v.nbytes for v in self._items.values())
            while self.max_bytes is not None and total > self.max_bytes and len(self._items) > 1:
                total -= self._items.popitem(last=False)[1].nbytes
