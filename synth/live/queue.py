"""The hand-off of impacts from trigger threads to the audio thread.

Each body has a bounded ring of preallocated slots (``capacity`` impacts, each with its
mode amplitudes, injection sample and in-contact samples). A trigger thread takes the
producers' lock (the audio thread never does), finds a FREE slot, fills it and marks it
READY last; the audio thread (:func:`synth.live.kernel.mix_body`) plays READY slots whose
time has come and marks them FREE. The audio thread never waits: a slot is only ever
written by its owner of the moment (the producer while FREE, the consumer while READY),
and the state word is written after the data (x86 and ARM64 keep the order of the
separate stores numpy makes here, which the GIL already serialises between them).
When every slot is taken the impact is refused and counted, never queued without bound.
"""

from __future__ import annotations

import threading

import numpy as np

from synth.live.kernel import FREE, READY


class PendingRing:
    """``capacity`` slots of pending impacts for a body of ``modes`` modes, each with up to
    ``max_contact`` in-contact samples."""

    def __init__(self, capacity: int, modes: int, max_contact: int):
        self.state = np.zeros(capacity, dtype=np.int64)
        self.inject = np.zeros(capacity, dtype=np.int64)
        self.first = np.zeros(capacity, dtype=np.int64)
        self.length = np.zeros(capacity, dtype=np.int64)
        self.amplitudes = np.zeros((capacity, modes), dtype=complex)
        self.response = np.zeros((capacity, max_contact))
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

    def put(
        self,
        inject: int,
        first: int,
        amplitudes: np.ndarray,
        response: np.ndarray,
        reference: float,
    ) -> bool:
        """Hand one impact over; False (and counted in ``refused``) when the ring is full."""
        with self._lock:
            free = np.flatnonzero(self.state == FREE)
            if free.size == 0:
                self.refused += 1
                return False
            i = int(free[0])
            self.amplitudes[i] = amplitudes
            self.response[i, : response.size] = response
            self.length[i] = response.size
            self.first[i] = first
            self.inject[i] = inject
            self.reference[i] = reference
            self.state[i] = READY
            self.puts += 1
            return True

    def free_slots(self) -> int:
        return int(np.count_nonzero(self.state == FREE))
