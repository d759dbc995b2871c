"""The analysis' faults on the engine's renders of constructed scenes, one per cause: a tick the
analysis must not report (a false tick, an impossible value) and how each rule keeps it out
(docs/analysis.md, Method). Each scene is scored against the engine's scheduler as
``synth bench analysis --random`` scores its random ones (benchmarks/analysis_scenes.py)."""

import numpy as np
import pytest
from conftest import analysis_tick

from benchmarks.analysis_scenes import SceneSpec, run_scene
from synth.analysis.detection import stand_out
from synth.analysis.options import AnalysisOptions
from synth.analysis.settings import make_settings
from synth.analysis.validity import (
    SPECTRAL_RISE_MIN_SPAN,
    RiseTest,
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
