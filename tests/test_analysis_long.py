"""Long recordings: analysed block by block (synth/analysis/blocks.py) in bounded memory, every
drop found whole, and absurd options refused before any work (docs/analysis.md, Long
recordings)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import soundfile as sf

from benchmarks import synthetic_bounce
from synth import analysis
from synth.analysis import blocks, pipeline
from synth.analysis.series import bounce_series
from synth.errors import ParameterError

FS = 48000


def _drops(
    duration: float, starts, n_ticks: int = 20, seed: int = 0
) -> tuple[np.ndarray, list[np.ndarray]]:
    """``duration`` s of white noise 80 dB under full scale with a synthetic bounce (e = 0.8,
    ``n_ticks`` ticks, not made by the engine) starting at each of ``starts`` (s), and the
    true onsets of each."""
    rng = np.random.default_rng(seed)
    y = rng.standard_normal(int(duration * FS)) * 1e-4
    truth = []
    for k, s0 in enumerate(starts):
        x, _, on = synthetic_bounce(0.8, FS, n_ticks=n_ticks, seed=k)
        a = int(round(s0 * FS))
        m = min(x.size, y.size - a)
        y[a : a + m] += 0.5 * x[:m]
        truth.append(on + a / FS)
    return y, truth


def _close(got: np.ndarray, want: np.ndarray, tol: float) -> bool:
    return got.size == want.size and bool(np.all(np.abs(got - want) <= tol))


@pytest.mark.slow
def test_drops_across_blocks_are_found_whole(monkeypatch):
    """Three drops in 26 s cut in blocks of 10 s: one that starts half a second before the
    first block ends (its series spans two blocks) and one in the overlap of the next. Each
    is found as one series, every onset within a sample period of the truth (the accuracy of
    docs/analysis.md, Accuracy, for a recording held whole)."""
    monkeypatch.setattr(blocks, "BLOCK", 10.0)
    monkeypatch.setattr(blocks, "WHOLE", 10.0)
    starts = (1.0, blocks.BLOCK - 0.5, 2 * blocks.BLOCK - 1.0 - blocks.OVERLAP / 2)
    y, truth = _drops(26.0, starts, n_ticks=10)
    a = analysis.analyze(y, FS)
    assert len(a.series) == 3
    for series, want in zip(a.series, truth):
        got = np.array([t.time for t in series.ticks])
        assert _close(got, want, 1.0 / FS), (got - want) if got.size == want.size else got


def test_one_block_is_the_whole_analysis(monkeypatch):
    """A recording that fits in a block is analysed as one array (the presets' round trip and
    frozen ticks rest on it); the same recording cut in blocks gives the same ticks within
    a sample period."""
    y, (want,) = _drops(8.0, (1.0,))
    whole = np.array([t.time for t in analysis.analyze(y, FS).ticks])
    monkeypatch.setattr(blocks, "BLOCK", 3.0)
    monkeypatch.setattr(blocks, "WHOLE", 3.0)
    monkeypatch.setattr(pipeline, "OVERLAP", 1.0)
    cut = np.array([t.time for t in analysis.analyze(y, FS).ticks])
    assert _close(whole, want, 1.0 / FS) and _close(cut, whole, 1.0 / FS)


#: A tick is the true one when its onset lies from this much before the truth ...
EARLY = 0.0001
#: ... to this much after it, s: the allowance of tests/test_recordings_scenes.py (a level
#: crossing interpolated between samples of a whitened burst, late where the earlier
#: ringing hides a weak tick's start). A drop of these alone in the same noise comes up to
#: two sample periods late (0.04 ms at 48 kHz).
LATE = 0.00025


@pytest.mark.slow
@pytest.mark.parametrize(
    "duration, period, n_ticks",
    [(27.0, 5.0, 10), (40.0, 2.5, 10), (70.0, 3.0, 10)],
)
def test_each_drop_is_one_series(duration, period, n_ticks):
    """Drops every ``period`` s (a new seed, so new modes, per drop) in recordings under and
    over ``WHOLE``: as many series as drops, each with every true tick, and no other tick.
    A search over several drops finds a series from the first tick that hops to a later
    drop (a first bounce seconds long, then that drop's ticks) longer than the first drop's
    own; three sure ticks in bounce order bound the first tick's own response
    (synth.analysis.series.last_second), and a recording held whole whose search shows a
    new series is searched drop by drop as a long one is."""
    starts = list(np.arange(1.0, duration - 1.0, period))
    y, truth = _drops(duration, starts, n_ticks=n_ticks, seed=1)
    a = analysis.analyze(y, FS)
    assert len(a.series) == len(starts)
    for series, want in zip(a.series, truth):
        got = np.array([t.time for t in series.ticks])
        assert got.size == want.size, (want[0], got)
        assert np.all((got - want >= -EARLY) & (got - want <= LATE)), (got - want) * FS


def _series_onsets(starts, n_ticks: int = 10, e: float = 0.8, t1: float = 0.15) -> np.ndarray:
    """Onsets (s) of a geometric bounce series (bounce ``t1 e^(n-1)``) from each of
    ``starts``."""
    one = np.r_[0.0, np.cumsum(t1 * e ** np.arange(n_ticks - 1))]
    return np.concatenate([s0 + one for s0 in starts])


def test_no_series_passes_over_a_sure_bounce():
    """Three drops 3 s apart, every candidate sure: the longest series from the first tick
    hops to the second drop (a first bounce of 3.4 s, 0.78 times that to the third drop,
    then its ticks: 11 ticks against the first drop's 10); a sure candidate that the next
    sure one follows in bounce order ends the first tick's own response, so the series is
    the first drop's. A sure contact end 3 ms after the first tick, followed by no sure
    candidate within its bounce's range, is still passed over."""
    on = _series_onsets((0.0, 3.0, 6.0))
    sure = np.ones(on.size, dtype=bool)
    assert len(bounce_series(on, 0.1)) > 10
    assert bounce_series(on, 0.1, sure=sure) == list(range(10))
    on = np.r_[0.0, 0.003, _series_onsets((0.0,))[1:]]
    got = bounce_series(on, 0.1, sure=np.ones(on.size, dtype=bool))
    assert got == [0] + list(range(2, on.size))


def _peak_bytes(path) -> tuple[int, analysis.Analysis]:
    tracemalloc.start()
    try:
        result = analysis.analyze_file(path)
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()


@pytest.mark.slow
def test_memory_does_not_grow_with_the_file(tmp_path, monkeypatch):
    """A file is read in blocks (here of 10 s), never whole: the peak of the memory allocated
    while a 90 s file with one drop is analysed stays within 10 % of a 30 s file's (a whole
    read of the 90 s file alone, in float64, is 35 MB), and the drop is found in both."""
    monkeypatch.setattr(blocks, "BLOCK", 10.0)
    monkeypatch.setattr(blocks, "WHOLE", 10.0)
    peaks = []
    for duration in (30.0, 90.0):
        y, (want,) = _drops(duration, (duration - 3.0,))
        path = tmp_path / f"drop{duration:g}.wav"
        sf.write(path, y.astype(np.float32), FS, subtype="FLOAT")
        peak, result = _peak_bytes(path)
        got = np.array([t.time for t in result.ticks])
        assert _close(got, want, 1.0 / FS)
        assert result.duration == pytest.approx(duration)
        peaks.append(peak)
    assert peaks[1] <= 1.1 * peaks[0] and peaks[1] < 90.0 * FS * 8, peaks


@pytest.mark.parametrize(
    "option, value, allowed",
    [
        ("window", 1e300, "<= 2"),
        ("hop", 5.0, "<= 0.01"),
        ("background", 1e9, "<= 1"),
        ("threshold_db", 1e4, "<= 300"),
        ("dynamic_range_db", float("inf"), "finite"),
        ("lpc_order", 10**9, "2..4096"),
        ("decay_smoothing", 60.0, "<= 0.1"),
        ("min_separation", 1e3, "<= 1"),
        ("gravity", 1e300, "<= 300"),
    ],
)
def test_absurd_options_are_refused_before_any_work(tmp_path, monkeypatch, option, value, allowed):
    """Each option has a documented range (synth.analysis.settings); a value outside it is a
    ParameterError naming the option, its value and the range, raised before a sample is
    read."""
    path = tmp_path / "x.wav"
    sf.write(path, np.zeros(4800), FS)

    def no_read(*args, **kwargs):
        raise AssertionError("samples read before the options were checked")

    monkeypatch.setattr(pipeline, "read_recording", no_read)
    monkeypatch.setattr(blocks.FileSource, "read", no_read)
    with pytest.raises(ParameterError, match=f"{option}=.*{allowed}"):
        analysis.analyze_file(path, **{option: value})


def test_cli_window_out_of_range(tmp_path, capsys):
    """``synth analyze FILE --window 1e300``: one line naming the option and its range,
    exit status 2... or 1 as for every ParameterError of the command line; no traceback
    (the command's ``main`` in this process: an exception would fail the test)."""
    from synth.cli import main

    path = tmp_path / "x.wav"
    sf.write(path, np.zeros(4800), FS)
    code = main(["analyze", str(path), "--window", "1e300"])
    err = capsys.readouterr().err
    assert code != 0
    assert "window=1e+300 must be > 0 and <= 2" in err
    assert "Traceback" not in err


def test_long_benchmark_recordings(tmp_path):
    """``synth bench long`` writes its recordings in pieces: the length asked, a drop at 1 s
    and, repeated, one every LONG_PERIOD s (20 ticks each: 3 drops in 25 s); its table has a
    row per recording."""
    import benchmarks as bench

    path = tmp_path / "long.wav"
    assert bench.long_recording(path, 25.0, True) == 60
    assert sf.info(path).frames == 25 * FS
    assert bench.long_recording(path, 25.0, False) == 20
    row = {"duration": 25.0, "repeated": True, "truth": 60, "ticks": 60, "series": 3}
    row.update(seconds=3.0, cpu_s=2.5, per_minute=7.2, cpu_per_minute=6.0, rss_mb=200.0)
    ten = dict(row, duration=600.0, seconds=29.0, cpu_s=25.0, rss_mb=510.0)
    table = bench.format_long(
        [row, ten, {"duration": 600.0, "repeated": False, "truth": 20, "error": "x"}]
    )
    assert "| 25 s, a drop every 10 s | 60 (60) | 3 | 3.00 (2.50) | 7.20 (6.00) | 200 |" in (table)
    assert "failed: x" in table
    assert "600 s, a drop every 10 s: 29.0 s (25.0 s CPU), process peak 510 MB" in table
    assert "not met" in table


def test_frame_energies_are_numpys_sums():
    """The detection function's compiled frame energies are numpy's ``sum`` over each frame to
    the last bit (its pairwise order), for the frame lengths and hops of 8 kHz to 768 kHz and
    overlapping frames, on values spanning ten decades."""
    from numpy.lib.stride_tricks import sliding_window_view

    from synth.analysis.detection import frame_energies

    rng = np.random.default_rng(5)
    for n in (12, 13, 700, 5001):
        for hop, w in ((12, 12), (3, 12), (1, 12), (24, 24), (48, 48), (192, 192), (5, 9), (2, 7)):
            if n < w:
                continue
            z = rng.standard_normal(n) * 10.0 ** rng.uniform(-5, 5, n)
            want = sliding_window_view(z * z, w)[::hop].sum(axis=1)
            assert np.array_equal(frame_energies(z, hop, w), want), (n, hop, w)
            back = z[::-1]  # a view with a negative stride
            want = sliding_window_view(back * back, w)[::hop].sum(axis=1)
            assert np.array_equal(frame_energies(back, hop, w), want), (n, hop, w)


def test_running_median_is_scipys():
    """The candidate search's running median (local background) gives the values of
    ``scipy.ndimage.median_filter(..., mode="nearest")``, for odd and even windows, ties,
    monotonic runs and windows longer than the signal."""
    from scipy.ndimage import median_filter

    from synth.analysis.deflation import running_median

    rng = np.random.default_rng(6)
    for n in (1, 2, 5, 80, 81, 700):
        for size in (3, 4, 80, 81):
            for d in (
                rng.standard_normal(n) ** 2,
                np.round(rng.standard_normal(n) ** 2, 1),
                np.sort(rng.standard_normal(n) ** 2),
                np.sort(rng.standard_normal(n) ** 2)[::-1].copy(),
                np.zeros(n),
            ):
                want = median_filter(d, size=size, mode="nearest")
                assert np.array_equal(running_median(d, size), want), (n, size)


def test_onset_walk_near_the_burst_is_the_whole_walk():
    """The onset walk of step 4 reads |r| near the burst only, longer where it reaches that
    stretch's start: the same onsets as over the whole signal, for bursts after long runs
    over the level (the walk goes far back), pre-ringing, and at the signal's start."""
    from synth.analysis import detection

    def whole(r, lo, hi, fraction, gap, noise, strict=False):
        mag = np.abs(r)
        k = lo + int(np.argmax(mag[lo:hi]))
        level = max(fraction * mag[k], min(noise, mag[k]))
        i = detection._walk_back(mag, k, level, gap)
        centre = detection._sinc_centre(r, mag, i, k, min(noise, mag[k]) if strict else 0.0)
        if centre is not None:
            return centre[0] + centre[1]
        if i == 0:
            return 0.0
        return (i - 1) + (level - mag[i - 1]) / (mag[i] - mag[i - 1])

    rng = np.random.default_rng(7)
    for trial in range(300):
        r = rng.standard_normal(6000) * 0.01
        at = int(rng.integers(0, 5500))
        run = int(rng.integers(0, 3000))
        r[max(0, at - run) : at] += rng.choice([-1.0, 1.0], min(at, run)) * 0.5
        r[at : at + 30] += rng.standard_normal(30) * 5.0
        if trial % 3 == 0 and at >= 7:  # an anti-aliasing filter's pre-ringing
            k = np.arange(7, 0, -1)
            r[at - 7 : at] = (-1.0) ** k / k * 3.0
        lo, hi = max(0, at - 12), min(r.size, at + 36)
        for gap, strict in ((12, False), (2, True), (1, False)):
            got = detection.refine_onset(r, lo, hi, detection.OnsetWalk(0.1, gap, 0.04, strict))
            assert got == whole(r, lo, hi, 0.1, gap, 0.04, strict), (trial, gap)


def test_lazy_block_ticks_are_the_measured_ones():
    """A block's ticks of steps 1-6 are measured only where the series rules ask; asked, each
    is the tick the whole measurement gives (the same fields, to the last bit)."""
    y, _ = _drops(12.0, (1.0, 6.0), n_ticks=10)
    settings = analysis.settings.make_settings(1, FS, analysis.AnalysisOptions())
    loc = pipeline._located(y, settings, False, locate=False)
    want, _ = pipeline._ticks(y, settings, False, resonator=False)
    assert [t.time for t in loc.ticks] == [t.time for t in want]
    assert [t.measured for t in loc.ticks] == want


def test_candidate_rules_are_the_array_formulation():
    """The compiled candidate rules give the values of their array formulation: the running
    median of the past, the fading memory, the floors, and the sums over the remainder span
    (``numpy.convolve``), the median of the lead-in ``lead`` from ``origin`` past the template's
    end ``cut``: the thresholds and backgrounds within 1e-14 (a few units in the last place:
    numpy's vectorised ``log10`` and power may round differently from the compiled code's
    libm), the candidates exactly."""
    from synth.analysis.deflation import Rules, _rules, running_median

    def arrays(d, sub, lead, first, rules: Rules):
        bg, noise, thr, fade, rise, floor, kappa, span, origin, cut = rules
        k = np.arange(d.size)
        a = max(0, first - bg - 3)
        med = np.full_like(d, np.nan)
        med[a:] = running_median(d[a:], bg)
        past_med = np.full_like(d, np.inf)
        j = k - 2 - bg // 2 - 1
        ok = (j >= bg // 2) & (k >= first)
        past_med[ok] = np.maximum(med[j[ok]], noise)
        for i in range(max(first, cut), min(d.size, cut + bg + 2)):
            b0 = max(origin, i - 2 - bg, 0)
            if b0 < i - 2:
                past_med[i] = max(np.median(lead[b0 : i - 2]), noise)
        with np.errstate(divide="ignore"):
            memory = np.maximum.accumulate(np.log10(d) + k * fade)
        past = np.zeros_like(d)
        past[2:] = 10.0 ** (memory[:-2] - k[2:] * fade + rise)
        threshold = np.maximum.reduce(
            [
                np.where(np.isfinite(past_med), past_med * thr, 0.0),
                past,
                np.full_like(d, floor),
                sub * kappa,
            ]
        )
        ones = np.ones(span)
        d_near = np.convolve(d, ones)[span - 2 : span - 2 + d.size]
        sub_near = np.convolve(sub, ones)[span - 2 : span - 2 + d.size]
        hit = np.nonzero((d >= threshold) & (d_near >= sub_near * kappa) & (k >= first))[0]
        return hit, threshold, past_med

    rng = np.random.default_rng(11)
    frames = np.random.default_rng(12)
    for trial in range(200):
        n = int(rng.integers(1, 900))
        d = rng.exponential(size=n) * 10.0 ** rng.uniform(-12, 0, n)
        d[rng.random(n) < 0.05] = 0.0
        sub = np.where(rng.random(n) < 0.5, 0.0, d * rng.uniform(0.0, 2.0, n))
        args = (
            int(rng.integers(0, max(1, n))),
            int(rng.integers(3, 100)),
            float(10.0 ** rng.uniform(-14, -6)),
            10.0,
            float(rng.uniform(0.001, 0.1)),
            0.6,
            float(10.0 ** rng.uniform(-12, -2)),
            1.0,
            int(rng.integers(2, 6)),
            int(frames.integers(-50, max(1, n))),  # the first onset's frame, the template's end
            int(frames.integers(-50, max(1, n) + 50)),
        )
        lead = np.where(frames.random(n) < 0.5, d, frames.exponential(size=n))
        got = _rules(d, sub, lead, args[0], Rules(*args[1:]))
        want = arrays(d, sub, lead, args[0], Rules(*args[1:]))
        np.testing.assert_allclose(got[1], want[1], rtol=1e-14, atol=0, err_msg=str(trial))
        np.testing.assert_allclose(got[2], want[2], rtol=1e-14, atol=0, err_msg=str(trial))
        assert np.array_equal(got[0], want[0]), trial


def test_design_rows_are_the_sliding_windows():
    """The rows of a fit's design matrix are those of the zero-padded templates' sliding
    windows, ``M[i, j] = T[i - o - l_j]``, for several templates and offsets and rows that
    start before, within and after the templates."""
    from synth.analysis.resonator import _NormalEquations

    rng = np.random.default_rng(12)
    for _ in range(40):
        Ts = [rng.standard_normal(int(rng.integers(5, 60))) for _ in range(int(rng.integers(1, 4)))]
        W = int(rng.integers(20, 200))
        pre, post = int(rng.integers(0, 4)), int(rng.integers(0, 8))
        offsets = (0,) + tuple(int(o) for o in rng.integers(1, W, int(rng.integers(0, 2))))
        ne = _NormalEquations(Ts, rng.standard_normal(W), pre, post, offsets)
        ntap = pre + post + 1
        cols = []
        for o in offsets:
            for T in Ts:
                Tp = np.concatenate(
                    (np.zeros(post + o), T[: max(0, W - o + pre)], np.zeros(pre + W))
                )
                cols.append(np.lib.stride_tricks.sliding_window_view(Tp, ntap)[:W])
        want = np.concatenate(cols, axis=1)
        lo, hi = sorted(int(v) for v in rng.integers(0, W + 1, 2))
        assert np.array_equal(ne._rows(lo, hi), want[lo:hi])


def test_bounce_series_tables_are_the_loop():
    """The bounce series' dynamic programme (step 3) gives the series of its loop over the
    candidates: ``searchsorted`` bounds, the longest series, ties to the earliest second
    tick, for onsets of bounce series, of noise and with equal times."""
    from synth.analysis.series import BOUNCE_GROWTH, _series_tables

    def loop(t, latest, e_min, growth):
        n = t.size
        best = np.zeros((n, n), dtype=int)
        second = np.zeros((n, n), dtype=int)
        back = np.full((n, n), -1, dtype=int)
        best[0, 1 : latest + 1] = 2
        second[0, 1:] = np.arange(1, n)
        for i in range(1, n - 1):
            col, sec = best[:i, i], second[:i, i]
            for j in range(i + 1, n):
                bounce = t[j] - t[i]
                lo = np.searchsorted(t[:i], t[i] - bounce / e_min, side="left")
                hi = np.searchsorted(t[:i], t[i] - bounce / growth, side="right")
                if hi <= lo:
                    continue
                c = col[lo:hi]
                m = int(c.max())
                if m == 0:
                    continue
                pick = np.nonzero(c == m)[0]
                k = lo + int(pick[np.argmin(sec[lo:hi][pick])])
                best[i, j], second[i, j], back[i, j] = m + 1, second[k, i], k
        return best, second, back

    rng = np.random.default_rng(13)
    for trial in range(150):
        n = int(rng.integers(3, 50))
        if trial % 2:
            t = np.sort(rng.uniform(0.0, 5.0, n))
        else:
            t = np.cumsum(0.5 * 0.8 ** np.arange(n) * rng.uniform(0.9, 1.1, n))
        if trial % 5 == 0:
            t = np.round(t, 2)
        latest = int(rng.integers(1, n))
        got = _series_tables(t, latest, 0.1, BOUNCE_GROWTH)
        want = loop(t, latest, 0.1, BOUNCE_GROWTH)
        assert all(np.array_equal(g, w) for g, w in zip(got, want)), trial
