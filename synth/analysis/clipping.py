"""Clipped samples found and interpolated (a clipped run whitens into false ticks): least squares
under a linear predictor (Janssen, Veldhuis and Vries 1986, IEEE Trans. ASSP 34, 317), each kept
at least at its clipped magnitude."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth import dsp

#: Fewest consecutive samples at a channel's extreme that make a flat top (clipping). Two
#: equal samples at the very extreme of a band-limited waveform need its peak to fall within
#: a quantisation step over a sample period: rare, and never many times at the one level.
FLAT_TOP = 2


@dataclass(frozen=True)
class Clipping:
    """Each channel's clipped samples (``mask``, shaped as the audio) and the warning."""

    mask: np.ndarray
    warning: str


def find_clipping(chans: np.ndarray, min_count: int) -> Clipping | None:
    """The clipped samples of ``chans`` (frames, channels), or None: ``min_count`` samples at an
    extreme in flat tops of :data:`FLAT_TOP` (a mere peak meets it once)."""
    mask = np.zeros(chans.shape, dtype=bool)
    for c, col in enumerate(chans.T):
        for level in (col.max(), col.min()):
            if level != 0.0 and np.count_nonzero(long_runs(col == level)) >= min_count:
                mask[:, c] |= col == level
    counts = np.count_nonzero(mask, axis=0)
    if not counts.any():
        return None
    c = int(np.argmax(counts))  # the channel clipped most
    peak = float(np.abs(chans[:, c]).max())
    return Clipping(mask, clipping_warning(int(counts.sum()), c, int(counts[c]), peak))


def clipping_warning(total: int, channel: int, count: int, peak: float) -> str:
    """The warning for ``total`` clipped samples, ``count`` in ``channel`` (peak ``peak``)."""
    return (
        f"clipping: {total} samples sit at a channel's extreme ({count} in channel {channel}, "
        f"magnitude {peak:.6g}); they were interpolated from the signal's linear predictor "
        f"before the ticks were sought, but the loudest ticks' peaks, energies and spectra "
        f"are unreliable, and their onsets and bounce times may be off too"
    )


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[lo, hi)`` of each run of True values of the boolean ``mask``."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]))


def long_runs(mask: np.ndarray, least: int = FLAT_TOP) -> np.ndarray:
    """The samples of ``mask`` in runs of at least ``least`` True values."""
    out = np.zeros(mask.size, dtype=bool)
    for a, b in runs(mask):
        if b - a >= least:
            out[a:b] = True
    return out


def ar_interpolate(x: np.ndarray, missing: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``x`` with ``missing`` samples estimated by least squares under the filter ``a`` (Janssen et
    al. 1986), none under its clipped magnitude: the normal equations ``G v = b``, ``G_ij =
    ra(|free_i - free_j|)`` (``ra`` the autocorrelation of ``a``), are banded (ridge 1e-9)."""
    from scipy.linalg import solveh_banded
    from scipy.signal import correlate, oaconvolve

    p = a.size - 1
    ra = correlate(a, a, mode="full")[p:]  # autocorrelation of a, lags 0..p
    y = x.copy()
    level = x[missing]
    free = np.nonzero(missing)[0]
    for _ in range(4):
        if free.size == 0:
            break
        y[free] = 0.0
        e0 = oaconvolve(y, a)[: y.size + p]  # prediction error with the gaps at 0
        # b_i = -sum_k a_k e0[i + k]
        b = -correlate(e0, a, mode="valid")[free]
        reach = np.searchsorted(free, free + p, side="right") - np.arange(free.size)
        bw = max(int(np.max(reach)) - 1, 0)
        ab = np.zeros((bw + 1, free.size))
        for k in range(bw + 1):
            lag = free[k:] - free[: free.size - k]
            ab[bw - k, k:] = np.where(lag <= p, ra[np.minimum(lag, p)], 0.0)
        ab[bw] *= 1.0 + 1e-9
        v = solveh_banded(ab, b)
        short = (np.abs(v) < np.abs(x[free])) | (np.sign(v) != np.sign(x[free]))
        y[free] = v
        if not short.any():
            break
        y[free[short]] = x[free[short]]
        free = free[~short]
    y[missing] = np.where(np.abs(y[missing]) < np.abs(level), level, y[missing])
    return y


def declipped_mix(chans: np.ndarray, mask: np.ndarray, order: int) -> np.ndarray:
    """Mean of ``chans`` with clipped samples interpolated by a predictor of 3 times the longest
    clipped run (Janssen et al.), within 8 or ``order / 20`` and ``order``."""
    out = np.empty_like(chans)
    for c in range(chans.shape[1]):
        col, m = chans[:, c], mask[:, c]
        if not m.any():
            out[:, c] = col
            continue
        longest = max(int(hi - lo) for lo, hi in runs(m))
        p = int(min(order, max(3 * longest, order // 20, 8)))
        tail = col[np.nonzero(m)[0][-1] + 1 :]
        a = dsp.autocorrelation_predictor(tail if tail.size >= 4 * order else col, p)
        out[:, c] = ar_interpolate(col, m, a)
    return out[:, 0] if out.shape[1] == 1 else out.mean(axis=1)
