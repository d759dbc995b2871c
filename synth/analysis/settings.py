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
    """The options of one recording in samples (durations, the detection frame, the onset walk's
    gaps), its rate (Hz) and the detection's floor (dB: :data:`DYNAMIC_RANGE_DB` unless given);
    the options' other fields read through; ``innovation``: the largest whitened magnitude."""

    options: AnalysisOptions
    samplerate: float
    min_separation: int
    hop: int
    frame: int  # samples summed in a frame of the detection function
    window: int
    decay_smoothing: int
    whitening_order: int
    onset_gap: int
    weak_onset_gap: int
    dynamic_range_db: float
    e_min: float  # least restitution of a bounce, 10^(-max_drop_db / 20)
    innovation: float | None = None

    def __getattr__(self, name):
        if name in OPTIONS:
            return getattr(self.options, name)
        raise AttributeError(name)

    #: Whether ``dynamic_range_db`` was given; whether ``lpc_order`` was (that order, no step 7).
    fixed_range = property(lambda self: self.options.dynamic_range_db is not None)
    fixed_order = property(lambda self: self.options.lpc_order is not None)


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

    def samples(name: str, lo: int = 1) -> int:  # a duration option in samples, at least lo
        n = int(round(getattr(o, name) * fs))
        if n < lo:
            raise ParameterError(
                f"{name}={getattr(o, name)!r} is shorter than {lo} sample(s) at {fs:g} Hz (s)"
            )
        return n

    hop, onset_gap = samples("hop"), max(2, int(round(ONSET_GAP * fs)))
    return Settings(
        options=o,
        samplerate=fs,
        min_separation=samples("min_separation"),
        hop=hop,
        frame=max(hop, MIN_FRAME),
        window=samples("window"),
        decay_smoothing=samples("decay_smoothing", lo=3),
        whitening_order=(
            max(8, int(round(WHITENING_SPAN * fs))) if o.lpc_order is None else o.lpc_order
        ),
        onset_gap=onset_gap,
        weak_onset_gap=max(onset_gap, int(round(WEAK_ONSET_GAP * fs))),
        dynamic_range_db=DYNAMIC_RANGE_DB if o.dynamic_range_db is None else o.dynamic_range_db,
        e_min=10.0 ** (-o.max_drop_db / 20.0),
    )


def audio_array(audio) -> np.ndarray:
    """``audio`` as float64 ``(frames, channels)``: real, finite, not empty."""
    a = np.asarray(audio)
    if a.dtype.kind not in "fiu":  # no bool, complex, string or object samples
        raise ParameterError(f"audio must hold real samples (floats), not dtype {a.dtype}")
    if a.ndim not in (1, 2):
        raise ParameterError(f"audio must be (frames,) or (frames, channels), got shape {a.shape}")
    if a.size == 0:
        raise ParameterError(f"audio is empty (shape {a.shape})")
    a = a.astype(np.float64, copy=False)
    bad = a.size - int(np.count_nonzero(np.isfinite(a)))
    if bad:
        raise ParameterError(f"audio holds {bad} NaN or infinite samples; all must be finite")
    return a if a.ndim == 2 else a[:, None]


def check_recording_path(path) -> None:
    """Raise ``ParameterError`` unless ``path`` names an existing file (not a directory)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file name, not {type(path).__name__}")
    if os.path.isdir(path):
        raise ParameterError(f"path={os.fspath(path)!r} is a directory, not an audio file")
    if not os.path.isfile(path):
        raise ParameterError(f"path={os.fspath(path)!r}: no such file")


def read_recording(path) -> tuple[np.ndarray, float]:
    """A sound file (WAV, FLAC, OGG, AIFF, ...) as ``(audio, samplerate)``: float64 ``(frames,
    channels)`` in units of full scale, Hz. Warns ``TruncatedAudioWarning`` where a WAV file holds
    fewer frames than its header declares; ParameterError for a bad or missing ``path``,
    AnalysisError for an unreadable file or one without samples."""
    check_recording_path(path)
    from synth.store.audio import AudioFileError, read_audio

    try:
        audio, samplerate = read_audio(path)  # the one reader: formats, truncation warning
    except AudioFileError as exc:
        raise AnalysisError(f"cannot read {os.fspath(path)!r} as sound: {exc}") from None
    if audio.shape[0] == 0:  # before the reshape: (0,) has no channel count to infer
        raise AnalysisError(f"{os.fspath(path)!r} holds no samples")
    return audio.reshape(audio.shape[0], -1), float(samplerate)
