"""One channel of :mod:`synth.stimuli.alter`: each tick's own sound (the recording less the
earlier ticks' predicted ringing) laid at its new time with its gain, continued by the
prediction models, the recorded noise handed over to synthesised noise (docs/analysis.md,
"Altering a recording")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.stimuli.prediction import (
    NOISE_FRAME,
    SMOOTHING,
    NoiseModel,
    Ringing,
    fit_model,
    wiener_gain,
)

#: After the last tick, the output stops at the recording's end level, at least this far under
#: its peak, dB, at most MAX_TAIL s after that tick.
END_FLOOR_DB = -80.0
MAX_TAIL = 60.0


@dataclass(frozen=True)
class TickLayout:
    """Where every tick is cut, joined and laid anew, samples, for every channel: ``cut``, GUARD
    before each onset (fits end, prediction starts); ``join`` and ``join_new``, LEAD before it
    (its own sound starts; in the recording and the output); each kept tick's ``gain`` and
    ``speed`` over tick 1's (the template's scale); ``excluded`` and ``excluded_new``:
    ``(start, stop)`` under each contact; ``lead``: LEAD as used, s."""

    cut: np.ndarray
    join: np.ndarray
    join_new: np.ndarray
    gain: np.ndarray
    speed: np.ndarray
    excluded: list
    excluded_new: list
    lead: float


@dataclass(frozen=True)
class _OwnSound:
    """A tick's own sound: ``recorded``, ``observed`` samples from its join; its continuation
    ``continued`` from sample ``continued_from``, crossfaded over ``[start - fade, start)``."""

    recorded: np.ndarray
    observed: int
    start: int
    fade: int
    continued: np.ndarray
    continued_from: int


class SplicedChannel:
    """Recording ``z`` at ``fs`` Hz re-laid by ``layout``, in time order: ``y`` is final up to
    ``done``, ``F`` holds what the ticks so far still sound after it; :meth:`finish` ends it;
    ``rng`` draws its synthesised noise."""

    def __init__(self, z, fs, layout: TickLayout, rng):
        self.z, self.fs = z, fs
        cut, join, join_new, gain = layout.cut, layout.join, layout.join_new, layout.gain
        self.cut, self.join, self.join_new = cut, join, join_new
        self.gain, self.speed = gain, layout.speed
        self.excluded, self.excluded_new = layout.excluded, layout.excluded_new
        self.N, self.M = cut.size, gain.size
        self.noise = NoiseModel(z, fs)
        self.level = _end_level(z, fs, self.noise.level)
        self.i0 = self._first_changed()
        self.unchanged = self.i0 == self.M
        if self.unchanged:
            return
        self.models = {}
        self.npow = self.noise.level**2
        r = max(1, int(round(layout.lead * fs)))  # ramps: the lead
        self.r = r
        self.ramp = 0.5 * (1.0 - np.cos(np.pi * (np.arange(r) + 0.5) / r))  # 0 -> 1
        self.lx = max(r, int(round(SMOOTHING * fs)))  # crossfade to a tick's continuation
        self.stop = 0.01 * self.level  # contributions are followed 40 dB under the end
        self.longest = int(round(MAX_TAIL * fs))
        self.rng = rng
        self.y, self.done, self.F = [z[: join[self.i0]].copy()], join[self.i0], np.zeros(0)
        self.syn = []  # (start, samples) of synthesised noise
        self.ref = self._reference(self.stop * min(1.0, float(np.min(self.speed[1:]))))
        for j in range(self.i0, self.M):
            latest, at = self._lay(j)
        self.tail = join_new[self.M - 1] + latest  # deterministic after this, but for noise
        self.gap = join_new[self.M - 1] + at  # synthesised noise from here on
        self.end = self.done + self._end()

    def _first_changed(self):
        """The first tick laid anew (the output is the recording before it)."""
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
        """:func:`fit_model` of the recording before sample q, fitted once."""
        if q not in self.models:
            self.models[q] = fit_model(self.z, q, self.fs, self.excluded)
        return self.models[q]

    def _ringing(self, q, at):
        """The recording's ringing predicted from before sample q, from ``at`` on."""
        P = Ringing(self._model(q)[0], self.z[:q])
        P.take(at - q)
        return P

    def _own_sound(self, j, need) -> _OwnSound:
        """Tick j's own sound as recorded (join to the next cut, with its noise) and its
        continuation, at least ``need`` samples from the join."""
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
        loud = wiener_gain(own, 10.0 * self.npow, fs) > 0.0
        top = int(np.argmax(own**2)) if obs > 0 else 0
        sink = top + int(np.argmin(loud[top:])) if not np.all(loud[top:]) else obs
        q = jj + obs
        if sink == obs and q < z.size and self._model(q)[1]:
            # the recording's ringing after q (every tick up to j) less that of the earlier
            # ticks: own_j rung on alone, continuing it where it stops
            d = _follow(self._ringing(q, q), Pj, self.stop, max(0, need - obs), fs)
            return _OwnSound(own, obs, obs, 0, d, obs)
        # a tick recorded too briefly or too weakly to be continued from its own recording:
        # the template (tick 1's own sound) at its impact speed
        st = max(min(sink, obs), r)
        k = min(self.lx, st - r)
        return _OwnSound(own, obs, st, k, self.speed[j] * self.ref[st - k : max(st, need)], st - k)

    def _rebase(self, j):
        """No onset within the reach of tick j's model: the output's ringing is continued from
        the output itself."""
        if j >= self.M:
            return False
        a = self._model(self.cut[j])[0]
        reach = self.join_new[j] - self.excluded_new[j - 1][1]
        return j == self.i0 or reach >= (0 if a is None else a.size - 1)

    def _lay(self, j):
        """Lay tick j's own sound times its gain at its new join; ``(latest, at)``: where its
        recorded part ends and its recorded noise is handed over, samples after the join."""
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
            self.F = _follow(Ringing(self._model(self.cut[j])[0], yp), None, self.stop, need, fs)
        sound = self._own_sound(j, need)
        own, obs, st, k = sound.recorded, sound.observed, sound.start, sound.fade
        d, d0 = sound.continued, sound.continued_from
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
        w[:obs] = wiener_gain(own, npow, fs)
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
        """The template: tick 1's own sound, continued by its model within 20 dB of the noise."""
        z, cut, join = self.z, self.cut, self.join
        jj = join[1]
        obs = join[2] - jj
        P = self._ringing(cut[1], jj)
        own = z[jj : jj + obs] - P.take(obs)
        top = int(np.argmax(own**2))
        clear = wiener_gain(own, 100.0 * self.npow, self.fs)[top:] > 0.0
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
        """Samples after ``done`` to where the deterministic part falls to the end level."""
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
    """``P - Q`` (Q None: 0) in 10 ms blocks to one at RMS ``stop``, at most ``longest``."""
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
    """The recording's end level: noise floor, last 10 ms' RMS, at least END_FLOOR_DB re peak."""
    n = max(1, int(round(NOISE_FRAME * fs)))
    last = float(np.sqrt(np.mean(z[-n:] ** 2)))
    return max(noise_level, last, float(np.max(np.abs(z))) * 10.0 ** (END_FLOOR_DB / 20.0))
