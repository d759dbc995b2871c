"""Altering a recording's restitution (thesis section 5.2.2)."""

import math

import numpy as np
import pytest

import synth
from synth.alter import alter_restitution, extend
from synth.errors import ParameterError
from synth.render import render

FS = 48000


@pytest.fixture(scope="module")
def recording():
    r = render(synth.load_preset("default"), samplerate=FS)
    return r.audio.astype(float), [imp.time for imp in r.impacts]


def test_scale_one_returns_the_recording(recording):
    # k = 1 changes nothing: the segments and their crossfades add back to the input (rounding).
    x, on = recording
    y, t_new, e, e_new = alter_restitution(x, FS, 1.0, onsets=on)
    assert y.shape == x.shape
    assert np.max(np.abs(y - x)) < 1e-9
    assert np.allclose(t_new, on, rtol=0, atol=1e-12)


@pytest.mark.parametrize("k", [0.5, 2.0])
def test_new_timing_follows_the_rule(recording, k):
    # e_n = T_n / T_(n-1); e'_n = 1 - k (1 - e_n); T'_n = e'_n T'_(n-1), T'_1 = T_1 (1e-12).
    x, on = recording
    y, t_new, e, e_new = alter_restitution(x, FS, k, onsets=on)
    T = np.diff(on)
    Tn = np.diff(t_new)
    assert np.allclose(e, T[1:] / T[:-1], rtol=1e-12)
    assert np.allclose(e_new, 1 - k * (1 - e), rtol=1e-12)
    assert Tn[0] == pytest.approx(T[0], rel=1e-12)
    assert np.allclose(Tn[1:] / Tn[:-1], e_new, rtol=1e-12)


def test_no_silence_and_no_click_where_bounces_lengthen(recording):
    # k = 0.5 lengthens every bounce: the tails are continued, never silenced. A tail decays
    # smoothly (the default plate loses at most a few dB per millisecond), so no 1 ms window
    # may fall more than 20 dB below the one before it, and none is zero. No join is sharper
    # than the recording around it (the largest sample-to-sample step in each join is below
    # the largest step of the tick before it).
    x, on = recording
    y, t_new, e, e_new = alter_restitution(x, FS, 0.5, onsets=on, scale_amplitude=False)
    w = FS // 1000
    a, b = int(t_new[0] * FS), int(t_new[40] * FS)
    rms = np.sqrt(np.mean(y[a:b][: (b - a) // w * w].reshape(-1, w) ** 2, axis=1))
    assert np.all(rms > 0.0)
    assert np.min(rms[1:] / rms[:-1]) > 0.1
    step = np.abs(np.diff(y))
    for i in range(1, 40):
        j = int(round(t_new[i] * FS)) - w          # the join starts 1 ms before the onset
        tick = int(round(t_new[i - 1] * FS))
        assert step[j:j + w].max() <= step[tick:tick + 2 * w].max()


def test_extend_continues_decaying_modes():
    # Linear prediction continues a sum of decaying sinusoids exactly (1e-9), and a rendered
    # tick's tail 100 ms after its onset to 1e-3 (30 ms ahead).
    t = np.arange(4000) / FS
    x = np.exp(-30 * t) * np.sin(2 * np.pi * 440 * t) + 0.5 * np.exp(-80 * t) * np.sin(2 * np.pi * 1234 * t + 1)
    ext = extend(x[:2000], 2000)
    assert np.linalg.norm(ext - x[2000:]) / np.linalg.norm(x[2000:]) < 1e-9
    s = synth.load_preset("default")
    seq = synth.simulate_scene(s, max_impacts=1)
    r = render(s, samplerate=FS, sequence=seq, normalize="none")
    a = r.audio.astype(float)
    o = int(r.impacts[0].time * FS)
    cut, n = o + int(0.1 * FS), int(0.03 * FS)
    ext = extend(a[o + 96:cut], n)
    assert np.linalg.norm(ext - a[cut:cut + n]) / np.linalg.norm(a[cut:cut + n]) < 1e-3


def test_alter_rejects_bad_input(recording):
    x, on = recording
    with pytest.raises(ParameterError, match="restitution_scale"):
        alter_restitution(x, FS, -1.0, onsets=on)
    with pytest.raises(ParameterError, match="e' <= 0"):
        alter_restitution(x, FS, 50.0, onsets=on)
    with pytest.raises(ParameterError, match="onsets"):
        alter_restitution(x, FS, 0.5, onsets=[0.1, 0.05, 0.3])
    with pytest.raises(ParameterError, match="samplerate"):
        alter_restitution(x, 0, 0.5, onsets=on)
    with pytest.raises(ParameterError, match="NaN"):
        alter_restitution(np.full(100, np.nan), FS, 0.5, onsets=on)
    with pytest.raises(ParameterError, match="crossfade"):
        alter_restitution(x, FS, 0.5, onsets=on, crossfade=0.0)
