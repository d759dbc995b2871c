"""A live engine: an always open output stream that plays physical impacts as they happen.

``Engine`` owns one PortAudio output stream whose callback, compiled code with no Python
in it (:mod:`synth.live.native`), mixes every body; ``Engine.process(frames)`` runs the
very same compiled mixing without a device. A body is one
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
times each hit's gain, each body's gain (settable at run time, ramped over a block) and the
master gain, so bodies and hits keep their true level relation. The master bus ends in a
stated soft clipper (identity up to -1 dBFS, a tanh knee above; ``clip=False`` turns it
off), so no sample above full scale reaches the device; its peak and the samples that
reached full scale before it are in :attr:`Engine.stats`.

The callback allocates nothing, touches no Python object, file or lock: PortAudio calls a
numba ``cfunc`` with the address of the engine's arrays (:mod:`synth.live.native`), so a
busy Python thread cannot delay it. ``Engine(callback="python")`` is the explicit fallback
for hosts where a C callback cannot be installed: a Python function that needs the GIL
each block (it calls the same compiled mixing). A body with no ringing mode and nothing
handed over costs nothing.

The engine's clock counts output frames from 0; ``Engine.time`` is the next frame to be
mixed, in seconds. A hit starts one block plus the stream's output latency after the call
(sub-sample exact, the same offset for every call, so there is no jitter), or at ``at``.
"""

from __future__ import annotations

import threading
import time
import weakref
from dataclasses import dataclass

import numpy as np

from synth import checks, cost
from synth.compilation import announce
from synth.constants import GRAVITY
from synth.errors import ParameterError, SynthError
from synth.io.audio import PHYSICAL_FULL_SCALE
from synth.live import kernel, native
from synth.live.queue import PendingRing
from synth.physics.bounces import simulate_bounces
from synth.physics.contact import ContactSolver
from synth.physics.scene import (
    MAX_DROP_HEIGHT,
    MIN_DROP_HEIGHT,
    Accelerometer,
    Ball,
    Contact,
    Microphone,
    Plate,
    Scene,
)
from synth.sound.modal_bank import (
    PULSE_POINTS,
    bank_coefficients,
    impact_excitation,
    power_table,
    pulse_layout,
    samples_in_contact,
)
from synth.sound.render import modal_model

#: The stream callbacks: compiled code that PortAudio calls without Python ("native"), or
#: the fallback, a Python function (needs the GIL each block).
CALLBACKS = ("native", "python")
#: Largest speed of a hit, m/s: far beyond the elastic range of every material in the table
#: (metal balls dent above a few m/s), a bound against nonsense, not a physical limit.
MAX_SPEED = 100.0
#: Largest gain of a hit or a body (linear; +80 dB: the physical calibration is set for
#: loud sources, a small panel heard from afar needs some +70 dB).
MAX_GAIN = 1e4
#: Longest time ahead of the engine's clock a hit or a drop may be scheduled, s (a slot of
#: the pending ring is held until then).
MAX_AHEAD = 60.0
#: Longest output ``process`` mixes in one call and ``record_seconds`` keeps, s (the
#: arrays are allocated whole: 600 s of mono float32 at 48 kHz is 115 MB).
MAX_SECONDS = 600.0
#: A running stream whose callback has not returned for this long (s, or 10 blocks if
#: longer) has lost its device or server: hits are refused, ``stats.silent_for`` says so.
DEVICE_LOST = 0.5
#: Default room in the body directory the audio thread reads.
MAX_BODIES = 256
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
#: The contact law of a hit or a drop given none (a scene's default: Hertz).
DEFAULT_CONTACT = Contact()
#: Impact points (and balls' contact solvers) a body keeps prepared, the oldest dropped.
KEPT_POINTS = 64
#: Radius (m) of the ball of the hit that warms a new body's hit path up (not played).
WARM_UP_BALL_RADIUS = 0.005


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made.

    callbacks: blocks mixed by a stream's callback; output_underflows: callbacks that
    PortAudio flagged ``output_underflow`` (the device ran dry before);
    callback_mean, callback_max, callback_last: the callback's run time from its entry to
    its return (read from the monotonic clock by the compiled callback itself), as a
    fraction of its block's duration; callback_gap_max: the longest time between two
    callbacks' entries, in blocks (about 1 when the system runs the audio thread on
    time; an underflow with a large gap and a small callback_max was the system's
    scheduling, not the callback's work); impacts_played: impacts injected into a body's
    modes; impacts_refused: impacts refused (a body's ring full, too many pulses waiting
    for one block, or a whole drop that did not fit); drops_refused: drops refused whole;
    impacts_too_close: hits refused by a body's ``min_interval``;
    impacts_late: impacts found after their start time (played at the start of the block
    they were found in); impacts_pending: handed over and not yet played; bodies_ringing:
    bodies whose modes ring (the voices in use: a body is one modal bank whatever the
    number of impacts exciting it); peak: the largest |sample| of the master bus before
    the clipper, full scale 1; output_peak: the largest |sample| sent to the device;
    clipped: master-bus samples that reached full scale (soft-clipped, or clipped by
    the float-to-integer conversion with ``clip=False``); failed: why the stream
    failed, or None; silent_for: seconds since the last callback returned while the
    stream runs (0 without a stream): beyond ``DEVICE_LOST`` the device is taken as lost.
    """

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
    impacts_pending: int
    bodies_ringing: int
    peak: float
    output_peak: float
    clipped: int
    failed: str | None
    silent_for: float


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

    def __init__(
        self, engine: Engine, plate: Plate, listener, gain: float, model, channel: int = -1
    ):
        self._engine = engine
        self._channel = channel
        self._min_interval = 0.0
        self._last_onsets: dict = {}  # onset (s) of the last hit at each point (1 mm grid)
        self._ears = [self]  # the bodies a hit plays on: this one, and the other ears
        self.plate = plate
        self.listener = listener
        self._model = model
        fs = engine.samplerate
        poles = np.ascontiguousarray(model.poles)
        self._scale = 1.0 / PHYSICAL_FULL_SCALE[model.units]
        self._prepared: dict = {}
        self._solvers: dict = {}
        coefficients = self._prepare(plate.centre).coefficients
        grid = pulse_layout(SLOT_CONTACT, 0.0, coefficients.omega_max, fs, engine.pulse_points)
        self._ring = PendingRing(
            engine.max_pending,
            poles.size,
            samples_in_contact(MAX_CONTACT, fs),
            min(grid.points, MAX_SLOT_GRID) + samples_in_contact(SLOT_CONTACT, fs),
            engine.max_hits_per_block,
        )
        self._state_arrays = kernel.body_state(poles.size)
        self._warm_up()
        arrays = native.body_arrays(
            coefficients,
            power_table(poles, float(fs)),
            self._state_arrays,
            self._ring,
            engine.floor,
            gain,
            channel,
        )
        self._counters = arrays["counters"]
        self._scalars = arrays["scalars"]
        self._index = len(engine._native.records)
        self._record = engine._native.add_body(arrays)

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
    def gain(self) -> float:
        """The body's gain (linear, in (0, MAX_GAIN]); settable while it plays: the change
        is ramped linearly over the next block (no click)."""
        return float(self._scalars[native.S_GAIN])

    @gain.setter
    def gain(self, value: float) -> None:
        g = checks.positive_at_most("gain", value, MAX_GAIN, "dimensionless")
        for ear in self._ears:
            ear._scalars[native.S_GAIN] = g

    @property
    def min_interval(self) -> float:
        """Shortest time between two hits at one point of the body, s, in [0, 1] (default
        0: no limit): a hit sooner than this after the last one played at the same point
        (to 1 mm) is refused (returns None) and counted in ``stats.impacts_too_close``, so
        that a game's jittering contact does not drone."""
        return self._min_interval

    @min_interval.setter
    def min_interval(self, value: float) -> None:
        self._min_interval = checks.in_range(
            "min_interval", value, 0.0, 1.0, "s", lo_open=False, hi_open=False
        )

    def _too_close(self, position, onset: float) -> bool:
        """Whether a hit at ``position`` starting at ``onset`` s comes within
        ``min_interval`` of the last one there; if not, it becomes the last one."""
        if self._min_interval <= 0.0:
            return False
        key = (round(position[0], 3), round(position[1], 3))
        last = self._last_onsets.get(key)
        if last is not None and abs(onset - last) < self._min_interval:
            self._engine._too_close += 1
            return True
        self._last_onsets.pop(key, None)
        if len(self._last_onsets) >= KEPT_POINTS:
            self._last_onsets.pop(next(iter(self._last_onsets)))
        self._last_onsets[key] = onset
        return False

    @property
    def modes(self) -> int:
        """Number of modes in the body's bank (below Nyquist)."""
        return int(self._model.poles.size)

    @property
    def memory(self) -> int:
        """Bytes of the arrays the body holds for the audio thread (modal state, power
        table, pending ring, workspace)."""
        records = self._engine._native.records
        return sum(
            int(a.nbytes)
            for ear in self._ears
            for a in records[ear._index][1].values()
            if isinstance(a, np.ndarray)
        )

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
        return self.ringing or any(ear._ring.pending() for ear in self._ears)

    @property
    def ringing(self) -> bool:
        """Whether the body's modes ring (as of the last block mixed)."""
        return any(bool(ear._counters[kernel.AWAKE]) for ear in self._ears)

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
        if contact.plate == "modal":
            raise ParameterError(
                f"contact.plate={contact.plate!r}: a live body solves its contacts with the "
                f"plate's impedance (contact.plate='impedance', or 'auto', which a live body "
                f"solves on the impedance plate: it carries no modes in the contact)"
            )
        return contact

    def _check_length(self, contact_time: float) -> None:
        if samples_in_contact(contact_time, self._engine.samplerate) > self._ring.max_contact:
            raise ParameterError(
                f"the contact lasts {contact_time:.4g} s, longer than the {MAX_CONTACT} s "
                f"a live body takes (a heavy ball on a light plate, or a soft contact): "
                f"render it offline with synth.render"
            )

    def _submit(
        self, result, onset: float, prepared: _Prepared, gain: float, weight=0.0, slot=None
    ) -> bool:
        """Hand one contact over, its tick starting at ``onset`` s on the engine's clock:
        its excitation is computed here, straight into a slot of the body's ring (``slot``,
        reserved by the caller, or one reserved here)."""
        ring = self._ring
        self._check_length(result.separation_time)
        if slot is None:
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
        self._check_length(result.separation_time)
        c = prepared.coefficients
        fs = c.samplerate
        lay = pulse_layout(
            result.separation_time, onset, c.omega_max, fs, self._engine.pulse_points
        )
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
            p[kernel.CONTACT_TIME] = result.separation_time
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
            gain=checks.positive_at_most("gain", gain, MAX_GAIN, "dimensionless"),
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
        or the hit comes within :attr:`min_interval` of the last one at its point (the
        impact is refused and counted in :attr:`Engine.stats`).
        """
        v = checks.positive_at_most("speed", speed, MAX_SPEED, "m/s")
        tr = self._trigger(ball, position, gain, contact, gravity, at)
        if self._too_close(tr.position, tr.onset):
            return None
        result = self._solver(tr).solve(v, position=tr.position)
        if not result.success:
            raise SynthError(
                f"the contact of {tr.ball!r} at speed={v!r} m/s did not converge: {result.message}"
            )
        accepted = [
            ear._hand_over(result, tr.onset, ear._prepare(tr.position), tr.gain)
            for ear in self._ears
        ]
        return tr.onset if all(accepted) else None

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
        (default Hertz at a scene's rtol, 1e-9) and ``gravity`` (m/s^2) as a Scene's; ``height``
        in [1e-6, 1000] m as a Scene's. Returns the start times (s) of its ticks.

        A drop is handed over whole or not at all: when the body's ring has fewer free slots
        than the drop has impacts, it is refused (returns an empty tuple) and its impacts are
        counted in ``impacts_refused`` (and the drop in ``drops_refused``); a drop with more
        impacts than ``max_pending`` can never fit and raises ParameterError."""
        h = _check_height(height)
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
        if len(sequence) > self._ring.capacity:
            raise ParameterError(
                f"the drop from height={height!r} m has {len(sequence)} impacts, more than "
                f"max_pending={self._ring.capacity} (the impacts a body holds): raise "
                f"max_pending, or drop from lower"
            )
        for imp in sequence:
            self._check_length(imp.result.separation_time)
        reserved = []
        for ear in self._ears:
            slots = ear._ring.reserve_many(len(sequence))
            if slots is None:
                _release(reserved)
                self._engine._drops_refused += 1
                return ()
            reserved.append((ear, list(slots)))
        t0 = sequence[0].time if len(sequence) else 0.0
        onsets = tuple(onset0 + (imp.time - t0) for imp in sequence)
        try:
            for ear, slots in reserved:
                prepared = ear._prepare(pos)
                while slots:
                    k = len(sequence) - len(slots)
                    imp = sequence[k]
                    weight = ball.mass * gravity if imp.result.settled else 0.0
                    ear._submit(imp.result, onsets[k], prepared, g, weight, slot=slots.pop(0))
        except BaseException:
            _release(reserved)
            raise
        return onsets

    def stop_all(self) -> None:
        """Silence the body at the next block: every mode stops, pending impacts are dropped
        (at once when no stream runs)."""
        if self._engine.running:
            for ear in self._ears:
                ear._counters[kernel.SILENCE] = 1  # the audio thread applies it
        else:
            self._apply_silence()

    def _apply_silence(self):
        for ear in self._ears:
            zr, zi, active, debt = ear._state_arrays[:4]
            kernel.silence(zr, zi, active, debt, ear._ring.state, ear._ring.transformed)
            ear._counters[kernel.AWAKE] = 0
            ear._counters[kernel.SILENCE] = 0


def _release(reserved) -> None:
    """Give back the slots a drop reserved and did not fill (``(body, slots)`` pairs)."""
    for ear, slots in reserved:
        for slot in slots:
            ear._ring.release(slot)


def ears(position, facing=(1.0, 0.0), spacing: float = 0.18) -> tuple[Microphone, Microphone]:
    """A listener's two ears as microphones, (left, right), for ``Engine(channels=2)``:
    the head at ``position`` ((x, y, z), m, z > 0 above the plate), facing the direction
    ``facing`` ((x, y) in the plate's plane, any length > 0), the ears ``spacing`` m apart
    (in (0, 1]; 0.18 m, an adult head's width) on the line across it, the left one on the
    left of the facing direction (z up). Each ear hears each mode with its own Rayleigh
    gain (:mod:`synth.sound.radiation`): level, delay-free directivity and the balance
    between the ears come from the plate's radiation, not from a pan law."""
    x, y, z = checks.point("position", position, 3)
    fx, fy = checks.point("facing", facing, 2, "dimensionless")
    norm = float(np.hypot(fx, fy))
    if not norm > 0.0:
        raise ParameterError(f"facing={facing!r} must be a direction of length > 0")
    d = checks.in_range("spacing", spacing, 0.0, 1.0, "m", hi_open=False)
    lx, ly = -fy / norm * d / 2, fx / norm * d / 2  # the facing direction turned left
    return Microphone((x + lx, y + ly, z)), Microphone((x - lx, y - ly, z))


def _check_height(height) -> float:
    h = checks.positive_at_most("height", height, MAX_DROP_HEIGHT, "m")
    if h < MIN_DROP_HEIGHT:
        raise ParameterError(
            f"height={height!r} must be >= {MIN_DROP_HEIGHT:g} and <= {MAX_DROP_HEIGHT:g} (m)"
        )
    return h


def _check_int(name, value, lo, hi, unit):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ParameterError(f"{name}={value!r} must be an integer in [{lo}, {hi}] ({unit})")
    return int(value)


class Engine:
    """An always open output stream that mixes the ringing of every :class:`Body`.

    Parameters
    ----------
    samplerate : int
        Hz, in [8000, 384000]; required (the device is opened at this rate; a device that
        does not offer it makes :meth:`start` raise a SynthError saying so).
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
    record_seconds : float
        The first seconds of the output are also kept in :attr:`recording`, s, in
        [0, MAX_SECONDS] (600 s).
    master_gain_db : float
        Gain of the master bus, dB, in [-120, 40]; settable (:attr:`master_gain_db`,
        ramped over a block).
    clip : bool
        Soft-clip the master bus (identity up to -1 dBFS, a tanh knee above it that stays
        below full scale); False passes it as is (PortAudio's conversion then clips).
    callback : "native" or "python"
        The stream's callback: compiled code that PortAudio calls without Python (default;
        needs a POSIX clock), or the explicit fallback, a Python function that holds the GIL
        for each block (a busy Python thread then delays it).
    max_bodies : int
        Bodies the engine can hold, in [1, 65536] (the audio thread's directory).
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
        master_gain_db: float = 0.0,
        clip: bool = True,
        callback: str = "native",
        max_bodies: int = MAX_BODIES,
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
        self.handover = checks.in_range(
            "handover", handover, 0.0, 0.1, "s", lo_open=False, hi_open=False
        )
        rec = checks.in_range(
            "record_seconds", record_seconds, 0.0, MAX_SECONDS, "s", lo_open=False, hi_open=False
        )
        if not isinstance(clip, bool):
            raise ParameterError(f"clip={clip!r} must be True or False")
        self.callback = checks.choice("callback", callback, CALLBACKS)
        if self.callback == "native" and not native.native_available():
            raise ParameterError(
                "callback='native' needs a POSIX monotonic clock, which this platform lacks: "
                "use callback='python'"
            )
        max_bodies = _check_int("max_bodies", max_bodies, 1, 65536, "bodies")
        announce("live")
        native.warm_up()
        self._native = native.EngineState(
            samplerate=self.samplerate,
            channels=self.channels,
            max_bodies=max_bodies,
            mix_frames=max(self.blocksize, 4096),
            record_frames=int(round(rec * self.samplerate)),
            fade_frames=max(1, int(round(fade_s * self.samplerate))),
            clip=clip,
        )
        self.master_gain_db = master_gain_db
        self._bodies: tuple[Body, ...] = ()
        self._stream = None
        self._closer = None
        self._state = "idle"  # idle <-> running; failed for good
        self._failure: str | None = None
        self._drops_refused = 0
        self._too_close = 0

    # -- bodies ---------------------------------------------------------------------------
    def _highest_frequency(self) -> float:
        """Hz: the highest mode frequency the bodies render (``max_frequency`` or Nyquist)."""
        return 0.5 * self.samplerate if self.max_frequency is None else self.max_frequency

    def add(self, plate: Plate | Scene, *, listener=None, gain: float = 1.0) -> Body:
        """Prepare ``plate`` once (modes, listener gains; from the caches when present) and
        return its :class:`Body`. ``listener``: an Accelerometer or a Microphone (default:
        a microphone 0.2 m above the plate's centre, a :class:`synth.Scene`'s default for
        impacts at the centre). Given a :class:`synth.Scene`, the body is its plate heard
        by its listener (the scene's default one, above its impact point, when it was given
        none), so that the scene sounds live as it renders offline. ``gain`` in
        (0, MAX_GAIN] scales everything it plays. Allowed while the stream runs (the
        callback picks the body up at its next block)."""
        if isinstance(listener, (tuple, list)):
            return self._add_ears(plate, listener, gain)
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
        elif isinstance(listener, Accelerometer):
            plate.check_position(listener.position, "listener.position")
        elif not isinstance(listener, Microphone):
            raise ParameterError(
                f"listener={listener!r} must be None, an Accelerometer or a Microphone"
            )
        g = checks.positive_at_most("gain", gain, MAX_GAIN, "dimensionless")
        self._check_open("add a body")
        if len(self._native.records) >= self._native.directory.shape[0]:
            raise ParameterError(
                f"the engine holds max_bodies={self._native.directory.shape[0]} bodies already"
            )
        cost.check_modes(plate, self._highest_frequency())
        model = modal_model(
            plate, listener, samplerate=self.samplerate, max_frequency=self.max_frequency
        )
        body = Body(self, plate, listener, g, model)
        self._bodies = self._bodies + (body,)
        return body

    def _add_ears(self, plate, listeners, gain) -> Body:
        """A body heard by one listener per output channel (see :meth:`add`)."""
        if self.channels < 2 or len(listeners) != self.channels:
            raise ParameterError(
                f"listener: a sequence of {len(listeners)} listeners needs an Engine with as "
                f"many channels (one listener per channel, at least 2); channels={self.channels}"
            )
        if not isinstance(plate, Plate):
            raise ParameterError(f"plate={plate!r} must be a Plate when listeners are given")
        for i, li in enumerate(listeners):
            if isinstance(li, Accelerometer):
                plate.check_position(li.position, f"listener[{i}].position")
            elif not isinstance(li, Microphone):
                raise ParameterError(
                    f"listener[{i}]={li!r} must be an Accelerometer or a Microphone"
                )
        g = checks.positive_at_most("gain", gain, MAX_GAIN, "dimensionless")
        self._check_open("add a body")
        if len(self._native.records) + len(listeners) > self._native.directory.shape[0]:
            raise ParameterError(
                f"the engine holds max_bodies={self._native.directory.shape[0]} bodies "
                f"(one per listener): no room for {len(listeners)} more"
            )
        cost.check_modes(plate, self._highest_frequency())
        models = [
            modal_model(plate, li, samplerate=self.samplerate, max_frequency=self.max_frequency)
            for li in listeners
        ]
        ears_ = [
            Body(self, plate, li, g, m, channel=c)
            for c, (li, m) in enumerate(zip(listeners, models))
        ]
        body = ears_[0]
        body.listener = tuple(listeners)
        body._ears = ears_
        self._bodies = self._bodies + (body,)
        return body

    @property
    def bodies(self) -> tuple[Body, ...]:
        return self._bodies

    # -- master bus -----------------------------------------------------------------------
    @property
    def master_gain_db(self) -> float:
        """The master bus' gain, dB in [-120, 40]; a change is ramped over the next block."""
        return 20.0 * float(np.log10(self._native.times[native.MASTER_GAIN]))

    @master_gain_db.setter
    def master_gain_db(self, value: float) -> None:
        db = checks.in_range(
            "master_gain_db", value, -120.0, 40.0, "dB", lo_open=False, hi_open=False
        )
        self._native.times[native.MASTER_GAIN] = 10.0 ** (db / 20.0)

    def reset_meter(self) -> None:
        """Start the master bus' peak meters (``stats.peak``, ``stats.output_peak``) anew."""
        self._native.times[native.PEAK] = 0.0
        self._native.times[native.OUT_PEAK] = 0.0

    # -- clock ----------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._state == "running"

    @property
    def failed(self) -> str | None:
        """Why the engine's stream failed (it then refuses everything), or None."""
        return self._failure

    @property
    def _frame(self) -> int:
        return int(self._native.ctl[native.FRAME])

    @property
    def time(self) -> float:
        """The next frame to be mixed, s on the engine's clock."""
        return self._frame / self.samplerate

    @property
    def recording(self) -> np.ndarray:
        """The first ``record_seconds`` of the output, float32 (frames, channels); frames
        not yet played are zero (``recorded`` counts those played)."""
        return self._native.recording

    @property
    def recorded(self) -> int:
        """Frames of :attr:`recording` written so far."""
        return int(self._native.ctl[native.RECORDED])

    @property
    def fade_frame(self) -> int | None:
        """The frame where the last :meth:`stop` fade began, or None."""
        f = int(self._native.ctl[native.FADE_FRAME])
        return None if f < 0 else f

    @property
    def latency(self) -> float:
        """The stream's output latency, s: from the start of a callback to the time its first
        sample is heard (PortAudio's ``outputBufferDacTime - currentTime``, measured at
        each callback; the stream's nominal latency before the first; 0 without a stream)."""
        return float(self._native.times[native.LEAD]) if self.running else 0.0

    def _check_open(self, what: str):
        if self._state == "failed":
            raise SynthError(f"cannot {what}: the engine's audio stream failed ({self._failure})")

    def _silent_for(self) -> float:
        """Seconds since the stream's last callback returned (since start() before the
        first); 0 without a stream."""
        if not self.running:
            return 0.0
        return max(0.0, native.monotonic() - float(self._native.times[native.END_TIME]))

    def _check_alive(self) -> None:
        silent = self._silent_for()
        limit = max(DEVICE_LOST, 10 * self.blocksize / self.samplerate)
        if silent > limit:
            raise SynthError(
                f"the audio stream has not called back for {silent:.2f} s (more than {limit:g} "
                f"s): its device or audio server is gone; stop() the engine (stats.silent_for)"
            )

    def _now_frame(self) -> float:
        """The frame (fractional) leaving the device now; without a stream, the next frame
        to be mixed."""
        if not self.running:
            return float(self._frame)
        frame, dac, callbacks = self._native.anchor()
        if callbacks == 0:  # no callback yet: the stream starts with the next frame
            return float(self._frame) - self._native.times[native.LEAD] * self.samplerate
        return frame + (native.monotonic() - dac) * self.samplerate

    def _onset(self, at) -> float:
        """A tick's start, s on the engine's clock: ``at`` (from the next frame to at most
        ``MAX_AHEAD`` s after it), or one block plus the output latency plus the hand-over
        allowance from now (no stream: from the next frame)."""
        self._check_open("play an impact")
        self._check_alive()
        if at is None:
            if not self.running:
                return (self._frame + self.blocksize) / self.samplerate
            lead = self._native.times[native.LEAD]
            frame = self._now_frame() + self.blocksize + (lead + self.handover) * self.samplerate
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

    # -- mixing ---------------------------------------------------------------------------
    def _mix_into(self, outdata, frames: int):
        """Mix ``frames`` frames into ``outdata`` (frames, channels) float32 with the
        callback's compiled code (:func:`synth.live.native.mix_engine`)."""
        native.mix_engine(self._native.ctl, outdata[:frames])

    def process(self, frames: int) -> np.ndarray:
        """Mix the next ``frames`` frames (in [0, MAX_SECONDS * samplerate]) without a
        device, in blocks of ``blocksize``: float32 (frames, channels), the very samples the
        stream's callback would emit. Not while the stream runs."""
        limit = int(MAX_SECONDS * self.samplerate)
        n = _check_int("frames", frames, 0, limit, f"frames, {MAX_SECONDS:g} s")
        if self.running:
            raise SynthError("process() mixes without a device: stop() the stream first")
        self._check_open("process")
        out = np.empty((n, self.channels), dtype=np.float32)
        for a in range(0, n, self.blocksize):  # the callback's blocks
            b = min(n, a + self.blocksize)
            native.mix_engine(self._native.ctl, out[a:b])
        return out

    def mix_into(self, out: np.ndarray) -> np.ndarray:
        """Mix the next ``out.shape[0]`` frames into ``out``, a caller's float32 C-contiguous
        (frames, channels) buffer, overwriting it: for hosts that own the audio callback
        (pygame's mixer, pyo, a game engine's stream, a plugin host) and call this once per
        block. The same compiled mixing as the stream's callback; not while the engine's own
        stream runs. Returns ``out``."""
        if (
            not isinstance(out, np.ndarray)
            or out.dtype != np.float32
            or out.ndim != 2
            or out.shape[1] != self.channels
            or not out.flags.c_contiguous
            or not out.flags.writeable
        ):
            raise ParameterError(
                f"out={type(out).__name__} {getattr(out, 'dtype', '')} "
                f"{getattr(out, 'shape', '')} must be a writeable C-contiguous float32 array "
                f"of shape (frames, {self.channels})"
            )
        _check_int("frames", out.shape[0], 0, int(MAX_SECONDS * self.samplerate), "frames")
        if self.running:
            raise SynthError("mix_into() mixes without the engine's stream: stop() it first")
        self._check_open("mix")
        native.mix_engine(self._native.ctl, out)
        return out

    def render_block(self, frames: int) -> np.ndarray:
        """The next ``frames`` frames as one block, a new float32 (frames, channels) array
        (:meth:`mix_into` of a fresh buffer)."""
        limit = int(MAX_SECONDS * self.samplerate)
        n = _check_int("frames", frames, 0, limit, f"frames, {MAX_SECONDS:g} s")
        return self.mix_into(np.empty((n, self.channels), dtype=np.float32))

    # -- stream ---------------------------------------------------------------------------
    def _open_stream(self, sd):
        """The PortAudio output stream with the engine's callback."""
        common = dict(
            samplerate=self.samplerate,
            blocksize=self.blocksize,
            device=self.device,
            channels=self.channels,
            dtype="float32",
            latency=self.latency_setting,
        )
        if self.callback == "python":
            return sd.OutputStream(callback=_python_callback(self._native.ctl), **common)
        import cffi

        ffi = cffi.FFI()
        return sd._StreamBase(
            kind="output",
            wrap_callback=None,
            callback=ffi.cast("void *", native.stream_callback.address),
            userdata=ffi.cast("void *", self._native.address),
            **common,
        )

    def start(self) -> Engine:
        """Open the output stream and start mixing, from the engine's clock where it stands
        (an engine stopped before starts again). Raises SynthError when PortAudio or the
        sounddevice package is missing, when there is no output device or it does not take
        the engine's rate, or when the engine failed."""
        if self.running:
            raise SynthError("the engine is already running")
        self._check_open("start")
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
            sd.check_output_settings(
                device=self.device,
                channels=self.channels,
                dtype="float32",
                samplerate=self.samplerate,
            )
        except (ValueError, sd.PortAudioError) as exc:
            raise SynthError(
                f"the output device {info['name']!r} does not take {self.samplerate} Hz with "
                f"{self.channels} channel(s) ({exc}); its default rate is "
                f"{info['default_samplerate']:g} Hz: make the Engine at a rate it offers"
            ) from None
        for body in self._bodies:  # hits queued without a stream: not bounded per block
            for ear in body._ears:
                native.transform_pending(ear._record)
        try:
            stream = self._open_stream(sd)
        except sd.PortAudioError as exc:
            raise SynthError(
                f"cannot open the output device {info['name']!r} at "
                f"{self.samplerate} Hz with {self.channels} channel(s): {exc}"
            ) from None
        times = self._native.times
        times[native.NOMINAL_LATENCY] = times[native.LEAD] = float(stream.latency)
        times[native.END_TIME] = native.monotonic()
        times[native.LAST_ENTRY] = 0.0  # the time stopped is not a gap
        ctl = self._native.ctl
        ctl[native.FADE_AT] = -1
        ctl[native.SEQ] = 0
        self._stream = stream
        # closes the stream if the engine is collected while it runs (the stream holds
        # nothing of the engine, only the addresses of the arrays the closer keeps)
        self._closer = weakref.finalize(self, _close_stream, stream, self._native, CLOSE_TIMEOUT)
        self._state = "running"
        stream.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Fade out (``fade`` s), then close the stream, within ``timeout`` s (>= 0) plus
        the fade. Pending impacts and ringing modes are dropped; :meth:`start` starts
        again. When the audio server does not answer in time (it died), the stream is
        abandoned, the engine marked failed (:attr:`failed`) and every later call refused
        with a SynthError saying so."""
        t = checks.nonnegative("timeout", timeout, "s")
        if not self.running:
            return
        ctl = self._native.ctl
        length = int(ctl[native.FADE_LENGTH])
        deadline = time.monotonic() + t + length / self.samplerate
        ctl[native.FADE_AT] = 0
        while ctl[native.FADE_AT] < length and time.monotonic() < deadline:
            time.sleep(0.002)
        self._closer.detach()
        closed = _close_stream(
            self._stream, self._native, max(0.0, deadline - time.monotonic()), abort=False
        )
        self._stream = None
        if not closed:
            self._state = "failed"
            self._failure = (
                f"the audio server did not answer within timeout={timeout!r} s; the stream "
                f"was abandoned (make a new Engine)"
            )
            return
        self._state = "idle"
        ctl[native.FADE_AT] = -1
        for body in self._bodies:
            body._apply_silence()

    def __enter__(self) -> Engine:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def stats(self) -> EngineStats:
        played = late = refused = pending = ringing = 0
        for body in self._bodies:  # a body heard by several listeners counts its first's
            played += int(body._counters[kernel.PLAYED])
            late += int(body._counters[kernel.LATE])
            refused += body._ring.refused
            pending += body.pending
            ringing += body.ringing
        c, t = self._native.ctl, self._native.times
        n = int(c[native.CALLBACKS])
        return EngineStats(
            callbacks=n,
            output_underflows=int(c[native.UNDERFLOWS]),
            callback_mean=float(t[native.COST_SUM]) / n if n else 0.0,
            callback_max=float(t[native.COST_MAX]),
            callback_last=float(t[native.COST_LAST]),
            callback_gap_max=float(t[native.GAP_MAX]),
            impacts_played=played,
            impacts_refused=refused,
            drops_refused=self._drops_refused,
            impacts_too_close=self._too_close,
            impacts_late=late,
            impacts_pending=pending,
            bodies_ringing=ringing,
            peak=float(t[native.PEAK]),
            output_peak=float(t[native.OUT_PEAK]),
            clipped=int(c[native.CLIPPED]),
            failed=self._failure,
            silent_for=self._silent_for(),
        )


#: Seconds the finaliser of a collected running engine waits for its stream to close.
CLOSE_TIMEOUT = 2.0
#: Streams whose server did not answer, with the arrays their callback may still read:
#: kept for the life of the process (freeing them could crash the audio thread).
_ABANDONED: list = []


def _close_stream(stream, state, timeout: float, abort: bool = True) -> bool:
    """Stop (or abort) and close ``stream`` on a helper thread, waiting at most
    ``timeout`` s (PortAudio's calls can hang when the server is gone). True if it closed;
    if not, the stream and its ``state`` are kept for the life of the process."""

    def close():
        try:
            stream.abort() if abort else stream.stop()
        finally:
            stream.close()

    worker = threading.Thread(target=close, name="synth-close-stream", daemon=True)
    worker.start()
    worker.join(timeout)
    if worker.is_alive():
        _ABANDONED.append((stream, state))
        return False
    return True


def _python_callback(ctl):
    """The fallback stream callback: a Python function (it needs the GIL each block) that
    runs the compiled block (:func:`synth.live.native.run_block`); it holds the engine's
    arrays, not the engine."""
    clock = native.CLOCK

    def callback(outdata, frames, time_info, status):
        entry = time.clock_gettime_ns(clock) if clock >= 0 else native.monotonic_ns()
        native.run_block(
            ctl,
            outdata,
            status._flags,
            time_info.currentTime,
            time_info.outputBufferDacTime,
            entry,
        )

    return callback
