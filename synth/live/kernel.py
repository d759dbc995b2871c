"""The audio thread's work: one compiled call per body per block, one to write the output.

A body's modal state is the offline modal bank's (:mod:`synth.sound.modal_bank`): its
modes' complex amplitudes, which of them ring, their omission debts and thresholds.
:func:`mix_body` advances it over one block with the bank's own steps
(:func:`~synth.sound.modal_bank.ring_modes` between injections,
:func:`~synth.sound.modal_bank.inject_amplitudes` at each impact that falls in the block),
so a sequence of impacts played block by block is the offline render of the same impacts,
up to the rounding of the state's advance (the segments end at block boundaries instead
of the bank's tiles).

Impacts handed over as force pulses (:mod:`synth.live.queue`, the PULSE form) are turned
into mode amplitudes first, at the start of the block, by the renderer's transform
(:func:`~synth.sound.modal_bank.transform_pulse`).

Compiled ``nogil=True``: while a block is mixed, trigger threads keep running (they solve
contacts and fill free slots of the pending ring, see :mod:`synth.live.queue`).
"""

from __future__ import annotations

import numba

from synth.live.atomics import fence
from synth.sound.modal_bank import (
    inject_amplitudes,
    ring_modes,
    transform_pulse,
)

#: Slot states of the pending ring (see :mod:`synth.live.queue`; WRITING = 2 is the
#: producers' own).
FREE = 0
READY = 1
PULSE = 3

#: The scalars of a slot in the PULSE form (columns of the ring's ``pulse``): the grid
#: step (s), the first in-contact sample's time from first touch (s), the weight left on
#: the plate (N), the contact time (s), the rule's error order, the hit's gain and the
#: accelerometer's direct-term line (listener units per N; 0 for a microphone).
STEP, OFFSET, WEIGHT, CONTACT_TIME, ORDER, GAIN, MASS_LINE = range(7)
N_PULSE_FIELDS = 7

#: Per-body counters (int64 array): impacts played, impacts that arrived after their
#: start (played at the start of the block they were found in), blocks in which the body
#: rang, 1 while the body has ringing modes or pending impacts, 1 while a ``stop_all``
#: waits for the audio thread, the most pulses one block has transformed.
PLAYED = 0
LATE = 1
BUSY_BLOCKS = 2
AWAKE = 3
SILENCE = 4
MOST_PULSES = 5
N_COUNTERS = 6

#: Where the master bus' soft clipper leaves the identity: -1 dBFS (a fraction of full
#: scale); above it a tanh knee approaches full scale (see :func:`synth.live.native.soft_clip`).
KNEE = 10.0 ** (-1.0 / 20.0)


@numba.njit(cache=True, nogil=True)
def _contact_samples(out, t0, n, state, first, length, response):
    """Add the in-contact samples of every pending impact that fall in ``[t0, t0 + n)``."""
    end = t0 + n
    for i in range(state.shape[0]):
        if state[i] != READY:
            continue
        fence()  # the slot's data after its state word
        lo = max(first[i], t0)
        hi = min(first[i] + length[i], end)
        for s in range(lo, hi):
            out[s - t0] += response[i, s - first[i]]


@numba.njit(cache=True, nogil=True)
def _next_due(state, inject, end):
    """The pending slot with the earliest injection before ``end``, or -1."""
    best = -1
    when = end
    for i in range(state.shape[0]):
        if state[i] == READY:
            fence()  # the slot's data after its state word
            if inject[i] < when:
                when = inject[i]
                best = i
    return best


@numba.njit(cache=True, nogil=True, inline="always")
def _transform_pulses(
    state, length, amplitudes, response, reference, transform, pulse_form, transformed
):
    """Turn every slot in the PULSE form into the READY form: the renderer's transform of
    its pulse (``transform``: the body's poles and one-sample steps, re and im, its largest
    decay rate in 1/s, the sample period in s and the audio thread's own workspace of
    :func:`~synth.sound.modal_bank.transform_workspace`), times the hit's gain, plus an
    accelerometer's direct term; as :func:`synth.sound.modal_bank.impact_excitation` and
    the producer's scaling would make it. Returns the number of pulses transformed."""
    pr, pi, ur, ui, sigma_max, period, work = transform
    coefficients, samples, points, pulse = pulse_form
    count = 0
    for i in range(state.shape[0]):
        if state[i] != PULSE:
            continue
        fence()  # the slot's data after its state word
        n = points[i]
        M = length[i]
        p = pulse[i]
        amps = amplitudes[i]
        resp = response[i, :M]
        forces = samples[i, 0]
        slopes = samples[i, 1]
        magnitude = transform_pulse(
            pr, pi, coefficients[i, 0], coefficients[i, 1], ur, ui, sigma_max, period,
            p[STEP], forces[:n], slopes[:n], p[OFFSET], forces[n : n + M], slopes[n : n + M],
            p[WEIGHT], p[CONTACT_TIME], p[ORDER], amps, resp, work,
        )  # fmt: skip
        g = p[GAIN]
        for k in range(amps.shape[0]):
            amps[k] *= g
        line = p[MASS_LINE]
        for m in range(M):
            resp[m] = (resp[m] + forces[n + m] * line) * g
        reference[i] = magnitude * g
        state[i] = READY
        transformed[0] += 1
        count += 1
    return count


@numba.njit(cache=True, nogil=True, inline="always")
def mix_body(
    out,
    t0,
    n,
    table,
    poles,
    fs,
    zr,
    zi,
    active,
    debt,
    debt_at,
    thresholds,
    thr2,
    level,
    floor,
    state,
    inject,
    first,
    length,
    amplitudes,
    response,
    reference,
    counters,
    transform,
    pulse_form,
    transformed,
):
    """Mix one body into ``out[0:n]`` (samples ``t0 .. t0 + n - 1`` of the engine's clock).

    The bank's state (``table`` .. ``thr2``, see :func:`~synth.sound.modal_bank.ring_modes`);
    level[0]: the body's reference amplitude, the largest ``reference`` (sum of ``|amps|``)
    of the impacts played so far; floor: the omission floor, a fraction of it, shared by
    the ``K`` modes (each mode's threshold is ``floor * level / K``, as offline). The
    pending ring: ``state`` (FREE/READY/PULSE), ``inject`` (sample of the amplitudes),
    ``first``/``length``/``response`` (in-contact samples), ``amplitudes`` (R, K),
    ``reference`` (R,); the PULSE form (``transform``, ``pulse_form``, ``transformed``:
    see :func:`_transform_pulses`). A body with no ringing mode and nothing pending
    returns at once.
    """
    pulses = _transform_pulses(
        state, length, amplitudes, response, reference, transform, pulse_form, transformed
    )
    if pulses > counters[MOST_PULSES]:
        counters[MOST_PULSES] = pulses
    end = t0 + n
    due = _next_due(state, inject, end + (1 << 40))
    if counters[AWAKE] == 0 and due < 0:
        return
    counters[AWAKE] = 1
    if due >= 0:
        _contact_samples(out, t0, n, state, first, length, response)
    K = zr.shape[0]
    a = t0
    while True:
        # ring up to the next injection due in this block (a late one: at once), or to the
        # block's end; one call site of ring_modes, which numba inlines (each inlined copy
        # is compiled again)
        i = _next_due(state, inject, end)
        stop = end
        if i >= 0:
            stop = inject[i]
            if stop < t0:
                counters[LATE] += 1
                stop = t0
        if stop > a:
            ring_modes(
                out, t0, a, stop, table, zr, zi, active, debt, debt_at, thresholds, thr2, poles, fs
            )
            a = stop
        if i < 0:
            break
        if reference[i] > level[0]:
            level[0] = reference[i]
            share = floor * level[0] / max(K, 1)
            for k in range(K):
                thresholds[k] = share
                thr2[k] = share * share
        inject_amplitudes(zr, zi, active, debt, debt_at, thresholds, poles, fs, amplitudes[i], a)
        fence()  # done reading the slot before a producer may take it
        state[i] = FREE
        counters[PLAYED] += 1
    counters[BUSY_BLOCKS] += 1
    awake = 0
    for k in range(K):
        if active[k]:
            awake = 1
            break
    if awake == 0:
        for i in range(state.shape[0]):
            if state[i] == READY:
                awake = 1
                break
    counters[AWAKE] = awake


@numba.njit(cache=True, nogil=True)
def silence(zr, zi, active, debt, state, transformed):
    """Stop every mode and drop every pending impact of a body (its level is kept); a slot
    that a producer is still filling stays its own. A dropped pulse counts as taken
    (``transformed``), so that the ring's bound on waiting pulses stays exact."""
    for k in range(zr.shape[0]):
        zr[k] = 0.0
        zi[k] = 0.0
        active[k] = False
        debt[k] = 0.0
    for i in range(state.shape[0]):
        if state[i] == PULSE:
            transformed[0] += 1
            state[i] = FREE
        elif state[i] == READY:
            state[i] = FREE


def body_state(modes: int) -> tuple:
    """A silent modal state of ``modes`` modes: amplitudes (re, im), ringing flags, omission
    debts, the sample of each debt, thresholds and their squares."""
    import numpy as np

    K = modes
    return (
        np.zeros(K),
        np.zeros(K),
        np.zeros(K, dtype=np.bool_),
        np.zeros(K),
        np.zeros(K, dtype=np.int64),
        np.zeros(K),
        np.zeros(K),
    )
