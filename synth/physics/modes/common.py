"""What the plate-mode solutions share: versions, budgets, aspect ratios, a one-thread product."""

from __future__ import annotations

import functools
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
    """What sets the solvers' last bits besides their inputs, part of every disk key: numpy,
    scipy and numba versions; the BLAS libraries loaded, with the kernels they chose for this
    CPU; the CPU numba compiles for and the C library (its math functions); the digest of the
    mode solvers' sources and all they import (any edit may move the last bits)."""
    return dict(_numerics())


@functools.cache
def _numerics() -> tuple:
    import hashlib
    import platform

    import llvmlite.binding as llvm
    import numba
    import scipy
    import scipy.linalg  # noqa: F401 - loads scipy's BLAS and LAPACK before they are listed
    from numba.core import config
    from threadpoolctl import threadpool_info

    from synth.jitcache import source_digest

    blas = sorted({(i["internal_api"], str(i.get("version")), str(i.get("architecture")))
                   for i in threadpool_info() if i["user_api"] == "blas"})  # fmt: skip
    features = config.CPU_FEATURES or llvm.get_host_cpu_features().flatten()
    return (
        ("numpy", np.__version__), ("scipy", scipy.__version__), ("numba", numba.__version__),
        ("blas", [list(b) for b in blas]), ("cpu", config.CPU_NAME or llvm.get_host_cpu_name()),
        ("cpu_features", hashlib.sha256(features.encode()).hexdigest()[:16]),
        ("libc", "-".join(platform.libc_ver())),
        ("code", source_digest(str(Path(__file__).with_name("__init__.py")))),
    )  # fmt: skip


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
