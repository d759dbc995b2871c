"""The cache of the free and clamped plates' Ritz solutions, in memory and as ``.npz`` in
``$SYNTH_CACHE_DIR``. Only the exact band is reused: a wider band's modes differ in their last
bits, and no result may depend on what was solved before."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from synth.physics.modes.common import numerics_key
from synth.physics.modes.ritz import RitzSolution, solution_key, solve_ritz
from synth.store.cache import MemoryCache, cache_path, load_npz, savez_atomic

# Solutions in memory: least recently used dropped beyond 1 GiB (the newest always kept).
CACHE = MemoryCache("solves", max_bytes=1 << 30)


#: Counters of the Ritz cache since start-up, and forgetting memory with them (not the disk).
cache_info = CACHE.info
clear_memory_cache = CACHE.clear


def _path(key: str, boundary: str) -> Path:
    return cache_path(f"plate-modes-{boundary}", key)


def _save(sol: RitzSolution, key: str) -> None:
    """Write ``sol`` to the disk cache (atomically); skipped if impossible."""
    arrays = dict(key=np.array(key), omega_max=np.array(sol.omega_max), omega=sol.omega)
    arrays.update(cls=sol.cls, col=sol.col)
    for c in range(4):
        arrays[f"I{c}"], arrays[f"J{c}"] = sol.index[c]
        arrays[f"coef{c}"] = sol.coef[c]
    try:
        path = _path(key, sol.boundary)
    except RuntimeError:  # no home directory
        return
    if savez_atomic(path, arrays):
        CACHE.count("disk_writes")


def _load(key: str, boundary: str, nu: float, aspect: float):
    """The stored solution of ``key``, or None if absent, unreadable or inconsistent."""
    try:
        path = _path(key, boundary)
        if not path.is_file():
            return None
        with load_npz(path) as z:
            if str(z["key"][()]) != key:
                return None
            omega_max, omega = float(z["omega_max"][()]), z["omega"]
            cls, col = z["cls"].astype(np.int64), z["col"].astype(np.int64)
            index = [(z[f"I{c}"].astype(np.int64), z[f"J{c}"].astype(np.int64)) for c in range(4)]
            coef = [np.ascontiguousarray(z[f"coef{c}"], dtype=float) for c in range(4)]
        ok = (
            omega.ndim == 1
            and cls.shape == col.shape == omega.shape
            and np.all(np.isfinite(omega))
            and np.all(np.diff(omega) >= 0.0)
            and 0.0 < omega_max < math.inf
            and (omega.size == 0 or (omega[-1] <= omega_max and 0 <= cls.min() <= cls.max() <= 3))
        )
        for c, (I, J) in enumerate(index):
            n = int(np.sum(cls == c))
            ok = ok and (
                I.ndim == 1
                and I.shape == J.shape
                and coef[c].shape == (I.size, n)
                and np.all(np.isfinite(coef[c]))
                and np.array_equal(col[cls == c], np.arange(n))
            )
        if not ok:
            return None
        return RitzSolution(
            boundary, nu, aspect, omega_max, omega, cls, col, index, coef, {"source": str(path)}
        )
    except Exception:  # noqa: BLE001 - any unreadable cache file is recomputed and rewritten
        return None


def cached_ritz(boundary: str, nu: float, aspect: float, omega_req: float, cache: bool):
    """The converged solution of band ``omega_req``: from memory, disk or solved (same arrays)."""
    return CACHE.fetch(
        band_key(boundary, nu, aspect, omega_req) if cache else None,
        lambda: solve_ritz(boundary, nu, aspect, omega_req),
        load=lambda key: _load(key, boundary, nu, aspect), save=_save,
        usable=lambda held: held.omega_max == omega_req,
    )  # fmt: skip


def band_key(boundary: str, nu: float, aspect: float, omega_req: float) -> str:
    """The cache key of the solution of exactly the band ``omega_req`` (dimensionless)."""
    return json.dumps(
        {"solution": solution_key(boundary, nu, aspect), "band": float(omega_req).hex(),
         "numerics": numerics_key()},
        sort_keys=True,
    )  # fmt: skip
