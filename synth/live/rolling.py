"""A ball rolling on a live body, updated by the game every frame (docs/live.md, "Rolling"):
the game's thread evaluates the mode shapes along the segment ahead, the audio thread
(:mod:`synth.live.rolling_block`) rolls the ball and drives the modes."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.live import kernel
from synth.live import rolling_block as rb
from synth.live.kernel import publish
from synth.live.voice import check_gain, stop_frames
from synth.physics.path import edge_distance
from synth.physics.rolling import Roller
from synth.physics.scene import Ball
from synth.physics.surface import ContactEnvelope
from synth.sound.rolling import path_excitation, table_step

#: Fastest rolling speed a voice takes, m/s; how far ahead an update's mode-shape table
#: reaches, s at its speed (beyond: held at its end, :attr:`RollingVoice.overruns`); its
#: reach behind the position and beyond the horizon, m (the touching point's offset).
MAX_ROLL_SPEED = 5.0
HORIZON = 0.05
MARGIN = 2e-3
#: Default rolling slots a body holds (``Engine(max_rolls=...)``): none, since a slot costs
#: memory and an engine with slots compiles the rolling integrator (``synth bench cold``).
MAX_ROLLS = 0


def body_rolls(slots: int, model, frames: int) -> dict:
    """A body's rolling slots, their tables long enough for :data:`MAX_ROLL_SPEED`."""
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


#: What ended a rolling voice, by ``I_ENDED``.
ENDED_BY = {rb.END_STOPPED: "stop", rb.END_SURFACE: "surface", rb.END_FAILED: "failed"}


def _counter(field: int, doc: str) -> property:
    return property(lambda voice: int(voice._ints[field]), doc=doc)


class RollingVoice:
    """A ball rolling on a body (:meth:`synth.live.Body.roll`), updated, set a ``gain`` and
    stopped from any thread; its ``id`` is reported by :meth:`synth.live.Engine.ended` once it
    ended at every ear (:attr:`ended_by`). Figures: its first ear's."""

    def __init__(self, body, vid: int, slots: list[int], direction: tuple[float, float]):
        self.body, self.id, self._direction = body, vid, direction
        self._slots = tuple(zip(body._ears, slots))  # (ear, its slot) of each ear
        # the body's: between the game's threads updating its voices and taking its slots
        self._lock = body._roll_lock
        self._ints = body._rolls["roll_ints"][slots[0]]  # its contact's (kept after the end)
        self._ear_ints = [ear._rolls["roll_ints"][r] for ear, r in self._slots]
        self._floats = [ear._rolls["roll_floats"][r] for ear, r in self._slots]
        self._state = body._rolls["roll_y"][slots[0]]

    def _holds(self, ear: int) -> bool:
        """Whether the voice still holds its slot at ear ``ear`` (ears may free it apart)."""
        ints = self._ear_ints[ear]
        return int(ints[rb.I_STATE]) != rb.FREE and int(ints[rb.I_ID]) == self.id

    def __repr__(self):
        return f"RollingVoice(id={self.id}, playing={self.playing})"

    @property
    def playing(self) -> bool:
        """Whether it still rolls or fades (read from the audio thread's state, no lock)."""
        i = self._ints
        return not self.body._freed and int(i[rb.I_STATE]) == rb.LIVE and int(i[rb.I_ID]) == self.id

    @property
    def path_position(self) -> float:
        """How far the ball's centre has rolled along its envelope, m (at the last block)."""
        return float(self._state[rb.rolling_kernels.S])

    overruns = _counter(rb.I_OVERRUN, "Samples whose touching point lay beyond its table.")
    steps = _counter(rb.I_STEPS, "Integration steps taken so far.")
    frames = _counter(rb.I_FRAMES, "Frames rolled so far.")

    @property
    def ended_by(self) -> str | None:
        """``"stop"``, ``"surface"`` (the envelope's end), ``"failed"`` (more than
        ``MAX_STEPS_PER_SAMPLE`` steps a sample), or None (rolling)."""
        return ENDED_BY.get(int(self._ints[rb.I_ENDED]))

    @property
    def gain(self) -> float:
        """The voice's gain (linear, in [0, 1e4]) on top of the body's, ramped over a block."""
        return float(self._floats[0][rb.F_GAIN])

    @gain.setter
    def gain(self, value: float) -> None:
        g = check_gain(value)
        with self._lock:
            if self.playing:
                for ear, floats in enumerate(self._floats):
                    if self._holds(ear):
                        floats[rb.F_GAIN] = g

    def update(self, position, velocity) -> None:
        """The ball's centre is now above ``position`` ((x, y), m), moving at ``velocity``
        ((vx, vy), m/s, at most :data:`MAX_ROLL_SPEED`; at rest it keeps its direction)."""
        x, y = self.body.plate.check_position(position, "position")
        speed, ux, uy = _velocity(velocity)
        with self._lock:
            if speed > 0.0:
                self._direction = (ux, uy)
            if self.playing:
                self._publish(x, y, speed)

    def _publish(self, x: float, y: float, speed: float) -> None:
        """Write the segment's table from ``(x, y)`` into each ear's back buffer and swap them
        into the middle (flagged fresh) at once."""
        body = self.body
        if any(ear._rolls is None for ear in body._ears):  # the body left its engine
            return
        ux, uy = self._direction
        plate, step, rows_cap = body.plate, body._roll_step, body._rolls["roll_rows"]
        back = min(MARGIN, max(edge_distance(plate, (x, y), (-ux, -uy)), 0.0))
        ahead = min(speed * HORIZON + MARGIN, max(edge_distance(plate, (x, y), (ux, uy)), 0.0))
        ahead = min(ahead, -back + (rows_cap - 1) * step)
        if not self._holds(0):  # ended: its slots may be another voice's
            return
        tables = {}  # by the ear's rendered modes (the same for ears of one plate)
        contact, b = self._ints, int(self._ints[rb.I_BACK])
        for ear, r in self._slots:
            key = (id(ear._model.modes), ear._model.rendered.tobytes())
            if key not in tables:
                tables[key] = path_excitation(
                    ear._model, origin=(x, y), direction=(ux, uy), start=-back, stop=ahead,
                    step=step,
                )  # fmt: skip
            table, rolls = tables[key], ear._rolls
            rows = table.excitation.shape[0]
            rolls["roll_tables"][r, b, :rows] = table.excitation
            rolls["roll_meta"][r, b] = (speed, table.start, table.step, rows)
        old = rb.exchange(contact, rb.I_MIDDLE, b | rb.FRESH)
        contact[rb.I_BACK] = old & 3

    def stop(self, fade: float | None = None) -> None:
        """Fade it out from the next block over ``fade`` s (in [0.001, 10]; default the
        engine's ``fade``); a second stop keeps the first fade."""
        frames = stop_frames(self.body._engine, fade)
        with self._lock:
            if self.playing and self._holds(0) and self._ints[rb.I_STOP] < 0:
                self._ints[rb.I_STOP] = frames


def rolls(body) -> bool:
    """Whether a rolling voice of ``body`` rolls, fades or is being handed over."""
    return any(
        ear._rolls is not None and bool(np.any(ear._rolls["roll_ints"][:, rb.I_STATE] != rb.FREE))
        for ear in body._ears
    )


def stop_rolls(body, fade: float | None) -> None:
    """Fade out every rolling voice of ``body`` over ``fade`` s (None: the engine's)."""
    frames = stop_frames(body._engine, fade)
    with body._roll_lock:
        if body._rolls is None:
            return
        ints = body._rolls["roll_ints"]
        for r in range(ints.shape[0]):
            if ints[r, rb.I_STATE] == rb.LIVE and ints[r, rb.I_STOP] < 0:
                ints[r, rb.I_STOP] = frames


@dataclass(frozen=True)
class RollOptions:
    """:meth:`synth.live.Body.roll`'s options: the ``envelope`` and the centre's ``start`` on it
    (m), the voice's ``gain``, the ``contact`` law and ``rtol`` (as :func:`synth.physics.
    rolling.roll`)."""

    envelope: ContactEnvelope
    start: float = 0.0
    gain: float = 1.0
    contact: str = "hertz"
    rtol: float = 1e-6


def start_roll(body, ball, position, velocity, **options) -> RollingVoice | None:
    """:meth:`synth.live.Body.roll` (see there; ``options``: :class:`RollOptions`)."""
    o = RollOptions(**options)
    envelope, engine = o.envelope, body._engine
    if body._removed:
        raise SynthError("this body was removed from its engine (Body.remove): add it again")
    engine._check_open("roll a ball")
    engine._check_alive()
    if engine.max_rolls == 0:
        raise ParameterError(
            "max_rolls=0: this body's engine has no rolling slots; make the engine with "
            "synth.Engine(..., max_rolls=1) (or more, up to 16) to roll balls on its bodies"
        )
    if not isinstance(ball, Ball):
        raise ParameterError(f"ball={ball!r} must be a Ball")
    x, y = body.plate.check_position(position, "position")
    speed, ux, uy = _velocity(velocity)
    g = check_gain(o.gain)
    roller = Roller.over(
        ball, body.plate, envelope, samplerate=engine.samplerate, origin=(0.0, 0.0),
        contact=o.contact, rtol=o.rtol,
    )  # fmt: skip
    s0 = checks.in_range("start", o.start, 0.0, envelope.length, "metres", lo_open=False)
    with body._roll_lock:  # no update of an ended voice of the slot writes into it meanwhile
        slots = _take_slots(body)
        if slots is None:
            body.rolls_refused += 1
            return None
        try:
            _fill_contact(body, slots[0], roller, envelope, s0, speed)
            for ear, r in zip(body._ears, slots):
                _fill_slot(ear, r, body, g)
            vid = engine._next_voice_id()
            voice = RollingVoice(body, vid, slots, (ux, uy) if speed > 0.0 else (1.0, 0.0))
            for ear, r in zip(body._ears, slots):
                ear._rolls["roll_ints"][r, rb.I_ID] = vid
            voice._publish(x, y, speed)
        except BaseException:
            for ear, r in zip(body._ears, slots):
                ear._rolls["roll_ints"][r, rb.I_STATE] = rb.FREE
            raise
        for ear, r in zip(body._ears, slots):  # last: the audio thread rolls it from now on
            publish(ear._rolls["roll_ints"][r], rb.I_STATE, rb.LIVE)
    return voice


def _take_slots(body) -> list[int] | None:
    """The same rolling slot at each ear, free at every one (the contact slot is not reused
    while another ear reads it), marked ``WRITING``; None if none (under ``_roll_lock``)."""
    free = np.ones(body._rolls["roll_ints"].shape[0], dtype=bool)
    for ear in body._ears:
        free &= ear._rolls["roll_ints"][:, rb.I_STATE] == rb.FREE
    if not free.any():
        return None
    slots = [int(np.flatnonzero(free)[0])] * len(body._ears)
    for ear, r in zip(body._ears, slots):
        ear._rolls["roll_ints"][r, rb.I_STATE] = rb.WRITING
    return slots


def _fill_contact(body, r, roller, envelope, s0, speed) -> None:
    """Write the contact of slot ``r`` at ``body``'s first ear (unpublished)."""
    arrays, fs = body._rolls, body._engine.samplerate
    coef_env = np.ascontiguousarray(envelope.coefficients, dtype=float)
    offsets = np.ascontiguousarray(envelope.contact_offsets, dtype=float)
    body._roll_holds[r] = (envelope, coef_env, offsets)  # alive while the slot reads them
    state = roller.initial_state(speed, s0)
    fv = arrays["roll_floats"][r]
    fv[rb.F_M : rb.F_HMAX + 1] = roller.constants
    fv[[rb.F_DX, rb.F_LENGTH, rb.F_H, rb.F_ANCHOR]] = (envelope.spacing, envelope.length,
                                                        state.step, s0)  # fmt: skip
    fv[[rb.F_PREVIOUS, rb.F_SPEED, rb.F_BEFORE]] = 0.0
    arrays["roll_y"][r] = state.vector
    fade = max(1, int(round(body._engine.options.fade * fs)))
    values = {
        rb.I_MIDDLE: 1, rb.I_FRONT: 0, rb.I_BACK: 2, rb.I_STOP: -1, rb.I_FADE_FROM: -1,
        rb.I_FADE_LEN: 1, rb.I_END_FADE: fade, rb.I_ENDED: 0, rb.I_STEPS: 0, rb.I_FRAMES: 0,
        rb.I_ENV: coef_env.ctypes.data, rb.I_ENV_N: coef_env.shape[0],
        rb.I_OFF: offsets.ctypes.data, rb.I_OFF_N: offsets.size, rb.I_BLOCK: -1,
    }  # fmt: skip
    arrays["roll_ints"][r, list(values)] = list(values.values())


def _fill_slot(body, r, lead, gain) -> None:
    """Write slot ``r`` at the ear ``body``: gain, modes at rest, coefficients and the
    addresses of its contact at the first ear ``lead`` (unpublished)."""
    arrays, fs = body._rolls, body._engine.samplerate
    fv = arrays["roll_floats"][r]
    fv[rb.F_GAIN] = fv[rb.F_GAIN_NOW] = gain
    arrays["roll_z"][r] = 0.0
    with body._move_lock:  # the listener's gains and their sequence number together
        model = body._model
        heard_seq = int(body._heard_seq[kernel.SEQ_PUT])
        gains = np.asarray(model.output, dtype=complex)
    accelerometer = model.listener.shape is not None
    p = np.asarray(model.poles, dtype=complex)
    hold, q, step = (np.exp(p / fs) - 1.0) / p, -1.0 / p, np.exp(p / fs)
    coef = arrays["roll_coef"][r]
    coef[:] = 0.0
    rows = {rb.C_ER: step.real, rb.C_EI: step.imag, rb.C_HR: hold.real, rb.C_HI: hold.imag,
            rb.C_QR: q.real, rb.C_QI: q.imag}  # fmt: skip
    rows.update(rb.heard_coefficients(gains, p, body._scale, accelerometer))
    for row, values in rows.items():
        coef[row] = values
    contact = lead._rolls
    values = {
        rb.I_STARTED: 0, rb.I_OVERRUN: 0, rb.I_EARS: int(body._counters[kernel.EARS]),
        rb.I_HEARD: heard_seq, rb.I_DIRECT: int(accelerometer),
        rb.I_C_INTS: contact["roll_ints"][r].ctypes.data,
        rb.I_C_FLOATS: contact["roll_floats"][r].ctypes.data,
        rb.I_C_Y: contact["roll_y"][r].ctypes.data,
        rb.I_C_BUF: contact["roll_buf"][r].ctypes.data,
    }  # fmt: skip
    arrays["roll_ints"][r, list(values)] = list(values.values())
    arrays["roll_meta"][r] = 0.0
