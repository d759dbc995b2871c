"""The master bus' true-peak limiter (docs/live.md): a look-ahead gain that keeps sample and
inter-sample peaks (4x, ITU-R BS.1770-4 Annex 2) at or below a ceiling; the output is the input
delayed by ``D`` frames times the gain, bit-identical while the gain is 1."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled

#: Interpolated points per sample of the true-peak estimate and taps per phase of the
#: interpolator (BS.1770-4 Annex 2: 4x, 12), and the frames it reads on each side (its reach).
OVERSAMPLING = 4
TAPS = 12
REACH = TAPS // 2
#: The interpolator's Kaiser beta: 60 dB side lobes (Kaiser's beta = 0.1102 (a - 8.7)).
KAISER_BETA = 0.1102 * (60.0 - 8.7)
#: The gain's release, dB/s: 6 dB in 0.1 s, as broadcast limiters' (50-200 ms), slow enough
#: to add no audible modulation to a modal ring.
RELEASE_DB_PER_S = 60.0
#: The detector's relative margin below the ceiling: float32 rounding (2^-24 a sample)
#: moves an interpolated point by at most sum |taps| (< 2) times that.
FLOAT32_MARGIN = 2.0**-22
#: The default look-ahead, s (or one block if shorter): 72 frames at 48 kHz, 60 of attack.
LOOKAHEAD = 0.0015
#: Fewest attack frames (a look-ahead shorter than ``2 * REACH + MIN_ATTACK`` is refused).
MIN_ATTACK = 4

#: ``ints``: frames in, last position with r < 1, window frames with m < 1, frames out
#: with a gain < 1 since the reset, D, A, channels.
I_TAKEN, I_BELOW_AT, I_BOX_BELOW, I_ACTIVE, I_DELAY, I_ATTACK, I_CHANNELS, N_INTS = range(8)
#: ``floats``: ceiling, release factor per frame, last gain, the mean's sum, least gain.
F_CEILING, F_RELEASE, F_GAIN, F_SUM, F_MIN_GAIN, N_FLOATS = range(6)


def interpolator() -> np.ndarray:
    """The interpolator's phases 1..OVERSAMPLING-1 (rows), phase ``p`` estimating ``x(q + p /
    OVERSAMPLING)`` from ``x[q - REACH + 1 + j]``: Kaiser-windowed sincs, unit gain at DC."""
    h = np.empty((OVERSAMPLING - 1, TAPS))
    k = np.arange(TAPS) - (REACH - 1)  # sample offsets from q
    for p in range(1, OVERSAMPLING):
        t = p / OVERSAMPLING - k  # time from each tap to the point, in samples
        w = np.i0(KAISER_BETA * np.sqrt(np.clip(1.0 - (t / REACH) ** 2, 0.0, None)))
        taps = np.sinc(t) * w / np.i0(KAISER_BETA)
        h[p - 1] = taps / taps.sum()
    return h


def true_peak(x: np.ndarray) -> float:
    """The limiter's true-peak estimate of a signal ``x`` ((frames[, channels]), 0 outside)."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    h = interpolator()
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    padded = np.pad(x, ((REACH - 1, REACH), (0, 0)))
    for p in range(OVERSAMPLING - 1):
        for c in range(x.shape[1]):
            y = np.convolve(padded[:, c], h[p][::-1], mode="valid")
            peak = max(peak, float(np.max(np.abs(y))) if y.size else 0.0)
    return peak


def min_delay() -> int:
    """The shortest look-ahead the limiter takes, frames."""
    return 2 * REACH + MIN_ATTACK


class LimiterState:
    """The limiter's arrays for a look-ahead of ``delay`` frames, a ``ceiling`` (linear) at
    ``samplerate`` Hz: ``ints``, ``floats``, ``taps``, input ring ``x``, rings ``r`` and ``m``."""

    def __init__(self, *, channels: int, delay: int, ceiling: float, samplerate: float):
        attack = delay - 2 * REACH
        self.ints = np.zeros(N_INTS, dtype=np.int64)
        self.floats = np.zeros(N_FLOATS)
        self.taps = np.ascontiguousarray(interpolator())
        self.x = np.zeros((delay + 1, channels))
        self.r = np.ones(attack + 2 * REACH + 1)
        self.m = np.ones(attack + 1)
        self.ints[[I_BELOW_AT, I_DELAY, I_ATTACK, I_CHANNELS]] = (-(1 << 62), delay, attack,
                                                                  channels)  # fmt: skip
        release = 10.0 ** (RELEASE_DB_PER_S / 20.0 / samplerate)
        self.floats[[F_CEILING, F_RELEASE, F_GAIN, F_SUM, F_MIN_GAIN]] = (
            ceiling * (1.0 - FLOAT32_MARGIN), release, 1.0, attack + 1.0, 1.0
        )  # fmt: skip

    def arrays(self) -> tuple:
        return self.ints, self.floats, self.taps, self.x, self.r, self.m

    @property
    def delay(self) -> int:
        return int(self.ints[I_DELAY])

    @property
    def reduction_db(self) -> float:
        """The gain reduction of the last frame out, dB (>= 0)."""
        return 0.0 - 20.0 * math.log10(float(self.floats[F_GAIN]))

    @property
    def max_reduction_db(self) -> float:
        """The largest gain reduction since the last reset, dB (>= 0)."""
        return 0.0 - 20.0 * math.log10(float(self.floats[F_MIN_GAIN]))

    @property
    def active_frames(self) -> int:
        """Frames that left with a gain below 1 since the last reset."""
        return int(self.ints[I_ACTIVE])


@compiled(nogil=True, inline="always")
def _required_gain(ints, floats, taps, x, q):
    """``r(q)``: 1, or the ceiling over the true-peak estimate at ``q`` (every channel)."""
    L, ceiling, peak = x.shape[0], floats[F_CEILING], 0.0
    for c in range(x.shape[1]):
        a = abs(x[q % L, c])
        if a > peak:
            peak = a
        for p in range(taps.shape[0]):
            acc = 0.0
            for j in range(TAPS):
                acc += taps[p, j] * x[(q - REACH + 1 + j) % L, c]
            a = abs(acc)
            if a > peak:
                peak = a
    if peak > ceiling:
        return ceiling / peak
    return 1.0


@compiled(nogil=True, inline="always")
def restart_meter(ints, floats):  # pragma: no cover - compiled
    """Start the gain reduction's meter (smallest gain, active frames) anew."""
    ints[I_ACTIVE] = 0
    floats[F_MIN_GAIN] = 1.0


@compiled(nogil=True, inline="always")
def _window_min(ints, r, u):
    """``m(u)``: the least ``r`` over ``[u - REACH, u + A + REACH]`` (exactly 1 if none < 1)."""
    if ints[I_BELOW_AT] < u - REACH:
        return 1.0
    L, least = r.shape[0], 1.0
    for q in range(u - REACH, u + ints[I_ATTACK] + REACH + 1):
        v = r[q % L]
        if v < least:
            least = v
    return least


@compiled(nogil=True)
def limit_block(state, bus, n):
    """Limit ``bus[c, 0:n]`` (float64, full scale 1) in place: each frame goes in, the frame
    ``D`` earlier comes out at the gain. ``state``: :meth:`LimiterState.arrays`."""
    ints, floats, taps, x, r, m = state
    D, A, channels = ints[I_DELAY], ints[I_ATTACK], ints[I_CHANNELS]
    Lx, Lr, Lm = x.shape[0], r.shape[0], m.shape[0]
    release, gain, total, least = (
        floats[F_RELEASE],
        floats[F_GAIN],
        floats[F_SUM],
        floats[F_MIN_GAIN],
    )
    active = 0
    for s in range(n):
        k = ints[I_TAKEN]
        for c in range(channels):
            x[k % Lx, c] = bus[c, s]
        # the newest position the interpolator can read to its end
        q = k - REACH
        rq = _required_gain(ints, floats, taps, x, q)
        r[q % Lr] = rq
        if rq < 1.0:
            ints[I_BELOW_AT] = q
        # the newest position of the mean's window, and the frame that leaves now
        u = q - A - REACH
        t = k - D
        mu, old = _window_min(ints, r, u), m[u % Lm]
        m[u % Lm] = mu
        if old < 1.0:
            ints[I_BOX_BELOW] -= 1
        if mu < 1.0:
            ints[I_BOX_BELOW] += 1
        if ints[I_BOX_BELOW] == 0:
            total = A + 1.0  # exact while the window holds only ones
            target = 1.0
        else:
            total += mu - old
            target = min(total / (A + 1), 1.0)
        gain = min(target, gain * release)
        if gain < 1.0:
            active += 1
            if gain < least:
                least = gain
        for c in range(channels):
            bus[c, s] = x[t % Lx, c] * gain if gain < 1.0 else x[t % Lx, c]
        ints[I_TAKEN] = k + 1
    floats[F_GAIN], floats[F_SUM], floats[F_MIN_GAIN] = gain, total, least
    ints[I_ACTIVE] += active
