"""The audio thread without Python: :func:`stream_callback`, a numba ``cfunc`` of PortAudio's
``PaStreamCallback`` signature on the engine's preallocated state (:mod:`synth.live.state`)
through addresses (``ctl``'s as ``userData``, as python-rtmixer does): no GIL, allocation or
lock. The rolling block is compiled apart, called through ``ctl[ROLLER]``."""

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
from synth.live import state as st
from synth.live.kernel import fence as _fence

#: PortAudio's stream callback flags (portaudio.h) and its paContinue.
PA_OUTPUT_UNDERFLOW, PA_OUTPUT_OVERFLOW, PA_CONTINUE = 0x4, 0x8, 0

#: The soft clipper's largest output: the largest float32 below full scale.
CEILING = float(np.nextafter(np.float32(1.0), np.float32(0.0)))


@compiled(nogil=True, inline="always")
def pan_gains(pan):
    """The constant-power pan law ``(cos, sin)((pan + 1) pi / 4)`` (centre -3.01 dB), as sines
    so the ends are exactly 1 and 0; NaN (unpanned): 1 on both."""
    if math.isnan(pan):
        return 1.0, 1.0
    return math.sin((1.0 - pan) * (0.25 * math.pi)), math.sin((1.0 + pan) * (0.25 * math.pi))


@compiled(nogil=True, inline="always")
def _add_ramped(row, out, g0, g1, n):
    """``row += g * out`` over ``n`` frames, ``g`` ramped linearly from ``g0`` to ``g1``."""
    if g0 == g1:
        for s in range(n):
            row[s] += g1 * out[s]
    else:
        step = (g1 - g0) / n
        for s in range(n):
            row[s] += (g0 + step * (s + 1)) * out[s]


@intrinsic
def _call_roller(typingctx, address, ctl, record, out, n):
    """Call the rolling block (:func:`_roll_body`, a ``cfunc``) at ``address`` (a C call)."""
    sig = types.int64(address, ctl, record, out, n)

    def codegen(context, builder, signature, args):
        i64 = cgutils.ir.IntType(64)
        fnty = cgutils.ir.FunctionType(i64, [i64] * 4)
        function = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(function, list(args[1:]))

    return sig, codegen


@compiled(nogil=True, inline="always")
def _mix_one_body(ctl, record, scratch, mix, t0, n, limit):
    """Mix the body of ``record`` over ``n`` frames from ``t0`` into its channel's row of
    ``mix`` (row 0: every channel's; panned: the first two at :func:`pan_gains`), its gain
    ramped; ``limit``: most pulses transformed (-1: all). Returns the pulses transformed."""
    counters = st.i64_at(record[st.B_COUNTERS], kernel.N_COUNTERS)
    scalars = st.f64_at(record[st.B_SCALARS], st.N_SCALARS)
    state = st.i64_at(record[st.B_STATE], record[st.B_SLOTS])
    if counters[kernel.SILENCE] != 0:
        silence_body(ctl, record)
    g0, g1 = scalars[st.S_GAIN_NOW], scalars[st.S_GAIN]
    # one word each: a pan set on another thread is read whole
    p0, p1 = scalars[st.S_PAN_NOW], scalars[st.S_PAN]
    busy, roller = counters[kernel.BUSY_BLOCKS], ctl[st.ROLLER]
    rolling = roller != 0 and rolling_block.any_live(st.rolling_form(record)[0])
    waiting = counters[kernel.AWAKE] != 0
    if not waiting:
        # asleep: nothing to mix unless something was handed over
        for i in range(state.shape[0]):
            if state[i] == kernel.READY or state[i] == kernel.PULSE:
                waiting = True
                break
        if not waiting and not rolling:
            scalars[st.S_GAIN_NOW], scalars[st.S_PAN_NOW] = g1, p1
            return 0
    out = scratch[0]
    for s in range(n):
        out[s] = 0.0
    pulses = 0
    if waiting:
        body = st.body_form(record)
        pulses = kernel.mix_body(out, scratch[1], t0, n, body, st.event_ring(ctl), limit)
    if rolling:
        rolling = _call_roller(roller, ctl.ctypes.data, record.ctypes.data, out.ctypes.data, n) != 0
    if counters[kernel.BUSY_BLOCKS] != busy or rolling:
        if math.isnan(p0) and math.isnan(p1):
            _add_ramped(mix[record[st.B_CHANNEL] + 1], out, g0, g1, n)
        else:  # a mono body panned between the first two channels
            left0, right0 = pan_gains(p0)
            left1, right1 = pan_gains(p1)
            _add_ramped(mix[1], out, g0 * left0, g1 * left1, n)
            _add_ramped(mix[2], out, g0 * right0, g1 * right1, n)
    scalars[st.S_GAIN_NOW], scalars[st.S_PAN_NOW] = g1, p1
    return pulses


@compiled(nogil=True)
def _share_budget(ctl, directory, bodies, allow, budget):
    """Share a callback's ``budget`` of pulse transforms among the bodies (``allow[b]``), in
    turn from ``SHARE_FROM``: the first left short is served first next time."""
    start = ctl[st.SHARE_FROM] if ctl[st.SHARE_FROM] < bodies else 0
    left, short, deferred = budget, -1, 0
    for k in range(bodies):
        b = start + k if start + k < bodies else start + k - bodies
        record = st.i64_at(directory[b], st.N_BODY)
        state = st.i64_at(record[st.B_STATE], record[st.B_SLOTS])
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
    ctl[st.TRANSFORMS_DEFERRED] += deferred
    ctl[st.SHARE_FROM] = short if short >= 0 else start


@compiled(nogil=True, inline="always")
def soft_clip(v):
    """The identity up to ``KNEE``, then a tanh knee (C1) capped at ``CEILING`` (< 0 dBFS)."""
    a = abs(v)
    if a <= kernel.KNEE:
        return v
    room = 1.0 - kernel.KNEE
    y = min(kernel.KNEE + room * math.tanh((a - kernel.KNEE) / room), CEILING)
    return y if v > 0.0 else -y


@compiled(nogil=True)
def _limiter(ctl, channels):
    """The limiter's arrays (:meth:`~synth.live.limiter.LimiterState.arrays`) from ``ctl``."""
    ints = st.i64_at(ctl[st.LIM_INTS], limiter.N_INTS)
    D, A = ints[limiter.I_DELAY], ints[limiter.I_ATTACK]
    return (
        ints,
        st.f64_at(ctl[st.LIM_FLOATS], limiter.N_FLOATS),
        numba.carray(
            st.pointer_to(ctl[st.LIM_TAPS]), (limiter.OVERSAMPLING - 1, limiter.TAPS), np.float64
        ),
        numba.carray(st.pointer_to(ctl[st.LIM_X]), (D + 1, channels), np.float64),
        st.f64_at(ctl[st.LIM_R], A + 2 * limiter.REACH + 1),
        st.f64_at(ctl[st.LIM_M], A + 1),
    )


@compiled(nogil=True)
def restart_meters(ctl, times):  # pragma: no cover - compiled
    """The meters' restart :meth:`~synth.live.engine.Engine.reset_meter` asked for (``ctl``'s
    resets asked ahead of those made): the bus' peaks and the limiter's gain reduction. Run
    by the callback at a block's start, which alone writes the meters while it runs (a reset
    written from outside while a block ran was overwritten by the block's own figures)."""
    asked = ctl[st.METER_ASKED]
    if asked == ctl[st.METER_DONE]:
        return
    times[st.PEAK] = 0.0
    times[st.OUT_PEAK] = 0.0
    if ctl[st.LIMIT] != 0:
        limiter.restart_meter(
            st.i64_at(ctl[st.LIM_INTS], limiter.N_INTS),
            st.f64_at(ctl[st.LIM_FLOATS], limiter.N_FLOATS),
        )
    ctl[st.METER_DONE] = asked


@compiled(nogil=True)
def _write_block(ctl, times, mix, out, row, n):
    """The master bus over ``n`` frames into ``out[row:]`` (channel ``c``: ``mix[0] + mix[c +
    1]``, cleared): fades, master gain, meters, limiter, clipper, recording."""
    restart_meters(ctl, times)
    channels, pos, length = out.shape[1], ctl[st.FADE_AT], ctl[st.FADE_LENGTH]
    if pos < 0 and ctl[st.FADE_ASKED] != 0:
        pos = 0  # the stop fade asked for starts with this block
    level, level_step = times[st.PAUSE_LEVEL], 1.0 / length
    target = 0.0 if ctl[st.PAUSE] != 0 else 1.0
    if pos == 0:
        ctl[st.FADE_FRAME] = ctl[st.FRAME]
    g0, g1 = times[st.MASTER_NOW], times[st.MASTER_GAIN]
    step = (g1 - g0) / n
    peak, out_peak, clipped, clip = times[st.PEAK], times[st.OUT_PEAK], 0, ctl[st.CLIP] != 0
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
            peak = max(peak, abs(v))
    if ctl[st.LIMIT] != 0:
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
            out_peak = max(out_peak, abs(w))
            out[row + s, c] = w
    ctl[st.FADE_AT] = pos
    times[st.PAUSE_LEVEL], times[st.MASTER_NOW] = level, g1
    times[st.PEAK], times[st.OUT_PEAK] = peak, out_peak
    ctl[st.CLIPPED] += clipped
    cap, done = ctl[st.RECORD_FRAMES], ctl[st.RECORDED]
    if done < cap:
        m = min(n, cap - done)
        rec = numba.carray(st.pointer_to(ctl[st.RECORD]), (cap, channels), np.float32)
        for s in range(m):
            for c in range(channels):
                rec[done + s, c] = out[row + s, c]
        ctl[st.RECORDED] = done + m


@compiled(nogil=True, inline="always")
def _mix_engine(ctl, out, budget):
    """Mix every body into ``out`` (float32 (frames, channels)) in pieces of ``MIX_CAP``
    frames, at most ``budget`` pulses transformed (-1: all); paused, silence."""
    frames, cap, times = out.shape[0], ctl[st.MIX_CAP], st.f64_at(ctl[st.TIMES], st.N_TIMES)
    mix = numba.carray(st.pointer_to(ctl[st.MIX]), (ctl[st.CHANNELS] + 1, cap), np.float64)
    scratch = numba.carray(st.pointer_to(ctl[st.SCRATCH]), (2, cap), np.float64)
    directory = st.i64_at(ctl[st.DIRECTORY], ctl[st.MAX_BODIES])
    allow = st.i64_at(ctl[st.ALLOW], ctl[st.MAX_BODIES])
    shared = -1  # the bodies counted when the budget was shared (once a call)
    # typed int64 from the start: a literal 0 would have numba type _write_block twice
    done = np.int64(0)
    while done < frames:
        if ctl[st.PAUSE] != 0 and times[st.PAUSE_LEVEL] <= 0.0:
            for s in range(done, frames):
                for c in range(out.shape[1]):
                    out[s, c] = 0.0
            return
        n, t0, bodies = min(cap, frames - done), ctl[st.FRAME], ctl[st.N_BODIES]
        _fence()  # the records of the bodies counted are complete
        if budget >= 0 and shared < 0:  # once a call: the budget is the callback's
            _share_budget(ctl, directory, bodies, allow, budget)
            shared = bodies
        for b in range(bodies):
            record = st.i64_at(directory[b], st.N_BODY)
            limit = -1  # a body added after the share waits for the next call
            if budget >= 0:
                limit = allow[b] if b < shared else 0
            pulses = _mix_one_body(ctl, record, scratch, mix, t0, n, limit)
            if budget >= 0:
                allow[b] = limit - pulses
        _write_block(ctl, times, mix, out, done, n)
        ctl[st.FRAME] = t0 + n
        done += n


@compiled(nogil=True)
def _transformed(ctl):
    """The pulses every body in the directory has transformed so far."""
    directory = st.i64_at(ctl[st.DIRECTORY], ctl[st.MAX_BODIES])
    total = 0
    for b in range(ctl[st.N_BODIES]):
        record = st.i64_at(directory[b], st.N_BODY)
        total += st.i64_at(record[st.B_TRANSFORMED], 1)[0]
    return total


@compiled(nogil=True, inline="always")
def _run_block(ctl, out, flags, current, dac, entry_ns, device):
    """One block, and for a stream's callback (``device``) its accounting: PortAudio's
    ``flags``, gaps, the clock's anchor (the first frame leaves ``dac - current`` s after
    ``entry_ns`` plus the look-ahead) and the run time as a fraction of the block."""
    times, frames = st.f64_at(ctl[st.TIMES], st.N_TIMES), out.shape[0]
    if device:
        if flags & PA_OUTPUT_UNDERFLOW:
            ctl[st.UNDERFLOWS] += 1
        if flags & PA_OUTPUT_OVERFLOW:
            ctl[st.OVERFLOWS] += 1
        measured = dac > 0.0 and current > 0.0 and dac >= current
        lead = times[st.LEAD] = dac - current if measured else times[st.NOMINAL_LATENCY]
        now = entry_ns * 1e-9
        if times[st.LAST_ENTRY] > 0.0:
            gap = (now - times[st.LAST_ENTRY]) * times[st.SAMPLERATE] / max(frames, 1)
            times[st.GAP_MAX] = max(times[st.GAP_MAX], gap)
        times[st.LAST_ENTRY] = now
        ctl[st.SEQ] += 1
        _fence()
        times[st.ANCHOR_FRAME] = ctl[st.FRAME]
        times[st.ANCHOR_DAC] = entry_ns * 1e-9 + lead + times[st.LIMIT_DELAY]
        _fence()
        ctl[st.SEQ] += 1
    budget = ctl[st.TRANSFORM_BUDGET] if device else np.int64(-1)
    before = _transformed(ctl)
    _mix_engine(ctl, out, budget)
    if device:
        ctl[st.TRANSFORMS_MAX] = max(ctl[st.TRANSFORMS_MAX], _transformed(ctl) - before)
        end = st.monotonic_ns()
        times[st.END_TIME], times[st.END_FRAME] = end * 1e-9, ctl[st.FRAME]
        cost = (end - entry_ns) * 1e-9 * times[st.SAMPLERATE] / max(frames, 1)
        times[st.COST_LAST] = cost
        times[st.COST_SUM] += cost
        times[st.COST_MAX] = max(times[st.COST_MAX], cost)
        ctl[st.CALLBACKS] += 1


CALLBACK_SIGNATURE = types.intc(
    types.voidptr, types.voidptr, types.uint64, types.voidptr, types.uint64, types.voidptr
)


def _callback(input, output, frames, time_info, flags, userdata):
    """PortAudio's ``PaStreamCallback`` on the engine's ``ctl`` (``userData``); a NULL
    ``timeInfo`` (:func:`mix_engine`) skips the device's accounting."""
    entry = st.monotonic_ns()
    ctl = numba.carray(userdata, st.N_CTL, np.int64)
    out = numba.carray(output, (np.int64(frames), ctl[st.CHANNELS]), np.float32)
    device = st.address_of(time_info) != 0
    current = dac = 0.0
    if device:
        info = numba.carray(time_info, 3, np.float64)  # adc time, current time, dac time
        current, dac = info[1], info[2]
    _run_block(ctl, out, np.int64(flags), current, dac, entry, device)
    return PA_CONTINUE


def _c_function(function, signature):
    """``function`` compiled (or loaded from the disk cache) as a C function."""
    with cfunc_compiling(function, signature):
        return numba.cfunc(signature, nopython=True, cache=True, fastmath=FASTMATH)(function)


@functools.cache
def stream_callback():
    """The compiled :func:`_callback`, the block's only compiled entry (Python calls it too):
    numba compiles a kernel's tree again into each caller compiled on its own."""
    return _c_function(_callback, CALLBACK_SIGNATURE)


ROLLER_SIGNATURE = types.int64(types.int64, types.int64, types.int64, types.int64)


def _roll_body(ctl_address, record_address, out_address, n):
    """A body's rolling voices over ``n`` frames added into its mix; 1 if one rang."""
    ctl, record = st.i64_at(ctl_address, st.N_CTL), st.i64_at(record_address, st.N_BODY)
    out, form, events = st.f64_at(out_address, n), st.rolling_form(record), st.event_ring(ctl)
    return 1 if rolling_block.mix_rolls(out, n, ctl[st.FRAME], form, events) else 0


@functools.cache
def rolling_block_code():
    """The compiled :func:`_roll_body`: apart, so an engine without rolling slots never
    compiles the rolling integrator (the largest kernel)."""
    return _c_function(_roll_body, ROLLER_SIGNATURE)


def mix_engine(ctl: np.ndarray, out: np.ndarray, flags: int = 0, time_info=None) -> None:
    """Mix the next frames into ``out`` (checked by the caller) with the compiled callback;
    with ``time_info`` (float64 adc, current and dac times, s; the Python fallback's) and
    PortAudio's ``flags``, the device's accounting too."""
    info = None if time_info is None else time_info.ctypes.data
    stream_callback().ctypes(None, out.ctypes.data, out.shape[0], info, flags, ctl.ctypes.data)


@compiled(nogil=True)
def transform_pending(record):
    """Transform a body's waiting pulses now, on the calling thread (before a stream starts)."""
    # -1 as mix_body's int64: a literal would compile transform_pulses twice
    kernel.transform_pulses(st.body_form(record), np.int64(-1))


@compiled(nogil=True)
def silence_body(ctl, record):
    """:func:`synth.live.kernel.silence` of a body and its rolling voices (``stop_all``)."""
    rolling_block.silence_rolls(st.rolling_form(record)[0], st.event_ring(ctl))
    kernel.silence(st.body_form(record), st.event_ring(ctl))


def warm_up(rolling: bool = False) -> None:
    """Compile (or load) all the audio thread runs, on a one-mode body with a pulse handed
    over, so that no callback compiles; with ``rolling``, the rolling block too."""
    from synth.live.voice import PendingRing
    from synth.sound.modal_bank import bank_coefficients

    fs = 48000
    ring = PendingRing(1, 1, 2, 7, 1, voices=2)
    slot = ring.reserve(pulse=True, voice=ring.open_voice(1, 1))
    ring.pulse[slot, [kernel.GAIN, kernel.STEP, kernel.CONTACT_TIME, kernel.ORDER]] = (
        1.0, 1e-5, 4e-5, 2.5
    )  # fmt: skip
    ring.publish(slot, 1, 0, 0, points=5)
    options = st.EngineOptions(samplerate=fs, max_bodies=1, callback="python")
    state = st.EngineState(options)
    c = bank_coefficients(np.array([-10.0 + 1000.0j]), np.ones(1), np.ones(1), float(fs))
    index = state.add_body(c, np.ones(1), ring, st.BodySettings())
    transform_pending(state.records[index][0])
    out = np.zeros((8, 1), dtype=np.float32)
    mix_engine(state.ctl, out, 0, np.zeros(3))  # compiles the cfunc, or loads it
    mix_engine(state.ctl, out)
    if rolling:
        rolling_block_code()
