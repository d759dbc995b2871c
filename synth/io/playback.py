"""Live playback through ``sounddevice`` (imported only here, only when playing).

``sounddevice`` loads the PortAudio C library when it is imported; on a machine without it
the import fails with an ``OSError``. :func:`play` turns that into a :class:`SynthError`
that says what to install.
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
    """Play ``audio``: a :class:`~synth.sound.render.Render`, or an array with ``samplerate``
    in Hz.

    ``blocking=False`` returns at once (``sounddevice.wait()`` or :func:`stop` later).
    """
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
