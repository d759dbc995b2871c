"""A plate in a live engine (:class:`Body`): its voice slots, its ring of pending impacts,
and the hits and drops that fill them on the calling thread."""

from __future__ import annotations

import threading
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError, SynthError
from synth.live import kernel, native, rolling
from synth.live import state as st
from synth.live import voice as vc
from synth.live.kernel import fence
from synth.live.state import BodySettings
from synth.live.voice import PendingRing, Trigger, Voice
from synth.physics.bounces import simulate_bounces
from synth.physics.contact import ContactSolver
from synth.physics.scene import Accelerometer, Ball, Contact, Microphone, Plate
from synth.sound import modal_bank as mb
from synth.sound.radiation.fixed import NEAR_FIELD_HEIGHT
from synth.sound.render import LISTENER_UNITS
from synth.store.audio import PHYSICAL_FULL_SCALE

if TYPE_CHECKING:
    from synth.live.engine import Engine

#: Longest contact a body takes, s; longest whose pulse a hit hands to the audio thread as
#: is, s (a longer one is transformed here; with ``MAX_SLOT_GRID``, a slot's pulse size).
MAX_CONTACT = 0.02
SLOT_CONTACT = 0.002
MAX_SLOT_GRID = 4097
#: Height (m) of the default microphone above the plate's centre (as a Scene's default);
#: impact points (and contact solvers) a body keeps prepared; radius (m) of the ball of the
#: hit that warms a new body's hit path up (not played).
DEFAULT_MICROPHONE_HEIGHT = 0.2
KEPT_POINTS = 64
WARM_UP_BALL_RADIUS = 0.005
#: A PULSE slot's scalars in the order :meth:`Body._hand_over` writes them.
PULSE_FIELDS = [kernel.STEP, kernel.OFFSET, kernel.WEIGHT, kernel.CONTACT_TIME, kernel.ORDER,
                kernel.GAIN, kernel.MASS_LINE]  # fmt: skip


@dataclass(frozen=True)
class _Prepared:
    """A body's excitation at one point: bank coefficients heard now, the plate's own (the
    voices' modal states take these), an accelerometer's direct-term line (0: microphone)."""

    coefficients: object
    plate: object
    mass_line: float


@dataclass(frozen=True)
class _Impact:
    """One solved contact to hand over: starting at ``onset`` s, at ``gain`` (linear), with
    ``weight`` N left on the plate (a settled ball)."""

    result: object
    onset: float
    gain: float
    weight: float = 0.0


class Body:
    """One plate in an :class:`Engine` (:meth:`Engine.add`): ``max_voices`` voice slots,
    each a modal state that one :class:`Voice` (a hit or a drop) excites."""

    def __init__(self, engine: Engine, plate: Plate, listener, model, settings: BodySettings):
        self._engine, self.plate, self.listener, self._model = engine, plate, listener, model
        self.max_voices, self._min_interval = settings.voices, 0.0
        self._last_onsets: dict = {}  # onset (s) of the last hit at each point (1 mm grid)
        self._ears = [self]  # the bodies a hit plays on: this one, and the other ears
        fs = engine.samplerate
        self._scale = 1.0 / PHYSICAL_FULL_SCALE[model.units]
        self._prepared: dict = {}
        self._plate_coefficients: dict = {}  # position -> (excitation, plate coefficients)
        self._solvers: dict = {}
        self._grid = None  # the plate's fixed radiation grids, once a listener moved
        coefficients = self._prepare(plate.centre).coefficients
        grid = mb.pulse_layout(SLOT_CONTACT, 0.0, coefficients.omega_max, fs, engine.pulse_points)
        self._ring = PendingRing(
            engine.max_pending, model.poles.size, mb.samples_in_contact(MAX_CONTACT, fs),
            min(grid.points, MAX_SLOT_GRID) + mb.samples_in_contact(SLOT_CONTACT, fs),
            engine.max_hits_per_block, voices=engine.max_pending + settings.voices,
        )  # fmt: skip
        self._warm_up()
        self._move_lock = threading.Lock()  # between the game's threads moving the listener
        native_state = engine._native
        rolls = rolling.body_rolls(engine.max_rolls, model, native_state.mix.shape[1])
        self._index = native_state.add_body(coefficients, model.output, self._ring, settings, rolls)
        self._record, self._arrays = native_state.records[self._index]
        arrays = self._arrays
        self._rolls = {k: v for k, v in arrays.items() if k.startswith("roll")}
        self._roll_step = rolling.table_step(model)
        self._roll_lock, self._roll_holds = threading.Lock(), [None] * engine.max_rolls
        self.rolls_refused = 0  # Body.roll calls that found every rolling slot taken
        self._heard, self._heard_seq = arrays["heard"], arrays["heard_seq"]
        self._counters, self._slots = arrays["counters"], arrays["voice_slots"]
        self._scalars = arrays["scalars"]
        # remove() called: hits and drops refused; its arrays let go (see Engine._reap)
        self._removed = self._freed = False

    def _warm_up(self):
        """Run the hit path once (numba compiles or loads it), so the first hit is fast."""
        solver = ContactSolver.for_pair(
            Ball(self.plate.material, WARM_UP_BALL_RADIUS), self.plate, rtol=vc.HIT_RTOL
        )
        result = solver.solve(1.0, position=self.plate.centre)
        mb.impact_excitation(self._prepare(self.plate.centre).coefficients, result, 0.0)

    def __repr__(self):
        return (
            f"Body(plate={self.plate!r}, listener={self.listener!r}, gain={self.gain!r}, "
            f"modes={self.modes})"
        )

    @property
    def gain(self) -> float:
        """The body's gain (linear, in (0, MAX_GAIN]); a change is ramped over the next block."""
        return float(self._scalars[st.S_GAIN])

    @gain.setter
    def gain(self, value: float) -> None:
        g = checks.positive_at_most("gain", value, vc.MAX_GAIN, "dimensionless")
        for ear in self._ears:
            ear._scalars[st.S_GAIN] = g

    @property
    def pan(self) -> float | None:
        """A one-listener body's place in an ``Engine(channels=2)``: -1 left to +1 right, or
        None (full level on both); constant power (:func:`synth.live.native.pan_gains`), ramped."""
        p = float(self._scalars[st.S_PAN])
        return None if np.isnan(p) else p

    @pan.setter
    def pan(self, value: float | None) -> None:
        self._scalars[st.S_PAN] = check_pan(value, self._engine.channels, len(self._ears))

    @property
    def min_interval(self) -> float:
        """Shortest time between two hits at one point (to 1 mm), s in [0, 1] (0: no limit): a
        sooner one is refused (``stats.impacts_too_close``), so a jittering contact won't drone."""
        return self._min_interval

    @min_interval.setter
    def min_interval(self, value: float) -> None:
        self._min_interval = vc.closed("min_interval", value, 0.0, 1.0, "s")

    def _too_close(self, position, onset: float) -> bool:
        """Whether a hit at ``position`` at ``onset`` s is within ``min_interval`` of the last."""
        if self._min_interval <= 0.0:
            return False
        key = (round(position[0], 3), round(position[1], 3))
        last = self._last_onsets.get(key)
        if last is not None and abs(onset - last) < self._min_interval:
            self._engine._too_close += 1
            return True
        self._last_onsets.pop(key, None)
        _keep(self._last_onsets, key, onset)
        return False

    @property
    def modes(self) -> int:
        """Number of modes in the body's bank (below Nyquist)."""
        return int(self._model.poles.size)

    @property
    def memory(self) -> int:
        """Bytes of the arrays the body holds for the audio thread."""
        if self._freed:
            return 0
        return sum(
            int(a.nbytes) for ear in self._ears for a in ear._arrays.values()
            if isinstance(a, np.ndarray)
        )  # fmt: skip

    @property
    def units(self) -> str:
        """Physical units of the listener: "Pa" or "m/s^2"."""
        return self._model.units

    @property
    def pending(self) -> int:
        """Impacts handed over and not yet played."""
        return 0 if self._freed else self._ring.pending()

    @property
    def awake(self) -> bool:
        """Whether the body rings or has impacts pending (a quiet body costs nothing)."""
        return self.ringing or any(ear.pending for ear in self._ears) or rolling.rolls(self)

    @property
    def ringing(self) -> bool:
        """Whether a voice of the body rang in the last block."""
        return not self._freed and any(bool(ear._counters[kernel.AWAKE]) for ear in self._ears)

    @property
    def voices_playing(self) -> int:
        """Voice slots of the body (its first ear) ringing in the last block."""
        return int(np.count_nonzero(self._slots[:, kernel.SL_OWNER] >= 0))

    def _prepare(self, position) -> _Prepared:
        """The bank coefficients of impacts at ``position`` (kept for ``KEPT_POINTS``)."""
        p = self._prepared.get(position)
        if p is not None:
            return p
        model = self._model
        plate = self._plate_coefficients.get(position)
        if plate is None:
            excitation, ones = model.excitation(position), np.ones(model.poles.size)
            c = mb.bank_coefficients(model.poles, excitation, ones, self._engine.samplerate)
            plate = _keep(self._plate_coefficients, position, (excitation, c))
        excitation, c = plate
        coef = (c.coef_re + 1j * c.coef_im) * model.output
        heard = replace(c, coef_re=coef.real.copy(), coef_im=coef.imag.copy())
        direct = model.direct(excitation)
        line = float(np.sum(direct.real)) if direct is not None else 0.0
        return _keep(self._prepared, position, _Prepared(heard, c, line))

    def move(self, listener) -> None:
        """Hear the body through ``listener`` (one per ear, of the units it was added with; its
        cost checked as :meth:`Engine.add`'s), each mode's gain ramped over the next block. The
        gains are computed here, for a microphone at least ``NEAR_FIELD_HEIGHT`` high from the
        plate's fixed grids (:mod:`synth.sound.radiation.fixed`), else exactly."""
        listeners = tuple(listener) if isinstance(listener, (tuple, list)) else (listener,)
        if len(listeners) != len(self._ears):
            raise ParameterError(
                f"listener: {len(listeners)} listener(s) for a body of {len(self._ears)} ear(s)"
            )
        if self._removed:
            raise SynthError("the body was removed: it cannot move its listener")
        engine = self._engine
        cuts = []
        for i, (ear, li) in enumerate(zip(self._ears, listeners)):
            check_listener(self.plate, li, f"listener[{i}]")
            if LISTENER_UNITS[type(li)] != ear._model.units:
                raise ParameterError(
                    f"listener[{i}]={li!r} hears in {LISTENER_UNITS[type(li)]}, the body's "
                    f"ear in {ear._model.units}: add a new body for another kind of listener"
                )
            cuts.append(engine._budget(self.plate, li, self.max_voices))
        models = [ear._heard_by(li, cut) for ear, li, cut in zip(self._ears, listeners, cuts)]
        for ear, li, model in zip(self._ears, listeners, models):
            ear._hand_over_gains(li, model)
        self.listener = listeners if len(listeners) > 1 else listeners[0]

    def _heard_by(self, listener, cut: int | None = None):
        """This ear's model heard by ``listener``; ``cut``: ``radiation_max_points`` (None: the
        fixed grids may serve)."""
        if cut is not None:
            return self._engine._exact_model(self.plate, listener, cut)
        grid = None
        if isinstance(listener, Microphone) and listener.position[2] >= NEAR_FIELD_HEIGHT:
            grid = self._grid = self._engine._listener_grid(self._model)
        return self._model.heard_by(listener, grid)

    def _hand_over_gains(self, listener, model) -> None:
        """Write the new gains under a sequence lock (odd while written; the mixing takes them
        whole at a block's start)."""
        with self._move_lock:
            self._model, self._prepared, self.listener = model, {}, listener
            gains, seq = np.asarray(model.output, dtype=complex), self._heard_seq
            seq[kernel.SEQ_PUT] += 1
            fence()
            self._heard[kernel.HPR], self._heard[kernel.HPI] = gains.real, gains.imag
            fence()
            seq[kernel.SEQ_PUT] += 1

    def prepare(self, *positions) -> None:
        """Evaluate the mode shapes at points (``(x, y)``, m) ahead of hits there."""
        for position in positions:
            p = self.plate.centre if position is None else position
            self._prepare(self.plate.check_position(p, "position"))

    def _check_length(self, contact_time: float) -> None:
        """Refuse a contact longer than ``MAX_CONTACT`` (s), which no slot can hold."""
        if mb.samples_in_contact(contact_time, self._engine.samplerate) > self._ring.max_contact:
            raise ParameterError(
                f"the contact lasts {contact_time:.4g} s, longer than the {MAX_CONTACT} s "
                f"a live body takes (a heavy ball on a light plate, or a soft contact): "
                f"render it offline with synth.render"
            )

    def _submit(self, impact: _Impact, prepared: _Prepared, voice: int, slot=None) -> bool:
        """Hand ``impact`` of voice record ``voice`` over, its excitation computed here into
        ``slot`` (reserved by the caller, or here)."""
        ring, result = self._ring, impact.result  # its length checked by the caller
        own = slot is None  # else the caller gives it back on failure
        if own:
            slot = ring.reserve(voice=voice)
        if slot < 0:
            return False
        try:
            # the plate's amplitudes for the voice's state; the response and peak heard
            options = dict(weight=impact.weight, pulse_points=self._engine.pulse_points)
            mb.impact_excitation(prepared.plate, result, impact.onset,
                                 amplitudes=ring.amplitudes[slot], **options)  # fmt: skip
            ex = mb.impact_excitation(prepared.coefficients, result, impact.onset,
                                      response=ring.response[slot], **options)  # fmt: skip
        except BaseException:
            if own:
                ring.release(slot)
            raise
        g = self._scale * impact.gain
        amplitudes, response = ring.amplitudes[slot], ex.response  # views of the slot
        amplitudes *= g
        if prepared.mass_line:
            response += ex.forces * prepared.mass_line
        response *= g
        ring.publish(slot, ex.inject, ex.first, response.size, ex.magnitude * g)
        return True

    def _hand_over(self, impact: _Impact, prepared: _Prepared, voice: int) -> bool:
        """Hand ``impact`` of voice record ``voice`` over as its force pulse, transformed by
        the audio thread (:mod:`synth.live.kernel`); one too long for a slot, by :meth:`_submit`."""
        ring, result = self._ring, impact.result
        self._check_length(result.separation_time)
        c = prepared.coefficients
        fs = c.samplerate
        lay = mb.pulse_layout(
            result.separation_time, impact.onset, c.omega_max, fs, self._engine.pulse_points
        )
        n, M = lay.points, lay.samples
        if n + M > ring.pulse_samples:
            return self._submit(impact, prepared, voice)
        slot = ring.reserve(pulse=True, bounded=self._engine.running, voice=voice)
        if slot < 0:
            return False
        try:
            result.pulse_samples(lay.step, n, lay.offset, 1.0 / fs, M, out=ring.samples[slot])
            ring.coefficients[slot, 0] = prepared.plate.coef_re  # the audio thread hears them
            ring.coefficients[slot, 1] = prepared.plate.coef_im
            ring.pulse[slot, PULSE_FIELDS] = (lay.step, lay.offset, 0.0, result.separation_time,
                                              result.pulse_order, self._scale * impact.gain,
                                              prepared.mass_line)  # fmt: skip
        except BaseException:
            ring.release(slot, pulse=True)
            raise
        ring.publish(slot, lay.inject, lay.first, M, points=n)
        return True

    def _solver(self, tr: Trigger) -> ContactSolver:
        """The contact solver of a hit's ball, law and gravity (kept for ``KEPT_POINTS``)."""
        key = (tr.ball, tr.law, tr.gravity)
        solver = self._solvers.get(key)
        if solver is None:
            solver = ContactSolver.for_pair(tr.ball, self.plate, gravity=tr.gravity,
                                            law=tr.law.law, rtol=vc.HIT_RTOL,
                                            **tr.law.options())  # fmt: skip
            _keep(self._solvers, key, solver)
        return solver

    def _trigger(self, ball, position, gain, contact, gravity, at, priority) -> Trigger:
        """The arguments :meth:`hit` and :meth:`drop` share, checked."""
        if self._removed:
            raise SynthError("this body was removed from its engine (Body.remove): add it again")
        onset = self._engine._onset(at)
        return vc.trigger(self.plate, ball, position, gain, contact, gravity, onset, priority)

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
        priority: int = 0,
    ) -> Voice | None:
        """One impact of ``ball`` at ``speed`` (m/s) at ``position`` ((x, y), m; default the
        centre) at ``gain``, from any thread: solved here (to 1e-6), handed over without blocking,
        starting at ``at`` (s, the engine's clock; default one block plus the latency from now).
        ``contact``: the law (default the ball's); ``gravity`` m/s^2; ``priority`` in [0, 255].
        Returns its :class:`Voice`, or None if refused (counted in :attr:`Engine.stats`)."""
        v = checks.positive_at_most("speed", speed, vc.MAX_SPEED, "m/s")
        tr = self._trigger(ball, position, gain, contact, gravity, at, priority)
        if self._too_close(tr.position, tr.onset):
            return None
        result = self._solver(tr).solve(v, position=tr.position)
        if not result.success:
            raise SynthError(
                f"the contact of {tr.ball!r} at speed={v!r} m/s did not converge: {result.message}"
            )
        return self._new_voice(tr, lambda vid: self._hand_over_voice(result, tr, vid))

    def _new_voice(self, tr: Trigger, hand_over) -> Voice | None:
        """The Voice ``hand_over(vid)`` makes of a new id the voice limit admits, or None."""
        vid, limit = self._engine._next_voice_id(), self._engine._voice_limit
        if not limit.admit(vid, tr.priority):
            return None
        voice = None
        try:
            voice = hand_over(vid)
        finally:
            limit.settle(vid, voice)
        return voice

    def _hand_over_voice(self, result, tr: Trigger, vid: int) -> Voice | None:
        """Hand a solved hit over at every ear as voice ``vid``, or at none (None)."""
        records: list[int] = []
        for ear in self._ears:
            r = ear._ring.open_voice(vid, 1, tr.priority)
            if r < 0:
                break
            try:
                impact = _Impact(result, tr.onset, tr.gain)
                accepted = ear._hand_over(impact, ear._prepare(tr.position), r)
            except BaseException:
                ear._ring.close_voice(r, 1)
                vc.stop_records(self._ears, records, vid)
                raise
            if not accepted:
                ear._ring.close_voice(r, 1)
                break
            records.append(r)
        if len(records) < len(self._ears):  # refused at one ear: at every ear
            vc.stop_records(self._ears, records, vid)
            return None
        return Voice(self, vid, records, (tr.onset,), tr.priority)

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
        priority: int = 0,
    ) -> Voice | None:
        """Drop ``ball`` from ``height`` (m, in [1e-6, 1000]): the whole bouncing sequence
        (:func:`synth.simulate_bounces`), the other arguments as :meth:`hit`'s. Returns one
        :class:`Voice` (``voice.onsets``, s), or None when the ring lacks free slots
        (``drops_refused``); more impacts than ``max_pending`` raise ParameterError."""
        h = vc.check_height(height)
        tr = self._trigger(ball, position, gain, contact, gravity, at, priority)
        law = tr.law
        sequence = simulate_bounces(tr.ball, self.plate, drop_height=h, position=tr.position,
                                    gravity=tr.gravity, contact_law=law.law, rtol=law.rtol,
                                    **law.options())  # fmt: skip
        if len(sequence) > self._ring.capacity:
            raise ParameterError(
                f"the drop from height={height!r} m has {len(sequence)} impacts, more than "
                f"max_pending={self._ring.capacity} (the impacts a body holds): raise "
                f"max_pending, or drop from lower"
            )
        for imp in sequence:
            self._check_length(imp.result.separation_time)
        return self._new_voice(tr, lambda vid: self._hand_over_drop(sequence, tr, vid))

    def _hand_over_drop(self, sequence, tr: Trigger, vid: int) -> Voice | None:
        """Hand a drop's impacts over at every ear as voice ``vid``, all or none."""
        n = len(sequence)
        reserved = []  # (ear, voice record, slots not yet handed over)
        for ear in self._ears:
            r = ear._ring.open_voice(vid, n, tr.priority)
            slots = ear._ring.reserve_many(n, voice=r) if r >= 0 else None
            if slots is None:
                if r >= 0:
                    ear._ring.close_voice(r, n)
                _release(reserved)
                self._engine._drops_refused += 1
                return None
            reserved.append((ear, r, list(slots)))
        t0 = sequence[0].time if n else 0.0
        onsets = tuple(tr.onset + (imp.time - t0) for imp in sequence)
        try:
            for ear, r, slots in reserved:
                prepared = ear._prepare(tr.position)
                while slots:
                    k = n - len(slots)
                    result = sequence[k].result
                    weight = tr.ball.mass * tr.gravity if result.settled else 0.0
                    impact = _Impact(result, onsets[k], tr.gain, weight)
                    ear._submit(impact, prepared, r, slots[0])
                    slots.pop(0)  # handed over: not given back on a failure
        except BaseException:
            _release(reserved)
            raise
        return Voice(self, vid, [r for _, r, _ in reserved], onsets, tr.priority)

    def roll(self, ball: Ball, position, velocity, **options) -> rolling.RollingVoice | None:
        """A ``ball`` rolling from ``position`` ((x, y), m) at ``velocity`` ((vx, vy), m/s), the
        options (``envelope``, ``start``, ``gain``, ``contact``, ``rtol``) as
        :func:`synth.physics.rolling.roll`'s; the game updates it every frame
        (:class:`synth.live.rolling.RollingVoice`). None when all ``max_rolls`` slots roll."""
        return rolling.start_roll(self, ball, position, velocity, **options)

    @property
    def removed(self) -> bool:
        """Whether :meth:`remove` was called."""
        return self._removed

    def remove(self, fade: float | None = None) -> None:
        """Take the body out of its engine (later hits raise SynthError): it rings out (``fade``
        None) or fades over ``fade`` s (in [0.001, 10]); its arrays are then freed, its counts
        stay in the stats."""
        frames = None if fade is None else vc.stop_frames(self._engine, fade)
        if self._removed:
            return
        self._removed = True
        rolling.stop_rolls(self, fade)
        if frames is not None:
            for ear in self._ears:
                ring = ear._ring
                for r in range(ring.voices.shape[0]):
                    ring.control_voice(r, int(ring.voices[r, kernel.V_ID]), stop=frames)
        self._engine._retire(self)

    def _free(self) -> None:
        """Let go of the arrays of every ear (the mixing no longer reads them)."""
        for ear in self._ears:
            ear._freed, ear._prepared, ear._solvers = True, {}, {}
            ear._ring = ear._rolls = ear._arrays = ear._grid = None

    def stop_all(self) -> None:
        """End every voice and drop pending impacts at the next block (at once without a stream)."""
        if self._engine.running:
            for ear in self._ears:
                ear._counters[kernel.SILENCE] = 1  # the audio thread applies it
        else:
            self._apply_silence()

    def _apply_silence(self):
        for ear in self._ears:
            native.silence_body(self._engine._native.ctl, ear._record)


def _keep(cache: dict, key, value):
    """``cache[key] = value``, the oldest entry dropped beyond ``KEPT_POINTS``; ``value``."""
    if len(cache) >= KEPT_POINTS:
        cache.pop(next(iter(cache)))
    cache[key] = value
    return value


def _release(reserved) -> None:
    """Give back the slots a drop reserved and did not fill (``(body, record, slots)``)."""
    for ear, r, slots in reserved:
        for slot in slots:
            ear._ring.release(slot)
        ear._ring.close_voice(r, len(slots))


def check_listener(plate: Plate, listener, field: str) -> None:
    """``listener`` (the argument ``field``) an Accelerometer on ``plate`` or a Microphone."""
    if isinstance(listener, Accelerometer):
        plate.check_position(listener.position, f"{field}.position")
    elif not isinstance(listener, Microphone):
        raise ParameterError(f"{field}={listener!r} must be an Accelerometer or a Microphone")


def check_pan(value, channels: int, listeners: int = 1) -> float:
    """``pan`` checked for an engine of ``channels`` and a body of ``listeners`` (None: NaN)."""
    if value is None:
        return float("nan")
    if channels != 2:
        raise ParameterError(
            f"pan={value!r}: a pan places a body between two channels; this engine has "
            f"channels={channels} (make it with channels=2, or hear the body through one "
            f"listener per channel)"
        )
    if listeners > 1:
        raise ParameterError(
            f"pan={value!r}: this body is heard through {listeners} listeners (ears), whose "
            f"balance comes from the plate's radiation; pan is for a body of one listener"
        )
    return vc.closed("pan", value, -1.0, 1.0, "dimensionless")


def ears(position, facing=(1.0, 0.0), spacing: float = 0.18) -> tuple[Microphone, Microphone]:
    """A listener's two ears as microphones (left, right) for ``Engine(channels=2)``: the
    head at ``position`` ((x, y, z), m, z > 0), facing ``facing`` ((x, y), length > 0), the
    ears ``spacing`` m apart (in (0, 1]; 0.18 m, a head's width), the left one on the left (z
    up). Each ear hears each mode through its own Rayleigh gain: the balance comes from the
    plate's radiation."""
    x, y, z = checks.point("position", position, 3)
    fx, fy = checks.point("facing", facing, 2, "dimensionless")
    norm = float(np.hypot(fx, fy))
    if not norm > 0.0:
        raise ParameterError(f"facing={facing!r} must be a direction of length > 0")
    d = checks.in_range("spacing", spacing, 0.0, 1.0, "m", hi_open=False)
    lx, ly = -fy / norm * d / 2, fx / norm * d / 2  # the facing direction turned left
    return Microphone((x + lx, y + ly, z)), Microphone((x - lx, y - ly, z))
