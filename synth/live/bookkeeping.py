"""The live engine's bookkeeping (the base of :class:`synth.live.Engine`): its state, clock,
events, removed bodies and statistics, read from the arrays the audio thread writes, and the
watchdog that finds a lost device."""

from __future__ import annotations

import time

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.live import kernel
from synth.live import state as st
from synth.live.atomics import fence
from synth.live.body import Body
from synth.live.hits import MAX_AHEAD
from synth.live.stats import EngineStats

#: s (or 10 blocks if longer) without a callback after which a stream's device is lost.
DEVICE_LOST = 0.5
#: How often the watchdog thread looks for a lost device while a stream runs, s.
WATCH_PERIOD = 0.05


class EngineBookkeeping:
    """What :class:`synth.live.Engine` reads of the state its ``__init__`` sets up."""

    def ended(self) -> list[int]:
        """The ids of the voices that ended (at every ear) since the last call, oldest first,
        read from the audio thread's lock-free ring (``stats.events_lost`` counts overflow)."""
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

    @property
    def bodies(self) -> tuple[Body, ...]:
        """The bodies the engine holds (a removed one until its arrays are let go)."""
        return self._bodies

    def _retire(self, body: Body) -> None:
        self._retiring.append([body, None])
        self._reap()

    def _reap(self) -> None:
        """Move removed bodies on: a silent one is vacated from the directory, one the mixing
        has left since is freed. Never waits (a host's audio callback may call it)."""
        if not self._retiring or not self._reap_lock.acquire(blocking=False):
            return
        try:
            for item in list(self._retiring):
                body, progress = item
                if progress is None:
                    if not body.awake:
                        item[1] = [self._native.vacate(ear._index) for ear in body._ears]
                elif all(self._native.left(p) for p in progress):
                    self._retired_counters += body._counters
                    self._retired_refused += body._ring.refused
                    for ear in body._ears:
                        self._native.release(ear._index)
                    body._free()
                    self._bodies = tuple(b for b in self._bodies if b is not body)
                    self._retiring.remove(item)
        finally:
            self._reap_lock.release()

    @property
    def running(self) -> bool:
        return self._state == "running"

    @property
    def paused(self) -> bool:
        """Whether :meth:`pause` was called (and :meth:`resume` not since)."""
        return bool(self._native.ctl[st.PAUSE])

    @property
    def failed(self) -> str | None:
        """Why the engine's stream failed (it then refuses everything), or None."""
        return self._failure

    @property
    def _frame(self) -> int:
        return int(self._native.ctl[st.FRAME])

    @property
    def time(self) -> float:
        """The next frame to be mixed, s on the engine's clock."""
        return self._frame / self.samplerate

    @property
    def recording(self) -> np.ndarray:
        """The first ``record_seconds`` of the output, float32 (frames, channels)."""
        return self._native.recording

    @property
    def recorded(self) -> int:
        """Frames of :attr:`recording` written so far."""
        return int(self._native.ctl[st.RECORDED])

    @property
    def latency(self) -> float:
        """The stream's output latency, s (PortAudio's ``outputBufferDacTime - currentTime`` at
        the last callback; 0 without a stream)."""
        return float(self._native.times[st.LEAD]) if self.running else 0.0

    def _check_open(self, what: str):
        if self._state == "failed":
            raise SynthError(f"cannot {what}: the engine's audio stream failed ({self._failure})")

    def _silent_for(self) -> float:
        """Seconds since the stream's last callback returned; 0 without a stream."""
        if not self.running:
            return 0.0
        return max(0.0, st.monotonic() - float(self._native.times[st.END_TIME]))

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
        """The frame (fractional) leaving the device now (no stream: the next to mix)."""
        if not self.running:
            return float(self._frame)
        frame, dac, callbacks = self._native.anchor()
        if callbacks == 0:  # no callback yet: the stream starts with the next frame
            times = self._native.times
            return float(self._frame) - (times[st.LEAD] + times[st.LIMIT_DELAY]) * self.samplerate
        return frame + (st.monotonic() - dac) * self.samplerate

    def _onset(self, at) -> float:
        """A tick's start, s on the engine's clock: ``at`` (at most ``MAX_AHEAD`` s ahead), or
        one block plus the output latency, the limiter's look-ahead and ``handover`` from
        now (no stream: from the next frame)."""
        self._check_open("play an impact")
        self._check_alive()
        if at is None:
            if not self.running:
                return (self._frame + self.blocksize) / self.samplerate
            times = self._native.times
            lead = times[st.LEAD] + times[st.LIMIT_DELAY]
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
        # a body heard by several listeners counts its first's
        counts = self._retired_counters + sum(b._counters for b in self._bodies)
        refused = self._retired_refused + sum(b._ring.refused for b in self._bodies)
        limit = self._voice_limit
        c, t = self._native.ctl, self._native.times
        lim = self._native.limiter
        n = int(c[st.CALLBACKS])
        return EngineStats(
            callbacks=n,
            output_underflows=int(c[st.UNDERFLOWS]),
            callback_mean=float(t[st.COST_SUM]) / n if n else 0.0,
            callback_max=float(t[st.COST_MAX]),
            callback_last=float(t[st.COST_LAST]),
            callback_gap_max=float(t[st.GAP_MAX]),
            impacts_played=int(counts[kernel.PLAYED]),
            impacts_refused=refused,
            drops_refused=self._drops_refused,
            impacts_too_close=self._too_close,
            impacts_late=int(counts[kernel.LATE]),
            transforms_max=int(c[st.TRANSFORMS_MAX]),
            transforms_deferred=int(c[st.TRANSFORMS_DEFERRED]),
            impacts_pending=sum(b.pending for b in self._bodies),
            bodies_ringing=sum(b.ringing for b in self._bodies),
            voices_playing=sum(b.voices_playing for b in self._bodies),
            voices_stolen=int(counts[kernel.STOLEN]) + limit.stolen,
            voices_refused=limit.refused + int(counts[kernel.REFUSED]),
            impacts_dropped=int(counts[kernel.DROPPED]),
            events_lost=int(self._native.events[kernel.E_LOST]),
            peak=float(t[st.PEAK]),
            output_peak=float(t[st.OUT_PEAK]),
            clipped=int(c[st.CLIPPED]),
            limiter_reduction_db=lim.reduction_db if lim is not None else 0.0,
            limiter_max_reduction_db=lim.max_reduction_db if lim is not None else 0.0,
            limiter_active=lim.active_frames if lim is not None else 0,
            failed=self._failure,
            device_lost=self._device_lost is not None,
            silent_for=self._silent_for(),
        )


def watch_device(engine_ref, stream) -> None:
    """A running stream's watchdog thread: reports a lost device once (``on_device_lost``,
    ``stats.device_lost``); holds the engine weakly and ends with the stream."""
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
