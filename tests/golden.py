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
