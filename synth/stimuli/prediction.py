"""Linear prediction of a recording's ringing for :mod:`synth.stimuli.alter`: all-pole
models fitted to the recording before a cut (the ticks' contacts left out, stable by
construction), their extension of a signal, the background noise's model and the Wiener
gain that separates a tick's sound from it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from synth import dsp

#: Past spanned by the prediction model, s (its order: 400 samples at 48 kHz).
ORDER = 1.0 / 120.0
#: Recording fitted before each cut, s.
CONTEXT = 0.1
#: Slowest decay of a predicted mode: 60 dB in this many seconds.
MAX_T60 = 15.0
#: Frames of the noise-floor estimate and of the end level, s.
NOISE_FRAME = dsp.NOISE_FRAME
#: Past spanned by the noise model, s.
NOISE_ORDER = 0.001
#: Smoothing of a tick's short-time power for its gain, s.
SMOOTHING = 0.001


def _solve(phi, ridge):
    """Prediction-error filter ``[1, a1 .. ap]`` from the normal equations by Cholesky (least
    squares where they are not positive definite), with a ridge of ``ridge`` times the mean
    diagonal (a white-noise correction) for conditioning."""
    from scipy.linalg import LinAlgError, cho_factor, cho_solve

    p = phi.shape[0] - 1
    R = phi[1:, 1:] + ridge * float(np.trace(phi[1:, 1:])) / p * np.eye(p)
    try:
        coef = cho_solve(cho_factor(R, check_finite=False), -phi[1:, 0], check_finite=False)
    except LinAlgError:
        coef = np.full(p, np.nan)
    if not np.all(np.isfinite(coef)):
        coef = np.linalg.lstsq(R, -phi[1:, 0], rcond=None)[0]
    return np.r_[1.0, coef]


def _inside(a, radius):
    """True when every root of ``a`` (a[0] = 1) lies inside ``radius``."""
    return dsp.is_minimum_phase(a * radius ** -np.arange(a.size, dtype=float))


#: Ridges tried in turn (white-noise corrections, relative to the mean signal power, from
#: -90 to -10 dB): the first conditions an exact fit; a fit with a pole outside the
#: allowed radius (a spurious one, from the start of a tick in the fitted stretch or from
#: an empty band) is redone with the next, which pulls the weak poles in and leaves the
#: strong modes.
RIDGES = (1e-9, 1e-7, 1e-5, 1e-3, 1e-2, 1e-1)


def _stable_fit(phi, fs):
    """The first fit of RIDGES whose roots all lie inside the radius of a 60 dB decay in
    MAX_T60 s; failing all, the last one with every root moved inward by one factor
    ``rho`` (``a_k rho^k``, found by bisection on the step-down test)."""
    radius = math.exp(-math.log(1000.0) / (MAX_T60 * fs))
    for ridge in RIDGES:
        a = _solve(phi, ridge)
        if _inside(a, radius):
            return a
    k = np.arange(a.size, dtype=float)
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if _inside(a * mid**k, radius):
            lo = mid
        else:
            hi = mid
    return a * lo**k


def _blocks(lo, end, p, excluded, spread):
    """Target blocks in ``[lo + p, end)`` outside the excluded intervals, each extended by
    ``spread`` samples."""
    blocks, start = [], lo + p
    for a, b in sorted(excluded):
        b += spread
        if b <= start or a >= end:
            continue
        if a > start:
            blocks.append((start, a))
        start = max(start, b)
    if start < end:
        blocks.append((start, end))
    return blocks


def fit_model(z, end, fs, excluded=(), context=CONTEXT, order=ORDER):
    """Prediction model of ``z`` from its last ``context`` s before sample ``end``, the samples in
    ``excluded`` (intervals) left out as targets; None when there is too little (fewer than 2
    poles) or only silence; and whether the fit is clean: targets within ``p`` samples after an
    excluded interval are left out too when at least ``3 p`` targets remain."""
    lo = max(0, end - int(round(context * fs)))
    p0 = min(max(2, int(round(order * fs))), (end - lo) // 3)
    for clean in (True, False):
        p, least = p0, (max(2, p0 // 2) if clean else 2)
        while p >= least:
            blocks = _blocks(lo, end, p, excluded, p if clean else 0)
            rows = sum(b - a for a, b in blocks)
            if rows >= 3 * p:
                break
            p = min(p - 1, rows // 3 if not clean else (rows + p) // 4)
        if p >= least:
            break
    if p < least:
        return None, False
    phi = dsp.covariance_matrix(z, p, blocks)
    if not phi[0, 0] > 0.0:
        return None, False
    return _stable_fit(phi, fs), clean


class NoiseModel:
    """The recording's background: RMS ``level`` (signal units) and an all-pole model
    ``a`` driven by white noise of RMS ``drive`` (level 0: no noise)."""

    def __init__(self, z, fs):
        self.level, self.a, self.drive = 0.0, np.ones(1), 0.0
        fr = dsp.noise_frames(z, fs, least=8)
        if fr.shape[0] == 0:
            return
        n = fr.shape[1]
        ms = np.mean(fr * fr, axis=1)
        live = ms > 0.0
        if not np.any(live):
            return
        quiet = dsp.quiet_frames(ms, among=live)
        power = float(np.mean(ms[quiet]))
        q = max(1, min(int(round(NOISE_ORDER * fs)), n // 4))
        w = np.hanning(n + 2)[1:-1]
        spec = np.fft.rfft(fr[quiet] * w, 2 * n, axis=1)
        r = np.fft.irfft(np.mean(np.abs(spec) ** 2, axis=0), 2 * n)[: q + 1]
        r = dsp.white_noise_corrected(r)
        a = dsp.levinson_predictor(r)
        self.level = math.sqrt(power)
        self.a = a
        self.drive = math.sqrt(power * max(float(np.dot(a, r)) / r[0], 0.0))

    def __call__(self, n, rng):
        if self.level == 0.0 or n <= 0:
            return np.zeros(max(n, 0))
        return lfilter([1.0], self.a, self.drive * rng.standard_normal(n))


def wiener_gain(own, noise_power, fs):
    """Wiener weight ``w = max(0, 1 - N / P)`` of a tick's own sound: its power ``P`` over
    the last SMOOTHING s (causal, so that the noise before the attack does not count)
    against the noise power ``N``; 1 where there is no noise. A tick decays: after its
    loudest point ``w`` never rises again, so that the noise's own fluctuations cannot
    make the gain pump."""
    if noise_power <= 0.0:
        return np.ones(own.size)
    m = max(2, int(round(SMOOTHING * fs)))
    h = np.hanning(2 * m + 1)[m:]  # the falling half: the recent past weighs most
    power = lfilter(h / h.sum(), [1.0], own * own)
    weight = np.where(power > noise_power, 1.0 - noise_power / np.maximum(power, 1e-300), 0.0)
    top = int(np.argmax(power))
    weight[top:] = np.minimum.accumulate(weight[top:])
    return weight


class Ringing:
    """The zero-input response of the all-pole model ``1/a`` from the last samples of
    ``past`` (zeros before it; ``a`` None: silence), taken block by block."""

    def __init__(self, a, past):
        self.a, self.zi = a, None
        if a is not None:
            # lfilter's state after the outputs ``past`` (what lfiltic gives, in one
            # correlation): zi[k] = -sum_j a[k+1+j] past[-1-j]
            p = a.size - 1
            hist = past[::-1][:p]
            if hist.size < p:
                hist = np.r_[hist, np.zeros(p - hist.size)]
            self.zi = -np.correlate(a[1:], hist, "full")[p - 1 :]

    def take(self, n):
        if self.a is None or n <= 0:
            return np.zeros(max(n, 0))
        out, self.zi = lfilter([1.0], self.a, np.zeros(n), zi=self.zi)
        return out
