"""Steps 2-4 (docs/analysis.md, Method): detection function, threshold, candidates and sub-sample
onsets; the delay of a whitened response (step 7); step 8. Positions in samples."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth.analysis.clipping import runs
from synth.analysis.series import ANCHOR_DB, bounce_series
from synth.analysis.settings import AnalysisError, Settings
from synth.compilation import compiled

#: Onset walk's least level, whitened background sigmas (P(>4 sigma) = 6e-5).
ONSET_NOISE_SIGMAS = 4.0
#: Least samples alternating in sign and growing towards a burst (ending at a quarter of its peak)
#: taken for an anti-aliasing filter's pre-ringing.
PRE_RINGING_RUN = 3
#: The cross-correlation timing a tick is interpolated band-limited on a grid this many times finer
#: than the sample period, then by a parabola (error well under 1e-3 sample).
DELAY_UPSAMPLING = 16
#: A tick clearly stands out (is clearly audible) when its energy over :data:`STANDS_OUT_SPAN` is
#: this much over the mean over :data:`STANDS_OUT_BEFORE` before it (per unit time), dB
#: (docs/analysis.md, step 8).
STANDS_OUT_DB = 6.0
#: The tick's first stretch, s ...
STANDS_OUT_SPAN = 0.001
#: ... and the stretch before it, s.
STANDS_OUT_BEFORE = 0.003
#: Probability that white Gaussian noise passes the whitened test of step 8 at one position: a
#: sample beyond :data:`ONSET_NOISE_SIGMAS` (6e-5), as step 4.
STANDS_OUT_FALSE_ALARM = math.erfc(ONSET_NOISE_SIGMAS / math.sqrt(2.0))
#: Least order of step 8's predictor of the stretch before a tick (doubled while better).
LOCAL_ORDER = 16


def frame_energies(z: np.ndarray, hop: int, w: int) -> np.ndarray:
    """Energy of ``z`` over frames ``[k hop, k hop + w)`` (the detection function), summed in
    numpy's pairwise order: bit-equal to ``sum`` per frame, at compiled speed."""
    if z.size < w:
        return np.zeros(0)
    return _frame_energies(np.ascontiguousarray(z, dtype=np.float64), int(hop), int(w))


@compiled(nogil=True)
def _frame_energies(z, hop, w):  # pragma: no cover - compiled
    squares = z * z
    n = (z.size - w) // hop + 1
    out = np.empty(n)
    for k in range(n):
        out[k] = pairwise_sum(squares, k * hop, w)
    return out


@compiled(nogil=True)
def pairwise_sum(a, start, n):  # pragma: no cover - compiled
    """numpy's pairwise ``sum(a[start:start+n])`` (as ``numpy.trace``) on a stack: a cached
    recursive kernel fails to load when called by another."""
    if n <= 128:  # one leaf (a frame of the detection function): no stack to set up
        return _pairwise_leaf(a, start, n)
    starts = np.empty(64, dtype=np.int64)
    sizes = np.empty(64, dtype=np.int64)
    phase = np.zeros(64, dtype=np.int64)  # 0: new, 1: waiting for its left half, 2: right
    left = np.empty(64)
    top = 0
    starts[0], sizes[0] = start, n
    result = 0.0
    while top >= 0:
        s, m = starts[top], sizes[top]
        if m > 128:
            half = m // 2
            half -= half % 8
            phase[top] = 1
            top += 1
            starts[top], sizes[top], phase[top] = s, half, 0
            continue
        result = _pairwise_leaf(a, s, m)
        top -= 1
        while top >= 0:
            if phase[top] == 1:
                left[top] = result
                phase[top] = 2
                half = sizes[top] // 2
                half -= half % 8
                starts[top + 1] = starts[top] + half
                sizes[top + 1] = sizes[top] - half
                phase[top + 1] = 0
                top += 1
                break
            result = left[top] + result
            top -= 1
    return result


@compiled(nogil=True)
def _pairwise_leaf(a, start, n):  # pragma: no cover - compiled
    """numpy's pairwise sum of ``a[start:start+n]``, ``n <= 128``."""
    if n < 8:
        res = 0.0
        for i in range(start, start + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
    r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
    i = start + 8
    top = start + n - n % 8
    while i < top:
        r0, r1, r2, r3 = r0 + a[i], r1 + a[i + 1], r2 + a[i + 2], r3 + a[i + 3]
        r4, r5, r6, r7 = r4 + a[i + 4], r5 + a[i + 5], r6 + a[i + 6], r7 + a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < start + n:
        res += a[i]
        i += 1
    return res


@dataclass(frozen=True)
class Detection:
    """Steps 2-3's candidate frames, ``d``, and each frame's threshold and the background it
    rises from (:func:`_rises_from`: the first burst's, the lead-in's; step 4's noise level)."""

    peaks: np.ndarray
    d: np.ndarray
    threshold: np.ndarray
    background: np.ndarray


def detect(r: np.ndarray, settings: Settings, background: float) -> Detection:
    """Candidate ticks of the whitened ``r`` (steps 2-3): local maxima of the detection function
    over its threshold (:func:`_candidates`); ``background``: the running median's length, s."""
    from scipy.ndimage import median_filter

    hop = settings.hop
    d = frame_energies(r, hop, settings.frame)
    size = max(3, int(round(background * settings.samplerate / hop)) | 1)
    med = median_filter(d, size=size, mode="nearest")
    rises = _rises_from(d, med, size, settings)
    threshold = np.maximum.reduce(
        [
            rises * 10.0 ** (settings.threshold_db / 10.0),
            _fading_memory(d, hop, settings) * 10.0 ** (settings.rise_db / 10.0),
            np.full_like(d, d.max() * 10.0 ** (-settings.dynamic_range_db / 10.0)),
        ]
    )
    return Detection(_candidates(d, threshold, settings), d, threshold, rises)


def _rises_from(d: np.ndarray, med: np.ndarray, size: int, settings: Settings) -> np.ndarray:
    """The background each frame of ``d`` rises from: ``med``, but the lead-in's median where lower
    up to the first peak (a centred median holds the first tick's ringing)."""
    k0 = int(np.argmax(d >= d.max() * 10.0 ** (-settings.dynamic_range_db / 10.0)))
    if k0 * settings.hop < STANDS_OUT_BEFORE * settings.samplerate:
        return med
    k1 = k0 + 1 + int(np.argmax(np.diff(d[k0:]) < 0))  # through the first burst's peak
    out = med.copy()
    out[:k1] = np.minimum(med[:k1], np.median(d[max(0, k0 - size) : k0]))
    return out


def _fading_memory(d: np.ndarray, hop: int, settings: Settings) -> np.ndarray:
    """``max_(j <= k-2) d_j 10^(-a (k - j))``: memory fading by ``release`` dB/ms."""
    a = settings.release * 1000.0 * hop / settings.samplerate / 10.0
    aj = np.arange(d.size) * a
    with np.errstate(divide="ignore"):
        memory = np.maximum.accumulate(np.log10(d) + aj)
    past = np.zeros_like(d)
    past[2:] = 10.0 ** (memory[:-2] - aj[2:])
    return past


def _candidates(d: np.ndarray, threshold: np.ndarray, settings: Settings) -> np.ndarray:
    """Local maxima of ``d`` over ``threshold``, one per ``min_separation``, no big drop."""
    from scipy.signal import find_peaks

    q = np.where(d >= threshold, d, 0.0)
    candidates = find_peaks(np.concatenate(([0.0], q, [0.0])))[0] - 1
    keep, energies = [], []
    drop = 10.0 ** (-settings.max_drop_db / 10.0)
    for k in candidates:
        if keep and (k - keep[-1]) * settings.hop < settings.min_separation:
            continue
        energy = d[k : k + 2].max()
        if keep and energy < energies[-1] * drop:
            continue
        keep.append(k)
        energies.append(energy)
    return np.array(keep, dtype=int)


@dataclass(frozen=True)
class OnsetWalk:
    """Step 4's walk back: level ``fraction`` of the peak (at least ``noise``), ``gap`` bridged
    (samples), ``strict`` pre-ringing, and ``weak_gap`` (samples) in a weak burst."""

    fraction: float
    gap: int
    noise: float
    strict: bool = False
    weak_gap: int | None = None

    def walk_gap(self, peak: float) -> int:
        """The gap (samples) bridged in a burst of peak ``peak``: ``weak_gap`` where the noise sets
        the level (a slow contact shows only its two end transients), else ``gap``."""
        if self.weak_gap is not None and min(self.noise, peak) > self.fraction * peak:
            return max(self.gap, self.weak_gap)
        return self.gap


def refine_onset(r: np.ndarray, lo: int, hi: int, walk: OnsetWalk) -> float:
    """Sub-sample onset (samples) of the burst of ``r`` peaking in ``[lo, hi)`` (step 4): the level
    crossing walking back (:meth:`OnsetWalk.walk_gap`), or a sinc's centre."""
    # the walk looks back from the burst only: |r| over a stretch before it, longer only
    # where the walk comes near the stretch's start (the same onset as over the whole of r)
    span = max(64, 8 * max(walk.gap, walk.weak_gap or 0))
    while True:
        a = max(0, lo - span)
        onset = _refined(r[a : min(r.size, hi + 1)], lo - a, hi - a, walk, a)
        if onset is not None:
            sample, fraction_past = onset
            return (a + sample) + fraction_past
        span *= 4


def _refined(
    r: np.ndarray, lo: int, hi: int, walk: OnsetWalk, offset: int
) -> tuple[int, float] | None:
    """:func:`refine_onset` over a stretch starting at sample ``offset``: (sample, fraction past
    it); None when the walk nears a stretch start that is not the signal's."""
    mag = np.abs(r)
    k = lo + int(np.argmax(mag[lo:hi]))
    level = max(walk.fraction * mag[k], min(walk.noise, mag[k]))
    gap = walk.walk_gap(float(mag[k]))
    i = _walk_back(mag, k, level, gap)
    if offset > 0 and i <= max(gap, PRE_RINGING_RUN):
        return None
    centre = _sinc_centre(r, mag, i, k, min(walk.noise, mag[k]) if walk.strict else 0.0)
    if centre is not None:
        return centre
    if i == 0:
        return 0, 0.0
    return i - 1, (level - mag[i - 1]) / (mag[i] - mag[i - 1])


def _walk_back(mag: np.ndarray, k: int, level: float, gap: int) -> int:
    """Earliest sample at or above ``level`` from ``k`` through gaps of at most ``gap``."""
    i = k
    while True:
        j0 = max(0, i - gap)
        above = np.nonzero(mag[j0:i] >= level)[0]
        if above.size == 0:
            return i
        i = j0 + int(above[0])


def _sinc_centre(
    r: np.ndarray, mag: np.ndarray, i: int, k: int, floor: float
) -> tuple[int, float] | None:
    """Centre ``(m, f)`` of a burst after :data:`PRE_RINGING_RUN` samples of anti-aliasing
    pre-ringing, ``r[m+1] / r[m] = f / (1 - f)``; else None."""
    m = i
    while m < k and r[m] * r[m + 1] < 0.0 and mag[m] < mag[m + 1]:
        m += 1
    j = m
    while j > 0 and r[j - 1] * r[j] < 0.0 and floor <= mag[j - 1] < mag[j]:
        j -= 1
    if m - j >= PRE_RINGING_RUN and mag[m] >= 0.25 * mag[k]:
        rho = mag[m + 1] / mag[m] if m + 1 < r.size and r[m] * r[m + 1] > 0.0 else 0.0
        return m, rho / (1.0 + rho)
    return None


def delay(y: np.ndarray, template: np.ndarray, lo: float, hi: float) -> float | None:
    """Sub-sample delay (samples, within ``[lo, hi]``) of ``y`` behind ``template``: the peak of
    their phase-transform cross-correlation (Knapp and Carter 1976, IEEE Trans. ASSP 24, 320),
    interpolated band-limited; None when the peak lies at an end of the lags allowed."""
    n = 1 << int(math.ceil(math.log2(y.size + template.size)))
    C = np.fft.rfft(y, n) * np.conj(np.fft.rfft(template, n))
    mag = np.abs(C)
    # unit magnitude, but for bins 240 dB under the strongest (rounding: they have no phase)
    C = np.where(mag > 1e-12 * mag.max(), C / np.maximum(mag, 1e-300), 0.0)
    # band-limited interpolation of the (circular) correlation: its spectrum zero-padded
    # DELAY_UPSAMPLING times (the Nyquist bin split between the two halves), evaluated on
    # the lags allowed and one on either side, then a parabola through the finest grid's peak
    up = DELAY_UPSAMPLING
    if n % 2 == 0:
        C[-1] *= 0.5
    i0 = int(math.ceil(lo * up))
    i1 = int(math.floor(hi * up))
    c = _fine_correlation(C, n * up, i0 - 1, i1 + 1)
    k = i0 + int(np.argmax(c[1:-1]))
    if k in (i0, i1) and i1 > i0:
        return None
    a, b, d = c[k - i0], c[k - i0 + 1], c[k - i0 + 2]
    den = a - 2.0 * b + d
    frac = 0.5 * (a - d) / den if den < 0.0 else 0.0
    return (k + min(0.5, max(-0.5, frac))) / up


def _fine_correlation(C: np.ndarray, n: int, k0: int, k1: int) -> np.ndarray:
    """Samples ``k0 .. k1`` of ``irfft(C, n)`` by the chirp z-transform (Rabiner, Schafer and Rader
    1969, IEEE Trans. Audio Electroacoust. 17, 86): transforms of ``m + k1 - k0`` points, not
    ``n``."""
    from scipy import fft

    pre, kernel, post = _chirps(n, k0, C.size, k1 - k0 + 1)
    X = fft.ifft(fft.fft(C * pre, kernel.size) * kernel)[: post.size] * post
    return (2.0 * X.real - C[0].real) / n


@functools.lru_cache(maxsize=4)
def _chirps(n: int, k0: int, m: int, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chirps of :func:`_fine_correlation` (exact integer phases), cached per template."""
    from scipy import fft

    size = fft.next_fast_len(m + count - 1)
    f = np.arange(m, dtype=np.int64)
    k = np.arange(count, dtype=np.int64)
    pre = np.exp(1j * math.pi / n * ((f * f + 2 * k0 * f) % (2 * n)))
    v = np.zeros(size, dtype=complex)
    v[:count] = np.exp(-1j * math.pi / n * ((k * k) % (2 * n)))
    v[size - m + 1 :] = np.exp(-1j * math.pi / n * ((f[:0:-1] ** 2) % (2 * n)))
    post = np.exp(1j * math.pi / n * ((k * k) % (2 * n)))
    return pre, fft.fft(v), post


@dataclass(frozen=True)
class FirstTicks:
    """Steps 2-4 on a whitened signal: candidate frames, onsets (samples), strengths (dB), the
    detection function ``d``, and the bounce series' sure ticks and their strengths."""

    peaks: np.ndarray
    onsets: np.ndarray
    strengths: np.ndarray
    d: np.ndarray
    anchors: np.ndarray
    anchor_strengths: np.ndarray


def first_ticks(
    r: np.ndarray, settings: Settings, background: float, x: np.ndarray | None = None
) -> FirstTicks:
    """Steps 2-4 on ``r`` (``background``: the running median's length, s), the whitening of
    the recording ``x`` (same samples; None: ``r`` alone); raises AnalysisError when no
    candidate is kept."""
    found = detect(r, settings, background)
    onsets = _candidate_onsets(r, found, settings)
    kept = _separate(onsets, settings.min_separation)
    if not kept:
        raise AnalysisError(
            "no tick detected: nothing rises above the background (is this a recording of impacts?)"
        )
    peaks, onsets = found.peaks[kept], onsets[kept]
    strength = 10.0 * np.log10(found.d[peaks] / found.threshold[peaks])
    anchors, anchor_strength = onsets[:1], strength[:1]
    if peaks.size > 1:
        # the candidates before the second tick are the first tick's own response; a sure
        # one, or one that clearly stands out of the recording, is not (its ringing decays)
        sure = strength >= ANCHOR_DB
        if x is not None:
            sure |= stand_out(x, r, onsets, settings, onsets[0])
        series = bounce_series(onsets, settings.e_min, sure=sure)
        anchors, anchor_strength = onsets[series], strength[series]
        sure = np.r_[True, anchor_strength[1:] >= ANCHOR_DB]
        anchors, anchor_strength = anchors[sure], anchor_strength[sure]
        keep = np.r_[0, series[1] : peaks.size]
        peaks, onsets, strength = peaks[keep], onsets[keep], strength[keep]
    return FirstTicks(peaks, onsets, strength, found.d, anchors, anchor_strength)


def _candidate_onsets(r: np.ndarray, found: Detection, settings: Settings) -> np.ndarray:
    """Each candidate's onset (step 4), level at least :data:`ONSET_NOISE_SIGMAS`."""
    hop, w = settings.hop, settings.frame
    sigma = ONSET_NOISE_SIGMAS * np.sqrt(found.background[found.peaks] / w)
    return np.array(
        [
            refine_onset(
                r,
                max(0, (k - 1) * hop),
                min(r.size, k * hop + w + hop),
                OnsetWalk(settings.onset_fraction, settings.onset_gap, s),
            )
            for k, s in zip(found.peaks, sigma)
        ]
    )


def _separate(onsets: np.ndarray, min_sep: int) -> list[int]:
    """Indices of onsets kept: not within ``min_sep`` of the last kept nor at sample 0."""
    kept = []
    for i in range(onsets.size):
        if onsets[i] == 0.0:
            continue
        if not kept or onsets[i] - onsets[kept[-1]] >= min_sep:
            kept.append(i)
    return kept


@dataclass(frozen=True)
class StandingOut:
    """Step 8's ticks: onsets (samples), strengths (dB, the smaller of its two tests)."""

    onsets: np.ndarray
    strengths: np.ndarray


def standing_out(
    x: np.ndarray, r: np.ndarray, known: np.ndarray, settings: Settings
) -> StandingOut:
    """Step 8 (docs/analysis.md): ticks of ``x`` not among ``known`` (samples) that clearly stand
    out (:data:`STANDS_OUT_DB`) and whose whitened ``r`` rises beyond noise's F quantile within
    the dynamic range; each timed by :func:`_local_onset`, kept when both tests hold there and it
    is not :func:`_dropped`."""
    hop, fs = settings.hop, settings.samplerate
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    blocks = max(1, int(round(STANDS_OUT_BEFORE * fs / hop)))
    before = blocks * hop
    need_x = 10.0 ** (STANDS_OUT_DB / 10.0)
    need_e = noise_rise(span, before)
    energy = frame_energies(r, hop, span)
    if energy.size == 0:
        return StandingOut(np.zeros(0), np.zeros(0))
    passing = (
        (_rise(x, hop, span, blocks) >= need_x)
        & (_rise(r, hop, span, blocks) >= need_e)
        & (energy >= energy.max() * 10.0 ** (-settings.dynamic_range_db / 10.0))
    )
    onsets, strengths = [], []
    known = np.sort(np.asarray(known, dtype=float))
    for lo, hi in runs(passing):
        if np.any(np.abs(known - lo * hop) < settings.min_separation + span):
            continue
        peak = lo + int(np.argmax(energy[lo:hi]))
        if _dropped(r, peak * hop, np.r_[known[known < lo * hop], onsets], span, settings):
            continue  # the run's strongest millisecond already too weak (below)
        found = _local_onset(x, lo * hop, span, before, settings)
        if found is None:
            continue
        on = found.onset
        rx = rise_at(x, int(on), span, before)
        re = rise_at(found.error, int(on) - found.start, span, before)
        near = np.abs(known - on) < settings.min_separation
        if rx < need_x or re < need_e or near.any():
            continue
        if onsets and on - onsets[-1] < settings.min_separation:
            continue
        if _dropped(r, on, np.r_[known[known < on], onsets], span, settings):
            continue
        onsets.append(on)
        strengths.append(10.0 * math.log10(min(rx / need_x, re / need_e)))
    return StandingOut(np.array(onsets), np.array(strengths))


def stand_out(
    x: np.ndarray, r: np.ndarray, onsets: np.ndarray, settings: Settings, first: float
) -> np.ndarray:
    """Whether each onset (samples) of the recording ``x`` clearly stands out of the first
    tick's ringing (from ``first``, samples) by step 8's two tests: ``x``'s mean square over
    :data:`STANDS_OUT_SPAN` :data:`STANDS_OUT_DB` over that of :data:`STANDS_OUT_BEFORE`
    before it, and its whitening ``r``'s beyond white noise's F quantile (:func:`noise_rise`).
    One whose stretch before reaches over ``first`` is not judged (False): it would rise over
    the lead-in, not over the ringing."""
    fs = settings.samplerate
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    before = max(1, int(round(STANDS_OUT_BEFORE * fs / settings.hop))) * settings.hop
    need_x, need_e = 10.0 ** (STANDS_OUT_DB / 10.0), noise_rise(span, before)
    return np.array(
        [
            int(on) - before > first
            and rise_at(x, int(on), span, before) >= need_x
            and rise_at(r, int(on), span, before) >= need_e
            for on in onsets
        ],
        dtype=bool,
    )


def _dropped(r: np.ndarray, on: float, earlier: np.ndarray, span: int, settings: Settings) -> bool:
    """Whether the energy from ``on`` is ``max_drop_db`` under the last earlier tick's."""
    if earlier.size == 0:
        return False
    prev = int(earlier.max())
    k = int(on)
    return float(np.dot(r[k : k + span], r[k : k + span])) < float(
        np.dot(r[prev : prev + span], r[prev : prev + span])
    ) * 10.0 ** (-settings.max_drop_db / 10.0)


def noise_rise(m: int, n: int) -> float:
    """Ratio of the mean squares of ``m`` and ``n`` samples of white Gaussian noise exceeded with
    probability :data:`STANDS_OUT_FALSE_ALARM` (Fisher's F distribution)."""
    from scipy.stats import f as fisher

    return float(fisher.isf(STANDS_OUT_FALSE_ALARM, m, n))


@dataclass(frozen=True)
class LocalOnset:
    """An onset (sample), the prediction error it was found in, and its start sample."""

    onset: float
    error: np.ndarray
    start: int


def _local_onset(
    x: np.ndarray, first: int, span: int, before: int, settings: Settings
) -> LocalOnset | None:
    """Onset of a tick rising from ``first``: where the error of a predictor of the past steps in
    variance (:func:`_cusum_start`, :func:`_change_point`), if the error before it is the past's
    noise by the F test; else None."""
    from scipy.signal import lfilter

    from synth.analysis.whitening import resonator_predictor

    end = first - span
    start = max(0, end - settings.whitening_order)
    if end - start < before:
        return None
    a = resonator_predictor(x[start:end], settings.samplerate, LOCAL_ORDER)
    if a is None:
        return None
    stop = min(x.size, first + 2 * span)
    e = lfilter(a, [1.0], x[start:stop])  # sample i of e is sample start + i of x
    fitted = e[a.size : end - start]
    variance = float(np.dot(fitted, fitted)) / max(1, fitted.size)
    lo = max(a.size, first - before - start)
    ref = e[lo : max(lo + 1, end - start)]
    ref_variance = float(np.dot(ref, ref)) / ref.size
    if not (variance > 0.0 and ref_variance > 0.0):
        return None
    rise = lo + _cusum_start(e[lo : first + span - start], ref_variance)
    a0 = max(lo, rise - span)
    if min(e.size, rise + span) - a0 < 4:
        return None
    on = a0 + _change_point(e[a0 : rise + span])
    past = e[max(lo, on - before) : on]
    if float(np.dot(past, past)) / max(1, past.size) > variance * noise_rise(
        past.size, fitted.size
    ):
        return None
    return LocalOnset(float(start + on), e, start)


def _cusum_start(z: np.ndarray, variance: float) -> int:
    """Where the variance of ``z`` steps up by :data:`STANDS_OUT_DB`: the last zero of Page's CUSUM
    before its peak (Page 1954, Biometrika 41, 100)."""
    g = 10.0 ** (STANDS_OUT_DB / 10.0)
    step = 0.5 * z * z / variance * (1.0 - 1.0 / g) - 0.5 * math.log(g)
    c = np.empty(z.size)
    acc = 0.0
    for i, v in enumerate(step):
        acc = max(0.0, acc + v)
        c[i] = acc
    top = int(np.argmax(c))
    zeros = np.nonzero(c[: top + 1] == 0.0)[0]
    return int(zeros[-1]) + 1 if zeros.size else 0


def _change_point(z: np.ndarray) -> int:
    """Maximum-likelihood split of ``z`` into two zero-mean Gaussian stretches (Hinkley 1971,
    Biometrika 58, 509)."""
    n = z.size
    c = np.cumsum(z * z)
    tau = np.arange(2, n - 1)
    v1 = c[tau - 1] / tau
    v2 = (c[-1] - c[tau - 1]) / (n - tau)
    ll = -tau * np.log(np.maximum(v1, 1e-300)) - (n - tau) * np.log(np.maximum(v2, 1e-300))
    return int(tau[np.argmax(ll)])


def rise_at(z: np.ndarray, k: int, span: int, before: int) -> float:
    """The mean square of ``z`` over ``[k, k + span)`` over that of ``[k - before, k)``."""
    a = z[k : k + span]
    b = z[max(0, k - before) : k]
    mb = float(np.dot(b, b)) / max(1, b.size)
    ma = float(np.dot(a, a)) / max(1, a.size)
    return math.inf if mb == 0.0 and ma > 0.0 else (ma / mb if mb > 0.0 else 0.0)


def _rise(z: np.ndarray, hop: int, span: int, blocks: int) -> np.ndarray:
    """Mean square over ``span`` after each ``k hop`` over the ``blocks hop`` before."""
    e_hop = frame_energies(z, hop, hop)
    after = frame_energies(z, hop, span)
    n = min(after.size, e_hop.size + 1)
    out = np.zeros(after.size)
    if n <= blocks:
        return out
    window = np.lib.stride_tricks.sliding_window_view(e_hop, blocks).sum(axis=1)
    k = np.arange(blocks, n)
    mean_before = window[k - blocks] / (blocks * hop)
    mean_after = after[k] / span
    with np.errstate(divide="ignore", invalid="ignore"):
        out[k] = np.where(mean_after > 0.0, mean_after / mean_before, 0.0)
    return out
