"""The audio thread's work on a body, one compiled ``nogil`` call a block. Voice slots hold
the plate's modal states as the offline bank's (:mod:`synth.sound.modal_bank`), heard
through each mode's complex listener gain (ramped after :meth:`synth.live.Body.move`; a mode
no longer heard parks, :func:`park`), so a voice is the offline render of its impacts up to
rounding. Producers write data, a fence, then the state word (ARM64 reorders without it)."""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from synth.compilation import compiled
from synth.sound.modal_bank import transform_pulse
from synth.sound.modal_bank.bank_kernels import SUB, falls_silent


@intrinsic
def _fence(typingctx):
    sig = types.none()

    def codegen(context, builder, signature, args):
        builder.fence("seq_cst")
        return context.get_dummy_value()

    return sig, codegen


@compiled(nogil=True, inline="always")
def fence():
    """A sequentially consistent fence (compiler and processor)."""
    _fence()


@compiled(nogil=True)
def publish(state, slot, value):
    """``state[slot] = value`` after the calling thread's earlier stores are visible."""
    _fence()
    state[slot] = value


@intrinsic
def pointer_to(typingctx, address):
    """The int64 ``address`` as a ``void*`` (for ``numba.carray``)."""
    sig = types.voidptr(types.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return sig, codegen


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
    pr, pi = park_r[k], park_i[k]
    if pr != 0.0 or pi != 0.0:
        e = np.exp(poles[k] * ((at - park_at[k]) / fs))
        pr, pi = pr * e.real - pi * e.imag, pr * e.imag + pi * e.real
    park_r[k], park_i[k], park_at[k] = pr + cr, pi + ci, at


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
        pr, pi = table[k, 0], table[k, 1]
        g0r, g0i, g1r, g1i = heard[H0R, k], heard[H0I, k], heard[H1R, k], heard[H1I, k]
        ramp = g0r != g1r or g0i != g1i
        g2 = heard_power(heard, k)
        cr, ci = zr[k], zi[k]
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
            er, ei = pr[m], pi[m]
            cr, ci = cr * er - ci * ei, cr * ei + ci * er
            s += m
            m2 = (cr * cr + ci * ci) * g2
            if m2 < thr2[k] and falls_silent(k, m2, s, debt, debt_at, thresholds, poles, fs):
                park(park_r, park_i, park_at, k, cr, ci, s, poles, fs)
                active[k] = False
                cr = ci = 0.0
                break
        zr[k], zi[k] = cr, ci


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
            zr[k] = zi[k] = 0.0


def heard_arrays(gains) -> tuple:
    """A body's ``heard``, every row at the complex ``gains`` (K,), and its ``heard_seq``."""
    heard = np.empty((N_HEARD_ROWS, gains.size))
    heard[0::2] = gains.real
    heard[1::2] = gains.imag
    return heard, np.zeros(2, dtype=np.int64)


#: Slot states of the pending ring (:mod:`synth.live.voice`; WRITING = 2 is the producers').
FREE, READY, PULSE = 0, 1, 3
#: A PULSE slot's scalars: grid step (s), first in-contact sample from first touch (s),
#: weight left on the plate (N), contact time (s), rule's order, gain, direct-term line.
STEP, OFFSET, WEIGHT, CONTACT_TIME, ORDER, GAIN, MASS_LINE, N_PULSE_FIELDS = range(8)
#: A body's counters (int64; EARS and STEAL_FRAMES, samples, are settings).
(
    PLAYED, LATE, BUSY_BLOCKS, AWAKE, SILENCE, MOST_PULSES, STOLEN, DROPPED, TAIL_END, EARS,
    STEAL_FRAMES, REFUSED, N_COUNTERS,
) = range(13)  # fmt: skip

#: A voice record (int64 columns of ``voices``): id, state, impacts handed over, those
#: played or dropped, stop fade asked (samples, -1 none), 1 once stolen or refused, its slot
#: (-1 none), priority.
V_ID, V_STATE, V_PUT, V_PLAYED, V_STOP, V_DEAD, V_SLOT, V_PRIORITY, N_VOICE_FIELDS = range(9)
V_FREE, V_LIVE = 0, 1

#: A voice slot (int64 columns of ``slots``): its voice record (-1 free), the sample it was
#: taken at, stop fade's start (-1 none) and length, where its state stands, steal fade length.
SL_OWNER, SL_START, SL_FADE_AT, SL_FADE_LEN, SL_POS, SL_STEAL, N_SLOT_FIELDS = range(7)
#: A voice slot's gain (``slot_gain`` columns): at the block's start, and its target.
G_NOW, G_NEXT = range(2)
#: A sample no impact reaches; passed as an int64 (a literal would compile a callee again).
NEVER = 1 << 62
#: A voice-ended event (int64, in the engine's event ring): ``id * EVENT_EARS + ears``.
EVENT_EARS = 128
#: Where the master bus' soft clipper leaves the identity: -1 dBFS (:func:`native.soft_clip`).
KNEE = 10.0 ** (-1.0 / 20.0)
#: The engine's event ring (int64): events written, read, lost to a full ring, then the ring.
E_WRITTEN, E_READ, E_LOST, N_EVENT_HEADER = range(4)


@compiled(nogil=True, inline="always")
def _voice_ended(records, r, events, ears):
    """Free voice record ``r`` and post its id to the engine's event ring."""
    vid = records[r, V_ID]
    fence()  # done with the record before a producer may take it
    records[r, V_STATE] = V_FREE
    post_event(events, vid * EVENT_EARS + ears)


@compiled(nogil=True, inline="always")
def post_event(events, value):
    """Post ``value`` in the event ring (lock-free: one writer, the mixing, one reader,
    :meth:`synth.live.Engine.ended`), or count it lost if the ring is full."""
    cap, written = events.shape[0] - N_EVENT_HEADER, events[E_WRITTEN]
    if written - events[E_READ] >= cap:
        events[E_LOST] += 1
        return
    events[N_EVENT_HEADER + written % cap] = value
    fence()  # the event before its count
    events[E_WRITTEN] = written + 1


@compiled(nogil=True)
def _settle(records, r, events, ears):
    """End voice ``r`` if it rings in no slot and has nothing left to play."""
    if records[r, V_SLOT] < 0 and records[r, V_PLAYED] == records[r, V_PUT]:
        _voice_ended(records, r, events, ears)


@compiled(nogil=True, inline="always")
def _drop(state, i, records, r, counters):
    """Drop pending impact ``i`` of voice ``r`` (stopped or stolen before it played)."""
    fence()  # done reading the slot before a producer may take it
    state[i] = FREE
    records[r, V_PLAYED] += 1
    counters[DROPPED] += 1


@compiled(nogil=True, inline="always")
def _drop_stopped(state, i, records, r, counters, events):
    """Drop pending impact ``i`` if its voice ``r`` was stopped, stolen or refused; whether
    it was."""
    if records[r, V_STOP] < 0 and records[r, V_DEAD] == 0:
        return False
    _drop(state, i, records, r, counters)
    _settle(records, r, events, counters[EARS])
    return True


@compiled(nogil=True, inline="always")
def _refuse(state, i, records, r, counters, events):
    """Refuse voice ``r`` (outranked by every ringing slot) at its pending impact ``i``."""
    records[r, V_DEAD] = 1
    counters[REFUSED] += 1
    _drop_stopped(state, i, records, r, counters, events)


@compiled(nogil=True)
def _outranked(records, slots, r):
    """Whether voice ``r`` would be refused a slot now (:func:`_victim`)."""
    for j in range(slots.shape[0]):
        if slots[j, SL_OWNER] < 0:
            return False
    return _victim(records, slots, r) < 0


@compiled(nogil=True)
def _contact_samples(out, t0, n, ring, voice_form, counters, events):
    """Add the in-contact samples in ``[t0, t0 + n)`` of pending impacts at their voice's
    gain; drop those of stopped voices, refuse an outranked voice before it sounds."""
    state, first, length, response, voice = ring[0], ring[2], ring[3], ring[5], ring[7]
    records, vgain, end = voice_form[0], voice_form[1], t0 + n
    for i in range(state.shape[0]):
        if state[i] != READY:
            continue
        fence()  # the slot's data after its state word
        r = voice[i]
        if _drop_stopped(state, i, records, r, counters, events):
            continue
        g, lo, hi = vgain[r], max(first[i], t0), min(first[i] + length[i], end)
        if lo < hi and records[r, V_SLOT] < 0 and _outranked(records, voice_form[2], r):
            _refuse(state, i, records, r, counters, events)  # before it sounds at all
            continue
        for s in range(lo, hi):
            out[s - t0] += g * response[i, s - first[i]]


@compiled(nogil=True)
def _earliest(state, inject, form, end):
    """The slot in ``form`` (READY or PULSE) with the earliest injection before ``end``, or -1."""
    best, when = -1, end
    for i in range(state.shape[0]):
        if state[i] == form:
            fence()  # the slot's data after its state word
            if inject[i] < when:
                when, best = inject[i], i
    return best


@compiled(nogil=True)
def transform_pulses(body, limit):
    """Turn at most ``limit`` PULSE slots (-1: all) of ``body`` (a
    :class:`~synth.live.state.BodyForm`), earliest first, into READY ones as
    :func:`synth.sound.modal_bank.impact_excitation` would (plate amplitudes; response and
    peak heard now). Returns the number transformed."""
    ring, heard, transformed = body.ring, body.bank[3], body.transformed
    state, length, amplitudes, response, reference = ring[0], ring[3], ring[4], ring[5], ring[6]
    pr, pi, ur, ui, sigma_max, period, work, heard_coef, heard_amps = body.transform
    coefficients, samples, points, pulse = body.pulse_form
    inject = ring[1]
    count = 0
    while limit < 0 or count < limit:
        i = _earliest(state, inject, np.int64(PULSE), np.int64(NEVER))
        if i < 0:
            break
        n, M, p, amps = points[i], length[i], pulse[i], amplitudes[i]
        resp = response[i, :M]
        forces, slopes = samples[i, 0], samples[i, 1]
        cr, ci = coefficients[i, 0], coefficients[i, 1]
        for k in range(cr.shape[0]):
            gr, gi = heard[H1R, k], heard[H1I, k]
            heard_coef[0, k] = gr * cr[k] - gi * ci[k]
            heard_coef[1, k] = gr * ci[k] + gi * cr[k]
        transform_pulse(
            pr, pi, cr, ci, ur, ui, sigma_max, period,
            p[STEP], forces[:n], slopes[:n], p[OFFSET], forces[n : n + M], slopes[n : n + M],
            p[WEIGHT], p[CONTACT_TIME], p[ORDER], amps, resp, work,
        )  # fmt: skip
        magnitude = transform_pulse(
            pr, pi, heard_coef[0], heard_coef[1], ur, ui, sigma_max, period,
            p[STEP], forces[:n], slopes[:n], p[OFFSET], forces[n : n + M], slopes[n : n + M],
            p[WEIGHT], p[CONTACT_TIME], p[ORDER], heard_amps, resp, work,
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


@compiled(nogil=True)
def _revive(t0, bank, modal, slots):
    """After a move: a parked mode heard louder, above its share, rings again from ``t0``."""
    poles, fs, heard = bank[1], bank[2], bank[3]
    zr, zi, active, debt, thr2 = modal[0], modal[1], modal[2], modal[3], modal[6]
    park_r, park_i, park_at = modal[8], modal[9], modal[10]
    for k in range(zr.shape[1]):
        before = heard[H0R, k] * heard[H0R, k] + heard[H0I, k] * heard[H0I, k]
        after = heard[H1R, k] * heard[H1R, k] + heard[H1I, k] * heard[H1I, k]
        if after <= before:
            continue
        for s in range(slots.shape[0]):
            pr, pi = park_r[s, k], park_i[s, k]
            if (pr == 0.0 and pi == 0.0) or slots[s, SL_OWNER] < 0:
                continue
            # heard now at most |G1| |park| (it decays): below its share it stays parked
            m2 = (pr * pr + pi * pi) * after
            if m2 <= thr2[s, k]:
                continue
            decay = math.exp(poles[k].real * ((t0 - park_at[s, k]) / fs))
            if m2 * decay * decay <= thr2[s, k]:
                continue
            e = np.exp(poles[k] * ((t0 - park_at[s, k]) / fs))
            zr[s, k] += pr * e.real - pi * e.imag
            zi[s, k] += pr * e.imag + pi * e.real
            park_r[s, k] = park_i[s, k] = debt[s, k] = 0.0
            active[s, k] = True


@compiled(nogil=True, inline="always")
def _copy_gains(heard, to, source):
    """Copy the complex gains of rows ``source`` (re, im) to rows ``to`` of ``heard``."""
    for k in range(heard.shape[1]):
        heard[to, k] = heard[source, k]
        heard[to + 1, k] = heard[source + 1, k]


@compiled(nogil=True)
def _take_gains(t0, bank, modal, slots, asleep):
    """At a block's start the last target gains become the start; gains handed over (whole,
    under the producer's sequence number) the target (at once for a body ``asleep``)."""
    heard, seq = bank[3], bank[4]
    _copy_gains(heard, H0R, H1R)
    put = seq[SEQ_PUT]
    if put == seq[SEQ_TAKEN] or put % 2 == 1:
        return
    fence()  # the gains after their sequence number
    _copy_gains(heard, H1R, HPR)
    fence()
    if seq[SEQ_PUT] != put:  # rewritten meanwhile: keep the old target, retry next block
        _copy_gains(heard, H1R, H0R)
        return
    seq[SEQ_TAKEN] = put
    if asleep:
        _copy_gains(heard, H0R, H1R)
    else:
        _revive(t0, bank, modal, slots)


@compiled(nogil=True)
def _ring_slot(vs, offset, a, b, s, bank, modal, t0, n):
    """Ring slot ``s`` from sample ``a`` to ``b`` into ``vs[a - offset :]`` (cleared first)."""
    table, poles, fs, heard = bank[0], bank[1], bank[2], bank[3]
    zr, zi, active, debt, debt_at, thresholds, thr2 = modal[:7]
    park_r, park_i, park_at = modal[8], modal[9], modal[10]
    for j in range(a - offset, b - offset):
        vs[j] = 0.0
    ring_heard(
        vs, offset, a, b, table, zr[s], zi[s], active[s], debt[s], debt_at[s], thresholds[s],
        thr2[s], poles, fs, park_r[s], park_i[s], park_at[s], heard, t0, n,
    )  # fmt: skip


@compiled(nogil=True, inline="always")
def _fade(x, at, frames):
    """A raised-cosine fade from 1 at sample ``at`` to 0 at ``at + frames`` (no click)."""
    p = x - at
    if p <= 0:
        return 1.0
    if p >= frames:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.pi * p / frames))


@compiled(nogil=True)
def _add_slot(out, t0, n, vs, offset, a, b, slot, gains, tail):
    """Add a slot's samples ``a .. b - 1`` into ``out`` (from ``t0``; later ones into the ring
    buffer ``tail``) at its ramped gain and fades."""
    g0, g1 = gains[G_NOW], gains[G_NEXT]
    fade_at, steal_at, steal_frames = slot[SL_FADE_AT], slot[SL_POS], slot[SL_STEAL]
    plain = g0 == g1 and fade_at < 0 and steal_frames == 0
    L = tail.shape[0]
    for x in range(a, b):
        v = vs[x - offset]
        if plain:
            v *= g1
        else:
            u = min(1.0, (x - t0 + 1) / n)
            v *= g0 + (g1 - g0) * u
            if fade_at >= 0:
                v *= _fade(x, fade_at, slot[SL_FADE_LEN])
            if steal_frames > 0:
                v *= _fade(x, steal_at, steal_frames)
        if x < t0 + n:
            out[x - t0] += v
        else:
            tail[x % L] += v


@compiled(nogil=True)
def _advance(out, t0, n, vs, s, b, bank, modal, voice_form):
    """Ring voice slot ``s`` from where it stands to sample ``b`` into ``out``."""
    slots, slot_gain, tail = voice_form[2], voice_form[3], voice_form[4]
    a = slots[s, SL_POS]
    if b > a:
        _ring_slot(vs, t0, a, b, s, bank, modal, t0, n)
        _add_slot(out, t0, n, vs, t0, a, b, slots[s], slot_gain[s], tail)
        slots[s, SL_POS] = b


@compiled(nogil=True, inline="always")
def _victim(records, slots, r):
    """The slot a new voice ``r`` may steal: lowest priority, then oldest, then lowest id; -1
    if that outranks ``r``. The oldest, not the quietest: age is the same at every ear."""
    s = numba.int64(0)  # not a literal: its callees are compiled for int64 once
    for j in range(1, slots.shape[0]):
        qj, qs = slots[j, SL_OWNER], slots[s, SL_OWNER]
        if (records[qj, V_PRIORITY], slots[j, SL_START], records[qj, V_ID]) < (
            records[qs, V_PRIORITY],
            slots[s, SL_START],
            records[qs, V_ID],
        ):
            s = j
    if records[slots[s, SL_OWNER], V_PRIORITY] > records[r, V_PRIORITY]:
        return -1
    return s


@compiled(nogil=True, inline="always")
def _steal(out, t0, n, vs, s, at, bank, modal, voice_form, counters, events):
    """Free slot ``s`` at sample ``at``: its voice ends through a ``STEAL_FRAMES`` fade."""
    records, slots, tail = voice_form[0], voice_form[2], voice_form[4]
    _advance(out, t0, n, vs, s, at, bank, modal, voice_form)
    F = counters[STEAL_FRAMES]
    _ring_slot(vs, at, at, at + F, s, bank, modal, t0, n)
    slots[s, SL_STEAL] = F  # from SL_POS = at
    _add_slot(out, t0, n, vs, at, at, at + F, slots[s], voice_form[3][s], tail)
    counters[TAIL_END] = max(counters[TAIL_END], at + F)
    q = slots[s, SL_OWNER]
    records[q, V_DEAD], records[q, V_SLOT], slots[s, SL_OWNER] = 1, -1, -1
    counters[STOLEN] += 1
    _settle(records, q, events, counters[EARS])


@compiled(nogil=True, inline="always")
def _take_slot(out, t0, n, vs, r, at, bank, modal, voice_form, counters, events):
    """A silent slot for voice ``r`` at sample ``at``: free, else stolen; -1 if outranked."""
    records, vgain, slots, slot_gain = voice_form[:4]
    s = -1
    for j in range(slots.shape[0]):
        if slots[j, SL_OWNER] < 0:
            s = j
            break
    if s < 0:
        s = _victim(records, slots, r)
        if s < 0:
            return -1
        _steal(out, t0, n, vs, s, at, bank, modal, voice_form, counters, events)
    zr, zi, active, debt, debt_at, thresholds, thr2, level, park_r, park_i = modal[:10]
    for a in (zr, zi, debt, thresholds, thr2, park_r, park_i):
        a[s, :] = 0.0
    active[s, :] = False
    level[s] = 0.0
    slots[s, SL_OWNER], slots[s, SL_START], slots[s, SL_POS] = r, at, at
    slots[s, SL_FADE_AT], slots[s, SL_FADE_LEN], slots[s, SL_STEAL] = -1, 0, 0
    slot_gain[s, G_NOW] = slot_gain[s, G_NEXT] = vgain[r]
    records[r, V_SLOT] = s
    return s


@compiled(nogil=True, inline="always")
def _inject(s, i, at, ring, bank, modal, floor):
    """Add impact ``i``'s amplitudes to slot ``s`` at ``at``; the voice's peak heard level
    sets each mode's omission threshold ``floor * peak / K``, as the offline bank's."""
    amplitudes, reference = ring[4], ring[6]
    poles, fs, heard = bank[1], bank[2], bank[3]
    zr, zi, active, debt, debt_at, thresholds, thr2, level = modal[:8]
    K = zr.shape[1]
    if reference[i] > level[s]:
        level[s] = reference[i]
        share = floor * level[s] / max(K, 1)
        thresholds[s, :] = share
        thr2[s, :] = share * share
    inject_heard(
        zr[s], zi[s], active[s], debt[s], debt_at[s], thresholds[s], poles, fs, amplitudes[i],
        at, modal[8][s], modal[9][s], modal[10][s], heard,
    )  # fmt: skip


@compiled(nogil=True, inline="always")
def _begin_voices(t0, voice_form):
    """At a block's start each ringing slot takes its voice's gain target and stop fade."""
    records, vgain, slots, slot_gain = voice_form[:4]
    for s in range(slots.shape[0]):
        r = slots[s, SL_OWNER]
        if r < 0:
            continue
        slots[s, SL_POS] = t0
        slot_gain[s, G_NEXT] = vgain[r]
        stop = records[r, V_STOP]
        if stop >= 0 and slots[s, SL_FADE_AT] < 0:
            slots[s, SL_FADE_AT], slots[s, SL_FADE_LEN] = t0, max(stop, 1)


@compiled(nogil=True, inline="always")
def _end_voices(out, t0, n, vs, bank, modal, voice_form, counters, events):
    """Ring every slot to the block's end, free those silent or faded; returns those ringing."""
    records, slots, slot_gain = voice_form[0], voice_form[2], voice_form[3]
    active, end, ringing = modal[2], t0 + n, 0
    for s in range(slots.shape[0]):
        r = slots[s, SL_OWNER]
        if r < 0:
            continue
        _advance(out, t0, n, vs, s, end, bank, modal, voice_form)
        slot_gain[s, G_NOW] = slot_gain[s, G_NEXT]
        done = slots[s, SL_FADE_AT] >= 0 and end >= slots[s, SL_FADE_AT] + slots[s, SL_FADE_LEN]
        if not done:
            done = True
            for k in range(active.shape[1]):
                if active[s, k]:
                    done = False
                    break
        if done:
            slots[s, SL_OWNER] = records[r, V_SLOT] = -1
            _settle(records, r, events, counters[EARS])
        else:
            ringing += 1
    return ringing


@compiled(nogil=True, inline="always")
def _take_tail(out, t0, n, tail, counters):
    """Add the stolen voices' fades that fall in ``[t0, t0 + n)`` (and clear them)."""
    L = tail.shape[0]
    for x in range(t0, min(t0 + n, counters[TAIL_END])):
        out[x - t0] += tail[x % L]
        tail[x % L] = 0.0


@compiled(nogil=True)
def mix_body(out, vs, t0, n, body, events, limit):
    """Mix ``body`` (a :class:`~synth.live.state.BodyForm`) into ``out[0:n]`` (samples from
    ``t0``; ``vs``: a voice's scratch); ``limit``: most pulses transformed (-1: all)."""
    bank, modal, ring, voice_form = body.bank, body.modal, body.ring, body.voice_form
    counters, floor, state, inject = body.counters, body.floor, ring[0], ring[1]
    records = voice_form[0]
    _take_gains(t0, bank, modal, voice_form[2], counters[AWAKE] == 0)
    pulses = transform_pulses(body, limit)
    if pulses > counters[MOST_PULSES]:
        counters[MOST_PULSES] = pulses
    end = t0 + n
    due = _earliest(state, inject, np.int64(READY), np.int64(NEVER))
    if counters[AWAKE] == 0 and due < 0:
        return pulses
    counters[AWAKE] = 1
    if counters[TAIL_END] > t0:
        _take_tail(out, t0, n, voice_form[4], counters)
    if due >= 0:
        _contact_samples(out, t0, n, ring, voice_form, counters, events)
    _begin_voices(t0, voice_form)
    while True:
        i = _earliest(state, inject, np.int64(READY), end)
        if i < 0:
            break
        at = inject[i]
        if at < t0:
            counters[LATE] += 1
            at = t0
        r = ring[7][i]
        if _drop_stopped(state, i, records, r, counters, events):
            continue
        s = records[r, V_SLOT]
        if s < 0:
            s = _take_slot(out, t0, n, vs, r, at, bank, modal, voice_form, counters, events)
            if s < 0:  # every slot rings a voice of higher priority
                _refuse(state, i, records, r, counters, events)
                continue
        else:
            _advance(out, t0, n, vs, s, at, bank, modal, voice_form)
        _inject(s, i, at, ring, bank, modal, floor)
        fence()  # done reading the slot before a producer may take it
        state[i] = FREE
        records[r, V_PLAYED] += 1
        counters[PLAYED] += 1
    ringing = _end_voices(out, t0, n, vs, bank, modal, voice_form, counters, events)
    counters[BUSY_BLOCKS] += 1
    awake = 1 if ringing > 0 or counters[TAIL_END] > end else 0
    if awake == 0:
        for i in range(state.shape[0]):
            if state[i] == READY or state[i] == PULSE:
                awake = 1
                break
    counters[AWAKE] = awake
    return pulses


@compiled(nogil=True)
def silence(body, events):
    """Stop every voice and drop every pending impact of ``body`` (a dropped pulse counts as
    taken)."""
    ring, voice_form, counters = body.ring, body.voice_form, body.counters
    transformed, state, voice = body.transformed, ring[0], ring[7]
    records, slots, tail = voice_form[0], voice_form[2], voice_form[4]
    ears = counters[EARS]
    for s in range(slots.shape[0]):
        r = slots[s, SL_OWNER]
        if r >= 0:
            slots[s, SL_OWNER] = records[r, V_SLOT] = -1
            records[r, V_DEAD] = 1
    for i in range(state.shape[0]):
        if state[i] == PULSE or state[i] == READY:
            if state[i] == PULSE:
                transformed[0] += 1
            fence()
            r = voice[i]
            records[r, V_DEAD] = 1
            _drop(state, i, records, r, counters)
    for r in range(records.shape[0]):
        if records[r, V_STATE] == V_LIVE and records[r, V_DEAD] != 0:
            _settle(records, r, events, ears)
    for j in range(tail.shape[0]):
        tail[j] = 0.0
    counters[TAIL_END] = counters[AWAKE] = counters[SILENCE] = 0


def body_state(modes: int, voices: int) -> dict:
    """The silent modal states of ``voices`` slots of ``modes`` modes, by body-record name."""
    names = ("zr", "zi", "active", "debt", "debt_at", "thresholds", "thr2", "park_r", "park_i",
             "park_at")  # fmt: skip
    types = (float, float, np.bool_, float, np.int64, float, float, float, float, np.int64)
    arrays = {name: np.zeros((voices, modes), dtype) for name, dtype in zip(names, types)}
    return arrays | {"level": np.zeros(voices)}
