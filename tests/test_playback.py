"""Playback: sounddevice is imported only to play, and a missing PortAudio is explained."""

import builtins
import subprocess
import sys

import numpy as np
import pytest

from synth.errors import ParameterError, SynthError
from synth.io import playback


def test_importing_synth_does_not_import_sounddevice():
    # The design rule: no sounddevice (nor matplotlib, pyloudnorm, dask) at import.
    code = (
        "import sys, synth; bad = [m for m in ('sounddevice', 'matplotlib', 'pyloudnorm', 'dask') "
        "if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_missing_portaudio_says_what_to_install(monkeypatch):
    # sounddevice raises OSError when PortAudio is missing: the error names the package.
    real_import = builtins.__import__

    def fake(name, *a, **k):
        if name == "sounddevice":
            raise OSError("PortAudio library not found")
        return real_import(name, *a, **k)

    monkeypatch.delitem(sys.modules, "sounddevice", raising=False)
    monkeypatch.setattr(builtins, "__import__", fake)
    with pytest.raises(SynthError, match="libportaudio2"):
        playback.play(np.zeros(100, np.float32), 48000)


def test_play_calls_sounddevice(monkeypatch):
    # With a stand-in sounddevice, play passes float32 audio and the rate in Hz.
    calls = []

    class FakeSD:
        @staticmethod
        def play(x, fs, blocking=True):
            calls.append((x.dtype, x.shape, fs, blocking))

    monkeypatch.setitem(sys.modules, "sounddevice", FakeSD)
    playback.play(np.zeros(10), 44100, blocking=False)
    assert calls == [(np.float32, (10,), 44100, False)]


@pytest.mark.parametrize(
    "audio, fs, word",
    [
        (np.zeros(10), None, "samplerate"),
        (np.zeros(10), -1.0, "samplerate"),
        (np.array([np.nan]), 48000, "audio"),
        (np.zeros(0), 48000, "audio"),
    ],
)
def test_play_rejects_bad_input(audio, fs, word):
    with pytest.raises(ParameterError, match=word):
        playback.play(audio, fs)
