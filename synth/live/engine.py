"""A live engine: an always open output stream that plays physical impacts as they happen
(docs/live.md). Its callback is compiled code with no Python, allocation or lock
(:mod:`synth.live.native`); :meth:`Engine.process` runs the same mixing without a device.
Levels are the listener's physical signal at the calibration of ``normalize="physical"``.
"""

from __future__ import annotations

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
from synth.live.bookkeeping import EngineBookkeeping, watch_device
from synth.live.hits import MAX_GAIN, check_int, closed
from synth.live.limiter import LOOKAHEAD, MIN_ATTACK, LimiterState, min_delay
from synth.live.rolling import MAX_ROLLS
from synth.live.stats import EngineStats
from synth.live.stream import CLOSE_TIMEOUT, check_device, close_stream, open_stream
from synth.live.voice import MAX_VOICES, STEAL_FADE, Voice, VoiceLimit
from synth.physics.scene import Microphone, Plate, Scene
from synth.sound.modal_bank import PULSE_POINTS
from synth.sound.radiation.fixed import GridTooLarge
from synth.sound.render import listener_grid, modal_model

__all__ = ["Body", "Engine", "EngineStats", "Voice", "ears"]

#: The stream callbacks: compiled code without Python, or a Python fallback.
CALLBACKS = ("native", "python")
#: Longest output ``process`` mixes in one call and ``record_seconds`` keeps, s.
MAX_SECONDS = 600.0
#: Default room in the body directory the audio thread reads.
MAX_BODIES = 256
#: Latency settings PortAudio takes by name (else a positive number of seconds).
LATENCIES = ("low", "high")
#: Default bound on the hits a callback transforms (``max_hits_per_block``).
HITS_PER_BLOCK = 16
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
    """An always open output stream that mixes the ringing of every :class:`Body`;
    docs/live.md states each setting at length. Keyword parameters:

    - ``samplerate`` Hz in [8000, 384000]; ``blocksize`` frames per callback in [16, 8192]
      (also :meth:`process`'s step); ``device`` a PortAudio output index or name (None: the
      default); ``latency`` "low", "high" or s > 0; ``channels`` in [1, 64] (a body of one
      listener plays on every channel, panned by :attr:`Body.pan` with two; one listener per
      channel, :func:`ears`, is heard on each its own).
    - ``floor_db`` < 0: each body's omission floor below its loudest impact; ``max_pending``
      impacts a body holds, in [1, 4096]; ``max_hits_per_block`` in [1, max_pending] (default
      ``min(HITS_PER_BLOCK, max_pending)``): hits a callback transforms, the others wait;
      ``max_frequency`` Hz, at most Nyquist (default Nyquist); ``pulse_points`` >= 5 (as the
      renderer's, :mod:`synth.sound.modal_bank`).
    - ``fade`` s in [0.001, 1] (:meth:`stop`); ``handover`` s in [0, 0.1] added to a hit's
      default start; ``record_seconds`` in [0, MAX_SECONDS] kept in :attr:`recording`.
    - ``master_gain_db`` in [-120, 40] (settable, ramped over a block); ``clip``: soft-clip
      the master bus above -1 dBFS; ``limiter``: a true-peak limiter before the clipper, at
      ``ceiling_db`` in [-20, 0] dBFS, ``lookahead`` s in [``min_delay()`` frames, one block]
      (None: ``LOOKAHEAD`` or one block if shorter).
    - ``callback``: "native" (compiled, no Python) or "python" (holds the GIL each block).
    - ``max_bodies`` in [1, 65536]; ``max_voices`` per body in [1, 256] (a new voice steals
      the lowest priority's, of those the oldest, :class:`Voice`); ``max_rolls`` per body in
      [0, 16] (0: the rolling block is never compiled); ``max_total_voices`` in [1, 65536]
      or None (:class:`~synth.live.voice.VoiceLimit`).
    - ``on_device_lost(reason)``: called once on the watchdog thread when a running stream's
      device is lost (no callback for ``DEVICE_LOST`` s or 10 blocks)."""

    def __init__(
        self,
        *,
        samplerate: int,
        blocksize: int = 256,
        device=None,
        latency="low",
        channels: int = 1,
        floor_db: float = -80.0,
        max_pending: int = 128,
        max_hits_per_block: int | None = None,
        max_frequency: float | None = None,
        pulse_points: int = PULSE_POINTS,
        fade: float = 0.01,
        handover: float = 0.002,
        record_seconds: float = 0.0,
        master_gain_db: float = 0.0,
        clip: bool = True,
        limiter: bool = False,
        ceiling_db: float = -1.0,
        lookahead: float | None = None,
        callback: str = "native",
        max_bodies: int = MAX_BODIES,
        max_voices: int = MAX_VOICES,
        max_total_voices: int | None = None,
        on_device_lost=None,
        max_rolls: int = MAX_ROLLS,
    ):
        self.samplerate = check_int("samplerate", samplerate, 8000, 384000, "Hz")
        self.blocksize = check_int("blocksize", blocksize, 16, 8192, "frames")
        if device is not None and (isinstance(device, bool) or not isinstance(device, (int, str))):
            raise ParameterError(f"device={device!r} must be None, a device index or a device name")
        self.device = device
        if isinstance(latency, str):
            try:
                latency = float(latency)
            except ValueError:
                checks.choice("latency", latency, LATENCIES)
        if not isinstance(latency, str):
            latency = checks.in_range("latency", latency, 0.0, 10.0, "s", hi_open=False)
        self.latency_setting = latency
        self.channels = check_int("channels", channels, 1, 64, "channels")
        db = checks.real("floor_db", floor_db, "dB", "< 0")
        if not db < 0.0:
            raise ParameterError(f"floor_db={floor_db!r} must be < 0 (dB)")
        self.floor = 10.0 ** (db / 20.0)
        self.max_pending = check_int("max_pending", max_pending, 1, 4096, "impacts")
        if max_hits_per_block is None:
            max_hits_per_block = min(HITS_PER_BLOCK, self.max_pending)
        self.max_hits_per_block = check_int(
            "max_hits_per_block", max_hits_per_block, 1, self.max_pending, "impacts"
        )
        self.pulse_points = check_int("pulse_points", pulse_points, 5, 100_000, "points")
        self.max_frequency = None
        if max_frequency is not None:
            self.max_frequency = checks.positive("max_frequency", max_frequency, "Hz")
            if self.max_frequency > 0.5 * self.samplerate:
                raise ParameterError(
                    f"max_frequency={max_frequency!r} must be <= the Nyquist "
                    f"frequency {0.5 * self.samplerate:g} Hz"
                )
        fade_s = closed("fade", fade, 0.001, 1.0, "s")
        self.handover = closed("handover", handover, 0.0, 0.1, "s")
        rec = closed("record_seconds", record_seconds, 0.0, MAX_SECONDS, "s")
        if not isinstance(clip, bool):
            raise ParameterError(f"clip={clip!r} must be True or False")
        limit = self._limiter_state(limiter, ceiling_db, lookahead)
        self.callback = checks.choice("callback", callback, CALLBACKS)
        if on_device_lost is not None and not callable(on_device_lost):
            raise ParameterError(f"on_device_lost={on_device_lost!r} must be None or callable")
        self._on_device_lost = on_device_lost
        self._device_lost: str | None = None  # why, once the watchdog found it lost
        if self.callback == "native" and not st.native_available():
            raise ParameterError(
                "callback='native' needs a POSIX monotonic clock, which this platform lacks: "
                "use callback='python'"
            )
        max_bodies = check_int("max_bodies", max_bodies, 1, 65536, "bodies")
        self.max_voices = check_int("max_voices", max_voices, 1, 256, "voices")
        self.max_rolls = check_int("max_rolls", max_rolls, 0, 16, "rolling voices")
        if max_total_voices is not None:
            max_total_voices = check_int("max_total_voices", max_total_voices, 1, 65536, "voices")
        self.max_total_voices = max_total_voices
        self._voice_limit = VoiceLimit(max_total_voices)
        self._fade = fade_s
        self._steal_frames = max(1, int(round(STEAL_FADE * self.samplerate)))
        roller = _compile_the_block(rolling=self.max_rolls > 0)
        self._native = st.EngineState(
            samplerate=self.samplerate, channels=self.channels, max_bodies=max_bodies,
            mix_frames=max(self.blocksize, 4096), record_frames=int(round(rec * self.samplerate)),
            fade_frames=max(1, int(round(fade_s * self.samplerate))), clip=clip,
            transforms_per_block=self.max_hits_per_block, events=EVENT_CAPACITY, limit=limit,
            roller=roller,
        )  # fmt: skip
        self.master_gain_db = master_gain_db
        self._bodies: tuple[Body, ...] = ()
        self._stream = None
        self._closer = None
        self._state = "idle"  # idle <-> running; failed for good
        self._failure: str | None = None
        self._drops_refused = 0
        # removed bodies: ringing out (body, None), or vacated (body, the mixing's progress)
        self._retiring: list = []
        self._retired_counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
        self._retired_refused = 0  # impacts refused by removed bodies' rings
        self._reap_lock = threading.Lock()  # between the game's threads, never waited on
        self._too_close = 0
        self._next_voice_id = itertools.count(1).__next__  # atomic under the GIL
        self._events_lock = threading.Lock()  # between readers of ended()
        # the fixed radiation grids of the plates whose listener moved (Body.move), kept
        # while a body of the plate holds its own reference
        self._grids: weakref.WeakValueDictionary = weakref.WeakValueDictionary()
        self._grids_lock = threading.Lock()  # between the game's threads moving listeners
        self._too_large_for_grids: set = set()  # plates whose grids exceed their budget
        self._partial_events: dict = {}  # id -> ears that ended it, of a body of several

    def _limiter_state(self, limit, ceiling_db, lookahead) -> LimiterState | None:
        if not isinstance(limit, bool):
            raise ParameterError(f"limiter={limit!r} must be True or False")
        ceiling = closed("ceiling_db", ceiling_db, -20.0, 0.0, "dBFS")
        if lookahead is None:
            frames = min(int(round(LOOKAHEAD * self.samplerate)), self.blocksize)
        else:
            frames = int(round(checks.positive("lookahead", lookahead, "s") * self.samplerate))
        lo, hi = min_delay(), self.blocksize
        if limit and not lo <= frames <= hi:
            raise ParameterError(
                f"lookahead={lookahead!r} s is {frames} frames at samplerate="
                f"{self.samplerate} Hz with blocksize={self.blocksize}; it must be in "
                f"[{lo}, {hi}] frames (at least the interpolator's reach and a "
                f"{MIN_ATTACK}-frame attack, at most one block)"
            )
        if not limit:
            return None
        return LimiterState(
            channels=self.channels,
            delay=frames,
            ceiling=10.0 ** (ceiling / 20.0),
            samplerate=self.samplerate,
        )

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
        if several:
            listeners = tuple(listener)
            if self.channels < 2 or len(listeners) != self.channels:
                raise ParameterError(
                    f"listener: a sequence of {len(listeners)} listeners needs an Engine with "
                    f"as many channels (one listener per channel, at least 2); "
                    f"channels={self.channels}"
                )
            if not isinstance(plate, Plate):
                raise ParameterError(f"plate={plate!r} must be a Plate when listeners are given")
        else:
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
            listeners = (listener,)
        for i, li in enumerate(listeners):
            check_listener(plate, li, f"listener[{i}]" if several else "listener")
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
            channel = c if several else -1
            ears_.append(Body(self, plate, li, g, model, channel, len(listeners), voices, panned))
        body = ears_[0]
        body.listener = listeners if several else listener
        body._ears = ears_
        self._bodies = self._bodies + (body,)
        return body

    @property
    def master_gain_db(self) -> float:
        """The master bus' gain, dB in [-120, 40]; a change is ramped over the next block."""
        return 20.0 * float(np.log10(self._native.times[st.MASTER_GAIN]))

    @master_gain_db.setter
    def master_gain_db(self, value: float) -> None:
        db = closed("master_gain_db", value, -120.0, 40.0, "dB")
        self._native.times[st.MASTER_GAIN] = 10.0 ** (db / 20.0)

    def move_listener(self, position, facing=(1.0, 0.0)) -> None:
        """Move every body's listener to ``position`` ((x, y, z), m, z > 0) from the next block
        (:meth:`Body.move`); two ears face ``facing`` ((x, y)), more move by one displacement."""
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
        """Build now (at a game's load time) the fixed radiation grids each microphone-heard
        plate's moves take their gains from; else its first move builds them."""
        for body in self.bodies:
            if body.removed or body.units != "Pa":
                continue
            for ear in body._ears:
                ear._grid = self._listener_grid(ear._model)

    def _listener_grid(self, model):
        """The fixed radiation grids of ``model``'s plate, shared by its bodies; None beyond
        :data:`~synth.sound.radiation.fixed.MAX_GRID_BYTES` (its moves take the exact rule)."""
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
        """Fade out over ``fade`` s, then hold the clock and every voice (the stream writes
        silence) until :meth:`resume`."""
        self._native.ctl[st.PAUSE] = 1

    def resume(self) -> None:
        """Play on from where :meth:`pause` held the clock, fading in over ``fade`` s."""
        self._native.ctl[st.PAUSE] = 0

    def process(self, frames: int) -> np.ndarray:
        """Mix the next ``frames`` frames without a device, in blocks of ``blocksize``: float32
        (frames, channels), the samples the stream's callback would emit."""
        out = self._new_block(frames)
        if self.running:
            raise SynthError("process() mixes without a device: stop() the stream first")
        self._check_open("process")
        for a in range(
            0, out.shape[0], self.blocksize
        ):  # the callback's blocks, removed bodies reaped
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
        """Open the output stream and mix from the engine's clock where it stands; SynthError
        without PortAudio, sounddevice or a device that takes the engine's rate."""
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
                latency=self.latency_setting,
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
        # closes the stream if the engine is collected while it runs (the stream holds
        # nothing of the engine, only the addresses of the arrays the closer keeps)
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
        """Fade out, then close the stream within ``timeout`` s (>= 0) plus the fade, dropping
        every impact and voice; a server that does not answer marks the engine :attr:`failed`."""
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
    """``listeners`` (Microphones only) moved by one displacement, their centroid to
    ``position`` ((x, y, z), m)."""
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
