"""Render -> analyze: the analysis recovers the engine's own timing and restitution.

Every preset is rendered (band to 12 kHz and tails to 2 s, to keep the suite fast: the timing
depends on neither) and analysed with the analysis' defaults, but for ``min_separation``,
which the analysis asks to be longer than the contact time (1.5 times the longest contact
of the first ten, at least the default 1 ms). The first ten onsets must come within 0.2 ms
of the engine's and the restitution ``e_n = T_n / T_(n-1)`` from consecutive onsets within
1 % of the engine's own (from its onsets): the accuracy a perception study needs
(well below the just-noticeable difference of a bounce rhythm).

A tick is recovered only while it can be told from the ringing of the earlier ones: its
tick-to-masker ratio (TMR), the energy of the tick alone over its window (to the next tick,
at most 20 ms) over the energy of all the other ticks' sound there, computed by rendering the
tick alone (the synthesis is linear). The check covers the first ten ticks, up to the first
one with a TMR below :data:`MASKED_DB`; on 15 of the 17 presets that is all ten. On the two
others the first masked ticks lie 17.5 dB (6 mm MDF, whose slow last bounces barely excite the
board: ticks 7-9) and 20 dB (a 0.5 mm steel sheet ringing for seconds: ticks 4-10, down to
-51 dB) under the ringing; the analysis still finds the steel sheet's fourth tick (-20 dB)
and the MDF board's sixth (-9 dB), the latter 36 us late.
"""

import numpy as np
import pytest

import synth
from synth.analysis import analyze
from synth.presets import available
from synth.render import render
from synth.scheduler import BounceSequence, simulate_scene

PRESETS = sorted(available())
FS = 48000
#: A tick whose own energy over its window is this far below the other ticks' sound there
#: is masked: under 3 % of the energy there.
MASKED_DB = -15.0
#: Presets on which some of the first ten ticks are masked (the docstring's figures).
PARTLY_MASKED = {"thesis-steel10-mdf6", "steel-ball-on-steel-sheet"}


def _tick_to_masker(scene, seq, full, n):
    """TMR (dB) of the first ``n`` ticks of ``full`` (rendered with ``normalize='none'``)."""
    t0 = seq[0].time
    out = []
    for i in range(n):
        imp = seq[i]
        pre = 0.005 + imp.time - t0
        alone = render(scene, samplerate=FS, max_frequency=12000.0, max_tail=0.05,
                       normalize="none", preroll=pre, fade=0.0,
                       sequence=BounceSequence((imp,), seq.stop_reason, seq.drop_height,
                                               seq.gravity)).audio.astype(float)
        a = int(round(pre * FS))
        b = a + int(0.02 * FS)
        if i + 1 < len(seq):
            b = min(b, int(round((0.005 + seq[i + 1].time - t0) * FS)))
        b = min(b, alone.size, full.size)
        own = np.sum(alone[a:b] ** 2)
        other = np.sum((full[a:b] - alone[a:b]) ** 2)
        out.append(np.inf if other == 0.0 else 10.0 * np.log10(own / other))
    return np.array(out)


@pytest.mark.parametrize("name", PRESETS)
def test_roundtrip_recovers_onsets_and_restitution(name):
    scene = synth.load_preset(name)
    seq = simulate_scene(scene)
    r = render(scene, samplerate=FS, max_frequency=12000.0, max_tail=2.0, normalize="none",
               sequence=seq)
    truth = np.array([imp.time for imp in r.impacts])
    n = min(10, truth.size)
    tmr = _tick_to_masker(scene, seq, r.audio.astype(float), n)
    masked = np.nonzero(tmr < MASKED_DB)[0]
    if masked.size:
        n = int(masked[0])
    assert (n < min(10, truth.size)) == (name in PARTLY_MASKED), (name, np.round(tmr, 1))
    assert n >= 3, (name, np.round(tmr, 1))        # at least one restitution to check

    longest = max(imp.result.contact_time for imp in r.impacts[:10])
    a = analyze(r.audio, r.samplerate, gravity=scene.gravity,
                min_separation=max(0.001, 1.5 * longest))
    got = np.array([t.time for t in a.ticks[:n]])
    assert got.size == n, (name, got.size, n)
    assert np.max(np.abs(got - truth[:n])) < 0.2e-3, (name, got - truth[:n])
    T = np.diff(truth)
    for i in range(2, n):
        e_true = T[i - 1] / T[i - 2]
        assert a.ticks[i].restitution == pytest.approx(e_true, rel=0.01), (name, i)


def test_deflation_finds_the_late_ticks_at_a_corner():
    # At the board's corner the restitution is low (0.52-0.68) and the late ticks lie
    # 0-13 dB under the ringing of the earlier ones (tick-to-masker ratio). Without the
    # deflation (analysis step 5) the tenth tick is 110 us late and its restitution 2 %
    # off; with it every one of the first ten is within 20 us and 0.2 %.
    scene = synth.load_preset("thesis-steel10-mdf18-corner")
    r = render(scene, samplerate=FS, max_frequency=12000.0, max_tail=2.0)
    truth = np.array([imp.time for imp in r.impacts[:10]])
    T = np.diff(truth)
    e_true = T[1:] / T[:-1]
    for deflate, onset_tol, e_tol in ((True, 20e-6, 0.002), (False, None, None)):
        a = analyze(r.audio, r.samplerate, deflate=deflate)
        got = np.array([t.time for t in a.ticks[:10]])
        e = np.array([t.restitution for t in a.ticks[2:10]])
        if deflate:
            assert np.max(np.abs(got - truth)) < onset_tol
            assert np.max(np.abs(e / e_true - 1.0)) < e_tol
        else:
            assert got.size < 10 or np.max(np.abs(e / e_true - 1.0)) > 0.01
