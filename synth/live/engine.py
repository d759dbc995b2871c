"""A live engine: an always open output stream that plays physical impacts as they happen.

``Engine`` owns one ``sounddevice.OutputStream`` whose callback mixes every body;
``Engine.process(frames)`` runs the very same mixing without a device. A body is one
plate heard by one listener: one modal state (:class:`~synth.sound.render.ModalModel`,
the offline renderer's), which every impact on it excites, so any number of balls on one
table cost one modal bank. ``Body.hit`` solves the contact on the calling thread and hands
its force pulse to the audio thread through a bounded ring (:mod:`synth.live.queue`); the
callback calls one compiled kernel per body per block (:mod:`synth.live.kernel`), which
first turns new pulses into the modes' amplitudes (the renderer's transform,
:func:`~synth.sound.modal_bank.transform_pulse`; at most ``max_hits_per_block`` a block)
and then advances the modes block by block from their state with the offline bank's own
steps. ``Body.drop`` computes its impacts' amplitudes on the calling thread
(:func:`~synth.sound.modal_bank.impact_excitation`) and hands those over. So the hits
played live are ``synth.render`` of the same impacts, to float32 rounding.

Levels: the output is the listener's physical signal (Pa or m/s^2) scaled by the fixed
calibration of ``normalize="physical"`` (:data:`synth.io.audio.PHYSICAL_FULL_SCALE`),
times each body's and each hit's gain, so bodies and hits keep their true level relation.

The callback allocates no array (it mixes into a preallocated buffer and writes the
stream's), touches no file and takes no lock: a trigger thread never holds anything the
audio thread waits for, except, briefly, Python's GIL (hence a short switch interval while
the stream runs). A body with no ringing mode and nothing new handed over is skipped.

The engine's clock counts output frames from 0; ``Engine.time`` is the next frame to be
mixed, in seconds. A hit starts one block plus the stream's output latency after the call
(sub-sample exact, the same offset for every call, so there is no jitter), or at ``at``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.compilation import announce
from synth.constants import GRAVITY
from synth.errors import ParameterError, SynthError
from synth.io.audio import PHYSICAL_FULL_SCALE
from synth.live import kernel
from synth.live.queue import PendingRing
from synth.physics.bounces import simulate_bounces
from synth.physics.contact import ContactSolver
from synth.physics.scene import Accelerometer, Ball, Contact, Microphone, Plate
from synth.sound.modal_bank import (
    PULSE_POINTS,
    bank_coefficients,
    impact_excitation,
    power_table,
    pulse_layout,
    samples_in_contact,
)
from synth.sound.render import modal_model

#: Python's thread switch interval while a stream runs, s. The callback runs a little
#: Python around its kernels and needs the GIL: with the default 5 ms interval a trigger
#: thread running Python code can keep it waiting for about a block.
SWITCH_INTERVAL = 0.0002
#: Latency settings PortAudio takes by name (else a positive number of seconds).
LATENCIES = ("low", "high")
#: Longest contact a body takes, s (its in-contact samples are handed over in a slot).
MAX_CONTACT = 0.02
#: Longest contact whose pulse a hit hands to the audio thread as is, s; a longer one (a
#: soft ball) is turned into mode amplitudes on the calling thread. Sets the size of a
#: slot's pulse samples (a grid of at most ``MAX_SLOT_GRID`` points, and the in-contact
#: samples).
SLOT_CONTACT = 0.002
MAX_SLOT_GRID = 4097
#: Default bound on the hits a body takes between two blocks (``max_hits_per_block``).
HITS_PER_BLOCK = 16
#: Height (m) of the default microphone above the plate's centre (as a Scene's default).
DEFAULT_MICROPHONE_HEIGHT = 0.2
#: Relative accuracy of a hit's contact solution (restitution and contact time); a drop
#: uses a scene's default (:class:`synth.physics.scene.Contact`), as its impacts string
#: together.
HIT_RTOL = 1e-6
#: The contact law of a hit or a drop given none (Hertz).
DEFAULT_CONTACT = Contact()
#: Impact points (and balls' contact solvers) a body keeps prepared, the oldest dropped.
KEPT_POINTS = 64
#: Radius (m) of the ball of the hit that warms a new body's hit path up (not played).
WARM_UP_BALL_RADIUS = 0.005


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made.

    callbacks: blocks mixed by the stream's callback; output_underflows: callbacks that
    PortAudio flagged ``output_underflow`` (the device ran dry before); callback_mean,
    callback_max: the callback's run time as a fraction of its block's duration;
    impacts_played: impacts injected into a body's modes; impacts_refused: impacts refused
    because a body's ring of pending impacts was full; impacts_late: impacts found after
    their start time (played at the start of the block they were found in);
    impacts_pending: handed over and not yet played.
    """

    callbacks: int
    output_underflows: int
    callback_mean: float
    callback_max: float
    impacts_played: int
    impacts_refused: int
    impacts_late: int
    impacts_pending: int


@dataclass(frozen=True)
class _Prepared:
    """A body's excitation at one impact point: the bank coefficients and the
    accelerometer's direct-term line (0 for a microphone)."""

    coefficients: object
    mass_line: float


@dataclass(slots=True)
class _Trigger:
    """What a hit or a drop is made of, checked: the ball, its impact point (m), its gain,
    the contact law, gravity (m/s^2) and its start on the engine's clock (s)."""

    ball: Ball
    position: tuple[float, float]
    gain: float
    law: Contact
    gravity: float
    onset: float


class Body:
    """One plate in an :class:`Engine` (made by :meth:`Engine.add`): one modal state that
    every impact on it excites."""

    def __init__(self, engine: Engine, plate: Plate, listener, gain: float, model):
        self._engine = engine
        self.plate = plate
        self.listener = listener
        self.gain = gain
        self._model = model
        fs = engine.samplerate
        poles = np.ascontiguousarray(model.poles)
        K = poles.size
        self._scale = gain / PHYSICAL_FULL_SCALE[model.units]
        self._prepared: dict = {}
        self._solvers: dict = {}
        coefficients = self._prepare(plate.centre).coefficients
        grid = pulse_layout(SLOT_CONTACT, 0.0, coefficients.omega_max, fs, engine.pulse_points)
        self._ring = PendingRing(
            engine.max_pending,
            K,
            samples_in_contact(MAX_CONTACT, fs),
            min(grid.points, MAX_SLOT_GRID) + samples_in_contact(SLOT_CONTACT, fs),
            engine.max_hits_per_block,
        )
        self._counters = np.zeros(kernel.N_COUNTERS, dtype=np.int64)
        self._silence = False
        self._puts_seen = 0
        self._state_arrays = kernel.body_state(K)
        self._level = np.zeros(1)
        self._warm_up()
        self._kernel_args = kernel.body_kernel_args(
            coefficients,
            power_table(poles, float(fs)),
            self._state_arrays,
            self._level,
            engine.floor,
            self._ring,
            self._counters,
        )

    def _warm_up(self):
        """Run the hit path once (contact solver, pulse transforms: numba compiles or loads
        them at their first call), so that the first real hit takes microseconds."""
        ball = Ball(self.plate.material, WARM_UP_BALL_RADIUS)
        solver = ContactSolver.for_pair(ball, self.plate, rtol=HIT_RTOL)
        result = solver.solve(1.0, position=self.plate.centre)
        impact_excitation(self._prepare(self.plate.centre).coefficients, result, 0.0)

    def __repr__(self):
        return (
            f"Body(plate={self.plate!r}, listener={self.listener!r}, gain={self.gain!r}, "
            f"modes={self.modes})"
        )

    @property
    def modes(self) -> int:
        """Number of modes in the body's bank (below Nyquist)."""
        return int(self._model.poles.size)

    @property
    def units(self) -> str:
        """Physical units of the listener: "Pa" or "m/s^2"."""
        return self._model.units

    @property
    def pending(self) -> int:
        """Impacts handed over and not yet played."""
        return self._ring.pending()

    @property
    def awake(self) -> bool:
        """Whether the body rings or has impacts pending (a quiet body costs nothing)."""
        return bool(self._counters[kernel.AWAKE]) or self.pending > 0

    def _prepare(self, position) -> _Prepared:
        """The bank coefficients for impacts at ``position`` (checked; kept for the last
        ``KEPT_POINTS`` points)."""
        p = self._prepared.get(position)
        if p is None:
            excitation = self._model.excitation(position)
            direct = self._model.direct(excitation)
            coefficients = bank_coefficients(
                self._model.poles, excitation, self._model.output, self._engine.samplerate
            )
            p = _Prepared(coefficients, float(np.sum(direct.real)) if direct is not None else 0.0)
            if len(self._prepared) >= KEPT_POINTS:
                self._prepared.pop(next(iter(self._prepared)))
            self._prepared[position] = p
        return p

    def prepare(self, *positions) -> None:
        """Prepare impact points ahead of hits there (``(x, y)``, m from a plate corner):
        a hit at a point the body has not prepared evaluates every mode's shape there
        first (a fraction of a millisecond for a few hundred modes). The body keeps the
        last ``KEPT_POINTS`` points."""
        for position in positions:
            self._prepare(self._position(position))

    def _position(self, position) -> tuple[float, float]:
        return self.plate.check_position(
            self.plate.centre if position is None else position, "position"
        )

    def _check_ball(self, ball):
        if not isinstance(ball, Ball):
            raise ParameterError(f"ball={ball!r} must be a Ball")
        if 2.0 * ball.radius > min(self.plate.length, self.plate.width):
            raise ParameterError(
                f"ball.radius={ball.radius!r} is too large for the plate: the ball's diameter "
                f"must not exceed the plate's smaller side "
                f"{min(self.plate.length, self.plate.width)!r} (metres)"
            )
        return ball

    @staticmethod
    def _check_contact(contact) -> Contact:
        if contact is None:
            return DEFAULT_CONTACT
        if not isinstance(contact, Contact):
            raise ParameterError(f"contact={contact!r} must be None or a Contact")
        if contact.plate != "impedance":
            raise ParameterError(
                f"contact.plate={contact.plate!r}: a live body solves its contacts with the "
                f"plate's impedance (contact.plate='impedance')"
            )
        return contact

    def _check_length(self, contact_time: float) -> None:
        if samples_in_contact(contact_time, self._engine.samplerate) > self._ring.max_contact:
            raise ParameterError(
                f"the contact lasts {contact_time:.4g} s, longer than the {MAX_CONTACT} s "
                f"a live body takes (a softer contact than any material in the table)"
            )

    def _submit(self, result, onset: float, prepared: _Prepared, gain: float, weight=0.0) -> bool:
        """Hand one contact over, its tick starting at ``onset`` s on the engine's clock:
        its excitation is computed here, straight into a reserved slot of the body's ring."""
        ring = self._ring
        self._check_length(result.contact_time)
        slot = ring.reserve()
        if slot < 0:
            return False
        try:
            ex = impact_excitation(
                prepared.coefficients,
                result,
                onset,
                weight=weight,
                pulse_points=self._engine.pulse_points,
                amplitudes=ring.amplitudes[slot],
                response=ring.response[slot],
            )
        except BaseException:
            ring.release(slot)
            raise
        g = self._scale * gain
        amplitudes, response = ex.amplitudes, ex.response  # views of the slot
        amplitudes *= g
        if prepared.mass_line:
            response += ex.forces * prepared.mass_line
        response *= g
        ring.publish(slot, ex.inject, ex.first, response.size, ex.magnitude * g)
        return True

    def _hand_over(self, result, onset: float, prepared: _Prepared, gain: float) -> bool:
        """Hand one contact over as its force pulse (the audio thread computes its
        excitation at its next block, see :mod:`synth.live.kernel`); a contact too long for
        a slot's pulse grid is computed here (:meth:`_submit`)."""
        ring = self._ring
        self._check_length(result.contact_time)
        c = prepared.coefficients
        fs = c.samplerate
        lay = pulse_layout(result.contact_time, onset, c.omega_max, fs, self._engine.pulse_points)
        n, M = lay.points, lay.samples
        if n + M > ring.pulse_samples:
            return self._submit(result, onset, prepared, gain)
        slot = ring.reserve(pulse=True, bounded=self._engine.running)
        if slot < 0:
            return False
        try:
            result.pulse_samples(lay.step, n, lay.offset, 1.0 / fs, M, out=ring.samples[slot])
            ring.coefficients[slot, 0] = c.coef_re
            ring.coefficients[slot, 1] = c.coef_im
            p = ring.pulse[slot]
            p[kernel.STEP] = lay.step
            p[kernel.OFFSET] = lay.offset
            p[kernel.WEIGHT] = 0.0
            p[kernel.CONTACT_TIME] = result.contact_time
            p[kernel.ORDER] = result.pulse_order
            p[kernel.GAIN] = self._scale * gain
            p[kernel.MASS_LINE] = prepared.mass_line
        except BaseException:
            ring.release(slot, pulse=True)
            raise
        ring.publish_pulse(slot, lay.inject, lay.first, M, n)
        return True

    def _solver(self, tr: _Trigger) -> ContactSolver:
        """The contact solver of a hit's ball, law and gravity (kept for the last few)."""
        key = (tr.ball, tr.law, tr.gravity)
        solver = self._solvers.get(key)
        if solver is None:
            solver = ContactSolver.for_pair(
                tr.ball,
                self.plate,
                gravity=tr.gravity,
                law=tr.law.law,
                rtol=HIT_RTOL,
                **tr.law.options(),
            )
            if len(self._solvers) >= KEPT_POINTS:
                self._solvers.pop(next(iter(self._solvers)))
            self._solvers[key] = solver
        return solver

    def _trigger(self, ball, position, gain, contact, gravity, at) -> _Trigger:
        """The arguments :meth:`hit` and :meth:`drop` share, checked (a ParameterError
        names the argument and its value)."""
        return _Trigger(
            ball=self._check_ball(ball),
            position=self._position(position),
            gain=checks.positive("gain", gain, "dimensionless"),
            law=self._check_contact(contact),
            gravity=checks.positive("gravity", gravity, "m/s^2"),
            onset=self._engine._onset(at),
        )

    def hit(
        self,
        ball: Ball,
        speed: float,
        *,
        position=None,
        gain: float = 1.0,
        at: float | None = None,
        contact: Contact | None = None,
        gravity: float = GRAVITY,
    ) -> float | None:
        """One impact of ``ball`` at ``speed`` (m/s, > 0) at ``position`` ((x, y), m from a
        plate corner; default the centre), scaled by ``gain`` (> 0). Callable from any
        thread: the contact is solved here and handed to the audio thread without blocking
        it.

        The tick starts at ``at`` (s on the engine's clock, not before :attr:`Engine.time`)
        or, by default, one block plus the stream's output latency after the call.
        ``contact``: the contact law (default Hertz, see :class:`synth.Contact`; its ``rtol``
        is not used: a single hit is solved to 1e-6); ``gravity``: m/s^2, > 0.
        Returns its start time in s, or None if the body's ring of pending impacts is full
        (the impact is refused and counted in :attr:`Engine.stats`).
        """
        v = checks.positive("speed", speed, "m/s")
        tr = self._trigger(ball, position, gain, contact, gravity, at)
        result = self._solver(tr).solve(v, position=tr.position)
        if not result.success:
            raise SynthError(
                f"the contact of {tr.ball!r} at speed={v!r} m/s did not converge: {result.message}"
            )
        accepted = self._hand_over(result, tr.onset, self._prepare(tr.position), tr.gain)
        return tr.onset if accepted else None

    def drop(
        self,
        ball: Ball,
        height: float,
        *,
        position=None,
        gain: float = 1.0,
        at: float | None = None,
        contact: Contact | None = None,
        gravity: float = GRAVITY,
    ) -> tuple[float, ...]:
        """Drop ``ball`` from ``height`` (m, > 0, its lowest point above the plate) at
        ``position`` (default the centre): the whole bouncing sequence
        (:func:`synth.simulate_bounces`, with a scene's contact accuracy), scheduled on the
        engine's clock from ``at`` (as :meth:`hit`: the first tick's start); ``contact``
        (default Hertz at a scene's rtol, 1e-9) and ``gravity`` (m/s^2) as a Scene's. Returns the
        start times (s) of the ticks handed over; impacts refused by a full ring are
        counted in :attr:`Engine.stats`."""
        h = checks.positive("height", height, "m")
        tr = self._trigger(ball, position, gain, contact, gravity, at)
        ball, pos, g, law, gravity, onset0 = (
            tr.ball,
            tr.position,
            tr.gain,
            tr.law,
            tr.gravity,
            tr.onset,
        )
        sequence = simulate_bounces(
            ball,
            self.plate,
            drop_height=h,
            position=pos,
            gravity=gravity,
            contact_law=law.law,
            rtol=law.rtol,
            **law.options(),
        )
        prepared = self._prepare(pos)
        t0 = sequence[0].time if len(sequence) else 0.0
        played = []
        for imp in sequence:
            onset = onset0 + (imp.time - t0)
            weight = ball.mass * gravity if imp.result.settled else 0.0
            if self._submit(imp.result, onset, prepared, g, weight):
                played.append(onset)
        return tuple(played)

    def stop_all(self) -> None:
        """Silence the body at the next block: every mode stops, pending impacts are dropped."""
        self._silence = True
        if not self._engine.running:
            self._apply_silence()

    def _apply_silence(self):
        zr, zi, active, debt = self._state_arrays[:4]
        kernel.silence(zr, zi, active, debt, self._ring.state, self._ring.transformed)
        self._counters[kernel.AWAKE] = 0
        self._silence = False


def _check_int(name, value, lo, hi, unit):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ParameterError(f"{name}={value!r} must be an integer in [{lo}, {hi}] ({unit})")
    return int(value)


class Engine:
    """An always open output stream that mixes the ringing of every :class:`Body`.

    Parameters
    ----------
    samplerate : int
        Hz, in [8000, 384000]; required (the device is opened at this rate).
    blocksize : int
        Frames per callback, in [16, 8192] (PortAudio's buffer size; also the step of
        :meth:`process`).
    device : int or str, optional
        Output device (a PortAudio index or name; default the system's).
    latency : "low", "high" or float
        The stream's suggested output latency (s, > 0, or PortAudio's named setting).
    channels : int
        Output channels, in [1, 64]; every channel carries the same mono mix.
    floor_db : float < 0
        Omission floor of each body's bank, dB below its loudest impact so far (as the
        offline renderer's ``floor_db``).
    max_pending : int
        Impacts a body holds before they are played, in [1, 4096]; beyond it a hit is
        refused and counted.
    max_hits_per_block : int, optional
        Hits a body takes between two blocks, in [1, max_pending] (default
        ``min(HITS_PER_BLOCK, max_pending)``): the audio thread turns
        each into mode amplitudes at the start of the next block (about ``modes * points``
        complex multiply-adds), so this bounds that work in any block; beyond it a hit is
        refused and counted.
    max_frequency : float, optional
        Highest mode of every body, Hz, at most Nyquist (default Nyquist): fewer modes cost
        less per block and per hit.
    pulse_points : int >= 5
        Fewest points of each force pulse's grid for its Laplace transforms at the poles (as
        the offline renderer's ``pulse_points``; the grid also keeps 8 points a period of the
        highest mode). The default, 65, is the renderer's (transform error below 2e-6 of the
        impulse); fewer make ``hit()`` cheaper (its main cost is ``points * modes``), with an
        error growing like ``points^-3.5`` for Hertz pulses (see :mod:`synth.sound.modal_bank`;
        5, i.e. 23 points for the default scene, leaves -76 dB of its loudest tick).
    fade : float
        Fade-out on :meth:`stop`, s, in [0.001, 1].
    handover : float
        Time allowed to :meth:`Body.hit` between its call and the hand-over of the impact,
        s, in [0, 0.1]: the default start of a tick is the call's time plus one block plus
        the output latency plus this (an impact handed over after its block was mixed is
        played at the start of the next block and counted as late).
    record_seconds : float >= 0
        The first seconds of the output are also kept in :attr:`recording`.
    """

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
    ):
        self.samplerate = _check_int("samplerate", samplerate, 8000, 384000, "Hz")
        self.blocksize = _check_int("blocksize", blocksize, 16, 8192, "frames")
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
        self.channels = _check_int("channels", channels, 1, 64, "channels")
        db = checks.real("floor_db", floor_db, "dB", "< 0")
        if not db < 0.0:
            raise ParameterError(f"floor_db={floor_db!r} must be < 0 (dB)")
        self.floor = 10.0 ** (db / 20.0)
        self.max_pending = _check_int("max_pending", max_pending, 1, 4096, "impacts")
        if max_hits_per_block is None:
            max_hits_per_block = min(HITS_PER_BLOCK, self.max_pending)
        self.max_hits_per_block = _check_int(
            "max_hits_per_block", max_hits_per_block, 1, self.max_pending, "impacts"
        )
        self.pulse_points = _check_int("pulse_points", pulse_points, 5, 100_000, "points")
        self.max_frequency = None
        if max_frequency is not None:
            self.max_frequency = checks.positive("max_frequency", max_frequency, "Hz")
            if self.max_frequency > 0.5 * self.samplerate:
                raise ParameterError(
                    f"max_frequency={max_frequency!r} must be <= the Nyquist "
                    f"frequency {0.5 * self.samplerate:g} Hz"
                )
        fade_s = checks.in_range("fade", fade, 0.001, 1.0, "s", lo_open=False, hi_open=False)
        self._fade_length = max(1, int(round(fade_s * self.samplerate)))
        self.handover = checks.in_range(
            "handover", handover, 0.0, 0.1, "s", lo_open=False, hi_open=False
        )
        rec = checks.nonnegative("record_seconds", record_seconds, "s")
        self.recording = np.zeros((int(round(rec * self.samplerate)), self.channels), np.float32)
        self._recorded = 0
        self._bodies: tuple[Body, ...] = ()
        self._mix = np.zeros(max(self.blocksize, 4096))
        self._frame = 0  # next frame to mix
        self._fade_at = -1  # position in the stop fade, -1: none
        self.fade_frame = None  # where the last stop() fade began (frame)
        self._stream = None
        self._state = "idle"  # idle -> running -> stopped
        # the clock of the last callback: its first frame, the perf_counter time at which
        # that frame reaches the output, the perf_counter time at its end, its last frame + 1
        self._anchor = np.zeros(4)
        self._anchor_seq = 0
        self._latency = 0.0
        self._callbacks = 0
        self._underflows = 0
        self._cb_sum = 0.0
        self._cb_max = 0.0
        self._lead = 0.0
        announce("live")
        kernel.warm_up()

    # -- bodies ---------------------------------------------------------------------------
    def add(self, plate: Plate, *, listener=None, gain: float = 1.0) -> Body:
        """Prepare ``plate`` once (modes, listener gains; from the caches when present) and
        return its :class:`Body`. ``listener``: an Accelerometer or a Microphone (default:
        a microphone 0.2 m above the plate's centre); ``gain`` > 0 scales everything it
        plays. Allowed while the stream runs (the callback picks the body up at its next
        block)."""
        if not isinstance(plate, Plate):
            raise ParameterError(f"plate={plate!r} must be a Plate")
        if listener is None:
            cx, cy = plate.centre
            listener = Microphone((cx, cy, DEFAULT_MICROPHONE_HEIGHT))
        elif isinstance(listener, Accelerometer):
            plate.check_position(listener.position, "listener.position")
        elif not isinstance(listener, Microphone):
            raise ParameterError(
                f"listener={listener!r} must be None, an Accelerometer or a Microphone"
            )
        g = checks.positive("gain", gain, "dimensionless")
        self._check_open("add a body")
        model = modal_model(
            plate, listener, samplerate=self.samplerate, max_frequency=self.max_frequency
        )
        body = Body(self, plate, listener, g, model)
        self._bodies = self._bodies + (body,)  # one assignment: the callback sees all or none
        return body

    @property
    def bodies(self) -> tuple[Body, ...]:
        return self._bodies

    # -- clock ----------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._state == "running"

    @property
    def time(self) -> float:
        """The next frame to be mixed, s on the engine's clock."""
        return self._frame / self.samplerate

    @property
    def latency(self) -> float:
        """The stream's output latency, s: from the start of a callback to the time its first
        sample is heard (PortAudio's ``outputBufferDacTime - currentTime``, measured at
        each callback; the stream's nominal latency before the first; 0 without a stream)."""
        return self._lead if self.running else 0.0

    def _check_open(self, what: str):
        if self._state == "stopped":
            raise SynthError(
                f"cannot {what}: the engine is stopped (start() it again, or make a new Engine)"
            )

    def _now_frame(self) -> float:
        """Where the output stands now: the frame (fractional) leaving the device now, less
        nothing when there is no stream (then the next frame to be mixed)."""
        if not self.running:
            return float(self._frame)
        while True:
            seq = self._anchor_seq
            f0, dac0 = self._anchor[0], self._anchor[1]
            if seq == self._anchor_seq and seq % 2 == 0:
                break
        if seq == 0:  # no callback yet: the stream starts with the next frame
            return float(self._frame) - self._lead * self.samplerate
        return f0 + (time.perf_counter() - dac0) * self.samplerate

    def _onset(self, at) -> float:
        """A tick's start, s on the engine's clock: ``at``, or one block plus the output
        latency plus the hand-over allowance from now (no stream: from the next frame)."""
        self._check_open("play an impact")
        if at is None:
            if not self.running:
                return (self._frame + self.blocksize) / self.samplerate
            frame = (
                self._now_frame() + self.blocksize + (self._lead + self.handover) * self.samplerate
            )
            return max(frame, float(self._frame)) / self.samplerate
        t = checks.real("at", at, "s")
        earliest = self._frame / self.samplerate
        if not self.running and t < earliest:
            raise ParameterError(
                f"at={at!r} must be >= {earliest!r} s, the engine's next frame (Engine.time)"
            )
        if t < 0.0:
            raise ParameterError(f"at={at!r} must be >= 0 s (the engine's clock)")
        return t

    # -- mixing ---------------------------------------------------------------------------
    def _mix_into(self, outdata, frames: int):
        """Mix ``frames`` frames into ``outdata`` (frames, channels) float32: the one mixing
        code of the callback and of :meth:`process`."""
        done = 0
        cap = self._mix.shape[0]
        while done < frames:
            n = min(cap, frames - done)
            t0 = self._frame
            for body in self._bodies:
                if body._silence:
                    body._apply_silence()
                puts = body._ring.puts
                if puts == body._puts_seen and not body._counters[kernel.AWAKE]:
                    continue  # quiet, nothing new: costs nothing
                body._puts_seen = puts
                kernel.mix_body(self._mix, t0, n, *body._kernel_args)
            block = outdata[done : done + n]
            if self._fade_at == 0:
                self.fade_frame = t0
            self._fade_at = kernel.write_output(
                self._mix, n, block, self._fade_at, self._fade_length
            )
            if self._recorded < self.recording.shape[0]:
                m = min(n, self.recording.shape[0] - self._recorded)
                self.recording[self._recorded : self._recorded + m] = block[:m]
                self._recorded += m
            self._frame = t0 + n
            done += n

    def process(self, frames: int) -> np.ndarray:
        """Mix the next ``frames`` frames without a device, in blocks of ``blocksize``:
        float32 (frames, channels), the very samples the stream's callback would emit.
        Not while the stream runs."""
        n = _check_int("frames", frames, 0, 1 << 40, "frames")
        if self.running:
            raise SynthError("process() mixes without a device: stop() the stream first")
        self._check_open("process")
        out = np.empty((n, self.channels), dtype=np.float32)
        for a in range(0, n, self.blocksize):  # the callback's blocks
            b = min(n, a + self.blocksize)
            self._mix_into(out[a:b], b - a)
        return out

    def _callback(self, outdata, frames, time_info, status):
        start = time.perf_counter()
        if status.output_underflow:
            self._underflows += 1
        dac = time_info.outputBufferDacTime
        now = time_info.currentTime
        lead = (dac - now) if (dac > 0.0 and now > 0.0 and dac >= now) else self._latency
        self._lead = lead
        self._anchor_seq += 1
        self._anchor[0] = self._frame
        self._anchor[1] = start + lead
        self._anchor_seq += 1
        self._mix_into(outdata, frames)
        end = time.perf_counter()
        self._anchor[2] = end
        self._anchor[3] = self._frame
        cost = (end - start) * self.samplerate / max(frames, 1)
        self._callbacks += 1
        self._cb_sum += cost
        if cost > self._cb_max:
            self._cb_max = cost

    # -- stream ---------------------------------------------------------------------------
    def start(self) -> Engine:
        """Open the output stream and start mixing. Raises SynthError when PortAudio or the
        sounddevice package is missing, or when there is no output device."""
        if self.running:
            raise SynthError("the engine is already running")
        from synth.io.playback import sounddevice_module

        sd = sounddevice_module()
        try:
            info = sd.query_devices(self.device, kind="output")
        except (ValueError, sd.PortAudioError) as exc:
            raise SynthError(
                f"no audio output device{'' if self.device is None else f' {self.device!r}'} "
                f"({exc}); list the devices with `python -m sounddevice`, or render offline "
                f"with Engine.process()"
            ) from None
        try:
            stream = sd.OutputStream(
                samplerate=self.samplerate,
                blocksize=self.blocksize,
                device=self.device,
                channels=self.channels,
                dtype="float32",
                latency=self.latency_setting,
                callback=self._callback,
            )
        except sd.PortAudioError as exc:
            raise SynthError(
                f"cannot open the output device {info['name']!r} at "
                f"{self.samplerate} Hz with {self.channels} channel(s): {exc}"
            ) from None
        self._latency = float(stream.latency)
        self._lead = self._latency
        self._switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(min(self._switch_interval, SWITCH_INTERVAL))
        self._anchor_seq = 0
        self._fade_at = -1
        self._stream = stream
        self._state = "running"
        stream.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Fade out (``fade`` s), then close the stream. Pending impacts and ringing modes
        are dropped; the engine can be started again."""
        if not self.running:
            return
        stream = self._stream
        self._fade_at = 0
        deadline = time.perf_counter() + timeout + self._fade_length / self.samplerate
        while (
            self._fade_at < self._fade_length and stream.active and time.perf_counter() < deadline
        ):
            time.sleep(0.002)
        try:
            stream.stop()
        finally:
            stream.close()
            self._stream = None
            self._state = "stopped"
            self._latency = 0.0
            sys.setswitchinterval(self._switch_interval)
        for body in self._bodies:
            body._apply_silence()
        self._fade_at = -1

    def __enter__(self) -> Engine:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def stats(self) -> EngineStats:
        played = late = refused = pending = 0
        for body in self._bodies:
            played += int(body._counters[kernel.PLAYED])
            late += int(body._counters[kernel.LATE])
            refused += body._ring.refused
            pending += body.pending
        n = self._callbacks
        return EngineStats(
            n,
            self._underflows,
            self._cb_sum / n if n else 0.0,
            self._cb_max,
            played,
            refused,
            late,
            pending,
        )
