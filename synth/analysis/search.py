"""Steps 1-9 over one signal (docs/analysis.md, Method), and the meter of the ticks found."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from synth import dsp
from synth.analysis.deflation import DeflationSearch, FirstTick
from synth.analysis.detection import first_ticks
from synth.analysis.measures import (
    WINDOW_GUARD,
    FoundTick,
    TickMeter,
    Whitening,
    with_standing_out,
)
from synth.analysis.options import MAX_ORDER
from synth.analysis.residual import ECHO_SLACK, residual_ticks
from synth.analysis.resonator import AGREEMENT, BACKGROUND_SPAN, ResonatorSearch
from synth.analysis.ringing import ringing_explained
from synth.analysis.series import DOUBTFUL_DB, bounce_order, fitting_additions
from synth.analysis.settings import (
    AnalysisError,
    Settings,
)
from synth.analysis.validity import (
    RiseTest,
    adds_sound,
    not_impacts,
    without_spurious_end,
)
from synth.analysis.whitening import (
    one_blas_thread,
    resonator_predictor,
    whiten,
    whitening_predictor,
)

#: Least gain in the first tick's ringing left for step 7 to be kept, dB.
RESONATOR_GAIN_DB = 20.0


#: The first bounce's free ringing starts this long after the first onset, s.
CLEAN_GUARD = 0.002
#: Step 7 fits the free ringing over at most this many times the largest predictor order: the
#: final prediction error of an order ``p`` fitted over ``N`` samples is ``(N + p) / (N - p)``
#: times the innovation's (Akaike 1970, Ann. Inst. Stat. Math. 22, 203), 0.1 dB at ``N = 87 p``;
#: a longer stretch (a single impact ringing for seconds) costs time, not accuracy.
RINGING_FIT_ORDERS = 87


@dataclass(frozen=True)
class FirstSearch:
    """Steps 1-5 over a signal: the whitening predictor and the search's result."""

    predictor: np.ndarray
    result: SearchResult


def first_search(
    x: np.ndarray, settings: Settings, locate: bool = False, parts: dict | None = None
) -> FirstSearch:
    """Steps 1-5 over ``x`` (with ``locate``, stopped past a new series' start); ``parts``: shared
    autocorrelation terms."""
    A = whitening_predictor(x, settings.whitening_order, settings.samplerate, parts)
    with one_blas_thread():
        return FirstSearch(A, _search(whiten(x, A), settings, locate=locate, x=x))


def measured_ticks(
    x: np.ndarray, search: FirstSearch, settings: Settings, clipped: bool, resonator: bool
) -> list:
    """The measured ticks of ``x`` from ``search`` after steps 6, 7 (with ``resonator``) and 9, and
    those adding no sound dropped."""
    meter = tick_meter(x, search, settings, clipped, resonator)
    with one_blas_thread():
        ticks = [meter.tick(i) for i in range(len(meter.found))]
    fs = settings.samplerate
    test = RiseTest(lambda a, b: x[a:b], fs, settings.dynamic_range_db, meter.noise)
    innovation = whitened_peak(search) if settings.innovation is None else settings.innovation
    dropped = set(not_impacts(ticks, test)) | set(
        ringing_ticks(x, ticks, meter.found, settings, innovation)
    )
    while dropped:  # the others measured again: their bounces span the dropped ones, and
        # a bounce that spans one may show a tick doubtful that the dropped one hid
        found = [f for i, f in enumerate(meter.found) if i not in dropped]
        meter = meter.with_found(found)
        with one_blas_thread():
            ticks = [meter.tick(i) for i in range(len(found))]
        dropped = set(not_impacts(ticks, test))
    if resonator:
        meter, ticks = _with_residual_ticks(x, meter, ticks, settings, innovation, test)
    return without_spurious_end(ticks, x.size / fs, settings.window / fs)


def _with_residual_ticks(
    x: np.ndarray,
    meter: TickMeter,
    ticks: list,
    settings: Settings,
    innovation: float,
    test: RiseTest,
) -> tuple[TickMeter, list]:
    """Step 10: ``meter`` and its ``ticks`` with the impacts the ringing's residual shows
    (:func:`~synth.analysis.residual.residual_ticks`); one under
    :data:`~synth.analysis.series.DOUBTFUL_DB` must raise the recording's spectrum as a drop's
    start (:func:`~synth.analysis.validity.adds_sound`), one over it need not: in a steady
    chatter the stretch before a tick holds the tick before, as loud. A new tick that step 9
    drops is left out, the others measured again without it."""
    onsets = np.array([f.onset for f in meter.found])
    if onsets.size == 0:
        return meter, ticks
    rises = residual_ticks(x, onsets, settings, innovation)
    fs = settings.samplerate
    added = []
    bursts = np.sort(np.r_[onsets, [r.onset for r in rises]])
    for r in rises:
        gap = float(np.abs(onsets - r.onset).min())
        if gap < settings.min_separation:
            continue
        if r.strength < DOUBTFUL_DB and not adds_sound(
            test, r.onset / fs, min(gap, _half_bounce(bursts, r.onset)) / fs
        ):
            continue  # a doubtful burst (an echo's, a reverberation's) must add sound
        added.append(FoundTick(r.onset, r.strength, None, 0, r.onset))
    timed = _residual_timed(onsets, rises, settings.min_separation)
    added = _series_additions(meter.found, timed, added)
    while added:
        found = sorted(meter.found + added, key=lambda f: f.onset)
        trial = meter.with_found(found)
        with one_blas_thread():
            measured = [trial.tick(i) for i in range(len(found))]
        new = {i for i, f in enumerate(found) if any(f is g for g in added)}
        dropped = new & set(ringing_ticks(x, measured, found, settings, innovation))
        if not dropped:
            return trial, measured
        added = [f for i, f in enumerate(found) if i in new and i not in dropped]
    return meter, ticks


def _half_bounce(bursts: np.ndarray, onset: float) -> float:
    """Half the time (samples) from the burst before ``onset`` among ``bursts`` (the ticks and the
    residual's bursts, samples, in time order): the longest stretch each side of ``onset`` whose
    spectra :func:`~synth.analysis.validity.adds_sound` compares. A longer stretch before reaches
    into the previous impact's first milliseconds, where its own broad, fast-decaying sound
    outweighs a later impact as loud as the ringing; a stretch over the burst before compares
    the onset with that burst, not with the ringing. Infinite before the first burst."""
    i = int(np.searchsorted(bursts, onset))
    return 0.5 * float(onset - bursts[i - 1]) if i else math.inf


def _residual_timed(onsets: np.ndarray, rises: list, min_sep: int) -> np.ndarray:
    """``onsets`` (samples) as the residual times them, for the bounces its new bursts make: each
    moved to a burst of ``rises`` within ``min_sep`` before it (part of it) and over
    :data:`~synth.analysis.residual.ECHO_SLACK` samples earlier (the searches time one burst
    within two sample periods). The residual is the recording less the free ringing its past
    predicts; where it rises is where it times a burst, so a new burst's bounce is measured from
    a tick timed the same way. Step 4 times a whitened burst whose first, weaker arrival (a
    microphone hears the plate's nearest point before the impact point) falls under its walk's
    level at its later peak: a bounce timed from that to a residual's burst looks grown. The
    reported onsets stay step 4's (a band-limited burst's residual rises at its filter's
    pre-echo, before the sinc's centre)."""
    out = np.array(onsets, dtype=float)
    for r in rises:
        i = int(np.argmin(np.abs(onsets - r.onset)))
        lead = onsets[i] - r.onset
        if ECHO_SLACK < lead < min_sep and (i == 0 or r.onset > onsets[i - 1] + min_sep):
            out[i] = r.onset
    return out


def _series_additions(
    found: list[FoundTick], timed: np.ndarray, added: list[FoundTick]
) -> list[FoundTick]:
    """The ``added`` ticks that leave the bounces of ``found`` (their onsets ``timed``, samples)
    with them no less like a ball's (:func:`~synth.analysis.series.fitting_additions`)."""
    ticks = sorted(
        [(on, False, f) for on, f in zip(timed, found)] + [(f.onset, True, f) for f in added],
        key=lambda t: t[0],
    )
    onsets = np.array([t[0] for t in ticks])
    keep = fitting_additions(onsets, np.array([t[1] for t in ticks], dtype=bool))
    return [t[2] for t, k in zip(ticks, keep) if k and t[1]]


def tick_meter(
    x: np.ndarray, search: FirstSearch, settings: Settings, clipped: bool, resonator: bool
) -> TickMeter:
    """The ticks of ``x`` kept from ``search`` by step 6 and, with ``resonator``, step 7 with step
    8's, ready to be measured (locating searches need no weak ticks)."""
    first = search.result
    found = [
        FoundTick(
            first.onsets[i],
            first.strengths[i],
            None if first.models is None else first.models[i],
            0,
            first.onsets[i],
        )
        for i in bounce_order(first.onsets, first.strengths, settings.e_min)
    ]
    whitenings = [Whitening(search.predictor, first.whitened, first.residual)]
    if (
        resonator
        and first.ringing_left is not None
        and first.ringing_left > 10.0 ** (-settings.dynamic_range_db / 10.0)
        and not settings.fixed_order
        and not clipped
    ):
        found = _resonator_stage(x, settings, first, found, whitenings)
    if resonator:  # a search's own ticks; where series start (steps 1-6) needs none of them
        found = with_standing_out(x, found, whitenings[0], settings)
    noise = dsp.noise_floor(x, settings.samplerate)
    return TickMeter(x, found, whitenings, settings, noise)


def whitened_peak(search) -> float:
    """Largest magnitude of ``search``'s whitened signal (``Settings.innovation``)."""
    return float(np.max(np.abs(search.result.whitened)))


def ringing_ticks(
    x: np.ndarray, ticks: list, found: list[FoundTick], settings: Settings, innovation: float
) -> list[int]:
    """Indices of the ``ticks`` whose burst the ringing explains (step 9), except step 7's
    (``found``)."""
    fs = settings.samplerate
    guard = int(round(CLEAN_GUARD * fs))
    return [
        i
        for i in range(1, len(ticks))
        if found[i].whitening == 0
        and ringing_explained(
            x,
            int(math.floor(ticks[i - 1].time * fs)) + guard,
            ticks[i].time * fs,
            settings,
            innovation,
        )
    ]


class LazyTick:
    """A tick of steps 1-6, measured only when more than its time is asked for."""

    def __init__(self, meter: TickMeter, i: int):
        self._meter, self._i, self._tick = meter, i, None

    @property
    def time(self) -> float:
        return self._meter.time(self._i)

    @property
    def measured(self):
        """The tick's :class:`~synth.analysis.report.Tick`."""
        if self._tick is None:
            self._tick = self._meter.tick(self._i)
        return self._tick

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.measured, name)


@dataclass(frozen=True)
class SearchResult:
    """One search: onsets (samples), strengths (dB), residual and models (or None), the ringing
    left, the candidate frames, and step 7's timed onsets."""

    whitened: np.ndarray
    onsets: np.ndarray
    strengths: np.ndarray
    residual: np.ndarray | None
    models: list | None
    ringing_left: float | None
    peaks: np.ndarray
    timed: np.ndarray | None
    stopped: bool = False


def _search(
    r: np.ndarray,
    settings: Settings,
    order: int | None = None,
    known=(),
    locate: bool = False,
    x: np.ndarray | None = None,
) -> SearchResult:
    """Steps 2-5 on ``r``, the whitening of the recording ``x``; with ``order``, step 7's rules
    (background over :data:`BACKGROUND_SPAN` times the order, no fixed floor unless given).
    ``known``: the first search's onsets."""
    fs, hop = settings.samplerate, settings.hop
    background = (
        settings.background
        if order is None
        else max(settings.background, BACKGROUND_SPAN * order / fs)
    )
    ft = first_ticks(r, settings, background, x)
    if not settings.deflate:
        return SearchResult(r, ft.onsets, ft.strengths, None, None, None, ft.peaks, None)
    peaks, d = ft.peaks, ft.d
    end1 = (peaks[1] - 1) * hop if peaks.size > 1 else r.size
    if order is not None and peaks.size > 1:
        end1 = min(end1, max(int(math.floor(ft.onsets[1])) - WINDOW_GUARD, 1))
    first = FirstTick(ft.onsets[0], ft.strengths[0], d[peaks[0] : peaks[0] + 2].max(), end1)
    anchors = (ft.anchors[1:], ft.anchor_strengths[1:])
    fixed_floor = d.max() * 10.0 ** (-settings.dynamic_range_db / 10.0)
    if order is None:
        search = DeflationSearch(r, settings, first, anchors, fixed_floor, float(d.max()), known)
    else:
        search = ResonatorSearch(
            r,
            settings,
            first,
            anchors,
            fixed_floor if settings.fixed_range else None,
            float(d.max()),
            known,
        )
    out = search.run(locate)
    return SearchResult(
        r,
        out.onsets,
        out.strengths,
        out.residual,
        out.models,
        out.ringing_left if peaks.size > 1 else None,
        peaks,
        out.timed,
        out.stopped,
    )


def _resonator_stage(
    x: np.ndarray,
    settings: Settings,
    first: SearchResult,
    found: list[FoundTick],
    whitenings: list[Whitening],
) -> list[FoundTick]:
    """Step 7, kept when it leaves :data:`RESONATOR_GAIN_DB` less ringing and agrees with the first
    search (:data:`AGREEMENT`); appends its whitening."""
    fs = settings.samplerate
    lo = int(math.floor(first.onsets[0])) + int(round(CLEAN_GUARD * fs))
    hi = min((first.peaks[1] - 1) * settings.hop, lo + RINGING_FIT_ORDERS * MAX_ORDER)
    a_res = resonator_predictor(x[lo:hi], fs, settings.whitening_order) if hi > lo else None
    if a_res is None:
        return found
    known = np.array([f.onset for f in found])
    try:
        with one_blas_thread():
            res = _search(whiten(x, a_res), settings, a_res.size - 1, known, x=x)
    except AnalysisError:
        return found
    if res.ringing_left is None or not (
        res.ringing_left < first.ringing_left * 10.0 ** (-RESONATOR_GAIN_DB / 10.0)
    ):
        return found
    kept = bounce_order(res.onsets, res.strengths, settings.e_min)
    on2 = res.onsets[kept]
    tol = AGREEMENT * fs
    n = 0
    while n < min(len(found), on2.size) and abs(on2[n] - found[n].onset) <= tol:
        n += 1
    if not (n >= 2 and (n == len(found) or on2.size > n and on2[n] < found[n].onset - tol)):
        return found
    whitenings.append(Whitening(a_res, res.whitened, res.residual))
    timed = res.timed
    return [replace(found[j], onset=timed[kept[j]]) for j in range(n)] + [
        FoundTick(timed[kept[j]], res.strengths[kept[j]], res.models[kept[j]], 1, on2[j])
        for j in range(n, on2.size)
    ]
