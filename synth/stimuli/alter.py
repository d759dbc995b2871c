"""Alter a recorded bouncing sound: the thesis' restitution change (section 5.2.2).

The rule
--------
Every bounce's restitution is changed by one factor ``k`` on ``1 - e``:
``1 - e'_n = k (1 - e_n)``, where ``e_n = T_n / T_(n-1)`` is measured from the bounce
times ``T_n`` between successive tick onsets. The new bounce times follow
``T'_n = e'_n T'_(n-1)`` from the first one, which is kept (it is set by the drop, not by
a measured restitution). ``k < 1`` makes the ball livelier (longer bounces), ``k > 1``
deader (shorter ones). With ``k = 1`` the recording comes back unchanged, sample for
sample (``T' = T``: nothing is re-laid).

The end of the series (``k > 1``)
---------------------------------
A deader ball stops sooner. The altered series ends at the first new bounce time
``T'_n`` shorter than ``min_bounce``: where ``e'_n <= 0`` the ball no longer leaves the
plate (``T'_n <= 0``), and a bounce shorter than the contact cannot be told from a
contact that goes on (the ball settles). The default ``min_bounce`` is the shortest
bounce of the recording: one that the analysis resolved, so longer than the contact
time, and no shorter than what the recording shows (with ``k <= 1`` no bounce gets
shorter, so no tick is dropped). The ticks after the end are dropped; the ringing of
the last ones goes on to its natural decay, never cut (below). An alteration that
would leave no altered bounce (fewer than 3 ticks) is refused.

The method: every tick's own sound, re-laid
-------------------------------------------
All ticks are the responses of one resonator (plate, room, pickup) to short contact
forces, and each rings on under the next ones. Around tick ``j``'s onset: the *cut*
``GUARD`` before it (where fits end and predictions start, clear of the pre-echo that an
anti-aliasing or resampling filter spreads before an attack) and the *join* ``LEAD``
before it (where its own sound starts: the onsets are known to about a sample period).

1. **Ringing.** ``P_j`` continues the recording from its cut by linear prediction: an
   all-pole model of the resonator (below) run with no input, i.e. what the earlier
   ticks would have rung on their own.
2. **A tick's own sound.** ``own_j = x - P_j`` from the join to the next tick's cut, as
   recorded (with the recording's noise), faded in over ``LEAD``. After it, ``own_j``
   goes on as ``P_(j+1) - P_j``: the ringing of every tick up to ``j`` less that of the
   earlier ones, i.e. tick ``j`` rung on alone. A tick recorded too briefly or too weakly
   for that (a fit over the starts of the closely spaced last ticks, or a tick sinking
   within 10 dB of the noise floor before the next one) goes on instead as the
   *template*: tick 1's own sound (recorded over the whole second bounce, and continued by
   its model once it comes within 20 dB of the noise) times ``v_j / v_1``, its impact
   speed over tick 1's, crossfaded over ``SMOOTHING`` s.
3. **Re-laying.** The output is built in time order: the recording up to the first
   changed tick (at least the first bounce), then every tick's own sound, scaled by its
   gain (below), added at its new join. When no new onset lies within the model's reach
   before a new join (a long bounce), the output's ringing from there on is continued
   from the output itself, which is exact there; else it is the sum of the earlier
   ticks' own sounds. A join is therefore a continuation of what already rings, with no
   crossfade of two versions of a signal, no step and no jump of the ringing before an
   attack.
4. **Where the recording has no sample** (a lengthened bounce after the next original
   tick, and after the last tick) the output is the continuation of step 2, decaying as
   the resonator does, plus background noise (below): never silence, which the thesis
   warns is heard. After the last tick kept the output runs until its deterministic part
   has fallen to the level at which the recording ends (its noise floor, the RMS of its
   last 10 ms, at least ``END_FLOOR_DB`` re its peak, at most ``MAX_TAIL`` s after that
   tick), and ends with a raised-cosine fade of ``FADE`` s.

Ticks are placed to the nearest sample (within half a sample period of ``T'``).

Linear prediction
-----------------
The model before sample ``q`` is fitted on the recording's last ``CONTEXT`` s by the
covariance method (least squares on the signal itself: exact for a sum of up to
``order/2`` decaying sinusoids), leaving out the samples under each contact (from the
cut to ``EXCITATION`` after the onset, at most half the bounce). A sample whose
regressors reach back over an onset has the start of a tick in them, which no all-pole
recursion continues: those are left out too when enough remain (a model of at least half
the order, three equations per pole: a clean tail), else kept (the closely spaced last
ticks: a compromise that keeps their level and decay, not their waveform; such a model
predicts from the join rather than the cut). The order spans ``ORDER`` s of past (400 at
48 kHz). A fit with a pole outside the radius of a 60 dB decay in ``MAX_T60`` s (a
spurious pole, from a tick's start in the fitted stretch or from a band the recording
leaves empty, above its anti-aliasing filter) is redone with the next, larger ridge of
``RIDGES``, which pulls the weak poles in and leaves the strong modes. Every constant is
a time, so the method is the same at any sample rate.

Noise
-----
A recording's background noise is not predictable: a continuation by linear prediction
alone decays into silence below the noise floor (a dropout, up to 33 dB deep at 20 dB
SNR). The noise floor is estimated from the recording's quietest 10 ms frames (within
3 dB of the quietest one, frames of digital silence left out): its level, and its
spectral envelope as an all-pole model of ``NOISE_ORDER`` s fitted to the mean
autocorrelation of those frames. Where the output has no recorded noise (step 4) that
model driven by white noise is added, ramped in over ``LEAD`` as the recorded noise is
ramped out; the predictor's own continuation of the noise dies away as the synthesised
noise builds up from rest, so the background keeps its level and spectrum. The
background is assumed stationary; a recording without a quiet stretch (cut while it
still rings) gets the level of its quietest frames. The synthesised noise is not
continued by the predictor (it is not ringing), and ``seed`` makes it reproducible.

Amplitude
---------
With ``scale_amplitude`` each tick is scaled by its new impact speed over its old one,
``g_j = v'_j / v_j = T'_(j-1) / T_(j-1)`` (``v = g T / 2``; a tick's amplitude is
proportional to the impact speed). Only the tick's own sound is scaled, not the ringing
of the earlier ticks and not the background noise: while tick ``j`` is the latest and
recorded its gain is ``1 + (g_j - 1) w``, and after that ``g_j w``, where
``w = max(0, 1 - N / P)`` is the Wiener weight of the tick's short-time power ``P``
(over ``SMOOTHING`` s, causal, never rising again after its peak) against the noise
power ``N``: the tick is scaled where it stands above the noise; its recorded noise is
kept (gain 1) while it is the latest, and left out once a later tick or the synthesised
noise carries the background. Its continuation (step 2) is scaled by ``g_j``.

Limits
------
A tick recorded for a few milliseconds only, or at the noise floor, is continued from
models fitted over several ticks or from the template: its level and decay are kept
(within about 5 dB of an ideal re-laying of rendered ticks), not its exact waveform or
its own spectrum. A recording without a quiet stretch gets a background at the level of
its quietest part.
The output of ``k < 1`` is longer than the recording (``k = 0``: every bounce as long as
the first); with ``scale_amplitude`` its later ticks are louder and may exceed full
scale (``normalize="peak"``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from synth import checks, dsp
from synth.compilation import compiled
from synth.errors import ParameterError

#: Past spanned by the prediction model, s (its order: 400 samples at 48 kHz).
ORDER = 1.0 / 120.0
#: Recording fitted before each cut, s.
CONTEXT = 0.1
#: Before each onset: where the fits end and the prediction starts, clear of the attack's
#: pre-echo (an anti-aliasing or resampling filter spreads an attack over a few tenths of
#: a millisecond before it), s; and where a tick's own sound starts (the onsets are known
#: to about a sample period), s. Both at most half the shortest bounce.
GUARD = 0.0005
LEAD = 0.0001
#: Samples after an onset left out of the fits (under the contact), s; at most half the
#: bounce. The analysis' default ``min_separation``, which must exceed the contact time.
EXCITATION = 0.001
#: Slowest decay of a predicted mode: 60 dB in this many seconds.
MAX_T60 = 15.0
#: Frames of the noise-floor estimate and of the end level, s.
NOISE_FRAME = dsp.NOISE_FRAME
#: Past spanned by the noise model, s.
NOISE_ORDER = 0.001
#: Smoothing of a tick's short-time power for its gain, s.
SMOOTHING = 0.001
#: After the last tick kept, the output stops where it has fallen to the recording's end
#: level, at least this far below its peak, dB, and at most MAX_TAIL s after that tick;
#: the last FADE s are faded out.
END_FLOOR_DB = -80.0
MAX_TAIL = 60.0
FADE = 0.005
#: Output levels.
NORMALIZE_MODES = ("none", "peak")


# --------------------------------------------------------------------------- prediction


@compiled(sums=True)
def _cholesky_solve(A, b):  # pragma: no cover - compiled
    """Solve ``A x = b`` for symmetric positive definite ``A`` (Cholesky, ``A = L L^T``,
    Golub and Van Loan, Matrix Computations, sec. 4.2); NaN when ``A`` is not positive
    definite. Single-threaded: the systems are small (a few hundred unknowns)."""
    n = b.size
    L = np.zeros((n, n))
    x = np.empty(n)
    for j in range(n):
        s = A[j, j]
        for m in range(j):
            s -= L[j, m] * L[j, m]
        if not s > 0.0:
            x[:] = np.nan
            return x
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, n):
            s = A[i, j]
            for m in range(j):
                s -= L[i, m] * L[j, m]
            L[i, j] = s / L[j, j]
    for i in range(n):
        s = b[i]
        for m in range(i):
            s -= L[i, m] * x[m]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for m in range(i + 1, n):
            s -= L[m, i] * x[m]
        x[i] = s / L[i, i]
    return x


def _solve(phi, ridge):
    """Prediction-error filter ``[1, a1 .. ap]`` from the normal equations, with a ridge
    of ``ridge`` times the mean diagonal (a white-noise correction) for conditioning."""
    p = phi.shape[0] - 1
    R = phi[1:, 1:] + ridge * float(np.trace(phi[1:, 1:])) / p * np.eye(p)
    coef = _cholesky_solve(R, -phi[1:, 0])
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


def _fit_model(z, end, fs, excluded=(), context=CONTEXT, order=ORDER):
    """Prediction model of ``z`` from its last ``context`` s before sample ``end``, the
    samples in ``excluded`` (intervals) left out as targets; None when there is too
    little (fewer than 2 poles) or only silence; and whether the fit is clean (below).

    A target less than ``p`` samples after an excluded interval has in its regressors the
    start of a tick, which no all-pole recursion continues; they are left out too when at
    least ``3 p`` targets remain (a clean tail, e.g. a long bounce), else kept (dense late
    ticks: a compromise that keeps the level and decay, not the waveform)."""
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


def _fit(z, end, fs, excluded=(), context=CONTEXT, order=ORDER):
    """The model of :func:`_fit_model` alone."""
    return _fit_model(z, end, fs, excluded, context, order)[0]


def _predict(a, past, n):
    """The next ``n`` samples of the all-pole model ``1/a`` with no input, from the last
    samples of ``past`` (zeros before it)."""
    return _Ringing(a, past).take(n)


def extend(x, n, samplerate, *, context=CONTEXT, order=ORDER):
    """Continue ``x`` by ``n`` samples by linear prediction (the model of the module
    docstring, fitted on the last ``context`` s of ``x`` with ``order`` s of past).
    Returns the ``n`` new samples.

    Parameters
    ----------
    x : array of float, (frames,)
        A tail (a sum of decaying modes, no attack), any units.
    n : int >= 0
        Samples to add.
    samplerate : float > 0
        Hz.
    context, order : float > 0
        s.

    The continuation is exact for a sum of at most ``order * samplerate / 2`` decaying
    sinusoids (1e-9 for two); a rendered tick of the default scene is continued to 1e-3
    over 30 ms from its tail 100 ms after the onset."""
    fs = checks.positive("samplerate", samplerate, "Hz")
    ctx = checks.positive("context", context, "s")
    od = checks.positive("order", order, "s")
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ParameterError(f"x with shape {x.shape} must be (frames,) and finite")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ParameterError(f"n={n!r} must be an integer >= 0 (samples)")
    return _predict(_fit(x, x.size, fs, context=ctx, order=od), x, int(n))


# --------------------------------------------------------------------------- noise floor


class _Noise:
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


def _wiener(own, noise_power, fs):
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


# --------------------------------------------------------------------------- the alteration


def _timing(t, k, min_bounce):
    """New bounce times from the rule, up to the end of the series."""
    T = np.diff(t)
    e = T[1:] / T[:-1]
    e_new = 1.0 - k * (1.0 - e)
    T_new = [T[0]]
    for en in e_new:
        tn = en * T_new[-1]
        if not tn >= min_bounce * (1.0 - 1e-9):  # to rounding: k = 1 keeps every tick
            break
        T_new.append(tn)
    return T, e, e_new, np.array(T_new)


def _check_one_series(t: np.ndarray) -> None:
    """Refuse onsets that are not one bounce series: a bounce time that does not shrink
    (``e_n >= 1``) is no restitution of a ball but a missed tick or a new drop, and the
    rule would turn it the wrong way (``k > 1`` raises an ``e_n > 1``: a deader ball
    would bounce livelier)."""
    T = np.diff(t)
    grown = np.nonzero(T[1:] >= T[:-1])[0]
    if grown.size:
        n = int(grown[0])
        raise ParameterError(
            f"onsets are not one bounce series: the bounce before tick {n + 3} "
            f"({T[n + 1] * 1e3:.4g} ms) is not shorter than the one before it "
            f"({T[n] * 1e3:.4g} ms), e = {T[n + 1] / T[n]:.3g} >= 1, which no ball does (a "
            f"tick missed in between, or a new drop); pass the onsets of one series, every "
            f"tick found (synth.analyze reports each series and flags such ticks)"
        )


def alter_restitution(
    audio,
    samplerate,
    restitution_scale,
    *,
    onsets=None,
    gravity=9.81,
    scale_amplitude=True,
    channel=None,
    min_bounce=None,
    normalize="none",
    peak_db=-1.0,
    seed=0,
):
    """Change the restitution of a recorded bouncing sound by ``1 - e' = k (1 - e)``
    (module docstring).

    Parameters
    ----------
    audio : ndarray, (frames,) or (frames, channels)
        The recording (any units; the output is in the same units).
    samplerate : float > 0
        Hz.
    restitution_scale : float >= 0
        ``k``, dimensionless.
    onsets : array of float, optional
        Tick onsets, s, at least 3, increasing, at least 2 samples apart, of one bounce
        series (every bounce time shorter than the one before: ``e_n < 1``); default:
        detected by :func:`synth.analysis.analyze`.
    gravity : float > 0
        m/s^2, for the detection (impact speeds), when ``onsets`` is None.
    scale_amplitude : bool
        Scale each tick's own sound by its new impact speed over its old one.
    channel : int or None
        Detect the ticks on this channel (None: their mean); every channel is altered.
    min_bounce : float > 0, optional
        Shortest new bounce time, s: the series ends before a shorter one. Default: the
        shortest bounce of the recording. At least 2 sample periods.
    normalize : {"none", "peak"}
        ``"none"``: the recording's units and level (a louder tick may exceed full
        scale); ``"peak"``: the largest sample put at ``peak_db`` dBFS.
    peak_db : float <= 0
        dBFS, for ``"peak"``.
    seed : int >= 0
        Seed of the synthesised background noise (the output is reproducible).

    Returns
    -------
    (audio, onsets, e, e_new)
        The altered audio (float64, same channels, in the recording's units unless
        ``normalize="peak"``); the new onsets of the ticks kept, s (``M`` of them: all,
        unless the series ended early); the measured restitutions ``e_n`` (``N - 2`` for
        ``N`` onsets); and the new ones between the ticks kept (``M - 2``), so that
        ``e_new == 1 - k (1 - e[:M - 2])``.

    Raises
    ------
    ParameterError
        Bad input, onsets that are not one bounce series (a bounce time that grows: a
        missed tick or several drops), or an alteration that leaves fewer than 3 ticks.
    """
    x = np.asarray(audio, dtype=float)
    if x.ndim not in (1, 2) or x.shape[0] == 0 or (x.ndim == 2 and x.shape[1] == 0):
        raise ParameterError(f"audio with shape {x.shape} must be (frames,) or (frames, channels)")
    if not np.all(np.isfinite(x)):
        raise ParameterError("audio contains NaN or inf; every sample must be finite")
    fs = checks.positive("samplerate", samplerate, "Hz")
    k = checks.nonnegative("restitution_scale", restitution_scale, "dimensionless")
    mode = checks.choice("normalize", normalize, NORMALIZE_MODES)
    target_db = checks.real("peak_db", peak_db, "dBFS")
    if target_db > 0.0:
        raise ParameterError(f"peak_db={peak_db!r} must be <= 0 (dBFS)")
    if not isinstance(scale_amplitude, (bool, np.bool_)):
        raise ParameterError(f"scale_amplitude={scale_amplitude!r} must be True or False")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed={seed!r} must be an integer >= 0")
    mono = x.ndim == 1
    X = x[:, None] if mono else x
    if onsets is None:
        from synth.analysis import analyze

        onsets = [t.time for t in analyze(x, fs, gravity=gravity, channel=channel).ticks]
    t = np.asarray(onsets, dtype=float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(t)):
        raise ParameterError(f"onsets must be at least 3 finite times (s), got shape {t.shape}")
    if np.any(np.diff(t) < 2.0 / fs) or t[0] < 0.0 or t[-1] * fs >= X.shape[0]:
        raise ParameterError(
            f"onsets must increase by at least 2 sample periods ({2e3 / fs:.4g} ms) and lie "
            f"inside the audio (0 to {X.shape[0] / fs:.6g} s)"
        )
    _check_one_series(t)
    if min_bounce is None:
        min_b = float(np.min(np.diff(t)))
    else:
        min_b = checks.positive("min_bounce", min_bounce, "s")
        if min_b < 2.0 / fs:
            raise ParameterError(
                f"min_bounce={min_bounce!r} must be at least 2 sample periods "
                f"({2.0 / fs:.4g} s at {fs:g} Hz)"
            )
    T, e, e_new, T_new = _timing(t, k, min_b)
    M = T_new.size + 1
    if M < 3:
        if e_new[0] <= 0.0:  # no rebound at all (a bounce time would be meaningless)
            why = "<= 0: the ball would not rebound"
        else:
            why = f"a bounce of {T_new[0] * e_new[0] * 1e3:.3g} ms against min_bounce = "
            why += f"{min_b * 1e3:.3g} ms"
        raise ParameterError(
            f"restitution_scale={k!r} ends the series after 2 ticks (e' = 1 - k (1 - e) = "
            f"{e_new[0]:.3g} at the second impact, {why}): no altered bounce is left; "
            f"k must be < {(1.0 - min_b / T[0]) / (1.0 - e[0]):.4g} here"
        )
    t_new = np.r_[t[0], t[1] + np.r_[0.0, np.cumsum(T_new[1:])]]  # t'_1 = t_1 exactly
    gain = np.ones(M)
    if scale_amplitude:
        gain[1:] = T_new / T[: M - 1]  # v'_n / v_n, for the tick after each bounce
    guard = min(GUARD, 0.5 * min_b, 0.5 * float(np.min(T)))
    lead = min(LEAD, guard)
    cut = np.maximum(np.round((t - guard) * fs).astype(int), 0)
    join = np.maximum(np.round((t - lead) * fs).astype(int), 0)
    join_new = np.maximum(np.round((t_new - lead) * fs).astype(int), 0)
    on, on_new = t * fs, t_new * fs
    # under each contact: from the cut to EXCITATION after the onset, at most half the bounce
    reach = np.minimum(EXCITATION * fs, 0.5 * np.r_[np.diff(on), np.inf])
    excluded = [(int(c), int(math.ceil(o + r))) for c, o, r in zip(cut, on, reach)]
    reach_new = np.minimum(EXCITATION * fs, 0.5 * np.r_[np.diff(on_new), np.inf])
    excluded_new = [(int(c), int(math.ceil(o + r))) for c, o, r in zip(join_new, on_new, reach_new)]
    speed = np.r_[1.0, T[: M - 1] / T[0]]  # v_j / v_1, for the template of a tail
    parts = [
        _Channel(
            X[:, ch],
            fs,
            cut,
            join,
            join_new,
            gain,
            speed,
            excluded,
            excluded_new,
            lead,
            np.random.default_rng([int(seed), ch]),
        )
        for ch in range(X.shape[1])
    ]
    if all(part.unchanged for part in parts):
        Y = X.copy()  # nothing changed (k = 1)
    else:
        n_out = max(part.end for part in parts)  # the channels end together
        Y = np.stack([part.finish(n_out) for part in parts], axis=1)
        nf = min(Y.shape[0], max(1, int(round(FADE * fs))))
        Y[-nf:] *= 0.5 * (1.0 + np.cos(np.pi * np.arange(1, nf + 1) / nf))[:, None]
    if mode == "peak":
        peak = float(np.max(np.abs(Y)))
        if peak > 0.0:
            Y = (Y / peak) * 10.0 ** (target_db / 20.0)
    T_kept = np.diff(t_new)
    return (Y[:, 0] if mono else Y), t_new, e, T_kept[1:] / T_kept[:-1]


class _Ringing:
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


class _Channel:
    """One channel of the alteration (module docstring), built in time order: ``y`` is
    final up to ``done``; ``F`` holds what the ticks so far will still sound after it
    (deterministic parts and gated recorded noise). :meth:`finish` ends it.

    ``cut``: where each tick's fits end and its prediction starts, GUARD before its onset
    (in the recording); ``join`` and ``join_new``: where its own sound starts, LEAD before
    its onset (in the recording and in the output)."""

    def __init__(self, z, fs, cut, join, join_new, gain, speed, excluded, excluded_new, lead, rng):
        self.z, self.fs = z, fs
        self.cut, self.join, self.join_new = cut, join, join_new
        self.gain, self.speed = gain, speed
        self.excluded, self.excluded_new = excluded, excluded_new
        self.N, self.M = cut.size, gain.size
        self.noise = _Noise(z, fs)
        self.level = _end_level(z, fs, self.noise.level)
        self.i0 = self._first_changed()
        self.unchanged = self.i0 == self.M
        if self.unchanged:
            return
        self.models = {}
        self.npow = self.noise.level**2
        r = max(1, int(round(lead * fs)))  # ramps: the lead
        self.r = r
        self.ramp = 0.5 * (1.0 - np.cos(np.pi * (np.arange(r) + 0.5) / r))  # 0 -> 1
        self.lx = max(r, int(round(SMOOTHING * fs)))  # crossfade to a tick's continuation
        self.stop = 0.01 * self.level  # contributions are followed 40 dB under the end
        self.longest = int(round(MAX_TAIL * fs))
        self.rng = rng
        self.y, self.done, self.F = [z[: join[self.i0]].copy()], join[self.i0], np.zeros(0)
        self.syn = []  # (start, samples) of synthesised noise
        self.ref = self._reference(self.stop * min(1.0, float(np.min(speed[1:]))))
        for j in range(self.i0, self.M):
            latest, at = self._lay(j)
        self.tail = join_new[self.M - 1] + latest  # deterministic after this, but for noise
        self.gap = join_new[self.M - 1] + at  # synthesised noise from here on
        self.end = self.done + self._end()

    def _first_changed(self):
        """The first tick laid anew: before it (at least the first bounce) the output is the
        recording itself."""
        join, join_new, gain, M = self.join, self.join_new, self.gain, self.M
        i0 = 1
        while (
            i0 < M
            and join_new[i0] == join[i0]
            and gain[i0] == 1.0
            and (join_new[i0 + 1] == join[i0 + 1] if i0 + 1 < M else M == self.N)
        ):
            i0 += 1
        return i0

    def _model(self, q):
        """The prediction model of the recording before sample q, and whether it is clean
        (:func:`_fit_model`), fitted once."""
        if q not in self.models:
            self.models[q] = _fit_model(self.z, q, self.fs, self.excluded)
        return self.models[q]

    def _ringing(self, q, at):
        """The recording's ringing predicted from before sample q, from ``at`` on."""
        P = _Ringing(self._model(q)[0], self.z[:q])
        P.take(at - q)
        return P

    def _own_sound(self, j, need):
        """Tick j's own sound as recorded (from its join to ``obs``, the next tick's cut,
        clear of that tick's pre-echo; with the recorded noise), and its deterministic
        continuation ``d`` from sample ``d0``, crossfaded over ``[st - k, st)``: ``(own, obs,
        st, k, d, d0)``."""
        z, fs, cut, join, r = self.z, self.fs, self.cut, self.join, self.r
        jj = join[j]
        obs = cut[j + 1] - jj if j + 1 < self.N else min(z.size - jj, jj - join[j - 1])
        # predicted from the cut, clear of the attack's pre-echo; but a model that had to be
        # fitted over the starts of ticks (the closely spaced last ones) predicts a short way
        # only: from the join
        Pj = self._ringing(cut[j] if self._model(cut[j])[1] else jj, jj)
        own = z[jj : jj + obs] - Pj.take(obs)
        own[:r] *= self.ramp[: own.size]
        # recorded and at least 10 dB above the noise: up to where it sinks below
        loud = _wiener(own, 10.0 * self.npow, fs) > 0.0
        top = int(np.argmax(own**2)) if obs > 0 else 0
        sink = top + int(np.argmin(loud[top:])) if not np.all(loud[top:]) else obs
        q = jj + obs
        if sink == obs and q < z.size and self._model(q)[1]:
            # the recording's ringing after q (every tick up to j) less that of the earlier
            # ticks: own_j rung on alone, continuing it where it stops
            d = _follow(self._ringing(q, q), Pj, self.stop, max(0, need - obs), fs)
            return own, obs, obs, 0, d, obs
        # a tick recorded too briefly or too weakly to be continued from its own recording:
        # the template (tick 1's own sound) at its impact speed
        st = max(min(sink, obs), r)
        k = min(self.lx, st - r)
        return own, obs, st, k, self.speed[j] * self.ref[st - k : max(st, need)], st - k

    def _rebase(self, j):
        """No onset of the output within the reach of tick j's model: the output's ringing
        is continued from the output itself (replacing what the earlier ticks' parts would
        give)."""
        if j >= self.M:
            return False
        a = self._model(self.cut[j])[0]
        reach = self.join_new[j] - self.excluded_new[j - 1][1]
        return j == self.i0 or reach >= (0 if a is None else a.size - 1)

    def _lay(self, j):
        """Lay tick j's own sound, scaled by its gain, at its new join (module docstring,
        steps 2-3). Returns ``(latest, at)``: where its recorded part ends, and where its
        recorded noise is handed over (samples after its join)."""
        r, ramp, npow, fs = self.r, self.ramp, self.npow, self.fs
        cn = self.join_new[j]
        span = self.join_new[j + 1] - cn if j + 1 < self.M else None
        # what tick j leaves after the next tick is needed only if that one does not start
        # afresh from the output
        need = span if self._rebase(j + 1) else self.longest
        if self._rebase(j):
            # (the synthesised noise is not continued: it is not the output's ringing)
            yp = np.concatenate(self.y)
            for s0, nz in self.syn:
                yp[s0 : s0 + nz.size] -= nz
            self.F = _follow(_Ringing(self._model(self.cut[j])[0], yp), None, self.stop, need, fs)
        own, obs, st, k, d, d0 = self._own_sound(j, need)
        ends = span is None or span > obs  # the record ends before the next tick
        latest = obs if ends else span
        n = max(obs, d0 + d.size)
        rec = np.zeros(n)
        rec[:obs] = own
        det = np.zeros(n)
        det[d0 : d0 + d.size] = d
        g = self.gain[j]
        # while tick j is the latest and recorded its recorded noise is kept (lam); handed
        # over to the next tick's (its fade-in) or to synthesised noise
        lam = np.zeros(n)
        at = max(0, latest - r) if ends else latest
        lam[:at] = 1.0
        m = min(r, max(0, n - at))
        lam[at : at + m] = 1.0 - ramp[:m]
        w = np.ones(n)
        w[:obs] = _wiener(own, npow, fs)
        recorded = (lam * (1.0 + (g - 1.0) * w) + (1.0 - lam) * g * w) * rec
        continued = g * det + lam * (rec - det)
        mu = np.zeros(n)  # from the recorded form to the continued one
        mu[st - k : st] = 0.5 * (1.0 - np.cos(np.pi * (np.arange(k) + 0.5) / max(k, 1)))
        mu[st:] = 1.0
        self._add(cn, (1.0 - mu) * recorded + mu * continued)
        if span is not None:
            self._final(cn + span, cn + at if ends else None)
        return latest, at

    def _reference(self, stop):
        """The template of a tick's tail: tick 1's own sound (its recording less tick 0's
        ringing), continued by its model from where it comes within 20 dB of the noise."""
        z, cut, join = self.z, self.cut, self.join
        jj = join[1]
        obs = join[2] - jj
        P = self._ringing(cut[1], jj)
        own = z[jj : jj + obs] - P.take(obs)
        top = int(np.argmax(own**2))
        clear = _wiener(own, 100.0 * self.npow, self.fs)[top:] > 0.0
        n = top + (int(np.argmin(clear)) if not np.all(clear) else clear.size)
        n = max(n, top + 1)
        P = self._ringing(cut[1], jj + n)
        return np.r_[
            own[:n], _follow(self._ringing(jj + n, jj + n), P, stop, self.longest, self.fs)
        ]

    def _add(self, start, a):
        """Add ``a`` from output sample ``start`` (>= done) to the future."""
        lo = start - self.done
        if lo + a.size > self.F.size:
            self.F = np.r_[self.F, np.zeros(lo + a.size - self.F.size)]
        self.F[lo : lo + a.size] += a

    def _final(self, upto, gap):
        """Make the output final up to ``upto``, with synthesised noise from ``gap`` on."""
        n = upto - self.done
        if self.F.size < n:
            self.F = np.r_[self.F, np.zeros(n - self.F.size)]
        seg = self.F[:n].copy()
        if gap is not None and gap < upto:
            nz = self._noise(upto - gap)
            seg[gap - self.done :] += nz
            self.syn.append((gap, nz))
        self.y.append(seg)
        self.F = self.F[n:]
        self.done = upto

    def _noise(self, n):
        nz = self.noise(n, self.rng)
        k = min(self.r, nz.size)
        nz[:k] *= self.ramp[:k]
        return nz

    def _end(self):
        """Samples after ``done`` to where the deterministic part has fallen to the level at
        which the recording ends (10 ms blocks after the last tick's recorded part)."""
        n = max(1, int(round(NOISE_FRAME * self.fs)))
        pos = max(0, self.tail - self.done)
        while pos < self.F.size:
            block = self.F[pos : pos + n]
            pos += n
            if float(np.sqrt(np.mean(block * block))) <= self.level:
                break
        return min(pos, self.F.size)

    def finish(self, n_out):
        """The channel's ``n_out`` samples, with synthesised noise after the last tick."""
        self._final(max(n_out, self.done), self.gap)
        return np.concatenate(self.y)[:n_out]


def _follow(P, Q, stop, longest, fs):
    """``P - Q`` (Q may be None) in 10 ms blocks until a block's RMS is at or below
    ``stop``, at most ``longest`` samples (rounded up to a block)."""
    n = max(1, int(round(NOISE_FRAME * fs)))
    out, done = [], 0
    while done < longest:
        block = P.take(n) - (0.0 if Q is None else Q.take(n))
        out.append(block)
        done += n
        if float(np.sqrt(np.mean(block * block))) <= stop:
            break
    return np.concatenate(out) if out else np.zeros(0)


def _end_level(z, fs, noise_level):
    """RMS level at which the recording ends: its noise floor, the RMS of its last 10 ms,
    and at least END_FLOOR_DB re its peak."""
    n = max(1, int(round(NOISE_FRAME * fs)))
    last = float(np.sqrt(np.mean(z[-n:] ** 2)))
    return max(noise_level, last, float(np.max(np.abs(z))) * 10.0 ** (END_FLOOR_DB / 20.0))
