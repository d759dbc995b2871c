"""The checked inputs of :func:`synth.analysis.analyze`: the audio, and its options in samples
(:class:`Settings`); bad input raises :class:`~synth.errors.ParameterError`, nothing is clamped."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.analysis.options import DYNAMIC_RANGE_DB, AnalysisOptions
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
    """The options for one recording, durations in samples; ``fixed_range``: range given;
    ``innovation``: the recording's largest whitened magnitude."""

    samplerate: float  # Hz
    gravity: float  # m/s^2
    channel: int | None
    min_separation: int  # samples
    hop: int  # samples
    threshold_db: float
    rise_db: float
    release: float  # dB/ms
    dynamic_range_db: float
    fixed_range: bool
    max_drop_db: float
    background: float  # s
    onset_fraction: float
    whitening_order: int
    fixed_order: bool  # lpc_order given: that order alone, no step 7
    window: int  # samples
    subtract_tails: bool
    deflate: bool
    decay_smoothing: int  # samples
    clip_samples: int
    on_clipping: str
    innovation: float | None = None

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
    lpc_order = o.lpc_order
    return Settings(
        samplerate=fs,
        gravity=o.gravity,
        channel=_channel(o.channel, channels),
        min_separation=_samples("min_separation", o.min_separation, fs),
        hop=_samples("hop", o.hop, fs),
        threshold_db=o.threshold_db,
        rise_db=o.rise_db,
        release=o.release,
        dynamic_range_db=DYNAMIC_RANGE_DB if o.dynamic_range_db is None else o.dynamic_range_db,
        fixed_range=o.dynamic_range_db is not None,
        max_drop_db=o.max_drop_db,
        background=o.background,
        onset_fraction=o.onset_fraction,
        whitening_order=max(8, int(round(WHITENING_SPAN * fs))) if lpc_order is None else lpc_order,
        fixed_order=lpc_order is not None,
        window=_samples("window", o.window, fs),
        subtract_tails=o.subtract_tails,
        deflate=o.deflate,
        decay_smoothing=_samples("decay_smoothing", o.decay_smoothing, fs, lo=3),
        clip_samples=o.clip_samples,
        on_clipping=o.on_clipping,
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


def _channel(channel: int | None, n: int) -> int | None:
    if channel is not None and not 0 <= channel < n:
        raise ParameterError(
            f"channel={channel!r} is out of range: the audio has {n} channel(s), "
            f"allowed 0..{n - 1} or None (mix)"
        )
    return channel


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
