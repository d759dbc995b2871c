"""Signal processing shared by the analysis and alteration of recordings: linear prediction by the
autocorrelation and covariance methods (Makhoul 1975, Proc. IEEE 63, 561), the Schur-Cohn test
(Markel & Gray 1976, 5.3) and a noise floor. Signals in any units; times in s, rates in Hz."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.compilation import compiled

#: Frame length of the noise-floor estimate, s.
NOISE_FRAME = 0.01
#: Frames within this of the quietest one hold noise alone, dB: frames of noise scatter far
#: less than that, frames with a tick or a tail stand above.
NOISE_SPREAD_DB = 3.0
#: White-noise correction of the autocorrelation method: the zero lag raised by this
#: fraction (-90 dB), so that a noiseless sum of a few sinusoids stays solvable.
WHITE_NOISE_CORRECTION = 1e-9


def white_noise_corrected(r: np.ndarray) -> np.ndarray:
    """A copy of the autocorrelation ``r`` with its zero lag raised by
    :data:`WHITE_NOISE_CORRECTION` (white noise -90 dB under the signal added)."""
    r = np.array(r, dtype=float)
    r[0] *= 1.0 + WHITE_NOISE_CORRECTION
    return r


def levinson_predictor(r: np.ndarray) -> np.ndarray:
    """Prediction-error filter ``[1, a1, ..., ap]`` from the autocorrelation ``r[0..p]``: the
    autocorrelation method's Toeplitz system, solved by the Levinson recursion."""
    from scipy.linalg import solve_toeplitz

    order = r.size - 1
    return np.concatenate(([1.0], solve_toeplitz(r[:order], -r[1:])))


def autocorrelation(x: np.ndarray, order: int, parts: dict | None = None) -> np.ndarray:
    """``r[d] = sum_n x[n] x[n + d]`` for ``d = 0..order`` (zero outside the signal), summed over
    blocks by FFT. ``parts``: the blocks' terms of an earlier call on a signal that ``x`` starts,
    keyed by ``(order, block start)``; reused where they lie inside ``x``, new ones added."""
    from scipy.fft import irfft, next_fast_len, rfft

    block = max(4 * order, 1 << 16)
    nfft = next_fast_len(block + order, real=True)
    r = np.zeros(order + 1)
    for s in range(0, x.size, block):
        whole = s + block + order <= x.size
        term = parts.get((order, s)) if parts is not None and whole else None
        if term is None:
            a = rfft(x[s : s + block], nfft)
            b = rfft(x[s : s + block + order], nfft)
            term = irfft(np.conj(a) * b, nfft)[: order + 1].copy()
            if parts is not None and whole:
                parts[(order, s)] = term
        r += term
    return r


def autocorrelation_predictor(x: np.ndarray, order: int) -> np.ndarray:
    """Prediction-error filter ``[1, a1, ..., ap]`` of ``x`` by the autocorrelation method
    (:func:`autocorrelation`, with the :data:`WHITE_NOISE_CORRECTION`)."""
    return levinson_predictor(white_noise_corrected(autocorrelation(x, order)))


def covariance_matrix(x: np.ndarray, order: int, blocks=None) -> np.ndarray:
    """Normal equations of the covariance method, ``C[i, j] = sum_n x[n-i] x[n-j]`` for
    ``i, j = 0..order`` over the targets of ``blocks`` (pairs ``[n1, n2)``, ``n1 >= order``;
    default ``[order, x.size)``): row 0 by FFT, then each diagonal by a recurrence,
    O(N log N + p^2)."""
    p = int(order)
    x = np.ascontiguousarray(x, dtype=float)
    if blocks is None:
        blocks = [(p, x.size)]
    C = np.zeros((p + 1, p + 1))
    C[0] = sum(_covariance_row(x[n1 - p : n2], p) for n1, n2 in blocks)
    first = np.array([x[n1 - 1 :: -1][:p] for n1, _ in blocks])
    last = np.array([x[n2 - 1 :: -1][:p] for _, n2 in blocks])
    _shift_recursion(C, first, last)
    return C


@dataclass(frozen=True)
class CovarianceBorder:
    """Of :func:`covariance_matrix` over one block: row 0, row 1 and the diagonal (the same
    values, the same sums in the same order)."""

    row0: np.ndarray
    row1: np.ndarray
    diagonal: np.ndarray


def covariance_border(x: np.ndarray, order: int) -> CovarianceBorder:
    """Rows 0 and 1 and the diagonal of ``covariance_matrix(x, order)`` in O(N log N + p): all
    that the generalized Schur algorithm takes of the normal equations (their first row and
    the samples entering and leaving the sums), without the ``(p + 1)^2`` matrix."""
    p = int(order)
    x = np.ascontiguousarray(x, dtype=float)
    row0 = 0 + _covariance_row(x, p)  # as covariance_matrix's sum over its one block
    f = x[p - 1 :: -1][:p]
    g = x[x.size - 1 :: -1][:p]
    row1 = np.empty(p + 1)
    row1[0] = row0[1]
    row1[1:] = (row0[:p] + f[0] * f) - g[0] * g
    d = float(row0[0])
    diagonal = [d]
    for fi, gi in zip(f.tolist(), g.tolist()):  # in order, as the recursion along it
        d = (d + fi * fi) - gi * gi
        diagonal.append(d)
    return CovarianceBorder(row0, row1, np.array(diagonal))


def _covariance_row(seg: np.ndarray, p: int) -> np.ndarray:
    """``sum_{n=p}^{N-1} seg[n] seg[n-d]`` for ``d = 0..p``: the full autocorrelation by FFT
    less the products of the first ``p`` samples."""
    from scipy.fft import irfft, next_fast_len, rfft

    n = seg.size
    nfft = next_fast_len(n + p + 1, real=True)
    X = rfft(seg, nfft)
    full = irfft(X * np.conj(X), nfft)[: p + 1]  # sum_t seg[t] seg[t+d]
    head = np.array([np.dot(seg[d:p], seg[: p - d]) for d in range(p + 1)])
    return full - head


@compiled()
def _shift_recursion(C, first, last):  # pragma: no cover - compiled
    """Rows 1..p of the covariance matrix from row 0 (in place), ``first[b, i] = x[n1-1-i]``
    and ``last[b, i] = x[n2-1-i]`` of each block; the lower triangle mirrored. One block (the
    usual case) runs along contiguous rows, the same sums in the same order."""
    p = C.shape[0] - 1
    if first.shape[0] == 1 and last.shape[0] == 1:
        f = first[0]
        g = last[0]
        for i in range(p):
            fi = f[i]
            gi = g[i]
            src = C[i]
            dst = C[i + 1]
            for j in range(i, p):
                dst[j + 1] = (src[j] + fi * f[j]) - gi * g[j]
    else:
        for i in range(p):
            for j in range(i, p):
                s = C[i, j]
                for b in range(first.shape[0]):
                    s += first[b, i] * first[b, j]
                for b in range(last.shape[0]):
                    s -= last[b, i] * last[b, j]
                C[i + 1, j + 1] = s
    _mirror_upper(C)


@compiled()
def _mirror_upper(C):  # pragma: no cover - compiled
    """The lower triangle of the square ``C`` from its upper one, in tiles that stay in cache."""
    n = C.shape[0]
    tile = 64
    for i0 in range(0, n, tile):
        for j0 in range(0, i0 + 1, tile):
            for i in range(i0, min(i0 + tile, n)):
                for j in range(j0, min(j0 + tile, i)):
                    C[i, j] = C[j, i]


def is_minimum_phase(a: np.ndarray) -> bool:
    """Whether the prediction-error filter ``a`` (``a[0] = 1``) has every root inside the unit
    circle, its all-pole model ``1/A`` stable: the step-down (backward Levinson) recursion,
    ``k_m = a_m``, ``a'_i = (a_i - k_m a_(m-i)) / (1 - k_m^2)``, every ``|k_m| < 1`` (the
    Schur-Cohn test)."""
    return bool(_step_down(np.ascontiguousarray(a, dtype=float)))


@compiled()
def _step_down(c):  # pragma: no cover - compiled
    c = c.copy()
    for m in range(c.size - 1, 0, -1):
        k = c[m]
        if not abs(k) < 1.0:
            return False
        d = 1.0 - k * k
        new = np.empty(m)
        for i in range(m):
            new[i] = (c[i] - k * c[m - i]) / d
        c[:m] = new
    return True


def noise_frames(x: np.ndarray, samplerate: float, least: int = 1) -> np.ndarray:
    """``x`` cut into consecutive frames of :data:`NOISE_FRAME` s (at least ``least``
    samples), shape ``(frames, samples)``; the remainder after the last whole frame is left
    out."""
    n = max(least, int(round(NOISE_FRAME * samplerate)))
    frames = x.size // n
    return x[: frames * n].reshape(frames, n)


def quiet_frames(power: np.ndarray, among: np.ndarray | None = None) -> np.ndarray:
    """Mask of the frames whose mean power ``power`` lies within :data:`NOISE_SPREAD_DB` of the
    quietest frame (of those in the mask ``among``, default all): the frames of noise alone."""
    pool = power if among is None else power[among]
    quiet = power <= pool.min() * 10.0 ** (NOISE_SPREAD_DB / 10.0)
    return quiet if among is None else among & quiet


def noise_floor(x: np.ndarray, samplerate: float) -> float:
    """RMS of the :data:`NOISE_FRAME` frames of ``x`` within :data:`NOISE_SPREAD_DB` of the
    quietest one, signal units (of the whole signal when it is shorter than a frame)."""
    fr = noise_frames(x, samplerate)
    if fr.shape[0] == 0:
        return float(np.sqrt(np.mean(x * x)))
    ms = np.mean(fr**2, axis=1)
    return float(np.sqrt(ms[quiet_frames(ms)].mean()))
