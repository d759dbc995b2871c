"""A handle on one sound of a live body: a hit, or a whole drop (see :class:`Voice`)."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from synth import checks
from synth.live.hits import MAX_GAIN, check_int

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
    """A hit's or a drop's ``priority``, checked: an integer in [0, MAX_PRIORITY]."""
    return check_int("priority", priority, 0, MAX_PRIORITY, "higher plays first")


class Voice:
    """A handle on one sound of a body: a hit or a whole drop (:meth:`Body.hit`,
    :meth:`Body.drop`); every method may be called from any thread.

    ``id``: unique in its engine (reported by :meth:`Engine.ended`); ``onset``: the stream
    time its first tick starts, s (``onsets``: every tick's). ``priority`` in [0,
    MAX_PRIORITY], higher kept longer: a voice takes one of its body's slots when its first
    impact joins; when all ring it steals the lowest priority's, of those the oldest (faded
    over ``STEAL_FADE``), or is refused if every one ranks higher (``stats.voices_refused``);
    ``max_total_voices`` caps all bodies alike (:class:`VoiceLimit`). A voice ends when every
    mode is below its share of ``floor_db`` relative to its peak, or its stop fade ends."""

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
        """Whether the voice is pending or ringing: read from the audio thread's state
        without a lock (True from the call that made it until it has ended)."""
        if self.body._freed:
            return False
        return any(
            ear._ring.voice_alive(r, self.id) for ear, r in zip(self.body._ears, self._records)
        )

    @property
    def gain(self) -> float:
        """The voice's gain (linear, in [0, MAX_GAIN], default 1), on top of the hit's and
        the body's; settable while it plays: the change is ramped linearly over the next
        block (no click). Setting it on an ended voice does nothing."""
        return self._gain

    @gain.setter
    def gain(self, value: float) -> None:
        g = checks.in_range("gain", value, 0.0, MAX_GAIN, "dimensionless", lo_open=False,
                            hi_open=False)  # fmt: skip
        self._gain = g
        if self.body._freed:
            return
        for ear, r in zip(self.body._ears, self._records):
            ear._ring.control_voice(r, self.id, gain=g)

    def stop(self, fade: float | None = None) -> None:
        """Fade the voice out from the next block: a raised cosine over ``fade`` s (in
        [0.001, 10]; default the engine's ``fade``), then it ends; impacts of it not yet
        played are dropped. Does nothing on an ended voice; a second stop keeps the first
        fade."""
        f = self.body._engine._fade if fade is None else fade
        f = checks.in_range("fade", f, MIN_STOP_FADE, MAX_STOP_FADE, "s", lo_open=False,
                            hi_open=False)  # fmt: skip
        frames = max(1, int(round(f * self.body._engine.samplerate)))
        if self.body._freed:
            return
        for ear, r in zip(self.body._ears, self._records):
            ear._ring.control_voice(r, self.id, stop=frames)


def stop_records(ears, records, vid) -> None:
    """Drop voice ``vid`` at the ears that took it (``records``: their voice records) before
    it plays: a hit refused at one ear is refused at every ear."""
    for ear, r in zip(ears, records):
        ear._ring.control_voice(r, vid, stop=0)


class VoiceLimit:
    """The engine-wide voice cap (``Engine(max_total_voices=n)``), kept on the threads that make
    voices: a voice counts from its call until it ends; beyond the cap the lowest priority's,
    of those the oldest, is stopped with a ``STEAL_FADE`` fade (``stolen``), or the new one
    refused (``refused``), as a body's slots do. ``limit`` None: no cap."""

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
