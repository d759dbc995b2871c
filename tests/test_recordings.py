"""Recordings the analysis must not misread: a missed tick (a bounce time that grows), several
drops in one file, a peak-normalised file that only looks clipped, a truncated WAV, and input
that is not a bouncing sound at all.

The signals are synthesised from their truth: every tick the response of the same four damped
modes to an impulse, its amplitude proportional to its impact speed (the bounce time: the thesis,
see docs/physics.md, References, section 3.1), so the onsets and restitutions are known exactly.
"""

import warnings
from dataclasses import replace

import numpy as np
import pytest
import soundfile

from synth import dsp
from synth.analysis import AnalysisError, analyze, analyze_file, read_recording
from synth.analysis.report import Tick
from synth.analysis.validity import AFTER_GROWN, GROWN_BOUNCE, MISSED_BOUNCE, missed_bounces
from synth.analysis.whitening import lead_in_noise, whitening_predictor
from synth.errors import ParameterError
from synth.stimuli.alter import alter_restitution
from synth.store.audio import TruncatedAudioWarning, read_audio

FS = 44100
#: (frequency Hz, decay time s, gain) of the resonator every tick excites.
MODES = ((523.0, 0.08, 1.0), (1287.0, 0.05, 0.6), (2990.0, 0.03, 0.4), (6110.0, 0.015, 0.25))


def series(t0, e, first, last=0.004):
    """Onsets (s) of a bounce series from ``t0``: bounce times ``first e^n`` down to ``last``."""
    out, T = [t0], first
    while T > last:
        out.append(out[-1] + T)
        T *= e
    return np.array(out)


def ticks(onsets, amps, dur, noise=1e-5, seed=0):
    """The modes excited at ``onsets`` with gains ``amps``, plus white noise, ``dur`` s."""
    n = int(dur * FS)
    x = np.zeros(n)
    tt = np.arange(n) / FS
    for on, a in zip(onsets, amps):
        k = int(np.ceil(on * FS))
        t = tt[k:] - on
        for f, tau, g in MODES:
            x[k:] += a * g * np.exp(-t / tau) * np.sin(2 * np.pi * f * t)
    return x + noise * np.random.default_rng(seed).standard_normal(n)


def drop(t0, e, first, gain=1.0):
    """Onsets of one drop and each tick's gain (its impact speed over the first's)."""
    on = series(t0, e, first)
    return on, gain * np.r_[1.0, np.diff(on) / first]


def matched(got, want, tol=0.1e-3):
    """How many of the onsets ``want`` have a tick of ``got`` within ``tol``, s."""
    got = np.asarray(got)
    return sum(bool(np.any(np.abs(got - w) < tol)) for w in want)


# ---------------------------------------------------------------------------
# impossible restitutions


@pytest.fixture(scope="module")
def missed():
    """A series with e = 0.8 whose fourth tick is missing (a lossy copy that lost it)."""
    on, amps = drop(0.05, 0.8, 0.3)
    keep = np.ones(on.size, bool)
    keep[3] = False
    return ticks(on[keep], amps[keep], 2.0), on[keep]


def test_missed_tick_is_flagged(missed):
    # without tick 4 the bounce before tick 4 found is t_3 + t_4 = e (1 + e) t_2: e = 1.44,
    # impossible for a ball; the next one is e^2 / (1 + e) = 0.36. Both are flagged and
    # withheld (the bounce times stay, the grown bounce's speed is withheld too), the
    # summary says so, and the mean is the rest's: e = 0.8 to the rounding of the onsets to
    # samples, < 0.1 %
    x, on = missed
    an = analyze(x, FS)
    assert matched([t.time for t in an.ticks], on) == on.size == len(an.ticks)
    bad = an.ticks[3]
    assert bad.bounce_time / an.ticks[2].bounce_time == pytest.approx(0.8 * 1.8, rel=1e-3)
    assert bad.restitution is None and bad.speed is None and an.ticks[4].restitution is None
    assert GROWN_BOUNCE in bad.flags and AFTER_GROWN in an.ticks[4].flags
    assert all(not t.flags for t in an.ticks if t.index not in (4, 5))
    assert any("impossible restitution" in w and "tick 4" in w for w in an.warnings)
    assert an.mean_restitution == pytest.approx(0.8, rel=1e-3)
    assert len(an.series) == 1 and an.series[0].mean_restitution == pytest.approx(0.8, rel=1e-3)


def test_missed_tick_of_a_dead_ball_is_flagged():
    # e = 0.55 without tick 4: the merged bounce makes e (1 + e) = 0.85 (below 1, so no
    # bounce grew) and the next e^2 / (1 + e) = 0.195; each departs from the series' 0.55 on
    # both sides by far more than RESTITUTION_STEP (25 %): both flagged, left out of the
    # mean, and the rest is e = 0.55 (to the rounding of the onsets to samples, < 0.1 %)
    on, amps = drop(0.05, 0.55, 0.3)
    keep = np.ones(on.size, bool)
    keep[3] = False
    an = analyze(ticks(on[keep], amps[keep], 1.5), FS)
    assert matched([t.time for t in an.ticks], on[keep]) == keep.sum() == len(an.ticks)
    bounces = [t.bounce_time for t in an.ticks[2:5]]
    assert [bounces[1] / bounces[0], bounces[2] / bounces[1]] == pytest.approx(
        [0.55 * 1.55, 0.55**2 / 1.55], rel=1e-3
    )
    assert [t.restitution for t in an.ticks[3:5]] == [None, None]  # withheld: flagged
    assert [t.index for t in an.ticks if t.flags] == [4, 5]
    assert all(t.flags == (MISSED_BOUNCE,) for t in an.ticks[3:5])
    assert any("missed bounce" in w and "tick 4" in w for w in an.warnings)
    assert an.mean_restitution == pytest.approx(0.55, rel=1e-3)


def _series_ticks(bounces, energies_db):
    """Ticks of one series with ``bounces`` (s, from the second tick on) and energies (dB):
    the fields the series' flags read."""
    times = np.r_[0.0, np.cumsum(bounces)]
    out = []
    for i, (t, level) in enumerate(zip(times, energies_db)):
        b = bounces[i - 1] if i else None
        e = bounces[i - 1] / bounces[i - 2] if i > 1 else None
        out.append(
            Tick(i + 1, t, b, e, None, 10.0 ** (level / 10.0), 1.0, 1e3, 1e2, 0.01, 0.02, 20.0)
        )
    return out


def test_tick_too_weak_for_its_bounce():
    # e = 0.96 over bounces of 0.29 and 0.28 s, the third tick 12.3 dB under the second
    # (wood-noise40 of tests/test_recordings_sdt.py without its first and third strikes,
    # whose last bounce spans 15 missed strikes): e^2 allows 0.36 dB, and a missed bounce
    # lowers the energy by (1 + e)^2 / e^2 >= 4 (6 dB) more; flagged. At e^2 (-0.36 dB) and
    # 5.5 dB under it: not flagged
    bounces = [0.2913, 0.2794]
    assert missed_bounces(_series_ticks(bounces, [0.0, 1.1, 1.1 - 12.3])) == {2}
    assert missed_bounces(_series_ticks(bounces, [0.0, 1.1, 1.1 - 0.36])) == set()
    assert missed_bounces(_series_ticks(bounces, [0.0, 1.1, 1.1 - 0.36 - 5.5])) == set()
    # a steady series, e = 0.8, energies falling by e^2: nothing flagged; one missing every
    # other tick from its start is geometric with e^2 = 0.64 in bounce times and energies
    # alike, and is not told from a ball of that restitution (docs/analysis.md)
    steady = [0.3 * 0.8**k for k in range(10)]
    levels = np.r_[0.0, 20.0 * np.log10(np.array(steady) / 0.3)]
    assert missed_bounces(_series_ticks(steady, levels)) == set()
    pairs = [steady[k] + steady[k + 1] for k in range(0, 10, 2)]
    assert missed_bounces(_series_ticks(pairs, levels[::2])) == set()
    # e = 0.55 without its fifth tick: the bounce before the next is e (1 + e) = 0.85 times
    # the one before (no grown bounce) while its impact speed fell by e^2: its energy is
    # (1 + e)^2 / e^2 = 8 (9 dB) under what that restitution allows, so the energies alone
    # flag it, as the restitutions do (tests above)
    dead = [0.3 * 0.55**k for k in range(8)]
    levels = np.r_[0.0, 20.0 * np.log10(np.array(dead) / 0.3)]
    ticks = _series_ticks(dead[:3] + [dead[3] + dead[4]] + dead[5:], np.delete(levels, 4))
    assert 4 in missed_bounces([replace(t, restitution=None) if t.index != 5 else t for t in ticks])


def test_alter_refuses_a_grown_bounce(missed):
    # k = 2 on e = 1.44 would give e' = 1.88: a deader ball bouncing livelier; refused, with
    # the onsets found by the analysis as with the analysis left to alter
    x, on = missed
    with pytest.raises(ParameterError, match="not one bounce series"):
        alter_restitution(x, FS, 2.0, onsets=on)
    with pytest.raises(ParameterError, match="not one bounce series"):
        alter_restitution(x, FS, 2.0)


# ---------------------------------------------------------------------------
# several drops


DROPS = ((0.05, 0.8, 0.3, 1.0), (2.5, 0.7, 0.25, 0.7), (5.0, 0.85, 0.35, 0.7))


def test_several_drops_make_several_series():
    # three drops with e = 0.8, 0.7, 0.85: three series, each starting at its drop, with
    # its own restitution (to 0.1 %, the rounding of the onsets to samples), no bounce time
    # or restitution across two drops, and no tick that is not an impact
    parts = [drop(t0, e, first, gain) for t0, e, first, gain in DROPS]
    truth = np.concatenate([p[0] for p in parts])
    x = ticks(truth, np.concatenate([p[1] for p in parts]), 7.0)
    an = analyze(x, FS)
    assert len(an.series) == 3
    assert matched([t.time for t in an.ticks], truth) == len(an.ticks)
    for s, (t0, e, _, _) in zip(an.series, DROPS):
        assert s.first == pytest.approx(t0, abs=0.1e-3)
        assert s.mean_restitution == pytest.approx(e, rel=1e-3)
        assert s.ticks[0].bounce_time is None and s.ticks[1].restitution is None
        assert len(s.ticks) >= 8
    assert sum(len(s.ticks) for s in an.series) == len(an.ticks)
    assert any("3 bounce series" in w for w in an.warnings)


# ---------------------------------------------------------------------------
# clipping


def _repeated_drop(copies=5):
    on, amps = drop(0.05, 0.8, 0.2)
    one = ticks(on, amps, 1.0, noise=0.0)
    x = np.tile(one, copies)
    return x * 10.0 ** (-1.0 / 20.0) / np.abs(x).max()


def test_peak_normalised_file_is_not_clipped(tmp_path):
    # five identical drops put at -1 dBFS: five isolated samples at the peak value (one per
    # drop, as a 16-bit file stores it), no flat top: not clipping
    path = tmp_path / "drops.wav"
    soundfile.write(path, _repeated_drop(), FS, subtype="PCM_16")
    x, _ = read_recording(path)
    assert np.count_nonzero(x == x.max()) >= 5
    an = analyze_file(path)
    assert not an.clipped and not any("clipping" in w for w in an.warnings)
    assert len(an.series) == 5


@pytest.mark.slow  # the analysis of clipped drops
def test_true_clip_is_clipping(tmp_path):
    # the same drops 12 dB too loud, clipped at full scale: flat tops, clipping
    path = tmp_path / "clipped.wav"
    soundfile.write(path, np.clip(4.0 * _repeated_drop(2), -1.0, 1.0), FS, subtype="PCM_16")
    an = analyze_file(path)
    assert an.clipped and "clipping" in an.warnings[0]


# ---------------------------------------------------------------------------
# truncated files


def test_truncated_wav_warns(tmp_path):
    # a WAV cut off after its header was written: the header declares 2 s, the file holds
    # 1 s; soundfile reads the second silently, the readers say so
    on, amps = drop(0.05, 0.8, 0.2)
    path = tmp_path / "cut.wav"
    x = ticks(on, amps, 2.0)
    soundfile.write(path, 0.5 * x / np.abs(x).max(), FS, subtype="PCM_16")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_audio(path)  # whole: no warning
        assert analyze_file(path).warnings == ()
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - FS * 2])
    with pytest.warns(TruncatedAudioWarning, match="declares 88200 frames"):
        x, _ = read_audio(path)
    assert x.shape[0] == FS
    with pytest.warns(TruncatedAudioWarning):
        an = analyze_file(path)
    assert any("truncated" in w and "holds 44100" in w for w in an.warnings)


# ---------------------------------------------------------------------------
# input that is not impacts


@pytest.mark.parametrize("level", [1.0, 0.5])
def test_square_wave_has_no_ticks(level):
    # a square wave at full scale is held at its extremes all the time (flat tops
    # everywhere); below full scale its edges whiten to bursts like ticks, but nothing
    # rings down after them: no impact either way
    t = np.arange(2 * FS) / FS
    x = level * np.where(np.sin(2 * np.pi * 45.0 * t + 0.3) >= 0.0, 1.0, -1.0)
    with pytest.raises(AnalysisError, match="impacts"):
        analyze(x, FS)


def test_sawtooth_has_no_ticks():
    # a sawtooth's jumps are bursts of the whitened signal, 45 of them a second, with
    # bounce times that never shrink and no decaying response: no impact
    t = np.arange(FS) / FS
    with pytest.raises(AnalysisError, match="decaying"):
        analyze(0.5 * ((45.0 * t) % 1.0 - 0.5), FS)


@pytest.mark.slow
def test_twelve_drops_in_thirty_seconds():
    # the same drop (e = 0.8) every 2.5 s: twelve series of 21 ticks each, every tick found,
    # each series' restitution 0.8 to 0.1 %, nothing flagged (the search of each drop is
    # bounded by the next one's start, so the time grows with the file's length, not with
    # its square)
    parts = [drop(0.05 + 2.5 * k, 0.8, 0.3) for k in range(12)]
    truth = np.concatenate([p[0] for p in parts])
    an = analyze(ticks(truth, np.concatenate([p[1] for p in parts]), 30.0), FS)
    assert len(an.series) == 12 and len(an.ticks) == truth.size
    assert matched([t.time for t in an.ticks], truth) == truth.size
    for k, s in enumerate(an.series):
        assert len(s.ticks) == parts[k][0].size
        assert s.mean_restitution == pytest.approx(0.8, rel=1e-3)
    assert not any(t.flags for t in an.ticks)


def test_analyze_command_warns_on_a_truncated_file(tmp_path, capsys):
    # the command line says it in its own words, on stderr, and analyses what is there
    from synth.cli import main

    on, amps = drop(0.05, 0.8, 0.2)
    x = ticks(on, amps, 2.0)
    path = tmp_path / "cut.wav"
    soundfile.write(path, 0.5 * x / np.abs(x).max(), FS, subtype="PCM_16")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - FS * 2])
    code = main(["analyze", str(path)])
    out, err = capsys.readouterr()
    assert code == 0 and err.startswith("synth: warning: ") and "truncated" in err
    assert "TruncatedAudioWarning" not in err and out.startswith(f"{on[on < 1.0].size} ticks")


def test_analyze_file_on_a_directory_says_so(tmp_path):
    # A directory is not "no such file": the message names what it is.
    with pytest.raises(ParameterError, match="is a directory"):
        analyze_file(tmp_path)


# ---------------------------------------------------------------------------
# a band the recording does not hold


def _lifted_band_db(a: np.ndarray, lo: float, hi: float, top: float) -> float:
    """Mean power gain of the prediction-error filter ``a`` over ``top`` to the Nyquist
    frequency over its mean gain from ``lo`` to ``hi`` (fractions of the Nyquist), dB."""
    H = np.abs(np.fft.rfft(a, 1 << 16)) ** 2
    f = np.linspace(0.0, 1.0, H.size)
    return float(10.0 * np.log10(H[f > top].mean() / H[(f > lo) & (f < hi)].mean()))


def test_band_the_recording_lacks_is_not_lifted():
    # a series in white noise 60 dB under its first tick, then lowpassed at 0.8 times the
    # Nyquist frequency as a lossy encoder does: the band above holds nothing. The
    # autocorrelation method alone lifts it 46 dB over the noise band below (up to 90 dB,
    # its white-noise correction), where the step from the silence assumed before the first
    # sample, or any small error, then whitens to a burst; held at the noise the recording
    # starts in, it is lifted as the noise is, within 6 dB (the noise floor, from the frames
    # within 3 dB of the quietest, under the noise's mean power; the noise in 80 % of the
    # band, 1 dB)
    on, amps = drop(0.2, 0.7, 0.25)
    x = ticks(on, amps, 1.5, noise=1e-3)
    spectrum = np.fft.rfft(x)
    spectrum[np.linspace(0.0, 1.0, spectrum.size) > 0.8] = 0.0
    y = np.fft.irfft(spectrum, x.size)
    order = int(round(0.02 * FS))
    assert _lifted_band_db(dsp.autocorrelation_predictor(y, order), 0.6, 0.75, 0.85) > 40.0
    assert abs(_lifted_band_db(whitening_predictor(y, order, FS), 0.6, 0.75, 0.85)) < 6.0
    # a recording that starts with its first sound (a render, no noise before it) is
    # whitened as by the autocorrelation method alone, to the bit
    clean = ticks(on - on[0], amps, 1.5, noise=0.0)
    assert lead_in_noise(clean, FS) == 0.0
    assert np.array_equal(
        whitening_predictor(clean, order, FS), dsp.autocorrelation_predictor(clean, order)
    )
