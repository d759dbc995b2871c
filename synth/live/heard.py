"""The listener's gains at a voice's output: slots hold the plate's modal states, heard
through each mode's complex gain (ramped after :meth:`synth.live.Body.move`), as the bank's
:func:`~synth.sound.modal_bank.ring_modes` and ``inject_amplitudes`` with the omission test
on the heard level; a mode no longer heard parks its plate state (:func:`park`).
"""

from __future__ import annotations

import numpy as np

from synth.compilation import compiled
from synth.sound.modal_bank.bank_kernels import SUB, falls_silent

#: Rows of ``heard`` (float64, (N_HEARD_ROWS, K)): gains at the block's start, target, handed over.
H0R, H0I, H1R, H1I, HPR, HPI, N_HEARD_ROWS = range(7)
#: ``heard_seq``: the producer's sequence number (odd while written), the last one taken.
SEQ_PUT, SEQ_TAKEN = range(2)


@compiled(nogil=True, inline="always")
def heard_power(heard, k):
    """Mode ``k``'s largest ``|G|^2`` over the block (never left out while ramped louder)."""
    a = heard[H0R, k] * heard[H0R, k] + heard[H0I, k] * heard[H0I, k]
    b = heard[H1R, k] * heard[H1R, k] + heard[H1I, k] * heard[H1I, k]
    return max(a, b)


@compiled(nogil=True, inline="always")
def park(park_r, park_i, park_at, k, cr, ci, at, poles, fs):
    """Park mode ``k``'s plate state ``cr + i ci`` at sample ``at`` (added to what it parked,
    decayed) for a later listener."""
    pr = park_r[k]
    pi = park_i[k]
    if pr != 0.0 or pi != 0.0:
        e = np.exp(poles[k] * ((at - park_at[k]) / fs))
        pr, pi = pr * e.real - pi * e.imag, pr * e.imag + pi * e.real
    park_r[k] = pr + cr
    park_i[k] = pi + ci
    park_at[k] = at


@compiled(nogil=True)
def ring_heard(out, offset, a, b, table, zr, zi, active, debt, debt_at, thresholds, thr2,
               poles, fs, park_r, park_i, park_at, heard, t0, n):  # fmt: skip
    """``out[s - offset] += Re[G_k(s) z_k r_k^(s - a)]``, the gain ramped from ``t0`` over
    ``n`` samples, folded into the state once per ``SUB`` samples (the bank's inner loop); a
    mode that fits its omission share stops and parks."""
    K = zr.shape[0]
    inv_n = 1.0 / n
    for k in range(K):
        if not active[k]:
            continue
        pr = table[k, 0]
        pi = table[k, 1]
        g0r = heard[H0R, k]
        g0i = heard[H0I, k]
        g1r = heard[H1R, k]
        g1i = heard[H1I, k]
        ramp = g0r != g1r or g0i != g1i
        g2 = heard_power(heard, k)
        cr = zr[k]
        ci = zi[k]
        s = a
        while s < b:
            m = min(SUB, b - s)
            o = out[s - offset : s - offset + m]
            if not ramp or s >= t0 + n:
                hr = g1r * cr - g1i * ci
                hi = g1r * ci + g1i * cr
                for j in range(m):
                    o[j] += hr * pr[j] - hi * pi[j]
            else:
                hr = g0r * cr - g0i * ci
                hi = g0r * ci + g0i * cr
                dr = (g1r - g0r) * cr - (g1i - g0i) * ci
                di = (g1r - g0r) * ci + (g1i - g0i) * cr
                base = s - t0 + 1
                for j in range(m):
                    u = min(1.0, (base + j) * inv_n)
                    o[j] += (hr * pr[j] - hi * pi[j]) + u * (dr * pr[j] - di * pi[j])
            er = pr[m]
            ei = pi[m]
            cr, ci = cr * er - ci * ei, cr * ei + ci * er
            s += m
            m2 = (cr * cr + ci * ci) * g2
            if m2 < thr2[k] and falls_silent(k, m2, s, debt, debt_at, thresholds, poles, fs):
                park(park_r, park_i, park_at, k, cr, ci, s, poles, fs)
                active[k] = False
                cr = 0.0
                ci = 0.0
                break
        zr[k] = cr
        zi[k] = ci


@compiled(nogil=True, inline="always")
def inject_heard(zr, zi, active, debt, debt_at, thresholds, poles, fs, amps, a, park_r,
                  park_i, park_at, heard):  # fmt: skip
    """:func:`~synth.sound.modal_bank.inject_amplitudes` of plate amplitudes ``amps``, the
    omission test on the heard level; a mode that stops parks (:func:`park`)."""
    for k in range(zr.shape[0]):
        zr[k] += amps[k].real
        zi[k] += amps[k].imag
        m2 = (zr[k] * zr[k] + zi[k] * zi[k]) * heard_power(heard, k)
        active[k] = not falls_silent(k, m2, a, debt, debt_at, thresholds, poles, fs)
        if not active[k]:
            park(park_r, park_i, park_at, k, zr[k], zi[k], a, poles, fs)
            zr[k] = 0.0
            zi[k] = 0.0


def heard_arrays(gains) -> tuple:
    """A body's ``heard``, every row at the complex ``gains`` (K,), and its ``heard_seq``."""
    heard = np.empty((N_HEARD_ROWS, gains.size))
    heard[0::2] = gains.real
    heard[1::2] = gains.imag
    return heard, np.zeros(2, dtype=np.int64)
