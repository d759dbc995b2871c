"""The engine's state: the preallocated arrays the audio thread reaches through their
addresses (its callback touches no Python object), their layout and their memory: ``ctl``
(int64), ``times`` (float64), a directory of body records (:data:`BODY_FIELDS`;
:func:`body_form` makes the kernel's views) and the voice-ended event ring.
"""

from __future__ import annotations

import math
import mmap
import time

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from synth.compilation import compiled
from synth.live import kernel, limiter, rolling_block
from synth.live.atomics import pointer_to as pointer_to
from synth.live.heard import N_HEARD_ROWS, heard_arrays

#: ``ctl`` fields (int64): the next frame to mix; the stop fade's position (-1 none), length
#: (frames) and first frame (-1 before); the bodies mixed (counted after their record) and
#: the directory's length; channels; the scratch buffers' frames; callbacks, and those
#: PortAudio flagged output underflow and overflow; samples that reached full scale before
#: the clipper; the anchor's sequence number (odd while written); the recording's frames
#: and those recorded; the addresses of ``times``, the body directory, the master mix
#: (float64, CHANNELS + 1 rows of MIX_CAP: every channel's bus, then each channel's own),
#: the scratch (a body's mix and a voice's, 2 x MIX_CAP), the recording (float32,
#: RECORD_FRAMES x CHANNELS); 1: soft-clip; the event ring's address and length (header
#: included); 1: pause asked; 1: limit; the limiter's arrays' addresses
#: (:meth:`~synth.live.limiter.LimiterState.arrays`); the most pulses a callback
#: transformed, a callback's budget, pulses left waiting, the body the next share serves
#: first, the address of the shares (int64, MAX_BODIES); the rolling block's address (0:
#: none).
(
    FRAME, FADE_AT, FADE_LENGTH, FADE_FRAME, N_BODIES, MAX_BODIES, CHANNELS, MIX_CAP,
    CALLBACKS, UNDERFLOWS, OVERFLOWS, CLIPPED, SEQ, RECORD_FRAMES, RECORDED, TIMES, DIRECTORY,
    MIX, SCRATCH, RECORD, CLIP, EVENTS, N_EVENTS, PAUSE, LIMIT, LIM_INTS, LIM_FLOATS,
    LIM_TAPS, LIM_X, LIM_R, LIM_M, TRANSFORMS_MAX, TRANSFORM_BUDGET, TRANSFORMS_DEFERRED,
    SHARE_FROM, ALLOW, ROLLER, N_CTL,
) = range(38)  # fmt: skip

#: ``times`` fields (float64): the sample rate (Hz); the stream's nominal latency and the
#: last callback's ``outputBufferDacTime - currentTime`` (s); the anchor: the last
#: callback's first frame and the monotonic time (s) it leaves the device; the monotonic
#: time at the last callback's end and the frame after its block; the sum, largest and last
#: callback run time (a fraction of its block); the master gain's target and its value at
#: the last block's end (linear); the largest ``|sample|`` of the bus before the clipper and
#: at the device since the last reset; the last callback's entry (s, 0 before) and the
#: longest gap between entries (blocks); the pause level (1 playing, 0 paused, ramped over
#: FADE_LENGTH); the limiter's look-ahead (s; the bus leaves that much later).
(
    SAMPLERATE, NOMINAL_LATENCY, LEAD, ANCHOR_FRAME, ANCHOR_DAC, END_TIME, END_FRAME,
    COST_SUM, COST_MAX, COST_LAST, MASTER_GAIN, MASTER_NOW, PEAK, OUT_PEAK, LAST_ENTRY,
    GAP_MAX, PAUSE_LEVEL, LIMIT_DELAY, N_TIMES,
) = range(19)  # fmt: skip

#: A body record (int64): addresses, then sizes.
(
    B_TABLE, B_POLES, B_ZR, B_ZI, B_ACTIVE, B_DEBT, B_DEBT_AT, B_THRESHOLDS, B_THR2,
    B_LEVEL, B_STATE, B_INJECT, B_FIRST, B_LENGTH, B_AMPLITUDES, B_RESPONSE, B_REFERENCE,
    B_COUNTERS, B_POLE_RE, B_POLE_IM, B_STEP_RE, B_STEP_IM, B_WORK, B_COEFFICIENTS,
    B_SAMPLES, B_POINTS, B_PULSE, B_TRANSFORMED, B_SCALARS,
    B_VOICE, B_VOICES, B_VOICE_GAIN, B_VOICE_SLOTS, B_SLOT_GAIN, B_TAIL,
    B_MODES, B_SLOTS, B_CONTACT, B_PULSE_SAMPLES, B_WORK_ROWS, B_TABLE_COLS, B_CHANNEL,
    B_N_RECORDS, B_N_VOICE_SLOTS, B_TAIL_FRAMES,
    B_PARK_R, B_PARK_I, B_PARK_AT, B_HEARD, B_HEARD_SEQ, B_HEARD_COEF, B_HEARD_AMPS,
    B_ROLL_INTS, B_ROLL_FLOATS, B_ROLL_Y, B_ROLL_BUF, B_ROLL_Z, B_ROLL_COEF,
    B_ROLL_TABLES, B_ROLL_META, B_N_ROLLS, B_ROLL_ROWS, B_ROLL_FRAMES, N_BODY,
) = range(64)  # fmt: skip
#: The record's field names, as :func:`body_arrays` keys them: ``B_TABLE`` is "table".
BODY_FIELDS = tuple(name[2:].lower() for name in sorted(
    (n for n in vars() if n.startswith("B_")), key=vars().get))  # fmt: skip

#: A body's scalars (float64): sample rate (Hz), omission floor (fraction), the largest
#: decay rate (1/s), the sample period (s), its gain's target and its value now (linear),
#: its pan's target and its value now (in [-1, 1], NaN unpanned; see :func:`pan_gains`).
S_FS, S_FLOOR, S_SIGMA_MAX, S_PERIOD, S_GAIN, S_GAIN_NOW, S_PAN, S_PAN_NOW, N_SCALARS = range(9)

#: The clock the callback reads (and the trigger threads, in Python).
CLOCK = time.CLOCK_MONOTONIC if hasattr(time, "CLOCK_MONOTONIC") else -1


def native_available() -> bool:
    """Whether this platform has the POSIX clock the compiled callback reads."""
    return CLOCK >= 0


def monotonic() -> float:
    """The callback's clock, s (POSIX ``CLOCK_MONOTONIC``)."""
    return time.clock_gettime_ns(CLOCK) * 1e-9


@intrinsic
def address_of(typingctx, pointer):
    """The ``void*`` ``pointer`` as an int64 (0: NULL)."""
    sig = types.int64(types.voidptr)

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], cgutils.ir.IntType(64))

    return sig, codegen


@intrinsic
def monotonic_ns(typingctx):
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
def f64_at(address, n):
    return numba.carray(pointer_to(address), n, np.float64)


@compiled(nogil=True, inline="always")
def i64_at(address, n):
    return numba.carray(pointer_to(address), n, np.int64)


@compiled(nogil=True)
def body_form(record):
    """Views of a body's arrays from its ``record``, grouped as :func:`kernel.mix_body` takes
    them: the bank (power table, poles, rate, the listener's gains and their sequence), the
    slots' modal states, the pending ring, the pulses' transform and PULSE form, the voices."""
    K = record[B_MODES]
    R = record[B_SLOTS]
    C = record[B_CONTACT]
    P = record[B_PULSE_SAMPLES]
    V = record[B_N_VOICE_SLOTS]
    scalars = f64_at(record[B_SCALARS], N_SCALARS)
    bank = (
        numba.carray(pointer_to(record[B_TABLE]), (K, 2, record[B_TABLE_COLS]), np.float64),
        numba.carray(pointer_to(record[B_POLES]), K, np.complex128),
        scalars[S_FS],
        numba.carray(pointer_to(record[B_HEARD]), (N_HEARD_ROWS, K), np.float64),
        i64_at(record[B_HEARD_SEQ], 2),
    )
    modal = (
        numba.carray(pointer_to(record[B_ZR]), (V, K), np.float64),
        numba.carray(pointer_to(record[B_ZI]), (V, K), np.float64),
        numba.carray(pointer_to(record[B_ACTIVE]), (V, K), np.bool_),
        numba.carray(pointer_to(record[B_DEBT]), (V, K), np.float64),
        numba.carray(pointer_to(record[B_DEBT_AT]), (V, K), np.int64),
        numba.carray(pointer_to(record[B_THRESHOLDS]), (V, K), np.float64),
        numba.carray(pointer_to(record[B_THR2]), (V, K), np.float64),
        f64_at(record[B_LEVEL], V),
        numba.carray(pointer_to(record[B_PARK_R]), (V, K), np.float64),
        numba.carray(pointer_to(record[B_PARK_I]), (V, K), np.float64),
        numba.carray(pointer_to(record[B_PARK_AT]), (V, K), np.int64),
    )
    ring = (
        i64_at(record[B_STATE], R),
        i64_at(record[B_INJECT], R),
        i64_at(record[B_FIRST], R),
        i64_at(record[B_LENGTH], R),
        numba.carray(pointer_to(record[B_AMPLITUDES]), (R, K), np.complex128),
        numba.carray(pointer_to(record[B_RESPONSE]), (R, C), np.float64),
        f64_at(record[B_REFERENCE], R),
        i64_at(record[B_VOICE], R),
    )
    transform = (
        f64_at(record[B_POLE_RE], K),
        f64_at(record[B_POLE_IM], K),
        f64_at(record[B_STEP_RE], K),
        f64_at(record[B_STEP_IM], K),
        scalars[S_SIGMA_MAX],
        scalars[S_PERIOD],
        numba.carray(pointer_to(record[B_WORK]), (record[B_WORK_ROWS], K), np.float64),
        numba.carray(pointer_to(record[B_HEARD_COEF]), (2, K), np.float64),
        numba.carray(pointer_to(record[B_HEARD_AMPS]), K, np.complex128),
    )
    pulse_form = (
        numba.carray(pointer_to(record[B_COEFFICIENTS]), (R, 2, K), np.float64),
        numba.carray(pointer_to(record[B_SAMPLES]), (R, 2, P), np.float64),
        i64_at(record[B_POINTS], R),
        numba.carray(pointer_to(record[B_PULSE]), (R, kernel.N_PULSE_FIELDS), np.float64),
    )
    N = record[B_N_RECORDS]
    voice_form = (
        numba.carray(pointer_to(record[B_VOICES]), (N, kernel.N_VOICE_FIELDS), np.int64),
        f64_at(record[B_VOICE_GAIN], N),
        numba.carray(pointer_to(record[B_VOICE_SLOTS]), (V, kernel.N_SLOT_FIELDS), np.int64),
        numba.carray(pointer_to(record[B_SLOT_GAIN]), (V, 2), np.float64),
        f64_at(record[B_TAIL], record[B_TAIL_FRAMES]),
    )
    return bank, modal, ring, transform, pulse_form, voice_form


@compiled(nogil=True, inline="always")
def rolling_form(record):
    """Views of a body's rolling slots and listener's gains, as
    :func:`synth.live.rolling_block.mix_rolls` takes them."""
    R = record[B_N_ROLLS]
    K = record[B_MODES]
    P = record[B_ROLL_ROWS]
    N = rolling_block.N_STATE
    return (
        numba.carray(pointer_to(record[B_ROLL_INTS]), (R, rolling_block.N_INTS), np.int64),
        numba.carray(pointer_to(record[B_ROLL_FLOATS]), (R, rolling_block.N_FLOATS), np.float64),
        numba.carray(pointer_to(record[B_ROLL_Y]), (R, N), np.float64),
        numba.carray(
            pointer_to(record[B_ROLL_BUF]),
            (R, rolling_block.N_BUF, record[B_ROLL_FRAMES]),
            np.float64,
        ),
        numba.carray(pointer_to(record[B_ROLL_Z]), (R, 2, K), np.float64),
        numba.carray(pointer_to(record[B_ROLL_COEF]), (R, rolling_block.N_COEF, K), np.float64),
        numba.carray(pointer_to(record[B_ROLL_TABLES]), (R, 3, P, K), np.float64),
        numba.carray(pointer_to(record[B_ROLL_META]), (R, 3, rolling_block.N_META), np.float64),
        numba.carray(pointer_to(record[B_HEARD]), (N_HEARD_ROWS, K), np.float64),
        i64_at(record[B_HEARD_SEQ], 2),
    )


@compiled(nogil=True)
def event_ring(ctl):
    return i64_at(ctl[EVENTS], ctl[N_EVENTS])


def touch(a: np.ndarray) -> np.ndarray:
    """Map every page of the C-contiguous array ``a`` now (calloc'd pages are mapped at their
    first access, a zero page copied at its first write), so the audio thread never takes a
    page fault on it: a byte of each page is rewritten (read, if read-only). Returns ``a``."""
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
    """The arrays the audio thread works on, allocated once (``samplerate`` Hz, scratch of
    ``mix_frames``, ``limit`` the limiter's state or None, ``roller`` the rolling block's
    address or 0)."""

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
        roller: int = 0,
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
        self.records: list = []  # the bodies' records and arrays, kept alive here
        self.limiter = limit
        c, t = self.ctl, self.times
        arrays = (self.directory, self.allow, self.mix, self.scratch, self.events, self.recording)
        c[[DIRECTORY, ALLOW, MIX, SCRATCH, EVENTS, RECORD]] = [touch(a).ctypes.data for a in arrays]
        sizes = (self.events.shape[0], max_bodies, channels, mix_frames, record_frames)
        c[[N_EVENTS, MAX_BODIES, CHANNELS, MIX_CAP, RECORD_FRAMES]] = sizes
        c[[TIMES, TRANSFORM_BUDGET, CLIP]] = (t.ctypes.data, transforms_per_block, clip)
        c[[FADE_AT, FADE_LENGTH, FADE_FRAME, ROLLER]] = (-1, fade_frames, -1, roller)
        if limit is not None:
            c[LIMIT] = 1
            lim = [a.ctypes.data for a in limit.arrays()]
            c[[LIM_INTS, LIM_FLOATS, LIM_TAPS, LIM_X, LIM_R, LIM_M]] = lim
            t[LIMIT_DELAY] = limit.delay / samplerate
        t[[SAMPLERATE, MASTER_GAIN, MASTER_NOW, PAUSE_LEVEL]] = (samplerate, 1.0, 1.0, 1.0)
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
        """Publish a body (arrays and sizes by :data:`BODY_FIELDS` name) to the audio thread:
        its record is written, then counted. Returns the record."""
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
        """Point body ``index``'s directory entry at the vacant record (one atomic word);
        returns the mixing's progress (next frame, callbacks) for :meth:`left`."""
        progress = int(self.ctl[FRAME]), int(self.ctl[CALLBACKS])
        self.directory[index] = self.vacant.ctypes.data
        return progress

    def left(self, progress: tuple[int, int]) -> bool:
        """Whether every block that may have read the entry :meth:`vacate` changed has ended."""
        return int(self.ctl[FRAME]) > progress[0] or int(self.ctl[CALLBACKS]) > progress[1]

    def release(self, index: int) -> None:
        """Let go of body ``index``'s arrays (vacated and left); its entry is free again."""
        self.records[index] = None

    def anchor(self) -> tuple[int, float, float]:
        """The last callback's first frame, the monotonic time (s) it leaves the device and the
        callbacks so far, read consistently under the callback's sequence number."""
        c, t = self.ctl, self.times
        while True:
            seq = int(c[SEQ])
            frame, dac = float(t[ANCHOR_FRAME]), float(t[ANCHOR_DAC])
            if seq % 2 == 0 and int(c[SEQ]) == seq:
                return frame, dac, seq // 2


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
    rolls: dict | None = None,
) -> dict:
    """A body's arrays and sizes by :data:`BODY_FIELDS` name for :meth:`EngineState.add_body`,
    from its bank ``coefficients``, power ``table``, slots' states
    (:func:`synth.live.kernel.body_state`), pending ``ring``, omission ``floor``, output
    ``channel`` (-1: all), steal fade (samples), the listener's complex ``gains`` (K,),
    ``pan`` (NaN: unpanned) and rolling slots (None: none)."""
    from synth.sound.modal_bank import transform_workspace

    c = coefficients
    fs = float(c.samplerate)
    K = c.poles.size
    V = modal_state["zr"].shape[0]
    heard, heard_seq = heard_arrays(np.asarray(gains, dtype=complex))
    voice_slots = np.zeros((V, kernel.N_SLOT_FIELDS), dtype=np.int64)
    voice_slots[:, kernel.SL_OWNER] = -1
    counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
    counters[kernel.EARS] = ears
    counters[kernel.STEAL_FRAMES] = steal_frames
    tail = np.zeros(mix_frames + steal_frames)
    scalars = np.zeros(N_SCALARS)
    fields = [S_FS, S_FLOOR, S_SIGMA_MAX, S_PERIOD, S_GAIN, S_GAIN_NOW, S_PAN, S_PAN_NOW]
    scalars[fields] = (fs, floor, c.sigma_max, 1.0 / fs, gain, gain, pan, pan)
    work = transform_workspace(K)
    if rolls is None:
        rolls = rolling_block.rolling_arrays(0, K, 2, 1)
    return rolls | modal_state | dict(
        table=np.ascontiguousarray(table),
        poles=np.ascontiguousarray(c.poles, dtype=np.complex128), state=ring.state,
        inject=ring.inject, first=ring.first, length=ring.length, amplitudes=ring.amplitudes,
        response=ring.response, reference=ring.reference, counters=counters,
        pole_re=np.ascontiguousarray(c.pole_re), pole_im=np.ascontiguousarray(c.pole_im),
        step_re=np.ascontiguousarray(c.step_re), step_im=np.ascontiguousarray(c.step_im),
        work=work, coefficients=ring.coefficients, samples=ring.samples, points=ring.points,
        pulse=ring.pulse, transformed=ring.transformed, scalars=scalars,
        modes=K, slots=ring.capacity, contact=ring.max_contact,
        pulse_samples=ring.pulse_samples, work_rows=work.shape[0], table_cols=table.shape[2],
        channel=channel, voice=ring.voice, voices=ring.voices, voice_gain=ring.voice_gain,
        voice_slots=voice_slots, slot_gain=np.ones((V, 2)), tail=tail,
        n_records=ring.voices.shape[0], n_voice_slots=V, tail_frames=tail.shape[0],
        heard=heard, heard_seq=heard_seq,
        heard_coef=np.zeros((2, K)), heard_amps=np.zeros(K, dtype=complex),
    )  # fmt: skip
