"""The measurements of every tick (docs/analysis.md, Tick measurements), on its own sound: its
excitation through the all-pole ``1/A`` over ``window`` from its onset."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from synth.analysis.detection import standing_out
from synth.analysis.report import Tick

#: Samples kept before the onset in a tick's window (and in its model's).
WINDOW_GUARD = 2
#: The decay fit stops where the envelope comes within this of the noise floor, dB.
DECAY_NOISE_MARGIN_DB = 10.0
#: Least fall of the fitted envelope over the fitted span, nepers (0.87 dB): a
#: smaller one cannot be told from noise and the other ticks' tails.
DECAY_MIN_FALL = 0.1


@dataclass(frozen=True)
class Whitening:
    """One whitening: filter ``A``, ``r = A * x`` and the residual ``q`` (or None)."""

    predictor: np.ndarray
    whitened: np.ndarray
    residual: np.ndarray | None


@dataclass(frozen=True)
class FoundTick:
    """A tick kept: onset (samples), strength (dB), whitened model (or None), its whitening's index,
    and its level-crossing onset (samples, where its window starts)."""

    onset: float
    strength: float
    model: np.ndarray | None
    whitening: int
    detected: float


def with_standing_out(x, found: list[FoundTick], whitening: Whitening, settings) -> list[FoundTick]:
    """``found`` with step 8's ticks of ``x`` added, in time order."""
    extra = standing_out(x, whitening.whitened, np.array([f.onset for f in found]), settings)
    if extra.onsets.size == 0:
        return found
    added = [FoundTick(on, st, None, 0, on) for on, st in zip(extra.onsets, extra.strengths)]
    return sorted(found + added, key=lambda f: f.onset)


@dataclass(frozen=True)
class SoundMeasures:
    """The measures of a tick's own sound over its window: energy (signal squared times s), peak
    (signal units), spectral centroid and spread (Hz), decay time (s, or None) and window (s)."""

    energy: float
    peak: float
    centroid: float
    spread: float
    decay_time: float | None
    window: float


class TickMeter:
    """The measurements of the ticks ``found`` in ``x``, one at a time (:meth:`tick`): each depends
    only on its own model and window, the next window's start and the earlier onsets. A tick's
    sound, once measured, is kept for every meter :meth:`with_found` makes: ticks dropped or added
    change only their neighbours' windows."""

    def __init__(
        self, x, found: list[FoundTick], whitenings: list[Whitening], settings, noise, sounds=None
    ):
        self.x, self.found, self.whitenings = x, found, whitenings
        self.settings, self.noise = settings, noise
        self.onsets = np.array([f.onset for f in found])  # samples
        detected = np.floor([f.detected for f in found]).astype(int)
        self.starts = np.maximum(detected - WINDOW_GUARD, 0)
        # (id of the FoundTick, end of its own excitation) -> (the FoundTick, its SoundMeasures);
        # the FoundTick held keeps its id from being reused
        self._sounds = {} if sounds is None else sounds

    def with_found(self, found: list[FoundTick]) -> TickMeter:
        """A meter of the ticks ``found`` in the same recording, sharing the sounds measured."""
        return TickMeter(
            self.x, found, self.whitenings, self.settings, self.noise, sounds=self._sounds
        )

    def time(self, i: int) -> float:
        """Onset of tick ``i``, s (as :meth:`tick` gives it)."""
        return float(self.onsets[i] / self.settings.samplerate)

    def tick(self, i: int) -> Tick:
        """The :class:`Tick` of the ``i``-th tick found."""
        settings, t, fs = self.settings, self.onsets, self.settings.samplerate
        m = self.sound(i)
        bt = None if i == 0 else float((t[i] - t[i - 1]) / fs)
        return Tick(
            index=i + 1,
            time=float(t[i] / fs),
            bounce_time=bt,
            restitution=None if i < 2 else float(bt / ((t[i - 1] - t[i - 2]) / fs)),
            speed=None if bt is None else float(settings.gravity * bt / 2.0),
            strength=float(self.found[i].strength),
            **dataclasses.asdict(m),
        )

    def sound(self, i: int) -> SoundMeasures:
        """The :class:`SoundMeasures` of the ``i``-th tick's own sound, measured once."""
        s, f = self.starts[i], self.found[i]
        e = min(self.x.size, s + self.settings.window)
        stop = min(e, self.starts[i + 1]) if i + 1 < self.starts.size else e
        key = (id(f), int(stop))
        hit = self._sounds.get(key)
        if hit is not None and hit[0] is f:
            return hit[1]
        if not self.settings.subtract_tails:
            y = self.x[s:e].copy()
        else:
            y = own_sound(f, self.whitenings[f.whitening], s, e, stop)
        m = measure_sound(y, self.settings.samplerate, self.settings.decay_smoothing, self.noise)
        self._sounds[key] = (f, m)
        return m


def measure_sound(y: np.ndarray, fs: float, smoothing: int, noise: float) -> SoundMeasures:
    """The :class:`SoundMeasures` of ``y`` (rate ``fs``, Hz; decay envelope smoothed over
    ``smoothing`` samples, fitted above ``noise``)."""
    c, sp = spectral_moments(y, fs)
    return SoundMeasures(
        energy=float(np.dot(y, y) / fs),
        peak=float(np.abs(y).max()),
        centroid=c,
        spread=sp,
        decay_time=decay_time(y, fs, smoothing, noise),
        window=float(y.size / fs),
    )


def own_sound(tick: FoundTick, whitening: Whitening, s: int, e: int, stop: int) -> np.ndarray:
    """The tick's model plus what no tick explains up to ``stop``, through ``1/A``."""
    from scipy.signal import lfilter

    exc = np.zeros(e - s)
    if tick.model is not None:
        m = tick.model[: e - s]
        exc[: m.size] += m
        exc[: stop - s] += whitening.residual[s:stop]
    else:
        exc[: stop - s] = whitening.whitened[s:stop]
    # a coefficient of lag >= e - s meets only the zero state before s: leaving it out is exact
    return lfilter([1.0], whitening.predictor[: max(1, e - s)], exc)


def decay_time(y: np.ndarray, fs: float, n: int, floor: float) -> float | None:
    """Time for the envelope of ``y`` (rate ``fs``, Hz; Hann over ``n``) to fall to 1/e, s, fitted
    above ``floor``; None when too short or flat."""
    if y.size < 2 * n:
        return None
    w = np.hanning(n + 2)[1:-1]
    env = np.sqrt(np.convolve(y * y, w / w.sum(), mode="same"))
    env = env[: env.size - n // 2]  # the last half-window feels the window's end
    k = int(np.argmax(env))
    seg = env[k:]
    low = np.nonzero(seg <= floor * 10.0 ** (DECAY_NOISE_MARGIN_DB / 20.0))[0]
    if low.size:
        seg = seg[: low[0]]
    if seg.size < max(3, n):
        return None
    slope = np.polyfit(np.arange(seg.size) / fs, np.log(seg), 1)[0]
    if not -slope * seg.size / fs >= DECAY_MIN_FALL:
        return None
    return float(-1.0 / slope)


def spectral_moments(y: np.ndarray, fs: float) -> tuple[float, float]:
    """Power-weighted mean and spread of frequency of ``y`` (rate ``fs``), Hz."""
    n = y.size
    taper = np.cos(0.5 * np.pi * np.arange(n) / n) ** 2
    nfft = 1 << max(12, int(math.ceil(math.log2(2 * n))))
    p = np.abs(np.fft.rfft(y * taper, nfft)) ** 2
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    total = p.sum()
    if not total > 0.0:
        return 0.0, 0.0
    c = float(np.dot(f, p) / total)
    return c, float(np.sqrt(np.dot((f - c) ** 2, p) / total))
