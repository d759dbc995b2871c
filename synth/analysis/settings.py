"""The checked inputs of :func:`synth.analysis.analyze`: the audio, and its options in samples
(:class:`Settings`); bad input raises :class:`~synth.errors.ParameterError`, nothing is clamped."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.analysis.options import DYNAMIC_RANGE_DB, OPTIONS, AnalysisOptions
from synth.errors import ParameterError, SynthError

#: Fewest samples in a frame of the detection function: at low rates the frames overlap, so that
#: noise's scatter over a few squares passes for no tick.
MIN_FRAME = 12
#: Longest gap bridged by the onset walk inside one burst (the zero crossings of a burst), s.
ONSET_GAP = 0.00025
#: Longest gap bridged by the onset walk in a doubtful candidate's weak burst, s: the longest
#: contact of a series (a slow ball on a soft board, about 0.5 ms), whose whitened burst is its two
#: end transients.
WEAK_ONSET_GAP = 0.0005
#: Length of the default whitening predictor, s (at least 8 samples).
WHITENING_SPAN = 0.02
#: The highest sample rate of audio converters, Hz.
MAX_SAMPLERATE = 768000.0


class AnalysisError(SynthError, ValueError):
    """The recording cannot be analysed: unreadable, silent, clipped, or without ticks."""


@dataclass(frozen=True)
class Settings:
    """The options of one recording: its rate and durations in samples, the options' other
    fields read through (:class:`AnalysisOptions`); ``innovation``: the recording's
    largest whitened magnitude."""

    options: AnalysisOptions
    samplerate: float  # Hz
    min_separation: int  # samples
    hop: int  # samples
    window: int  # samples
    decay_smoothing: int  # samples
    whitening_order: int
    innovation: float | None = None

    def __getattr__(self, name):
        if name in OPTIONS:
            return getattr(self.options, name)
        raise AttributeError(name)

    @property
    def dynamic_range_db(self) -> float:
        """The detection's floor, dB (:data:`DYNAMIC_RANGE_DB` unless given)."""
        given = self.options.dynamic_range_db
        return DYNAMIC_RANGE_DB if given is None else given

    @property
    def fixed_range(self) -> bool:
        """Whether ``dynamic_range_db`` was given."""
        return self.options.dynamic_range_db is not None

    @property
    def fixed_order(self) -> bool:
        """Whether ``lpc_order`` was given: that order alone, no step 7."""
        return self.options.lpc_order is not None

    @property
    def frame(self) -> int:
        """Samples summed in a frame of the detection function."""
        return max(self.hop, MIN_FRAME)

    @property
    def e_min(self) -> float:
        """Least restitution of a bounce, ``10^(-max_drop_db / 20)``."""
        return 10.0 ** (-self.max_drop_db / 20.0)

    @property
    def onset_gap(self) -> int:
        """Longest gap bridged by the onset walk, samples."""
        return max(2, int(round(ONSET_GAP * self.samplerate)))

    @property
    def weak_onset_gap(self) -> int:
        """Longest gap bridged by the onset walk in a weak burst, samples."""
        return max(self.onset_gap, int(round(WEAK_ONSET_GAP * self.samplerate)))


def make_settings(channels: int, samplerate, options: AnalysisOptions) -> Settings:
    """The :class:`Settings` of ``options`` for ``channels`` channels at ``samplerate`` Hz;
    ParameterError for a bad rate, channel or duration."""
    fs = checks.positive_at_most("samplerate", samplerate, MAX_SAMPLERATE, "Hz")
    o = options
    if o.channel is not None and not 0 <= o.channel < channels:
        raise ParameterError(
            f"channel={o.channel!r} is out of range: the audio has {channels} channel(s), "
            f"allowed 0..{channels - 1} or None (mix)"
        )
    return Settings(
        options=o,
        samplerate=fs,
        min_separation=_samples("min_separation", o.min_separation, fs),
        hop=_samples("hop", o.hop, fs),
        window=_samples("window", o.window, fs),
        decay_smoothing=_samples("decay_smoothing", o.decay_smoothing, fs, lo=3),
        whitening_order=(
            max(8, int(round(WHITENING_SPAN * fs))) if o.lpc_order is None else o.lpc_order
        ),
    )


def audio_array(audio) -> np.ndarray:
    """``audio`` as float64 ``(frames, channels)``: real, finite, not empty."""
    a = audio if isinstance(audio, np.ndarray) else np.asarray(audio)
    if a.dtype == bool or not (
        np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)
    ):
        raise ParameterError(f"audio must hold real samples (floats), not dtype {a.dtype}")
    if a.ndim not in (1, 2):
        raise ParameterError(f"audio must be (frames,) or (frames, channels), got shape {a.shape}")
    if a.size == 0:
        raise ParameterError(f"audio is empty (shape {a.shape})")
    a = a.astype(np.float64, copy=False)
    finite = np.isfinite(a)
    if not finite.all():
        raise ParameterError(
            f"audio holds {a.size - int(np.count_nonzero(finite))} NaN or infinite samples; "
            f"all must be finite"
        )
    return a if a.ndim == 2 else a[:, None]


def _samples(name: str, seconds: float, fs: float, lo: int = 1) -> int:
    """A duration in s, as a whole number of samples (at least ``lo``)."""
    n = int(round(seconds * fs))
    if n < lo:
        raise ParameterError(f"{name}={seconds!r} is shorter than {lo} sample(s) at {fs:g} Hz (s)")
    return n


def check_recording_path(path) -> None:
    """Raise ``ParameterError`` unless ``path`` names an existing file (not a directory)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file name, not {type(path).__name__}")
    if os.path.isdir(path):
        raise ParameterError(f"path={os.fspath(path)!r} is a directory, not an audio file")
    if not os.path.isfile(path):
        raise ParameterError(f"path={os.fspath(path)!r}: no such file")


def read_recording(path) -> tuple[np.ndarray, float]:
    """Read a sound file (WAV, FLAC, OGG, AIFF, ..., any rate and channels) for
    :func:`synth.analysis.analyze`: ``(audio, samplerate)``, the samples as float64 ``(frames,
    channels)`` in units of full scale and the rate in Hz. Warns ``TruncatedAudioWarning`` where
    a WAV file holds fewer frames than its header declares. Raises ParameterError for a bad or
    missing ``path``, AnalysisError for an unreadable file or one without samples."""
    check_recording_path(path)
    from synth.store.audio import AudioFileError, read_audio

    try:
        audio, samplerate = read_audio(path)  # the one reader: formats, truncation warning
    except AudioFileError as exc:
        raise AnalysisError(f"cannot read {os.fspath(path)!r} as sound: {exc}") from None
    if audio.shape[0] == 0:  # before the reshape: (0,) has no channel count to infer
        raise AnalysisError(f"{os.fspath(path)!r} holds no samples")
    audio = audio.reshape(audio.shape[0], -1)
    return audio, float(samplerate)
