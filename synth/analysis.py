"""Analysis of bouncing sounds: find the ticks in a recording and measure them.

The measurements are the perceptual parameters of PHYSICS.md section 7 (thesis
Chapter 5 and section 3.1): per tick the onset time, the bounce time since the
previous tick, the restitution ``e_n = t_n / t_(n-1)`` and the impact speed
``v_n = g t_n / 2`` that follow from the bounce times, the tick's energy and
peak, its spectral centroid and spread, and its decay time.

Tick detection (:func:`analyze`)
--------------------------------
A bouncing ball's ticks come closer and closer (the last ones a few ms apart)
and each rings on under the next ones, so a detector on the raw level sees the
new ticks as small bumps on the old tails. The ticks of one recording are all
the response of the same resonator (the plate, the room) to short contact
forces, so the detector first removes the resonator:

1. **Whitening.** A linear predictor of order ``p`` is fitted to the whole
   signal (autocorrelation method, Levinson via ``scipy.linalg.solve_toeplitz``)
   and the prediction error ``r = A(z) x`` is formed. The ringing of every
   tick is predictable from its own past and cancels; what is left is close to
   the excitation, one short burst per contact, plus the whitened noise. This is
   the inverse filter of linear-prediction analysis (Makhoul 1975), used here as
   the adaptive whitening of onset detectors (Stowell and Plumbley 2007).
2. **Detection function.** The energy of ``r`` in frames of ``hop`` seconds
   (default 0.25 ms).
3. **Adaptive threshold.** A frame is a tick when it is a local maximum, at
   least ``min_separation`` from a stronger one, and its energy is
   ``threshold_db`` above the larger of the local background (the running
   median of the detection function over ``background`` seconds: robust to the
   ticks themselves, which are sparse in time) and the floor
   ``dynamic_range_db`` below the strongest frame.
4. **Onset refinement.** The envelope of ``r`` (root of ``r^2`` smoothed by a
   Hann window of ``smoothing`` samples) is followed back from the tick's peak to
   the first point where it falls below ``onset_fraction`` of the peak; the
   crossing is interpolated between the two samples around it, and the half-length
   of the smoothing window is added back (the smoothing spreads an impulse that
   much ahead of itself). The onset is therefore the time at which the
   excitation's envelope first reaches ``onset_fraction`` of its peak: for an
   impulse that is the impulse itself; for a contact of duration ``tau`` (a
   half-sine force) it is later than the first touch by
   ``asin(onset_fraction) tau / pi`` (``tau / 6`` at 0.5), a lag that changes
   only as slowly as ``tau`` with speed and so hardly enters the bounce times.

Accuracy on synthetic ticks (sums of damped sinusoids with known sub-sample
onsets, tails overlapping, ``tests/test_analysis.py``): onset errors below one
sample period (23 us at 44.1 kHz) on clean signals; see the tests for noise.

Tick measurements
-----------------
Tick ``n``'s window runs from its onset to the next tick's onset, at most
``window`` seconds. Unless ``subtract_tails=False``, the tails of the earlier
ticks are removed from it first: the linear predictor of step 1 continues the
signal from the samples just before the onset with no new excitation, which is
what the earlier ticks would have rung on their own, and that is subtracted.
On the tick's own signal ``y`` over its window:

* ``energy = sum(y^2) / samplerate`` (signal units^2 s);
* ``peak = max |y|``;
* ``centroid`` and ``spread``: mean and standard deviation of frequency weighted
  by the power spectrum ``|Y(f)|^2`` (Hz), ``y`` tapered by the falling half of a
  Hann window (the onset is kept, the cut at the window's end is smoothed);
* ``decay_time``: the time for the amplitude envelope to fall by ``1/e``,
  ``-1/slope`` of a least-squares line through the log of the envelope (root of
  ``y^2`` smoothed over ``decay_smoothing`` seconds) from its peak to the end of
  the window or to where it falls within 10 dB of the noise floor; ``None``
  when that span is shorter than ``decay_smoothing`` or the envelope does not
  fall.

The noise floor is the RMS of the quietest tenth of 10 ms frames of the signal.

Clipping is reported, not raised (unless ``on_clipping="raise"``): when
``clip_samples`` or more samples sit at exactly the signal's largest magnitude,
:attr:`Analysis.clipped` is true and :attr:`Analysis.warnings` says so.
"""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from dataclasses import dataclass, fields

import numpy as np

from . import _checks
from .errors import ParameterError, SynthError


class AnalysisError(SynthError, ValueError):
    """The recording cannot be analysed: unreadable, silent, or without ticks."""


@dataclass(frozen=True)
class Tick:
    """One detected tick (SI units).

    Attributes
    ----------
    index : int
        1 for the first tick.
    time : float
        Onset, s from the start of the recording.
    bounce_time : float or None
        Time since the previous tick's onset, s (the flight time plus the
        previous contact); ``None`` for the first tick.
    restitution : float or None
        ``e_n = t_n / t_(n-1)``, the ratio of this bounce time to the previous one,
        dimensionless: the restitution of the previous tick's impact (thesis 3.1).
        ``None`` for the first two ticks.
    speed : float or None
        Impact speed ``v_n = g t_n / 2`` from the bounce time, m/s; ``None`` for
        the first tick.
    energy : float
        Sum of squares of the tick's own signal over its window divided by the
        sample rate, signal units^2 s.
    peak : float
        Largest magnitude of the tick's own signal, signal units.
    centroid : float
        Spectral centroid (power-weighted mean frequency), Hz.
    spread : float
        Spectral spread (power-weighted standard deviation of frequency), Hz.
    decay_time : float or None
        Time for the amplitude envelope to fall to 1/e of its peak, s; ``None``
        when the window is too short to fit it.
    window : float
        Length of the measurement window, s.
    strength : float
        Detection strength: the tick's whitened energy above the detection
        threshold's reference, dB.
    """

    index: int
    time: float
    bounce_time: float | None
    restitution: float | None
    speed: float | None
    energy: float
    peak: float
    centroid: float
    spread: float
    decay_time: float | None
    window: float
    strength: float


@dataclass(frozen=True)
class Analysis:
    """The ticks found in one recording and what they say.

    Attributes
    ----------
    ticks : tuple of Tick
        In time order.
    samplerate : float
        Sample rate, Hz.
    duration : float
        Length of the recording, s.
    noise_floor : float
        RMS of the noise estimate (quietest tenth of 10 ms frames), signal units.
    gravity : float
        Gravity used for the speeds, m/s^2.
    channel : int or None
        The channel analysed; ``None`` when the channels were mixed (mean).
    clipped : bool
        True when the recording looks clipped (see :func:`analyze`).
    warnings : tuple of str
        Anything the measurements should be read with (clipping, ...).
    """

    ticks: tuple[Tick, ...]
    samplerate: float
    duration: float
    noise_floor: float
    gravity: float
    channel: int | None
    clipped: bool
    warnings: tuple[str, ...]

    @property
    def mean_restitution(self) -> float | None:
        """Mean of the defined ``e_n``, dimensionless; ``None`` when there is none."""
        e = [t.restitution for t in self.ticks if t.restitution is not None]
        return float(np.mean(e)) if e else None


# ---------------------------------------------------------------------------
# validation


def _audio_array(audio, name: str = "audio") -> np.ndarray:
    if isinstance(audio, np.ndarray):
        a = audio
    else:
        try:
            a = np.asarray(audio)
        except Exception:  # noqa: BLE001 - anything that is not array-like
            raise ParameterError(
                f"{name} must be an array of samples, not {type(audio).__name__}") from None
    if a.dtype == bool or not (np.issubdtype(a.dtype, np.floating)
                               or np.issubdtype(a.dtype, np.integer)):
        raise ParameterError(
            f"{name} must hold real numbers (float samples), not dtype {a.dtype}")
    if a.ndim not in (1, 2):
        raise ParameterError(
            f"{name} must be (frames,) or (frames, channels), got shape {a.shape}")
    if a.shape[0] == 0 or (a.ndim == 2 and a.shape[1] == 0):
        raise ParameterError(f"{name} is empty (shape {a.shape})")
    a = a.astype(np.float64, copy=False)
    if not np.all(np.isfinite(a)):
        bad = int(np.size(a) - np.count_nonzero(np.isfinite(a)))
        raise ParameterError(f"{name} holds {bad} NaN or infinite samples; all must be finite")
    return a


def _pick_channel(a: np.ndarray, channel) -> tuple[np.ndarray, np.ndarray]:
    """Return (the signal to analyse, the channels it was made from)."""
    if a.ndim == 1:
        chans = a[:, None]
    else:
        chans = a
    n = chans.shape[1]
    if channel is None:
        return chans.mean(axis=1), chans
    if isinstance(channel, bool) or not isinstance(channel, (int, np.integer)):
        raise ParameterError(
            f"channel={channel!r} must be None (mix) or an integer channel index")
    if not -n <= channel < n:
        raise ParameterError(
            f"channel={channel!r} is out of range: the audio has {n} channel(s), "
            f"allowed 0..{n - 1} (or None to mix)")
    return chans[:, channel].copy(), chans[:, [channel]]


def _int_param(name: str, value, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name}={value!r} must be an integer >= {lo}")
    if value < lo:
        raise ParameterError(f"{name}={value!r} must be >= {lo}")
    return int(value)


# ---------------------------------------------------------------------------
# numerics


def _lpc(x: np.ndarray, order: int) -> np.ndarray:
    """Prediction-error filter ``[1, a1, ..., ap]`` of ``x`` (autocorrelation method).

    The autocorrelation is computed by ``order + 1`` dot products (no FFT of the
    whole file); the zero lag is raised by 1e-9 (a -90 dB white-noise
    correction) so that a noiseless sum of a few sinusoids stays solvable.
    """
    from scipy.linalg import solve_toeplitz

    r = np.array([np.dot(x[: x.size - k], x[k:]) for k in range(order + 1)])
    r[0] *= 1.0 + 1e-9
    a = solve_toeplitz(r[:order], -r[1:])
    return np.concatenate(([1.0], a))


def _smooth_power(x: np.ndarray, length: int) -> np.ndarray:
    """``x^2`` smoothed by a unit-sum Hann window of ``length`` samples (centred)."""
    from scipy.signal import fftconvolve

    if length <= 1:
        return x * x
    w = np.hanning(length + 2)[1:-1]
    w /= w.sum()
    return np.maximum(fftconvolve(x * x, w, mode="same"), 0.0)


def _noise_floor(x: np.ndarray, samplerate: float) -> float:
    """RMS of the quietest tenth of 10 ms frames, signal units."""
    n = max(1, int(round(0.01 * samplerate)))
    frames = x.size // n
    if frames == 0:
        return float(np.sqrt(np.mean(x * x)))
    ms = np.mean(x[: frames * n].reshape(frames, n) ** 2, axis=1)
    return float(np.sqrt(np.quantile(ms, 0.1)))


def _clipping(chans: np.ndarray, min_count: int) -> tuple[bool, str | None]:
    worst = None
    for c in range(chans.shape[1]):
        mag = np.abs(chans[:, c])
        peak = mag.max()
        if peak == 0.0:
            continue
        count = int(np.count_nonzero(mag >= peak))
        if count >= min_count and (worst is None or count > worst[1]):
            worst = (c, count, peak)
    if worst is None:
        return False, None
    c, count, peak = worst
    return True, (f"clipping: {count} samples of channel {c} sit at the largest magnitude "
                  f"{peak:.6g}; peaks, energies and spectra of the loudest ticks are wrong")


def _detect(r: np.ndarray, fs: float, hop: int, min_sep: int, background: float,
            threshold_db: float, rise_db: float, release: float, dynamic_range_db: float):
    """Frame indices of the ticks in the whitened signal ``r``.

    Returns the frames, the detection function (energy of ``r`` per frame),
    each frame's reference (the largest of the three levels a tick must clear,
    each already raised by its own margin) and the local background (energy per
    frame).
    """
    from scipy.ndimage import median_filter
    from scipy.signal import find_peaks

    frames = r.size // hop
    d = np.sum(r[: frames * hop].reshape(frames, hop) ** 2, axis=1)
    # local background: running median, robust to the (sparse) ticks themselves
    size = max(3, int(round(background * fs / hop)) | 1)
    med = median_filter(d, size=size, mode="nearest")
    bg = med * 10.0 ** (threshold_db / 10.0)
    # rise: above the memory of the past frames (j <= k - 2; frame k - 1 may hold
    # the start of the same burst), which fades by `release` dB per ms: rejects
    # the decaying remainder of a tick and the weaker echo of its end of contact.
    # In log10 units: max_j (log d_j - a (k - j)) = max_j (log d_j + a j) - a k.
    a = release * 1000.0 * hop / fs / 10.0
    j = np.arange(frames) * a
    with np.errstate(divide="ignore"):
        memory = np.maximum.accumulate(np.log10(d) + j)
    past = np.zeros_like(d)
    past[2:] = 10.0 ** (memory[:-2] - j[2:])
    rise = past * 10.0 ** (rise_db / 10.0)
    floor = d.max() * 10.0 ** (-dynamic_range_db / 10.0)
    ref = np.maximum(np.maximum(bg, rise), floor)
    q = np.where(d >= ref, d, 0.0)
    candidates = find_peaks(np.concatenate(([0.0], q, [0.0])))[0] - 1
    # a tick is the first candidate of a cluster closer than min_sep: a long contact
    # gives a second burst at its end (as strong as the start for a symmetric pulse)
    keep = []
    last = -min_sep
    for k in candidates:
        if (k - last) * hop >= min_sep:
            keep.append(k)
            last = k
    return np.array(keep, dtype=int), d, ref, med


def _refine(r: np.ndarray, lo: int, hi: int, fraction: float, gap: int,
            noise: float) -> float:
    """Sub-sample onset (in samples) of the burst of ``r`` peaking in ``[lo, hi)``.

    From the largest ``|r|``, walk back through the samples at or above
    ``fraction`` of it, bridging gaps of up to ``gap`` samples (the zero crossings
    of an oscillating burst); the onset is the crossing of that level between the
    earliest such sample and the one before it, linearly interpolated.
    """
    mag = np.abs(r)
    k = lo + int(np.argmax(mag[lo:hi]))
    level = max(fraction * mag[k], noise)
    i = k
    while True:
        j0 = max(0, i - gap)
        above = np.nonzero(mag[j0:i] >= level)[0]
        if above.size == 0:
            break
        i = j0 + int(above[0])
    if i == 0:
        return 0.0
    return (i - 1) + (level - mag[i - 1]) / (mag[i] - mag[i - 1])


def _tail(x: np.ndarray, a: np.ndarray, start: int, length: int) -> np.ndarray:
    """Free continuation of ``x`` from ``start`` on by the predictor ``a`` (no excitation)."""
    from scipy.signal import lfilter, lfiltic

    p = a.size - 1
    past = x[max(0, start - p): start][::-1]
    if past.size == 0:
        return np.zeros(length)
    zi = lfiltic([1.0], a, past)
    y, _ = lfilter([1.0], a, np.zeros(length), zi=zi)
    return y


def _decay_time(y: np.ndarray, fs: float, smoothing: float, floor: float) -> float | None:
    n = max(3, int(round(smoothing * fs)))
    if y.size < 2 * n:
        return None
    env = np.sqrt(_smooth_power(y, n))
    half = n // 2
    body = env[: env.size - half]          # the last half-window is cut by the window's end
    k = int(np.argmax(body))
    limit = floor * 10.0 ** (10.0 / 20.0)
    seg = body[k:]
    below = np.nonzero(seg <= limit)[0]
    if below.size:
        seg = seg[: below[0]]
    if seg.size < max(3, n):
        return None
    t = np.arange(seg.size) / fs
    slope = np.polyfit(t, np.log(seg), 1)[0]
    if not slope < 0.0:
        return None
    return float(-1.0 / slope)


def _spectrum_moments(y: np.ndarray, fs: float) -> tuple[float, float]:
    n = y.size
    taper = np.cos(0.5 * np.pi * np.arange(n) / n) ** 2   # falling half of a Hann window
    nfft = 1 << max(12, int(math.ceil(math.log2(2 * n))))
    p = np.abs(np.fft.rfft(y * taper, nfft)) ** 2
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    total = p.sum()
    if not total > 0.0:
        return 0.0, 0.0
    c = float(np.dot(f, p) / total)
    s = float(np.sqrt(max(np.dot((f - c) ** 2, p) / total, 0.0)))
    return c, s


# ---------------------------------------------------------------------------
# public API


def analyze(audio, samplerate, *, gravity=9.81, channel=None, min_separation=0.001,
            hop=0.00025, threshold_db=10.0, rise_db=6.0, release=10.0, dynamic_range_db=60.0, background=0.02,
            onset_fraction=0.3, lpc_order=None, window=0.05, subtract_tails=True,
            decay_smoothing=0.002, clip_samples=4, on_clipping="warn") -> Analysis:
    """Detect the ticks of a bouncing sound and measure them.

    Parameters
    ----------
    audio : array of float, (frames,) or (frames, channels)
        The recording, any signal units (the energies and peaks are in them).
    samplerate : float > 0
        Sample rate, Hz.
    gravity : float > 0
        Gravity for the impact speeds ``v_n = g t_n / 2``, m/s^2.
    channel : int or None
        The channel to analyse; ``None`` mixes them (mean).
    min_separation : float > 0
        Shortest time between two ticks, s (a weaker tick closer than this to a
        stronger one is dropped).
    hop : float > 0
        Frame length of the detection function, s.
    threshold_db : float > 0
        How far above its reference a frame's whitened energy must be, dB.
    dynamic_range_db : float > 0
        Ticks more than this below the strongest are ignored, dB.
    background : float > 0
        Length of the running median giving the local background, s.
    onset_fraction : float in (0, 1)
        The onset is where the excitation envelope first reaches this fraction of
        its peak (dimensionless).
    lpc_order : int >= 2, optional
        Order of the whitening predictor. Default: 0.5 ms of samples, at least 8.
    window : float > 0
        Longest measurement window of a tick, s.
    subtract_tails : bool
        Remove the earlier ticks' predicted tails before measuring a tick.
    decay_smoothing : float > 0
        Length of the Hann window smoothing the envelope for the decay fit, s.
    clip_samples : int >= 2
        Samples at exactly the largest magnitude that make the signal clipped.
    on_clipping : {"warn", "raise"}
        Report clipping in :attr:`Analysis.warnings`, or raise ``AnalysisError``.

    Returns
    -------
    Analysis

    Raises
    ------
    ParameterError
        Bad input (the message names the field and its value).
    AnalysisError
        A silent recording, one with no detectable tick, or a clipped one with
        ``on_clipping="raise"``.
    """
    a = _audio_array(audio)
    fs = _checks.positive("samplerate", samplerate, "Hz")
    g = _checks.positive("gravity", gravity, "m/s^2")
    min_sep_s = _checks.positive("min_separation", min_separation, "s")
    hop_s = _checks.positive("hop", hop, "s")
    thr = _checks.positive("threshold_db", threshold_db, "dB")
    rise = _checks.positive("rise_db", rise_db, "dB")
    rel = _checks.positive("release", release, "dB/ms")
    dyn = _checks.positive("dynamic_range_db", dynamic_range_db, "dB")
    bg_s = _checks.positive("background", background, "s")
    frac = _checks.in_range("onset_fraction", onset_fraction, 0.0, 1.0)
    win_s = _checks.positive("window", window, "s")
    dec_s = _checks.positive("decay_smoothing", decay_smoothing, "s")
    clip_n = _int_param("clip_samples", clip_samples, 2)
    _checks.choice("on_clipping", on_clipping, ("warn", "raise"))
    if not isinstance(subtract_tails, (bool, np.bool_)):
        raise ParameterError(f"subtract_tails={subtract_tails!r} must be True or False")
    if lpc_order is None:
        order = max(8, int(round(0.001 * fs)))
    else:
        order = _int_param("lpc_order", lpc_order, 2)
    x, chans = _pick_channel(a, channel)
    if order >= x.size // 2:
        raise ParameterError(
            f"audio has {x.size} frames: too short for a whitening predictor of order {order} "
            f"(need more than {2 * order})")

    warnings: list[str] = []
    if not np.any(x):
        raise AnalysisError("the audio is silent (every sample of the analysed signal is 0)")
    clipped, msg = _clipping(chans, clip_n)
    if clipped:
        if on_clipping == "raise":
            raise AnalysisError(msg)
        warnings.append(msg)

    from scipy.signal import lfilter

    A = _lpc(x, order)
    r = lfilter(A, [1.0], x)
    hop_n = max(1, int(round(hop_s * fs)))
    min_sep = max(1, int(round(min_sep_s * fs)))
    peaks, d, ref, med = _detect(r, fs, hop_n, min_sep, bg_s, thr, rise, rel, dyn)
    if peaks.size == 0:
        raise AnalysisError(
            "no tick was detected: nothing rises above the background; is this a bouncing sound?")

    gap = max(2, int(round(0.00025 * fs)))
    # a burst's samples must stand above the whitened noise: 4 standard deviations
    # (a Gaussian noise sample exceeds that with probability 6e-5)
    sigma = np.sqrt(med[peaks] / hop_n)
    onsets = np.array([
        _refine(r, max(0, (k - 1) * hop_n), min(r.size, (k + 2) * hop_n), frac, gap, 4.0 * s)
        for k, s in zip(peaks, sigma)])
    strength = 10.0 * np.log10(d[peaks] / ref[peaks])

    noise = _noise_floor(x, fs)
    ticks = []
    win_n = max(1, int(round(win_s * fs)))
    for i, on in enumerate(onsets):
        s = max(0, int(math.floor(on)) - 1)
        e = min(x.size, s + win_n)
        if i + 1 < onsets.size:
            e = min(e, max(s + 1, int(math.floor(onsets[i + 1])) - 1))
        y = x[s:e].copy()
        if subtract_tails and s > 0:
            y -= _tail(x, A, s, y.size)
        t = on / fs
        bt = None if i == 0 else (on - onsets[i - 1]) / fs
        prev_bt = None if i < 2 else (onsets[i - 1] - onsets[i - 2]) / fs
        c, sp = _spectrum_moments(y, fs)
        ticks.append(Tick(
            index=i + 1, time=float(t), bounce_time=None if bt is None else float(bt),
            restitution=None if prev_bt is None else float(bt / prev_bt),
            speed=None if bt is None else float(g * bt / 2.0),
            energy=float(np.dot(y, y) / fs), peak=float(np.abs(y).max()),
            centroid=c, spread=sp, decay_time=_decay_time(y, fs, dec_s, noise),
            window=float(y.size / fs), strength=float(strength[i])))
    return Analysis(ticks=tuple(ticks), samplerate=fs, duration=x.size / fs,
                    noise_floor=noise, gravity=g, channel=None if channel is None else
                    int(channel) % a.shape[1] if a.ndim == 2 else 0,
                    clipped=clipped, warnings=tuple(warnings))
