"""Golden renders compared by value: a seeded count sketch of the audio.

A render is stored as ``K`` sums: sample ``i`` is added, with a seeded sign ``s_i = +-1``, to
bucket ``h_i`` of ``K`` (a count sketch, Charikar, Chen & Farach-Colton 2002). For any change
``d`` of the audio, ``E |S d|^2 = |d|^2`` with a relative spread of about ``sqrt(2 / K)``, so
the sketch's relative change ``|S a' - S a| / |S a|`` estimates the waveform's relative L2 error
``|a' - a| / |a|`` from a few hundred bytes, whatever the render's length. Float rounding of a
new numpy, scipy or numba moves it by about 1e-7; a change of the sound by far more. Signs and
buckets come from PCG64's raw output, whose stream numpy keeps fixed across versions.
"""

from __future__ import annotations

import numpy as np

#: Buckets of the sketch (a power of two: a bucket is the low bits of a raw word).
BUCKETS = 64
#: Seed of the signs and buckets (one stream for every render).
SEED = 20261129
#: The waveform's largest relative L2 error against its recording (-120 dB): float rounding
#: moves it by about 1e-7.
MAX_RELATIVE_ERROR = 1e-6
#: Relative change of the drop height that stands for the float rounding of another numpy,
#: scipy or numba version, at 100 times its size: such a version moves a first impact's
#: restitution by about 1e-14 relative (the plate's modes come out of another LAPACK).
ROUNDING_PERTURBATION = 1e-12


def sketch(audio: np.ndarray) -> np.ndarray:
    """The ``BUCKETS`` signed sums of ``audio`` (1-D, any float dtype, its own units), in
    float64."""
    audio = np.asarray(audio, dtype=np.float64).ravel()
    raw = np.random.PCG64(SEED).random_raw(audio.size)
    bucket = (raw & np.uint64(BUCKETS - 1)).astype(np.intp)
    sign = 1.0 - 2.0 * ((raw >> np.uint64(32)) & np.uint64(1)).astype(np.float64)
    return np.bincount(bucket, weights=sign * audio, minlength=BUCKETS)


def relative_error(audio: np.ndarray, recorded) -> float:
    """Estimated relative L2 error of ``audio`` against the render whose sketch is
    ``recorded``."""
    recorded = np.asarray(recorded, dtype=np.float64)
    return float(np.linalg.norm(sketch(audio) - recorded) / np.linalg.norm(recorded))


def rounding_horizon(audio: np.ndarray, moved: np.ndarray, bound: float) -> int | None:
    """Samples from the start over which ``moved`` (the render of a rounding-sized change of
    an input) stays within relative L2 error ``bound`` of ``audio``: the part of the render
    that float rounding cannot move. None if the whole render stays within it (the same
    length, the whole error below ``bound``). A bounce series on a ringing plate amplifies
    rounding impact by impact, so that past its horizon the render is not fixed by its inputs
    to better than rounding, and another dependency version may end it elsewhere."""
    a = np.asarray(audio, dtype=np.float64).ravel()
    b = np.asarray(moved, dtype=np.float64).ravel()
    n = min(a.size, b.size)
    diff = np.cumsum((a[:n] - b[:n]) ** 2)
    energy = np.cumsum(a[:n] ** 2)
    error = np.sqrt(np.divide(diff, energy, out=np.zeros(n), where=energy > 0.0))
    beyond = np.flatnonzero(error > bound)
    if beyond.size == 0:
        return None if a.size == b.size else n
    return int(beyond[0])


def recorded_renders() -> dict:
    """tests/data/preset_renders.json: each preset's recorded render (samples or its rounding
    horizon, sketch, ticks)."""
    import json
    from pathlib import Path

    return json.loads((Path(__file__).parent / "data" / "preset_renders.json").read_text())
