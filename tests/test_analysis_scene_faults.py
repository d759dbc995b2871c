"""The analysis' faults on the engine's renders of constructed scenes, one per cause: a tick the
analysis must not report (a false tick, an impossible value) and how each rule keeps it out
(docs/analysis.md, Method). Each scene is scored against the engine's scheduler as
``synth bench analysis --random`` scores its random ones (benchmarks/analysis_scenes.py)."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import analysis_tick

from benchmarks.analysis_scenes import SceneSpec, run_scene
from synth.analysis.detection import detect, first_ticks, stand_out
from synth.analysis.options import AnalysisOptions
from synth.analysis.series import MAX_EXCESS_DB
from synth.analysis.settings import make_settings
from synth.analysis.validity import (
    SPECTRAL_RISE_MIN_SPAN,
    RiseTest,
    doubtful_ticks,
    not_impacts,
    rise_verdict,
    without_spurious_end,
)


def test_an_undecaying_second_tick_cut_by_the_end_is_dropped():
    # a second tick has no bounce before its own to be shorter than: one that does not ring
    # down and whose window the recording's end cuts (the start of a render's fade-out) is
    # confirmed by nothing, and dropped; a third tick whose bounce shrank continues the series
    first = analysis_tick(0.005, decay_time=0.01)
    cut = analysis_tick(1.155, decay_time=None)
    assert without_spurious_end([first, cut], 1.16, 0.02) == [first]
    second = analysis_tick(0.1, decay_time=0.01)
    third = analysis_tick(1.155, restitution=0.8, decay_time=None)
    kept = [first, second, third]
    assert without_spurious_end(kept, 1.16, 0.02) == kept
    # within the window of the end only: a second tick far from it stays
    assert without_spurious_end([first, cut], 2.0, 0.02) == [first, cut]


def test_the_spectral_rise_is_judged_up_to_the_recordings_end():
    # stationary ringing faded out over its last 5 ms: at the fade's start the spectrum falls,
    # over as long a stretch before it as the recording holds after it, not undecided for
    # want of the full span after it
    fs = 48000
    t = np.arange(int(0.1 * fs)) / fs
    ring = sum(np.sin(2 * np.pi * f * t + k) for k, f in enumerate(np.linspace(500, 9000, 40)))
    n = int(0.005 * fs)
    ring[-n:] *= 0.5 * (1.0 + np.cos(np.pi * np.arange(n) / n))
    test = RiseTest(lambda a, b: ring[a:b], fs, 60.0, 0.0)
    at = (ring.size - n) / fs
    v = rise_verdict(test, at, 0.05)
    assert v.frequencies > 0 and not v.adds
    # shorter than the least span after it: undecided, kept
    late = (ring.size - int(0.5 * SPECTRAL_RISE_MIN_SPAN * fs)) / fs
    assert rise_verdict(test, late, 0.05).adds


def test_a_burst_stands_out_of_the_first_ticks_ringing_not_of_the_lead_in():
    # a decaying ringing from an impact at 5 ms after silence, with a second impact 100 ms
    # later: the second stands out (step 8's tests: 6 dB over the 3 ms before it); a point
    # 2 ms into the first tick's ringing rises over the silent lead-in only and is not
    # judged (step 3 takes it for no bounce)
    fs = 48000
    t = np.arange(int(0.3 * fs)) / fs
    rng = np.random.default_rng(5000)
    x = 1e-6 * rng.standard_normal(t.size)
    for t0, a in ((0.005, 1.0), (0.105, 0.5)):
        k = t >= t0
        tt = t[k] - t0
        x[k] += a * np.exp(-tt / 0.02) * np.sin(2 * np.pi * 1500.0 * tt)
    settings = make_settings(1, fs, AnalysisOptions())
    onsets = np.array([0.005, 0.007, 0.105]) * fs
    out = stand_out(x, x, onsets, settings, onsets[0])
    assert out.tolist() == [False, False, True]


#: A 29 mm brass ball dropped 7 cm on a 19 mm clamped steel plate, heard at 96 kHz: one audible
#: impact, then the plate rings loud until the render's 5 ms fade-out, whose start was a tick
#: 1.15 s after the impact (an impact speed of 5.6 m/s, over the drop's free fall of 1.2 m/s).
FADE = SceneSpec(
    "brass", 0.0147, "steel", 0.0193, 0.743, 0.441, "clamped", 0.072, (0.109, 0.377),
    "microphone", (0.333, 0.224, 0.353), 96000, 7.3, 1.06,
)  # fmt: skip


#: A 16 mm steel ball dropped 22 cm on a 6.2 mm free granite plate, an accelerometer: each
#: impact's response holds a burst 3.3 ms after it (a bending wave's reflection), which step
#: 3's longest series took for the second tick, the true second tick 121 ms after the first for
#: the first tick's response and the end of its template past it; that burst after the second
#: tick was then reported as a tick (restitution 0.03).
ECHO = SceneSpec(
    "steel", 0.008014886562813026, "granite", 0.0061728265252330595, 0.6446405477370476,
    0.49694439632378334, "free", 0.21761770363567354, (0.33266883060784086, 0.4269443599096276),
    "accelerometer", (0.08616855594919884, 0.20943144182208415), 44100, 7.761839137122871,
    1.1071897181935024,
)  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("spec", [FADE, ECHO], ids=["fade-out", "reflection"])
def test_scene_without_false_tick_or_impossible_value(spec):
    s = run_scene(spec)
    assert s.error is None, s.error
    assert (s.false_ticks, s.impossible, s.missed) == (0, 0, 0), s.faults


def test_the_first_onset_is_walked_back_over_the_lead_in_not_its_own_ringing():
    # a whitened first burst over a digitally silent lead-in: 0.5 ms of contact at a tenth of
    # the burst's peak, then 20 ms of ringing the whitening leaves nearly as loud as the peak
    # (a thin, lightly damped plate). The centred running median there holds that ringing, 4
    # of its standard deviations are over the peak, and the walk stopped at the peak, 1 ms
    # late; the noise level is the lead-in's, the background the threshold rises from
    fs = 44100
    settings = make_settings(1, fs, AnalysisOptions())
    rng = np.random.default_rng(5001)
    start = 221
    r = np.zeros(int(0.06 * fs))
    contact = int(0.0005 * fs)
    sign = (-1.0) ** np.arange(contact)
    r[start : start + contact] = 150.0 * sign
    r[start + contact : start + contact + 20] = 1400.0 * (-1.0) ** np.arange(20)
    ring = slice(start + contact + 20, start + int(0.021 * fs))
    r[ring] = 700.0 * rng.standard_normal(ring.stop - ring.start)
    found = detect(r, settings, settings.background)
    assert found.background[found.peaks[0]] < 1.0  # the lead-in's, not the ringing's
    onset = first_ticks(r, settings, settings.background).onsets[0]
    assert abs(onset - start) <= 1.0, onset - start  # within a sample period


def _ringing(fs: float, seconds: float, seed: int) -> np.ndarray:
    """A plate's stationary ringing: 40 modes, 500 Hz to 9 kHz, random phases."""
    t = np.arange(int(seconds * fs)) / fs
    rng = np.random.default_rng(seed)
    freqs = np.linspace(500.0, 9000.0, 40)
    return sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, rng.uniform(0, 6.3, 40)))


def test_a_doubtful_tick_told_by_nothing_is_dropped():
    # stationary ringing holds no impact: a second tick in it that nothing confirms (no
    # bounces after it) and that does not ring down is dropped unless its spectrum
    # rises beyond RISE_FALSE_ALARM, whatever the frequencies that hold sound (a ringing
    # plate's bursts over a few lines were kept, 0.97 s after the impact)
    fs = 48000
    x = _ringing(fs, 1.5, 5002)
    test = RiseTest(lambda a, b: x[a:b], fs, 60.0, 0.0)
    first = analysis_tick(0.005)
    silent = analysis_tick(0.97, decay_time=None)
    assert not_impacts([first, silent], test) == [1]
    # a real impact's broad spectrum over the ringing rises beyond chance: kept
    impact = _with_impact(x, fs, 0.97)
    assert not_impacts([first, silent], impact) == []


def _with_impact(x: np.ndarray, fs: float, at: float) -> RiseTest:
    """The :class:`RiseTest` of ``x`` (rate ``fs``, Hz) with an impact's broad burst at ``at``
    (s) over it, 30 times the ringing's modes."""
    y = x.copy()
    k = int(at * fs)
    tt = np.arange(y.size - k) / fs
    y[k:] += 30.0 * np.exp(-tt / 0.005) * np.sin(2 * np.pi * 3000.0 * tt) * np.cos(
        2 * np.pi * 7100.0 * tt
    ) + 30.0 * np.exp(-tt / 0.003) * np.random.default_rng(5003).standard_normal(tt.size)
    return RiseTest(lambda a, b: y[a:b], fs, 60.0, 0.0)


def test_a_second_tick_louder_than_the_first_is_no_bounce():
    # restitution below 1: the second impact is no faster than the first, so its sound is no
    # louder (MAX_EXCESS_DB for the measurement); a soft ball's release at the end of a long
    # contact, 2 ms after its onset, carried 7 dB more than the onset's tick and was reported
    fs = 48000
    x = _ringing(fs, 0.4, 5004)
    test = _with_impact(x, fs, 0.1)  # the second tick's spectrum rises beyond chance
    first = analysis_tick(0.005)
    for excess_db, dropped in ((MAX_EXCESS_DB + 1.0, [1]), (MAX_EXCESS_DB - 1.0, [])):
        second = replace(analysis_tick(0.1), energy=10.0 ** (excess_db / 10.0))
        assert not_impacts([first, second], test) == dropped, excess_db
    # bounces after it that confirm it (two agreeing restitutions) show a ball nearing the
    # listener, its level rising: kept
    second = replace(analysis_tick(0.1), energy=10.0 ** ((MAX_EXCESS_DB + 1.0) / 10.0))
    ball = [analysis_tick(0.18, restitution=0.8), analysis_tick(0.244, restitution=0.8)]
    assert not_impacts([first, second, *ball], test) == []


def test_a_last_tick_whose_restitution_departs_and_that_does_not_ring_down_is_doubtful():
    # missed_bounces needs a neighbour on each side; a last tick whose bounce parts the
    # series' steady restitution (0.84, then 0.57) is doubtful where its own sound does not
    # ring down, and a real one (it decays) is not
    times = [0.0, 0.1, 0.184, 0.2546, 0.2546 + 0.0706 * 0.57]
    ticks = [analysis_tick(times[0]), analysis_tick(times[1])]
    for n in range(2, len(times)):
        e = (times[n] - times[n - 1]) / (times[n - 1] - times[n - 2])
        ticks.append(analysis_tick(times[n], restitution=e))
    assert doubtful_ticks(ticks) == []
    ticks[-1] = replace(ticks[-1], decay_time=None)
    assert doubtful_ticks(ticks) == [len(ticks) - 1]


def _modal_ringing(t, onsets, amplitudes, tau):
    """Unit impulses at ``onsets`` (s) times ``amplitudes`` through 60 modes of 0.5-20 kHz,
    each decaying to 1/e in ``tau`` s (fixed phases, seed 5001), sampled at ``t`` (s)."""
    rng = np.random.default_rng(5001)
    freqs = np.linspace(500.0, 20000.0, 60)
    phases = rng.uniform(0.0, 2.0 * np.pi, freqs.size)
    x = np.zeros_like(t)
    for t0, a in zip(onsets, amplitudes):
        k = t >= t0
        tt = t[k] - t0
        x[k] += a * np.exp(-tt / tau) * np.sin(2.0 * np.pi * freqs * tt[:, None] + phases).sum(1)
    return x


def test_a_chatters_impact_is_judged_over_half_its_bounce():
    # two impacts 12 ms apart into a plate ringing down to 1/e in 3 ms, the second at half the
    # first's amplitude: its own sound stands 29 dB over the first's ringing, yet 10 ms before
    # its onset reach into the first impact's first 2 ms, whose own sound outweighs it, and
    # the spectrum "falls"; over half the bounce each side it rises. The ringing alone (no
    # second impact) rises over neither: the shorter stretch adds no false tick.
    from synth.analysis.search import _half_bounce

    fs = 96000
    t = np.arange(int(0.06 * fs)) / fs
    noise = 1e-7 * np.random.default_rng(5002).standard_normal(t.size)
    two = _modal_ringing(t, (0.005, 0.017), (1.0, 0.5), 0.003) + noise
    one = _modal_ringing(t, (0.005,), (1.0,), 0.003) + noise
    half = _half_bounce(np.array([0.005, 0.017]) * fs, 0.017 * fs) / fs
    assert half == pytest.approx(0.006)
    test_two = RiseTest(lambda a, b: two[a:b], fs, 60.0, 1e-7)
    test_one = RiseTest(lambda a, b: one[a:b], fs, 60.0, 1e-7)
    assert not rise_verdict(test_two, 0.017, 0.01).adds
    assert rise_verdict(test_two, 0.017, half).adds
    assert not rise_verdict(test_one, 0.017, half).adds


def test_a_new_bursts_bounce_is_timed_from_the_residuals_start_of_the_tick_before():
    # a microphone hears the plate's nearest point first: step 4 times a whitened burst whose
    # first, weak arrival falls under its walk's level at its peak, 0.6 ms late, and the
    # bounce to the next tick shrinks to 15.4 ms, so the new burst's 15.5 ms after it looks
    # grown and is left out; timed where the residual rises, the ticks' bounces are 16.6 and
    # 16.0 ms, and the burst's 15.5 ms stays. A rise within two sample periods
    # of an onset (the searches' agreement), after it, or nearer the tick before, moves
    # nothing. The reported onsets stay step 4's.
    from synth.analysis.measures import FoundTick
    from synth.analysis.residual import Rise
    from synth.analysis.search import _residual_timed, _series_additions

    fs = 96000
    min_sep = int(0.001 * fs)
    times = np.array([0.2, 0.25, 0.27, 0.2866, 0.3026]) * fs
    late = times.copy()
    late[3] += 0.0006 * fs
    found = [FoundTick(on, 30.0, None, 0, on) for on in late]
    start = Rise(times[3], 1.0)
    timed = _residual_timed(late, [start], min_sep)
    assert np.array_equal(timed, times)
    burst = FoundTick(times[4] + 0.0155 * fs, 1.0, None, 0, times[4] + 0.0155 * fs)
    assert _series_additions(found, late, [burst]) == []
    assert _series_additions(found, timed, [burst]) == [burst]
    near = Rise(late[3] - 1.5, 1.0)
    after = Rise(late[1] + 20.0, 1.0)
    assert np.array_equal(_residual_timed(late, [near, after], min_sep), late)


def test_the_order_search_takes_its_errors_from_the_normal_equations():
    # a lightly damped plate's long free ringing: the order search's error energies from the
    # normal equations (no pass over the samples) are the errors the predictors leave on the
    # samples, to rounding (1e-8 of them: the description length moves by N 1e-8, far under
    # one order's cost ln N), with the ridge the factor holds as with none to speak of
    from synth.analysis.whitening import (
        _border_cholesky,
        _error_energies,
        _order_criterion,
        _predictors,
        _quadratic_energies,
    )
    from synth.dsp import covariance_border

    rng = np.random.default_rng(5402)
    fs = 48000
    t = np.arange(20000) / fs
    x = sum(
        np.exp(-t / rng.uniform(0.2, 2.0)) * np.sin(2 * np.pi * rng.uniform(100, 20000) * t)
        for _ in range(80)
    ) + 1e-3 * rng.standard_normal(t.size)
    p = 128
    C = covariance_border(x, p)
    for load in (1e-12 * C.diagonal[1:].sum() / p, 1e-4 * C.row0[0]):
        f = _border_cholesky(x, C, load, np.empty(p * p))
        crit = _order_criterion(x, f.L, C.row0, f.load)
        predictors = _predictors(f.L, crit.y, crit.grid)
        quad = _quadratic_energies(C.row0[0], crit.y, predictors, crit.grid, f.load)
        formed = _error_energies(x, predictors, p)
        assert quad is not None
        np.testing.assert_allclose(quad, formed, rtol=1e-8)
