"""Caches of expensive results (plate modes, radiation gains): in memory and on disk.

A :class:`MemoryCache` holds results under a key (a canonical JSON string of everything
that determines them), drops the least recently used beyond an entry count or a size in
bytes, and counts its traffic; it is thread-safe. On disk, results are ``.npz`` files in
:func:`cache_dir`, named by a digest of the key, written atomically by
:func:`savez_atomic` (a reader never sees a partial file); the key is stored in the file
too, and the reader checks it and the arrays' consistency before use.
"""

from __future__ import annotations

import hashlib
import os
import sys
import threading
from collections import OrderedDict
from pathlib import Path

import numpy as np

from synth.io.atomic import write_atomically


def cache_dir() -> Path:
    """Directory of the disk cache: ``$SYNTH_CACHE_DIR`` if set, else the platform's
    user cache directory (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux,
    ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%`` on Windows) + ``synth``."""
    env = os.environ.get("SYNTH_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    home = Path.home()
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA")
        return (Path(base) if base else home / "AppData" / "Local") / "synth" / "Cache"
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "synth"
    base = os.environ.get("XDG_CACHE_HOME")
    return (Path(base) if base else home / ".cache") / "synth"


def cache_path(prefix: str, key: str) -> Path:
    """The file of ``key`` in :func:`cache_dir`: ``{prefix}-{digest}.npz``. Raises
    RuntimeError where there is no home directory."""
    digest = hashlib.sha256(key.encode()).hexdigest()[:24]
    return cache_dir() / f"{prefix}-{digest}.npz"


def savez_atomic(path: Path, arrays: dict) -> bool:
    """Write ``arrays`` to ``path`` (``.npz``): a temporary file in the same directory,
    then an atomic rename, so that a reader never sees a partial file. Returns False,
    having written nothing, if the file cannot be written (a cache is then skipped)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(path, lambda tmp: np.savez(tmp, **arrays))
        return True
    except (OSError, RuntimeError):  # unwritable or no home directory: no disk cache
        return False


class MemoryCache:
    """Results held in memory under their keys, least recently used dropped first.

    Parameters
    ----------
    computed : str
        Name of the counter of results computed (``"solves"``, ``"computations"``).
    max_entries : int or None
        Most results held.
    max_bytes : int or None
        Most bytes held, by ``value.nbytes`` (the newest result is always kept).

    Counters (:meth:`info`): the computed ones, ``memory_hits``, ``disk_hits``,
    ``disk_writes``, and ``entries`` (results held).
    """

    def __init__(self, computed: str, *, max_entries: int | None = None,
                 max_bytes: int | None = None):
        self.max_entries = max_entries
        self.max_bytes = max_bytes
        self._items: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self._computed = computed
        self._stats = {computed: 0, "memory_hits": 0, "disk_hits": 0, "disk_writes": 0}

    def info(self) -> dict:
        """The counters since start-up or :meth:`clear`, and ``entries``."""
        with self._lock:
            return dict(self._stats, entries=len(self._items))

    def clear(self) -> None:
        """Forget the results held and reset the counters."""
        with self._lock:
            self._items.clear()
            for k in self._stats:
                self._stats[k] = 0

    def count(self, name: str) -> None:
        """Add one to the counter ``name`` (``computed``, ``disk_writes``)."""
        with self._lock:
            self._stats[self._computed if name == "computed" else name] += 1

    def get(self, key: str, usable=None) -> object | None:
        """The result held for ``key`` (counted as a memory hit) if there is one and
        ``usable(result)`` is true (default: always), else None."""
        with self._lock:
            value = self._items.get(key)
            if value is None or (usable is not None and not usable(value)):
                return None
            self._stats["memory_hits"] += 1
            self._items.move_to_end(key)
            return value

    def put(self, key: str, value, *, source: str, better=None) -> None:
        """Hold ``value`` for ``key``, obtained from ``source`` (``"computed"`` or
        ``"disk"``, counted), unless ``better(held, value)`` says the result held is
        at least as good. Then drop the least recently used beyond the limits."""
        with self._lock:
            self._stats[self._computed if source == "computed" else "disk_hits"] += 1
            old = self._items.get(key)
            if old is not None and better is not None and better(old, value):
                return
            self._items[key] = value
            self._items.move_to_end(key)
            if self.max_entries is not None:
                while len(self._items) > self.max_entries:
                    self._items.popitem(last=False)
            if self.max_bytes is not None:
                total = sum(v.nbytes for v in self._items.values())
                while total > self.max_bytes and len(self._items) > 1:
                    _, dropped = self._items.popitem(last=False)
                    total -= dropped.nbytes
