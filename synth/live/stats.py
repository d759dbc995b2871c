"""The counters of a live engine (:attr:`synth.live.Engine.stats`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made (docs/live.md, "Stats", states each).

    Callback: ``callbacks`` (blocks mixed), ``output_underflows`` (flagged by PortAudio),
    ``callback_mean``, ``callback_max``, ``callback_last`` (its run time as a fraction of the
    block, read from the monotonic clock by the compiled callback; the Python fallback's exclude
    the wait for the GIL), ``callback_gap_max`` (the longest time between two callbacks'
    entries, blocks). Impacts: ``impacts_played``, ``impacts_refused``, ``drops_refused``,
    ``impacts_too_close`` (by ``min_interval``), ``impacts_late`` (played at the start of the
    block they were found in), ``transforms_max`` and ``transforms_deferred`` (the bound
    ``max_hits_per_block``), ``impacts_pending``, ``impacts_dropped`` (their voice stopped
    first). Voices: ``bodies_ringing``, ``voices_playing``, ``voices_stolen``,
    ``voices_refused`` (for their priority), ``events_lost`` (the ended-events ring full).
    Master bus: ``peak`` (before the clipper, full scale 1), ``output_peak`` (at the device),
    ``clipped`` (samples that reached full scale), ``limiter_reduction_db``,
    ``limiter_max_reduction_db`` (dB, since :meth:`Engine.reset_meter`), ``limiter_active``
    (frames with a gain below 1). Stream: ``failed`` (why, or None), ``silent_for`` (s since
    the last callback returned), ``device_lost``."""

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
