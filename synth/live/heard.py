"""The listener's gains at a voice's output: each mode heard through its complex gain.

Voice slots hold the plate's modal states; the mixing hears them through ``heard``, each
mode's gain at the block's start and its target at the end (ramped after the listener
moved, :meth:`synth.live.Body.move`). :func:`ring_heard` is the bank's
:func:`~synth.sound.modal_bank.ring_modes` with that gain at its output, :func:`inject_heard`
its :func:`~synth.sound.modal_bank.inject_amplitudes` with the omission test on the heard
level; a mode no longer heard parks its plate state (:func:`park`) for a later listener.
"""

from __future__ import annotations

import numpy as np

from synth.compilation import compiled
from synth.sound.modal_bank.bank_kernels import SUB, falls_silent

#: Rows of a body's ``heard`` (float64, (N_HEARD_ROWS, K)): the listener's complex gain
#: of each mode at the start of the block (re, im), its target at the block's end (re, im;
#: ramped linearly over the block), and the gains a producer hands over (re, im; see
#: :meth:`synth.live.Body.move`).
H0R, H0I, H1R, H1I, HPR, HPI = range(6)
N_HEARD_ROWS = 6
#: ``heard_seq`` (int64): the producer's sequence number of the handed-over gains (odd
#: while it writes them), and the last one the mixing took.
SEQ_PUT, SEQ_TAKEN = range(2)


@compiled(nogil=True, inline="always")
def heard_power(heard, k):
    """The largest power gain ``|G|^2`` of mode ``k`` over the block (its start and its
    target): what the omission tests compare against, so that a mode is never left out
    while the ramp makes it louder than the test assumed."""
    a = heard[H0R, k] * heard[H0R, k] + heard[H0I, k] * heard[H0I, k]
    b = heard[H1R, k] * heard[H1R, k] + heard[H1I, k] * heard[H1I, k]
    return max(a, b)


@compiled(nogil=True, inline="always")
def park(park_r, park_i, park_at, k, cr, ci, at, poles, fs):
    """Keep mode ``k``'s plate state ``cr + i ci`` at sample ``at`` when it stops being
    heard (its heard level under its omission share): added to what it parked before,
    decayed to ``at``, so that a listener that hears it better later gets it back
    (see :func:`synth.live.kernel.mix_body`)."""
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
    """:func:`~synth.sound.modal_bank.ring_modes` of a voice slot's plate state (its modes'
    complex amplitudes without the listener's gains), heard through each mode's complex
    gain ``G_k`` (``heard``), ramped linearly from its value at the block's start ``t0``
    to its target over the block's ``n`` samples (the target after it):
    ``out[s - offset] += Re[G_k(s) z_k r_k^(s - a)]``. With a still listener the gain is
    folded into the state once per ``SUB`` samples, and the inner loop is the bank's;
    while the gains ramp it takes one more complex multiply-add a mode-sample. A mode whose
    heard level (with its larger gain of the block) and debt fit its omission share stops,
    as in the bank, and parks its plate state (:func:`park`)."""
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
    """:func:`~synth.sound.modal_bank.inject_amplitudes` of plate amplitudes ``amps``: the
    omission test takes each mode's heard level (its larger gain of the block); a mode
    that stops parks its plate state (:func:`park`)."""
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
    """A body's ``heard`` (:data:`N_HEARD_ROWS`, K) with every row at the listener's
    complex gains ``gains`` (K,), and its ``heard_seq`` (int64, 2)."""
    heard = np.empty((N_HEARD_ROWS, gains.size))
    heard[0::2] = gains.real
    heard[1::2] = gains.imag
    return heard, np.zeros(2, dtype=np.int64)
