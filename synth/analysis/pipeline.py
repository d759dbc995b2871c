"""The analysis of a recording stage by stage (docs/analysis.md, Method), a long one block by block
(docs/analysis.md, Long recordings)."""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, replace

import numpy as np

from synth import checks, dsp
from synth.analysis.blocks import (
    OVERLAP,
    ArraySource,
    FileSource,
    Source,
    Survey,
    block_frames,
    file_frames,
    mix_of,
    survey,
    whole_frames,
)
from synth.analysis.clipping import Clipping, clipping_warning, declipped_mix, find_clipping
from synth.analysis.measures import WINDOW_GUARD
from synth.analysis.options import AnalysisOptions, parameters_doc
from synth.analysis.report import Analysis
from synth.analysis.search import (
    LazyTick,
    first_search,
    measured_ticks,
    tick_meter,
    whitened_peak,
)
from synth.analysis.series import BOUNCE_GROWTH
from synth.analysis.settings import (
    AnalysisError,
    Settings,
    audio_array,
    check_recording_path,
    make_settings,
    read_recording,
)
from synth.analysis.validity import (
    RiseTest,
    Series,
    as_series_start,
    check_impulsive,
    flag_series,
    flag_warnings,
    impact_series,
    make_series,
    new_series_at,
    without_spurious_end,
)
from synth.analysis.whitening import one_blas_thread, predictors_reused
from synth.errors import ParameterError
from synth.store.audio import wav_shortfall

#: Largest fraction of the samples in flat tops (clipping) of a recording of impacts: its
#: ticks' peaks are short and their ringing decays below the clip level within each bounce,
#: so a signal held at its extremes for half its length is no such recording.
CLIPPED_AT_MOST = 0.5


def analyze(audio, samplerate, *, options=None, **overrides) -> Analysis:
    """Detect the ticks of a bouncing sound and measure them (docs/analysis.md, Method), with
    ``options`` (an :class:`~synth.analysis.options.AnalysisOptions`) and/or its fields as
    keywords (the keywords win). A recording longer than :data:`~synth.analysis.blocks.WHOLE` is
    analysed block by block, in linear time.

    Parameters
    ----------
    audio : array of float, (frames,) or (frames, channels)
        The recording, in any signal units (energies and peaks are in them).
    samplerate : float in (0, 768000]
        Sample rate, Hz.
    options : AnalysisOptions, optional
        The options; a keyword below changes one of them.
    OPTIONS_DOC

    Bad input raises ParameterError before any work, an unknown keyword TypeError, a silent
    recording, no tick or clipping with ``on_clipping="raise"`` AnalysisError."""
    o = AnalysisOptions.of(options, **overrides)
    chans = audio_array(audio)
    settings = make_settings(chans.shape[1], samplerate, o)
    return _analyze_source(ArraySource(chans, settings.samplerate), settings)


def _analyze_source(source: Source, settings: Settings) -> Analysis:
    """``source`` analysed whole up to :data:`~synth.analysis.blocks.WHOLE`; a stretch's resonator
    predictor solved once (:func:`~synth.analysis.whitening.predictors_reused`)."""
    with predictors_reused():
        if source.frames <= whole_frames(settings.samplerate):
            return _analyze_whole(source.read(0, source.frames), settings)
        return _analyze_blocks(source, settings)


def _analyze_whole(chans: np.ndarray, settings: Settings) -> Analysis:
    """The analysis of a recording held whole, ``(frames, channels)``."""
    used = chans if settings.channel is None else chans[:, [settings.channel]]
    clipping = _checked_signal(used, settings)
    x = mix_of(used)
    _refuse_silence(True, bool(np.any(x)))
    if clipping is not None:
        x = declipped_mix(used, clipping.mask, settings.whitening_order)
    found = _drops(x, settings, clipping is not None)
    noise = dsp.noise_floor(x, settings.samplerate)
    test = RiseTest(lambda a, b: x[a:b], settings.samplerate, settings.dynamic_range_db, noise)
    series = _impact_series(found, test, lambda first: x[first:], settings)
    return _result(series, x.size, noise, None if clipping is None else clipping.warning, settings)


def _result(series: list, frames: int, noise: float, clipping: str | None, settings) -> Analysis:
    """The :class:`Analysis` of ``series`` in ``frames`` frames, noise and clipping."""
    return Analysis(
        ticks=[t for s in series for t in s.ticks],
        samplerate=settings.samplerate,
        duration=frames / settings.samplerate,
        noise_floor=noise,
        gravity=settings.gravity,
        channel=settings.channel,
        clipped=clipping is not None,
        warnings=(() if clipping is None else (clipping,)) + flag_warnings(series),
        series=series,
    )


def _analyze_blocks(source: Source, settings: Settings) -> Analysis:
    """A long recording: one survey pass, then :func:`_block_drops`."""
    sv = survey(source, settings.channel)
    _refuse_silence(sv.any_sample, sv.any_mix)
    levels = _clip_levels(sv, settings.clip_samples)
    warning = None
    if levels:
        tops = sum(
            int(sv.high_tops[c] if lv == sv.highs[c] else sv.low_tops[c]) for c, lv in levels
        )
        worst = max(levels, key=lambda cl: sv.high_tops[cl[0]] + sv.low_tops[cl[0]])[0]
        warning = clipping_warning(
            tops,
            worst,
            int(sv.high_tops[worst] + sv.low_tops[worst]),
            float(max(abs(sv.highs[worst]), abs(sv.lows[worst]))),
        )
        _check_clipping(tops, source.frames * sv.highs.size, warning, settings)

    def signal(start: int, stop: int) -> np.ndarray:
        chans = source.read(start, stop)
        used = chans if settings.channel is None else chans[:, [settings.channel]]
        mask = np.zeros(used.shape, dtype=bool)
        for c, level in levels:
            mask[:, c] |= used[:, c] == level
        if mask.any():
            return declipped_mix(used, mask, settings.whitening_order)
        return mix_of(used)

    found = _block_drops(source.frames, signal, settings, bool(levels))
    test = RiseTest(signal, settings.samplerate, settings.dynamic_range_db, sv.noise_floor)
    series = _impact_series(
        found,
        test,
        lambda first: signal(first, min(source.frames, first + block_frames(test.fs))),
        settings,
    )
    return _result(series, source.frames, sv.noise_floor, warning, settings)


def _impact_series(found: list[list], test: RiseTest, ringing_from, settings: Settings):
    """The numbered series of ``found`` starting with an impact; AnalysisError where nothing rings
    down (:func:`~synth.analysis.validity.check_impulsive`) or none starts with one."""
    ticks = [t for s in _numbered(found) for t in s.ticks]
    first = int(ticks[0].time * settings.samplerate) if ticks else 0  # the first onset
    check_impulsive(ticks, ringing_from(first), test.fs)
    kept = impact_series(found, test)
    if ticks and not kept:
        raise AnalysisError(
            f"no impact found: none of the {len(ticks)} bursts found raises the recording's "
            f"spectrum as an impact does (is this a recording of impacts?)"
        )
    return _numbered(kept)


def _clip_levels(sv: Survey, min_count: int) -> list[tuple[int, float]]:
    """The clipped extremes ``(channel, level)``: ``min_count`` flat-top samples."""
    out = []
    for c in range(sv.highs.size):
        for level, tops in ((sv.highs[c], sv.high_tops[c]), (sv.lows[c], sv.low_tops[c])):
            if level != 0.0 and tops >= min_count:
                out.append((c, float(level)))
    return out


def _block_drops(frames: int, signal, settings: Settings, clipped: bool) -> list[list]:
    """The series of a recording of ``frames`` frames read by ``signal``, block by block: steps 1-6
    locate series, each drop is searched on its own (steps 1-7), one BLAS thread."""
    fs = settings.samplerate
    base = block_frames(fs)
    lead = int(math.ceil(settings.background * fs)) + WINDOW_GUARD
    overlap = int(round(OVERLAP * fs))
    done: list[list] = []
    last = -math.inf  # onset of the last tick kept, s
    pos, size = 0, base
    while True:
        stop = min(frames, pos + size)
        x = signal(pos, stop)
        shift = pos / fs
        with one_blas_thread():  # the resonator's predictor of a drop too: see below
            ticks = _block_ticks(x, settings, clipped, last - shift, lead)
        ticks = [
            replace(t, time=t.time + shift)
            for t in ticks
            if t.time + shift > last + settings.min_separation / fs
        ]
        cut = new_series_at(ticks)
        if cut is not None:
            done.append(ticks[:cut])
            last = ticks[cut - 1].time
            nxt = int(math.floor(ticks[cut].time * fs)) - lead
            pos = max(nxt, pos + int(math.floor((ticks[0].time - shift) * fs)) + 1)
            size = base
            continue
        if stop >= frames:
            return done + ([ticks] if ticks else [])
        nxt = stop - overlap
        if ticks:
            start = int(math.floor(ticks[0].time * fs)) - lead
            if not _series_ended(ticks, stop / fs, lead / fs):
                if start <= pos:  # one series over the whole block: a longer block
                    size *= 2
                    continue
                pos, size = start, base
                continue
            done.append(ticks)
            last = ticks[-1].time
            if start > pos:
                nxt = start
        pos, size = nxt, base


def _block_ticks(x: np.ndarray, settings: Settings, clipped: bool, kept: float, lead: int):
    """The ticks of block ``x`` (new after ``kept``, s): its first series alone, then steps 1-6's
    from the next drop; else the whole block by steps 1-7."""
    fs = settings.samplerate
    parts: dict = {}  # the whitening predictors' autocorrelation terms, x's and its start's
    loc = _located(x, settings, clipped, locate=True, parts=parts)
    cut = None if loc is None else new_series_at(loc.ticks)
    if loc is not None and loc.stopped and (cut is None or cut + 3 > len(loc.ticks)):
        loc = _located(x, settings, clipped, locate=False, parts=parts)
        cut = None if loc is None else new_series_at(loc.ticks)
    located = [] if loc is None else loc.ticks
    del loc
    if not any(t.time > kept for t in located):
        return []
    if cut is not None and located[cut - 1].time > kept:
        end = max(1, int(math.floor(located[cut].time * fs)) - lead)
        rest = [t.measured for t in located[cut:]]
        own = _searched(x[:end], settings, clipped, parts=parts) or [
            t.measured for t in located[:cut]
        ]
        if new_series_at(own + rest) is not None:
            return own + rest
    del located  # its whitening and residual: not held through the search of the block
    return _searched(x, settings, clipped, parts=parts)


@dataclass(frozen=True)
class Located:
    """Steps 1-6's ticks over a block, and whether the search stopped early."""

    ticks: list
    stopped: bool


def _located(
    x: np.ndarray, settings: Settings, clipped: bool, locate: bool, parts=None
) -> Located | None:
    """Steps 1-6 over block ``x`` (a :class:`Located`), or None without a tick."""
    try:
        first = first_search(x, settings, locate, parts)
        meter = tick_meter(x, first, settings, clipped, resonator=False)
    except (AnalysisError, ParameterError):
        return None
    fs = settings.samplerate
    ticks = [LazyTick(meter, i) for i in range(len(meter.found))]
    return Located(
        without_spurious_end(ticks, x.size / fs, settings.window / fs), first.result.stopped
    )


def _searched(
    x: np.ndarray, settings: Settings, clipped: bool, resonator: bool = True, parts=None
) -> list:
    """The ticks of ``x`` (:func:`_ticks`), none where it has none."""
    try:
        return _ticks(x, settings, clipped, resonator, parts)[0]
    except (AnalysisError, ParameterError):
        return []


def _series_ended(ticks: list, end: float, lead: float) -> bool:
    """Whether the block goes on past the series' next bounce (and the local background), so that it
    can have no tick after ``end`` (s)."""
    bounce = ticks[-1].bounce_time or 0.0
    return end - ticks[-1].time >= max(OVERLAP, BOUNCE_GROWTH * bounce) + lead


def _drops(x: np.ndarray, settings: Settings, clipped: bool) -> list[list]:
    """The ticks of each series of ``x``: steps 1-7 over the whole for one series; else as a long
    recording (:func:`_block_drops`): one drop's template fits no other's ringing."""
    ticks, innovation = _ticks(x, settings, clipped)
    if new_series_at(ticks) is None:
        return [ticks]
    drops = replace(settings, innovation=innovation)
    return _block_drops(x.size, lambda a, b: x[a:b], drops, clipped)


def _numbered(found: list[list]) -> list[Series]:
    """The series of ``found``, ticks numbered over the recording, bounces across drops left out,
    impossible values flagged."""
    out: list[Series] = []
    index = 0
    for k, ticks in enumerate(t for t in found if t):
        mine = [replace(t, index=index + j + 1) for j, t in enumerate(ticks)]
        if k:
            mine[0] = as_series_start(mine[0])
            if len(mine) > 1:
                mine[1] = replace(mine[1], restitution=None)
        index += len(mine)
        out.append(make_series(flag_series(mine)))
    return out


def _ticks(
    x: np.ndarray, settings: Settings, clipped: bool, resonator: bool = True, parts=None
) -> tuple[list, float]:
    """The measured ticks of ``x`` by steps 1-7 (1-6 without ``resonator``), and its largest
    whitened magnitude. ``parts``: as for :func:`first_search`."""
    search = first_search(x, settings, parts=parts)
    ticks = measured_ticks(x, search, settings, clipped, resonator)
    return ticks, whitened_peak(search)


def analyze_file(path, *, options=None, **overrides) -> Analysis:
    """Read a sound file (any format soundfile reads) and :func:`analyze` it, block by block past
    :data:`~synth.analysis.blocks.WHOLE`; a truncated WAV file is analysed as far as it goes
    (``TruncatedAudioWarning``).

    Parameters
    ----------
    path : str or path-like
    options : AnalysisOptions, optional
        The options; a keyword below changes one of them.
    OPTIONS_DOC

    An unreadable file raises AnalysisError, the rest as :func:`analyze`."""
    o = AnalysisOptions.of(options, **overrides)
    check_recording_path(path)
    frames = file_frames(path)  # None: a format read whole
    source = None if frames is None else FileSource(path)
    settings = None if source is None else make_settings(source.channels, source.samplerate, o)
    if source is None or frames <= whole_frames(settings.samplerate):
        result = analyze(*read_recording(path), options=o)
    else:
        result = _analyze_source(source, settings)
    short = wav_shortfall(path)
    return result if short is None else replace(result, warnings=result.warnings + (short,))


def _generated_signature(function, *leading: str) -> None:
    """Give ``function`` the options as keyword parameters and docs."""
    if function.__doc__:  # None under python -OO
        function.__doc__ = function.__doc__.replace("    OPTIONS_DOC", parameters_doc())
    function.__signature__ = inspect.Signature(
        [
            *(inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD) for n in leading),
            *checks.keyword_parameters(AnalysisOptions),
            inspect.Parameter("options", inspect.Parameter.KEYWORD_ONLY, default=None),
        ],
        return_annotation=Analysis,
    )


_generated_signature(analyze, "audio", "samplerate")
_generated_signature(analyze_file, "path")


def _checked_signal(used: np.ndarray, settings: Settings) -> Clipping | None:
    """Check the analysed channels (long enough, not silent); find clipping."""
    order = settings.whitening_order
    if used.shape[0] <= 2 * order:
        raise ParameterError(
            f"audio has {used.shape[0]} frames: too short for a whitening predictor of order "
            f"{order} (needs more than {2 * order})"
        )
    _refuse_silence(bool(np.any(used)), True)
    clipping = find_clipping(used, settings.clip_samples)
    if clipping is not None:
        tops = int(np.count_nonzero(clipping.mask))
        _check_clipping(tops, used.size, clipping.warning, settings)
    return clipping


def _refuse_silence(any_sample: bool, any_mix: bool) -> None:
    """Raise ``AnalysisError`` where every sample analysed is 0, or the mix of the channels."""
    if not any_sample:
        raise AnalysisError("the audio is silent: every sample of the analysed signal is 0")
    if not any_mix:
        raise AnalysisError("the audio is silent: the mean of the channels is 0 everywhere")


def _check_clipping(tops: int, size: int, warning: str, settings: Settings) -> None:
    """Raise AnalysisError past :data:`CLIPPED_AT_MOST` of ``size`` samples in flat tops, or
    with ``warning`` where ``on_clipping="raise"``."""
    if tops > CLIPPED_AT_MOST * size:
        raise AnalysisError(
            f"{tops} of {size} samples sit in flat tops at the extremes: not a recording of "
            f"impacts (a square wave, or one clipped throughout)"
        )
    if settings.on_clipping == "raise":
        raise AnalysisError(warning)
