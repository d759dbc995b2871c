"""The live engine's bookkeeping (the base of :class:`synth.live.Engine`): its clock, events,
removed bodies and statistics, read from the arrays the audio thread writes, and the
watchdog that finds a lost device."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.live import kernel
from synth.live import state as st
from synth.live.atomics import fence
from synth.live.body import Body
from synth.live.voice import MAX_AHEAD

#: s (or 10 blocks if longer) without a callback after which a stream's device is lost; how
#: often the watchdog looks, s.
DEVICE_LOST = 0.5
WATCH_PERIOD = 0.05
#: :class:`EngineStats` fields read from ``ctl``, ``times`` and the bodies' counters.
_FROM_CTL = dict(callbacks=st.CALLBACKS, output_underflows=st.UNDERFLOWS, clipped=st.CLIPPED,
                 transforms_max=st.TRANSFORMS_MAX,
                 transforms_deferred=st.TRANSFORMS_DEFERRED)  # fmt: skip
_FROM_TIMES = dict(callback_max=st.COST_MAX, callback_last=st.COST_LAST,
                   callback_gap_max=st.GAP_MAX, peak=st.PEAK, output_peak=st.OUT_PEAK)  # fmt: skip
_FROM_COUNTERS = dict(impacts_played=kernel.PLAYED, impacts_late=kernel.LATE,
                      impacts_dropped=kernel.DROPPED)  # fmt: skip


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made (docs/live.md, "Stats"): callback costs in
    blocks, peaks in full scale 1, limiter figures in dB since a reset, ``silent_for`` in s."""

    callbacks: int
    output_underflows: int
    callback_mean: float
    callback_max: float
    callback_last: float
    callback_gap_max: float
    impacts_played: int
    impacts_refused: int
    drops_refused: int
    impacts_too_close: int
    impacts_late: int
    transforms_max: int
    transforms_deferred: int
    impacts_pending: int
    bodies_ringing: int
    voices_playing: int
    voices_stolen: int
    voices_refused: int
    impacts_dropped: int
    events_lost: int
    peak: float
    output_peak: float
    clipped: int
    limiter_reduction_db: float
    limiter_max_reduction_db: float
    limiter_active: int
    failed: str | None
    silent_for: float
    device_lost: bool


class EngineBookkeeping:
    """What :class:`synth.live.Engine` reads of the state its ``__init__`` sets up."""

    def ended(self) -> list[int]:
        """The ids of the voices that ended (at every ear) since the last call, oldest first
        (``stats.events_lost`` counts a full ring's)."""
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
        """Vacate silent removed bodies from the directory, free those the mixing has left since.
        Never waits (a host's audio callback may call it)."""
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
        """The stream's output latency at the last callback, s (0 without a stream)."""
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
        """A tick's start, s on the engine's clock: ``at`` (at most ``MAX_AHEAD`` s ahead), or one
        block plus the latency, look-ahead and ``handover`` from now (no stream: the next frame)."""
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
        c, t, limit, lim = (
            self._native.ctl,
            self._native.times,
            self._voice_limit,
            self._native.limiter,
        )
        read = (
            {name: int(c[i]) for name, i in _FROM_CTL.items()}
            | {name: float(t[i]) for name, i in _FROM_TIMES.items()}
            | {name: int(counts[i]) for name, i in _FROM_COUNTERS.items()}
        )
        n = read["callbacks"]
        return EngineStats(
            **read,
            callback_mean=float(t[st.COST_SUM]) / n if n else 0.0,
            impacts_refused=self._retired_refused + sum(b._ring.refused for b in self._bodies),
            drops_refused=self._drops_refused,
            impacts_too_close=self._too_close,
            impacts_pending=sum(b.pending for b in self._bodies),
            bodies_ringing=sum(b.ringing for b in self._bodies),
            voices_playing=sum(b.voices_playing for b in self._bodies),
            voices_stolen=int(counts[kernel.STOLEN]) + limit.stolen,
            voices_refused=limit.refused + int(counts[kernel.REFUSED]),
            events_lost=int(self._native.events[kernel.E_LOST]),
            limiter_reduction_db=lim.reduction_db if lim is not None else 0.0,
            limiter_max_reduction_db=lim.max_reduction_db if lim is not None else 0.0,
            limiter_active=lim.active_frames if lim is not None else 0,
            failed=self._failure,
            device_lost=self._device_lost is not None,
            silent_for=self._silent_for(),
        )


def watch_device(engine_ref, stream) -> None:
    """A running stream's watchdog: reports a lost device once (``on_device_lost``); holds the
    engine weakly and ends with the stream."""
    while True:
        engine = engine_ref()
        if engine is None or engine._stream is not stream:
            return
        why = engine._lost()
        if why is not None:
            engine._device_lost = why
            callback = engine.options.on_device_lost
            del engine
            if callback is not None:
                callback(why)
            return
        del engine
        time.sleep(WATCH_PERIOD)
