"""The hand-off of impacts from trigger threads to the audio thread.

Each body has a bounded ring of preallocated slots (``capacity`` impacts, each with its
mode amplitudes, injection sample and in-contact samples; their memory is touched when
the ring is made, so that no hit pays for a page fault). A trigger thread takes the
producers' lock (the audio thread never does) to reserve a FREE slot (marked WRITING),
fills it in place and marks it READY last; the audio thread
(:func:`synth.live.kernel.mix_body`) plays READY slots whose time has come and marks them
FREE. The audio thread never waits: a slot is only ever written by its owner of the
moment (the producer while FREE or WRITING, the consumer while READY), and the state word
is written after the data (x86 and ARM64 keep the order of the separate stores numpy
makes here, which the GIL already serialises between them). When every slot is taken
the impact is refused and counted, never queued without bound.
"""

from __future__ import annotations

import threading

import numpy as np

from synth.live.kernel import FREE, READY

#: Slot state while a producer fills it (the audio thread plays READY slots only). The
#: largest state, so that the first FREE slot is the first minimum of ``state``.
WRITING = 2


class PendingRing:
    """``capacity`` slots of pending impacts for a body of ``modes`` modes, each with up to
    ``max_contact`` in-contact samples."""

    def __init__(self, capacity: int, modes: int, max_contact: int):
        self.state = np.zeros(capacity, dtype=np.int64)
        self.inject = np.zeros(capacity, dtype=np.int64)
        self.first = np.zeros(capacity, dtype=np.int64)
        self.length = np.zeros(capacity, dtype=np.int64)
        self.amplitudes = np.empty((capacity, modes), dtype=complex)
        self.amplitudes.fill(0.0)  # touch every page now, not at a hit
        self.response = np.empty((capacity, max_contact))
        self.response.fill(0.0)
        self.reference = np.zeros(capacity)
        self.refused = 0
        self.puts = 0  # impacts handed over so far (written after READY)
        self._lock = threading.Lock()  # between producers only

    @property
    def capacity(self) -> int:
        return self.state.shape[0]

    @property
    def max_contact(self) -> int:
        return self.response.shape[1]

    def pending(self) -> int:
        """Impacts handed over and not yet played."""
        return int(np.count_nonzero(self.state == READY))

    def reserve(self) -> int:
        """A FREE slot, now marked WRITING for the caller to fill (see :meth:`publish`);
        -1 (and counted in ``refused``) when the ring is full."""
        with self._lock:
            i = int(np.argmin(self.state))
            if self.state[i] != FREE:
                self.refused += 1
                return -1
            self.state[i] = WRITING
            return i

    def publish(self, slot: int, inject: int, first: int, length: int, reference: float):
        """Hand the filled ``slot`` over: its amplitudes (``amplitudes[slot]``) join the
        modes at sample ``inject``, its ``length`` in-contact samples (``response[slot]``)
        start at sample ``first``; ``reference``: the sum of the amplitudes' magnitudes."""
        self.length[slot] = length
        self.first[slot] = first
        self.inject[slot] = inject
        self.reference[slot] = reference
        self.state[slot] = READY  # last: the audio thread reads the slot from now on
        with self._lock:
            self.puts += 1

    def release(self, slot: int) -> None:
        """Give a reserved slot back unfilled (its impact failed before publishing)."""
        self.state[slot] = FREE

    def free_slots(self) -> int:
        return int(np.count_nonzero(self.state == FREE))
