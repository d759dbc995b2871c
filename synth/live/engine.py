"""A live engine: an always open output stream that plays physical impacts as they happen
(docs/live.md), its callback compiled code with no Python, allocation or lock
(:mod:`synth.live.native`); levels at the calibration of ``normalize="physical"``."""

from __future__ import annotations

import inspect
import itertools
import threading
import time
import weakref
from dataclasses import dataclass

import numpy as np

from synth import checks, cost
from synth.compilation import announce
from synth.errors import ParameterError, SynthError
from synth.live import kernel, native
from synth.live import state as st
from synth.live.body import DEFAULT_MICROPHONE_HEIGHT, Body, check_listener, check_pan, ears
from synth.live.kernel import fence
from synth.live.state import MAX_SECONDS, BodySettings, EngineOptions
from synth.live.voice import MAX_AHEAD, MAX_GAIN, Voice, VoiceLimit, check_int, closed
from synth.physics.scene import Microphone, Plate, Scene
from synth.sound.radiation.fixed import GridTooLarge
from synth.sound.render import listener_grid, modal_model

__all__ = ["Body", "Engine", "EngineStats", "Voice", "ears"]

#: Voice-ended events the engine holds for :meth:`Engine.ended` (more are counted lost).
EVENT_CAPACITY = 4096
#: s (or 10 blocks if longer) without a callback after which a stream's device is lost; how
#: often the watchdog looks, s; how long a collected running engine's finaliser waits for its
#: stream to close, s.
DEVICE_LOST = 0.5
WATCH_PERIOD = 0.05
CLOSE_TIMEOUT = 2.0
#: s between two of stop()'s looks at the fade beyond which its own thread was held up (the
#: process or machine stalled): the stream is then given its whole timeout again.
HELD_UP = 0.1
#: Streams whose server did not answer and their arrays, kept (freeing could crash them).
ABANDONED: list = []
#: :class:`EngineStats` fields read from ``ctl``, ``times`` and the bodies' counters.
_FROM_CTL = dict(callbacks=st.CALLBACKS, output_underflows=st.UNDERFLOWS, clipped=st.CLIPPED,
                 transforms_max=st.TRANSFORMS_MAX,
                 transforms_deferred=st.TRANSFORMS_DEFERRED)  # fmt: skip
_FROM_TIMES = dict(callback_max=st.COST_MAX, callback_last=st.COST_LAST,
                   callback_gap_max=st.GAP_MAX, peak=st.PEAK, output_peak=st.OUT_PEAK)  # fmt: skip
_FROM_COUNTERS = dict(impacts_played=kernel.PLAYED, impacts_late=kernel.LATE,
                      impacts_dropped=kernel.DROPPED)  # fmt: skip


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made (docs/live.md, "Stats"): callback costs in
    blocks, peaks in full scale 1, limiter figures in dB since a reset, ``silent_for`` in s."""

    callbacks: int
    output_underflows: int
    callback_mean: float
    callback_max: float
    callback_last: float
    callback_gap_max: float
    impacts_played: int
    impacts_refused: int
    drops_refused: int
    impacts_too_close: int
    impacts_late: int
    transforms_max: int
    transforms_deferred: int
    impacts_pending: int
    bodies_ringing: int
    voices_playing: int
    voices_stolen: int
    voices_refused: int
    impacts_dropped: int
    events_lost: int
    peak: float
    output_peak: float
    clipped: int
    limiter_reduction_db: float
    limiter_max_reduction_db: float
    limiter_active: int
    failed: str | None
    silent_for: float
    device_lost: bool


class Engine:
    """An always open output stream that mixes the ringing of every :class:`Body`, made with
    the keywords of :class:`EngineOptions` (docs/live.md states each): a body of one listener
    plays on every channel (panned by :attr:`Body.pan` with two), one listener per channel
    (:func:`ears`) is heard on each its own; ``callback="native"`` runs no Python."""

    def __init__(self, **settings):
        self.options = o = EngineOptions(**settings)
        self._device_lost: str | None = None  # why, once the watchdog found it lost
        self._voice_limit = VoiceLimit(o.max_total_voices)
        announce("live")
        if o.max_rolls > 0:
            announce("live-rolling")
        native.warm_up(rolling=o.max_rolls > 0)  # compiles (or loads) the audio thread's code
        roller = native.rolling_block_code().address if o.max_rolls > 0 else 0
        self._native = st.EngineState(o, roller, events=EVENT_CAPACITY)
        self.master_gain_db = o.master_gain_db
        self._bodies: tuple[Body, ...] = ()
        self._stream = self._closer = None
        self._state = "idle"  # idle <-> running; failed for good
        self._failure: str | None = None
        self._drops_refused = self._too_close = 0
        # removed bodies: ringing out [body, None], or vacated [body, the mixing's progress]
        self._retiring: list = []
        self._retired_counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
        self._retired_refused = 0  # impacts refused by removed bodies' rings
        self._reap_lock = threading.Lock()  # between the game's threads, never waited on
        self._next_voice_id = itertools.count(1).__next__  # atomic under the GIL
        self._events_lock = threading.Lock()  # between readers of ended()
        # the fixed radiation grids of plates whose listener moved, while a body holds them
        self._grids: weakref.WeakValueDictionary = weakref.WeakValueDictionary()
        self._grids_lock = threading.Lock()  # between the game's threads moving listeners
        self._too_large_for_grids: set = set()  # plates whose grids exceed their budget
        self._partial_events: dict = {}  # id -> ears that ended it, of a body of several

    def _budget(self, plate, listener, voices: int) -> int | None:
        """The radiation points a body's cost allows (:func:`synth.cost.check_body`)."""
        top = 0.5 * self.samplerate if self.max_frequency is None else self.max_frequency
        return cost.check_body(plate, listener, top, voices)

    def _exact_model(self, plate, listener, cut):
        return modal_model(plate, listener, samplerate=self.samplerate,
                           max_frequency=self.max_frequency, radiation_max_points=cut)  # fmt: skip

    def add(
        self,
        plate: Plate | Scene,
        *,
        listener=None,
        gain: float = 1.0,
        max_voices=None,
        pan: float | None = None,
    ) -> Body:
        """Add ``plate`` (or a :class:`synth.Scene`'s plate and listener) as a :class:`Body`
        heard by ``listener`` (default a microphone 0.2 m above the centre; a sequence: one
        per channel), at ``gain`` in (0, MAX_GAIN], ``max_voices`` in [1, 256] (default the
        engine's), ``pan`` in [-1, 1] or None (:attr:`Body.pan`); while the stream runs too.
        Its cost is held to a render's budget first (:func:`synth.cost.check_body`)."""
        voices = self.max_voices if max_voices is None else max_voices
        voices = check_int("max_voices", voices, 1, 256, "voices")
        several = isinstance(listener, (tuple, list))
        panned = check_pan(pan, self.channels, len(listener) if several else 1)
        plate, listeners = self._listeners(plate, listener)
        g = checks.positive_at_most("gain", gain, MAX_GAIN, "dimensionless")
        self._check_open("add a body")
        self._reap()
        room = self._native.directory.shape[0]
        held = sum(1 for r in self._native.records if r is not None)  # removed not counted
        if held + len(listeners) > room:
            raise ParameterError(
                f"the engine holds max_bodies={room} bodies (one per listener): no room for "
                f"{len(listeners)} more"
            )
        ears_ = []
        for c, li in enumerate(listeners):
            model = self._exact_model(plate, li, self._budget(plate, li, voices))
            settings = BodySettings(gain=g, voices=voices, pan=panned,
                                    channel=c if several else -1, ears=len(listeners))  # fmt: skip
            ears_.append(Body(self, plate, li, model, settings))
        body = ears_[0]
        body.listener = listeners if several else listeners[0]
        body._ears = ears_
        self._bodies = self._bodies + (body,)
        return body

    def _listeners(self, plate, listener) -> tuple[Plate, tuple]:
        """The plate and its listeners (one per channel, or one) of :meth:`add`, checked."""
        if isinstance(listener, (tuple, list)):
            listeners = tuple(listener)
            if self.channels < 2 or len(listeners) != self.channels:
                raise ParameterError(
                    f"listener: a sequence of {len(listeners)} listeners needs an Engine with "
                    f"as many channels (one listener per channel, at least 2); "
                    f"channels={self.channels}"
                )
            if not isinstance(plate, Plate):
                raise ParameterError(f"plate={plate!r} must be a Plate when listeners are given")
            for i, li in enumerate(listeners):
                check_listener(plate, li, f"listener[{i}]")
            return plate, listeners
        if isinstance(plate, Scene):
            if listener is not None:
                raise ParameterError(
                    "listener must be None when adding a Scene (the scene's listener is used)"
                )
            plate, listener = plate.plate, plate.listener
        if not isinstance(plate, Plate):
            raise ParameterError(f"plate={plate!r} must be a Plate or a Scene")
        if listener is None:
            cx, cy = plate.centre
            listener = Microphone((cx, cy, DEFAULT_MICROPHONE_HEIGHT))
        check_listener(plate, listener, "listener")
        return plate, (listener,)

    @property
    def bodies(self) -> tuple[Body, ...]:
        """The bodies the engine holds (a removed one until its arrays are let go)."""
        return self._bodies

    def _retire(self, body: Body) -> None:
        """Queue a removed ``body`` for its arrays to be let go once the mixing has left it."""
        self._retiring.append([body, None])
        self._reap()

    def _reap(self) -> None:
        """Vacate silent removed bodies from the directory, free those the mixing has left since.
        Never waits (a host's audio callback may call it)."""
        if not self._retiring or not self._reap_lock.acquire(blocking=False):
            return
        try:
            for item in list(self._retiring):
                body, progress = item
                if progress is None:
                    if not body.awake:
                        item[1] = [self._native.vacate(ear._index) for ear in body._ears]
                elif all(self._native.left(p) for p in progress):
                    self._retired_counters += body._counters
                    self._retired_refused += body._ring.refused
                    for ear in body._ears:  # let go of its arrays: its entry is free again
                        self._native.records[ear._index] = None
                    body._free()
                    self._bodies = tuple(b for b in self._bodies if b is not body)
                    self._retiring.remove(item)
        finally:
            self._reap_lock.release()

    def ended(self) -> list[int]:
        """The ids of the voices that ended (at every ear) since the last call, oldest first
        (``stats.events_lost`` counts a full ring's)."""
        self._reap()
        with self._events_lock:
            ev = self._native.events
            written = int(ev[kernel.E_WRITTEN])
            fence()  # the events before their count
            cap = ev.shape[0] - kernel.N_EVENT_HEADER
            ids = []
            for k in range(int(ev[kernel.E_READ]), written):
                vid, ears = divmod(int(ev[kernel.N_EVENT_HEADER + k % cap]), kernel.EVENT_EARS)
                if ears > 1:
                    seen = self._partial_events.pop(vid, 0) + 1
                    if seen < ears:
                        self._partial_events[vid] = seen
                        continue
                ids.append(vid)
            fence()  # done reading before the writer may reuse the room
            ev[kernel.E_READ] = written
            return ids

    @property
    def master_gain_db(self) -> float:
        """The master bus' gain, dB in [-120, 40]; a change is ramped over the next block."""
        return 20.0 * float(np.log10(self._native.times[st.MASTER_GAIN]))

    @master_gain_db.setter
    def master_gain_db(self, value: float) -> None:
        db = closed("master_gain_db", value, -120.0, 40.0, "dB")
        self._native.times[st.MASTER_GAIN] = 10.0 ** (db / 20.0)

    def move_listener(self, position, facing=(1.0, 0.0)) -> None:
        """Move every body's listener to ``position`` ((x, y, z), m, z > 0) (:meth:`Body.move`);
        two ears face ``facing`` ((x, y)), more move by one displacement."""
        position = checks.point("position", position, 3)
        checks.point("facing", facing, 2, "dimensionless")
        if not position[2] > 0.0:
            raise ParameterError(f"position.z={position[2]!r} must be > 0 (m above the plate)")
        for body in self.bodies:
            if body.removed:
                continue
            n = len(body._ears)
            if n == 1:
                body.move(Microphone(position))
            elif n == 2:
                body.move(ears(position, facing))
            else:
                body.move(_shifted(body.listener, position))

    def prepare_moves(self) -> None:
        """Build now (at load time) the fixed radiation grids microphone-heard plates' moves take
        their gains from; else a plate's first move builds them."""
        for body in self.bodies:
            if body.removed or body.units != "Pa":
                continue
            for ear in body._ears:
                ear._grid = self._listener_grid(ear._model)

    def _listener_grid(self, model):
        """The fixed radiation grids of ``model``'s plate, shared by its bodies; None beyond
        their memory budget (its moves take the exact rule)."""
        plate = model.modes.plate
        with self._grids_lock:
            grid = self._grids.get(plate)
            if grid is None and plate not in self._too_large_for_grids:
                try:
                    grid = listener_grid(model)
                except GridTooLarge:
                    self._too_large_for_grids.add(plate)  # the exact rule for its moves
                    return None
                self._grids[plate] = grid
        return grid

    @property
    def listener_grid_memory(self) -> int:
        """Bytes of the fixed radiation grids kept for moving listeners (one per plate)."""
        return sum(grid.nbytes for grid in list(self._grids.values()))

    def reset_meter(self) -> None:
        """Start the master bus' peak meters (``stats.peak``, ``stats.output_peak``) and the
        limiter's anew: from the next block while the stream runs (the callback alone writes
        them then), at once without it."""
        ask_meter_reset(self._native.ctl)
        if not self.running:
            native.restart_meters(self._native.ctl, self._native.times)

    def pause(self) -> None:
        """Fade out over ``fade`` s, then hold the clock and every voice until :meth:`resume`."""
        self._native.ctl[st.PAUSE] = 1

    def resume(self) -> None:
        """Play on from where :meth:`pause` held the clock, fading in over ``fade`` s."""
        self._native.ctl[st.PAUSE] = 0

    @property
    def paused(self) -> bool:
        """Whether :meth:`pause` was called (and :meth:`resume` not since)."""
        return bool(self._native.ctl[st.PAUSE])

    @property
    def running(self) -> bool:
        return self._state == "running"

    @property
    def failed(self) -> str | None:
        """Why the engine's stream failed (it then refuses everything), or None."""
        return self._failure

    @property
    def _frame(self) -> int:
        return int(self._native.ctl[st.FRAME])

    @property
    def time(self) -> float:
        """The next frame to be mixed, s on the engine's clock."""
        return self._frame / self.samplerate

    @property
    def recording(self) -> np.ndarray:
        """The first ``record_seconds`` of the output, float32 (frames, channels)."""
        return self._native.recording

    @property
    def recorded(self) -> int:
        """Frames of :attr:`recording` written so far."""
        return int(self._native.ctl[st.RECORDED])

    @property
    def latency(self) -> float:
        """The stream's output latency at the last callback, s (0 without a stream)."""
        return float(self._native.times[st.LEAD]) if self.running else 0.0

    def process(self, frames: int) -> np.ndarray:
        """The next ``frames`` frames mixed without a device, in blocks of ``blocksize``: float32
        (frames, channels), as the stream's callback would emit them."""
        out = self._new_block(frames, "process()")
        for a in range(0, out.shape[0], self.blocksize):  # the callback's blocks
            self._mix(out[a : a + self.blocksize])
        return out

    def mix_into(self, out: np.ndarray) -> np.ndarray:
        """Mix the next frames into ``out`` (a writeable C-contiguous float32 (frames, channels)
        array, overwritten), for hosts that own the audio callback; returns ``out``."""
        _check_block(out, self.channels)
        self._check_offline("mix_into()", out.shape[0])
        return self._mix(out)

    def render_block(self, frames: int) -> np.ndarray:
        """The next ``frames`` frames as one block (:meth:`mix_into` of a new array)."""
        return self._mix(self._new_block(frames, "render_block()"))

    def _check_offline(self, what: str, frames) -> int:
        """``frames`` checked (at most ``MAX_SECONDS``) for mixing without the stream."""
        limit = int(MAX_SECONDS * self.samplerate)
        n = check_int("frames", frames, 0, limit, f"frames, {MAX_SECONDS:g} s")
        if self.running:
            raise SynthError(f"{what} mixes without the engine's stream: stop() it first")
        self._check_open("mix")
        return n

    def _new_block(self, frames: int, what: str) -> np.ndarray:
        n = self._check_offline(what, frames)
        return np.empty((n, self.channels), dtype=np.float32)

    def _mix(self, out: np.ndarray) -> np.ndarray:
        native.mix_engine(self._native.ctl, out)
        if self._retiring:
            self._reap()
        return out

    def start(self) -> Engine:
        """Open the output stream, mixing from the engine's clock; SynthError without PortAudio,
        sounddevice or a device that takes the engine's rate."""
        if self.running:
            raise SynthError("the engine is already running")
        self._check_open("start")
        from synth.io.playback import sounddevice_module

        sd = sounddevice_module()
        info = _check_device(sd, self.device, self.channels, self.samplerate)
        for body in self._bodies:  # hits queued without a stream: not bounded per block
            for ear in body._ears:
                native.transform_pending(ear._record)
        try:
            stream = _open_stream(
                sd, self._native, self.callback, samplerate=self.samplerate,
                blocksize=self.blocksize, device=self.device, channels=self.channels,
                latency=self.options.latency,
            )  # fmt: skip
        except sd.PortAudioError as exc:
            raise SynthError(
                f"cannot open the output device {info['name']!r} at "
                f"{self.samplerate} Hz with {self.channels} channel(s): {exc}"
            ) from None
        times, ctl = self._native.times, self._native.ctl
        times[st.NOMINAL_LATENCY] = times[st.LEAD] = float(stream.latency)
        times[st.END_TIME] = st.monotonic()
        times[st.LAST_ENTRY] = 0.0  # the time stopped is not a gap
        ctl[[st.FADE_AT, st.FADE_ASKED, st.SEQ]] = (-1, 0, 0)
        self._stream = stream
        # closes the stream if the engine is collected while it runs (the closer keeps the
        # arrays whose addresses the stream holds)
        self._closer = weakref.finalize(self, _close_stream, stream, self._native, CLOSE_TIMEOUT)
        self._state = "running"
        self._device_lost = None
        stream.start()
        threading.Thread(target=_watch_device, args=(weakref.ref(self), stream),
                         name="synth-watchdog", daemon=True).start()  # fmt: skip
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Fade out, then close the stream, dropping every impact and voice; a server that does
        not answer (no callback for ``timeout`` s plus the fade, counted while this thread
        runs) marks the engine :attr:`failed`."""
        t = checks.nonnegative("timeout", timeout, "s")
        if not self.running:
            return
        ctl = self._native.ctl
        length = int(ctl[st.FADE_LENGTH])
        patience = t + length / self.samplerate
        ask_fade(ctl)
        if self.paused and self._native.times[st.PAUSE_LEVEL] <= 0.0:
            left = patience  # silent already
        else:
            left = _await_fade(ctl, length, patience)
        self._closer.detach()
        done = _close_stream(self._stream, self._native, left, abort=False)
        self._stream = None  # its watchdog ends
        self._device_lost = None
        if not done:
            self._state = "failed"
            self._failure = (
                f"the audio server did not answer within timeout={timeout!r} s; the stream "
                f"was abandoned (make a new Engine)"
            )
            return
        self._state = "idle"
        ctl[[st.FADE_AT, st.FADE_ASKED, st.PAUSE]] = (-1, 0, 0)  # a pause ends with the stream
        self._native.times[st.PAUSE_LEVEL] = 1.0
        for body in self._bodies:
            body._apply_silence()

    def __enter__(self) -> Engine:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def _check_open(self, what: str):
        if self._state == "failed":
            raise SynthError(f"cannot {what}: the engine's audio stream failed ({self._failure})")

    def _silent_for(self) -> float:
        """Seconds since the stream's last callback returned; 0 without a stream."""
        if not self.running:
            return 0.0
        return max(0.0, st.monotonic() - float(self._native.times[st.END_TIME]))

    def _lost(self) -> str | None:
        """Why the running stream's device is taken as lost, or None."""
        silent = self._silent_for()
        limit = max(DEVICE_LOST, 10 * self.blocksize / self.samplerate)
        if silent <= limit:
            return None
        return (
            f"the audio stream has not called back for {silent:.2f} s (more than {limit:g} "
            f"s): its device or audio server is gone; stop() the engine (stats.silent_for)"
        )

    def _check_alive(self) -> None:
        if why := self._lost():
            raise SynthError(why)

    def _onset(self, at) -> float:
        """A tick's start, s on the engine's clock: ``at`` (at most ``MAX_AHEAD`` s ahead), or one
        block plus the latency, look-ahead and ``handover`` from now (no stream: the next frame)."""
        self._check_open("play an impact")
        self._check_alive()
        if at is None:
            if not self.running:
                return (self._frame + self.blocksize) / self.samplerate
            times, fs = self._native.times, self.samplerate
            lead = times[st.LEAD] + times[st.LIMIT_DELAY]
            frame, dac, callbacks = self._native.anchor()
            if callbacks == 0:  # no callback yet: the stream starts with the next frame
                now = float(self._frame) - lead * fs
            else:  # the frame leaving the device now
                now = frame + (st.monotonic() - dac) * fs
            frame = now + self.blocksize + (lead + self.handover) * fs
            return max(frame, float(self._frame)) / self.samplerate
        t = checks.real("at", at, "s")
        earliest = self._frame / self.samplerate
        latest = earliest + MAX_AHEAD
        if (not self.running and t < earliest) or t < 0.0 or t > latest:
            lo = earliest if not self.running else 0.0
            raise ParameterError(
                f"at={at!r} must be in [{lo!r}, {latest!r}] s (the engine's clock: from "
                f"{'its next frame' if not self.running else '0'} to {MAX_AHEAD:g} s after "
                f"Engine.time)"
            )
        return t

    @property
    def stats(self) -> EngineStats:
        self._reap()
        # a body heard by several listeners counts its first's
        counts = self._retired_counters + sum(b._counters for b in self._bodies)
        c, t, lim = self._native.ctl, self._native.times, self._native.limiter
        read = (
            {name: int(c[i]) for name, i in _FROM_CTL.items()}
            | {name: float(t[i]) for name, i in _FROM_TIMES.items()}
            | {name: int(counts[i]) for name, i in _FROM_COUNTERS.items()}
        )
        n = read["callbacks"]
        return EngineStats(
            **read,
            callback_mean=float(t[st.COST_SUM]) / n if n else 0.0,
            impacts_refused=self._retired_refused + sum(b._ring.refused for b in self._bodies),
            drops_refused=self._drops_refused,
            impacts_too_close=self._too_close,
            impacts_pending=sum(b.pending for b in self._bodies),
            bodies_ringing=sum(b.ringing for b in self._bodies),
            voices_playing=sum(b.voices_playing for b in self._bodies),
            voices_stolen=int(counts[kernel.STOLEN]) + self._voice_limit.stolen,
            voices_refused=self._voice_limit.refused + int(counts[kernel.REFUSED]),
            events_lost=int(self._native.events[kernel.E_LOST]),
            limiter_reduction_db=lim.reduction_db if lim else 0.0,
            limiter_max_reduction_db=lim.max_reduction_db if lim else 0.0,
            limiter_active=lim.active_frames if lim else 0,
            failed=self._failure,
            device_lost=self._device_lost is not None,
            silent_for=self._silent_for(),
        )


def _shifted(listeners, position) -> tuple:
    """``listeners`` (Microphones) moved by one displacement, their centroid to ``position``."""
    for i, li in enumerate(listeners):
        if not isinstance(li, Microphone):
            raise ParameterError(
                f"listener[{i}]={li!r}: move_listener moves microphones only; use body.move"
            )
    points = np.array([li.position for li in listeners], dtype=float)
    moved = points + (np.asarray(position, dtype=float) - points.mean(axis=0))
    for i, p in enumerate(moved):
        if not p[2] > 0.0:
            raise ParameterError(
                f"listener[{i}] would be at z={p[2]!r} m: an ear must stay above the plate"
            )
    return tuple(Microphone(tuple(float(v) for v in p)) for p in moved)


Engine.__init__.__signature__ = inspect.Signature(
    [inspect.Parameter("self", inspect.Parameter.POSITIONAL_ONLY)]
    + checks.keyword_parameters(EngineOptions)
)


def _option(name: str) -> property:
    return property(lambda engine: getattr(engine.options, name), doc=f"``options.{name}``")


#: The options an engine is read by, attributes of its own as well (read-only).
for _name in ("samplerate", "blocksize", "device", "channels", "callback", "handover",
              "max_pending", "max_hits_per_block", "pulse_points", "max_frequency",
              "max_voices", "max_rolls", "max_total_voices"):  # fmt: skip
    setattr(Engine, _name, _option(_name))


def _watch_device(engine_ref, stream) -> None:
    """A running stream's watchdog: reports a lost device once (``on_device_lost``); holds the
    engine weakly and ends with the stream."""
    while True:
        engine = engine_ref()
        if engine is None or engine._stream is not stream:
            return
        why = engine._lost()
        if why is not None:
            engine._device_lost = why
            callback = engine.options.on_device_lost
            del engine
            if callback is not None:
                callback(why)
            return
        del engine
        time.sleep(WATCH_PERIOD)


def _check_device(sd, device, channels: int, samplerate: int) -> dict:
    """PortAudio's output ``device`` (None: default), checked for ``channels`` float32
    channels at ``samplerate`` Hz (else SynthError)."""
    try:
        info = sd.query_devices(device, kind="output")
    except (ValueError, sd.PortAudioError) as exc:
        raise SynthError(
            f"no audio output device{'' if device is None else f' {device!r}'} "
            f"({exc}); list the devices with `python -m sounddevice`, or render offline "
            f"with Engine.process()"
        ) from None
    try:
        sd.check_output_settings(
            device=device, channels=channels, dtype="float32", samplerate=samplerate
        )
    except (ValueError, sd.PortAudioError) as exc:
        raise SynthError(
            f"the output device {info['name']!r} does not take {samplerate} Hz with "
            f"{channels} channel(s) ({exc}); its default rate is "
            f"{info['default_samplerate']:g} Hz: make the Engine at a rate it offers"
        ) from None
    return info


def _open_stream(sd, state, callback: str, **settings):
    """A PortAudio float32 output stream mixing ``state``: the compiled callback on its
    address, or Python (holding the arrays, not the engine) running the compiled block."""
    if callback == "python":
        ctl, time_info = state.ctl, np.zeros(3)  # adc, current and dac time, s

        def python_callback(outdata, frames, info, status):
            time_info[1:] = info.currentTime, info.outputBufferDacTime
            native.mix_engine(ctl, outdata, status._flags, time_info)

        return sd.OutputStream(callback=python_callback, dtype="float32", **settings)
    import cffi

    ffi = cffi.FFI()
    return sd._StreamBase(
        kind="output", wrap_callback=None, dtype="float32",
        callback=ffi.cast("void *", native.stream_callback().address),
        userdata=ffi.cast("void *", state.address), **settings,
    )  # fmt: skip


def ask_fade(ctl) -> None:
    """Ask the callback for the stop fade from its next block on. The callback alone writes
    the fade's position: a position written here while a block runs would be overwritten by
    the block's own at its end, and the fade never start."""
    ctl[st.FADE_ASKED] = 1


def ask_meter_reset(ctl) -> None:
    """Ask the callback to restart the meters at its next block's start
    (:func:`~synth.live.native.restart_meters`)."""
    ctl[st.METER_ASKED] += 1


def _await_fade(ctl, length: int, patience: float) -> float:
    """Wait until the stop fade (``length`` frames) has played, or the callback has not come for
    ``patience`` s; returns the time left of it, s. A look more than ``HELD_UP`` s after the last
    starts the count anew; the wait also ends once the stream has played the fade without its
    end, so it never waits on a stream that plays on."""
    seen, last = int(ctl[st.CALLBACKS]), time.monotonic()
    deadline = last + patience
    asked = frame = int(ctl[st.FRAME])
    block = 0
    while ctl[st.FADE_AT] < length:
        now, callbacks = time.monotonic(), int(ctl[st.CALLBACKS])
        if callbacks != seen:
            block, frame = max(block, int(ctl[st.FRAME]) - frame), int(ctl[st.FRAME])
            if frame - asked > length + 2 * block:
                break
        if callbacks != seen or now - last > HELD_UP:
            seen, deadline = callbacks, now + patience
        elif now >= deadline:
            break
        last = now
        time.sleep(0.002)
    return max(0.0, deadline - time.monotonic())


def _close_stream(stream, state, timeout: float, abort: bool = True) -> bool:
    """Stop (or abort) and close ``stream`` on a helper thread within ``timeout`` s (PortAudio
    can hang when the server is gone), else keep it for good. Returns whether it closed."""

    def close():
        try:
            stream.abort() if abort else stream.stop()
        finally:
            stream.close()

    worker = threading.Thread(target=close, name="synth-close-stream", daemon=True)
    worker.start()
    worker.join(timeout)
    if worker.is_alive():
        ABANDONED.append((stream, state))
        return False
    return True


def _check_block(out, channels: int) -> None:
    """``out`` checked: a writeable C-contiguous float32 (frames, channels) array."""
    if not (
        isinstance(out, np.ndarray)
        and out.dtype == np.float32
        and out.ndim == 2
        and out.shape[1] == channels
        and out.flags.c_contiguous
        and out.flags.writeable
    ):
        raise ParameterError(
            f"out={type(out).__name__} {getattr(out, 'dtype', '')} {getattr(out, 'shape', '')} "
            f"must be a writeable C-contiguous float32 array of shape (frames, {channels})"
        )
