"""Long recordings cost what their drops and length cost (docs/analysis.md, Long recordings):
each drop is searched whole once, a fit window across a silence costs its templates' length,
and the shorter look for the next candidate gives the longer look's answer. No clock is read:
the work is counted."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import synthetic_bounce
from synth import analysis
from synth.analysis import blocks, deflation, pipeline, resonator
from synth.analysis.options import AnalysisOptions
from synth.analysis.settings import make_settings

FS = 48000


def _drops(duration: float, starts, n_ticks: int = 10) -> tuple[np.ndarray, list[np.ndarray]]:
    """White noise 80 dB under full scale with a synthetic bounce (e = 0.8, ``n_ticks``
    ticks, a new seed per drop) at each of ``starts`` (s), and the true onsets."""
    rng = np.random.default_rng(1)
    y = rng.standard_normal(int(duration * FS)) * 1e-4
    truth = []
    for k, s0 in enumerate(starts):
        x, _, on = synthetic_bounce(0.8, FS, n_ticks=n_ticks, seed=k)
        a = int(round(s0 * FS))
        m = min(x.size, y.size - a)
        y[a : a + m] += 0.5 * x[:m]
        truth.append(on + a / FS)
    return y, truth


@pytest.mark.slow
def test_each_drop_is_searched_whole_once(monkeypatch):
    """Six drops 5 s apart in 32 s cut in blocks of 10 s: steps 1-7 run once per drop (and
    not on a block that holds none), steps 1-6 once per block (and on the last block's
    remainder); every onset within 1.5 sample periods of the truth (these drops' ticks,
    whose onsets fall anywhere between two samples, come within 1.2 sample periods when each
    block is searched whole and each drop again on its own, four searches by steps 1-7 per
    drop)."""
    monkeypatch.setattr(blocks, "BLOCK", 10.0)
    monkeypatch.setattr(blocks, "WHOLE", 10.0)
    calls = {True: 0, False: 0}
    ticks = pipeline._ticks

    def counted(x, settings, clipped, resonator=True, parts=None):
        calls[resonator] += 1
        return ticks(x, settings, clipped, resonator, parts)

    monkeypatch.setattr(pipeline, "_ticks", counted)
    located = pipeline._located

    def counted_blocks(x, settings, clipped, locate, parts=None):
        calls[False] += 1  # a block's steps 1-6, which show where its series start
        return located(x, settings, clipped, locate, parts)

    monkeypatch.setattr(pipeline, "_located", counted_blocks)
    starts = [1.0 + 5.0 * k for k in range(6)]
    y, truth = _drops(32.0, starts)
    a = analysis.analyze(y, FS)
    assert len(a.series) == len(starts)
    for series, want in zip(a.series, truth):
        got = np.array([t.time for t in series.ticks])
        assert got.size == want.size and np.all(np.abs(got - want) <= 1.5 / FS), got
    assert calls[True] == len(starts), calls
    assert calls[False] <= len(starts) + 2, calls


def test_fit_across_a_silence_forms_only_the_templates_rows():
    """A joint fit of two ticks 2 s apart (a series' last tick and the next drop's first) is
    the least-squares fit of the whole design matrix (taps within 1e-9 of
    ``numpy.linalg.lstsq``'s: the normal equations carry a ridge of 1e-12 of their mean
    diagonal; the residual that of the whole matrix with those taps), and forms only the rows
    where a template can be non-zero: its length and lags twice, not the 2 s between."""
    rng = np.random.default_rng(3)
    T = [rng.standard_normal(300) * np.exp(-np.arange(300) / 60.0) for _ in range(2)]
    pre, post, gap = 3, 8, 2 * FS
    y = rng.standard_normal(gap + 600) * 1e-3
    y[:300] += T[0]
    y[gap : gap + 300] += 0.5 * T[1]
    ne = resonator._NormalEquations(T, y, pre, post, (0, gap))
    rows = sum(hi - lo for lo, hi in ne.chunks)
    assert rows <= 2 * (300 + pre + post)
    h, res = ne.solve(len(T), pre, post)
    M = ne._rows(0, y.size)  # the whole design matrix (its rows: test_analysis_long.py)
    want, *_ = np.linalg.lstsq(M, y, rcond=None)
    np.testing.assert_allclose(h, want, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(res, y - M @ h, rtol=0, atol=1e-15)


@pytest.mark.parametrize("seed", range(6))
def test_the_shorter_look_for_a_candidate_gives_the_longer_looks_answer(seed, monkeypatch):
    """The search for the next candidate first looks over a shorter stretch and keeps its
    answer only where no later frame could change it: over whitened noise with bursts
    anywhere (also just past the shorter stretch's end), every answer equals the one of
    the longer look alone."""
    rng = np.random.default_rng(seed)
    settings = make_settings(1, FS, AnalysisOptions())
    r = rng.standard_normal(60000)
    for at in rng.integers(500, 59000, 25):
        r[at : at + 30] += rng.uniform(3.0, 30.0) * rng.standard_normal(30)
    template = r[100:400].copy()
    noise = 1.0
    floor = 10.0 * settings.frame
    res = deflation.Residual(r, template, 100, settings, floor, noise)
    afters = list(rng.integers(1000, 58000, 40))
    shorter = [res.candidate(int(a)) for a in afters]
    monkeypatch.setattr(deflation, "SHORT_LOOK", 0)
    longer = [res.candidate(int(a)) for a in afters]
    assert shorter == longer


@pytest.mark.slow
def test_a_whole_recording_of_several_drops_is_searched_drop_by_drop(monkeypatch):
    """Four drops 10 s apart in 42 s (as ``synth bench long`` lays them), a recording held
    whole (under ``WHOLE``), whose search of the whole shows a new series: it is then
    searched block by block, so steps 1-7 run once on the whole and then once per drop,
    each on no more than a block (never on to the recording's end: the time grows with the
    drops, not with their square); every onset
    within 1.5 sample periods of the truth (as :func:`test_each_drop_is_searched_whole_once`)."""
    searched = {True: [], False: []}
    ticks = pipeline._ticks

    def counted(x, settings, clipped, resonator=True, parts=None):
        searched[resonator].append(x.size)
        return ticks(x, settings, clipped, resonator, parts)

    monkeypatch.setattr(pipeline, "_ticks", counted)
    located = pipeline._located

    def counted_blocks(x, settings, clipped, locate, parts=None):
        searched[False].append(x.size)  # a block's steps 1-6, which show where series start
        return located(x, settings, clipped, locate, parts)

    monkeypatch.setattr(pipeline, "_located", counted_blocks)
    starts = [1.0 + 10.0 * k for k in range(4)]
    y, truth = _drops(42.0, starts, n_ticks=20)
    a = analysis.analyze(y, FS)
    assert len(a.series) == len(starts)
    for series, want in zip(a.series, truth):
        got = np.array([t.time for t in series.ticks])
        assert got.size == want.size and np.all(np.abs(got - want) <= 1.5 / FS), got
    whole, *drops = searched[True]
    assert whole == y.size and len(drops) == len(starts), searched
    assert max(drops) <= blocks.block_frames(FS), searched
    assert len(searched[False]) <= len(starts), searched


@pytest.mark.parametrize("seed", range(4))
def test_a_bounded_look_for_a_candidate_gives_the_full_looks_answer(seed):
    """The end of a fit window needs the next candidate only where it starts by a given
    sample: the bounded look (``within``) gives the full look's candidate when that one
    starts by then, and None when it starts later or there is none, over whitened noise with
    bursts anywhere."""
    rng = np.random.default_rng(seed)
    settings = make_settings(1, FS, AnalysisOptions())
    r = rng.standard_normal(60000)
    for at in rng.integers(500, 59000, 25):
        r[at : at + 30] += rng.uniform(3.0, 30.0) * rng.standard_normal(30)
    res = deflation.Residual(r, r[100:400].copy(), 100, settings, 10.0 * settings.frame, 1.0)
    for after, reach in zip(rng.integers(1000, 58000, 40), rng.integers(0, 6000, 40)):
        within = int(after + reach)
        full = res.candidate(int(after))
        bounded = res.candidate(int(after), within=within)
        assert bounded == (full if full is not None and full.first <= within else None)


def test_a_fit_in_one_piece_is_the_least_squares_fit():
    """A fit whose rows make one piece keeps them for its residuals: taps and residual are
    those of the whole design matrix (as across a silence, within the normal equations'
    ridge of 1e-12), for the widest lags and for a narrower choice of fewer templates."""
    rng = np.random.default_rng(4)
    T = [rng.standard_normal(400) * np.exp(-np.arange(400) / 80.0) for _ in range(3)]
    pre, post = 3, 24
    y = rng.standard_normal(900) * 1e-3
    y[:400] += T[0] + 0.3 * T[1]
    ne = resonator._NormalEquations(T, y, pre, post)
    assert len(ne.chunks) == 1
    M = ne._rows(0, y.size)  # the whole design matrix (its rows: test_analysis_long.py)
    for n_t, p, q in ((3, pre, post), (2, 1, 2)):
        h, res = ne.solve(n_t, p, q)
        lags = np.arange(post - q, post + p + 1)
        cols = np.concatenate([t * (pre + post + 1) + lags for t in range(n_t)])
        want, *_ = np.linalg.lstsq(M[:, cols], y, rcond=None)
        np.testing.assert_allclose(h, want, rtol=1e-7, atol=1e-10)
        np.testing.assert_allclose(res, y - M[:, cols] @ h, rtol=0, atol=1e-15)
