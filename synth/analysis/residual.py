"""Step 10 (docs/analysis.md): impacts the earlier steps missed, sought in the recording less the
ringing its own past predicts. Between two ticks the recording is the plate's free ringing; the
modes fitted to the stretch after a tick (Prony's method, as step 9) predict each sample from the
ones before, so what the prediction leaves is what no past ringing explains: an impact a few
milliseconds after the last stands out of that residual, not under the ringing's level. Positions
in samples."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth.analysis.detection import (
    ONSET_NOISE_SIGMAS,
    STANDS_OUT_BEFORE,
    STANDS_OUT_FALSE_ALARM,
    STANDS_OUT_SPAN,
    OnsetWalk,
    frame_energies,
    refine_onset,
)
from synth.analysis.ringing import RINGING_FIT, ringing_predictor
from synth.analysis.settings import Settings

#: The free ringing after a tick starts this long after its onset, s: past the longest contact
#: of a series (a slow ball on a soft board, about 0.5 ms) and its whitened transients (as
#: step 7's and step 9's fits).
FREE_GUARD = 0.002
#: The shortest stretch of free ringing a predictor is fitted over, s: a chatter's next impact
#: may follow its contact by 3 ms; a predictor of a third of its samples models the strongest
#: modes there (7 modes at 44.1 kHz), longer fits the rest of the gap.
SHORT_FIT = 0.001
#: Fits from :data:`SHORT_FIT` to :data:`~synth.analysis.ringing.RINGING_FIT`, their lengths in
#: geometric steps (1, 3.2 and 10 ms): a predictor is trusted at most about three times its own
#: stretch ahead, where the next one takes over (a short fit models few modes, and the others'
#: beating drifts out of it).
FIT_STEPS = 3
#: Seconds of white-noise prediction error over which the test passes once by chance: it is
#: made at every hop of every gap, so its false-alarm probability per position is the hop over
#: this (2.5e-7 at the default hop), where step 8's one test per burst may pass once in 1.6e4.
FALSE_ALARM_SPAN = 1000.0
#: Two bursts lie as far from the ticks before them within this, samples, only as echoes at one
#: delay (a reflection's path does not change; the searches time a burst within two sample
#: periods), not as two bounces of a ball (whose flights differ by more).
ECHO_SLACK = 2.0
#: The error is worked out over stretches of this much, s, up to the first burst.
SCAN_CHUNK = 0.05


@dataclass(frozen=True)
class Rise:
    """A burst of the residual: its onset (samples of the recording) and its rise (dB) over the
    residual before it, less the F quantile white noise exceeds once in
    :data:`FALSE_ALARM_SPAN`."""

    onset: float
    strength: float


def residual_ticks(
    x: np.ndarray, onsets: np.ndarray, settings: Settings, innovation: float
) -> list[Rise]:
    """The bursts of ``x`` between the ticks at ``onsets`` (samples, in time order) after the
    second and after the last, each at least ``min_separation`` from every tick, that the
    ringing predicted from the free stretch after the tick before does not explain
    (:func:`first_rise`); each found starts a new free stretch. The first bounce's bursts are
    the first tick's own response (step 3: a room's reflections, a pickup's echo): a later
    burst as far from an earlier tick as one of them from the first (:func:`echo_delays`) is
    its echo, no impact; so are bursts as far from the tick before them as another is (within
    :data:`ECHO_SLACK`), which the first tick's ringing hid. Linear in the recording's length:
    up to three fits per tick found."""
    onsets = np.asarray(onsets, dtype=float)
    if onsets.size < 2:
        return []
    sep = settings.min_separation
    stops = [int(math.floor(v)) for v in onsets[2:] - sep] + [x.size]
    echoes = echo_delays(x, onsets[0], int(math.floor(onsets[1] - sep)), settings, innovation)
    out: list[Rise] = []
    after: list[float] = []  # each rise's delay from the tick or rise before it
    ticks = list(onsets)
    for a, stop in zip(onsets[1:], stops):
        last = float(a)
        for r in _gap_rises(x, float(a), stop, settings, innovation):
            delays = r.onset - np.array([t for t in ticks if t < r.onset])
            if not np.any((delays[:, None] >= echoes[:, 0]) & (delays[:, None] <= echoes[:, 1])):
                out.append(r)
                after.append(r.onset - last)
            ticks.append(r.onset)
            last = r.onset
    d = np.array(after)
    repeated = np.abs(d[:, None] - d[None, :]) <= ECHO_SLACK
    return [r for r, n in zip(out, repeated.sum(axis=1)) if n == 1]


def echo_delays(
    x: np.ndarray, onset: float, stop: int, s: Settings, innovation: float
) -> np.ndarray:
    """The delays (samples, rows ``[lo, hi]``) from ``onset`` (the first tick's) of the bursts of
    its response up to ``stop`` (the second tick): every run of samples that passes
    :func:`_scan`'s test under the predictors of :func:`first_rise`, from a hop before its
    first to the test's span after its last. The test is step 8's, one false alarm in
    :data:`~synth.analysis.detection.STANDS_OUT_FALSE_ALARM`: a later burst is judged at its
    own delay, once, not searched for (a reflection shows fainter under the first tick's
    ringing than under a later one's)."""
    fs, hop = s.samplerate, s.hop
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    start = int(math.floor(onset)) + int(round(FREE_GUARD * fs))
    passing = []
    for n, limit in _fits(start, stop, fs):
        end = start + n
        a = _fitted(x, start, end, limit, fs)
        if a is None:
            continue
        for c0, c1 in _chunks(end, limit, fs, hop):
            sc = _scan(x, a, end, c0, c1, s, innovation, STANDS_OUT_FALSE_ALARM)
            if sc is not None:
                passing.append(sc.positions)
    pos = np.unique(np.concatenate(passing)) if passing else np.zeros(0, dtype=int)
    if not pos.size:
        return np.zeros((0, 2))
    breaks = np.nonzero(np.diff(pos) > hop)[0]
    firsts = pos[np.r_[0, breaks + 1]]
    lasts = pos[np.r_[breaks, pos.size - 1]]
    return np.column_stack((firsts - hop - onset, lasts + span - onset))


def _fitted(x: np.ndarray, start: int, end: int, stop: int, fs: float) -> np.ndarray | None:
    """Step 9's predictor of ``x[start:end]``, None where nothing after it up to ``stop`` can be
    tested (a span of error before a span tested) or the stretch is silent."""
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    if end + 2 * span > min(stop, x.size - span) or end - start < 4:
        return None
    return ringing_predictor(x[start:end])


def _fits(start: int, stop: int, fs: float) -> list[tuple[int, int]]:
    """:func:`first_rise`'s fits from ``start``: each one's length and the end of its test
    (samples), the next longer one's first test sample, the last ``stop``."""
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    lengths = [
        max(1, int(round(SHORT_FIT * (RINGING_FIT / SHORT_FIT) ** (i / (FIT_STEPS - 1)) * fs)))
        for i in range(FIT_STEPS)
    ]
    limits = [min(stop, start + n + span) for n in lengths[1:]] + [stop]
    return list(zip(lengths, limits))


def _chunks(end: int, stop: int, fs: float, hop: int) -> list[tuple[int, int]]:
    """``[end, stop)`` in stretches of :data:`SCAN_CHUNK`, a whole number of hops each."""
    chunk = max(int(round(SCAN_CHUNK * fs)), 8 * hop)
    chunk -= chunk % hop
    return [(c0, min(stop, c0 + chunk)) for c0 in range(end, stop, chunk)]


def _gap_rises(
    x: np.ndarray, onset: float, stop: int, settings: Settings, innovation: float
) -> list[Rise]:
    """The bursts of :func:`first_rise` one after the other from ``onset`` up to ``stop``."""
    out: list[Rise] = []
    start = onset
    while True:
        rise = first_rise(x, start, stop, settings, innovation)
        if rise is None or rise.onset - start < settings.min_separation:
            return out
        out.append(rise)
        start = rise.onset


def first_rise(
    x: np.ndarray, onset: float, stop: int, s: Settings, innovation: float
) -> Rise | None:
    """The first burst of ``x`` before ``stop`` in the prediction error of the ringing free from
    :data:`FREE_GUARD` after ``onset``: predictors fitted over :data:`FIT_STEPS` lengths from
    :data:`SHORT_FIT` to :data:`~synth.analysis.ringing.RINGING_FIT`, each tested up to where
    the next longer one's test begins."""
    start = int(math.floor(onset)) + int(round(FREE_GUARD * s.samplerate))
    for n, limit in _fits(start, stop, s.samplerate):
        rise = _rise_after(x, start, start + n, limit, s, innovation)
        if rise is not None:
            return rise
    return None


def _rise_after(
    x: np.ndarray, start: int, end: int, stop: int, s: Settings, innovation: float
) -> Rise | None:
    """The first burst in ``[end + span, stop)`` of the error of the predictor fitted over
    ``x[start:end]``: the mean square over ``span`` (:data:`~synth.analysis.detection.
    STANDS_OUT_SPAN`) from a sample on the hop grid over that of the error before it (at most
    :data:`~synth.analysis.detection.STANDS_OUT_BEFORE`, never the fitted stretch) beyond
    white noise's F quantile, and its peak within ``dynamic_range_db`` of ``innovation`` (the
    strongest impact's contact force, as step 9)."""
    fs = s.samplerate
    a = _fitted(x, start, end, stop, fs)
    if a is None:
        return None
    for c0, c1 in _chunks(end, stop, fs, s.hop):  # the first burst costs the stretch to it
        rise = _first_hit(x, a, end, c0, c1, s, innovation)
        if rise is not None:
            return rise
    return None


def _first_hit(
    x: np.ndarray, a: np.ndarray, end: int, c0: int, c1: int, s: Settings, innovation: float
) -> Rise | None:
    """:func:`_rise_after`'s first burst in ``[c0, c1)`` (:func:`_scan`), its onset walked back
    on the error (step 4)."""
    sc = _scan(x, a, end, c0, c1, s, innovation)
    if sc is None or not sc.hits.size:
        return None
    h = int(sc.hits[0])
    at = int(sc.k[h])
    sigma = ONSET_NOISE_SIGMAS * math.sqrt(sc.mean_before[h])
    lo_w = max(0, at - s.hop)
    hi_w = min(sc.e.size, at + max(1, int(round(STANDS_OUT_SPAN * s.samplerate))) + s.hop)
    walk = OnsetWalk(s.onset_fraction, s.onset_gap, sigma, strict=True)
    on = max(refine_onset(sc.e, lo_w, hi_w, walk), float(lo_w))  # in the burst, not the past
    return Rise(sc.b0 + on, 10.0 * math.log10(sc.margin[h]))


@dataclass(frozen=True)
class Scan:
    """:func:`_scan`'s error ``e`` from sample ``b0``, the positions tested (indices of ``e``), the
    mean square before each, each one's margin over the F quantile (power ratio) and the indices
    of those that pass."""

    e: np.ndarray
    b0: int
    k: np.ndarray
    mean_before: np.ndarray
    margin: np.ndarray
    hits: np.ndarray

    @property
    def positions(self) -> np.ndarray:
        """The samples of ``x`` that pass."""
        return self.b0 + self.k[self.hits]


def _scan(
    x: np.ndarray,
    a: np.ndarray,
    end: int,
    c0: int,
    c1: int,
    s: Settings,
    innovation: float,
    alarm: float | None = None,
) -> Scan | None:
    """:func:`_rise_after`'s test at the hop grid's samples in ``[c0, c1)`` (from ``end``, the
    fitted stretch's end) of the error of the prediction-error filter ``a``, at the false-alarm
    probability ``alarm`` per sample (default :data:`FALSE_ALARM_SPAN`'s); None where no sample
    is tested."""
    from scipy.signal import lfilter

    fs, hop = s.samplerate, s.hop
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    held = max(span, int(round(STANDS_OUT_BEFORE * fs)))
    p = a.size - 1
    b0 = max(end, c0 - held)  # the error from b0: never over the fitted stretch
    b1 = min(x.size, c1 + span)
    e = lfilter(a, [1.0], x[b0 - p : b1])[p:]  # e[i]: the error at sample b0 + i
    first = c0 - b0
    count = (min(c1, b1 - span) - c0 + hop - 1) // hop
    if count <= 0:
        return None
    k = first + np.arange(count) * hop  # the positions in e
    energies = frame_energies(e[first:], hop, span)[:count]
    cum = np.r_[0.0, np.cumsum(e * e)]
    lo = np.maximum(0, k - held)
    length = k - lo
    ok = length >= span
    mean_before = np.where(ok, (cum[k] - cum[lo]) / np.maximum(length, 1), np.inf)
    alarm = hop / fs / FALSE_ALARM_SPAN if alarm is None else alarm
    c = correlation_spread(e[first:], span)
    d1 = max(1, int(span / c))  # whole degrees of freedom, rounded down: a quantile no lower
    need = np.array([_need(d1, max(1, int(m / c)), alarm) if m >= span else np.inf for m in length])
    margin = energies / span / np.maximum(mean_before, 1e-300) / need
    floor = innovation * 10.0 ** (-s.dynamic_range_db / 20.0)
    peak = _span_peaks(np.abs(e[first:]), hop, span, count)
    hits = np.nonzero(ok & (margin >= 1.0) & (peak > floor))[0]
    return Scan(e, b0, k, mean_before, margin, hits)


def correlation_spread(z: np.ndarray, lags: int) -> float:
    """``sum_k rho_k^2`` over the lags ``|k| < lags`` of ``z``'s autocorrelation ``rho`` (1 for
    white noise): the variance of a mean square of ``n`` samples of a Gaussian process is that of
    ``n / spread`` white ones (Bartlett 1946, J. R. Stat. Soc. Suppl. 8, 27), so the residual's
    leftover ringing, coloured, counts as fewer independent samples."""
    n = z.size
    if n < 2 * lags or not np.any(z):
        return 1.0
    m = 1 << int(math.ceil(math.log2(n + lags)))
    f = np.fft.rfft(z, m)
    r = np.fft.irfft(f * np.conj(f), m)[:lags]
    rho = r / r[0]
    return float(max(1.0, 1.0 + 2.0 * np.dot(rho[1:], rho[1:])))


@functools.lru_cache(maxsize=1024)
def _need(span: int, before: int, alarm: float) -> float:
    """Ratio of the mean squares of ``span`` and ``before`` independent samples of Gaussian noise
    exceeded with probability ``alarm`` (Fisher's F distribution)."""
    from scipy.stats import f as fisher

    return float(fisher.isf(alarm, span, before))


def _span_peaks(mag: np.ndarray, hop: int, span: int, count: int) -> np.ndarray:
    """The largest of ``mag`` over ``[k hop, k hop + span)`` for ``k < count``."""
    from scipy.ndimage import maximum_filter1d

    m = maximum_filter1d(mag, size=span, origin=-(span // 2), mode="constant", cval=0.0)
    return m[np.arange(count) * hop]
