"""The rules of a bounce series (the thesis, docs/physics.md, References, section 3.1). Onsets in
samples, strengths in dB."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled

#: A bounce over this many times the previous one breaks a series (room for the contact time,
#: growing as the ball slows, and a missed tick).
BOUNCE_GROWTH = 1.5
#: Candidates searched for the longest bounce series from the first tick.
SERIES_HORIZON = 64
#: A candidate more than this above the energy its bounce time allows (``(t_n / t_(n-1))^2`` times
#: the last tick's) is no bounce, dB: 3 dB for a remainder as large as the tick, 0.4 dB for a
#: background 10 dB under the threshold, rounded up.
MAX_EXCESS_DB = 6.0
#: Ticks this far above their threshold are sure, dB (100 times in energy, well above a remainder or
#: a reflection): no bounce-order rule drops them.
ANCHOR_DB = 20.0
#: Largest relative change of the restitution from one bounce to the next (largest where the contact
#: time is a sizeable part of the bounce, a steel ball on a thin board).
RESTITUTION_STEP = 0.25
#: Ticks weaker than this (``strength``, dB) are doubtful.
DOUBTFUL_DB = 6.0


def separation(onsets, strengths, min_sep: int, e_min: float) -> int:
    """Shortest plausible bounce (step 5): ``min_sep``, or ``e_min`` times the last."""
    if len(onsets) < 2 or strengths[-1] < DOUBTFUL_DB:
        return min_sep
    return max(min_sep, int(math.ceil(e_min * (onsets[-1] - onsets[-2]))))


def soonest(onsets, strengths, min_sep: int) -> int:
    """Shortest plausible bounce after the last of ``onsets`` in step 7: ``(1 - RESTITUTION_STEP)``
    times the last restitution times the last bounce after a trusted tick; else ``min_sep``."""
    if len(onsets) < 3 or strengths[-1] < DOUBTFUL_DB:
        return min_sep
    t = onsets[-1] - onsets[-2]
    return max(1, int(math.ceil((1.0 - RESTITUTION_STEP) * t * t / (onsets[-2] - onsets[-3]))))


def too_strong(onsets, strengths, energies, on: float, energy: float) -> bool:
    """Whether a candidate at ``on`` (energy ``energy``) is :data:`MAX_EXCESS_DB` over ``(t_n /
    t_(n-1))^2`` times the last trusted tick's energy."""
    if len(onsets) < 2 or strengths[-1] < DOUBTFUL_DB:
        return False
    ratio = (on - onsets[-1]) / (onsets[-1] - onsets[-2])
    return energy > energies[-1] * ratio * ratio * 10.0 ** (MAX_EXCESS_DB / 10.0)


def bounce_series(onsets: np.ndarray, e_min: float, sure: np.ndarray | None = None) -> list[int]:
    """Indices of the longest bounce series from the first tick (step 3), by dynamic programming
    over the first :data:`SERIES_HORIZON`; ``sure`` bounds its second tick (:func:`last_second`)."""
    t = np.asarray(onsets[:SERIES_HORIZON], dtype=float)
    n = t.size
    if n < 3:
        return list(range(n))
    latest = n - 1 if sure is None else last_second(t, np.asarray(sure[:SERIES_HORIZON]), e_min)
    # best[i, j]: most ticks in a series from tick 0 ending ..., t_i, t_j; second[i, j]:
    # its second tick; back[i, j]: the tick before t_i
    best, second, back = _series_tables(t, latest, e_min, BOUNCE_GROWTH)
    ends = np.argwhere(best == best.max())
    i, j = min(ends, key=lambda ij: (second[ij[0], ij[1]], ij[1]))
    chain = [int(j), int(i)]
    while back[i, j] >= 0:
        i, j = back[i, j], i
        chain.append(int(i))
    if chain[-1] != 0:
        chain.append(0)
    return chain[::-1]


@compiled(nogil=True)
def _series_tables(t, latest, e_min, growth):  # pragma: no cover - compiled
    """:func:`bounce_series`' tables: ``best[i, j]`` (ticks ending t_i, t_j), ``second[i, j]`` and
    ``back[i, j]`` (-1: none)."""
    n = t.size
    best = np.zeros((n, n), dtype=np.int64)
    second = np.zeros((n, n), dtype=np.int64)
    back = np.full((n, n), -1, dtype=np.int64)
    for j in range(1, latest + 1):
        best[0, j] = 2
    for j in range(1, n):
        second[0, j] = j
    for i in range(1, n - 1):
        for j in range(i + 1, n):
            bounce = t[j] - t[i]
            # the bounce before, t_i - t_k, must lie in [bounce / growth, bounce / e_min]
            lo = np.searchsorted(t[:i], t[i] - bounce / e_min, side="left")
            hi = np.searchsorted(t[:i], t[i] - bounce / growth, side="right")
            m = 0
            k = -1
            for c in range(lo, hi):
                if best[c, i] > m or (best[c, i] == m and m > 0 and second[c, i] < second[k, i]):
                    m = best[c, i]
                    k = c
            if m == 0:
                continue
            best[i, j] = m + 1
            second[i, j] = second[k, i]
            back[i, j] = k
    return best, second, back


def last_second(t: np.ndarray, sure: np.ndarray, e_min: float) -> int:
    """Latest possible second tick: the first sure one that the next sure one follows in bounce
    order (three are a series, not a response); else the last."""
    idx = np.nonzero(sure)[0]
    idx = idx[idx > 0]
    for c, d in zip(idx[:-1], idx[1:]):
        if _in_order(t, [0, c, d], e_min):
            return int(c)
    return t.size - 1


def _in_order(on, kept, e_min) -> bool:
    """Whether the last bounce of ``kept`` is within ``e_min`` .. :data:`BOUNCE_GROWTH` times the
    one before."""
    if len(kept) < 3:
        return True
    before = on[kept[-2]] - on[kept[-3]]
    return e_min * before <= on[kept[-1]] - on[kept[-2]] <= BOUNCE_GROWTH * before


def bounce_order(onsets: np.ndarray, strengths: np.ndarray, e_min: float) -> np.ndarray:
    """Indices of the ticks that keep the order of a bounce series (step 6), in time order after the
    first two. A tick too soon after the last is dropped, unless the last is a doubtful remainder
    just before it, which it replaces; a late one is kept as :func:`_split_bounce` rules; then
    :func:`_drop_splits`."""
    on, st = onsets, strengths
    kept = list(range(min(2, on.size)))
    for i in range(2, on.size):
        t_last = on[kept[-1]] - on[kept[-2]]
        t = on[i] - on[kept[-1]]
        if t < e_min * t_last:
            weak = st[kept[-1]]
            if weak < DOUBTFUL_DB and st[i] > weak and _in_order(on, kept[:-1] + [i], e_min):
                kept[-1] = i
        elif t <= BOUNCE_GROWTH * t_last or _split_bounce(on, st, kept, i, e_min):
            kept.append(i)
    _drop_splits(on, st, kept)
    return np.array(kept, dtype=int)


def _split_bounce(on, strengths, kept: list, i: int, e_min: float) -> bool:
    """Tick ``i`` ends a bounce over :data:`BOUNCE_GROWTH` times the one before: drop the tick that
    split a bounce, or the weaker unsure ticks before; returns whether ``i`` is kept (not a late
    remainder)."""
    options = [
        j
        for j in (len(kept) - 1, len(kept) - 2)
        if j >= 2
        and strengths[kept[j]] < strengths[i]
        and _in_order(on, kept[:j] + kept[j + 1 :] + [i], e_min)
        and _in_order(on, kept[:j] + kept[j + 1 :], e_min)
    ]
    run = None
    for m in range(2, len(kept) - 1):
        if max(strengths[j] for j in kept[-m:]) >= min(strengths[i], ANCHOR_DB):
            break
        if _in_order(on, kept[:-m] + [i], e_min):
            run = m
            break
    if options:
        del kept[min(options, key=lambda j: strengths[kept[j]])]
    elif run is not None:
        del kept[-run:]
    elif strengths[i] < DOUBTFUL_DB:
        return False
    return True


def _drop_splits(on, strengths, kept: list) -> None:
    """Drop from ``kept`` each unsure tick between two others when the bounce across it continues
    the series' restitution (within :data:`RESTITUTION_STEP`) and its two bounces do not; the
    unsure tick after it instead where the bounce to it continues the series better still."""
    k = 3
    while k + 1 < len(kept):
        t = on[kept[k - 3 : k + 2]]
        if strengths[kept[k]] < ANCHOR_DB:
            e_before = (t[2] - t[1]) / (t[1] - t[0])
            split = max(
                abs((t[3] - t[2]) / (t[2] - t[1]) / e_before - 1.0),
                abs((t[4] - t[3]) / (t[3] - t[2]) / e_before - 1.0),
            )
            merged = abs((t[4] - t[2]) / (t[2] - t[1]) / e_before - 1.0)
            if merged < RESTITUTION_STEP < split:  # the unsure tick after it instead where
                # the bounce to this one continues the series better than the one across it
                alone = abs((t[3] - t[2]) / (t[2] - t[1]) / e_before - 1.0)
                del kept[k + (alone < merged and strengths[kept[k + 1]] < ANCHOR_DB)]
                continue
        k += 1


def unlike_bounces(onsets: np.ndarray) -> int:
    """How many bounces of ``onsets`` (in time order) no ball makes: one that grew (restitution
    ``t_n / t_(n-1)`` of 1 or more: a ball's flights shrink, and step 6 keeps only a missed tick
    to explain it) or whose restitution departs from the one before by more than
    :data:`RESTITUTION_STEP`."""
    t = np.diff(np.asarray(onsets, dtype=float))
    if t.size < 2:
        return 0
    e = t[1:] / np.maximum(t[:-1], 1e-300)
    jump = np.abs(e[1:] / np.maximum(e[:-1], 1e-300) - 1.0) > RESTITUTION_STEP
    return int(np.count_nonzero(e >= 1.0) + np.count_nonzero(jump))


def fitting_additions(onsets: np.ndarray, new: np.ndarray) -> np.ndarray:
    """Which of the ticks at ``onsets`` (in time order) marked ``new`` to keep. A new tick whose
    own bounce grew is left out (a ball's flight after an impact is shorter than the one before
    it), as is one after a tick whose bounce grew (placed by no ball's series: no flight after
    it is known), and so is one without which the series has fewer :func:`unlike_bounces`, the
    one that removes the most first, until none does. A new tick that leaves the series no less like
    a ball's stays: what found it judged it; this judges only what a series allows."""
    t = np.asarray(onsets, dtype=float)
    new = np.asarray(new, dtype=bool)
    keep = np.ones(t.size, dtype=bool)
    while True:
        idx = np.nonzero(keep)[0]
        worst, worst_gain = -1, 0.0
        kept = t[idx]
        for pos in np.nonzero(new[idx])[0]:
            if _grown(kept, pos) or _grown(kept, pos - 1):
                gain = math.inf
            else:
                gain = float(_unlike_bounces_removed(kept, pos))
            if gain > worst_gain:
                worst, worst_gain = int(idx[pos]), gain
        if worst < 0:
            return keep
        keep[worst] = False


def _unlike_bounces_removed(t: np.ndarray, i: int) -> int:
    """How many fewer :func:`unlike_bounces` ``t`` has without ``t[i]``: counted on ``t[i - 3 :
    i + 4]`` alone, which holds every bounce, restitution and jump the removal changes."""
    near = t[max(0, i - 3) : i + 4]
    return unlike_bounces(near) - unlike_bounces(np.delete(near, min(i, 3)))


def _grown(t: np.ndarray, i: int) -> bool:
    """Whether the bounce that ends at ``t[i]`` is no shorter than the one before it."""
    return i >= 2 and t[i] - t[i - 1] >= t[i - 1] - t[i - 2]
