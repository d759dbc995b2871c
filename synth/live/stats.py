"""The counters of a live engine (:attr:`synth.live.Engine.stats`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made; docs/live.md ("Stats") states each. Callback
    costs are fractions of a block, gaps in blocks, peaks in full scale 1, limiter figures in
    dB since :meth:`Engine.reset_meter`, ``silent_for`` in s."""

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
