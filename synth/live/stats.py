"""The counters of a live engine (:attr:`synth.live.Engine.stats`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EngineStats:
    """Counters of an engine since it was made.

    callbacks: blocks mixed by a stream's callback; output_underflows: callbacks that
    PortAudio flagged ``output_underflow`` (the device ran dry before; a stall of many
    blocks may be flagged once: callback_gap_max gives its length);
    callback_mean, callback_max, callback_last: the callback's run time from its entry to
    its return (read from the monotonic clock by the compiled callback itself, the first
    thing it does), as a fraction of its block's duration; callback_gap_max: the longest
    time between two callbacks' entries, in blocks (about 1 when the system runs the audio
    thread on time; an underflow with a large gap and a small callback_max was the
    system's scheduling, not the callback's work). With the Python fallback
    (``Engine(callback="python")``) the callback reads the clock once it holds the GIL:
    its callback_mean, callback_max and callback_last exclude the wait for the GIL, which
    only callback_gap_max shows (read that one there).

    impacts_played: impacts injected into a body's modes; impacts_refused: impacts refused
    (a body's ring full, too many pulses waiting for one block, or a whole drop that did not
    fit); drops_refused: drops refused whole; impacts_too_close: hits refused by a body's
    ``min_interval``; impacts_late: impacts found after their start time (played at the
    start of the block they were found in); transforms_max: the most hits' pulses one
    callback of the stream turned into mode amplitudes, over every body (at most
    ``max_hits_per_block``); transforms_deferred: pulses a callback left for a later one by
    that bound (a pulse left twice counted twice); impacts_pending: handed over and not yet
    played; bodies_ringing: bodies with a voice ringing; voices_playing: voice slots ringing
    (as of the last block mixed; a body of several ears counts its first's); voices_stolen:
    voices ended by a new one when all of their body's slots rang, or beyond the engine's
    ``max_total_voices`` (see :class:`Voice`); voices_refused: voices refused for their
    priority (lower than every voice ringing in their body's slots when they came to join,
    or than every voice of a full engine; each counted once, at its first ear);
    impacts_dropped: impacts not played because their voice was stopped or stolen (or the
    body silenced) first; events_lost: voice-ended events that found :meth:`Engine.ended`'s
    ring full; peak: the largest |sample| of the master bus before the clipper, full scale
    1; output_peak: the largest |sample| sent to the device; clipped: master-bus samples
    that reached full scale (soft-clipped, or clipped by the float-to-integer conversion
    with ``clip=False``; after the limiter when it runs); limiter_reduction_db: the
    true-peak limiter's gain reduction at the last frame out, dB (0 without a limiter);
    limiter_max_reduction_db: its largest since the last :meth:`Engine.reset_meter`;
    limiter_active: frames it sent out with a gain below 1 since then; failed: why the
    stream failed, or None; silent_for: seconds since the last callback returned while the
    stream runs (0 without a stream): beyond ``DEVICE_LOST`` the device is taken as lost;
    device_lost: whether the engine's watchdog found the running stream's device lost
    (reported once through ``on_device_lost``; False again after :meth:`Engine.stop`).
    """

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
