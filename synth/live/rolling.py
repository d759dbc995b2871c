"""A ball rolling on a live body, its speed and position updated by the game every frame
(:meth:`synth.live.Body.roll`, :class:`RollingVoice`; docs/live.md, "Rolling").

The game's thread checks each update and evaluates the mode shapes along the straight
segment ahead of the ball (:func:`synth.sound.rolling.path_excitation`, every
``table_step`` m, over :data:`HORIZON` s at the update's speed, plus :data:`MARGIN` m
behind and beyond for the touching point's offset); the audio thread
(:mod:`synth.live.rolling_block`) takes the newest update at each block's start, rolls the
ball over the block with the offline contact integrator and drives the modes with its
force at the moving touching point. An update sounds from the next block's start: one
block plus the stream's output latency after the call at most.
"""

from __future__ import annotations

import math

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.live import kernel
from synth.live import rolling_block as rb
from synth.live.atomics import publish
from synth.live.hits import MAX_GAIN
from synth.live.voice import MAX_STOP_FADE, MIN_STOP_FADE
from synth.physics.rolling import Roller
from synth.physics.scene import Ball
from synth.sound.modal_bank import bank_coefficients
from synth.sound.rolling import POINTS_PER_WAVELENGTH, bending_wavenumber, path_excitation

#: Fastest rolling speed a voice takes, m/s.
MAX_ROLL_SPEED = 5.0
#: How far ahead an update's mode-shape table reaches, s at the update's speed: a game that
#: misses frames for longer holds the excitation at the table's end (counted in
#: :attr:`RollingVoice.overruns`).
HORIZON = 0.05
#: The table's reach behind the game's position and beyond the horizon, m: room for the
#: touching point's offset from the centre (sub-millimetre for roughness much lower than
#: the ball) and for the centre's path from the update's block to the next.
MARGIN = 2e-3
#: Default rolling slots a body holds (``Engine(max_rolls=...)``): none. A slot costs each
#: body its tables and modal state (``synth bench live`` prints the memory), and an engine
#: with slots compiles and loads the rolling contact's integrator beside its callback
#: (``synth bench cold``): an engine that rolls asks for them (``Body.roll`` says so).
MAX_ROLLS = 0


def table_step(model) -> float:
    """The mode-shape table's row spacing of a :class:`synth.sound.listener.ModalModel`, m:
    :data:`synth.sound.rolling.POINTS_PER_WAVELENGTH` rows per bending wavelength of its
    highest mode (as the offline rolling's table)."""
    w_max = float(np.max(np.abs(model.poles.imag))) if model.poles.size else 0.0
    k_b = bending_wavenumber(model.modes.plate, w_max)
    return 2.0 * math.pi / (POINTS_PER_WAVELENGTH * k_b) if k_b > 0.0 else 1.0


def body_rolls(slots: int, model, frames: int) -> dict:
    """A body's rolling slots (:func:`synth.live.rolling_block.rolling_arrays`): tables of
    rows enough for :data:`MAX_ROLL_SPEED` over :data:`HORIZON` plus the margins."""
    rows = int(math.ceil((MAX_ROLL_SPEED * HORIZON + 2.0 * MARGIN) / table_step(model))) + 2
    return rb.rolling_arrays(slots, model.poles.size, rows, frames)


def _velocity(velocity) -> tuple[float, float, float]:
    """``(speed, ux, uy)`` of ``velocity`` ((vx, vy), m/s), checked; ``(0, 0, 0)`` at rest."""
    vx, vy = checks.point("velocity", velocity, 2, "m/s")
    speed = math.hypot(vx, vy)
    if not speed <= MAX_ROLL_SPEED:
        raise ParameterError(
            f"velocity={velocity!r} has speed {speed!r} m/s: it must be at most "
            f"{MAX_ROLL_SPEED} m/s"
        )
    return (speed, vx / speed, vy / speed) if speed > 0.0 else (0.0, 0.0, 0.0)


def _reach(plate, x, y, ux, uy) -> float:
    """How far (m) the point ``(x, y)`` may move along ``(ux, uy)`` and stay on the plate."""
    reach = math.inf
    for p, u, size in ((x, ux, plate.length), (y, uy, plate.width)):
        if u > 0.0:
            reach = min(reach, (size - p) / u)
        elif u < 0.0:
            reach = min(reach, -p / u)
    return max(reach, 0.0)


class RollingVoice:
    """A ball rolling on a body (made by :meth:`synth.live.Body.roll`): the game updates its
    position and velocity (:meth:`update`, every frame), sets its ``gain`` and stops it
    (:meth:`stop`). Every method may be called from any thread.

    ``id``: unique in its engine (reported by :meth:`synth.live.Engine.ended` once it has
    ended). It ends after its stop fade; or, faded out over the engine's ``fade``, when
    its centre reaches the end of its surface's envelope (``ended_by == "surface"``) or
    its contact needs more than :data:`synth.live.rolling_block.MAX_STEPS_PER_SAMPLE`
    integration steps a sample (``"failed"``)."""

    def __init__(self, body, vid: int, slot: int, direction: tuple[float, float]):
        self.body = body
        self.id = vid
        self._slot = slot
        self._direction = direction
        # the body's: between the game's threads updating its voices and taking its slots
        self._lock = body._roll_lock
        rolls = body._rolls
        self._ints = rolls["roll_ints"][slot]  # its slot's scalars (kept after the body's end)
        self._floats = rolls["roll_floats"][slot]
        self._state = rolls["roll_y"][slot]

    def __repr__(self):
        return f"RollingVoice(id={self.id}, playing={self.playing})"

    @property
    def playing(self) -> bool:
        """Whether it still rolls or fades (read from the audio thread's state, no lock)."""
        ints = self._ints
        return (
            not self.body._freed
            and int(ints[rb.I_STATE]) == rb.LIVE
            and int(ints[rb.I_ID]) == self.id
        )

    @property
    def path_position(self) -> float:
        """How far the ball's centre has rolled along its surface's envelope, m (from the
        envelope's start; as of the last block mixed)."""
        return float(self._state[rb.rolling_kernels.S])

    @property
    def overruns(self) -> int:
        """Samples whose touching point lay beyond its update's table (updates too rare)."""
        return int(self._ints[rb.I_OVERRUN])

    @property
    def steps(self) -> int:
        """Integration steps taken so far (the audio thread's work)."""
        return int(self._ints[rb.I_STEPS])

    @property
    def frames(self) -> int:
        """Frames rolled so far."""
        return int(self._ints[rb.I_FRAMES])

    @property
    def ended_by(self) -> str | None:
        """``"stop"``, ``"surface"`` (the envelope's end), ``"failed"``, or None (rolling)."""
        code = int(self._ints[rb.I_ENDED])
        return {rb.END_STOPPED: "stop", rb.END_SURFACE: "surface", rb.END_FAILED: "failed"}.get(
            code
        )

    @property
    def gain(self) -> float:
        """The voice's gain (linear, in [0, 1e4]), on top of the body's; set while it rolls,
        it is ramped linearly over the next block."""
        return float(self._floats[rb.F_GAIN])

    @gain.setter
    def gain(self, value: float) -> None:
        g = checks.in_range("gain", value, 0.0, MAX_GAIN, "dimensionless", lo_open=False,
                            hi_open=False)  # fmt: skip
        with self._lock:
            if self.playing:
                self._floats[rb.F_GAIN] = g

    def update(self, position, velocity) -> None:
        """The ball's centre is now above ``position`` ((x, y), m from the plate's corner),
        moving at ``velocity`` ((vx, vy), m/s, speed at most :data:`MAX_ROLL_SPEED`): from
        the next block the ball rolls at that speed, its touching point moving from there
        along that direction. At rest (``(0, 0)``) it keeps its last direction."""
        plate = self.body.plate
        x, y = plate.check_position(position, "position")
        speed, ux, uy = _velocity(velocity)
        with self._lock:
            if speed > 0.0:
                self._direction = (ux, uy)
            if self.playing:
                self._publish(x, y, speed)

    def _publish(self, x: float, y: float, speed: float) -> None:
        """Write the table of the segment from ``(x, y)`` into the back buffer and swap it
        into the middle (flagged fresh) for the audio thread."""
        body, r = self.body, self._slot
        rolls = body._rolls
        if rolls is None:  # the body left its engine
            return
        ux, uy = self._direction
        plate = body.plate
        step = body._roll_step
        rows_cap = rolls["roll_rows"]
        back = min(MARGIN, _reach(plate, x, y, -ux, -uy))
        ahead = min(speed * HORIZON + MARGIN, _reach(plate, x, y, ux, uy))
        ahead = min(ahead, -back + (rows_cap - 1) * step)
        table = path_excitation(
            body._model, origin=(x, y), direction=(ux, uy), start=-back, stop=ahead, step=step
        )
        ints = self._ints
        b = int(ints[rb.I_BACK])
        rows = table.excitation.shape[0]
        rolls["roll_tables"][r, b, :rows] = table.excitation
        rolls["roll_meta"][r, b] = (speed, table.start, table.step, rows)
        old = rb.exchange(ints, rb.I_MIDDLE, b | rb.FRESH)
        ints[rb.I_BACK] = old & 3

    def stop(self, fade: float | None = None) -> None:
        """Fade it out from the next block: a raised cosine over ``fade`` s (in [0.001, 10];
        default the engine's ``fade``), then it ends. Does nothing on an ended voice; a
        second stop keeps the first fade."""
        engine = self.body._engine
        f = engine._fade if fade is None else fade
        f = checks.in_range("fade", f, MIN_STOP_FADE, MAX_STOP_FADE, "s", lo_open=False,
                            hi_open=False)  # fmt: skip
        with self._lock:
            ints = self._ints
            if self.playing and ints[rb.I_STOP] < 0:
                ints[rb.I_STOP] = max(1, int(round(f * engine.samplerate)))


def rolls(body) -> bool:
    """Whether a rolling voice of ``body`` rolls or fades (or is being handed over)."""
    arrays = body._rolls
    return arrays is not None and bool(np.any(arrays["roll_ints"][:, rb.I_STATE] != rb.FREE))


def stop_rolls(body, fade: float | None) -> None:
    """Fade out every rolling voice of ``body`` (taken out of its engine) over ``fade`` s
    (None: the engine's ``fade``)."""
    engine = body._engine
    frames = max(1, int(round((engine._fade if fade is None else fade) * engine.samplerate)))
    with body._roll_lock:
        ints = body._rolls["roll_ints"]
        for r in range(ints.shape[0]):
            if ints[r, rb.I_STATE] == rb.LIVE and ints[r, rb.I_STOP] < 0:
                ints[r, rb.I_STOP] = frames


def start_roll(
    body, ball, position, velocity, *, envelope, start: float = 0.0, gain: float = 1.0,
    contact: str = "hertz", rtol: float = 1e-6,
) -> RollingVoice | None:  # fmt: skip
    """:meth:`synth.live.Body.roll` (see there)."""
    engine = body._engine
    if body._removed:
        raise SynthError("this body was removed from its engine (Body.remove): add it again")
    engine._check_open("roll a ball")
    engine._check_alive()
    if len(body._ears) != 1 or body._model.listener.shape is not None:
        raise ParameterError(
            "a rolling voice plays on a body heard by one microphone (not through ears, "
            "not an accelerometer)"
        )
    if not isinstance(ball, Ball):
        raise ParameterError(f"ball={ball!r} must be a Ball")
    x, y = body.plate.check_position(position, "position")
    speed, ux, uy = _velocity(velocity)
    g = checks.in_range("gain", gain, 0.0, MAX_GAIN, "dimensionless", lo_open=False,
                        hi_open=False)  # fmt: skip
    fs = engine.samplerate
    roller = Roller.over(
        ball, body.plate, envelope, samplerate=fs, origin=(0.0, 0.0), contact=contact, rtol=rtol
    )
    s0 = checks.in_range("start", start, 0.0, envelope.length, "metres", lo_open=False)
    slots = body._rolls["roll_ints"]
    with body._roll_lock:  # no update of an ended voice of the slot writes into it meanwhile
        free = [r for r in range(slots.shape[0]) if slots[r, rb.I_STATE] == rb.FREE]
        if not free:
            body.rolls_refused += 1
            return None
        r = free[0]
        slots[r, rb.I_STATE] = rb.WRITING
        try:
            _fill_slot(body, r, roller, envelope, s0, speed, g)
            vid = engine._next_voice_id()
            voice = RollingVoice(body, vid, r, (ux, uy) if speed > 0.0 else (1.0, 0.0))
            slots[r, rb.I_ID] = vid
            voice._publish(x, y, speed)
        except BaseException:
            slots[r, rb.I_STATE] = rb.FREE
            raise
        publish(slots[r], rb.I_STATE, rb.LIVE)  # last: the audio thread rolls it from now on
    return voice


def _fill_slot(body, r, roller, envelope, s0, speed, gain) -> None:
    """Write slot ``r``'s constants, start state, coefficients and envelope (the game's
    thread owns it until it is published)."""
    arrays = body._rolls
    model = body._model
    fs = body._engine.samplerate
    coef_env = np.ascontiguousarray(envelope.coefficients, dtype=float)
    offsets = np.ascontiguousarray(envelope.contact_offsets, dtype=float)
    body._roll_holds[r] = (envelope, coef_env, offsets)  # alive while the slot reads them
    state = roller.initial_state(speed, s0)
    fv = arrays["roll_floats"][r]
    fv[rb.F_M : rb.F_HMAX + 1] = roller.kernel_constants()
    fv[rb.F_DX] = envelope.spacing
    fv[rb.F_LENGTH] = envelope.length
    fv[rb.F_H] = state.step
    fv[rb.F_ANCHOR] = s0
    fv[rb.F_GAIN] = fv[rb.F_GAIN_NOW] = gain
    fv[rb.F_PREVIOUS] = fv[rb.F_SPEED] = 0.0
    arrays["roll_y"][r] = state.vector
    arrays["roll_z"][r] = 0.0
    p = np.asarray(model.poles, dtype=complex)
    c = bank_coefficients(p, np.ones(p.size), np.asarray(model.output) * body._scale, fs)
    hold = (np.exp(p / fs) - 1.0) / p
    q = -1.0 / p
    arrays["roll_coef"][r] = (c.step_re, c.step_im, c.coef_re, c.coef_im, hold.real,
                              hold.imag, q.real, q.imag)  # fmt: skip
    iv = arrays["roll_ints"][r]
    fade = max(1, int(round(body._engine._fade * fs)))
    values = {
        rb.I_MIDDLE: 1, rb.I_FRONT: 0, rb.I_BACK: 2, rb.I_STOP: -1, rb.I_FADE_AT: -1,
        rb.I_FADE_LEN: 1, rb.I_END_FADE: fade, rb.I_STARTED: 0, rb.I_ENDED: 0, rb.I_STEPS: 0,
        rb.I_FRAMES: 0, rb.I_OVERRUN: 0, rb.I_ENV: coef_env.ctypes.data,
        rb.I_ENV_N: coef_env.shape[0], rb.I_OFF: offsets.ctypes.data, rb.I_OFF_N: offsets.size,
        rb.I_EARS: int(body._counters[kernel.EARS]),
    }  # fmt: skip
    for field, value in values.items():
        iv[field] = value
    arrays["roll_meta"][r] = 0.0
