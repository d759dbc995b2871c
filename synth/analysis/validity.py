"""What a bouncing ball can and cannot do (the thesis, docs/physics.md, References, section 3.1):
where drops begin, and which measurements are impossible."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from synth.analysis.measures import decay_time
from synth.analysis.report import (
    AFTER_GROWN,
    GROWN_BOUNCE,
    MISSED_BOUNCE,
    NO_DECAY,
    RESTITUTION_FLAGS,
    Tick,
)
from synth.analysis.series import BOUNCE_GROWTH, MAX_EXCESS_DB, RESTITUTION_STEP
from synth.analysis.settings import AnalysisError

#: A bounce over this many times the previous one is a silence no missed ticks explain: two missed
#: ticks make at most ``e (1 + e + e^2) < 3`` times.
MISSED_GROWTH = 3.0
#: Least shortfall of a tick's energy under ``e_n^2`` times the tick before's that a missed tick
#: makes, dB: ``(1 + e)^2 / e^2 >= 4`` for ``e <= 1``.
MISSED_ENERGY_DB = 10.0 * math.log10(4.0)
#: Least rise of the spectrum at an impact, dB (median over the frequencies holding sound of the
#: power after the onset over before): an impact at least as loud as the ringing it falls into
#: doubles the power over its broad contact spectrum; beating modes move power between frequencies
#: and add none.
SPECTRAL_RISE_DB = 3.0
#: Longest stretch each side of an onset for that rise, s: a 100 Hz resolution parts a plate's
#: ringing from an impact's broad spectrum.
SPECTRAL_RISE_SPAN = 0.01
#: Shortest such stretch, s: shorter has too few frequencies; the tick is kept.
SPECTRAL_RISE_MIN_SPAN = 0.001


#: A frequency holds sound where the power before and after exceeds the noise's by this, dB
#: (exponential scatter: 10 dB over the mean has probability 5e-5).
SPECTRAL_NOISE_MARGIN_DB = 10.0
#: Largest chance that stationary ringing shows the rise measured over as many frequencies
#: (significance 0.1 %): each burst of a ringing plate taken for a drop's start is a series of false
#: ticks (:func:`rise_chance`).
RISE_FALSE_ALARM = 1e-3
#: Frequencies of a Hann-windowed spectrum this far apart are nearly independent: the powers
#: of neighbouring bins of a random signal correlate by 4/9, of bins two apart by 1/36.
INDEPENDENT_BINS = 2


@dataclass(frozen=True)
class RiseTest:
    """What :func:`adds_sound` weighs: ``read``, ``fs`` (Hz), range (dB), noise (RMS)."""

    read: object
    fs: float
    dynamic_range_db: float
    noise_rms: float


def spectral_rise_db(
    before: np.ndarray, after: np.ndarray, dynamic_range_db: float, noise_rms: float = 0.0
) -> float:
    """Median of :func:`rise_ratios_db`, dB; +inf where no frequency holds sound."""
    ratios = rise_ratios_db(before, after, dynamic_range_db, noise_rms)
    return float(np.median(ratios)) if ratios.size else math.inf


def rise_chance(ratios_db: np.ndarray) -> float:
    """Chance stationary ringing gives this median rise (1 without frequencies)."""
    if not ratios_db.size:
        return 1.0
    return median_rise_chance(float(np.median(ratios_db)), ratios_db.size)


def median_rise_chance(median_db: float, count: int) -> float:
    """Chance that stationary ringing gives a median rise of ``median_db`` (dB) over ``count``
    frequencies: F(2, 2) ratios, binomial median over independent bins."""
    if median_db == math.inf:
        return 0.0
    p = 1.0 / (1.0 + 10.0 ** (median_db / 10.0))
    k = -(-count // INDEPENDENT_BINS)
    need = -(-k // 2)
    return float(sum(math.comb(k, j) * p**j * (1.0 - p) ** (k - j) for j in range(need, k + 1)))


def rise_ratios_db(
    before: np.ndarray, after: np.ndarray, dynamic_range_db: float, noise_rms: float = 0.0
) -> np.ndarray:
    """Power of ``after`` over ``before`` (Hann-windowed), dB, at the frequencies holding sound
    (within the range, over the noise ``noise_rms``)."""
    w = np.hanning(before.size)
    pb = np.abs(np.fft.rfft(before * w)) ** 2
    pa = np.abs(np.fft.rfft(after * w)) ** 2
    total = pa + pb
    noise = 2.0 * noise_rms**2 * float(np.sum(w * w))  # two stretches' expected power
    keep = (total > total.max() * 10.0 ** (-dynamic_range_db / 10.0)) & (
        total > noise * 10.0 ** (SPECTRAL_NOISE_MARGIN_DB / 10.0)
    )
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(pa[keep] / pb[keep])


#: Frequencies (bins) one spectral line covers in :func:`rise_ratios_db`: the main lobe of
#: the Hann window, four bins wide (Harris 1978, Proc. IEEE 66, 51, table 1).
HANN_LINE_BINS = 4
#: Least lines of sound for :func:`not_impacts` to drop a silent tick within a series.
SILENT_MIN_LINES = 3


@dataclass(frozen=True)
class RiseVerdict:
    """Whether the spectrum rises, whether that is decisive, over how many frequencies; whether
    the stretch was measured (long enough), and whether the rise measured is one stationary
    ringing shows at most :data:`RISE_FALSE_ALARM` of the time (``significant``)."""

    adds: bool
    decisive: bool
    frequencies: int = 0
    measured: bool = False
    significant: bool = False


def rise_verdict(test: RiseTest, tick_time: float, span: float) -> RiseVerdict:
    """Whether the spectrum rises at ``tick_time`` (s) by :data:`SPECTRAL_RISE_DB` over ``span``
    (s), beyond :data:`RISE_FALSE_ALARM`, where decidable."""
    fs = test.fs
    n = int(round(min(span, SPECTRAL_RISE_SPAN) * fs))
    i = int(round(tick_time * fs))
    undecided = RiseVerdict(True, False)
    if n < SPECTRAL_RISE_MIN_SPAN * fs or i < n:
        return undecided
    seg = np.asarray(test.read(i - n, i + n), dtype=float)
    if seg.size < 2 * n:  # the recording ends within the span: as long a stretch each side
        n = seg.size - n
        if n < SPECTRAL_RISE_MIN_SPAN * fs:
            return undecided
        seg = seg[seg.size - 2 * n :]
    ratios = rise_ratios_db(seg[:n], seg[n:], test.dynamic_range_db, test.noise_rms)
    if not ratios.size:
        return RiseVerdict(True, False, measured=True)
    decisive = median_rise_chance(SPECTRAL_RISE_DB, ratios.size) <= RISE_FALSE_ALARM
    rises = float(np.median(ratios)) >= SPECTRAL_RISE_DB
    significant = rises and rise_chance(ratios) <= RISE_FALSE_ALARM
    return RiseVerdict(
        significant or (rises and not decisive), decisive, int(ratios.size), True, significant
    )


def adds_sound(test: RiseTest, tick_time: float, span: float) -> bool:
    """Whether the spectrum rises at ``tick_time`` (s) (:func:`rise_verdict`)."""
    return rise_verdict(test, tick_time, span).adds


def impact_series(found: list[list], test: RiseTest) -> list[list]:
    """The series of ``found`` whose first tick adds sound (:func:`adds_sound`): a series that
    starts with none is whitened ringing of a plate at rest."""
    out = []
    for ticks in found:
        if not ticks:
            continue
        span = ticks[1].time - ticks[0].time if len(ticks) > 1 else SPECTRAL_RISE_SPAN
        if adds_sound(test, ticks[0].time, span):
            out.append(ticks)
    return out


def doubtful_ticks(ticks: list[Tick]) -> list[int]:
    """Indices of the ticks after the first whose bounce times show no ball's bounce: grown, after a
    grown one, over a missed one, an unconfirmed second tick, or a departing last one."""
    missed = missed_bounces(ticks)
    out = []
    for i in range(1, len(ticks)):
        grown = [
            e is not None and not e < 1.0 for e in (ticks[i - 1].restitution, ticks[i].restitution)
        ]
        unconfirmed = i == 1 and not _confirmed_second(ticks, missed)
        if unconfirmed or any(grown) or i in missed or _departing_last(ticks, i):
            out.append(i)
    return out


def _departing_last(ticks: list[Tick], i: int) -> bool:
    """Whether tick ``i`` is the last, its own sound does not ring down, and its restitution
    departs from the one before by over :data:`~synth.analysis.series.RESTITUTION_STEP`: a
    missed bounce or no bounce, and neither a tick after it (:func:`missed_bounces` needs both
    neighbours) nor its sound tells which."""
    if i + 1 < len(ticks) or ticks[i].decay_time is not None or not valid_restitution(ticks[i]):
        return False
    before = ticks[i - 1]
    return valid_restitution(before) and (
        abs(ticks[i].restitution / before.restitution - 1.0) > RESTITUTION_STEP
    )


def _confirmed_second(ticks: list[Tick], missed: set[int]) -> bool:
    """Whether ``e_2 < 1`` over no missed bounce, and ``e_3`` within
    :data:`~synth.analysis.series.RESTITUTION_STEP` of it, confirm the second tick."""
    following = ticks[2:4]
    if not following or missed & {2, 3}:
        return False
    if not all(_restitution_below_one(t) for t in following):
        return False
    return all(
        abs(t.restitution / following[0].restitution - 1.0) <= RESTITUTION_STEP for t in following
    )


def _louder_second(ticks: list[Tick]) -> bool:
    """Whether the second tick is over :data:`~synth.analysis.series.MAX_EXCESS_DB` louder than
    the first: no bounce of it."""
    return len(ticks) > 1 and ticks[1].energy > ticks[0].energy * 10.0 ** (MAX_EXCESS_DB / 10.0)


def _told_by_spectrum(ticks: list[Tick], i: int, missed: set[int]) -> bool:
    """Whether only the spectrum can tell tick ``i`` an impact: a departing last tick
    (:func:`_departing_last`), or a second tick the restitutions after it do not confirm
    (:func:`_confirmed_second`) whose own sound does not ring down either (one that rings down
    is judged as any doubtful tick: a plate's uneven bounces leave a real one unconfirmed)."""
    if _departing_last(ticks, i):
        return True
    if i != 1 or _confirmed_second(ticks, missed):
        return False
    return ticks[1].decay_time is None


def not_impacts(ticks: list[Tick], test: RiseTest) -> list[int]:
    """Indices of the doubtful ticks no impact made: no spectral rise where decided, or no rise
    and no decay over :data:`SILENT_MIN_LINES` lines (a single ringing line's power may fall
    when an impact hits it out of phase). A tick at a series' end that no bounce confirms
    (:func:`_told_by_spectrum`) is told by its spectrum alone: dropped unless the rise measured
    is one stationary ringing shows at most :data:`RISE_FALSE_ALARM` of the time (none where
    no frequency holds sound over the noise), not reported as a doubtful one. An unconfirmed
    second tick louder than the first by over :data:`~synth.analysis.series.MAX_EXCESS_DB` is
    dropped too (a restitution below 1: the second impact is no faster than the first, which
    starts the drop; a soft ball's release at the end of a long contact is such a burst; the
    bounces after a confirmed one show a ball, its level rising as it nears the listener)."""
    missed = missed_bounces(ticks)
    out = [1] if _louder_second(ticks) and not _confirmed_second(ticks, missed) else []
    for i in doubtful_ticks(ticks):
        if i in out:
            continue
        gaps = [ticks[i].time - ticks[i - 1].time]
        if i + 1 < len(ticks):
            gaps.append(ticks[i + 1].time - ticks[i].time)
        verdict = rise_verdict(test, ticks[i].time, min(gaps))
        silent = ticks[i].decay_time is None
        lines = verdict.frequencies >= SILENT_MIN_LINES * HANN_LINE_BINS
        unconfirmed = _told_by_spectrum(ticks, i, missed)
        if (not verdict.adds and (verdict.decisive or (silent and lines))) or (
            unconfirmed and verdict.measured and not verdict.significant
        ):
            out.append(i)
    return out


#: Envelope smoothing for a whole recording's decay, s (periods down to 20 Hz).
RINGING_SMOOTHING = 0.05


@dataclass(frozen=True)
class Series:
    """One drop's series: ``ticks``, ``first`` and ``last`` onsets (s), and ``mean_restitution`` of
    the unflagged (None without one)."""

    ticks: list[Tick]
    first: float
    last: float
    mean_restitution: float | None


def new_series_at(ticks: list[Tick]) -> int | None:
    """Index of the first tick that starts a new series (a grown bounce, louder or after a silence),
    or None."""
    times = [t.time for t in ticks]
    for i in range(2, len(ticks)):
        ratio = (times[i] - times[i - 1]) / (times[i - 1] - times[i - 2])
        if ratio > BOUNCE_GROWTH and (
            ratio > MISSED_GROWTH
            or ticks[i].energy > ticks[i - 1].energy * 10.0 ** (MAX_EXCESS_DB / 10.0)
        ):  # the energies only where the bounce grew (a tick may be measured on demand)
            return i
    return None


def as_series_start(tick: Tick) -> Tick:
    """``tick`` as the first tick of a series: no bounce time, speed nor restitution."""
    return replace(tick, bounce_time=None, speed=None, restitution=None)


def flag_series(ticks: list[Tick]) -> list[Tick]:
    """The ticks of one series with :data:`GROWN_BOUNCE`, :data:`AFTER_GROWN`, :data:`MISSED_BOUNCE`
    and :data:`NO_DECAY` flagged, restitutions withheld (:func:`without_flagged_restitutions`)."""
    return without_flagged_restitutions(_flagged(ticks))


def without_flagged_restitutions(ticks: list[Tick]) -> list[Tick]:
    """``ticks`` with the restitution withheld where a flag of :data:`RESTITUTION_FLAGS` says it is
    no ratio of two flights, and the speed too where the bounce grew."""
    return [
        replace(t, restitution=None, speed=None if GROWN_BOUNCE in t.flags else t.speed)
        if set(t.flags) & set(RESTITUTION_FLAGS)
        else t
        for t in ticks
    ]


def _flagged(ticks: list[Tick]) -> list[Tick]:
    """``ticks`` with the flags of :func:`flag_series`, their values as measured."""
    out = []
    for i, t in enumerate(ticks):
        flags = list(t.flags)
        if t.restitution is not None and not t.restitution < 1.0:
            flags.append(GROWN_BOUNCE)
        if i > 0 and GROWN_BOUNCE in out[-1].flags and t.restitution is not None:
            flags.append(AFTER_GROWN)
        if t.decay_time is None:
            flags.append(NO_DECAY)
        out.append(replace(t, flags=tuple(flags)))
    return _with_missed_bounces(out)


def _with_missed_bounces(ticks: list[Tick]) -> list[Tick]:
    """``ticks`` with :data:`MISSED_BOUNCE` added to the flags of :func:`missed_bounces`."""
    missed = missed_bounces(ticks)
    return [
        replace(t, flags=t.flags + (MISSED_BOUNCE,)) if i in missed else t
        for i, t in enumerate(ticks)
    ]


def missed_bounces(ticks: list[Tick]) -> set[int]:
    """Indices of the ticks whose restitution spans a missed bounce: off both neighbours' by
    :data:`~synth.analysis.series.RESTITUTION_STEP`, or :data:`MISSED_ENERGY_DB` under ``e_n^2``
    times the tick before's energy (the thesis, section 3.1)."""
    rest = {i: t.restitution for i, t in enumerate(ticks) if _restitution_below_one(t)}
    out = set()
    for i, e in rest.items():
        near = [rest[j] for j in (i - 1, i + 1) if j in rest]
        if len(near) == 2 and all(abs(e / other - 1.0) > RESTITUTION_STEP for other in near):
            out.add(i)
        if ticks[i].energy < e * e * ticks[i - 1].energy * 10.0 ** (-MISSED_ENERGY_DB / 10.0):
            out.add(i)
    return out


def _restitution_below_one(tick: Tick) -> bool:
    """Whether ``tick`` has a restitution that is not flagged impossible and below 1."""
    return valid_restitution(tick) and tick.restitution < 1.0


def valid_restitution(tick: Tick) -> bool:
    """Whether ``tick`` has a restitution that is not flagged impossible."""
    return tick.restitution is not None and not set(tick.flags) & set(RESTITUTION_FLAGS)


def check_impulsive(ticks: list[Tick], ringing: np.ndarray, fs: float) -> None:
    """Raise AnalysisError when nothing found rings down after it (a square wave's edges);
    ``ringing`` (rate ``fs``, Hz) is fitted where no tick has a decay."""
    if not ticks or not all(NO_DECAY in t.flags for t in ticks):
        return
    if decay_time(ringing, fs, max(3, int(round(RINGING_SMOOTHING * fs))), 0.0) is not None:
        return
    raise AnalysisError(
        f"no impact found: none of the {len(ticks)} bursts found is followed by a "
        f"decaying ringing (is this a recording of impacts? a periodic wave's edges "
        f"are not)"
    )


def _continues_series(ticks: list[Tick]) -> bool:
    """Whether the last tick continues the series: a bounce shorter than the one before. A
    second tick has no bounce before its own to be shorter than: nothing confirms it."""
    e = ticks[-1].restitution
    return e is not None and e < 1.0


def _after_rest(ticks: list[Tick]) -> bool:
    """Whether the last tick came after a silence (:data:`MISSED_GROWTH`)."""
    e = ticks[-1].restitution
    return len(ticks) > 2 and (e is None or e > MISSED_GROWTH)


def without_spurious_end(ticks: list[Tick], duration: float, window: float) -> list[Tick]:
    """``ticks`` without the trailing undecaying bursts after the last impact (after a rest, or past
    the end with ``window`` and ``duration``, s)."""
    out = list(ticks)
    decays = any(t.decay_time is not None for t in out)
    while (
        out
        and out[-1].decay_time is None
        and (
            (decays and _after_rest(out))
            or (out[-1].time + window > duration and not _continues_series(out))
        )
    ):
        out.pop()
    return out


def make_series(ticks: list[Tick]) -> Series:
    """The :class:`Series` of ``ticks`` (one series, flags set)."""
    e = [t.restitution for t in ticks if valid_restitution(t)]
    return Series(
        ticks=ticks,
        first=ticks[0].time,
        last=ticks[-1].time,
        mean_restitution=float(np.mean(e)) if e else None,
    )


def _listed(ticks: list, shown: int = 5) -> str:
    """The first ``shown`` flagged ticks with their bounce time, and how many more."""
    listed = ", ".join(
        f"tick {t.index} (bounce {t.bounce_time:.4g} s)"
        if t.bounce_time is not None
        else f"tick {t.index}"
        for t in ticks[:shown]
    )
    return listed + (f" and {len(ticks) - shown} more" if len(ticks) > shown else "")


def flag_warnings(series: list[Series]) -> tuple[str, ...]:
    """The summary of the flags and of the series, one warning each, in words."""
    out = []
    missed = [t for s in series for t in s.ticks if MISSED_BOUNCE in t.flags]
    if missed:
        out.append(
            f"restitution over a missed bounce at {len(missed)} tick(s): {_listed(missed)}; "
            f"its bounce times or energy do not follow one ball's series (flagged, "
            f"restitution withheld)"
        )
    grown = [t for s in series for t in s.ticks if GROWN_BOUNCE in t.flags]
    if grown:
        out.append(
            f"physically impossible restitution at {len(grown)} tick(s): {_listed(grown)}; a "
            f"ball's bounce times shrink, so a tick was missed before each (its restitution "
            f"and the next one's are flagged and withheld)"
        )
    silent = [t for s in series for t in s.ticks if NO_DECAY in t.flags]
    if silent:
        out.append(
            f"{len(silent)} tick(s) without a decaying response (first: tick "
            f"{silent[0].index} at {silent[0].time:.4f} s): doubtful impacts"
        )
    if len(series) > 1:
        shown = 5  # a long recording of many drops would make the line kilobytes long
        starts = ", ".join(f"{s.first:.3f} s" for s in series[:shown])
        if len(series) > shown:
            starts += f" and {len(series) - shown} more"
        out.append(
            f"{len(series)} bounce series (drops) starting at {starts}: each is "
            f"measured on its own (Analysis.series)"
        )
    return tuple(out)
