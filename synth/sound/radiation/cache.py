"""The cache of :func:`synth.sound.radiation.plate_gains`: gains in memory and on disk
(``radiation-gains-*.npz`` beside the plate-mode cache), keyed by everything that determines
them, so that a scene rendered again (in this process or another) does not repeat the integral.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from synth.jitcache import source_digest
from synth.sound.radiation.common import (
    COHERENT_FLOOR,
    GRADING,
    MAX_ORDER,
    MAX_RULES,
    NEAR_RHO,
    REFINE,
    RadiationResult,
)
from synth.sound.radiation.polar import POLAR_REVISION
from synth.store.cache import MemoryCache, cache_path, load_npz, savez_atomic

_CACHE_VERSION = 1  # layout of the stored gains and the algorithm; part of the key
CACHE = MemoryCache("computations", max_entries=32)  # least recently used dropped


#: Counters of the gain cache of :func:`plate_gains` since start-up (``computations``,
#: ``memory_hits``, ``disk_hits``, ``disk_writes``, ``entries``), and forgetting what memory
#: holds with the counters (the disk untouched).
cache_info = CACHE.info
clear_memory_cache = CACHE.clear


def gains_key(modes, listener, s, settings, rule) -> str:
    """Everything that determines the gains of :func:`plate_gains`, as canonical JSON
    (``settings`` the checked :class:`~.common.Settings`, ``rule`` the name of the rule's
    class, :mod:`~synth.sound.radiation.rules`), with the digest of the radiation's sources
    and all they import: an entry written by edited code is recomputed, not served."""

    def hexed(value):
        return None if value is None else float(value).hex()

    poles = np.ascontiguousarray(s, dtype=np.complex128)
    return json.dumps(
        {
            "rule": rule, "polar_revision": POLAR_REVISION, "version": _CACHE_VERSION,
            "shapes": modes.shape_key, "listener": [hexed(v) for v in listener],
            "poles": hashlib.sha256(poles.tobytes()).hexdigest(), "n_poles": int(s.size),
            "max_wavenumber": hexed(settings.kb), "air_density": hexed(settings.rho),
            "sound_speed": hexed(settings.c), "reference_distance": hexed(settings.r0),
            "tol": hexed(settings.tol), "max_points": int(settings.max_points),
            "quadrature": [MAX_ORDER, REFINE, MAX_RULES, GRADING, NEAR_RHO, COHERENT_FLOOR],
            "code": source_digest(str(Path(__file__).with_name("__init__.py"))),
        },
        sort_keys=True,
    )  # fmt: skip


def _gains_path(key: str) -> Path:
    return cache_path("radiation-gains", key)


_FIELDS = ("gains", "error", "coherent", "n_points", "refinements", "panels", "status",
           "message", "rule")  # fmt: skip


def save_gains(result: RadiationResult, key: str) -> None:
    """Write ``result`` to the disk cache (atomically); skipped if impossible."""
    arrays = {"key": np.array(key), **{f: np.array(getattr(result, f)) for f in _FIELDS}}
    try:
        path = _gains_path(key)
    except RuntimeError:  # no home directory
        return
    if savez_atomic(path, arrays):
        CACHE.count("disk_writes")


def load_gains(key: str, m: int):
    """The stored result for ``key`` (``m`` modes), or None if absent, unreadable or
    inconsistent."""
    try:
        path = _gains_path(key)
        if not path.is_file():
            return None
        with load_npz(path) as z:
            f = {name: z[name][()] for name in ("key", *_FIELDS)}
        sums = (f["gains"], f["error"], f["coherent"])
        n_points, refinements, status = (int(f[k]) for k in ("n_points", "refinements", "status"))
        ok = (
            str(f["key"]) == key
            and f["gains"].dtype == np.complex128
            and all(v.shape == (m,) and np.all(np.isfinite(v)) for v in sums)
            and f["panels"].shape == (2,)
            and status in (0, 1, 2)
            and min(n_points, refinements) >= 0
            and str(f["rule"]) in ("rectangle", "polar", "banded")
        )
        if not ok:
            return None
        return frozen(
            RadiationResult(f["gains"], f["error"].astype(float), f["coherent"].astype(float),
                            n_points, refinements, tuple(int(p) for p in f["panels"]),
                            status == 0, status, str(f["message"]), str(f["rule"]))
        )  # fmt: skip
    except Exception:  # noqa: BLE001 - any unreadable cache file is recomputed and rewritten
        return None


def frozen(result: RadiationResult) -> RadiationResult:
    """``result`` with read-only arrays (it is shared between callers)."""
    for arr in (result.gains, result.error, result.coherent):
        arr.setflags(write=False)
    return result
