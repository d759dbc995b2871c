"""The numba block ringing of the modal bank (:mod:`synth.sound.modal_bank`): each mode rings
by a table of its powers ``r^j = e^(p j / fs)``, ``SUB`` samples at a time (the inner loop
vectorises); the live engine takes the same steps block by block."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled

#: Samples a mode writes from its power table before its state is advanced (and the
#: tail floor checked).
SUB = 32
#: Samples per tile of the modal bank's output (16 kB of float64: stays in cache).
TILE = 2048


@compiled(sums=True, nogil=True, inline="always")
def power_table(poles, fs):
    """``r^j = e^(p_k j / fs)``, ``j = 0..SUB``, of every mode: (K, 2, SUB + 1) real and
    imaginary parts, by recurrence from ``r = e^(p / fs)`` re-anchored on an exact
    exponential every 8 steps (rounding within a few ulp). poles (K,) complex, rad/s;
    fs: Hz."""
    K = poles.shape[0]
    table = np.empty((K, 2, SUB + 1))
    for k in range(K):
        r = np.exp(poles[k] / fs)
        z = 1.0 + 0.0j
        for j in range(SUB + 1):
            if j % 8 == 0 and j > 0:
                z = np.exp(poles[k] * (j / fs))
            elif j > 0:
                z = z * r
            table[k, 0, j] = z.real
            table[k, 1, j] = z.imag
    return table


@compiled(sums=True, nogil=True, inline="always")
def falls_silent(k, m2, s, debt, debt_at, thresholds, poles, fs):
    """Whether mode ``k``, of squared magnitude ``m2`` at sample ``s``, now fits its share
    of the omission budget: ``|z|`` plus its debt decayed to ``s`` (poles in rad/s, fs in
    Hz) at most ``thresholds[k]``. If so, its debt takes ``|z|`` on, as of ``s``, and the
    caller stops the mode."""
    d = debt[k]
    if d > 0.0:
        d *= math.exp(poles[k].real * ((s - debt_at[k]) / fs))
    mag = math.sqrt(m2)
    if mag + d > thresholds[k]:
        return False
    debt[k] = d + mag
    debt_at[k] = s
    return True


@compiled(sums=True, nogil=True, inline="always")
def inject_amplitudes(zr, zi, active, debt, debt_at, thresholds, poles, fs, amps, a):
    """Add one impact's complex amplitudes ``amps`` (K,) to the modes' states ``zr + i zi``
    at sample ``a`` (the bank's state, see :func:`ring_modes`); a mode whose state plus what
    it has already left out (decayed to ``a``) is within its threshold stops (its ``|z|``
    joins its debt), any other one rings."""
    K = zr.shape[0]
    for k in range(K):
        zr[k] += amps[k].real
        zi[k] += amps[k].imag
        m2 = zr[k] * zr[k] + zi[k] * zi[k]
        active[k] = not falls_silent(k, m2, a, debt, debt_at, thresholds, poles, fs)
        if not active[k]:
            zr[k] = 0.0
            zi[k] = 0.0


@compiled(sums=True, nogil=True, inline="always")
def ring_modes(
    out, offset, a, b, table, zr, zi, active, debt, debt_at, thresholds, thr2, poles, fs
):
    """Advance every ringing mode from sample ``a`` to ``b`` (no injection in between),
    adding ``Re[z_k r_k^j]`` into ``out[s - offset]``. The bank's state per mode: ``zr, zi``
    its complex amplitude, ``active`` whether it rings, ``debt`` a bound of what it has left
    out as of sample ``debt_at``, ``thresholds`` its share of the omission budget (``thr2``
    squared); ``table`` the :func:`power_table` of the ``poles`` (rad/s) at ``fs`` Hz. A mode
    stops once ``|z| + debt <= threshold``. Returns (mode-samples computed, end of the last
    sample written)."""
    K = zr.shape[0]
    work = 0
    last = 0
    for k in range(K):
        if not active[k]:
            continue
        pr = table[k, 0]
        pi = table[k, 1]
        cr = zr[k]
        ci = zi[k]
        s = a
        while s < b:
            n = min(SUB, b - s)
            o = out[s - offset : s - offset + n]  # a view: unsigned indexing, the loop vectorises
            for j in range(n):
                o[j] += cr * pr[j] - ci * pi[j]
            er = pr[n]
            ei = pi[n]
            cr, ci = cr * er - ci * ei, cr * ei + ci * er
            s += n
            m2 = cr * cr + ci * ci
            if m2 < thr2[k] and falls_silent(k, m2, s, debt, debt_at, thresholds, poles, fs):
                active[k] = False
                cr = 0.0
                ci = 0.0
                break
        work += s - a
        if s > last:
            last = s
        zr[k] = cr
        zi[k] = ci
    return work, last


@compiled(sums=True, nogil=True, inline="always")
def remainder(zr, zi, active, debt, debt_at, poles, fs, at):
    """Bound of what the bank's modes leave out at sample ``at``: ``|z|`` of the modes still
    ringing plus every mode's debt decayed to ``at``."""
    left = 0.0
    for k in range(zr.shape[0]):
        d = debt[k]
        if d > 0.0:
            d *= math.exp(poles[k].real * ((at - debt_at[k]) / fs))
        left += d
        if active[k]:
            left += math.sqrt(zr[k] * zr[k] + zi[k] * zi[k])
    return left


@compiled(sums=True)
def ring_bank(out, fs, poles, amps, inject, thresholds):
    """The modal bank: every mode's ringing after every injection, added into ``out`` (S,),
    at ``fs`` Hz: ``poles`` (K,) rad/s, ``amps`` (I, K) joining the state at the ascending
    samples ``inject`` (I,), ``thresholds`` (K,) each mode's share of the omission budget
    (what a mode leaves out stays within it at every sample). Returns (mode-samples computed,
    end of the last sample written, the modes' ``|z|`` plus debts left at the end)."""
    S = out.shape[0]
    K = poles.shape[0]
    I = inject.shape[0]
    table = power_table(poles, fs)
    zr = np.zeros(K)
    zi = np.zeros(K)
    active = np.zeros(K, dtype=np.bool_)
    debt = np.zeros(K)  # bound of the omitted part, as of sample debt_at
    debt_at = np.zeros(K, dtype=np.int64)
    thr2 = thresholds * thresholds
    work = 0
    last = 0
    nxt = 0
    a = 0
    while a < S:
        while nxt < I and inject[nxt] <= a:
            if inject[nxt] == a:
                inject_amplitudes(
                    zr, zi, active, debt, debt_at, thresholds, poles, fs, amps[nxt], a
                )
            nxt += 1
        # this segment ends at the tile's end or at the next injection
        b = min(S, (a // TILE + 1) * TILE)
        if nxt < I and inject[nxt] < b:
            b = inject[nxt]
        w, e = ring_modes(
            out, 0, a, b, table, zr, zi, active, debt, debt_at, thresholds, thr2, poles, fs
        )
        work += w
        if e > last:
            last = e
        a = b
    return work, last, remainder(zr, zi, active, debt, debt_at, poles, fs, S)
