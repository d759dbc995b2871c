"""Steps 2-4 of the tick detection (docs/analysis.md, Method): the detection function of the
whitened signal, its adaptive threshold, the candidates, and each burst's sub-sample onset; and
the delay of one whitened response behind another (the timing of step 7).

All positions and lengths are in samples; energies are sums of squares per frame of the
whitened signal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from synth.analysis.series import ANCHOR_DB, bounce_series
from synth.analysis.settings import AnalysisError, Settings

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


def frame_energies(z: np.ndarray, hop: int, w: int) -> np.ndarray:
    """Energy of ``z`` over frames ``[k hop, k hop + w)`` (the detection function): each the
    sum of its squares in the order of numpy's pairwise summation, so the same to the last
    bit as ``sum`` over each frame (the search calls this thousands of times per recording,
    on a few hundred frames each)."""
    if z.size < w:
        return np.zeros(0)
    return _frame_energies(np.ascontiguousarray(z, dtype=np.float64), int(hop), int(w))


@numba.njit(cache=True, nogil=True)
def _frame_energies(z, hop, w):  # pragma: no cover - compiled
    n = (z.size - w) // hop + 1
    out = np.empty(n)
    for k in range(n):
        out[k] = _pairwise_squares(z, k * hop, w)
    return out


@numba.njit(cache=True, nogil=True)
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
            med * 10.0 ** (settings.threshold_db / 10.0),
            _fading_memory(d, hop, settings) * 10.0 ** (settings.rise_db / 10.0),
            np.full_like(d, d.max() * 10.0 ** (-settings.dynamic_range_db / 10.0)),
        ]
    )
    return Detection(_candidates(d, threshold, settings), d, threshold, med)


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


def refine_onset(
    r: np.ndarray, lo: int, hi: int, fraction: float, gap: int, noise: float, strict: bool = False
) -> float:
    """Sub-sample onset (samples) of the burst of the whitened signal ``r`` peaking in
    ``[lo, hi)`` (step 4): the crossing of the level (``fraction`` of the burst's largest
    ``|r|``, at least ``noise``) before the earliest sample reached by walking back over
    samples at or above it, bridging ``gap``; or, after a linear-phase anti-aliasing
    filter's pre-ringing, the centre of the burst's sampled sinc. With ``strict`` the
    pre-ringing's samples must stand above ``noise``."""
    # the walk looks back from the burst only: |r| over a stretch before it, longer only
    # where the walk comes near the stretch's start (the same onset as over the whole of r)
    span = max(64, 8 * gap)
    while True:
        a = max(0, lo - span)
        onset = _refined(
            r[a : min(r.size, hi + 1)], lo - a, hi - a, fraction, gap, noise, strict, a
        )
        if onset is not None:
            sample, fraction_past = onset
            return (a + sample) + fraction_past
        span *= 4


def _refined(
    r: np.ndarray,
    lo: int,
    hi: int,
    fraction: float,
    gap: int,
    noise: float,
    strict: bool,
    offset: int,
) -> tuple[int, float] | None:
    """:func:`refine_onset` over the stretch ``r`` (``lo``, ``hi`` into it) that starts at
    sample ``offset`` of the whole, as a sample of the stretch and the fraction of a sample
    past it (added to the sample of the whole: the onset to the last bit); None when the
    walk back comes within ``gap`` (or :data:`PRE_RINGING_RUN`) samples of the stretch's
    start and ``offset`` is not 0 (the walk, or the pre-ringing's run, may go on before
    it)."""
    mag = np.abs(r)
    k = lo + int(np.argmax(mag[lo:hi]))
    level = max(fraction * mag[k], min(noise, mag[k]))
    i = _walk_back(mag, k, level, gap)
    if offset > 0 and i <= max(gap, PRE_RINGING_RUN):
        return None
    centre = _sinc_centre(r, mag, i, k, min(noise, mag[k]) if strict else 0.0)
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
    # DELAY_UPSAMPLING times (the Nyquist bin split between the two halves), then a
    # parabola through the finest grid's peak
    up = DELAY_UPSAMPLING
    if n % 2 == 0:
        C[-1] *= 0.5
    c = np.fft.irfft(C, n * up)
    i0 = int(math.ceil(lo * up))
    i1 = int(math.floor(hi * up))
    lags = np.arange(i0, i1 + 1)
    k = int(lags[np.argmax(c[lags % c.size])])
    if k in (i0, i1) and i1 > i0:
        return None
    a, b, d = c[(k - 1) % c.size], c[k % c.size], c[(k + 1) % c.size]
    den = a - 2.0 * b + d
    frac = 0.5 * (a - d) / den if den < 0.0 else 0.0
    return (k + min(0.5, max(-0.5, frac))) / up


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
        No candidate clears the threshold.
    """
    found = detect(r, settings, background)
    peaks = found.peaks
    if peaks.size == 0:
        raise AnalysisError(
            "no tick detected: nothing rises above the background (is this a recording of impacts?)"
        )
    onsets = _candidate_onsets(r, found, settings)
    kept = _separate(onsets, settings.min_separation)
    peaks, onsets = peaks[kept], onsets[kept]
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
                settings.onset_fraction,
                settings.onset_gap,
                s,
            )
            for k, s in zip(found.peaks, sigma)
        ]
    )


def _separate(onsets: np.ndarray, min_sep: int) -> list[int]:
    """Indices of the onsets kept: a candidate whose onset walks back to within ``min_sep``
    of the previous tick's is part of that tick's burst, and one at the first sample is the
    recording's cut.

    Raises
    ------
    AnalysisError
        None is kept.
    """
    kept = []
    for i in range(onsets.size):
        if onsets[i] == 0.0:
            continue
        if not kept or onsets[i] - onsets[kept[-1]] >= min_sep:
            kept.append(i)
    if not kept:
        raise AnalysisError(
            "no tick detected: nothing rises above the background (is this a recording of impacts?)"
        )
    return kept
