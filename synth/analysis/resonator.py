"""Step 7 (docs/analysis.md, Method): the resonator's own predictor
(:func:`synth.analysis.whitening.resonator_predictor`) cancels the first tick's ringing, and step
5 runs again with each tick modelled over its whole response."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth.analysis.deflation import DeflationSearch, NewTick, Residual, Snapshot, solve_general
from synth.analysis.detection import delay, frame_energies, pairwise_sum
from synth.analysis.measures import WINDOW_GUARD
from synth.analysis.series import (
    ANCHOR_DB,
    BOUNCE_GROWTH,
    DOUBTFUL_DB,
    RESTITUTION_STEP,
    soonest,
)
from synth.analysis.settings import Settings
from synth.analysis.whitening import PREDICTION_FLOOR
from synth.compilation import compiled

#: Agreement with the first search's ticks, s (two sample periods at 48 kHz).
AGREEMENT = 0.00004
#: Longest lag after of a tick's filter, s: a contact up to 0.5 ms longer.
RESONATOR_POST = 0.0005
#: Least samples of the fit window per unknown filter tap.
FIT_SAMPLES_PER_TAP = 2
#: Most ticks taken whole as templates: the first and the next sure ones alone (two or three
#: sub-sample onsets span the others).
MAX_TEMPLATES = 3
#: What a tick's model leaves outside its fit window is expected at its relative error in the
#: window raised by this, dB (at most all of it).
REMAINDER_MARGIN_DB = 10.0
#: The template ends under the noise or this far under the range's floor, dB.
TEMPLATE_FLOOR_DB = 10.0
#: Spacing of hypothesised ticks, samples: the shortest filters' lags (-1 .. +2).
HYPOTHESIS_STEP = 4
#: Design matrix rows formed at once (1.4 s at 48 kHz).
FIT_ROWS = 1 << 16
#: Step 7's local background in predictor orders (a whitened response's length).
BACKGROUND_SPAN = 4


@dataclass(frozen=True)
class ModelChoice:
    """A fit of tick models on templates: its description length ``W ln(RSS) + P ln W``, the
    templates used, the lags ``-pre .. post`` (samples), the taps and the residual."""

    length: float
    templates: list
    pre: int
    post: int
    taps: np.ndarray
    residual: np.ndarray


class ResonatorResidual(Residual):
    """Step 7's residual: ticks modelled on up to :data:`MAX_TEMPLATES` templates, and ``expect``,
    what each model should leave (energy per sample)."""

    def __init__(self, r: np.ndarray, template: np.ndarray, start: int, settings: Settings,
                 *levels: float):  # fmt: skip
        """As :class:`Residual`'s (``levels``: its ``floor`` and ``noise``)."""
        super().__init__(r, template, start, settings, *levels)
        self.expect = np.zeros_like(r)
        self.post_long = max(self.post, int(round(RESONATOR_POST * settings.samplerate)))

    @property
    def longest_lag(self) -> int:
        return self.post_long

    def snapshot(self, s: int, n: int) -> Snapshot:
        q = self.q[s : s + n].copy()
        return Snapshot(s, q, self.expect[s : s + q.size].copy())

    def restore(self, snap: Snapshot) -> None:
        self.q[snap.start : snap.start + snap.q.size] = snap.q
        self.expect[snap.start : snap.start + snap.q.size] = snap.expect

    def taken_out(self, lo: int, hi: int) -> np.ndarray:
        return frame_energies(np.sqrt(self.expect[lo:hi]), self.hop, self.w)

    def remove(self, s: int, end: int, alone: int | None = None, joint=()) -> np.ndarray:
        """Fit :meth:`choose` to ``q[s:end]``, take it out and return it; ``expect`` gets its error
        raised by :data:`REMAINDER_MARGIN_DB` up to ``alone``."""
        q = self.q
        W = min(end, q.size) - s
        if W <= 0:
            return np.zeros(0)
        y = q[s : s + W].copy()
        fit = self.choose(y, [0] + [int(o) - s for o in joint])
        contrib = self._contribution(fit)
        n = min(contrib.size, q.size - s)
        q[s : s + n] -= contrib[:n]
        model = y - fit.residual
        m = W if alone is None else max(1, min(W, int(alone) - s))
        rss = float(np.dot(fit.residual[:m], fit.residual[:m]))
        fitted = float(np.dot(model[:m], model[:m]))
        eps = min(1.0, 10.0 ** (REMAINDER_MARGIN_DB / 10.0) * rss / max(fitted, 1e-300))
        self.expect[s : s + n] += eps * contrib[:n] ** 2
        return contrib

    @staticmethod
    def _contribution(fit: ModelChoice) -> np.ndarray:
        """The first tick's model of ``fit`` from its start: ``sum_j h_j T[t - l_j]``."""
        ntap = fit.pre + fit.post + 1
        contrib = np.zeros(max(T.size for T in fit.templates) + fit.post)
        for i, T in enumerate(fit.templates):
            c = np.convolve(T, fit.taps[i * ntap : (i + 1) * ntap][::-1])[fit.pre :]
            contrib[: c.size] += c
        return contrib

    def choose(self, y: np.ndarray, offsets=(0,)) -> ModelChoice:
        """The model of least description length (Rissanen 1983, Ann. Stat. 11, 416) of ticks at
        ``offsets`` in ``y``, over template counts and lags."""
        W = y.size
        K = len(offsets)
        choices = [
            (n_t, pre, post)
            for n_t in range(len(self.T), 0, -1)
            for pre, post in ((self.pre, self.post_long), (self.pre, self.post), (1, 2))
            if W >= FIT_SAMPLES_PER_TAP * K * n_t * (pre + post + 1)
        ]
        if not choices:
            n_t = max(1, min(len(self.T), W // (FIT_SAMPLES_PER_TAP * K)))
            h, res = self._fit(self.T[:n_t], y, 0, 0, offsets)
            return ModelChoice(
                W * math.log(_rss(res, y)) + K * n_t * math.log(W), self.T[:n_t], 0, 0, h, res
            )
        normal = _NormalEquations(
            self.T[: max(c[0] for c in choices)],
            y,
            max(c[1] for c in choices),
            max(c[2] for c in choices),
            offsets,
        )
        if normal.kept is not None:
            k, crit, h, res = _least_description(
                normal.G,
                normal.b,
                y,
                normal.kept,
                normal.chunks[0][0],
                np.array(choices, dtype=np.int64),
                (K, normal.n_templates, normal.pre, normal.post),
            )
            n_t, pre, post = choices[k]
            return ModelChoice(crit, self.T[:n_t], pre, post, h, res)
        best = None
        for n_t, pre, post in choices:
            P = K * n_t * (pre + post + 1)
            h, res = normal.solve(n_t, pre, post)
            crit = W * math.log(_rss(res, y)) + P * math.log(W)
            if best is None or crit < best.length:
                best = ModelChoice(crit, self.T[:n_t], pre, post, h, res)
        return best

    @staticmethod
    def _fit(Ts, y, pre, post, offsets=(0,)):
        """Least-squares filters of ``Ts`` at ``offsets`` fitting ``y``: taps, residual."""
        return _NormalEquations(Ts, y, pre, post, offsets).solve(len(Ts), pre, post)

    def take(self, s: int, n: int) -> np.ndarray:
        """Take ``q[s:s+n]`` out of ``q`` as a new template and return it."""
        T = self.q[s : s + n].copy()
        self.q[s : s + n] = 0.0
        self.T.append(T)
        return T


class _NormalEquations:
    """Normal equations of the filters (lags ``-pre .. post``) of templates ``Ts`` at ``offsets``
    fitting ``y``, formed on the rows a template reaches only, :data:`FIT_ROWS` at a time."""

    def __init__(self, Ts, y: np.ndarray, pre: int, post: int, offsets=(0,)):
        W = y.size
        longest = max(T.size for T in Ts)
        self.templates = np.zeros((len(Ts), longest))
        for t, T in enumerate(Ts):
            self.templates[t, : T.size] = T
        self.lengths = np.array([T.size for T in Ts], dtype=np.int64)
        self.offsets = np.array(offsets, dtype=np.int64)
        self.y = y
        self.n_templates, self.pre, self.post = len(Ts), pre, post
        self.n_offsets = len(offsets)
        self.chunks = _row_chunks([(o - pre, o + post + longest) for o in offsets], W)
        # the rows formed are kept for the residuals when they make one piece (a window
        # across no silence: every fit but a joint one across two drops)
        self.kept = None
        self.G = None
        self.b = None
        for lo, hi in self.chunks:
            M = self._rows(lo, hi)
            G, b = M.T @ M, M.T @ y[lo:hi]
            self.G = G if self.G is None else self.G + G
            self.b = b if self.b is None else self.b + b
            if len(self.chunks) == 1:
                self.kept = M

    def _rows(self, lo: int, hi: int) -> np.ndarray:
        """Rows ``lo .. hi - 1`` of the design matrix."""
        return _design_rows(self.templates, self.lengths, self.offsets, self.pre, self.post, lo, hi)

    def solve(self, n_t: int, pre: int, post: int) -> tuple[np.ndarray, np.ndarray]:
        """Taps and residual of the fit on the first ``n_t`` templates, lags ``-pre .. post``."""
        idx = _columns(self.n_offsets, self.n_templates, self.pre, self.post, n_t, pre, post)
        whole = idx is None
        G = self.G.copy() if whole else self.G.take(idx, axis=0).take(idx, axis=1)
        P = G.shape[0]
        G.flat[:: P + 1] += 1e-12 * np.trace(G) / P + 1e-300
        h = solve_general(G, self.b if whole else self.b[idx])
        res = self.y.copy()
        for lo, hi in self.chunks:
            M = self._rows(lo, hi) if self.kept is None else self.kept
            res[lo:hi] = self.y[lo:hi] - (M if whole else M.take(idx, axis=1)) @ h
        return h, res


@compiled()
def _least_description(G, b, y, M, lo, choices, layout):  # pragma: no cover - compiled
    """:meth:`ResonatorResidual.choose` in one compiled pass (as :meth:`_NormalEquations.solve`):
    index, length, taps and residual of the first least of ``choices``; ``layout``: ``(offsets,
    templates, pre, post)``."""
    n_offsets, n_templates, pre_all, post_all = layout
    W = y.size
    ntap_all = pre_all + post_all + 1
    floor = 1e-300 * np.dot(y, y) + 1e-300
    best, best_length = -1, 0.0
    best_h, best_res = np.zeros(0), np.zeros(0)
    for c in range(choices.shape[0]):
        n_t, pre, post = choices[c, 0], choices[c, 1], choices[c, 2]
        P = n_offsets * n_t * (pre + post + 1)
        idx = np.empty(P, dtype=np.int64)
        i = 0
        for k in range(n_offsets):
            for t in range(n_t):
                for lag in range(post_all - post, post_all + pre + 1):
                    idx[i] = (k * n_templates + t) * ntap_all + lag
                    i += 1
        Gs = np.empty((P, P))
        diag = np.empty(P)
        for r in range(P):
            for q in range(P):
                Gs[r, q] = G[idx[r], idx[q]]
            diag[r] = Gs[r, r]
        load = 1e-12 * pairwise_sum(diag, np.int64(0), P) / P + 1e-300  # int64: one specialisation
        for r in range(P):
            Gs[r, r] += load
        h = np.linalg.solve(Gs, b[idx])
        Ms = np.empty((M.shape[0], P))
        for r in range(M.shape[0]):
            for q in range(P):
                Ms[r, q] = M[r, idx[q]]
        fit = np.dot(Ms, h)
        res = y.copy()
        for r in range(M.shape[0]):
            res[lo + r] = y[lo + r] - fit[r]
        crit = W * math.log(max(np.dot(res, res), floor)) + P * math.log(W)
        if best < 0 or crit < best_length:
            best, best_length, best_h, best_res = c, crit, h, res
    return best, best_length, best_h, best_res


@compiled(nogil=True)
def _design_rows(templates, lengths, offsets, pre, post, lo, hi):  # pragma: no cover - compiled
    """Rows ``lo .. hi - 1`` of the design matrix of :class:`_NormalEquations`: ``M[i, (k n_t + t)
    ntap + j] = T_t[i - o_k - post + j]`` (0 outside ``T_t``)."""
    ntap = pre + post + 1
    n_t = templates.shape[0]
    M = np.zeros((hi - lo, offsets.size * n_t * ntap))
    for k in range(offsets.size):
        for t in range(n_t):
            base = (k * n_t + t) * ntap
            n = lengths[t]
            for r in range(hi - lo):
                first = lo + r - offsets[k] - post
                for j in range(max(0, -first), min(ntap, n - first)):
                    M[r, base + j] = templates[t, first + j]
    return M


@functools.lru_cache(maxsize=256)
def _columns(
    n_offsets: int, n_templates: int, pre_all: int, post_all: int, n_t: int, pre: int, post: int
) -> np.ndarray | None:
    """Columns of the fit on ``n_t`` templates, lags ``-pre .. post``; None for all."""
    ntap_all = pre_all + post_all + 1
    lags = np.arange(post_all - post, post_all + pre + 1)
    idx = np.concatenate(
        [(k * n_templates + t) * ntap_all + lags for k in range(n_offsets) for t in range(n_t)]
    )
    if idx.size == n_offsets * n_templates * ntap_all:
        return None
    idx.flags.writeable = False
    return idx


def _row_chunks(spans, rows: int) -> list[tuple[int, int]]:
    """The union of ``spans`` in ``0 .. rows`` as ordered chunks of :data:`FIT_ROWS`."""
    merged: list[list[int]] = []
    for lo, hi in sorted((max(0, lo), min(rows, hi)) for lo, hi in spans):
        if lo >= hi:
            continue
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return [(a, min(hi, a + FIT_ROWS)) for lo, hi in merged for a in range(lo, hi, FIT_ROWS)]


def _rss(res: np.ndarray, y: np.ndarray) -> float:
    """Residual energy, never under 1e-300 of ``y``'s (rounding)."""
    return max(float(np.dot(res, res)), 1e-300 * float(np.dot(y, y)) + 1e-300)


class ResonatorSearch(DeflationSearch):
    """Step 5 on the resonator's whitening with step 7's rules (docs/analysis.md): templates, joint
    refits, the soonest bounce, one more tick by description length, template timing. ``floor``
    None: from noise and the last tick; ``known``: the first search's onsets."""

    strict_onsets = True

    def __init__(self, *args, **kwargs):
        self.relative = False
        # the last tick's window start, and ``q`` and ``expect`` from there before its model
        # was taken out (None after the first tick and a template)
        self.prev: Snapshot | None = None
        super().__init__(*args, **kwargs)
        self.timed = [float(self.first.onset)]

    def _initial_floor(self, floor, noise, strongest):
        self.relative = floor is None
        if self.relative:
            return max(
                10.0 ** (self.settings.threshold_db / 10.0) * noise * noise * self.w,
                PREDICTION_FLOOR * strongest,
            )
        return floor

    def _template_cut(self, noise):
        return max(super()._template_cut(noise), self.floor * 10.0 ** (-TEMPLATE_FLOOR_DB / 10.0))

    def _residual(self, template, noise):
        return ResonatorResidual(self.r, template, self.s1, self.settings, self.floor, noise)

    def _separation(self, onsets, strengths):
        return soonest(onsets, strengths, self.min_sep)

    def _confirmed(self, on):
        """Whether the first search found a tick within :data:`AGREEMENT` of ``on`` (a tick even
        sooner than the series allows)."""
        if self.known.size == 0:
            return False
        return bool(np.abs(self.known - on).min() <= AGREEMENT * self.settings.samplerate)

    def _lower_floor(self, energy):
        """``e_min^2`` times the last tick's energy: ``max_drop_db`` under it."""
        if self.relative:
            e_min = self.settings.e_min
            self.residual.floor = max(self.floor, e_min * e_min * energy)

    def _onset_walk_start(self, c):
        """A frame before the first frame that cleared: not earlier remainders."""
        return max(super()._onset_walk_start(c), c.first - self.w)

    def _next_start(self, c):
        return c.first

    def _refit(self, e2, e):
        return e2 != e

    def _timing(self, start: int, model: np.ndarray, level_crossing: float) -> float:
        """The onset: the model's delay behind the template
        (:func:`~synth.analysis.detection.delay`) from its onset, else ``level_crossing``."""
        if not np.any(model):
            return level_crossing
        res = self.residual
        lag = delay(model, res.T[0], -res.pre, res.post_long)
        if lag is None:  # no peak within the filters' lags: timed by the level crossing
            return level_crossing
        return self.first.onset + (start - self.s1) + lag

    def _uncover(self, s, new, e, snap):
        """Windows from the soonest next bounce, 10 % longer each, uncover the next."""
        if not (len(self.onsets) >= 2 and new.strength >= DOUBTFUL_DB):
            return e, False
        on = new.onset
        t_last = on - self.onsets[-1]
        ratio = t_last / (self.onsets[-1] - self.onsets[-2])
        end = s + int((1.0 - RESTITUTION_STEP) * ratio * t_last)
        latest = min(e, s + int(BOUNCE_GROWTH * ratio * t_last) + self.hop)
        while end < latest:
            self.residual.remove(s, end, alone=self.after)
            c = self.residual.candidate(self.after, within=end + 2 * self.hop)
            self.residual.restore(snap)
            if c is not None:
                return max(c.first - self.hop, int(math.floor(on)) + 1), True
            end = max(end + self.hop, s + int(1.1 * (end - s)))
        return e, False

    def _clear_span(self, s: int, on: float) -> float:
        """How long the tick rings alone from ``s``: to the soonest next bounce."""
        if len(self.onsets) >= 2:
            t_last = on - self.onsets[-1]
            return (1.0 - RESTITUTION_STEP) * t_last * t_last / (self.onsets[-1] - self.onsets[-2])
        later = self.known[self.known > on + self.min_sep]
        return later[0] - s if later.size else 0.0

    def _finish(self, s, new, e, model, snap):
        """A sure tick becomes a template; else joint refit with the previous."""
        res = self.residual
        if (
            len(res.T) < MAX_TEMPLATES
            and new.strength >= ANCHOR_DB
            and self.L < self.first.end - self.s1
            and self._clear_span(s, new.onset) >= self.L + self.w
        ):
            res.restore(snap)
            self.prev = None
            return res.take(s, self.L)
        if self.prev is not None:
            res.restore(snap)
            res.restore(self.prev)
            ps = self.prev.start
            pmodel = res.remove(ps, e, joint=(s,), alone=self.after)
            self.models[-1] = pmodel[: self.settings.window].copy()
            self.timed[-1] = self._timing(ps, pmodel, self.timed[-1])
            snap = res.snapshot(s, self.L + res.longest_lag + 1)
            model = res.remove(s, e, alone=self.after)
        self.prev = snap
        return model

    def _record(self, s, model, on):
        self.timed.append(self._timing(s, model, on))

    def _timed(self):
        return np.array(self.timed)

    def _hypothesis(self):
        """One more tick against none by description length, tried every :data:`HYPOTHESIS_STEP`
        samples where the series and floor allow; strength in dB."""
        if self.prev is None or len(self.onsets) < 3:
            return None
        onsets, res = self.onsets, self.residual
        ps, psaved = self.prev.start, self.prev.q
        t_last = onsets[-1] - onsets[-2]
        ratio = t_last / (onsets[-2] - onsets[-3])
        if ratio >= 1.0:
            # a bounce longer than the one before: a tick was missed in between (a ball's
            # flights only shorten), whose response no model holds
            return None
        lo = int(math.ceil(onsets[-1])) + self._separation(onsets, self.strengths) - WINDOW_GUARD
        hi = int(math.floor(onsets[-1] + BOUNCE_GROWTH * ratio * t_last)) - WINDOW_GUARD
        end = min(self.r.size, hi + WINDOW_GUARD + int(t_last))
        if end - hi < 2 or lo > hi:
            return None
        y = np.concatenate((psaved, res.q[ps + psaved.size : end]))[: end - ps]
        null = res.choose(y).length
        places = range(lo, hi + 1, HYPOTHESIS_STEP)
        # the energies of the frames starting at every sample: a place's burst is its frames
        # at 0, hop and 2 hop, as a candidate's
        e_s = frame_energies(res.q[lo : hi + self.w + 2 * self.hop], 1, self.w)
        best = None
        for p in places:
            k = p - lo
            burst = e_s[k : k + 2 * self.hop + 1 : self.hop]
            energy = float(burst.max()) if burst.size else 0.0
            if energy < res.floor:
                continue
            crit = res.choose(y, (0, p - ps)).length + 2.0 * math.log(len(places))
            if best is None or crit < best[0]:
                best = (crit, p, energy)
        if best is None or best[0] >= null:
            return None
        crit, p, energy = best
        return NewTick(
            float(p + WINDOW_GUARD), 10.0 / math.log(10.0) * (null - crit) / y.size, energy
        )
