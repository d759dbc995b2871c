"""A hit or a drop on a live body: its checked arguments (:class:`Trigger`), its handle
(:class:`Voice`), and its hand-off to the audio thread (docs/live.md), a bounded ring of
preallocated slots, each READY (amplitudes computed here) or a PULSE (transformed by the
audio thread). Producers reserve under their own lock and publish the state word last."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from synth import checks
from synth.errors import ParameterError
from synth.live import kernel
from synth.live.kernel import publish
from synth.physics.scene import MAX_DROP_HEIGHT, MIN_DROP_HEIGHT, Ball, Contact, HollowBall, Plate

if TYPE_CHECKING:
    from synth.live.body import Body

#: Largest speed of a hit, m/s: far beyond any elastic range, a bound against nonsense.
MAX_SPEED = 100.0
#: Largest gain of a hit or a body (linear, +80 dB: a small panel heard afar needs ~70 dB).
MAX_GAIN = 1e4
#: Longest time ahead of the engine's clock a hit or drop may be scheduled, s.
MAX_AHEAD = 60.0
#: Relative accuracy of a hit's contact solution (a drop uses a scene's default).
HIT_RTOL = 1e-6
#: The contact law of a hit or a drop given none: Hertz, or the thin-shell law.
DEFAULT_CONTACT = Contact()
SHELL_CONTACT = Contact(law="shell")


@dataclass(slots=True)
class Trigger:
    """A hit's or drop's ball, point (m), gain, law, gravity (m/s^2), start (s) and priority."""

    ball: Ball
    position: tuple[float, float]
    gain: float
    law: Contact
    gravity: float
    onset: float
    priority: int


def trigger(plate: Plate, ball, position, gain, contact, gravity, onset, priority) -> Trigger:
    """The arguments a hit and a drop share, checked (``onset`` by the engine's clock, s)."""
    return Trigger(
        ball=check_ball(ball, plate),
        position=plate.check_position(plate.centre if position is None else position, "position"),
        gain=checks.positive_at_most("gain", gain, MAX_GAIN, "dimensionless"),
        law=check_contact(contact, ball),
        gravity=checks.positive("gravity", gravity, "m/s^2"),
        onset=onset,
        priority=check_int("priority", priority, 0, MAX_PRIORITY, "higher plays first"),
    )


def check_ball(ball, plate: Plate) -> Ball:
    """``ball`` checked: a Ball whose diameter does not exceed the plate's smaller side."""
    if not isinstance(ball, Ball):
        raise ParameterError(f"ball={ball!r} must be a Ball")
    if 2.0 * ball.radius > min(plate.length, plate.width):
        raise ParameterError(
            f"ball.radius={ball.radius!r} is too large for the plate: the ball's diameter "
            f"must not exceed the plate's smaller side "
            f"{min(plate.length, plate.width)!r} (metres)"
        )
    return ball


def check_contact(contact, ball=None) -> Contact:
    """``contact`` checked: None (the ball's own law) or a Contact on the plate's impedance."""
    if contact is None:
        return SHELL_CONTACT if isinstance(ball, HollowBall) else DEFAULT_CONTACT
    if not isinstance(contact, Contact):
        raise ParameterError(f"contact={contact!r} must be None or a Contact")
    if contact.plate == "modal":
        raise ParameterError(
            f"contact.plate={contact.plate!r}: a live body solves its contacts with the "
            f"plate's impedance (contact.plate='impedance', or 'auto', which a live body "
            f"solves on the impedance plate: it carries no modes in the contact)"
        )
    return contact


def check_height(height) -> float:
    return closed("height", height, MIN_DROP_HEIGHT, MAX_DROP_HEIGHT, "m")


def closed(name, value, lo, hi, unit) -> float:
    """``value`` checked: a finite float in [lo, hi] (unit)."""
    return checks.in_range(name, value, lo, hi, unit, lo_open=False, hi_open=False)


def check_int(name, value, lo, hi, unit):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ParameterError(f"{name}={value!r} must be an integer in [{lo}, {hi}] ({unit})")
    return int(value)


#: Default voices a body rings at once (``max_voices``), each a modal state (a bank a block).
MAX_VOICES = 8
#: A stolen voice's raised-cosine fade, s: short (the new voice is not masked long) and of
#: zero slope at both ends (no click).
STEAL_FADE = 0.005
#: Bounds of a :meth:`Voice.stop` fade, s; largest priority (integers from 0, the default).
MIN_STOP_FADE = 0.001
MAX_STOP_FADE = 10.0
MAX_PRIORITY = 255


def check_gain(gain) -> float:
    """A voice's gain (linear), checked: in [0, MAX_GAIN]."""
    return closed("gain", gain, 0.0, MAX_GAIN, "dimensionless")


def stop_frames(engine, fade: float | None) -> int:
    """A stop fade of ``fade`` s (None: the engine's ``fade``), checked, in frames (>= 1)."""
    fade = engine.options.fade if fade is None else fade
    f = closed("fade", fade, MIN_STOP_FADE, MAX_STOP_FADE, "s")
    return max(1, int(round(f * engine.samplerate)))


class Voice:
    """A handle on one sound of a body, a hit or a whole drop, usable from any thread: ``id``
    (:meth:`Engine.ended`), ``onsets`` (s), ``priority`` in [0, MAX_PRIORITY] (a new voice
    steals the lowest priority's, of those the oldest, or is refused). It ends when every
    mode is below its share of ``floor_db`` under its peak, or its stop fade ends."""

    __slots__ = ("body", "id", "onsets", "priority", "_records", "_gain")

    def __init__(self, body: Body, vid: int, records, onsets: tuple, priority: int = 0):
        self.body, self.id, self.onsets, self.priority = body, vid, tuple(onsets), priority
        self._records = tuple(records)  # the voice's record at each of the body's ears
        self._gain = 1.0

    def __repr__(self):
        return f"Voice(id={self.id}, onset={self.onset!r}, playing={self.playing})"

    @property
    def onset(self) -> float:
        """The start of its first tick, s on the engine's clock."""
        return self.onsets[0]

    @property
    def playing(self) -> bool:
        """Whether the voice is pending or ringing (read without a lock)."""
        if self.body._freed:
            return False
        return any(
            ear._ring.voice_alive(r, self.id) for ear, r in zip(self.body._ears, self._records)
        )

    def _control(self, **request) -> None:
        if not self.body._freed:
            for ear, r in zip(self.body._ears, self._records):
                ear._ring.control_voice(r, self.id, **request)

    @property
    def gain(self) -> float:
        """The voice's gain (linear, in [0, MAX_GAIN], default 1), ramped over the next block."""
        return self._gain

    @gain.setter
    def gain(self, value: float) -> None:
        self._gain = check_gain(value)
        self._control(gain=self._gain)

    def stop(self, fade: float | None = None) -> None:
        """Fade out from the next block over ``fade`` s (in [0.001, 10]; default the engine's),
        its impacts not yet played dropped; a second stop keeps the first fade."""
        self._control(stop=stop_frames(self.body._engine, fade))


def stop_records(ears, records, vid) -> None:
    """Drop voice ``vid`` at the ears that took it: refused at one ear, at every ear."""
    for ear, r in zip(ears, records):
        ear._ring.control_voice(r, vid, stop=0)


class VoiceLimit:
    """The engine-wide voice cap (``max_total_voices``; None: none), kept on the threads that
    make voices: beyond it the lowest priority's, of those the oldest, fades out over
    ``STEAL_FADE`` (``stolen``) or the new one is refused (``refused``)."""

    def __init__(self, limit: int | None):
        self.limit, self.stolen, self.refused = limit, 0, 0
        self._live: dict = {}  # id -> Voice (None while its hit is handed over)
        self._lock = threading.Lock()  # between the threads that make voices

    def admit(self, vid: int, priority: int) -> bool:
        """Make room for voice ``vid`` of ``priority`` (stealing one), or refuse it (False)."""
        if self.limit is None:
            return True
        with self._lock:
            for k, voice in list(self._live.items()):
                if voice is not None and not voice.playing:
                    del self._live[k]
            if len(self._live) >= self.limit:
                ringing = [v for v in self._live.values() if v is not None]
                victim = min(ringing, key=lambda v: (v.priority, v.onset, v.id), default=None)
                if victim is None or victim.priority > priority:
                    self.refused += 1
                    return False
                victim.stop(fade=STEAL_FADE)
                del self._live[victim.id]
                self.stolen += 1
            self._live[vid] = None
            return True

    def settle(self, vid: int, voice: Voice | None) -> None:
        """Voice ``vid`` admitted was handed over (``voice``) or refused by its body (None)."""
        if self.limit is None:
            return
        with self._lock:
            if voice is None:
                self._live.pop(vid, None)
            elif vid in self._live:
                self._live[vid] = voice


#: Slot state while a producer fills it: not the least, so a FREE slot is ``state``'s minimum.
WRITING = 2


class PendingRing:
    """``capacity`` slots of impacts of ``modes`` modes (``max_contact`` in-contact samples,
    ``pulse_samples`` of pulse; at most ``max_new`` PULSE ones wait), ``voices`` records."""

    def __init__(
        self,
        capacity: int,
        modes: int,
        max_contact: int,
        pulse_samples: int,
        max_new: int,
        voices: int = 1,
    ):
        self.voice = np.zeros(capacity, dtype=np.int64)  # each slot's voice record
        self.voices = np.zeros((voices, kernel.N_VOICE_FIELDS), dtype=np.int64)
        self.voices[:, kernel.V_SLOT] = -1
        self.voice_gain = np.ones(voices)
        # each slot's state word, first sample joining the modes, in-contact samples' start, length
        self.state, self.inject, self.first, self.length = np.zeros((4, capacity), dtype=np.int64)
        self.amplitudes = np.zeros((capacity, modes), dtype=complex)
        self.response = np.zeros((capacity, max_contact))
        self.reference = np.zeros(capacity)
        # the PULSE form: coefficients (re, im); force (N) and slope (N/s) on the grid's
        # ``points`` points then at the in-contact samples; kernel.N_PULSE_FIELDS scalars
        self.coefficients = np.zeros((capacity, 2, modes))
        self.samples = np.zeros((capacity, 2, pulse_samples))
        self.points = np.zeros(capacity, dtype=np.int64)
        self.pulse = np.zeros((capacity, kernel.N_PULSE_FIELDS))
        for a in (self.amplitudes, self.response, self.coefficients, self.samples):
            a.fill(0.0)  # map every page now, not at a hit
        self.capacity, self.max_contact, self.pulse_samples = capacity, max_contact, pulse_samples
        self.max_new, self.refused = max_new, 0
        self.pulses = 0  # pulses handed over so far (producers)
        self.transformed = np.zeros(1, dtype=np.int64)  # pulses taken by the audio thread
        self._lock = threading.Lock()  # between producers only
        self._next = 0  # the slot after the last one reserved

    def pending(self) -> int:
        """Impacts handed over and not yet played."""
        return int(np.count_nonzero((self.state == kernel.READY) | (self.state == kernel.PULSE)))

    def open_voice(self, vid: int, impacts: int, priority: int = 0) -> int:
        """A free voice record for voice ``vid`` handing over ``impacts``, or -1 (counted)."""
        with self._lock:
            r = int(self.voices[:, kernel.V_STATE].argmin())
            if self.voices[r, kernel.V_STATE] != kernel.V_FREE:
                self.refused += impacts
                return -1
            fields = [kernel.V_ID, kernel.V_PUT, kernel.V_PLAYED, kernel.V_STOP, kernel.V_DEAD,
                      kernel.V_SLOT, kernel.V_PRIORITY]  # fmt: skip
            self.voices[r, fields] = (vid, impacts, 0, -1, 0, -1, priority)
            self.voice_gain[r] = 1.0
            self.voices[r, kernel.V_STATE] = kernel.V_LIVE
            return r

    def close_voice(self, r: int, unsent: int) -> None:
        """Take back ``unsent`` of the impacts record ``r`` announced; with none left, free it."""
        with self._lock:
            v = self.voices[r]
            v[kernel.V_PUT] -= unsent
            if v[kernel.V_PUT] == 0:
                v[kernel.V_STATE] = kernel.V_FREE
            else:
                v[kernel.V_STOP] = max(int(v[kernel.V_STOP]), 0)  # handed-over impacts drop

    def voice_alive(self, r: int, vid: int) -> bool:
        """Whether voice record ``r`` still holds voice ``vid`` (lock-free)."""
        return (
            int(self.voices[r, kernel.V_STATE]) == kernel.V_LIVE
            and int(self.voices[r, kernel.V_ID]) == vid
        )

    def control_voice(self, r: int, vid: int, gain=None, stop=None) -> None:
        """Set voice ``vid``'s gain or stop fade (samples; the first kept), if ``r`` holds it."""
        with self._lock:
            if not self.voice_alive(r, vid):
                return
            if gain is not None:
                self.voice_gain[r] = gain
            if stop is not None and self.voices[r, kernel.V_STOP] < 0:
                self.voices[r, kernel.V_STOP] = stop

    def reserve(self, pulse: bool = False, bounded: bool = True, voice: int = 0) -> int:
        """A FREE slot for voice record ``voice``, marked WRITING for the caller to fill and
        publish; -1 (counted) when full or, for a ``bounded`` pulse, ``max_new`` wait."""
        with self._lock:
            i = self._next
            if self.state[i] != kernel.FREE:  # slots mostly free in the order they were taken
                i = int(self.state.argmin())
            if self.state[i] != kernel.FREE or (
                pulse and bounded and self.pulses - int(self.transformed[0]) >= self.max_new
            ):
                self.refused += 1
                return -1
            self.state[i] = WRITING
            self.voice[i] = voice
            self._next = i + 1 if i + 1 < self.state.shape[0] else 0
            if pulse:
                self.pulses += 1
            return i

    def reserve_many(self, n: int, voice: int = 0) -> list[int] | None:
        """``n`` FREE slots for voice record ``voice``, marked WRITING, or None (counted)."""
        with self._lock:
            free = np.flatnonzero(self.state == kernel.FREE)
            if free.size < n:
                self.refused += n
                return None
            slots = [int(i) for i in free[:n]]
            self.state[slots] = WRITING
            self.voice[slots] = voice
            return slots

    def publish(self, slot: int, inject: int, first: int, length: int, reference=0.0, points=None):
        """Hand ``slot`` over: amplitudes join at sample ``inject``, ``length`` in-contact
        samples from ``first``; READY with its heard peak ``reference``, or a PULSE of
        ``points`` grid samples."""
        self.length[slot], self.first[slot], self.inject[slot] = length, first, inject
        if points is None:
            self.reference[slot] = reference
            publish(self.state, slot, kernel.READY)  # last: the audio thread reads it
        else:
            self.points[slot] = points
            publish(self.state, slot, kernel.PULSE)

    def release(self, slot: int, pulse: bool = False) -> None:
        """Give a reserved slot back unfilled (its impact failed before publishing)."""
        with self._lock:
            if pulse:
                self.pulses -= 1
            self.state[slot] = kernel.FREE
