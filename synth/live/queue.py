"""The hand-off of impacts from trigger threads to the audio thread (docs/live.md, "What runs
where").

Each body has a bounded ring of preallocated, pre-touched slots. A slot carries an impact
READY (mode amplitudes computed by the producer: a drop's impacts, long contacts) or as a
PULSE (its force pulse and the listener's coefficients, turned into amplitudes by the audio
thread at the start of a block; at most ``max_new`` wait, bounding any block's work). A
producer reserves a FREE slot under the producers' lock (which the audio thread never
takes), fills it and writes its state word last, after a fence (:mod:`synth.live.atomics`);
the audio thread plays READY slots when due and frees them. A full ring refuses and counts.
Each impact belongs to a voice record (``voices``, :data:`synth.live.kernel.V_ID`) whose
gain and stop request producers write under the lock and the audio thread reads each block.
"""

from __future__ import annotations

import threading

import numpy as np

from synth.live.atomics import publish
from synth.live.kernel import (
    FREE,
    N_PULSE_FIELDS,
    N_VOICE_FIELDS,
    PULSE,
    READY,
    V_DEAD,
    V_FREE,
    V_ID,
    V_LIVE,
    V_PLAYED,
    V_PRIORITY,
    V_PUT,
    V_SLOT,
    V_STATE,
    V_STOP,
)

#: Slot state while a producer fills it (the audio thread plays READY slots only). The
#: largest state, so that the first FREE slot is the first minimum of ``state``.
WRITING = 2


class PendingRing:
    """``capacity`` slots of pending impacts for a body of ``modes`` modes, each with up to
    ``max_contact`` in-contact samples and up to ``pulse_samples`` samples of its pulse (the
    grid, then the in-contact samples); at most ``max_new`` slots wait in the PULSE form;
    ``voices`` voice records."""

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
        self.voices = np.zeros((voices, N_VOICE_FIELDS), dtype=np.int64)
        self.voices[:, V_SLOT] = -1
        self.voice_gain = np.ones(voices)
        self.state = np.zeros(capacity, dtype=np.int64)
        self.inject = np.zeros(capacity, dtype=np.int64)
        self.first = np.zeros(capacity, dtype=np.int64)
        self.length = np.zeros(capacity, dtype=np.int64)
        self.amplitudes = np.zeros((capacity, modes), dtype=complex)
        self.response = np.zeros((capacity, max_contact))
        self.reference = np.zeros(capacity)
        # the PULSE form: the listener's coefficients (re, im); the force (N) and its slope
        # (N/s) on the grid's ``points`` points, then at the in-contact samples; the
        # scalars of kernel.N_PULSE_FIELDS
        self.coefficients = np.zeros((capacity, 2, modes))
        self.samples = np.zeros((capacity, 2, pulse_samples))
        self.points = np.zeros(capacity, dtype=np.int64)
        self.pulse = np.zeros((capacity, N_PULSE_FIELDS))
        for a in (self.amplitudes, self.response, self.coefficients, self.samples):
            a.fill(0.0)  # touch every page now, not at a hit
        self.max_new = max_new
        self.pulses = 0  # pulses handed over so far (producers)
        self.transformed = np.zeros(1, dtype=np.int64)  # pulses taken by the audio thread
        self.refused = 0
        self._lock = threading.Lock()  # between producers only
        self._next = 0  # the slot after the last one reserved

    @property
    def capacity(self) -> int:
        return self.state.shape[0]

    @property
    def max_contact(self) -> int:
        return self.response.shape[1]

    @property
    def pulse_samples(self) -> int:
        return self.samples.shape[2]

    def pending(self) -> int:
        """Impacts handed over and not yet played."""
        return int(np.count_nonzero((self.state == READY) | (self.state == PULSE)))

    def open_voice(self, vid: int, impacts: int, priority: int = 0) -> int:
        """A free voice record for voice ``vid`` (> 0) of ``priority`` that will hand over
        ``impacts`` impacts, or -1 (the impacts counted in ``refused``) when every record
        is taken."""
        with self._lock:
            r = int(self.voices[:, V_STATE].argmin())
            if self.voices[r, V_STATE] != V_FREE:
                self.refused += impacts
                return -1
            v = self.voices[r]
            v[V_ID] = vid
            v[V_PUT] = impacts
            v[V_PLAYED] = 0
            v[V_STOP] = -1
            v[V_DEAD] = 0
            v[V_SLOT] = -1
            v[V_PRIORITY] = priority
            self.voice_gain[r] = 1.0
            v[V_STATE] = V_LIVE
            return r

    def close_voice(self, r: int, unsent: int) -> None:
        """Take back ``unsent`` of the impacts voice record ``r`` announced (refused or
        failed before they were handed over); a record with nothing handed over is freed."""
        with self._lock:
            v = self.voices[r]
            v[V_PUT] -= unsent
            if v[V_PUT] == 0:
                v[V_STATE] = V_FREE
            else:
                v[V_STOP] = max(int(v[V_STOP]), 0)  # what was handed over is dropped

    def voice_alive(self, r: int, vid: int) -> bool:
        """Whether voice record ``r`` still holds voice ``vid`` (lock-free: the audio
        thread frees a record by its state word; a record taken again has a new id)."""
        return int(self.voices[r, V_STATE]) == V_LIVE and int(self.voices[r, V_ID]) == vid

    def control_voice(self, r: int, vid: int, gain=None, stop=None) -> None:
        """Set voice ``vid``'s gain target or ask for its stop fade (samples; the first
        asked is kept), if record ``r`` still holds it."""
        with self._lock:
            if not self.voice_alive(r, vid):
                return
            if gain is not None:
                self.voice_gain[r] = gain
            if stop is not None and self.voices[r, V_STOP] < 0:
                self.voices[r, V_STOP] = stop

    def reserve(self, pulse: bool = False, bounded: bool = True, voice: int = 0) -> int:
        """A FREE slot for an impact of voice record ``voice``, now marked WRITING for the
        caller to fill (see :meth:`publish` and :meth:`publish_pulse`, which ``pulse``
        announces); -1 (and counted in ``refused``) when the ring is full or, for a pulse
        and if ``bounded``, ``max_new`` pulses wait (the bound protects an audio thread's
        deadline; mixing without a device has none)."""
        with self._lock:
            i = self._next
            if self.state[i] != FREE:  # slots mostly free in the order they were taken
                i = int(self.state.argmin())
            if self.state[i] != FREE or (
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
        """``n`` FREE slots at once for impacts of voice record ``voice``, marked WRITING
        (each to be published), or None (and ``n`` counted in ``refused``) when fewer are
        free: all or nothing."""
        with self._lock:
            free = np.flatnonzero(self.state == FREE)
            if free.size < n:
                self.refused += n
                return None
            slots = [int(i) for i in free[:n]]
            self.state[slots] = WRITING
            self.voice[slots] = voice
            return slots

    def publish(self, slot: int, inject: int, first: int, length: int, reference: float):
        """Hand the filled ``slot`` over: its amplitudes (``amplitudes[slot]``) join the
        modes at sample ``inject``, its ``length`` in-contact samples (``response[slot]``)
        start at sample ``first``; ``reference``: the sum of the amplitudes' magnitudes."""
        self.length[slot] = length
        self.first[slot] = first
        self.inject[slot] = inject
        self.reference[slot] = reference
        publish(self.state, slot, READY)  # last: the audio thread reads the slot from now on

    def publish_pulse(self, slot: int, inject: int, first: int, length: int, points: int):
        """Hand over ``slot`` (reserved with ``pulse=True``) in the PULSE form: its
        ``samples[slot]`` (``points`` on the grid, then ``length`` in-contact ones, the first
        at sample ``first``), ``coefficients[slot]`` and ``pulse[slot]``; its amplitudes
        join the modes at sample ``inject``."""
        self.points[slot] = points
        self.length[slot] = length
        self.first[slot] = first
        self.inject[slot] = inject
        publish(self.state, slot, PULSE)  # last, as in publish

    def release(self, slot: int, pulse: bool = False) -> None:
        """Give a reserved slot back unfilled (its impact failed before publishing)."""
        with self._lock:
            if pulse:
                self.pulses -= 1
            self.state[slot] = FREE
