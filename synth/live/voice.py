"""A handle on one sound of a live body: a hit, or a whole drop (see :class:`Voice`)."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from synth.live.hits import MAX_GAIN, check_int, closed

if TYPE_CHECKING:
    from synth.live.body import Body

#: Default voices a body rings at once (``max_voices``): each is a modal state of its own,
#: so a body costs up to this many banks per block.
MAX_VOICES = 8
#: Length of the raised-cosine fade of a stolen voice, s: short, so the new voice is not
#: masked for long, and smooth (zero slope at both ends), so it does not click.
STEAL_FADE = 0.005
#: Bounds of a :meth:`Voice.stop` fade, s.
MIN_STOP_FADE = 0.001
MAX_STOP_FADE = 10.0
#: Largest priority of a voice (priorities are integers from 0, the default, to this).
MAX_PRIORITY = 255


def check_priority(priority) -> int:
    return check_int("priority", priority, 0, MAX_PRIORITY, "higher plays first")


def check_gain(gain) -> float:
    """A voice's gain (linear), checked: in [0, MAX_GAIN]."""
    return closed("gain", gain, 0.0, MAX_GAIN, "dimensionless")


def stop_frames(engine, fade: float | None) -> int:
    """A stop fade of ``fade`` s (None: the engine's ``fade``), checked, in frames (>= 1)."""
    f = closed("fade", engine._fade if fade is None else fade, MIN_STOP_FADE, MAX_STOP_FADE, "s")
    return max(1, int(round(f * engine.samplerate)))


class Voice:
    """A handle on one sound of a body, a hit or a whole drop, usable from any thread: ``id``
    (reported by :meth:`Engine.ended`), ``onsets`` (s), ``priority`` in [0, MAX_PRIORITY]
    (when all slots ring, a new voice steals the lowest priority's, of those the oldest, or
    is refused). It ends when every mode is below its share of ``floor_db`` relative to its
    peak, or its stop fade ends."""

    __slots__ = ("body", "id", "onsets", "priority", "_records", "_gain")

    def __init__(self, body: Body, vid: int, records, onsets: tuple, priority: int = 0):
        self.body = body
        self.id = vid
        self.onsets = tuple(onsets)
        self.priority = priority
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
        """The voice's gain (linear, in [0, MAX_GAIN], default 1) on top of the hit's and the
        body's; a change is ramped over the next block."""
        return self._gain

    @gain.setter
    def gain(self, value: float) -> None:
        self._gain = check_gain(value)
        self._control(gain=self._gain)

    def stop(self, fade: float | None = None) -> None:
        """Fade the voice out from the next block over ``fade`` s (in [0.001, 10]; default the
        engine's ``fade``), dropping its impacts not yet played; a second stop keeps the
        first fade."""
        self._control(stop=stop_frames(self.body._engine, fade))


def stop_records(ears, records, vid) -> None:
    """Drop voice ``vid`` at the ears that took it (``records``) before it plays: a hit
    refused at one ear is refused at every ear."""
    for ear, r in zip(ears, records):
        ear._ring.control_voice(r, vid, stop=0)


class VoiceLimit:
    """The engine-wide voice cap (``Engine(max_total_voices=n)``, ``limit`` None: none), kept
    on the threads that make voices: beyond it the lowest priority's, of those the oldest, is
    stopped over ``STEAL_FADE`` (``stolen``) or the new one refused (``refused``)."""

    def __init__(self, limit: int | None):
        self.limit = limit
        self.stolen = 0
        self.refused = 0
        self._live: dict = {}  # id -> Voice (None while its hit is handed over)
        self._lock = threading.Lock()  # between the threads that make voices

    def admit(self, vid: int, priority: int) -> bool:
        """Make room for voice ``vid`` of ``priority`` (stealing one if need be), or refuse
        it (False)."""
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

    def playing(self) -> int:
        """Voices counted against the cap now (0 without a cap)."""
        with self._lock:
            return sum(1 for v in self._live.values() if v is None or v.playing)
