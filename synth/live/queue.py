"""The hand-off of impacts from trigger threads to the audio thread.

Each body has a bounded ring of preallocated slots (``capacity`` impacts; their memory is
touched when the ring is made, so that no hit pays for a page fault). A slot carries an
impact in one of two forms:

* READY: its mode amplitudes, injection sample and in-contact response, computed by the
  producer (a drop's impacts, and contacts too long for a slot's pulse grid);
* PULSE: its force pulse (on the transform grid and at the in-contact samples), the
  listener's coefficients at its point and its gain; the audio thread turns it into the
  READY form at the start of the next block (:func:`synth.live.kernel.mix_body`, the
  renderer's transform). At most ``max_new`` PULSE slots wait at a time: that bounds the
  transform work of any block.

A trigger thread takes the producers' lock (the audio thread never does) to reserve a FREE
slot (marked WRITING), fills it in place and marks it READY or PULSE last; the audio
thread plays READY slots whose time has come and marks them FREE. The audio thread never
waits: a slot is only ever written by its owner of the moment (the producer while FREE or
WRITING, the consumer while READY or PULSE), and the state word is written after the data
with a fence between them (:mod:`synth.live.atomics`; the audio thread fences between the
state word it reads and the slot's data). When every slot is taken, or ``max_new`` pulses wait,
the impact is refused and counted, never queued without bound.
"""

from __future__ import annotations

import threading

import numpy as np

from synth.live.atomics import publish
from synth.live.kernel import FREE, N_PULSE_FIELDS, PULSE, READY

#: Slot state while a producer fills it (the audio thread plays READY slots only). The
#: largest state, so that the first FREE slot is the first minimum of ``state``.
WRITING = 2


class PendingRing:
    """``capacity`` slots of pending impacts for a body of ``modes`` modes, each with up to
    ``max_contact`` in-contact samples and up to ``pulse_samples`` samples of its pulse (the
    grid, then the in-contact samples); at most ``max_new`` slots wait in the PULSE form."""

    def __init__(
        self, capacity: int, modes: int, max_contact: int, pulse_samples: int, max_new: int
    ):
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
        self.puts = 0  # impacts handed over so far (written after READY or PULSE)
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

    def reserve(self, pulse: bool = False, bounded: bool = True) -> int:
        """A FREE slot, now marked WRITING for the caller to fill (see :meth:`publish` and
        :meth:`publish_pulse`, which ``pulse`` announces); -1 (and counted in ``refused``)
        when the ring is full or, for a pulse and if ``bounded``, ``max_new`` pulses wait
        (the bound protects an audio thread's deadline; mixing without a device has none)."""
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
            self._next = i + 1 if i + 1 < self.state.shape[0] else 0
            if pulse:
                self.pulses += 1
            return i

    def reserve_many(self, n: int) -> list[int] | None:
        """``n`` FREE slots at once, marked WRITING (each to be published), or None (and
        ``n`` counted in ``refused``) when fewer are free: all or nothing."""
        with self._lock:
            free = np.flatnonzero(self.state == FREE)
            if free.size < n:
                self.refused += n
                return None
            slots = [int(i) for i in free[:n]]
            self.state[slots] = WRITING
            return slots

    def publish(self, slot: int, inject: int, first: int, length: int, reference: float):
        """Hand the filled ``slot`` over: its amplitudes (``amplitudes[slot]``) join the
        modes at sample ``inject``, its ``length`` in-contact samples (``response[slot]``)
        start at sample ``first``; ``reference``: the sum of the amplitudes' magnitudes."""
        self.length[slot] = length
        self.first[slot] = first
        self.inject[slot] = inject
        self.reference[slot] = reference
        self._hand_over(slot, READY)

    def publish_pulse(self, slot: int, inject: int, first: int, length: int, points: int):
        """Hand over ``slot`` (reserved with ``pulse=True``) in the PULSE form: its
        ``samples[slot]`` (``points`` on the grid, then ``length`` in-contact ones, the first
        at sample ``first``), ``coefficients[slot]`` and ``pulse[slot]``; its amplitudes
        join the modes at sample ``inject``."""
        self.points[slot] = points
        self.length[slot] = length
        self.first[slot] = first
        self.inject[slot] = inject
        self._hand_over(slot, PULSE)

    def _hand_over(self, slot: int, state: int) -> None:
        publish(self.state, slot, state)  # last: the audio thread reads the slot from now on
        with self._lock:
            self.puts += 1

    def release(self, slot: int, pulse: bool = False) -> None:
        """Give a reserved slot back unfilled (its impact failed before publishing)."""
        with self._lock:
            if pulse:
                self.pulses -= 1
            self.state[slot] = FREE

    def free_slots(self) -> int:
        return int(np.count_nonzero(self.state == FREE))
