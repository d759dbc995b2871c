"""The hand-off of impacts from trigger threads to the audio thread (docs/live.md): a body's
bounded ring of preallocated slots, each an impact READY (mode amplitudes computed by the
producer) or a PULSE (transformed by the audio thread; at most ``max_new`` wait). A producer
reserves a FREE slot under the producers' lock (never the audio thread's), fills it and
writes its state word last, after a fence; a full ring refuses and counts.
"""

from __future__ import annotations

import threading

import numpy as np

from synth.live import kernel
from synth.live.atomics import publish

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
        self.state = np.zeros(capacity, dtype=np.int64)
        self.inject = np.zeros(capacity, dtype=np.int64)
        self.first = np.zeros(capacity, dtype=np.int64)
        self.length = np.zeros(capacity, dtype=np.int64)
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
        self.max_new = max_new
        self.pulses = 0  # pulses handed over so far (producers)
        self.transformed = np.zeros(1, dtype=np.int64)  # pulses taken by the audio thread
        self.refused = 0
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
            v = self.voices[r]
            v[kernel.V_ID] = vid
            v[kernel.V_PUT] = impacts
            v[kernel.V_PLAYED] = 0
            v[kernel.V_STOP] = -1
            v[kernel.V_DEAD] = 0
            v[kernel.V_SLOT] = -1
            v[kernel.V_PRIORITY] = priority
            self.voice_gain[r] = 1.0
            v[kernel.V_STATE] = kernel.V_LIVE
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
        self.length[slot] = length
        self.first[slot] = first
        self.inject[slot] = inject
        if points is None:
            self.reference[slot] = reference
        else:
            self.points[slot] = points
        form = kernel.READY if points is None else kernel.PULSE
        publish(self.state, slot, form)  # last: the audio thread reads it

    def release(self, slot: int, pulse: bool = False) -> None:
        """Give a reserved slot back unfilled (its impact failed before publishing)."""
        with self._lock:
            if pulse:
                self.pulses -= 1
            self.state[slot] = kernel.FREE
