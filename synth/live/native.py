"""The audio thread without Python: PortAudio calls compiled code directly.

:func:`stream_callback` is a numba ``cfunc`` of PortAudio's ``PaStreamCallback`` signature
working on the engine's preallocated state (:mod:`synth.live.state`) through addresses
(``ctl``'s as ``userData``, as python-rtmixer does), so PortAudio's thread runs it without
the GIL, allocation or lock, reading ``clock_gettime(CLOCK_MONOTONIC)``. The Python
fallback (:func:`run_block`) and :meth:`synth.live.Engine.process` (:func:`mix_engine`)
call the same code; the rolling block (:func:`rolling_block_code`) is compiled apart and
called through ``ctl[ROLLER]``. numba keys this file's cache on the file alone: after
changing a kernel it calls, delete ``synth/live/__pycache__/native.*``. Ordering: a slot's
data before its state word, a body's record before ``ctl[N_BODIES]`` counts it, anchors
bracketed by a sequence number and fences (:func:`synth.live.atomics.fence`).
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from synth.compilation import FASTMATH, cfunc_compiling, compiled
from synth.live import kernel, limiter, rolling_block
from synth.live.atomics import fence as _fence
from synth.live.state import (
    ALLOW,
    ANCHOR_DAC,
    ANCHOR_FRAME,
    B_CHANNEL,
    B_COUNTERS,
    B_SCALARS,
    B_SLOTS,
    B_STATE,
    B_TRANSFORMED,
    CALLBACKS,
    CHANNELS,
    CLIP,
    CLIPPED,
    COST_LAST,
    COST_MAX,
    COST_SUM,
    DIRECTORY,
    END_FRAME,
    END_TIME,
    FADE_AT,
    FADE_FRAME,
    FADE_LENGTH,
    FRAME,
    GAP_MAX,
    LAST_ENTRY,
    LEAD,
    LIM_FLOATS,
    LIM_INTS,
    LIM_M,
    LIM_R,
    LIM_TAPS,
    LIM_X,
    LIMIT,
    LIMIT_DELAY,
    MASTER_GAIN,
    MASTER_NOW,
    MAX_BODIES,
    MIX,
    MIX_CAP,
    N_BODIES,
    N_BODY,
    N_CTL,
    N_SCALARS,
    N_TIMES,
    NOMINAL_LATENCY,
    OUT_PEAK,
    OVERFLOWS,
    PAUSE,
    PAUSE_LEVEL,
    PEAK,
    RECORD,
    RECORD_FRAMES,
    RECORDED,
    ROLLER,
    S_FLOOR,
    S_GAIN,
    S_GAIN_NOW,
    S_PAN,
    S_PAN_NOW,
    SAMPLERATE,
    SCRATCH,
    SEQ,
    SHARE_FROM,
    TIMES,
    TRANSFORM_BUDGET,
    TRANSFORMS_DEFERRED,
    TRANSFORMS_MAX,
    UNDERFLOWS,
    EngineState,
    address_of,
    body_arrays,
    body_form,
    event_ring,
    f64_at,
    i64_at,
    monotonic_ns,
    pointer_to,
    rolling_form,
)
from synth.live.state import monotonic as monotonic
from synth.live.state import native_available as native_available

#: PortAudio's stream callback flags (portaudio.h) and its paContinue.
PA_OUTPUT_UNDERFLOW = 0x4
PA_OUTPUT_OVERFLOW = 0x8
PA_CONTINUE = 0

#: The soft clipper's largest output: the largest float32 below full scale.
CEILING = float(np.nextafter(np.float32(1.0), np.float32(0.0)))


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


@intrinsic
def _call_roller(typingctx, address, ctl, record, out, n):
    """Call the rolling voices' block (:func:`_roll_body`, compiled apart as a ``cfunc``)
    at ``address`` on the engine's ``ctl``, a body's ``record`` and its mix ``out``
    (addresses) over ``n`` frames: a plain C call through a pointer, no Python. Returns
    its result (1 if a rolling voice rang)."""
    sig = types.int64(address, ctl, record, out, n)

    def codegen(context, builder, signature, args):
        i64 = cgutils.ir.IntType(64)
        fnty = cgutils.ir.FunctionType(i64, [i64] * 4)
        function = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(function, list(args[1:]))

    return sig, codegen


@compiled(nogil=True, inline="always")
def _mix_one_body(ctl, record, scratch, mix, t0, n, limit):
    """Mix the body of ``record`` over ``n`` frames from ``t0`` into ``mix`` (every
    channel's row, then each channel's own, see :func:`_write_block`) at its gain, into
    its channel's row (every channel's for a body of one listener), or for a panned body
    into the first two channels' rows at its gain times :func:`pan_gains`; each channel's
    gain is ramped linearly over the block from its value at the last block to its target.
    Applies a pending ``stop_all`` first. ``scratch``: the body's mix and a voice's;
    ``limit``: the most pulses it transforms (-1: all). Returns the pulses transformed."""
    counters = i64_at(record[B_COUNTERS], kernel.N_COUNTERS)
    transformed = i64_at(record[B_TRANSFORMED], 1)
    scalars = f64_at(record[B_SCALARS], N_SCALARS)
    R = record[B_SLOTS]
    state = i64_at(record[B_STATE], R)
    if counters[kernel.SILENCE] != 0:
        bank, modal, ring, transform, pulse_form, voice_form = body_form(record)
        rolling_block.silence_rolls(rolling_form(record)[0], event_ring(ctl))
        kernel.silence(modal, ring, transformed, voice_form, counters, event_ring(ctl))
    g0 = scalars[S_GAIN_NOW]
    g1 = scalars[S_GAIN]
    p0 = scalars[S_PAN_NOW]
    p1 = scalars[S_PAN]  # one word: a pan set on another thread is read whole
    busy = counters[kernel.BUSY_BLOCKS]
    roller = ctl[ROLLER]
    rolling = roller != 0 and rolling_block.any_live(rolling_form(record)[0])
    waiting = counters[kernel.AWAKE] != 0
    if not waiting:
        # asleep: nothing to mix unless something was handed over
        for i in range(R):
            if state[i] == kernel.READY or state[i] == kernel.PULSE:
                waiting = True
                break
        if not waiting and not rolling:
            scalars[S_GAIN_NOW] = g1
            scalars[S_PAN_NOW] = p1
            return 0
    out = scratch[0]
    for s in range(n):
        out[s] = 0.0
    pulses = 0
    if waiting:
        bank, modal, ring, transform, pulse_form, voice_form = body_form(record)
        pulses = kernel.mix_body(
            out, scratch[1], t0, n, bank, modal, scalars[S_FLOOR], ring, counters, transform,
            pulse_form, transformed, voice_form, event_ring(ctl), limit,
        )  # fmt: skip
    if rolling:
        rolling = _call_roller(roller, ctl.ctypes.data, record.ctypes.data, out.ctypes.data, n) != 0
    if counters[kernel.BUSY_BLOCKS] != busy or rolling:
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
        record = i64_at(directory[b], N_BODY)
        state = i64_at(record[B_STATE], record[B_SLOTS])
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
    ints = i64_at(ctl[LIM_INTS], limiter.N_INTS)
    D = ints[limiter.I_DELAY]
    A = ints[limiter.I_ATTACK]
    return (
        ints,
        f64_at(ctl[LIM_FLOATS], limiter.N_FLOATS),
        numba.carray(
            pointer_to(ctl[LIM_TAPS]), (limiter.OVERSAMPLING - 1, limiter.TAPS), np.float64
        ),
        numba.carray(pointer_to(ctl[LIM_X]), (D + 1, channels), np.float64),
        f64_at(ctl[LIM_R], A + 2 * limiter.REACH + 1),
        f64_at(ctl[LIM_M], A + 1),
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
        rec = numba.carray(pointer_to(ctl[RECORD]), (cap, channels), np.float32)
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
    times = f64_at(ctl[TIMES], N_TIMES)
    mix = numba.carray(pointer_to(ctl[MIX]), (ctl[CHANNELS] + 1, cap), np.float64)
    scratch = numba.carray(pointer_to(ctl[SCRATCH]), (2, cap), np.float64)
    directory = i64_at(ctl[DIRECTORY], ctl[MAX_BODIES])
    allow = i64_at(ctl[ALLOW], ctl[MAX_BODIES])
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
            record = i64_at(directory[b], N_BODY)
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
    directory = i64_at(ctl[DIRECTORY], ctl[MAX_BODIES])
    total = 0
    for b in range(ctl[N_BODIES]):
        record = i64_at(directory[b], N_BODY)
        total += i64_at(record[B_TRANSFORMED], 1)[0]
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
    times = f64_at(ctl[TIMES], N_TIMES)
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
        end = monotonic_ns()
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
    entry = monotonic_ns()
    ctl = numba.carray(userdata, N_CTL, np.int64)
    out = numba.carray(output, (np.int64(frames), ctl[CHANNELS]), np.float32)
    device = address_of(time_info) != 0
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
    """The compiled :func:`_callback` (a numba ``CFunc``: ``.address`` for PortAudio), made on
    first use after the engine's note (:func:`synth.compilation.announce`), since numba
    compiles a ``cfunc`` where it is made. It is the block's only compiled entry (its levels
    are inlined and Python calls it too): numba compiles a kernel's whole tree again into each
    caller that is compiled on its own."""
    with cfunc_compiling(_callback, CALLBACK_SIGNATURE):
        return numba.cfunc(CALLBACK_SIGNATURE, nopython=True, cache=True, fastmath=FASTMATH)(
            _callback
        )


ROLLER_SIGNATURE = types.int64(types.int64, types.int64, types.int64, types.int64)


def _roll_body(ctl_address, record_address, out_address, n):
    """The rolling voices of the body at ``record_address`` over ``n`` frames, added into its
    mix at ``out_address`` (:func:`synth.live.rolling_block.mix_rolls`, from the engine's
    frame; their ends posted in the event ring of the engine at ``ctl_address``). Returns 1
    if one rang, else 0."""
    ctl = i64_at(ctl_address, N_CTL)
    record = i64_at(record_address, N_BODY)
    out = f64_at(out_address, n)
    if rolling_block.mix_rolls(out, n, ctl[FRAME], rolling_form(record), event_ring(ctl)):
        return 1
    return 0


@functools.cache
def rolling_block_code():
    """The compiled :func:`_roll_body` (a numba ``CFunc``), which the callback calls through
    its address (``ctl[ROLLER]``, :func:`_call_roller`) for an engine with rolling slots.

    Apart from the callback, so that an engine without rolling slots never compiles,
    loads nor runs the rolling contact's integrator
    (:func:`synth.physics.rolling_kernels.roll`, the largest kernel the live engine
    calls); made on first use, as :func:`stream_callback`."""
    with cfunc_compiling(_roll_body, ROLLER_SIGNATURE):
        return numba.cfunc(ROLLER_SIGNATURE, nopython=True, cache=True, fastmath=FASTMATH)(
            _roll_body
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
    bank, modal, ring, transform, pulse_form, voice_form = body_form(record)
    transformed = i64_at(record[B_TRANSFORMED], 1)
    # the in-contact response and peak heard with the gains the mixing holds now; every
    # pulse (limit -1) as an int64, the type mix_body passes: a literal -1 would have numba
    # compile transform_pulses a second time
    kernel.transform_pulses(ring, transform, pulse_form, transformed, bank[3], np.int64(-1))


@compiled(nogil=True)
def silence_body(ctl, record):
    """Stop every voice of a body and drop its pending impacts now, on the calling thread
    (no stream runs; see :func:`synth.live.kernel.silence`)."""
    bank, modal, ring, transform, pulse_form, voice_form = body_form(record)
    counters = i64_at(record[B_COUNTERS], kernel.N_COUNTERS)
    transformed = i64_at(record[B_TRANSFORMED], 1)
    rolling_block.silence_rolls(rolling_form(record)[0], event_ring(ctl))
    kernel.silence(modal, ring, transformed, voice_form, counters, event_ring(ctl))


def warm_up(rolling: bool = False) -> None:
    """Compile (or load from numba's cache) everything the audio thread runs, on a one-mode
    body with one pulse handed over, so that no callback compiles; with ``rolling``, the
    rolling voices' block too (:func:`rolling_block_code`)."""
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
    if rolling:
        rolling_block_code()
