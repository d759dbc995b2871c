"""The output stage: audio files, levels and fades (synth/audio_io.py)."""

import math
import os
import sys

import numpy as np
import pytest
import soundfile

from synth.errors import ParameterError, SynthError
from synth.store.audio import (
    PHYSICAL_FULL_SCALE,
    AudioFileError,
    apply_fade_out,
    normalize,
    read_audio,
    write_audio,
)

SR = 48000


def ramp_and_noise(frames=4801, channels=None, seed=0):
    """Full-scale ramp (both ends of the range) plus random samples in [-1, 1]."""
    rng = np.random.default_rng(seed)
    x = np.concatenate(
        [np.linspace(-1.0, 1.0, frames // 2), rng.uniform(-1, 1, frames - frames // 2)]
    )
    if channels is None:
        return x
    return np.stack([x * (0.9**c) for c in range(channels)], axis=1)


def decaying_tone(duration=1.0, f=1000.0, decay=0.1, amplitude=0.2, sr=SR):
    t = np.arange(int(duration * sr)) / sr
    return amplitude * np.sin(2 * np.pi * f * t) * np.exp(-t / decay)


# --------------------------------------------------------------------------- write / read


# libsndfile stores round(x * 2^(b-1)), clipped to 2^(b-1) - 1, and reads code / 2^(b-1):
# the error is half a step everywhere and one step 2^-(b-1) at +1.0.
@pytest.mark.parametrize("suffix", [".wav", ".flac"])
@pytest.mark.parametrize("subtype,bits", [("PCM_16", 16), ("PCM_24", 24)])
def test_write_audio_round_trip_pcm(tmp_path, suffix, subtype, bits):
    x = ramp_and_noise()
    path = write_audio(tmp_path / f"x{suffix}", x, SR, subtype=subtype)
    y, sr = read_audio(path)
    assert sr == SR
    assert y.shape == x.shape and y.dtype == np.float64
    assert np.max(np.abs(y - x)) <= 2.0 ** -(bits - 1)
    assert soundfile.info(str(path)).subtype == subtype


def test_write_audio_round_trip_float_is_exact(tmp_path):
    # 32-bit float WAV stores float32 samples bit for bit.
    x = ramp_and_noise().astype(np.float32) * 3.0
    write_audio(tmp_path / "x.wav", x, SR, subtype="FLOAT")
    y, _ = read_audio(tmp_path / "x.wav")
    assert np.array_equal(y, x.astype(np.float64))


def test_write_audio_default_subtype_is_pcm_24(tmp_path):
    # The documented default for both formats.
    for suffix in (".wav", ".flac"):
        write_audio(tmp_path / f"d{suffix}", ramp_and_noise(), SR)
        assert soundfile.info(str(tmp_path / f"d{suffix}")).subtype == "PCM_24"


def test_write_audio_two_dimensional(tmp_path):
    # (frames, channels) in, the same layout out; PCM_24 step 2^-23.
    x = ramp_and_noise(channels=3)
    write_audio(tmp_path / "x.flac", x, 44100)
    y, sr = read_audio(tmp_path / "x.flac")
    assert sr == 44100 and y.shape == (x.shape[0], 3)
    assert np.max(np.abs(y - x)) <= 2.0**-23


def test_write_audio_refuses_to_clip_pcm(tmp_path):
    x = np.array([0.0, 1.5, -0.5])
    for suffix in (".wav", ".flac"):
        with pytest.raises(ParameterError, match=r"peak 1\.5 .*normalize='peak'"):
            write_audio(tmp_path / f"c{suffix}", x, SR, subtype="PCM_16")
        assert not (tmp_path / f"c{suffix}").exists()
    # A float WAV holds samples beyond full scale exactly (1.5 is a float32).
    write_audio(tmp_path / "c.wav", x, SR, subtype="FLOAT")
    assert read_audio(tmp_path / "c.wav")[0][1] == 1.5


def test_write_audio_rejects_bad_suffix(tmp_path):
    for name in ("x.mp3", "x.txt", "x"):
        with pytest.raises(ParameterError, match=name):
            write_audio(tmp_path / name, ramp_and_noise(), SR)


def test_write_audio_rejects_missing_directory(tmp_path):
    target = tmp_path / "no" / "such" / "x.wav"
    with pytest.raises(ParameterError, match="does not exist"):
        write_audio(target, ramp_and_noise(), SR)
    assert not (tmp_path / "no").exists()  # no directory created silently


@pytest.mark.parametrize("samplerate", [0, -1, 44100.5, None, True, "48000"])
def test_write_audio_rejects_bad_samplerate(tmp_path, samplerate):
    with pytest.raises(ParameterError, match="samplerate"):
        write_audio(tmp_path / "x.wav", ramp_and_noise(), samplerate)


@pytest.mark.parametrize(
    "audio",
    [
        np.array([0.0, np.nan, 0.1]),
        np.array([np.inf]),
        np.zeros(0),
        np.zeros((0, 2)),
        np.zeros((4, 2, 2)),
        np.array([0, 1, -1], dtype=np.int16),
        None,
        "audio",
    ],
)
def test_write_audio_rejects_bad_audio(tmp_path, audio):
    with pytest.raises(ParameterError, match="audio"):
        write_audio(tmp_path / "x.wav", audio, SR)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(
    "suffix,subtype", [(".flac", "FLOAT"), (".wav", "PCM_99"), (".wav", 16), (".flac", "VORBIS")]
)
def test_write_audio_rejects_bad_subtype(tmp_path, suffix, subtype):
    with pytest.raises(ParameterError, match="subtype"):
        write_audio(tmp_path / f"x{suffix}", ramp_and_noise(), SR, subtype=subtype)


def _failing_write(real_write):
    """soundfile.write that writes part of the file, then fails."""

    def write(file, data, samplerate, **kw):
        real_write(file, data[:10], samplerate, **kw)
        with open(file, "ab") as fh:
            fh.write(b"partial")
        raise OSError("disk full")

    return write


def test_write_audio_is_atomic(tmp_path, monkeypatch):
    # A failed write leaves neither the target nor a temporary file.
    monkeypatch.setattr(soundfile, "write", _failing_write(soundfile.write))
    with pytest.raises(OSError, match="disk full"):
        write_audio(tmp_path / "x.wav", ramp_and_noise(), SR)
    assert os.listdir(tmp_path) == []


def test_write_audio_is_atomic_keeps_existing_file(tmp_path, monkeypatch):
    target = tmp_path / "x.wav"
    write_audio(target, ramp_and_noise(), SR)
    before = target.read_bytes()
    monkeypatch.setattr(soundfile, "write", _failing_write(soundfile.write))
    with pytest.raises(OSError):
        write_audio(target, 0.5 * ramp_and_noise(), SR)
    assert target.read_bytes() == before
    assert os.listdir(tmp_path) == ["x.wav"]


def test_write_audio_leaves_no_temporary_file(tmp_path):
    write_audio(tmp_path / "x.wav", ramp_and_noise(), SR)
    write_audio(tmp_path / "x.wav", ramp_and_noise(seed=1), SR)  # overwrite
    assert os.listdir(tmp_path) == ["x.wav"]


def test_write_audio_is_atomic_rejects_directory_target(tmp_path):
    (tmp_path / "d.wav").mkdir()
    with pytest.raises(ParameterError, match="directory"):
        write_audio(tmp_path / "d.wav", ramp_and_noise(), SR)


def test_read_audio_channels(tmp_path):
    # FLOAT storage is exact for float32 data, so the selection and the mean are exact.
    x = ramp_and_noise(channels=3).astype(np.float32).astype(np.float64)
    write_audio(tmp_path / "m.wav", x, SR, subtype="FLOAT")
    y, _ = read_audio(tmp_path / "m.wav")
    assert y.shape == x.shape
    for c in range(3):
        assert np.array_equal(read_audio(tmp_path / "m.wav", channel=c)[0], x[:, c])
    mix, _ = read_audio(tmp_path / "m.wav", channel="mix")
    assert mix.shape == (x.shape[0],)
    assert np.max(np.abs(mix - x.mean(axis=1))) <= 1e-15
    # A mono file: 1-D whatever the selection.
    write_audio(tmp_path / "mono.wav", x[:, 0], SR, subtype="FLOAT")
    for ch in (None, 0, "mix"):
        assert np.array_equal(read_audio(tmp_path / "mono.wav", channel=ch)[0], x[:, 0])


def test_read_audio_rejects_bad_channel(tmp_path):
    write_audio(tmp_path / "m.wav", ramp_and_noise(channels=2), SR)
    for ch in (2, -1):
        with pytest.raises(ParameterError, match=r"channel=.*out of range.*2 channels"):
            read_audio(tmp_path / "m.wav", channel=ch)
    for ch in ("left", 1.0, True):
        with pytest.raises(ParameterError, match="channel"):
            read_audio(tmp_path / "m.wav", channel=ch)


def test_read_audio_rejects_missing_file(tmp_path):
    with pytest.raises(AudioFileError, match="no such file"):
        read_audio(tmp_path / "missing.wav")
    with pytest.raises(AudioFileError, match="not a file"):
        read_audio(tmp_path)


def test_read_audio_rejects_corrupt_file(tmp_path):
    bad = tmp_path / "x.wav"
    bad.write_bytes(b"RIFF\x00\x00garbage, not a wave header" * 10)
    with pytest.raises(
        AudioFileError, match=r"cannot read .*x\.wav.*corrupt or unsupported.*not recognised"
    ):
        read_audio(bad)
    # AudioFileError belongs to the project's tree and is a ValueError.
    assert issubclass(AudioFileError, ParameterError) and issubclass(AudioFileError, ValueError)


# --------------------------------------------------------------------------- levels


def test_normalize_peak():
    x = decaying_tone(0.2)
    y, gain = normalize(x, "peak", samplerate=SR, units="Pa", peak_db=-3.0)
    target = 10 ** (-3.0 / 20)
    # The largest sample at the target (and never above it), y = x * gain.
    assert abs(np.max(np.abs(y)) - target) <= 1e-6
    assert np.max(np.abs(y)) <= target
    assert np.max(np.abs(y - x * gain)) <= 1e-15
    # 0 dBFS gives exactly full scale: PCM writes accept it.
    y0, _ = normalize(x, "peak", samplerate=SR, units="Pa", peak_db=0.0)
    assert np.max(np.abs(y0)) == 1.0


def test_normalize_keeps_float32():
    x = decaying_tone(0.2).astype(np.float32)
    y, gain = normalize(x, "peak", samplerate=SR, units="Pa")
    assert y.dtype == np.float32
    assert abs(np.max(np.abs(y)) - 10 ** (-1 / 20)) <= 1e-6  # float32 rounding 6e-8


def test_normalize_silence_has_gain_one():
    # Documented: all-zero audio has no level to set; it comes back unchanged.
    for mode in ("peak", "loudness"):
        y, gain = normalize(np.zeros(1000), mode, samplerate=SR, units="Pa")
        assert gain == 1.0 and not y.any()


def test_normalize_loudness():
    pyln = pytest.importorskip("pyloudnorm", reason="optional loudness extra not installed")
    x = np.stack([decaying_tone(1.0, 440.0), decaying_tone(1.0, 1300.0, 0.3, 0.05)], axis=1)
    y, gain = normalize(x, "loudness", samplerate=SR, units="Pa", loudness_lufs=-20.0)
    # Measured again by the reference implementation of BS.1770.
    assert abs(pyln.Meter(SR).integrated_loudness(y) - (-20.0)) <= 0.1
    assert np.max(np.abs(y - x * gain)) <= 1e-15


def test_normalize_loudness_short_audio_is_padded():
    pyln = pytest.importorskip("pyloudnorm", reason="optional loudness extra not installed")
    # 50 ms tick: measured as if followed by silence up to one 400 ms block.
    x = decaying_tone(0.05, 2000.0, 0.01)
    y, _ = normalize(x, "loudness", samplerate=SR, units="Pa", loudness_lufs=-30.0)
    padded = np.pad(y, (0, int(0.4 * SR) - y.size))
    assert abs(pyln.Meter(SR).integrated_loudness(padded) - (-30.0)) <= 0.1


def test_normalize_loudness_rejects_peak_above_full_scale():
    pytest.importorskip("pyloudnorm", reason="optional loudness extra not installed")
    # Sparse clicks have a large crest factor: -5 LUFS needs a peak far above 0 dBFS.
    x = np.zeros(SR)
    x[::4800] = 0.1
    with pytest.raises(ParameterError, match=r"sample peak at .*dBFS.*lower loudness_lufs"):
        normalize(x, "loudness", samplerate=SR, units="Pa", loudness_lufs=-5.0)
    # With the limit lifted (for a float file), the result exceeds full scale, unclipped.
    y, gain = normalize(x, "loudness", samplerate=SR, units="Pa", loudness_lufs=-5.0, max_peak=None)
    assert np.max(np.abs(y)) > 1.0
    assert np.max(np.abs(y - x * gain)) <= 1e-12


def test_normalize_loudness_rejects_missing_pyloudnorm(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyloudnorm", None)  # import raises ImportError
    with pytest.raises(SynthError, match=r"pip install pyloudnorm.*impact-synth\[loudness\]"):
        normalize(decaying_tone(0.5), "loudness", samplerate=SR, units="Pa")


def test_normalize_loudness_rejects_unmeasurable_audio():
    pytest.importorskip("pyloudnorm", reason="optional loudness extra not installed")
    # A 4 s raised-cosine swell (content near 0.25 Hz) is removed by the K-weighting
    # high-pass (about 38 Hz, 12 dB/octave): every block is far below the -70 LUFS gate.
    t = np.arange(4 * SR) / SR
    with pytest.raises(ParameterError, match="no measurable loudness"):
        normalize(0.5 * (1 - np.cos(2 * np.pi * t / 4.0)), "loudness", samplerate=SR, units="Pa")
    with pytest.raises(ParameterError, match="6 channels"):
        normalize(
            np.ones((SR, 6)) * decaying_tone(1.0)[:, None], "loudness", samplerate=SR, units="Pa"
        )


@pytest.mark.slow  # three renders to 12 kHz, the plate's modes in the contact in two
@pytest.mark.parametrize(
    "preset", ["thesis-glass17-mdf12", "thesis-steel10-mdf6", "ceramic-cup-on-stone"]
)
def test_physical_level_fits_the_loudest_presets(preset, tmp_path):
    # The calibration leaves headroom for the engine's own loudest scenes (microphone and
    # accelerometer): their physical render writes to a 24-bit file without clipping.
    import synth

    r = synth.render_preset(preset, normalize="physical", max_frequency=12000.0)
    assert 0.0 < np.max(np.abs(r.audio)) < 10 ** (-6 / 20)
    synth.write_audio(tmp_path / "x.wav", r.audio, r.samplerate)


def test_normalize_physical():
    # Fixed calibration: 1000 Pa (154 dB SPL re 20 uPa) and 10 000 m/s^2 are full scale.
    assert 20 * math.log10(PHYSICAL_FULL_SCALE["Pa"] / 20e-6) == pytest.approx(154.0, abs=0.1)
    x = decaying_tone(0.1, amplitude=1500.0)  # above full scale: kept, not clipped
    y, gain = normalize(x, "physical", samplerate=SR, units="Pa")
    assert gain == 1 / 1000
    assert np.max(np.abs(y)) == pytest.approx(np.max(np.abs(x)) / 1000, rel=1e-15)
    assert np.max(np.abs(y)) > 1.0
    _, gain_acc = normalize(x, "physical", samplerate=SR, units="m/s^2")
    assert gain_acc == 1 / 10000
    # The same gain for any scene: the level relation between scenes is kept.
    _, gain_quiet = normalize(x * 1e-3, "physical", samplerate=SR, units="Pa")
    assert gain_quiet == gain


def test_normalize_none():
    x = decaying_tone(0.1)
    y, gain = normalize(x, "none", samplerate=SR, units="m/s^2")
    assert gain == 1.0 and np.array_equal(y, x)


@pytest.mark.parametrize(
    "kw,field",
    [
        (dict(mode="rms"), "mode"),
        (dict(peak_db=1.0), "peak_db"),
        (dict(peak_db=float("nan")), "peak_db"),
        (dict(loudness_lufs=3.0), "loudness_lufs"),
        (dict(loudness_lufs="loud"), "loudness_lufs"),
        (dict(units="dB"), "units"),
        (dict(samplerate=0), "samplerate"),
        (dict(samplerate=48000.0), "samplerate"),
        (dict(max_peak=0.0), "max_peak"),
        (dict(audio=np.array([1.0, np.nan])), "audio"),
        (dict(audio=np.arange(4)), "audio"),
    ],
)
def test_normalize_rejects_bad_input(kw, field):
    args = dict(audio=decaying_tone(0.1), mode="peak", samplerate=SR, units="Pa")
    args.update(kw)
    with pytest.raises(ParameterError, match=field):
        normalize(args.pop("audio"), args.pop("mode"), **args)


# --------------------------------------------------------------------------- fade


def test_fade_out_window():
    x = np.ones((1000, 2))
    y = x.copy()
    apply_fade_out(y, 100)
    # Untouched before the fade; w = (1 + cos(pi (k+1)/n)) / 2: 0.5 at k+1 = n/2, 0 at the end.
    assert np.array_equal(y[:900], x[:900])
    assert y[949, 0] == pytest.approx(0.5, abs=1e-15)
    assert np.array_equal(y[-1], [0.0, 0.0])
    # Monotonic decrease and the mean of half a Hann window: 1/2 - 1/(2n) for this sampling.
    assert np.all(np.diff(y[899:, 0]) < 0)
    assert y[900:, 0].mean() == pytest.approx(0.5 - 1 / 200, abs=1e-12)
    apply_fade_out(x, 0)
    assert np.array_equal(x, np.ones((1000, 2)))  # 0 frames: nothing changes
