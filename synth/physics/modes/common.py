"""What the plate-mode solutions share: versions, budgets, aspect ratios, a one-thread product."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

# Temporary-array budget of shapes(): elements (8 bytes each).
CHUNK_ELEMENTS = 1 << 22
# Largest matrix product handed to BLAS in one call, multiply-adds: OpenBLAS runs up to 4 *
# 65536 on one thread; beside busy threads a multithreaded product stalls for a free core.
_PIECE = 1 << 18
# Version of the stored solution layout and algorithm; part of the cache key.
VERSION = 1


def numerics_key() -> dict:
    """numpy, scipy and numba versions (BLAS and LAPACK set the last bits) and the digest of
    the mode solvers' sources and all they import (any edit of that code may move the last
    bits; a version number alone misses one): part of disk keys."""
    import numba
    import scipy

    from synth.jitcache import source_digest

    return {"numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "code": source_digest(str(Path(__file__).with_name("__init__.py")))}  # fmt: skip


def single_thread_product(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out[...] = a @ b`` (2-D) in pieces OpenBLAS runs on the calling thread."""
    n, k = a.shape
    m = b.shape[1]
    rows = min(n, max(8, math.isqrt(_PIECE // max(1, k))))
    cols = min(m, max(8, _PIECE // max(1, k * rows)))
    for r0 in range(0, n, rows):
        for c0 in range(0, m, cols):
            np.matmul(
                a[r0 : r0 + rows], b[:, c0 : c0 + cols], out=out[r0 : r0 + rows, c0 : c0 + cols]
            )


def ratios(aspect: float):
    """``(L/a, L/b)`` for ``aspect = a/b`` and ``L = max(a, b)``."""
    return (1.0, aspect) if aspect >= 1.0 else (1.0 / aspect, 1.0)
