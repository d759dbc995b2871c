"""A live engine: an always open output stream that plays physical impacts as they happen
(docs/live.md). Its callback is compiled code with no Python, allocation or lock
(:mod:`synth.live.native`); :meth:`Engine.process` runs the same mixing without a device.
Levels are the listener's physical signal at the calibration of ``normalize="physical"``.
"""

from __future__ import annotations

import inspect
import itertools
import threading
import time
import weakref

import numpy as np

from synth import checks, cost
from synth.compilation import announce
from synth.errors import ParameterError, SynthError
from synth.live import kernel, native
from synth.live import state as st
from synth.live.body import DEFAULT_MICROPHONE_HEIGHT, Body, check_listener, check_pan, ears
from synth.live.bookkeeping import EngineBookkeeping, EngineStats, watch_device
from synth.live.state import MAX_SECONDS, BodySettings, EngineOptions
from synth.live.stream import CLOSE_TIMEOUT, check_device, close_stream, open_stream
from synth.live.voice import MAX_GAIN, Voice, VoiceLimit, check_int, closed
from synth.physics.scene import Microphone, Plate, Scene
from synth.sound.radiation.fixed import GridTooLarge
from synth.sound.render import listener_grid, modal_model

__all__ = ["Body", "Engine", "EngineStats", "Voice", "ears"]

#: Voice-ended events the engine holds for :meth:`Engine.ended` (more are counted lost).
EVENT_CAPACITY = 4096


def _compile_the_block(*, rolling: bool) -> int:
    """Compile (or load) the audio thread's code, and with ``rolling`` the rolling block;
    returns that block's address for ``ctl[ROLLER]`` (0: none)."""
    announce("live")
    if rolling:
        announce("live-rolling")
    native.warm_up(rolling=rolling)
    return native.rolling_block_code().address if rolling else 0


class Engine(EngineBookkeeping):
    """An always open output stream that mixes the ringing of every :class:`Body`, made with
    the keywords of :class:`EngineOptions` (docs/live.md states each): a body of one listener
    plays on every channel (panned by :attr:`Body.pan` with two), one listener per channel
    (:func:`ears`) is heard on each its own; ``callback="native"`` runs no Python."""

    def __init__(self, **settings):
        self.options = o = EngineOptions(**settings)
        self._device_lost: str | None = None  # why, once the watchdog found it lost
        self._voice_limit = VoiceLimit(o.max_total_voices)
        roller = _compile_the_block(rolling=self.max_rolls > 0)
        self._native = st.EngineState(o, roller, events=EVENT_CAPACITY)
        self.master_gain_db = o.master_gain_db
        self._bodies: tuple[Body, ...] = ()
        self._stream = None
        self._closer = None
        self._state = "idle"  # idle <-> running; failed for good
        self._failure: str | None = None
        self._drops_refused = 0
        # removed bodies: ringing out [body, None], or vacated [body, the mixing's progress]
        self._retiring: list = []
        self._retired_counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
        self._retired_refused = 0  # impacts refused by removed bodies' rings
        self._reap_lock = threading.Lock()  # between the game's threads, never waited on
        self._too_close = 0
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
        if self._native.bodies_held() + len(listeners) > room:
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
        """Start the master bus' peak meters (``stats.peak``, ``stats.output_peak``) anew."""
        self._native.times[st.PEAK] = 0.0
        self._native.times[st.OUT_PEAK] = 0.0
        if self._native.limiter is not None:
            self._native.limiter.reset_meter()

    def pause(self) -> None:
        """Fade out over ``fade`` s, then hold the clock and every voice until :meth:`resume`."""
        self._native.ctl[st.PAUSE] = 1

    def resume(self) -> None:
        """Play on from where :meth:`pause` held the clock, fading in over ``fade`` s."""
        self._native.ctl[st.PAUSE] = 0

    def process(self, frames: int) -> np.ndarray:
        """The next ``frames`` frames mixed without a device, in blocks of ``blocksize``: float32
        (frames, channels), as the stream's callback would emit them."""
        out = self._new_block(frames)
        if self.running:
            raise SynthError("process() mixes without a device: stop() the stream first")
        self._check_open("process")
        for a in range(0, out.shape[0], self.blocksize):  # the callback's blocks
            self.mix_into(out[a : a + self.blocksize])
        return out

    def mix_into(self, out: np.ndarray) -> np.ndarray:
        """Mix the next frames into ``out`` (a writeable C-contiguous float32 (frames, channels)
        array, overwritten), for hosts that own the audio callback; returns ``out``."""
        native.check_block(self._native.ctl, out)
        check_int("frames", out.shape[0], 0, int(MAX_SECONDS * self.samplerate), "frames")
        if self.running:
            raise SynthError("mix_into() mixes without the engine's stream: stop() it first")
        self._check_open("mix")
        native.mix_engine(self._native.ctl, out)
        if self._retiring:
            self._reap()
        return out

    def render_block(self, frames: int) -> np.ndarray:
        """The next ``frames`` frames as one block (:meth:`mix_into` of a new array)."""
        return self.mix_into(self._new_block(frames))

    def _new_block(self, frames: int) -> np.ndarray:
        limit = int(MAX_SECONDS * self.samplerate)
        n = check_int("frames", frames, 0, limit, f"frames, {MAX_SECONDS:g} s")
        return np.empty((n, self.channels), dtype=np.float32)

    def start(self) -> Engine:
        """Open the output stream, mixing from the engine's clock; SynthError without PortAudio,
        sounddevice or a device that takes the engine's rate."""
        if self.running:
            raise SynthError("the engine is already running")
        self._check_open("start")
        from synth.io.playback import sounddevice_module

        sd = sounddevice_module()
        info = check_device(sd, self.device, self.channels, self.samplerate)
        for body in self._bodies:  # hits queued without a stream: not bounded per block
            for ear in body._ears:
                native.transform_pending(ear._record)
        try:
            stream = open_stream(
                sd, self._native, self.callback, samplerate=self.samplerate,
                blocksize=self.blocksize, device=self.device, channels=self.channels,
                latency=self.options.latency,
            )  # fmt: skip
        except sd.PortAudioError as exc:
            raise SynthError(
                f"cannot open the output device {info['name']!r} at "
                f"{self.samplerate} Hz with {self.channels} channel(s): {exc}"
            ) from None
        times = self._native.times
        times[st.NOMINAL_LATENCY] = times[st.LEAD] = float(stream.latency)
        times[st.END_TIME] = st.monotonic()
        times[st.LAST_ENTRY] = 0.0  # the time stopped is not a gap
        ctl = self._native.ctl
        ctl[st.FADE_AT] = -1
        ctl[st.SEQ] = 0
        self._stream = stream
        # closes the stream if the engine is collected while it runs (the closer keeps the
        # arrays whose addresses the stream holds)
        self._closer = weakref.finalize(self, close_stream, stream, self._native, CLOSE_TIMEOUT)
        self._state = "running"
        self._device_lost = None
        stream.start()
        watch = threading.Thread(
            target=watch_device, args=(weakref.ref(self), stream), name="synth-watchdog",
            daemon=True,
        )  # fmt: skip
        watch.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Fade out, then close the stream within ``timeout`` s plus the fade, dropping every
        impact and voice; a server that does not answer marks the engine :attr:`failed`."""
        t = checks.nonnegative("timeout", timeout, "s")
        if not self.running:
            return
        ctl = self._native.ctl
        length = int(ctl[st.FADE_LENGTH])
        deadline = time.monotonic() + t + length / self.samplerate
        ctl[st.FADE_AT] = 0
        silent = self.paused and self._native.times[st.PAUSE_LEVEL] <= 0.0
        while not silent and ctl[st.FADE_AT] < length and time.monotonic() < deadline:
            time.sleep(0.002)
        self._closer.detach()
        done = close_stream(
            self._stream, self._native, max(0.0, deadline - time.monotonic()), abort=False
        )
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
        ctl[st.FADE_AT] = -1
        ctl[st.PAUSE] = 0  # a pause ends with the stream
        self._native.times[st.PAUSE_LEVEL] = 1.0
        for body in self._bodies:
            body._apply_silence()

    def __enter__(self) -> Engine:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


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
