"""Playback through ``sounddevice``, imported only when playing: without the PortAudio C
library its import fails, and the :class:`SynthError` says what to install.
"""

from __future__ import annotations

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError

PORTAUDIO_HELP = (
    "playback needs the PortAudio library: on Debian/Ubuntu `apt-get install "
    "libportaudio2`, on Fedora `dnf install portaudio`, on macOS `brew install "
    "portaudio` (Windows wheels of sounddevice include it)"
)


def sounddevice_module():
    """The ``sounddevice`` module, imported on first use: a SynthError saying what to install
    when it or the PortAudio library is missing."""
    try:
        import sounddevice
    except OSError as exc:  # sounddevice is installed, PortAudio is not
        raise SynthError(f"{PORTAUDIO_HELP} ({exc})") from None
    except ImportError as exc:
        raise SynthError(
            f"playback needs the sounddevice package: pip install sounddevice ({exc})"
        ) from None
    return sounddevice


def play(audio, samplerate: float | None = None, *, blocking: bool = True) -> None:
    """Play a :class:`~synth.sound.render.Render`, or an array at ``samplerate`` Hz;
    ``blocking=False`` returns at once (:func:`stop` ends it)."""
    if hasattr(audio, "audio") and hasattr(audio, "samplerate"):
        audio, samplerate = audio.audio, audio.samplerate if samplerate is None else samplerate
    if samplerate is None:
        raise ParameterError("samplerate=None: give the sample rate in Hz (there is no default)")
    fs = checks.positive("samplerate", samplerate, "Hz")
    x = np.asarray(checks.audio_array("audio", audio), dtype=np.float32)
    sd = sounddevice_module()
    sd.play(x, int(round(fs)), blocking=blocking)


def stop() -> None:
    """Stop a playback started with ``blocking=False``."""
    sounddevice_module().stop()
