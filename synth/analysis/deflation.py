"""Step 5 (docs/analysis.md, Method): ticks after the first, one by one with the earlier ones taken
out of the whitened ``r``: a later tick is the first one's whitened response through a short
filter (same path, other contact force). Step 7 subclasses :class:`Residual` and
:class:`DeflationSearch`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from synth import dsp
from synth.analysis.detection import (
    ONSET_NOISE_SIGMAS,
    OnsetWalk,
    frame_energies,
    refine_onset,
)
from synth.analysis.measures import WINDOW_GUARD
from synth.analysis.series import DOUBTFUL_DB, separation, too_strong
from synth.analysis.settings import Settings
from synth.analysis.validity import MISSED_GROWTH
from synth.analysis.whitening import silence_floor
from synth.compilation import compiled

#: Lags of the FIR filter that shapes the first tick's whitened response into a later
#: tick's, s: before (onset error) and after (a longer contact than the first).
DEFLATION_PRE = 0.00006
DEFLATION_POST = 0.00017
#: A candidate's least energy over what was taken out of its frame, dB.
DEFLATION_KAPPA_DB = 0.0
#: A candidate must carry more energy than was taken out over the frames spanning this from the
#: frame before its own, s (a model a fraction of a sample off spreads its remainder).
REMAINDER_SPAN = 0.001
#: The template ends at its last frame this far above the whitened noise floor, dB.
TEMPLATE_NOISE_DB = 6.0
#: Fits of a tick's filter at most, each over a longer stretch.
DEFLATION_REFITS = 3
#: The candidate search looks first this many local backgrounds (at least 4096 samples) ahead, then
#: eight (doubled until decided); 0: the longer look only. Same answer, half the cost.
SHORT_LOOK = 2
#: A search that only locates new series (long recordings' blocks) stops this many ticks after a
#: bounce over :data:`~synth.analysis.validity.MISSED_GROWTH` times the one before: enough for the
#: new series' second tick and the bounce-order rules of step 6.
LOCATE_TICKS = 6


@dataclass(frozen=True)
class Candidate:
    """The first tick after a sample: its strongest frame's start and energy, the threshold and
    background where it cleared, and its first frame's start."""

    start: int
    energy: float
    threshold: float
    background: float
    first: int


@dataclass(frozen=True)
class NewTick:
    """A tick accepted: onset (samples), strength (dB), whitened burst energy (per frame)."""

    onset: float
    strength: float
    energy: float


@dataclass(frozen=True)
class Snapshot:
    """The residual (and step 7's expected remainders) from ``start``, saved."""

    start: int
    q: np.ndarray
    expect: np.ndarray | None


@dataclass(frozen=True)
class FirstTick:
    """Step 3's first tick: onset (samples), strength (dB), whitened burst energy, and the end of
    its response, the template (samples)."""

    onset: float
    strength: float
    energy: float
    end: int


@dataclass(frozen=True)
class SearchOutcome:
    """A deflating search's onsets (samples), strengths (dB), residual, models, ringing left (power
    ratio), step 7's timed onsets (or None) and whether it stopped early."""

    onsets: np.ndarray
    strengths: np.ndarray
    residual: np.ndarray
    models: list
    ringing_left: float
    timed: np.ndarray | None
    stopped: bool = False


def running_median(d: np.ndarray, size: int) -> np.ndarray:
    """Running median of ``d`` over ``size`` values, ends extended (as
    ``scipy.ndimage.median_filter(d, size, mode="nearest")``), by a sorted window."""
    if d.size == 0:
        return np.zeros(0)
    return _running_median(np.ascontiguousarray(d, dtype=np.float64), int(size))


@compiled(nogil=True)
def _running_median(d, size):  # pragma: no cover - compiled
    n = d.size
    half = size // 2
    out = np.empty(n)
    win = np.empty(size)
    for j in range(size):
        win[j] = d[min(max(j - half, 0), n - 1)]
    win.sort()
    out[0] = win[half]
    for i in range(1, n):
        gone = d[min(max(i - 1 - half, 0), n - 1)]
        new = d[min(max(i - half + size - 1, 0), n - 1)]
        if new != gone:
            lo, hi = 0, size - 1  # the place of a value equal to the one leaving
            while lo < hi:
                mid = (lo + hi) // 2
                if win[mid] < gone:
                    lo = mid + 1
                else:
                    hi = mid
            j = lo
            if new > gone:  # the values between move down over it
                while j + 1 < size and win[j + 1] < new:
                    win[j] = win[j + 1]
                    j += 1
            else:
                while j > 0 and win[j - 1] > new:
                    win[j] = win[j - 1]
                    j -= 1
            win[j] = new
        out[i] = win[half]
    return out


def solve_general(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``G^-1 b`` by LAPACK ``dgesv`` (as ``numpy.linalg.solve`` without its checks' cost); ``G`` is
    overwritten. Raises ``numpy.linalg.LinAlgError`` when ``G`` is singular."""
    from scipy.linalg import lapack

    _, _, h, info = lapack.dgesv(G, b, overwrite_a=True, overwrite_b=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular normal equations (dgesv info={info})")
    return h


class Rules(NamedTuple):
    """Parameters of :func:`_rules`: background length ``bg`` (frames), whitened ``noise`` and
    ``floor`` (energies per frame), margins ``thr`` and ``kappa`` (power ratios), memory ``fade``
    per frame and ``rise`` (log10 units), remainder frames ``span``, and the frames of the first
    tick's onset ``origin`` and of its template's end ``cut``."""

    bg: int
    noise: float
    thr: float
    fade: float
    rise: float
    floor: float
    kappa: float
    span: int
    origin: int
    cut: int


@compiled(nogil=True)
def _rules(d, sub, lead, first, rules):  # pragma: no cover - compiled
    """Frames ``k >= first`` of ``d`` over the largest of: the past's median (frames ``k-2-bg ..
    k-3``, at least ``noise``) times ``thr``, the fading memory raised by ``rise``, ``floor``,
    ``kappa`` times ``sub``; carrying over ``kappa`` times what was taken out over ``k-1 ..
    k+span-2``. Past the template's end (``cut``), while the past reaches into it, the median is
    that of ``lead`` from ``origin`` on (:meth:`Residual.background_frames`). Returns them, the
    thresholds and backgrounds."""
    bg, noise, thr, fade, rise, floor, kappa, span, origin, cut = rules
    n = d.size
    a = max(0, first - bg - 3)
    med = _running_median(d[a:], bg) if a < n else np.zeros(0)
    past_med = np.full(n, np.inf)
    threshold = np.empty(n)
    memory = np.empty(n)
    m = -np.inf
    for k in range(n):
        v = np.log10(d[k]) + k * fade
        if v > m:
            m = v
        memory[k] = m
    half = bg // 2
    for k in range(n):
        j = k - 2 - half - 1
        b0 = max(origin, k - 2 - bg, 0)
        if k >= first and cut <= k < cut + bg + 2 and b0 < k - 2:
            past_med[k] = max(np.median(lead[b0 : k - 2]), noise)
        elif j >= half and k >= first:
            past_med[k] = max(med[j - a], noise)
        t = past_med[k] * thr if np.isfinite(past_med[k]) else 0.0
        past = 10.0 ** (memory[k - 2] - k * fade + rise) if k >= 2 else 0.0
        t = max(t, past)
        t = max(t, floor)
        threshold[k] = max(t, sub[k] * kappa)
    hits = np.empty(n, dtype=np.int64)
    count = 0
    for k in range(max(first, 0), n):
        if not d[k] >= threshold[k]:
            continue
        near = 0.0
        taken = 0.0
        for i in range(max(0, k - 1), min(n, k + span - 1)):
            near += d[i]
            taken += sub[i]
        if near >= taken * kappa:
            hits[count] = k
            count += 1
    return hits[:count], threshold, past_med


class Residual:
    """The whitened signal ``r`` less the ticks found so far (the template ``T`` through
    least-squares FIR filters); ``r - q`` is what was taken out."""

    def __init__(
        self,
        r: np.ndarray,
        template: np.ndarray,
        start: int,
        settings: Settings,
        floor: float,
        noise: float,
    ):
        fs, hop = settings.samplerate, settings.hop
        self.r = r
        self.q = r.copy()
        self.T = [template]
        self.hop = hop
        self.w = settings.frame
        self.bg = max(3, int(round(settings.background * fs / hop)))
        self.thr = 10.0 ** (settings.threshold_db / 10.0)
        self.rise = settings.rise_db / 10.0
        self.fade = settings.release * 1000.0 * hop / fs / 10.0  # log10 units per frame
        self.floor = floor
        self.kappa = 10.0 ** (DEFLATION_KAPPA_DB / 10.0)
        self.noise = noise * noise * self.w  # energy per frame of the whitened noise floor
        self.span = max(2, int(round(REMAINDER_SPAN * fs / hop)))
        self.pre = max(1, int(round(DEFLATION_PRE * fs)))
        self.post = max(1, int(round(DEFLATION_POST * fs)))
        self.q[start : start + template.size] -= template
        # the first tick's onset and its template's end, where its ringing stops being taken out;
        # None where the lead-in holds sound, the background of the ticks after it as of the
        # first (:meth:`background_frames`)
        self.origin = start if self._silent_lead_in(start) else None
        self.template_end = start + template.size

    def _silent_lead_in(self, start: int) -> bool:
        """Whether the background's span before sample ``start`` (the first onset) holds no frame
        over the whitened noise floor nor within the dynamic range (a render's digital silence):
        no sound, so no background of the ringing after it (:meth:`background_frames`). A lead-in
        that holds sound (a room's noise and reverberation) is the background a tick rises from."""
        lead = frame_energies(self.r[max(0, start - self.bg * self.hop) : start], self.hop, self.w)
        return not np.any(lead > max(self.noise, self.floor or 0.0))

    @property
    def longest_lag(self) -> int:
        """The longest lag of any filter fitted, samples."""
        return self.post

    def snapshot(self, s: int, n: int) -> Snapshot:
        """``q[s:s+n]``, saved."""
        return Snapshot(s, self.q[s : s + n].copy(), None)

    def restore(self, snap: Snapshot) -> None:
        """Put back what :meth:`snapshot` saved."""
        self.q[snap.start : snap.start + snap.q.size] = snap.q

    def taken_out(self, lo: int, hi: int) -> np.ndarray:
        """Energy per frame over ``[lo, hi)`` of all that the earlier ticks' models took out."""
        return frame_energies(self.r[lo:hi] - self.q[lo:hi], self.hop, self.w)

    def candidate(self, after: int, within: int | None = None) -> Candidate | None:
        """The first tick in ``q`` at or after sample ``after``, or None (also when it starts after
        ``within``); a short look first, kept where no later frame changes it."""
        hop, bg = self.hop, self.bg
        lo = max(0, after - (4 * bg + 2) * hop)
        first = -(-(after - lo) // hop)
        if within is not None and not self._clears_by(lo, first, within):
            return None
        chunk = max(8 * bg * hop, 4096)
        # a shorter look first, whose answer is kept only where no frame beyond it decides it
        # (the same as the longer look's): most candidates lie within a bounce
        short = max(SHORT_LOOK * bg * hop, 4096)
        if SHORT_LOOK and after + short < min(self.q.size, after + chunk):
            hi = after + short
            d = frame_energies(self.q[lo:hi], hop, self.w)
            found = self._first_clearing(d, self.taken_out(lo, hi), first, lo, settled=True)
            if found is not None:
                return found
        while True:
            hi = min(self.q.size, after + chunk)
            d = frame_energies(self.q[lo:hi], hop, self.w)
            if d.size == 0:
                return None
            found = self._first_clearing(d, self.taken_out(lo, hi), first, lo)
            if found is not None:
                return found
            if hi >= self.q.size:
                return None
            chunk *= 2

    def _clears_by(self, lo: int, first: int, within: int) -> bool:
        """Whether a frame from ``first`` (0 at ``lo``) clears the rules by ``within``."""
        last = (within - lo) // self.hop
        if last < first:
            return False
        hi = min(self.q.size, lo + (last + self.span) * self.hop + self.w)
        d = frame_energies(self.q[lo:hi], self.hop, self.w)
        hit = self._hits(d, self.taken_out(lo, hi), first, lo)[0]
        return bool(hit.size) and int(hit[0]) <= last

    def _hits(
        self, d: np.ndarray, sub: np.ndarray, first: int, lo: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The frames of ``d`` (frame 0 at ``lo``) clearing the rules, their thresholds and
        backgrounds."""
        scalars = (self.noise, self.thr, self.fade, self.rise, self.floor, self.kappa)
        if self.origin is None:  # the median rule over the past alone
            origin, cut, past = 0, d.size, d
        else:
            origin = (self.origin - lo) // self.hop
            cut = (self.template_end - lo) // self.hop
            past = self.background_frames(d, lo)
        rules = Rules(self.bg, *map(float, scalars), self.span, int(origin), int(cut))
        d, sub, past = (np.ascontiguousarray(a, dtype=np.float64) for a in (d, sub, past))
        return _rules(d, sub, past, int(first), rules)

    def background_frames(self, d: np.ndarray, lo: int) -> np.ndarray:
        """The frame energies (frame 0 at ``lo``) a frame past the first tick's template rises
        from, after a silent lead-in (:meth:`_silent_lead_in`): ``d``, but over the template's
        span those of ``r``: beyond the template's end a frame rises from the first tick's
        ringing, whose level there is ``r``'s, not the residual's (zero by construction)."""
        a = max(lo, self.origin)
        b = min(lo + (d.size - 1) * self.hop + self.w, self.template_end)
        if b <= a:
            return d
        z = self.q[lo : lo + (d.size - 1) * self.hop + self.w].copy()
        z[a - lo : b - lo] = self.r[a:b]
        return frame_energies(z, self.hop, self.w)

    def _first_clearing(
        self, d: np.ndarray, sub: np.ndarray, first: int, lo: int, settled: bool = False
    ) -> Candidate | None:
        """The first frame from ``first`` of ``d`` (frame 0 at ``lo``) that clears the rules, at its
        local maximum; with ``settled``, None unless later frames cannot change it."""
        hit, threshold, past_med = self._hits(d, sub, first, lo)
        if not hit.size or (settled and hit[0] + self.span - 2 >= d.size):
            return None
        first_hit = m = int(hit[0])
        while m + 1 < d.size and d[m + 1] > d[m]:
            m += 1  # on to the frame's local maximum
        if settled and m + 1 >= d.size:
            return None
        noise = past_med[m] if np.isfinite(past_med[m]) else threshold[m] / self.thr
        return Candidate(
            lo + m * self.hop,
            float(d[m]),
            float(max(threshold[first_hit], 1e-300)),
            float(noise),
            lo + first_hit * self.hop,
        )

    def remove(self, s: int, end: int, alone: int | None = None) -> np.ndarray:
        """Fit ``q[s:end] ~ h * T`` (lags ``-pre .. post``; one tap in a short window), take it out
        of ``q`` from ``s`` on and return it. ``alone``: step 7 only."""
        q = self.q
        W = min(end, q.size) - s
        if W <= 0:
            return np.zeros(0)
        T = self.T[0]
        pre, post = self.pre, self.post
        if W < 2 * (pre + post + 1):
            pre = post = 0
        ntap = pre + post + 1
        # M[i, j] = T[i - l_j] with lags l_j = post - j
        Tp = np.concatenate((np.zeros(post), T[: W + pre], np.zeros(pre + max(0, W - T.size))))
        M = np.lib.stride_tricks.sliding_window_view(Tp, ntap)[:W]
        G = M.T @ M
        G[np.diag_indices(ntap)] += 1e-9 * np.trace(G) / ntap + 1e-300
        h = solve_general(G, M.T @ q[s : s + W])
        # contribution at s + t: sum_j h_j T[t - l_j]
        contrib = np.convolve(T, h[::-1])[pre:]
        n = min(contrib.size, q.size - s)
        q[s : s + n] -= contrib[:n]
        return contrib


class DeflationSearch:
    """Step 5, tick by tick on the residual; ``anchors`` (onsets, strengths): step 3's sure ticks,
    none passed over; ``floor``: the dynamic range's (energy per frame)."""

    def __init__(
        self,
        r: np.ndarray,
        settings: Settings,
        first: FirstTick,
        anchors,
        floor: float | None,
        strongest: float,
        known=(),
    ):
        self.settings = settings
        self.r = r
        self.hop, self.w = settings.hop, settings.frame
        self.min_sep = settings.min_separation
        self.first = first
        self.s1 = max(int(math.floor(first.onset)) - WINDOW_GUARD, 0)
        template = r[self.s1 : max(first.end, self.s1 + 1)].copy()
        span = int(round(settings.background * settings.samplerate))
        noise = max(dsp.noise_floor(r, settings.samplerate), silence_floor(r, self.w, span))
        e_t = frame_energies(template, self.hop, self.w)
        self.ringing_left = (
            float(np.median(e_t[e_t.size // 2 :]) / e_t.max())
            if e_t.size > 1 and e_t.max() > 0.0
            else 0.0
        )
        self.floor = self._initial_floor(floor, noise, strongest)
        # the template ends where it sinks into the noise (or under the floor): beyond, taking
        # it out of a later tick would only add its noise
        loud = np.nonzero(e_t > self._template_cut(noise))[0]
        if loud.size:
            template = template[: min(template.size, int(loud[-1]) * self.hop + self.w)]
        self.residual = self._residual(template, noise)
        self.L = template.size
        self.onsets = [float(first.onset)]
        self.strengths = [float(first.strength)]
        self.energies = [float(first.energy)]
        self.models = [template[: settings.window].copy()]
        self.anchor_on, self.anchor_strength = anchors
        self.known = np.asarray(known, dtype=float)
        self.after = int(math.floor(first.onset)) + self.min_sep

    # -- what step 7 changes

    def _initial_floor(self, floor: float | None, noise: float, strongest: float) -> float:
        """The floor of the detection (energy per frame): the dynamic range's."""
        return floor

    def _template_cut(self, noise: float) -> float:
        """Frame energy under which the template has sunk into the whitened noise."""
        return 10.0 ** (TEMPLATE_NOISE_DB / 10.0) * noise * noise * self.w

    def _residual(self, template: np.ndarray, noise: float) -> Residual:
        """The residual from which the ticks are taken out."""
        return Residual(self.r, template, self.s1, self.settings, self.floor, noise)

    def _separation(self, onsets, strengths) -> int:
        """Shortest plausible bounce after the last of ``onsets``."""
        return separation(onsets, strengths, self.min_sep, self.settings.e_min)

    def _confirmed(self, on: float) -> bool:
        """Whether an earlier search confirms a tick at ``on`` (step 7 only)."""
        return False

    def _lower_floor(self, energy: float) -> None:
        """Set the floor after a tick of whitened energy ``energy`` (step 7 only)."""

    def _hypothesis(self) -> NewTick | None:
        """One more tick when no candidate clears the rules (step 7 only)."""
        return None

    def _onset_walk_start(self, c: Candidate) -> int:
        """The onset walk goes back no further than the previous tick."""
        return int(math.floor(self.onsets[-1])) + 1

    strict_onsets = False

    def _next_start(self, c: Candidate) -> int:
        """Where the next tick shows: its candidate frame."""
        return c.start

    def _refit(self, e2: int, e: int) -> bool:
        """Whether to refit over ``e2``: the next tick was this one's remainder."""
        return e2 > e

    def _uncover(self, s: int, new: NewTick, e: int, snap: Snapshot) -> tuple[int, bool]:
        """The end of the tick's fit window, and whether a search uncovered it (step 7)."""
        return e, False

    def _finish(
        self, s: int, new: NewTick, e: int, model: np.ndarray, snap: Snapshot
    ) -> np.ndarray:
        """The tick's model once fitted (step 7 refits it)."""
        return model

    def _record(self, s: int, model: np.ndarray, on: float) -> None:
        """Record what step 7 keeps of an accepted tick."""

    def _timed(self) -> np.ndarray | None:
        """The onsets timed against the first tick's template (step 7 only)."""
        return None

    # -- the search

    def run(self, locate: bool = False) -> SearchOutcome:
        """The ticks after the first; with ``locate``, stop :data:`LOCATE_TICKS` ticks into a new
        series."""
        self._lower_floor(self.energies[-1])
        silence = None  # index of the first tick after such a silence
        stopped = False
        while True:
            c = self.residual.candidate(self.after)
            anchor = self._passed_anchor(c)
            if anchor is not None:
                new = self._anchor_tick(anchor)
            elif c is None:
                new = self._hypothesis()
                if new is None:
                    break
            else:
                new = self._candidate_tick(c)
                if new is None:
                    self.after = c.start + self.hop  # part of the previous tick's response
                    continue
            self._add(new)
            if locate and silence is None and self._after_silence():
                silence = len(self.onsets) - 1
            if silence is not None and len(self.onsets) > silence + LOCATE_TICKS:
                stopped = True
                break
        return SearchOutcome(
            np.array(self.onsets),
            np.array(self.strengths),
            self.residual.q,
            self.models,
            self.ringing_left,
            self._timed(),
            stopped,
        )

    def _after_silence(self) -> bool:
        """Whether the last tick's bounce is over :data:`MISSED_GROWTH` times the one before."""
        on = self.onsets
        return len(on) >= 3 and on[-1] - on[-2] > MISSED_GROWTH * (on[-2] - on[-3])

    def _passed_anchor(self, c: Candidate | None) -> int | None:
        """The next sure tick of step 3's series when the search would pass over it."""
        nxt = np.nonzero(self.anchor_on > self.onsets[-1] + self.min_sep)[0]
        a = int(nxt[0]) if nxt.size else None
        if a is not None and (c is None or self.anchor_on[a] < c.start - self.min_sep):
            return a
        return None

    def _burst(self, on: float) -> np.ndarray:
        """Frame energies of ``q`` over the frames holding the first samples from onset ``on``."""
        i0 = int(math.floor(on))
        w, hop = self.w, self.hop
        return frame_energies(self.residual.q[max(0, i0 - w + 1) : i0 + w + 2 * hop], hop, w)

    def _anchor_tick(self, a: int) -> NewTick:
        on, strength = float(self.anchor_on[a]), float(self.anchor_strength[a])
        burst = self._burst(on)
        return NewTick(on, strength, float(burst.max()) if burst.size else 0.0)

    def _candidate_tick(self, c: Candidate) -> NewTick | None:
        """The candidate's onset and energy, or None when the series rejects it (too soon or too
        strong) and no sure tick lies there."""
        s = self.settings
        lo = self._onset_walk_start(c)
        hi = min(self.r.size, c.start + self.w + 2 * self.hop)
        sigma = ONSET_NOISE_SIGMAS * math.sqrt(c.background / self.w)
        # a doubtful candidate (its frame under DOUBTFUL_DB over its threshold) may be a slow
        # contact whose start transient the noise's level parts from its end's
        doubtful = 10.0 * math.log10(c.energy / c.threshold) < DOUBTFUL_DB
        on = lo + refine_onset(
            self.residual.q[lo:hi],
            max(0, c.start - self.hop - lo),
            hi - lo,
            OnsetWalk(
                s.onset_fraction,
                s.onset_gap,
                sigma,
                strict=self.strict_onsets,
                weak_gap=s.weak_onset_gap if doubtful else None,
            ),
        )
        burst = self._burst(on)
        energy = max(c.energy, float(burst.max())) if burst.size else c.energy
        near = np.abs(self.anchor_on - on) < self.min_sep
        too_soon = on - self.onsets[-1] < self._separation(self.onsets, self.strengths)
        if not near.any() and (
            (too_soon and not self._confirmed(on))
            or too_strong(self.onsets, self.strengths, self.energies, on, energy)
        ):
            return None
        strength = 10.0 * math.log10(energy / c.threshold)
        if near.any():
            strength = max(strength, float(self.anchor_strength[near].max()))
        return NewTick(on, strength, energy)

    def _fit_end(self, s: int) -> int:
        """End of a fit window from ``s``: where the next tick shows, at most the template."""
        nxt = self.residual.candidate(self.after, within=s + self.L + self.hop)
        if nxt is None:
            return s + self.L
        return min(s + self.L, self._next_start(nxt) - self.hop)

    def _add(self, new: NewTick) -> None:
        """Model the new tick, take it out of the residual, and record it."""
        self._lower_floor(new.energy)
        on = new.onset
        s = max(int(math.floor(on)) - WINDOW_GUARD, 0)
        self.after = int(math.floor(on)) + self._separation(
            self.onsets + [on], self.strengths + [new.strength]
        )
        model = self._model(s, new)
        self.onsets.append(float(on))
        self.strengths.append(new.strength)
        self.energies.append(float(new.energy))
        self.models.append(model[: self.settings.window].copy())
        self._record(s, model, float(on))

    def _model(self, s: int, new: NewTick) -> np.ndarray:
        """Fit the tick's model up to the next tick and take it out; if that removed what looked
        like the next tick (its own remainder), fit again longer."""
        e = self._fit_end(s)
        snap = self.residual.snapshot(s, self.L + self.residual.longest_lag + 1)
        e, uncovered = self._uncover(s, new, e, snap)
        model = self.residual.remove(s, e, alone=self.after)
        for _ in range(0 if uncovered else DEFLATION_REFITS - 1):
            e2 = self._fit_end(s)
            if not self._refit(e2, e):
                break
            self.residual.restore(snap)
            e = e2
            model = self.residual.remove(s, e, alone=self.after)
        return self._finish(s, new, e, model, snap)
