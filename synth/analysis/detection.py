"""Steps 2-4 of the tick detection (docs/analysis.md, Method): the detection function of the
whitened signal, its adaptive threshold, the candidates, and each burst's sub-sample onset; and
the delay of one whitened response behind another (the timing of step 7).

All positions and lengths are in samples; energies are sums of squares per frame of the
whitened signal.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth.analysis.clipping import runs
from synth.analysis.series import ANCHOR_DB, bounce_series
from synth.analysis.settings import AnalysisError, Settings
from synth.compilation import compiled

#: Level of the onset walk relative to the whitened background, standard deviations (a
#: Gaussian sample exceeds 4 sigma with probability 6e-5).
ONSET_NOISE_SIGMAS = 4.0
#: Samples alternating in sign and growing towards a burst, at least, that are taken for
#: an anti-aliasing filter's pre-ringing rather than the start of the contact (ending on
#: a sample at least a quarter of the burst's largest).
PRE_RINGING_RUN = 3
#: The cross-correlation that times a tick against the first tick's template is interpolated
#: on a grid this many times finer than the sample period (band-limited), then by a parabola
#: through its peak (off by well under 1e-3 sample periods at that spacing for a main lobe
#: about a sample period wide).
DELAY_UPSAMPLING = 16
#: A tick clearly stands out of a recording when its energy over its first
#: :data:`STANDS_OUT_SPAN` is this much over the mean over the :data:`STANDS_OUT_BEFORE`
#: before it (per unit time), dB: the criterion a listener's "clearly audible tick" is
#: checked by (docs/analysis.md, step 8).
STANDS_OUT_DB = 6.0
#: The tick's first stretch, s ...
STANDS_OUT_SPAN = 0.001
#: ... and the stretch before it, s.
STANDS_OUT_BEFORE = 0.003
#: Probability that white Gaussian noise alone passes the whitened test of step 8 at one
#: position: that of a sample beyond :data:`ONSET_NOISE_SIGMAS` standard deviations (6e-5),
#: the level below which the onset walk of step 4 takes a sample for noise.
STANDS_OUT_FALSE_ALARM = math.erfc(ONSET_NOISE_SIGMAS / math.sqrt(2.0))
#: The predictor of what precedes a tick of step 8 is sought from this order up (doubled
#: while a higher one describes the stretch better).
LOCAL_ORDER = 16


def frame_energies(z: np.ndarray, hop: int, w: int) -> np.ndarray:
    """Energy of ``z`` over frames ``[k hop, k hop + w)`` (the detection function): each the
    sum of its squares in the order of numpy's pairwise summation, so the same to the last
    bit as ``sum`` over each frame (the search calls this thousands of times per recording,
    on a few hundred frames each)."""
    if z.size < w:
        return np.zeros(0)
    return _frame_energies(np.ascontiguousarray(z, dtype=np.float64), int(hop), int(w))


@compiled(nogil=True)
def _frame_energies(z, hop, w):  # pragma: no cover - compiled
    n = (z.size - w) // hop + 1
    out = np.empty(n)
    for k in range(n):
        out[k] = _pairwise_squares(z, k * hop, w)
    return out


@compiled(nogil=True)
def _pairwise_squares(z, start, n):  # pragma: no cover - compiled
    """``sum(z[start:start+n]**2)`` as numpy's pairwise summation adds it: a plain sum under
    8 terms, eight running sums combined pairwise up to 128, halves (multiples of 8) beyond."""
    if n < 8:
        res = 0.0
        for i in range(start, start + n):
            res += z[i] ** 2
        return res
    if n <= 128:
        s0, s1, s2, s3 = z[start] ** 2, z[start + 1] ** 2, z[start + 2] ** 2, z[start + 3] ** 2
        s4, s5, s6, s7 = z[start + 4] ** 2, z[start + 5] ** 2, z[start + 6] ** 2, z[start + 7] ** 2
        i = start + 8
        top = start + n - n % 8
        while i < top:
            s0, s1, s2, s3 = (
                s0 + z[i] ** 2,
                s1 + z[i + 1] ** 2,
                s2 + z[i + 2] ** 2,
                s3 + z[i + 3] ** 2,
            )
            s4, s5, s6, s7 = (
                s4 + z[i + 4] ** 2,
                s5 + z[i + 5] ** 2,
                s6 + z[i + 6] ** 2,
                s7 + z[i + 7] ** 2,
            )
            i += 8
        res = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))
        while i < start + n:
            res += z[i] ** 2
            i += 1
        return res
    half = n // 2
    half -= half % 8
    return _pairwise_squares(z, start, half) + _pairwise_squares(z, start + half, n - half)


@dataclass(frozen=True)
class Detection:
    """The candidates of steps 2-3: their frames (``peaks``), the detection function ``d``,
    each frame's ``threshold`` and local ``background`` (energies per frame)."""

    peaks: np.ndarray
    d: np.ndarray
    threshold: np.ndarray
    background: np.ndarray


def detect(r: np.ndarray, settings: Settings, background: float) -> Detection:
    """Candidate ticks in the whitened signal ``r`` (steps 2 and 3): the local maxima of the
    detection function over its threshold, one per cluster closer than ``min_separation``,
    none more than ``max_drop_db`` under the previous one. ``background``: the running
    median's length, s."""
    from scipy.ndimage import median_filter

    hop = settings.hop
    d = frame_energies(r, hop, settings.frame)
    size = max(3, int(round(background * settings.samplerate / hop)) | 1)
    med = median_filter(d, size=size, mode="nearest")
    threshold = np.maximum.reduce(
        [
            _rises_from(d, med, size, settings) * 10.0 ** (settings.threshold_db / 10.0),
            _fading_memory(d, hop, settings) * 10.0 ** (settings.rise_db / 10.0),
            np.full_like(d, d.max() * 10.0 ** (-settings.dynamic_range_db / 10.0)),
        ]
    )
    return Detection(_candidates(d, threshold, settings), d, threshold, med)


def _rises_from(d: np.ndarray, med: np.ndarray, size: int, settings: Settings) -> np.ndarray:
    """The background each frame of ``d`` must rise from: the running median ``med`` (centred,
    ``size`` frames), except up to the first burst's peak, which rises from the lead-in before
    it (the median of up to ``size`` frames under the dynamic range's floor), where lower: a
    centred median there holds the first tick's own ringing, which the whitening of a lightly
    damped plate leaves nearly as loud as its burst. A lead-in shorter than
    :data:`STANDS_OUT_BEFORE` (the stretch step 8 weighs a tick against) is no background:
    the noise of a recording cut just before a tick crosses the floor within it."""
    k0 = int(np.argmax(d >= d.max() * 10.0 ** (-settings.dynamic_range_db / 10.0)))
    if k0 * settings.hop < STANDS_OUT_BEFORE * settings.samplerate:
        return med
    k1 = k0 + 1 + int(np.argmax(np.diff(d[k0:]) < 0))  # through the first burst's peak
    out = med.copy()
    out[:k1] = np.minimum(med[:k1], np.median(d[max(0, k0 - size) : k0]))
    return out


def _fading_memory(d: np.ndarray, hop: int, settings: Settings) -> np.ndarray:
    """Memory of the frames ``j <= k - 2`` (frame ``k - 1`` may hold the start of the same
    burst), fading by ``release`` dB per ms: ``max_j d_j 10^(-a (k - j))``, computed in
    log10 units as ``max_j (log d_j + a j) - a k``."""
    a = settings.release * 1000.0 * hop / settings.samplerate / 10.0
    aj = np.arange(d.size) * a
    with np.errstate(divide="ignore"):
        memory = np.maximum.accumulate(np.log10(d) + aj)
    past = np.zeros_like(d)
    past[2:] = 10.0 ** (memory[:-2] - aj[2:])
    return past


def _candidates(d: np.ndarray, threshold: np.ndarray, settings: Settings) -> np.ndarray:
    """Frames of the local maxima of ``d`` at or over ``threshold``, taken in time order: the
    first of a cluster closer than ``min_separation``, and none more than ``max_drop_db``
    under the previous one (its burst may straddle two frames)."""
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
    """How step 4 walks back from a burst's largest ``|r|`` to its onset.

    Attributes
    ----------
    fraction : float
        The walk's level over the burst's largest ``|r|`` (dimensionless).
    gap : int
        The longest run under the level the walk bridges (samples).
    noise : float
        The noise's level in ``|r|``: the walk's level is at least this (or the peak).
    strict : bool
        An anti-aliasing filter's pre-ringing counts only where its samples stand above
        ``noise``.
    weak_gap : int or None
        For a doubtful candidate of the deflation (steps 5 and 7): the gap bridged in a weak
        burst, whose level is the noise's (:meth:`walk_gap`).
    """

    fraction: float
    gap: int
    noise: float
    strict: bool = False
    weak_gap: int | None = None

    def walk_gap(self, peak: float) -> int:
        """The longest gap (samples) bridged in a burst whose largest ``|r|`` is ``peak``:
        ``gap`` (the zero crossings of a burst), or ``weak_gap`` where the noise sets the
        walk's level (``fraction`` of the peak under ``noise``). Whitened, a contact of many
        sample periods is the transients at its two ends (above its force spectrum's first
        zero the whitening lifts the high frequencies those carry); in a weak burst its body
        between them lies under the noise's level, and its start is the earlier transient, up
        to a contact length before the later, stronger one."""
        if self.weak_gap is not None and min(self.noise, peak) > self.fraction * peak:
            return max(self.gap, self.weak_gap)
        return self.gap


def refine_onset(r: np.ndarray, lo: int, hi: int, walk: OnsetWalk) -> float:
    """Sub-sample onset (samples) of the burst of the whitened signal ``r`` peaking in
    ``[lo, hi)`` (step 4): the crossing of the level (``walk.fraction`` of the burst's largest
    ``|r|``, at least ``walk.noise``) before the earliest sample reached by walking back over
    samples at or above it, bridging :meth:`OnsetWalk.walk_gap`; or, after a linear-phase
    anti-aliasing filter's pre-ringing, the centre of the burst's sampled sinc. With
    ``walk.strict`` the pre-ringing's samples must stand above the noise. A weak burst (a
    doubtful candidate given ``walk.weak_gap``) shows only the transients at a slow contact's
    two ends under the noise's level (:meth:`OnsetWalk.walk_gap`)."""
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
    """:func:`refine_onset` over the stretch ``r`` (``lo``, ``hi`` into it) that starts at
    sample ``offset`` of the whole, as a sample of the stretch and the fraction of a sample
    past it (added to the sample of the whole: the onset to the last bit); None when the
    walk back comes within the gap it bridges (or :data:`PRE_RINGING_RUN`) samples of the
    stretch's start and ``offset`` is not 0 (the walk, or the pre-ringing's run, may go on
    before it)."""
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
    """The earliest sample at or above ``level`` reached from ``k`` through gaps of at most
    ``gap`` samples."""
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
    """The centre of a burst recorded through a linear-phase anti-aliasing filter, or None.

    A run of at least :data:`PRE_RINGING_RUN` samples alternating in sign and growing
    towards the burst (each at least ``floor``) is the filter's pre-ringing: the burst is a
    sampled sinc ``A sinc(t - m - f)``, whose two central samples give
    ``r[m+1] / r[m] = f / (1 - f)``: ``(m, f)``.
    """
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
    """Sub-sample delay (samples, within ``[lo, hi]``) of ``y`` behind ``template``: the
    peak of their cross-correlation with the phase transform (each frequency's cross
    spectrum ``Y T*`` taken at unit magnitude; Knapp and Carter 1976, IEEE Trans. ASSP
    24, 320), interpolated band-limited. None when the correlation has no peak inside
    ``(lo, hi)``: its largest value there at either end, rising beyond it, says the delay lies
    outside the lags allowed (a weak, slow contact whose pulse spectrum changes sign within
    the band against the template's), not where.

    For ``y = h * template`` it is the delay ``d`` whose linear phase best fits the phase of
    the filter ``h`` over the band, ``max sum_f cos(arg H(f) - 2 pi f d)``: every frequency
    counts once, so the band where the whitened responses carry most of their energy (near
    the Nyquist frequency) sets no lobes two samples apart, and a ratio of pulse shapes of
    zero phase that keeps its sign over the band moves the delay by its centre alone.
    """
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
    """Samples ``k0 .. k1`` (any integers; periodic) of ``irfft(C, n)``, ``C`` the bins ``0 ..
    m`` of a spectrum zero-padded to ``n``: ``(C_0 + 2 Re sum_(f>=1) C_f e^(2 pi i f k / n)) /
    n`` by the chirp z-transform (Bluestein's convolution; Rabiner, Schafer and Rader 1969,
    IEEE Trans. Audio Electroacoust. 17, 86): transforms of about ``m + k1 - k0`` points,
    not ``n`` (:func:`_chirps`)."""
    from scipy import fft

    pre, kernel, post = _chirps(n, k0, C.size, k1 - k0 + 1)
    X = fft.ifft(fft.fft(C * pre, kernel.size) * kernel)[: post.size] * post
    return (2.0 * X.real - C[0].real) / n


@functools.lru_cache(maxsize=4)
def _chirps(n: int, k0: int, m: int, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chirps of :func:`_fine_correlation` for ``m`` bins, ``count`` lags from ``k0``, a
    transform of ``n``: with ``f k = (f^2 + k^2 - (k - f)^2) / 2``, the factor of each bin
    ``e^(i pi (f^2 + 2 k0 f) / n)``, the transform of the convolution kernel ``e^(-i pi j^2 /
    n)`` (``j = 1 - m .. count - 1``) and the factor of each lag ``e^(i pi k^2 / n)``; each
    phase from its exact integer numerator modulo ``2 n``. The same for every tick timed
    against one template (the resonator's search), so computed once."""
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
    """Steps 2-4 on a whitened signal: the candidate frames from the first tick on (the first
    tick's own response before the second tick left out), their onsets (samples) and
    strengths (dB), the detection function ``d``, and the sure ticks of the bounce series
    (``anchors``, onsets, and their strengths)."""

    peaks: np.ndarray
    onsets: np.ndarray
    strengths: np.ndarray
    d: np.ndarray
    anchors: np.ndarray
    anchor_strengths: np.ndarray


def first_ticks(r: np.ndarray, settings: Settings, background: float) -> FirstTicks:
    """Steps 2-4 on the whitened signal ``r`` (``background``: the running median's length,
    s).

    Raises
    ------
    AnalysisError
        No candidate clears the threshold (or none is kept by :func:`_separate`).
    """
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
        # the candidates before the second tick are the first tick's own response
        series = bounce_series(onsets, settings.e_min, sure=strength >= ANCHOR_DB)
        anchors, anchor_strength = onsets[series], strength[series]
        sure = np.r_[True, anchor_strength[1:] >= ANCHOR_DB]
        anchors, anchor_strength = anchors[sure], anchor_strength[sure]
        keep = np.r_[0, series[1] : peaks.size]
        peaks, onsets, strength = peaks[keep], onsets[keep], strength[keep]
    return FirstTicks(peaks, onsets, strength, found.d, anchors, anchor_strength)


def _candidate_onsets(r: np.ndarray, found: Detection, settings: Settings) -> np.ndarray:
    """Each candidate's onset (step 4), its level at least :data:`ONSET_NOISE_SIGMAS` standard
    deviations of the local background (an energy per frame), searched over its frame and a
    hop either side."""
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
    """Indices of the onsets kept: a candidate whose onset walks back to within ``min_sep``
    of the previous tick's is part of that tick's burst, and one at the first sample is the
    recording's cut."""
    kept = []
    for i in range(onsets.size):
        if onsets[i] == 0.0:
            continue
        if not kept or onsets[i] - onsets[kept[-1]] >= min_sep:
            kept.append(i)
    return kept


@dataclass(frozen=True)
class StandingOut:
    """Ticks of step 8: their onsets (samples) and strengths (dB: the smaller of the margins
    by which they clear the test on the recording and the test on the prediction error)."""

    onsets: np.ndarray
    strengths: np.ndarray


def standing_out(
    x: np.ndarray, r: np.ndarray, known: np.ndarray, settings: Settings
) -> StandingOut:
    """The ticks that clearly stand out of the recording ``x`` but are not among the onsets
    ``known`` (samples; none closer than ``min_separation`` to one), from its whitened signal
    ``r`` (step 8, docs/analysis.md).

    A tick stands out at its onset when the recording's energy over the next
    :data:`STANDS_OUT_SPAN` is at least :data:`STANDS_OUT_DB` over its mean over the
    :data:`STANDS_OUT_BEFORE` before (per unit time): a clearly audible tick (docs/analysis.md,
    step 8). The recording alone does not tell a tick from the beating of a few strong modes,
    which the whitening predicts; so the whitened signal must rise too, by more than white
    noise's scatter allows (the ratio of the mean squares of ``L`` and ``B`` samples of white
    Gaussian noise follows Fisher's F distribution with ``(L, B)`` degrees of freedom: its
    quantile of :data:`STANDS_OUT_FALSE_ALARM`), and lie within ``dynamic_range_db`` of its
    strongest stretch (the floor of steps 1-6, under which the whitening's remainders of the
    ringing lie). Each run of positions (frames of ``hop``) where all three hold, away from the
    ticks ``known``, is a candidate, timed in what the recording's past does not predict
    (:func:`_local_onset`), and kept when, at that onset, the recording's criterion holds and
    that prediction error rises by the F quantile (the recording's noise, whatever its level and
    spectrum, judged by its own statistics), and its whitened energy lies within ``max_drop_db``
    of the tick before it (:func:`_dropped`).
    """
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


def _dropped(r: np.ndarray, on: float, earlier: np.ndarray, span: int, settings: Settings) -> bool:
    """Whether the whitened energy of ``r`` over ``span`` samples from ``on`` lies more than
    ``max_drop_db`` under that of the latest tick ``earlier`` (onsets, samples) before it: no
    bounce (as in step 3: a tick's energy goes as its impact speed squared), but what the
    whitening leaves of the ringing."""
    if earlier.size == 0:
        return False
    prev = int(earlier.max())
    k = int(on)
    return float(np.dot(r[k : k + span], r[k : k + span])) < float(
        np.dot(r[prev : prev + span], r[prev : prev + span])
    ) * 10.0 ** (-settings.max_drop_db / 10.0)


def noise_rise(m: int, n: int) -> float:
    """The ratio of the mean squares of ``m`` and ``n`` samples of white Gaussian noise
    exceeded with probability :data:`STANDS_OUT_FALSE_ALARM` (Fisher's F distribution)."""
    from scipy.stats import f as fisher

    return float(fisher.isf(STANDS_OUT_FALSE_ALARM, m, n))


@dataclass(frozen=True)
class LocalOnset:
    """A candidate's onset (sample of the recording) and the prediction error it was found in,
    from sample ``start`` of the recording."""

    onset: float
    error: np.ndarray
    start: int


def _local_onset(
    x: np.ndarray, first: int, span: int, before: int, settings: Settings
) -> LocalOnset | None:
    """Onset of a tick whose rise shows from sample ``first`` on, in the prediction error of
    the predictor of the recording's last :data:`~synth.analysis.settings.WHITENING_SPAN`
    before the rise (its noise and ringing, fitted by
    :func:`~synth.analysis.whitening.resonator_predictor`): what the past does not predict.
    The onset is where that error's variance steps (:func:`_cusum_start`, refined by
    :func:`_change_point` within :data:`STANDS_OUT_SPAN` of it), if the error over the
    :data:`STANDS_OUT_BEFORE` before it is the past's noise, by the F test of
    :func:`standing_out` (else the tick began earlier, more slowly than it stands out: a
    ramp, whose start no step marks). None where there is too little past or no onset."""
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
    """Where the variance of ``z`` steps from ``variance`` to :data:`STANDS_OUT_DB` over it:
    the last sample at which Page's CUSUM of the log-likelihood ratio of the two (Gaussian,
    zero mean) is zero before its largest value (Page 1954, Biometrika 41, 100; Basseville and
    Nikiforov 1993, "Detection of abrupt changes", section 2.2)."""
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
    """Where the variance of ``z`` steps: the maximum-likelihood split into two stretches of
    zero-mean Gaussian noise of different variances (Hinkley 1971, Biometrika 58, 509)."""
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
    """At each position ``k hop`` (from ``blocks hop`` on; 0 before), the mean square of ``z``
    over the next ``span`` samples over that of the ``blocks hop`` samples before (sums of
    positive terms only, so exact to rounding however quiet a stretch after a loud one);
    infinite after silence."""
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
