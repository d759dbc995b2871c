"""Alter a recorded bouncing sound: the thesis' restitution change (section 5.2.2).

Every bounce's restitution is changed by one factor ``k`` on ``1 - e``:
``1 - e'_n = k (1 - e_n)``, where ``e_n = T_n / T_(n-1)`` is measured from the bounce
times ``T_n`` between successive onsets. The new bounce times follow
``T'_n = e'_n T'_(n-1)`` from the first one, which is kept (it is set by the drop, not by a
restitution). The recording is cut at the detected onsets into one segment per tick (the
tick and its tail up to the next onset), and the segments are laid out again at the new
onsets:

* where a bounce gets longer, the segment's tail is continued by linear prediction
  (an all-pole model of the tail's last ``context`` seconds, which continues a sum of
  decaying modes), never by silence: the thesis warns that inserted silence is heard;
* where a bounce gets shorter, the segment is cut at the new onset;
* every join is a raised-cosine crossfade of ``crossfade`` seconds, so no click;
* optionally (``scale_amplitude``) each tick is scaled by its new impact speed over its
  old one, ``v'_n / v_n = T'_(n-1) / T_(n-1)`` (``v = g T / 2``), as a physical tick's
  amplitude is proportional to the impact speed.

With ``k = 1`` the recording comes back unchanged.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter, lfiltic

from . import _checks
from .errors import ParameterError


def _lpc(x, order):
    """All-pole coefficients ``a`` (a[0] = 1) by least squares on the signal itself (the
    covariance method: exact for a sum of up to ``order/2`` decaying sinusoids), with a
    tiny ridge for conditioning."""
    x = np.asarray(x, dtype=float)
    n = x.size
    A = np.lib.stride_tricks.sliding_window_view(x, order)[:n - order][:, ::-1]
    b = -x[order:]
    lam = 1e-9 * float(np.sum(x * x)) / max(n, 1)
    coef = np.linalg.solve(A.T @ A + lam * np.eye(order), A.T @ b)
    return np.r_[1.0, coef]


#: Largest pole radius of the extension: tails decay, so no pole may sit on or outside the
#: unit circle (0.99999 per sample is a 60 dB decay in 14 s at 48 kHz).
MAX_POLE_RADIUS = 0.99999


def extend(x, n, *, order=400, context=4800):
    """Continue signal ``x`` by ``n`` samples with linear prediction from its last ``context``
    samples (all-pole model of at most ``order`` poles and at most a third of the context,
    poles kept inside ``MAX_POLE_RADIUS``). Returns the ``n`` new samples.

    ``x`` should be a tail only (no attack): a sum of decaying modes, which the model
    continues exactly when it has at least two poles per mode (e.g. 1e-4 relative error
    100 ms into a tick of the default scene); with fewer (early in a dense tail) it keeps
    the level and the dominant modes, not the waveform."""
    x = np.asarray(x, dtype=float)
    if n <= 0:
        return np.zeros(0)
    seg = x[-context:]
    order = min(order, max(2, seg.size // 3))
    if seg.size <= 2 * order or not np.any(seg):
        return np.zeros(n)
    a = _lpc(seg, order)
    y = _predict(a, seg, n)
    level = float(np.max(np.abs(seg[-order:])))
    if not np.all(np.isfinite(y)) or float(np.max(np.abs(y))) > 2.0 * level:
        # the model grows: move every pole inside MAX_POLE_RADIUS by bandwidth expansion,
        # a_k rho^k (exact, and well conditioned, unlike rebuilding a polynomial from roots)
        r_max = float(np.max(np.abs(np.roots(a))))
        if r_max > MAX_POLE_RADIUS:
            a = a * (MAX_POLE_RADIUS / r_max) ** np.arange(a.size)
        y = _predict(a, seg, n)
    return y


def _predict(a, seg, n):
    zi = lfiltic([1.0], a, y=seg[::-1][:a.size - 1])
    y, _ = lfilter([1.0], a, np.zeros(n), zi=zi)
    return y


def _fade(n):
    return 0.5 * (1.0 - np.cos(np.linspace(0.0, math.pi, n))) if n > 0 else np.zeros(0)


def alter_restitution(audio, samplerate, restitution_scale, *, onsets=None, gravity=9.81,
                      crossfade=0.001, scale_amplitude=True, channel=None):
    """Change the restitution of a recorded bouncing sound by ``1 - e' = k (1 - e)``.

    Parameters
    ----------
    audio : ndarray, (frames,) or (frames, channels)
        The recording (any units).
    samplerate : float
        Hz.
    restitution_scale : float >= 0
        ``k``.
    onsets : array of float, optional
        Tick onsets in s; default: detected by :func:`synth.analysis.analyze`.
    crossfade : float > 0
        Length of every join, s.
    scale_amplitude : bool
        Scale each tick by its new impact speed over its old one.
    channel : int or None
        Analyse this channel (None: their mean); every channel is altered.

    Returns
    -------
    (altered audio (float64, same channels), new onsets (s), old e, new e)
    """
    x = np.asarray(audio, dtype=float)
    if x.ndim not in (1, 2) or x.shape[0] == 0:
        raise ParameterError(f"audio with shape {x.shape} must be (frames,) or (frames, channels)")
    if not np.all(np.isfinite(x)):
        raise ParameterError("audio contains NaN or inf")
    fs = _checks.positive("samplerate", samplerate, "Hz")
    k = _checks.nonnegative("restitution_scale", restitution_scale, "dimensionless")
    xf = _checks.positive("crossfade", crossfade, "s")
    mono = x.ndim == 1
    X = x[:, None] if mono else x
    if onsets is None:
        from .analysis import analyze
        onsets = [t.time for t in analyze(x, fs, gravity=gravity, channel=channel).ticks]
    t = np.asarray(onsets, dtype=float)
    if t.ndim != 1 or t.size < 3 or np.any(np.diff(t) <= 0) or t[0] < 0:
        raise ParameterError(f"onsets must be at least 3 increasing times >= 0 (s), got {t.size}")
    T = np.diff(t)
    e = T[1:] / T[:-1]
    e_new = 1.0 - k * (1.0 - e)
    if np.any(e_new <= 0.0):
        n_ok = int(np.argmax(e_new <= 0.0))
        raise ParameterError(f"restitution_scale={k!r} gives e' <= 0 at bounce {n_ok + 2} "
                             f"(e = {e[n_ok]:.3f}): k must be < 1 / (1 - e) = {1 / (1 - e[n_ok]):.3f}")
    T_new = np.empty_like(T)
    T_new[0] = T[0]
    for i in range(1, T.size):
        T_new[i] = e_new[i - 1] * T_new[i - 1]
    t_new = t[0] + np.r_[0.0, np.cumsum(T_new)]
    gain = np.ones(t.size)
    if scale_amplitude:
        gain[1:] = T_new / T       # v'_n / v_n for the tick after each bounce
    nx = max(2, int(round(xf * fs)))
    start = [int(round(s * fs)) for s in t]
    start_new = [int(round(s * fs)) for s in t_new]
    if start[0] < nx:
        raise ParameterError(f"the first onset ({t[0]:.4f} s) must be at least crossfade={xf!r} s "
                             f"after the start of the audio")
    N = t.size
    attack = int(round(0.002 * fs))        # the tail model starts 2 ms after an onset
    # the crossfade before onset j: at most nx, and at most half of the shorter interval
    # beside it (old or new), so that no three segments ever overlap
    L = np.full(N, nx, dtype=int)
    for j in range(1, N):
        near = [start[j] - start[j - 1], start_new[j] - start_new[j - 1]]
        if j + 1 < N:
            near += [start[j + 1] - start[j], start_new[j + 1] - start_new[j]]
        L[j] = max(1, min(nx, min(near) // 2))
    tail_len = X.shape[0] - start[-1]
    out = np.zeros((start_new[-1] + tail_len, X.shape[1]))
    out[:start[0] - nx] = X[:start[0] - nx]                 # before the first tick: unchanged
    for i in range(N):
        # segment i starts L[i] samples before its onset (the joins fall in the previous
        # tail, never on an attack) and reaches the next onset
        c = start[i] - L[i]
        if i + 1 < N:
            want = start_new[i + 1] - start_new[i] + L[i]
            have = start[i + 1] - c                          # up to the next onset
            if want <= have:
                seg = X[c:c + want].copy()
            else:
                body = X[c:start[i + 1] - L[i + 1]]          # stop short of the next join
                tail = X[start[i] + attack:start[i + 1] - L[i + 1]]   # the tail alone
                ext = np.stack([extend(tail[:, ch] if tail.shape[0] > 8 else body[:, ch],
                                       want - body.shape[0]) for ch in range(X.shape[1])], axis=1)
                seg = np.concatenate([body, ext], axis=0)
        else:
            seg = X[c:].copy()
        seg = seg * gain[i]
        if i > 0:
            seg[:L[i]] *= _fade(L[i])[:, None]
        else:
            seg[:L[0]] = X[c:c + L[0]]                       # the first join is no join
        if i + 1 < N:
            seg[-L[i + 1]:] *= _fade(L[i + 1])[::-1][:, None]
        o = start_new[i] - L[i]
        m = min(seg.shape[0], out.shape[0] - o)
        out[o:o + m] += seg[:m]
    return (out[:, 0] if mono else out), t_new, e, e_new
