"""The live engine's bookkeeping: its state and clock, its events, its removed bodies and
its statistics, read from the arrays the audio thread writes (:mod:`synth.live.state`).

:class:`EngineBookkeeping` is the base of :class:`synth.live.Engine`, which holds what a
user calls (bodies, the master bus, the mixing, the stream); the queries and the
conversions between the caller's clock and the engine's are here, with the watchdog that
finds a lost device (:func:`watch_device`).
"""

from __future__ import annotations

import time

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.live import kernel, native
from synth.live.atomics import fence
from synth.live.body import Body
from synth.live.hits import MAX_AHEAD
from synth.live.stats import EngineStats

#: A running stream whose callback has not returned for this long (s, or 10 blocks if
#: longer) has lost its device or server: hits are refused, ``stats.silent_for`` says so.
DEVICE_LOST = 0.5
#: How often the watchdog thread looks for a lost device while a stream runs, s.
WATCH_PERIOD = 0.05


class EngineBookkeeping:
    """What :class:`synth.live.Engine` reads of its state (see the module's docstring): the
    attributes it sets up in its ``__init__`` (``_native``, the engine's
    :class:`~synth.live.state.EngineState`, the clock's settings, the removed bodies)."""

    # -- events --------------------------------------------------------------------------
    def ended(self) -> list[int]:
        """The ids of the voices that ended since the last call (at every ear of their
        body), oldest first; never blocks the audio thread (a lock-free ring it writes,
        read here; ``EVENT_CAPACITY`` events wait at most, more are counted in
        ``stats.events_lost``). Call it from the game's loop."""
        self._reap()
        with self._events_lock:
            ev = self._native.events
            written = int(ev[kernel.E_WRITTEN])
            fence()  # the events before their count
            read = int(ev[kernel.E_READ])
            cap = ev.shape[0] - kernel.N_EVENT_HEADER
            ids = []
            for k in range(read, written):
                vid, ears = divmod(int(ev[kernel.N_EVENT_HEADER + k % cap]), kernel.EVENT_EARS)
                if ears > 1:
                    seen = self._partial_events.pop(vid, 0) + 1
                    if seen < ears:
                        self._partial_events[vid] = seen
                        continue
                ids.append(vid)
            fence()  # done reading before the writer may reuse the room
            ev[kernel.E_READ] = written
            return ids

    # -- removed bodies --------------------------------------------------------------------
    @property
    def bodies(self) -> tuple[Body, ...]:
        """The bodies the engine holds (a removed one until its arrays are let go)."""
        return self._bodies

    def _retire(self, body: Body) -> None:
        """Take a removed body (:meth:`Body.remove`) through ringing out to freed."""
        self._retiring.append([body, None])
        self._reap()

    def _reap(self) -> None:
        """Move the removed bodies on: one that has fallen silent leaves the mixing (its
        directory entries vacated); one the mixing has left since is let go of. Skipped
        while another thread does it (a host's audio callback never waits here)."""
        if not self._retiring or not self._reap_lock.acquire(blocking=False):
            return
        try:
            self._reap_bodies()
        finally:
            self._reap_lock.release()

    def _reap_bodies(self) -> None:
        for item in list(self._retiring):
            body, progress = item
            if progress is None:
                if body.awake:
                    continue
                item[1] = [self._native.vacate(ear._index) for ear in body._ears]
            elif all(self._native.left(p) for p in item[1]):
                self._retired_counters += body._counters
                self._retired_refused += body._ring.refused
                for ear in body._ears:
                    self._native.release(ear._index)
                body._free()
                self._bodies = tuple(b for b in self._bodies if b is not body)
                self._retiring.remove(item)

    # -- state and clock -------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._state == "running"

    @property
    def paused(self) -> bool:
        """Whether :meth:`pause` was called (and :meth:`resume` not since)."""
        return bool(self._native.ctl[native.PAUSE])

    @property
    def failed(self) -> str | None:
        """Why the engine's stream failed (it then refuses everything), or None."""
        return self._failure

    @property
    def _frame(self) -> int:
        return int(self._native.ctl[native.FRAME])

    @property
    def time(self) -> float:
        """The next frame to be mixed, s on the engine's clock."""
        return self._frame / self.samplerate

    @property
    def recording(self) -> np.ndarray:
        """The first ``record_seconds`` of the output, float32 (frames, channels); frames
        not yet played are zero (``recorded`` counts those played)."""
        return self._native.recording

    @property
    def recorded(self) -> int:
        """Frames of :attr:`recording` written so far."""
        return int(self._native.ctl[native.RECORDED])

    @property
    def latency(self) -> float:
        """The stream's output latency, s: from the start of a callback to the time its first
        sample is heard (PortAudio's ``outputBufferDacTime - currentTime``, measured at
        each callback; the stream's nominal latency before the first; 0 without a stream)."""
        return float(self._native.times[native.LEAD]) if self.running else 0.0

    def _check_open(self, what: str):
        if self._state == "failed":
            raise SynthError(f"cannot {what}: the engine's audio stream failed ({self._failure})")

    def _silent_for(self) -> float:
        """Seconds since the stream's last callback returned (since start() before the
        first); 0 without a stream."""
        if not self.running:
            return 0.0
        return max(0.0, native.monotonic() - float(self._native.times[native.END_TIME]))

    def _lost(self) -> str | None:
        """Why the running stream's device is taken as lost, or None."""
        silent = self._silent_for()
        limit = max(DEVICE_LOST, 10 * self.blocksize / self.samplerate)
        if silent > limit:
            return (
                f"the audio stream has not called back for {silent:.2f} s (more than {limit:g} "
                f"s): its device or audio server is gone; stop() the engine (stats.silent_for)"
            )
        return None

    def _check_alive(self) -> None:
        why = self._lost()
        if why is not None:
            raise SynthError(why)

    def _now_frame(self) -> float:
        """The frame (fractional) leaving the device now; without a stream, the next frame
        to be mixed."""
        if not self.running:
            return float(self._frame)
        frame, dac, callbacks = self._native.anchor()
        if callbacks == 0:  # no callback yet: the stream starts with the next frame
            times = self._native.times
            return (
                float(self._frame)
                - (times[native.LEAD] + times[native.LIMIT_DELAY]) * self.samplerate
            )
        return frame + (native.monotonic() - dac) * self.samplerate

    def _onset(self, at) -> float:
        """A tick's start, s on the engine's clock: ``at`` (from the next frame to at most
        ``MAX_AHEAD`` s after it), or one block plus the output latency, the limiter's
        look-ahead and the hand-over allowance from now (no stream: from the next frame;
        the frame leaving the device now counts the look-ahead's delay, see
        :func:`synth.live.native._run_block`)."""
        self._check_open("play an impact")
        self._check_alive()
        if at is None:
            if not self.running:
                return (self._frame + self.blocksize) / self.samplerate
            times = self._native.times
            lead = times[native.LEAD] + times[native.LIMIT_DELAY]
            frame = self._now_frame() + self.blocksize + (lead + self.handover) * self.samplerate
            return max(frame, float(self._frame)) / self.samplerate
        t = checks.real("at", at, "s")
        earliest = self._frame / self.samplerate
        latest = earliest + MAX_AHEAD
        if (not self.running and t < earliest) or t < 0.0 or t > latest:
            lo = earliest if not self.running else 0.0
            raise ParameterError(
                f"at={at!r} must be in [{lo!r}, {latest!r}] s (the engine's clock: from "
                f"{'its next frame' if not self.running else '0'} to {MAX_AHEAD:g} s after "
                f"Engine.time)"
            )
        return t

    @property
    def stats(self) -> EngineStats:
        self._reap()
        gone = self._retired_counters
        played, late = int(gone[kernel.PLAYED]), int(gone[kernel.LATE])
        stolen, dropped = int(gone[kernel.STOLEN]), int(gone[kernel.DROPPED])
        refused, pending, ringing, voices = self._retired_refused, 0, 0, 0
        limit = self._voice_limit
        voices_refused = limit.refused + int(gone[kernel.REFUSED])
        for body in self._bodies:  # a body heard by several listeners counts its first's
            played += int(body._counters[kernel.PLAYED])
            late += int(body._counters[kernel.LATE])
            stolen += int(body._counters[kernel.STOLEN])
            dropped += int(body._counters[kernel.DROPPED])
            voices_refused += int(body._counters[kernel.REFUSED])
            refused += body._ring.refused
            pending += body.pending
            ringing += body.ringing
            voices += body.voices_playing
        c, t = self._native.ctl, self._native.times
        lim = self._native.limiter
        n = int(c[native.CALLBACKS])
        return EngineStats(
            callbacks=n,
            output_underflows=int(c[native.UNDERFLOWS]),
            callback_mean=float(t[native.COST_SUM]) / n if n else 0.0,
            callback_max=float(t[native.COST_MAX]),
            callback_last=float(t[native.COST_LAST]),
            callback_gap_max=float(t[native.GAP_MAX]),
            impacts_played=played,
            impacts_refused=refused,
            drops_refused=self._drops_refused,
            impacts_too_close=self._too_close,
            impacts_late=late,
            transforms_max=int(c[native.TRANSFORMS_MAX]),
            transforms_deferred=int(c[native.TRANSFORMS_DEFERRED]),
            impacts_pending=pending,
            bodies_ringing=ringing,
            voices_playing=voices,
            voices_stolen=stolen + limit.stolen,
            voices_refused=voices_refused,
            impacts_dropped=dropped,
            events_lost=int(self._native.events[kernel.E_LOST]),
            peak=float(t[native.PEAK]),
            output_peak=float(t[native.OUT_PEAK]),
            clipped=int(c[native.CLIPPED]),
            limiter_reduction_db=lim.reduction_db if lim is not None else 0.0,
            limiter_max_reduction_db=lim.max_reduction_db if lim is not None else 0.0,
            limiter_active=lim.active_frames if lim is not None else 0,
            failed=self._failure,
            device_lost=self._device_lost is not None,
            silent_for=self._silent_for(),
        )


def watch_device(engine_ref, stream) -> None:
    """The watchdog of one running stream (a thread): report a lost device once, through
    ``on_device_lost`` and ``stats.device_lost``. Holds the engine only weakly (collecting
    it stops the stream) and ends with the stream."""
    while True:
        engine = engine_ref()
        if engine is None or engine._stream is not stream:
            return
        why = engine._lost()
        if why is not None:
            engine._device_lost = why
            callback = engine._on_device_lost
            del engine
            if callback is not None:
                callback(why)
            return
        del engine
        time.sleep(WATCH_PERIOD)
