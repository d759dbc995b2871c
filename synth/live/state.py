"""The engine's options and state: the preallocated arrays the audio thread reaches through
their addresses (its callback touches no Python object): ``ctl`` (int64), ``times``
(float64), a directory of body records (:data:`BODY_FIELDS`; :func:`body_form` makes the
kernel's views) and the voice-ended event ring.
"""

from __future__ import annotations

import math
import mmap
import time
from collections import namedtuple
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from synth import checks
from synth.compilation import compiled
from synth.errors import ParameterError
from synth.live import kernel, rolling_block
from synth.live.kernel import N_HEARD_ROWS, heard_arrays, pointer_to
from synth.live.limiter import LOOKAHEAD, MIN_ATTACK, LimiterState, min_delay
from synth.live.rolling import MAX_ROLLS
from synth.live.voice import MAX_VOICES, STEAL_FADE, check_int, closed
from synth.sound.modal_bank import PULSE_POINTS

#: ``ctl`` fields (int64): the clock (next frame), the stop fade (position, length, first
#: frame; written by the callback only), bodies counted and room, channels, mixing piece
#: (frames), callbacks and PortAudio's under/overflows, samples clipped, the anchor's sequence
#: number (odd while written), recording (room, written), addresses of ``times``, the
#: directory, mix (CHANNELS + 1 rows: the common bus, then each channel's), scratch,
#: recording, flags (clip), the event ring (address, length), pause and limit flags, the
#: limiter's arrays, the transform budget's figures and shares, the rolling block's address
#: (0: none), the stop fade asked for (1) and the meter resets asked for (a count; both written
#: by the controlling thread only: a field both threads wrote could lose a write), the meter
#: resets made (the callback's).
(
    FRAME, FADE_AT, FADE_LENGTH, FADE_FRAME, N_BODIES, MAX_BODIES, CHANNELS, MIX_CAP,
    CALLBACKS, UNDERFLOWS, OVERFLOWS, CLIPPED, SEQ, RECORD_FRAMES, RECORDED, TIMES, DIRECTORY,
    MIX, SCRATCH, RECORD, CLIP, EVENTS, N_EVENTS, PAUSE, LIMIT, LIM_INTS, LIM_FLOATS,
    LIM_TAPS, LIM_X, LIM_R, LIM_M, TRANSFORMS_MAX, TRANSFORM_BUDGET, TRANSFORMS_DEFERRED,
    SHARE_FROM, ALLOW, ROLLER, FADE_ASKED, METER_ASKED, METER_DONE, N_CTL,
) = range(41)  # fmt: skip

#: ``times`` fields (float64): rate (Hz), nominal and last output latency (s), the anchor
#: (a callback's first frame and its monotonic time at the device, s), the last callback's
#: end (s, frame), its run time (sum, max, last; fractions of a block), master gain (target,
#: now), peaks (bus, device), last entry (s) and longest gap (blocks), pause level, look-ahead.
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
#: The record's field names, as :meth:`EngineState.body_arrays` keys them (B_TABLE: "table").
BODY_FIELDS = tuple(name[2:].lower() for name in sorted(
    (n for n in vars() if n.startswith("B_")), key=vars().get))  # fmt: skip

#: A body's scalars (float64): rate (Hz), omission floor, largest decay rate (1/s), sample
#: period (s), gain and pan (target and now; pan NaN unpanned).
S_FS, S_FLOOR, S_SIGMA_MAX, S_PERIOD, S_GAIN, S_GAIN_NOW, S_PAN, S_PAN_NOW, N_SCALARS = range(9)

#: The clock the callback reads (and the trigger threads, in Python); -1 where the platform
#: has no POSIX monotonic clock (the compiled callback is then not available).
CLOCK = time.CLOCK_MONOTONIC if hasattr(time, "CLOCK_MONOTONIC") else -1


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


#: A body's arrays as one record for the kernels (:func:`body_form`): the bank (power table,
#: poles, rate, heard gains and their sequence), the slots' modal states, the pending ring,
#: the pulses' transform and PULSE form, the voices, its counters, pulses transformed and
#: omission floor (a fraction of a voice's peak).
BodyForm = namedtuple(
    "BodyForm", "bank modal ring transform pulse_form voice_form counters transformed floor"
)


@compiled(nogil=True)
def body_form(record):
    """The :class:`BodyForm` of a body's ``record``: views of its arrays as the kernels take
    them (no copy)."""
    K, R, C, P = record[B_MODES], record[B_SLOTS], record[B_CONTACT], record[B_PULSE_SAMPLES]
    V, N = record[B_N_VOICE_SLOTS], record[B_N_RECORDS]
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
    voice_form = (
        numba.carray(pointer_to(record[B_VOICES]), (N, kernel.N_VOICE_FIELDS), np.int64),
        f64_at(record[B_VOICE_GAIN], N),
        numba.carray(pointer_to(record[B_VOICE_SLOTS]), (V, kernel.N_SLOT_FIELDS), np.int64),
        numba.carray(pointer_to(record[B_SLOT_GAIN]), (V, 2), np.float64),
        f64_at(record[B_TAIL], record[B_TAIL_FRAMES]),
    )
    counters = i64_at(record[B_COUNTERS], kernel.N_COUNTERS)
    transformed = i64_at(record[B_TRANSFORMED], 1)
    return BodyForm(bank, modal, ring, transform, pulse_form, voice_form, counters, transformed,
                    scalars[S_FLOOR])  # fmt: skip


@compiled(nogil=True, inline="always")
def rolling_form(record):
    """Views of a body's rolling slots and gains, as :func:`rolling_block.mix_rolls` takes them."""
    R, K, P, N = record[B_N_ROLLS], record[B_MODES], record[B_ROLL_ROWS], rolling_block.N_STATE
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
    """Map every page of the C-contiguous ``a`` now (calloc'd pages map at first access), so
    the audio thread takes no page fault on it: a byte a page rewritten (read if read-only)."""
    b = a.reshape(-1).view(np.uint8)
    if b.size == 0:
        return a
    if a.flags.writeable:
        b[:: mmap.PAGESIZE] = b[:: mmap.PAGESIZE].copy()
        b[-1] = b[-1]
    else:
        _read = int(b[:: mmap.PAGESIZE].sum()) + int(b[-1])  # noqa: F841 (the reads touch)
    return a


#: The stream callbacks (compiled, or a Python fallback); latencies PortAudio takes by name.
STREAM_CALLBACKS = ("native", "python")
LATENCIES = ("low", "high")
#: Longest output ``process`` mixes in one call and ``record_seconds`` keeps, s.
MAX_SECONDS = 600.0
#: Defaults: room in the body directory, hits a callback transforms (``max_hits_per_block``).
DEFAULT_MAX_BODIES = 256
HITS_PER_BLOCK = 16
#: Frames a body's mixing piece holds (at least a block).
MIX_FRAMES = 4096
#: The integer options' bounds and units, and the real options' closed ranges and units.
_INTEGERS = (
    ("samplerate", 8000, 384000, "Hz"), ("blocksize", 16, 8192, "frames"),
    ("channels", 1, 64, "channels"), ("max_pending", 1, 4096, "impacts"),
    ("pulse_points", 5, 100_000, "points"), ("max_bodies", 1, 65536, "bodies"),
    ("max_voices", 1, 256, "voices"), ("max_rolls", 0, 16, "rolling voices"),
)  # fmt: skip
_RANGES = (
    ("fade", 0.001, 1.0, "s"), ("handover", 0.0, 0.1, "s"),
    ("record_seconds", 0.0, MAX_SECONDS, "s"), ("master_gain_db", -120.0, 40.0, "dB"),
    ("ceiling_db", -20.0, 0.0, "dBFS"),
)  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class EngineOptions:
    """An :class:`Engine`'s settings, checked and converted on construction; docs/live.md
    states each (SI units: Hz, s, dB; frames and counts are integers)."""

    samplerate: int
    blocksize: int = 256
    device: int | str | None = None
    latency: str | float = "low"
    channels: int = 1
    floor_db: float = -80.0
    max_pending: int = 128
    max_hits_per_block: int | None = None
    max_frequency: float | None = None
    pulse_points: int = PULSE_POINTS
    fade: float = 0.01
    handover: float = 0.002
    record_seconds: float = 0.0
    master_gain_db: float = 0.0
    clip: bool = True
    limiter: bool = False
    ceiling_db: float = -1.0
    lookahead: float | None = None
    callback: str = "native"
    max_bodies: int = DEFAULT_MAX_BODIES
    max_voices: int = MAX_VOICES
    max_total_voices: int | None = None
    on_device_lost: Callable[[str], object] | None = None
    max_rolls: int = MAX_ROLLS

    def __post_init__(self):
        for name, lo, hi, unit in _INTEGERS:
            self._set(name, check_int(name, getattr(self, name), lo, hi, unit))
        for name, lo, hi, unit in _RANGES:
            self._set(name, closed(name, getattr(self, name), lo, hi, unit))
        for name, value in (("clip", self.clip), ("limiter", self.limiter)):
            if not isinstance(value, bool):
                raise ParameterError(f"{name}={value!r} must be True or False")
        d = self.device
        if d is not None and (isinstance(d, bool) or not isinstance(d, (int, str))):
            raise ParameterError(f"device={d!r} must be None, a device index or a device name")
        self._set("latency", _latency(self.latency))
        if not checks.real("floor_db", self.floor_db, "dB", "< 0") < 0.0:
            raise ParameterError(f"floor_db={self.floor_db!r} must be < 0 (dB)")
        hits = self.max_hits_per_block
        hits = min(HITS_PER_BLOCK, self.max_pending) if hits is None else hits
        hits = check_int("max_hits_per_block", hits, 1, self.max_pending, "impacts")
        self._set("max_hits_per_block", hits)
        if self.max_frequency is not None:
            top = checks.positive("max_frequency", self.max_frequency, "Hz")
            if top > 0.5 * self.samplerate:
                raise ParameterError(
                    f"max_frequency={self.max_frequency!r} must be <= the Nyquist "
                    f"frequency {0.5 * self.samplerate:g} Hz"
                )
            self._set("max_frequency", top)
        self._check_lookahead()
        self._set("callback", checks.choice("callback", self.callback, STREAM_CALLBACKS))
        if self.on_device_lost is not None and not callable(self.on_device_lost):
            raise ParameterError(f"on_device_lost={self.on_device_lost!r} must be None or callable")
        if self.callback == "native" and CLOCK < 0:
            raise ParameterError(
                "callback='native' needs a POSIX monotonic clock, which this platform lacks: "
                "use callback='python'"
            )
        if self.max_total_voices is not None:
            total = check_int("max_total_voices", self.max_total_voices, 1, 65536, "voices")
            self._set("max_total_voices", total)

    def _set(self, name: str, value) -> None:
        object.__setattr__(self, name, value)

    def _check_lookahead(self) -> None:
        if self.lookahead is not None:
            self._set("lookahead", checks.positive("lookahead", self.lookahead, "s"))
        frames, lo, hi = self.lookahead_frames(), min_delay(), self.blocksize
        if self.limiter and not lo <= frames <= hi:
            raise ParameterError(
                f"lookahead={self.lookahead!r} s is {frames} frames at samplerate="
                f"{self.samplerate} Hz with blocksize={self.blocksize}; it must be in "
                f"[{lo}, {hi}] frames (at least the interpolator's reach and a "
                f"{MIN_ATTACK}-frame attack, at most one block)"
            )

    def lookahead_frames(self) -> int:
        """The limiter's look-ahead, frames (default ``LOOKAHEAD`` or one block if shorter)."""
        if self.lookahead is None:
            return min(int(round(LOOKAHEAD * self.samplerate)), self.blocksize)
        return int(round(self.lookahead * self.samplerate))

    def frames(self, seconds: float) -> int:
        """``seconds`` (s) in frames at the engine's rate, at least 1."""
        return max(1, int(round(seconds * self.samplerate)))

    def limiter_state(self) -> LimiterState | None:
        """The limiter's arrays, or None without ``limiter``."""
        if not self.limiter:
            return None
        ceiling = 10.0 ** (self.ceiling_db / 20.0)
        return LimiterState(channels=self.channels, delay=self.lookahead_frames(),
                            ceiling=ceiling, samplerate=self.samplerate)  # fmt: skip


def _latency(latency):
    if isinstance(latency, str):
        try:
            latency = float(latency)
        except ValueError:
            return checks.choice("latency", latency, LATENCIES)
    return checks.in_range("latency", latency, 0.0, 10.0, "s", hi_open=False)


@dataclass(frozen=True)
class BodySettings:
    """A body's (one ear's) mixing: ``gain`` (linear), ``voices`` slots, ``pan`` in [-1, 1]
    (NaN: unpanned), output ``channel`` (-1: all) and the ``ears`` its voices ring at."""

    gain: float = 1.0
    voices: int = 1
    pan: float = math.nan
    channel: int = -1
    ears: int = 1


class EngineState:
    """The arrays the audio thread works on, allocated once from the engine's ``options``
    (``roller``: the rolling block's address or 0)."""

    def __init__(self, options: EngineOptions, roller: int = 0, events: int = 4096):
        o = options
        fs, channels, mix_frames = o.samplerate, o.channels, max(o.blocksize, MIX_FRAMES)
        record_frames = int(round(o.record_seconds * fs))
        self.floor = 10.0 ** (o.floor_db / 20.0)
        self.steal_frames = o.frames(STEAL_FADE)
        self.ctl, self.times = np.zeros(N_CTL, dtype=np.int64), np.zeros(N_TIMES)
        # the body records' addresses, and each body's share of a callback's pulse transforms
        self.directory, self.allow = np.zeros((2, o.max_bodies), dtype=np.int64)
        self.mix, self.scratch = np.zeros((channels + 1, mix_frames)), np.zeros((2, mix_frames))
        # the voice-ended events: the kernel's header, then a ring of ``events``
        self.events = np.zeros(kernel.N_EVENT_HEADER + events, dtype=np.int64)
        self.recording = np.zeros((record_frames, channels), dtype=np.float32)
        self.records: list = []  # the bodies' records and arrays, kept alive here
        self.limiter = limit = o.limiter_state()
        c, t = self.ctl, self.times
        arrays = (self.directory, self.allow, self.mix, self.scratch, self.events, self.recording)
        c[[DIRECTORY, ALLOW, MIX, SCRATCH, EVENTS, RECORD]] = [touch(a).ctypes.data for a in arrays]
        sizes = (self.events.shape[0], o.max_bodies, channels, mix_frames, record_frames)
        c[[N_EVENTS, MAX_BODIES, CHANNELS, MIX_CAP, RECORD_FRAMES]] = sizes
        c[[TIMES, TRANSFORM_BUDGET, CLIP]] = (t.ctypes.data, o.max_hits_per_block, o.clip)
        c[[FADE_AT, FADE_LENGTH, FADE_FRAME, ROLLER]] = (-1, o.frames(o.fade), -1, roller)
        if limit is not None:
            c[LIMIT] = 1
            lim = [a.ctypes.data for a in limit.arrays()]
            c[[LIM_INTS, LIM_FLOATS, LIM_TAPS, LIM_X, LIM_R, LIM_M]] = lim
            t[LIMIT_DELAY] = limit.delay / fs
        t[[SAMPLERATE, MASTER_GAIN, MASTER_NOW, PAUSE_LEVEL]] = (fs, 1.0, 1.0, 1.0)
        # the record a removed body's entry points to: no voice or pending slot, asleep
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

    def add_body(self, coefficients, gains, ring, settings: BodySettings, rolls=None) -> int:
        """Publish a body to the audio thread (:meth:`body_arrays`): its record is written,
        then counted. Returns its index in :attr:`records`."""
        arrays = self.body_arrays(coefficients, gains, ring, settings, rolls)
        n = int(self.ctl[N_BODIES])
        index = next((i for i, r in enumerate(self.records) if r is None), n)
        if index >= self.directory.shape[0]:
            raise IndexError(n)
        record = np.zeros(N_BODY, dtype=np.int64)
        for i, name in enumerate(BODY_FIELDS):
            value = arrays[name]
            if isinstance(value, np.ndarray):
                if not value.flags.c_contiguous:
                    raise ValueError(f"{name} must be C-contiguous")
                record[i] = touch(value).ctypes.data  # no page fault on the audio thread
            else:
                record[i] = int(value)
        if index == n:
            self.records.append(None)
        self.records[index] = (record, arrays)
        self.directory[index] = record.ctypes.data  # a removed body's entry: mixed from now on
        if index == n:
            self.ctl[N_BODIES] = n + 1  # last: the callback mixes the body from now on
        return index

    def body_arrays(self, coefficients, gains, ring, settings: BodySettings, rolls=None) -> dict:
        """A body's arrays and sizes by :data:`BODY_FIELDS` name: its bank ``coefficients``,
        the listener's complex ``gains`` (K,), its pending ``ring`` (:mod:`synth.live.voice`),
        ``settings`` and rolling slots (None: none)."""
        from synth.sound.modal_bank import power_table, transform_workspace

        c, s = coefficients, settings
        fs, K = float(c.samplerate), c.poles.size
        poles = np.ascontiguousarray(c.poles, dtype=np.complex128)
        heard, heard_seq = heard_arrays(np.asarray(gains, dtype=complex))
        voice_slots = np.zeros((s.voices, kernel.N_SLOT_FIELDS), dtype=np.int64)
        voice_slots[:, kernel.SL_OWNER] = -1
        counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
        counters[[kernel.EARS, kernel.STEAL_FRAMES]] = (s.ears, self.steal_frames)
        tail = np.zeros(self.mix.shape[1] + self.steal_frames)
        scalars = np.zeros(N_SCALARS)
        fields = [S_FS, S_FLOOR, S_SIGMA_MAX, S_PERIOD, S_GAIN, S_GAIN_NOW, S_PAN, S_PAN_NOW]
        scalars[fields] = (fs, self.floor, c.sigma_max, 1.0 / fs, s.gain, s.gain, s.pan, s.pan)
        work, table = transform_workspace(K), power_table(poles, fs)
        if rolls is None:
            rolls = rolling_block.rolling_arrays(0, K, 2, 1)
        return rolls | kernel.body_state(K, s.voices) | dict(
            table=table, poles=poles, state=ring.state, inject=ring.inject, first=ring.first,
            length=ring.length, amplitudes=ring.amplitudes, response=ring.response,
            reference=ring.reference, counters=counters,
            pole_re=np.ascontiguousarray(c.pole_re), pole_im=np.ascontiguousarray(c.pole_im),
            step_re=np.ascontiguousarray(c.step_re), step_im=np.ascontiguousarray(c.step_im),
            work=work, coefficients=ring.coefficients, samples=ring.samples, points=ring.points,
            pulse=ring.pulse, transformed=ring.transformed, scalars=scalars,
            modes=K, slots=ring.capacity, contact=ring.max_contact,
            pulse_samples=ring.pulse_samples, work_rows=work.shape[0], table_cols=table.shape[2],
            channel=s.channel, voice=ring.voice, voices=ring.voices, voice_gain=ring.voice_gain,
            voice_slots=voice_slots, slot_gain=np.ones((s.voices, 2)), tail=tail,
            n_records=ring.voices.shape[0], n_voice_slots=s.voices, tail_frames=tail.shape[0],
            heard=heard, heard_seq=heard_seq,
            heard_coef=np.zeros((2, K)), heard_amps=np.zeros(K, dtype=complex),
        )  # fmt: skip

    def vacate(self, index: int) -> tuple[int, int]:
        """Point body ``index``'s directory entry at the vacant record (one atomic word);
        returns the mixing's progress (next frame, callbacks) for :meth:`left`."""
        progress = int(self.ctl[FRAME]), int(self.ctl[CALLBACKS])
        self.directory[index] = self.vacant.ctypes.data
        return progress

    def left(self, progress: tuple[int, int]) -> bool:
        """Whether every block that may have read the entry :meth:`vacate` changed has ended."""
        return int(self.ctl[FRAME]) > progress[0] or int(self.ctl[CALLBACKS]) > progress[1]

    def anchor(self) -> tuple[int, float, float]:
        """The last callback's first frame, the monotonic time (s) it leaves the device and the
        callbacks so far, read consistently under the callback's sequence number."""
        c, t = self.ctl, self.times
        while True:
            seq = int(c[SEQ])
            frame, dac = float(t[ANCHOR_FRAME]), float(t[ANCHOR_DAC])
            if seq % 2 == 0 and int(c[SEQ]) == seq:
                return frame, dac, seq // 2
