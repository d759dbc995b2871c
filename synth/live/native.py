"""The audio thread without Python: PortAudio calls compiled code directly.

The engine's whole state lives in preallocated numpy arrays that the audio thread reaches
through their addresses, so that its callback touches no Python object:

* ``ctl`` (int64, :data:`N_CTL`): the engine's integers (the clock, the stop fade, the
  number of bodies, the callback's counters) and the addresses of the other arrays;
* ``times`` (float64, :data:`N_TIMES`): the clock's anchor (which frame leaves the device
  when, for :meth:`synth.live.Engine.hit` on other threads), the callback's costs, the
  master bus' gain, pause level and meter;
* a directory of body records (int64, one address per body; a record holds the addresses
  and sizes of the body's voice slots' modal states, pending ring, voice records and
  counters, see :data:`BODY_FIELDS`; :func:`_body_form` makes the views the kernel takes);
* the voice-ended event ring (int64) that :meth:`synth.live.Engine.ended` reads.

:func:`stream_callback` gives a numba ``cfunc`` with PortAudio's ``PaStreamCallback``
signature; the engine hands its address to sounddevice's stream base class with ``ctl``'s
address as ``userData`` (as python-rtmixer does with its C callback). PortAudio's thread
then runs it without Python's GIL: a busy Python thread cannot delay it. It allocates
nothing (every array is a view made from an address), takes no lock, and reads the time
with ``clock_gettime`` (the clock of ``time.clock_gettime_ns(time.CLOCK_MONOTONIC)``, with
which the trigger threads compare). The Python fallback callback (:func:`run_block`) and
:meth:`synth.live.Engine.process` (:func:`mix_engine`) call the very same compiled code.

numba caches these functions keyed on this file alone (its time stamp and size): after a
change to a kernel they call (:mod:`synth.live.kernel`, the bank's kernels) and nothing here,
delete their cache (``synth/live/__pycache__/native.*``) so that they are compiled anew.

Ordering between threads: a producer writes a slot's data, then its state word (see
:mod:`synth.live.queue`); a body's record is complete before ``ctl[N_BODIES]`` counts it;
the callback brackets its anchor writes with a sequence number and full fences
(:func:`synth.live.atomics.fence`), so a reader sees a consistent anchor or retries.
"""

from __future__ import annotations

import functools
import math
import mmap
import time

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from synth.compilation import FASTMATH, cfunc_compiling, compiled
from synth.live import kernel, limiter
from synth.live.atomics import fence as _fence

#: ``ctl`` fields (int64).
(
    FRAME,  # next frame to mix, on the engine's clock
    FADE_AT,  # position in the stop fade, -1 without one
    FADE_LENGTH,  # frames
    FADE_FRAME,  # frame where the last stop fade began, -1 before
    N_BODIES,  # bodies the callback mixes (published after their record)
    MAX_BODIES,  # the directory's length
    CHANNELS,
    MIX_CAP,  # frames of the mixing scratch buffers
    CALLBACKS,  # blocks mixed by a stream's callback
    UNDERFLOWS,  # callbacks PortAudio flagged output underflow
    OVERFLOWS,  # callbacks flagged output overflow (PortAudio's paOutputOverflow)
    CLIPPED,  # output samples that reached full scale (before the clipper)
    SEQ,  # the anchor's sequence number: odd while the callback writes it
    RECORD_FRAMES,  # frames of the recording buffer
    RECORDED,  # frames recorded so far
    TIMES,  # address of ``times``
    DIRECTORY,  # address of the body directory
    MIX,  # address of the master mix (float64, CHANNELS + 1 rows of MIX_CAP: every channel's
    # bus, then each channel's own)
    SCRATCH,  # address of one body's mix and one voice's (float64, 2 x MIX_CAP)
    RECORD,  # address of the recording (float32, RECORD_FRAMES x CHANNELS)
    CLIP,  # 1: soft-clip the master bus (see :func:`soft_clip`), 0: pass it as is
    EVENTS,  # address of the voice-ended event ring (int64, see synth.live.kernel.E_WRITTEN)
    N_EVENTS,  # its length (header included)
    PAUSE,  # 1: pause asked (fade out, then hold the clock and write silence), 0: play
    LIMIT,  # 1: the master bus runs through the true-peak limiter (synth.live.limiter)
    LIM_INTS,  # addresses of the limiter's arrays (see synth.live.limiter.LimiterState)
    LIM_FLOATS,
    LIM_TAPS,
    LIM_X,
    LIM_R,
    LIM_M,
    TRANSFORMS_MAX,  # the most pulses one callback transformed (over every body)
    TRANSFORM_BUDGET,  # the most pulses a stream's callback transforms, over every body
    TRANSFORMS_DEFERRED,  # pulses a callback left waiting for a later one (each time left)
    SHARE_FROM,  # the body served first by the next callback's share of the budget
    ALLOW,  # address of each body's share of a callback's budget (int64, MAX_BODIES)
    N_CTL,
) = range(37)

#: ``times`` fields (float64).
(
    SAMPLERATE,  # Hz
    NOMINAL_LATENCY,  # the stream's output latency as PortAudio opened it, s
    LEAD,  # the last callback's outputBufferDacTime - currentTime, s
    ANCHOR_FRAME,  # the last callback's first frame
    ANCHOR_DAC,  # the monotonic time (s) at which that frame leaves the device
    END_TIME,  # monotonic time (s) at the end of the last callback
    END_FRAME,  # the frame after the last callback's block
    COST_SUM,  # sum over callbacks of (run time / block duration)
    COST_MAX,
    COST_LAST,
    MASTER_GAIN,  # the master bus' target gain (linear)
    MASTER_NOW,  # its value at the end of the last block (ramped towards the target)
    PEAK,  # largest |sample| of the master bus (before the clipper) since the last reset
    OUT_PEAK,  # largest |sample| sent to the device since the last reset
    LAST_ENTRY,  # monotonic time (s) of the last callback's entry, 0 before the first
    GAP_MAX,  # longest time between two callbacks' entries, in blocks
    PAUSE_LEVEL,  # 1 playing, 0 paused; ramped by 1 / FADE_LENGTH a sample between them
    LIMIT_DELAY,  # the limiter's look-ahead, s (0 without it): the bus leaves that much later
    N_TIMES,
) = range(19)

#: A body record (int64): addresses, then sizes.
BODY_FIELDS = (
    "table", "poles", "zr", "zi", "active", "debt", "debt_at", "thresholds", "thr2",
    "level", "state", "inject", "first", "length", "amplitudes", "response", "reference",
    "counters", "pole_re", "pole_im", "step_re", "step_im", "work", "coefficients",
    "samples", "points", "pulse", "transformed", "scalars",
    "voice", "voices", "voice_gain", "voice_slots", "slot_gain", "tail",
    "modes", "slots", "contact", "pulse_samples", "work_rows", "table_cols", "channel",
    "n_records", "n_voice_slots", "tail_frames",
    "park_r", "park_i", "park_at", "heard", "heard_seq", "heard_coef", "heard_amps",
)  # fmt: skip
(
    B_TABLE, B_POLES, B_ZR, B_ZI, B_ACTIVE, B_DEBT, B_DEBT_AT, B_THRESHOLDS, B_THR2,
    B_LEVEL, B_STATE, B_INJECT, B_FIRST, B_LENGTH, B_AMPLITUDES, B_RESPONSE, B_REFERENCE,
    B_COUNTERS, B_POLE_RE, B_POLE_IM, B_STEP_RE, B_STEP_IM, B_WORK, B_COEFFICIENTS,
    B_SAMPLES, B_POINTS, B_PULSE, B_TRANSFORMED, B_SCALARS,
    B_VOICE, B_VOICES, B_VOICE_GAIN, B_VOICE_SLOTS, B_SLOT_GAIN, B_TAIL,
    B_MODES, B_SLOTS, B_CONTACT, B_PULSE_SAMPLES, B_WORK_ROWS, B_TABLE_COLS, B_CHANNEL,
    B_RECORDS, B_VOICE_SLOT_COUNT, B_TAIL_FRAMES,
    B_PARK_R, B_PARK_I, B_PARK_AT, B_HEARD, B_HEARD_SEQ, B_HEARD_COEF, B_HEARD_AMPS,
) = range(len(BODY_FIELDS))  # fmt: skip
N_BODY = len(BODY_FIELDS)

#: A body's scalars (float64): sample rate (Hz), omission floor (fraction), the largest
#: decay rate (1/s), the sample period (s), its gain's target and its value now (linear),
#: its pan's target and its value now (in [-1, 1], NaN unpanned; see :func:`pan_gains`).
S_FS, S_FLOOR, S_SIGMA_MAX, S_PERIOD, S_GAIN, S_GAIN_NOW, S_PAN, S_PAN_NOW = range(8)
N_SCALARS = 8

#: PortAudio's stream callback flags (portaudio.h) and its paContinue.
PA_OUTPUT_UNDERFLOW = 0x4
PA_OUTPUT_OVERFLOW = 0x8
PA_CONTINUE = 0

#: The soft clipper's largest output: the largest float32 below full scale.
CEILING = float(np.nextafter(np.float32(1.0), np.float32(0.0)))

#: The clock the callback reads (and the trigger threads, in Python).
CLOCK = time.CLOCK_MONOTONIC if hasattr(time, "CLOCK_MONOTONIC") else -1


def native_available() -> bool:
    """Whether this platform has the POSIX clock the compiled callback reads."""
    return CLOCK >= 0


def monotonic() -> float:
    """The callback's clock, s (POSIX ``CLOCK_MONOTONIC``)."""
    return time.clock_gettime_ns(CLOCK) * 1e-9


@intrinsic
def _pointer(typingctx, address):
    """The int64 ``address`` as a ``void*`` (for ``numba.carray``)."""
    sig = types.voidptr(types.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return sig, codegen


@intrinsic
def _address(typingctx, pointer):
    """The ``void*`` ``pointer`` as an int64 (0: NULL)."""
    sig = types.int64(types.voidptr)

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], cgutils.ir.IntType(64))

    return sig, codegen


@intrinsic
def _monotonic_ns(typingctx):
    """``clock_gettime(CLOCK)`` in ns: the C library's call, no Python."""
    sig = types.int64()

    def codegen(context, builder, signature, args):
        i64 = cgutils.ir.IntType(64)
        i32 = cgutils.ir.IntType(32)
        spec = cgutils.ir.LiteralStructType([i64, i64])
        fnty = cgutils.ir.FunctionType(i32, [i32, spec.as_pointer()])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "clock_gettime")
        ts = cgutils.alloca_once(builder, spec)
        builder.call(fn, [i32(max(CLOCK, 0)), ts])
        sec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 0))
        nsec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 1))
        return builder.add(builder.mul(sec, i64(1_000_000_000)), nsec)

    return sig, codegen


@compiled(nogil=True, inline="always")
def _f64(address, n):
    return numba.carray(_pointer(address), n, np.float64)


@compiled(nogil=True, inline="always")
def _i64(address, n):
    return numba.carray(_pointer(address), n, np.int64)


@compiled(nogil=True)
def _body_form(record):
    """Views of a body's arrays from its ``record``, grouped as :func:`kernel.mix_body`
    takes them: the bank (power table, poles, sample rate, the listener's gains and their
    sequence numbers), the voice slots' modal states (with their parked modes), the
    pending ring, the PULSE form's transform and pulses, the voices."""
    K = record[B_MODES]
    R = record[B_SLOTS]
    C = record[B_CONTACT]
    P = record[B_PULSE_SAMPLES]
    V = record[B_VOICE_SLOT_COUNT]
    scalars = _f64(record[B_SCALARS], N_SCALARS)
    bank = (
        numba.carray(_pointer(record[B_TABLE]), (K, 2, record[B_TABLE_COLS]), np.float64),
        numba.carray(_pointer(record[B_POLES]), K, np.complex128),
        scalars[S_FS],
        numba.carray(_pointer(record[B_HEARD]), (kernel.N_HEARD_ROWS, K), np.float64),
        _i64(record[B_HEARD_SEQ], 2),
    )
    modal = (
        numba.carray(_pointer(record[B_ZR]), (V, K), np.float64),
        numba.carray(_pointer(record[B_ZI]), (V, K), np.float64),
        numba.carray(_pointer(record[B_ACTIVE]), (V, K), np.bool_),
        numba.carray(_pointer(record[B_DEBT]), (V, K), np.float64),
        numba.carray(_pointer(record[B_DEBT_AT]), (V, K), np.int64),
        numba.carray(_pointer(record[B_THRESHOLDS]), (V, K), np.float64),
        numba.carray(_pointer(record[B_THR2]), (V, K), np.float64),
        _f64(record[B_LEVEL], V),
        numba.carray(_pointer(record[B_PARK_R]), (V, K), np.float64),
        numba.carray(_pointer(record[B_PARK_I]), (V, K), np.float64),
        numba.carray(_pointer(record[B_PARK_AT]), (V, K), np.int64),
    )
    ring = (
        _i64(record[B_STATE], R),
        _i64(record[B_INJECT], R),
        _i64(record[B_FIRST], R),
        _i64(record[B_LENGTH], R),
        numba.carray(_pointer(record[B_AMPLITUDES]), (R, K), np.complex128),
        numba.carray(_pointer(record[B_RESPONSE]), (R, C), np.float64),
        _f64(record[B_REFERENCE], R),
        _i64(record[B_VOICE], R),
    )
    transform = (
        _f64(record[B_POLE_RE], K),
        _f64(record[B_POLE_IM], K),
        _f64(record[B_STEP_RE], K),
        _f64(record[B_STEP_IM], K),
        scalars[S_SIGMA_MAX],
        scalars[S_PERIOD],
        numba.carray(_pointer(record[B_WORK]), (record[B_WORK_ROWS], K), np.float64),
        numba.carray(_pointer(record[B_HEARD_COEF]), (2, K), np.float64),
        numba.carray(_pointer(record[B_HEARD_AMPS]), K, np.complex128),
    )
    pulse_form = (
        numba.carray(_pointer(record[B_COEFFICIENTS]), (R, 2, K), np.float64),
        numba.carray(_pointer(record[B_SAMPLES]), (R, 2, P), np.float64),
        _i64(record[B_POINTS], R),
        numba.carray(_pointer(record[B_PULSE]), (R, kernel.N_PULSE_FIELDS), np.float64),
    )
    N = record[B_RECORDS]
    voice_form = (
        numba.carray(_pointer(record[B_VOICES]), (N, kernel.N_VOICE_FIELDS), np.int64),
        _f64(record[B_VOICE_GAIN], N),
        numba.carray(_pointer(record[B_VOICE_SLOTS]), (V, kernel.N_SLOT_FIELDS), np.int64),
        numba.carray(_pointer(record[B_SLOT_GAIN]), (V, 2), np.float64),
        _f64(record[B_TAIL], record[B_TAIL_FRAMES]),
    )
    return bank, modal, ring, transform, pulse_form, voice_form


@compiled(nogil=True)
def _events(ctl):
    return _i64(ctl[EVENTS], ctl[N_EVENTS])


@compiled(nogil=True, inline="always")
def pan_gains(pan):
    """The constant-power pan law: the (left, right) gains of a mono body at ``pan`` in
    [-1, 1] (-1 left, 0 centre, +1 right), ``cos(theta)`` and ``sin(theta)`` with
    ``theta = (pan + 1) pi / 4``, so that left^2 + right^2 = 1 (the body's power is the
    same at every pan; the centre is -3.01 dB on each channel). Computed as
    ``sin((1 - pan) pi / 4)`` and ``sin((1 + pan) pi / 4)``, the same gains, exactly 1 and 0
    at the ends. NaN (unpanned): 1 on both, the body's mono signal at its full level."""
    if math.isnan(pan):
        return 1.0, 1.0
    return math.sin((1.0 - pan) * (0.25 * math.pi)), math.sin((1.0 + pan) * (0.25 * math.pi))


@compiled(nogil=True, inline="always")
def _add_ramped(row, out, g0, g1, n):
    """``row += g * out`` over ``n`` frames, ``g`` ramped linearly from ``g0`` (before the
    block) to ``g1`` (at its last sample)."""
    if g0 == g1:
        for s in range(n):
            row[s] += g1 * out[s]
    else:
        step = (g1 - g0) / n
        for s in range(n):
            row[s] += (g0 + step * (s + 1)) * out[s]


@compiled(nogil=True, inline="always")
def _mix_one_body(ctl, record, scratch, mix, t0, n, limit):
    """Mix the body of ``record`` over ``n`` frames from ``t0`` into ``mix`` (every
    channel's row, then each channel's own, see :func:`_write_block`) at its gain, into
    its channel's row (every channel's for a body of one listener), or for a panned body
    into the first two channels' rows at its gain times :func:`pan_gains`; each channel's
    gain is ramped linearly over the block from its value at the last block to its target.
    Applies a pending ``stop_all`` first. ``scratch``: the body's mix and a voice's;
    ``limit``: the most pulses it transforms (-1: all). Returns the pulses transformed."""
    counters = _i64(record[B_COUNTERS], kernel.N_COUNTERS)
    transformed = _i64(record[B_TRANSFORMED], 1)
    scalars = _f64(record[B_SCALARS], N_SCALARS)
    R = record[B_SLOTS]
    state = _i64(record[B_STATE], R)
    if counters[kernel.SILENCE] != 0:
        bank, modal, ring, transform, pulse_form, voice_form = _body_form(record)
        kernel.silence(modal, ring, transformed, voice_form, counters, _events(ctl))
    g0 = scalars[S_GAIN_NOW]
    g1 = scalars[S_GAIN]
    p0 = scalars[S_PAN_NOW]
    p1 = scalars[S_PAN]  # one word: a pan set on another thread is read whole
    busy = counters[kernel.BUSY_BLOCKS]
    if counters[kernel.AWAKE] == 0:
        # asleep: nothing to mix unless something was handed over
        waiting = False
        for i in range(R):
            if state[i] == kernel.READY or state[i] == kernel.PULSE:
                waiting = True
                break
        if not waiting:
            scalars[S_GAIN_NOW] = g1
            scalars[S_PAN_NOW] = p1
            return 0
    bank, modal, ring, transform, pulse_form, voice_form = _body_form(record)
    out = scratch[0]
    for s in range(n):
        out[s] = 0.0
    pulses = kernel.mix_body(
        out, scratch[1], t0, n, bank, modal, scalars[S_FLOOR], ring, counters, transform,
        pulse_form, transformed, voice_form, _events(ctl), limit,
    )  # fmt: skip
    if counters[kernel.BUSY_BLOCKS] != busy:
        if math.isnan(p0) and math.isnan(p1):
            _add_ramped(mix[record[B_CHANNEL] + 1], out, g0, g1, n)
        else:  # a mono body panned between the first two channels
            left0, right0 = pan_gains(p0)
            left1, right1 = pan_gains(p1)
            _add_ramped(mix[1], out, g0 * left0, g1 * left1, n)
            _add_ramped(mix[2], out, g0 * right0, g1 * right1, n)
    scalars[S_GAIN_NOW] = g1
    scalars[S_PAN_NOW] = p1
    return pulses


@compiled(nogil=True)
def _share_budget(ctl, directory, bodies, allow, budget):
    """Share a callback's ``budget`` of pulse transforms among the ``bodies`` first bodies
    of the ``directory``: ``allow[b]``, at most the pulses body ``b`` has waiting, given in
    turn from the body ``SHARE_FROM`` names, the first body left short serves first at
    the next callback (so under a sustained surplus every body's pulses are taken in turn
    and none waits for ever). The pulses left waiting are counted in
    ``TRANSFORMS_DEFERRED``; a pulse handed over after this count waits for the next
    callback."""
    start = ctl[SHARE_FROM]
    if start >= bodies:
        start = 0
    left = budget
    short = -1
    deferred = 0
    for k in range(bodies):
        b = start + k
        if b >= bodies:
            b -= bodies
        record = _i64(directory[b], N_BODY)
        state = _i64(record[B_STATE], record[B_SLOTS])
        waiting = 0
        for i in range(state.shape[0]):
            if state[i] == kernel.PULSE:
                waiting += 1
        give = min(waiting, left)
        allow[b] = give
        left -= give
        if give < waiting:
            deferred += waiting - give
            if short < 0:
                short = b
    ctl[TRANSFORMS_DEFERRED] += deferred
    ctl[SHARE_FROM] = short if short >= 0 else start


@compiled(nogil=True, inline="always")
def soft_clip(v):
    """The master bus' soft clipper: the identity up to ``KNEE`` of full scale, then a
    tanh knee that approaches full scale without reaching it (continuous with its first
    derivative), capped at ``CEILING`` (the largest float32 below 1, where the tanh rounds
    to 1 in float32), so no sample at or above 0 dBFS reaches the device."""
    a = abs(v)
    if a <= kernel.KNEE:
        return v
    room = 1.0 - kernel.KNEE
    y = min(kernel.KNEE + room * math.tanh((a - kernel.KNEE) / room), CEILING)
    return y if v > 0.0 else -y


@compiled(nogil=True)
def _limiter(ctl, channels):
    """The limiter's arrays (:meth:`synth.live.limiter.LimiterState.arrays`), made from
    their addresses in ``ctl``."""
    ints = _i64(ctl[LIM_INTS], limiter.N_INTS)
    D = ints[limiter.I_DELAY]
    A = ints[limiter.I_ATTACK]
    return (
        ints,
        _f64(ctl[LIM_FLOATS], limiter.N_FLOATS),
        numba.carray(_pointer(ctl[LIM_TAPS]), (limiter.OVERSAMPLING - 1, limiter.TAPS), np.float64),
        numba.carray(_pointer(ctl[LIM_X]), (D + 1, channels), np.float64),
        _f64(ctl[LIM_R], A + 2 * limiter.REACH + 1),
        _f64(ctl[LIM_M], A + 1),
    )


@compiled(nogil=True)
def _write_block(ctl, times, mix, out, row, n):
    """The master bus over ``n`` frames: the pause and stop fades, the master gain (ramped
    over the block), the meter, the optional true-peak limiter (:mod:`synth.live.limiter`)
    and the optional soft clipper; channel ``c`` of ``out[row:row + n]`` (float32) is
    ``mix[0] + mix[c + 1]`` (every channel's bus plus its own), cleared after; the
    recording."""
    channels = out.shape[1]
    pos = ctl[FADE_AT]
    length = ctl[FADE_LENGTH]
    level = times[PAUSE_LEVEL]
    target = 0.0 if ctl[PAUSE] != 0 else 1.0
    level_step = 1.0 / length
    if pos == 0:
        ctl[FADE_FRAME] = ctl[FRAME]
    g0 = times[MASTER_NOW]
    g1 = times[MASTER_GAIN]
    step = (g1 - g0) / n
    peak = times[PEAK]
    out_peak = times[OUT_PEAK]
    clipped = 0
    clip = ctl[CLIP] != 0
    for s in range(n):
        g = g0 + step * (s + 1)
        if level != target:
            level = min(level + level_step, 1.0) if target > level else max(level - level_step, 0.0)
        if level < 1.0:
            g *= 0.5 * (1.0 - math.cos(math.pi * level))
        if pos >= 0:
            if pos < length:
                g *= 0.5 * (1.0 + math.cos(math.pi * pos / length))
            else:
                g = 0.0
            pos += 1
        common = mix[0, s]
        mix[0, s] = 0.0
        for c in range(channels):
            v = (common + mix[c + 1, s]) * g
            mix[c + 1, s] = v
            a = abs(v)
            if a > peak:
                peak = a
    if ctl[LIMIT] != 0:
        limiter.limit_block(_limiter(ctl, channels), mix[1:], n)
    for s in range(n):
        for c in range(channels):
            v = mix[c + 1, s]
            mix[c + 1, s] = 0.0
            if abs(v) >= 1.0:
                clipped += 1
            if clip:
                v = soft_clip(v)
            w = np.float32(v)
            a = abs(w)
            if a > out_peak:
                out_peak = a
            out[row + s, c] = w
    ctl[FADE_AT] = pos
    times[PAUSE_LEVEL] = level
    times[MASTER_NOW] = g1
    times[PEAK] = peak
    times[OUT_PEAK] = out_peak
    ctl[CLIPPED] += clipped
    cap = ctl[RECORD_FRAMES]
    done = ctl[RECORDED]
    if done < cap:
        m = min(n, cap - done)
        rec = numba.carray(_pointer(ctl[RECORD]), (cap, channels), np.float32)
        for s in range(m):
            for c in range(channels):
                rec[done + s, c] = out[row + s, c]
        ctl[RECORDED] = done + m


@compiled(nogil=True, inline="always")
def _mix_engine(ctl, out, budget):
    """Mix the next ``out.shape[0]`` frames of every body into ``out`` (frames, channels)
    float32, in pieces of at most ``MIX_CAP`` frames, transforming at most ``budget``
    pulses over every body (-1: all; see :func:`_share_budget`). Paused (its fade done),
    it writes silence and holds the clock and every voice."""
    frames = out.shape[0]
    cap = ctl[MIX_CAP]
    times = _f64(ctl[TIMES], N_TIMES)
    mix = numba.carray(_pointer(ctl[MIX]), (ctl[CHANNELS] + 1, cap), np.float64)
    scratch = numba.carray(_pointer(ctl[SCRATCH]), (2, cap), np.float64)
    directory = _i64(ctl[DIRECTORY], ctl[MAX_BODIES])
    allow = _i64(ctl[ALLOW], ctl[MAX_BODIES])
    shared = -1  # the bodies counted when the budget was shared (once a call)
    # typed int64 from the start: a literal 0 would have numba type _write_block twice
    done = np.int64(0)
    while done < frames:
        if ctl[PAUSE] != 0 and times[PAUSE_LEVEL] <= 0.0:
            for s in range(done, frames):
                for c in range(out.shape[1]):
                    out[s, c] = 0.0
            return
        n = min(cap, frames - done)
        t0 = ctl[FRAME]
        bodies = ctl[N_BODIES]
        _fence()  # the records of the bodies counted are complete
        if budget >= 0 and shared < 0:  # once a call: the budget is the callback's
            _share_budget(ctl, directory, bodies, allow, budget)
            shared = bodies
        for b in range(bodies):
            record = _i64(directory[b], N_BODY)
            limit = -1
            if budget >= 0:  # a body added after the share waits for the next call
                limit = allow[b] if b < shared else 0
            pulses = _mix_one_body(ctl, record, scratch, mix, t0, n, limit)
            if budget >= 0:
                allow[b] = limit - pulses
        _write_block(ctl, times, mix, out, done, n)
        ctl[FRAME] = t0 + n
        done += n


@compiled(nogil=True)
def _transformed(ctl):
    """The pulses every body in the directory has transformed so far (a removed body's
    vacant record counts none)."""
    directory = _i64(ctl[DIRECTORY], ctl[MAX_BODIES])
    total = 0
    for b in range(ctl[N_BODIES]):
        record = _i64(directory[b], N_BODY)
        total += _i64(record[B_TRANSFORMED], 1)[0]
    return total


@compiled(nogil=True, inline="always")
def _run_block(ctl, out, flags, current, dac, entry_ns, device):
    """One block: :func:`_mix_engine`, and for a ``device`` block (a stream's callback) the
    accounting around it: count PortAudio's status ``flags``, note the time since the
    last callback's entry (a gap of more than a block means the system ran the audio
    thread late, whatever the callback's own cost), anchor the clock (the block's first
    frame leaves the device ``dac - current`` s after ``entry_ns``, the callback's entry on
    the monotonic clock, plus the limiter's look-ahead, by which it delays the bus), and
    account the callback's run time from its entry as a fraction of the block. One call
    of :func:`_mix_engine` for both, so that its code is compiled once."""
    times = _f64(ctl[TIMES], N_TIMES)
    frames = out.shape[0]
    if device:
        if flags & PA_OUTPUT_UNDERFLOW:
            ctl[UNDERFLOWS] += 1
        if flags & PA_OUTPUT_OVERFLOW:
            ctl[OVERFLOWS] += 1
        if dac > 0.0 and current > 0.0 and dac >= current:
            lead = dac - current
        else:
            lead = times[NOMINAL_LATENCY]
        times[LEAD] = lead
        now = entry_ns * 1e-9
        if times[LAST_ENTRY] > 0.0:
            gap = (now - times[LAST_ENTRY]) * times[SAMPLERATE] / max(frames, 1)
            if gap > times[GAP_MAX]:
                times[GAP_MAX] = gap
        times[LAST_ENTRY] = now
        ctl[SEQ] += 1
        _fence()
        times[ANCHOR_FRAME] = ctl[FRAME]
        times[ANCHOR_DAC] = entry_ns * 1e-9 + lead + times[LIMIT_DELAY]
        _fence()
        ctl[SEQ] += 1
    budget = ctl[TRANSFORM_BUDGET] if device else np.int64(-1)
    before = _transformed(ctl)
    _mix_engine(ctl, out, budget)
    if device:
        transforms = _transformed(ctl) - before
        if transforms > ctl[TRANSFORMS_MAX]:
            ctl[TRANSFORMS_MAX] = transforms
        end = _monotonic_ns()
        times[END_TIME] = end * 1e-9
        times[END_FRAME] = ctl[FRAME]
        cost = (end - entry_ns) * 1e-9 * times[SAMPLERATE] / max(frames, 1)
        times[COST_LAST] = cost
        times[COST_SUM] += cost
        if cost > times[COST_MAX]:
            times[COST_MAX] = cost
        ctl[CALLBACKS] += 1


CALLBACK_SIGNATURE = types.intc(
    types.voidptr, types.voidptr, types.uint64, types.voidptr, types.uint64, types.voidptr
)


def _callback(input, output, frames, time_info, flags, userdata):
    """PortAudio's ``PaStreamCallback``: ``int (const void *input, void *output,
    unsigned long frameCount, const PaStreamCallbackTimeInfo *timeInfo,
    PaStreamCallbackFlags statusFlags, void *userData)``, with ``userData`` the address of
    the engine's ``ctl``; float32 interleaved output. Returns paContinue. A NULL
    ``timeInfo`` (never from PortAudio) mixes without the device's accounting: the block of
    :func:`mix_engine`."""
    entry = _monotonic_ns()
    ctl = numba.carray(userdata, N_CTL, np.int64)
    out = numba.carray(output, (np.int64(frames), ctl[CHANNELS]), np.float32)
    device = _address(time_info) != 0
    current = 0.0
    dac = 0.0
    if device:
        info = numba.carray(time_info, 3, np.float64)  # adc time, current time, dac time
        current = info[1]
        dac = info[2]
    _run_block(ctl, out, np.int64(flags), current, dac, entry, device)
    return PA_CONTINUE


@functools.cache
def stream_callback():
    """The compiled :func:`_callback` (a numba ``CFunc``: ``.address`` for PortAudio).
    numba compiles a ``cfunc`` where it is made, not on its first call, and compiling this
    one compiles the whole block: made on first use, after the engine's note that it
    compiles (:func:`synth.compilation.announce`), not when this module is imported.

    It is the only compiled entry to the block: the mixing levels it calls are inlined
    into it (``inline="always"``), and Python calls it too (:func:`mix_engine`,
    :func:`run_block`), so that the block's tree of kernels is compiled into one library.
    A kernel compiled on its own and called from another is linked into the caller's
    code and optimised and compiled to machine code again with it (numba's
    ``CodeLibrary.finalize``): each compiled entry to the block would compile its whole
    tree once more."""
    with cfunc_compiling(_callback, CALLBACK_SIGNATURE):
        return numba.cfunc(CALLBACK_SIGNATURE, nopython=True, cache=True, fastmath=FASTMATH)(
            _callback
        )


def _check_block(ctl: np.ndarray, out: np.ndarray) -> None:
    """``out`` must be what the compiled block writes: float32, C-contiguous, writeable,
    (frames, the engine's channels)."""
    if (
        out.dtype != np.float32
        or out.ndim != 2
        or out.shape[1] != ctl[CHANNELS]
        or not out.flags.c_contiguous
        or not out.flags.writeable
    ):
        raise ValueError(
            f"out {out.dtype} {out.shape} must be writeable C-contiguous float32 "
            f"(frames, {int(ctl[CHANNELS])})"
        )


def mix_engine(ctl: np.ndarray, out: np.ndarray) -> None:
    """Mix the next ``out.shape[0]`` frames of every body into ``out`` (frames, channels)
    float32, in pieces of at most ``MIX_CAP`` frames, with the stream's compiled callback
    (:func:`stream_callback`, without its device accounting): the one mixing code of the
    stream, of the fallback Python callback and of :meth:`synth.live.Engine.process`.
    Paused (its fade done), it writes silence and holds the clock and every voice."""
    _check_block(ctl, out)
    stream_callback().ctypes(None, out.ctypes.data, out.shape[0], None, 0, ctl.ctypes.data)


def run_block(ctl: np.ndarray, out: np.ndarray, flags: int, time_info: np.ndarray) -> None:
    """One callback's work (the stream's compiled callback, called from Python: the
    fallback callback): PortAudio's status ``flags`` and ``time_info`` (float64: the
    stream's adc, current and dac times, s) accounted, then the block mixed into ``out``
    as by :func:`mix_engine`."""
    _check_block(ctl, out)
    if time_info.dtype != np.float64 or time_info.shape != (3,):
        raise ValueError(f"time_info {time_info.dtype} {time_info.shape} must be float64 (3,)")
    stream_callback().ctypes(
        None, out.ctypes.data, out.shape[0], time_info.ctypes.data, flags, ctl.ctypes.data
    )


@compiled(nogil=True)
def transform_pending(record):
    """Turn a body's waiting pulses into mode amplitudes now, on the calling thread (before
    a stream starts: hits queued without a stream are not bounded per block)."""
    bank, modal, ring, transform, pulse_form, voice_form = _body_form(record)
    transformed = _i64(record[B_TRANSFORMED], 1)
    # the in-contact response and peak heard with the gains the mixing holds now; every
    # pulse (limit -1) as an int64, the type mix_body passes: a literal -1 would have numba
    # compile _transform_pulses a second time
    kernel._transform_pulses(ring, transform, pulse_form, transformed, bank[3], np.int64(-1))


@compiled(nogil=True)
def silence_body(ctl, record):
    """Stop every voice of a body and drop its pending impacts now, on the calling thread
    (no stream runs; see :func:`synth.live.kernel.silence`)."""
    bank, modal, ring, transform, pulse_form, voice_form = _body_form(record)
    counters = _i64(record[B_COUNTERS], kernel.N_COUNTERS)
    transformed = _i64(record[B_TRANSFORMED], 1)
    kernel.silence(modal, ring, transformed, voice_form, counters, _events(ctl))


def touch(a: np.ndarray) -> np.ndarray:
    """Map every page of the C-contiguous array ``a`` into memory now, on the calling
    thread, so that the audio thread never takes a page fault on it: a fresh allocation's
    pages (numpy's zeros are calloc's) are only mapped at their first access, a zero page
    only copied at its first write. One byte of each page (and the last byte) is written
    with its own value; a read-only array is read instead. Returns ``a``."""
    b = a.reshape(-1).view(np.uint8)
    if b.size == 0:
        return a
    if a.flags.writeable:
        b[:: mmap.PAGESIZE] = b[:: mmap.PAGESIZE].copy()
        b[-1] = b[-1]
    else:
        _read = int(b[:: mmap.PAGESIZE].sum()) + int(b[-1])  # noqa: F841 (the reads touch)
    return a


class EngineState:
    """The arrays the audio thread works on (see the module's docstring), allocated once:
    ``samplerate`` Hz, ``channels``, room for ``max_bodies`` bodies, mixing scratch of
    ``mix_frames`` frames, a recording of ``record_frames`` frames, a ring of ``events``
    voice-ended events, the master bus' true-peak limiter's state (``limit``, or None
    without a limiter), and the most pulses a stream's callback transforms over every body
    (``transforms_per_block``; see :func:`_share_budget`)."""

    def __init__(
        self,
        *,
        samplerate: int,
        channels: int,
        max_bodies: int,
        mix_frames: int,
        record_frames: int,
        fade_frames: int,
        clip: bool,
        transforms_per_block: int,
        events: int = 4096,
        limit: limiter.LimiterState | None = None,
    ):
        self.ctl = np.zeros(N_CTL, dtype=np.int64)
        self.times = np.zeros(N_TIMES)
        self.directory = np.zeros(max_bodies, dtype=np.int64)
        self.allow = np.zeros(max_bodies, dtype=np.int64)
        self.mix = np.zeros((channels + 1, mix_frames))
        self.scratch = np.zeros((2, mix_frames))
        # the voice-ended events: the kernel's header, then a ring of ``events``
        self.events = np.zeros(kernel.N_EVENT_HEADER + events, dtype=np.int64)
        self.recording = np.zeros((record_frames, channels), dtype=np.float32)
        for a in (self.directory, self.allow, self.mix, self.scratch, self.events,
                  self.recording):  # fmt: skip
            touch(a)
        self.records: list = []  # the bodies' records and arrays, kept alive here
        c, t = self.ctl, self.times
        c[FADE_AT] = -1
        c[FADE_LENGTH] = fade_frames
        c[FADE_FRAME] = -1
        c[MAX_BODIES] = max_bodies
        c[CHANNELS] = channels
        c[MIX_CAP] = mix_frames
        c[RECORD_FRAMES] = record_frames
        c[TIMES] = t.ctypes.data
        c[DIRECTORY] = self.directory.ctypes.data
        c[ALLOW] = self.allow.ctypes.data
        c[TRANSFORM_BUDGET] = transforms_per_block
        c[MIX] = self.mix.ctypes.data
        c[SCRATCH] = self.scratch.ctypes.data
        c[RECORD] = self.recording.ctypes.data
        c[CLIP] = int(bool(clip))
        self.limiter = limit
        if limit is not None:
            c[LIMIT] = 1
            for field, a in zip(
                (LIM_INTS, LIM_FLOATS, LIM_TAPS, LIM_X, LIM_R, LIM_M), limit.arrays()
            ):
                c[field] = a.ctypes.data
            t[LIMIT_DELAY] = limit.delay / samplerate
        c[EVENTS] = self.events.ctypes.data
        c[N_EVENTS] = self.events.shape[0]
        t[SAMPLERATE] = samplerate
        t[MASTER_GAIN] = t[MASTER_NOW] = 1.0
        t[PAUSE_LEVEL] = 1.0
        # the record a removed body's directory entry points to: a body with no voice
        # slot and no pending slot, asleep for good (the callback returns at once)
        self._vacant_arrays = dict(
            counters=np.zeros(kernel.N_COUNTERS, dtype=np.int64),
            transformed=np.zeros(1, dtype=np.int64),
            scalars=np.zeros(N_SCALARS),
            state=np.zeros(1, dtype=np.int64),
        )
        self._vacant_arrays["scalars"][[S_PAN, S_PAN_NOW]] = math.nan
        self.vacant = np.zeros(N_BODY, dtype=np.int64)
        for name, a in self._vacant_arrays.items():
            self.vacant[BODY_FIELDS.index(name)] = a.ctypes.data
        self.vacant[B_CHANNEL] = -1

    @property
    def address(self) -> int:
        """The address of ``ctl``: the callback's ``userData``."""
        return self.ctl.ctypes.data

    def add_body(self, arrays: dict) -> np.ndarray:
        """Publish a body (its arrays by :data:`BODY_FIELDS` name, sizes as ints) to the
        audio thread: its record is written, then counted. Returns the record."""
        n = int(self.ctl[N_BODIES])
        free = [i for i, r in enumerate(self.records) if r is None]
        if not free and n >= self.directory.shape[0]:
            raise IndexError(n)
        record = np.zeros(N_BODY, dtype=np.int64)
        for i, name in enumerate(BODY_FIELDS):
            value = arrays[name]
            if isinstance(value, np.ndarray):
                if not value.flags.c_contiguous:
                    raise ValueError(f"{name} must be C-contiguous")
                touch(value)  # the audio thread takes no page fault on it
                record[i] = value.ctypes.data
            else:
                record[i] = int(value)
        if free:  # a removed body's entry: the callback mixes the body from the write on
            self.records[free[0]] = (record, arrays)
            self.directory[free[0]] = record.ctypes.data
            return record
        self.records.append((record, arrays))
        self.directory[n] = record.ctypes.data
        self.ctl[N_BODIES] = n + 1  # last: the callback mixes the body from now on
        return record

    def bodies_held(self) -> int:
        """Bodies in the directory (removed ones not counted)."""
        return sum(1 for r in self.records if r is not None)

    def vacate(self, index: int) -> tuple[int, int]:
        """Take body ``index`` out of the mixing: its directory entry points to the vacant
        record from now on (one atomic word). Returns the mixing's progress then (the next
        frame, the callbacks), for :meth:`left`."""
        progress = int(self.ctl[FRAME]), int(self.ctl[CALLBACKS])
        self.directory[index] = self.vacant.ctypes.data
        return progress

    def left(self, progress: tuple[int, int]) -> bool:
        """Whether every block that may have read a directory entry before :meth:`vacate`
        returned ``progress`` has ended (a piece mixed since, or a callback returned)."""
        return int(self.ctl[FRAME]) > progress[0] or int(self.ctl[CALLBACKS]) > progress[1]

    def release(self, index: int) -> None:
        """Let go of body ``index``'s arrays (vacated, and left by the mixing); its entry
        is taken again by the next :meth:`add_body`."""
        self.records[index] = None

    def anchor(self) -> tuple[int, float, float]:
        """The last callback's first frame, the monotonic time (s) at which it leaves the
        device and the callbacks so far (0: none yet): a consistent reading (the callback
        writes them between two increments of a sequence number)."""
        c, t = self.ctl, self.times
        while True:
            seq = int(c[SEQ])
            frame, dac = float(t[ANCHOR_FRAME]), float(t[ANCHOR_DAC])
            if seq % 2 == 0 and int(c[SEQ]) == seq:
                return frame, dac, seq // 2


def warm_up() -> None:
    """Compile (or load from numba's cache) everything the audio thread runs, on a one-mode
    body with one pulse handed over, so that no callback compiles."""
    from synth.live.queue import PendingRing
    from synth.sound.modal_bank import bank_coefficients, power_table

    fs = 48000
    poles = np.array([-10.0 + 1000.0j])
    ring = PendingRing(1, 1, 2, 7, 1, voices=2)
    voice = ring.open_voice(1, 1)
    slot = ring.reserve(pulse=True, voice=voice)
    ring.pulse[slot, kernel.GAIN] = 1.0
    ring.pulse[slot, kernel.STEP] = 1e-5
    ring.pulse[slot, kernel.CONTACT_TIME] = 4e-5
    ring.pulse[slot, kernel.ORDER] = 2.5
    ring.publish_pulse(slot, 1, 0, 0, 5)
    state = EngineState(
        samplerate=fs, channels=1, max_bodies=1, mix_frames=8, record_frames=4,
        fade_frames=4, clip=True, transforms_per_block=1,
    )  # fmt: skip
    c = bank_coefficients(poles, np.ones(1), np.ones(1), float(fs))
    table = power_table(poles, float(fs))
    arrays = body_arrays(
        c, table, kernel.body_state(1, 1), ring, 1e-4, 1.0, steal_frames=4, gains=np.ones(1)
    )
    record = state.add_body(arrays)
    transform_pending(record)
    out = np.zeros((8, 1), dtype=np.float32)
    run_block(state.ctl, out, 0, np.zeros(3))  # compiles the cfunc, or loads it
    mix_engine(state.ctl, out)


def body_arrays(
    coefficients,
    table,
    modal_state,
    ring,
    floor: float,
    gain: float,
    channel: int = -1,
    *,
    steal_frames: int,
    mix_frames: int = 4096,
    ears: int = 1,
    gains: np.ndarray,
    pan: float = math.nan,
) -> dict:
    """A body's arrays and sizes by :data:`BODY_FIELDS` name, for :meth:`EngineState.add_body`:
    its poles and one-sample steps (``coefficients``, a
    :class:`~synth.sound.modal_bank.BankCoefficients` at any point), power ``table``, its
    voice slots' modal states (:func:`synth.live.kernel.body_state`), pending ``ring`` with
    its voice records (:class:`synth.live.queue.PendingRing`), omission ``floor``, ``gain``,
    output ``channel`` (-1: every channel), the steal fade (``steal_frames`` samples, at
    most ``mix_frames``, the engine's mixing piece; the stolen voices' ring buffer holds
    both), the ``ears`` of the body it belongs to, and the listener's complex ``gains`` of
    its modes (K,; the mixing applies them at its output, the voices' states are the
    plate's) and its ``pan`` (NaN: unpanned; see :func:`pan_gains`)."""
    from synth.sound.modal_bank import transform_workspace

    c = coefficients
    fs = float(c.samplerate)
    K = c.poles.size
    zr, zi, active, debt, debt_at, thresholds, thr2, level, park_r, park_i, park_at = modal_state
    V = zr.shape[0]
    heard, heard_seq = kernel.heard_arrays(np.asarray(gains, dtype=complex))
    voice_slots = np.zeros((V, kernel.N_SLOT_FIELDS), dtype=np.int64)
    voice_slots[:, kernel.SL_OWNER] = -1
    counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
    counters[kernel.EARS] = ears
    counters[kernel.STEAL_FRAMES] = steal_frames
    tail = np.zeros(mix_frames + steal_frames)
    scalars = np.zeros(N_SCALARS)
    scalars[S_FS] = fs
    scalars[S_FLOOR] = floor
    scalars[S_SIGMA_MAX] = c.sigma_max
    scalars[S_PERIOD] = 1.0 / fs
    scalars[S_GAIN] = scalars[S_GAIN_NOW] = gain
    scalars[S_PAN] = scalars[S_PAN_NOW] = pan
    work = transform_workspace(K)
    return dict(
        table=np.ascontiguousarray(table),
        poles=np.ascontiguousarray(c.poles, dtype=np.complex128),
        zr=zr, zi=zi, active=active, debt=debt, debt_at=debt_at, thresholds=thresholds,
        thr2=thr2, level=level, state=ring.state, inject=ring.inject, first=ring.first,
        length=ring.length, amplitudes=ring.amplitudes, response=ring.response,
        reference=ring.reference, counters=counters,
        pole_re=np.ascontiguousarray(c.pole_re), pole_im=np.ascontiguousarray(c.pole_im),
        step_re=np.ascontiguousarray(c.step_re), step_im=np.ascontiguousarray(c.step_im),
        work=work, coefficients=ring.coefficients, samples=ring.samples, points=ring.points,
        pulse=ring.pulse, transformed=ring.transformed, scalars=scalars,
        modes=K, slots=ring.capacity, contact=ring.max_contact,
        pulse_samples=ring.pulse_samples, work_rows=work.shape[0], table_cols=table.shape[2],
        channel=channel, voice=ring.voice, voices=ring.voices, voice_gain=ring.voice_gain,
        voice_slots=voice_slots, slot_gain=np.ones((V, 2)), tail=tail,
        n_records=ring.voices.shape[0], n_voice_slots=V, tail_frames=tail.shape[0],
        park_r=park_r, park_i=park_i, park_at=park_at, heard=heard, heard_seq=heard_seq,
        heard_coef=np.zeros((2, K)), heard_amps=np.zeros(K, dtype=complex),
    )  # fmt: skip
