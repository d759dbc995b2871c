"""Pictures of a render (synth/plot.py)."""

import dataclasses
import os
import struct
import sys
import types

import numpy as np
import pytest

from synth.errors import ParameterError, SynthError
from synth.physics.bounces import simulate_bounces
from synth.physics.scene import Ball, Plate

pytest.importorskip("matplotlib", reason="optional plot extra not installed")

from synth.io.plot import DPI, FIGSIZE, plot_render  # noqa: E402

SR = 48000
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def stand_in(impacts, sr=SR, channels=1, lead=0.01, tail=0.2, units="Pa"):
    """A Render look-alike: the first impact ``lead`` s into the audio, and two
    decaying partials started at each impact, amplitude proportional to the speed."""
    onsets = np.array([i.time for i in impacts]) - impacts[0].time + lead
    frames = int((impacts.duration - impacts[0].time + lead + tail) * sr)
    t = np.arange(frames) / sr
    signal = np.zeros(frames)
    for imp, onset in zip(impacts, onsets):
        start = int(np.ceil(onset * sr))
        dt = t[start:] - onset
        signal[start:] += (
            0.05
            * imp.speed
            * (
                np.sin(2 * np.pi * 820 * dt) * np.exp(-dt / 0.05)
                + 0.5 * np.sin(2 * np.pi * 3100 * dt) * np.exp(-dt / 0.02)
            )
        )
    gain = 0.9 / np.max(np.abs(signal))
    audio = (signal * gain).astype(np.float32)
    if channels > 1:
        audio = np.stack([audio * 0.8**c for c in range(channels)], axis=1)
    return types.SimpleNamespace(
        audio=audio,
        samplerate=sr,
        impacts=impacts,
        onsets=onsets,
        units=units,
        gain=float(gain),
        settings={
            "samplerate": sr,
            "normalize": "peak",
            "listener": "Microphone(position=(0.6, 0.25, 0.2))",
        },
    )


@pytest.fixture(scope="module")
def render():
    seq = simulate_bounces(
        Ball("steel", 0.005, mass=4.17e-3),
        Plate("mdf-18", 0.018, 1.227, 0.49),
        drop_height=0.1,
        max_impacts=10,
    )
    return stand_in(seq)


def png_size(path):
    """(width, height) from the IHDR chunk, which follows the signature (PNG spec 11.2.2)."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_plot_render(render, tmp_path):
    out = plot_render(render, tmp_path / "r.png")
    assert out == tmp_path / "r.png"
    # The figure is FIGSIZE inches at DPI dots per inch.
    assert png_size(out) == (round(FIGSIZE[0] * DPI), round(FIGSIZE[1] * DPI))
    assert os.listdir(tmp_path) == ["r.png"]  # no temporary file left behind
    # Something was drawn: the image is not one flat colour.
    import matplotlib.image

    img = matplotlib.image.imread(out)
    assert img[..., :3].std() > 0.05


def test_plot_render_multichannel_and_short_audio(render, tmp_path):
    # Two channels (waveform drawn as min/max envelope: more than 20000 frames).
    size = (round(FIGSIZE[0] * DPI), round(FIGSIZE[1] * DPI))
    two = stand_in(render.impacts, channels=2)
    assert two.audio.shape[0] > 20_000
    assert png_size(plot_render(two, tmp_path / "two.png")) == size
    # 5 ms of audio: shorter than a spectrogram frame, one impact, accelerometer units.
    one = dataclasses.replace(render.impacts, impacts=render.impacts.impacts[:1])
    short = stand_in(one, tail=0.005, units="m/s^2")
    assert short.audio.shape[0] < 0.02 * SR
    assert png_size(plot_render(short, tmp_path / "short.png")) == size


def test_plot_render_rejects_bad_input(render, tmp_path):
    with pytest.raises(ParameterError, match="r.jpg"):
        plot_render(render, tmp_path / "r.jpg")
    with pytest.raises(ParameterError, match="does not exist"):
        plot_render(render, tmp_path / "missing" / "r.png")
    for field, value in (
        ("gain", 0.0),
        ("units", "V"),
        ("samplerate", 0),
        ("audio", np.array([0.0, np.nan])),
        ("impacts", [object()]),
        ("onsets", "x"),
        ("onsets", [np.nan] * len(render.impacts)),
    ):
        bad = types.SimpleNamespace(**{**vars(render), field: value})
        with pytest.raises(ParameterError, match=field):
            plot_render(bad, tmp_path / "r.png")
    partial = types.SimpleNamespace(**{k: v for k, v in vars(render).items() if k != "gain"})
    with pytest.raises(ParameterError, match="'gain'"):
        plot_render(partial, tmp_path / "r.png")
    with pytest.raises(ParameterError, match="max_pulses"):
        plot_render(render, tmp_path / "r.png", max_pulses=-1)
    assert os.listdir(tmp_path) == []


def test_plot_render_rejects_missing_matplotlib(render, tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.setitem(sys.modules, name, None)  # importing any of them raises ImportError
    with pytest.raises(SynthError, match=r"pip install matplotlib.*impact-synth\[plot\]"):
        plot_render(render, tmp_path / "r.png")


def test_plot_render_rejects_failed_write(render, tmp_path, monkeypatch):
    # A failure while saving leaves neither the target nor a temporary file, and names the path.
    from matplotlib.figure import Figure

    def fail(self, fname, **kw):
        with open(fname, "wb") as fh:
            fh.write(PNG_SIGNATURE)
        raise OSError("disk full")

    monkeypatch.setattr(Figure, "savefig", fail)
    with pytest.raises(SynthError, match=r"r\.png.*disk full"):
        plot_render(render, tmp_path / "r.png")
    assert os.listdir(tmp_path) == []
