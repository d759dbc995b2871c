"""The checked inputs of :func:`synth.analysis.analyze`: the audio, and its settings in samples.

Every bad argument raises :class:`~synth.errors.ParameterError` naming the field, its value and
what is allowed; nothing is clamped.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.analysis.whitening import MAX_ORDER
from synth.errors import ParameterError, SynthError

#: Fewest samples summed in a frame of the detection function: at low rates the frames
#: overlap, so that a frame of noise is never a sum of only a few squares, whose scatter
#: would pass for a tick.
MIN_FRAME = 12
#: Longest gap bridged by the onset walk inside one burst (the zero crossings of a burst), s.
ONSET_GAP = 0.00025
#: Longest gap bridged by the onset walk inside the weak burst of a doubtful candidate of the
#: deflation (its walk level the noise's), s: the longest contact of a bounce series' ticks,
#: whose whitened burst is the transients at its two ends (a slow ball's on a soft board: 0.54
#: ms on the thesis' 6 mm board's tenth bounce, its end's transients 0.37 ms after its start's).
WEAK_ONSET_GAP = 0.0005
#: Default floor of the detection, dB under the strongest frame of the whitened signal, in
#: steps 1-6 (a guard against what the 20 ms predictor leaves of the earlier ticks, which
#: those steps do not model over their whole response) and for the test that calls step 7.
DYNAMIC_RANGE_DB = 60.0
#: Length of the default whitening predictor, s (at least 8 samples).
WHITENING_SPAN = 0.02

#: The upper ends of the options' ranges, checked before any work (each a bound past which
#: the option has no use, so that an absurd value is named rather than run into an
#: allocation or an overflow):
#: the highest sample rate of audio converters, Hz;
MAX_SAMPLERATE = 768000.0
#: gravity, m/s^2: past the Sun's surface gravity (274 m/s^2);
MAX_GRAVITY = 300.0
#: margins and ranges in dB: float64 resolves 313 dB (2^-52) and no more;
MAX_DB = 300.0
#: the fading memory's release, dB per ms: past this it forgets within a sample at 1 MHz;
MAX_RELEASE = 1000.0
#: ``min_separation``, s: a bounce series' ticks come within a second of each other once
#: the ball has bounced (a first bounce of 1 s is a drop from 1.2 m);
MAX_SEPARATION = 1.0
#: ``hop``, s: the frames must resolve ticks a few ms apart;
MAX_HOP = 0.01
#: ``background``, s: the local background of the detection (ticks are sparse over it);
MAX_BACKGROUND = 1.0
#: ``window``, s: a tick's measurement window (a lightly damped plate rings for seconds);
MAX_WINDOW = 2.0
#: ``decay_smoothing``, s: the envelope's smoothing, under the longest window;
MAX_SMOOTHING = 0.1


class AnalysisError(SynthError, ValueError):
    """The recording cannot be analysed: unreadable, silent, clipped, or without ticks."""


@dataclass(frozen=True)
class Settings:
    """The options of :func:`synth.analysis.analyze`, checked, durations in samples.

    ``dynamic_range_db`` is the floor of steps 1-6 (:data:`DYNAMIC_RANGE_DB` unless given);
    ``fixed_range`` says whether the caller gave it (then it holds in step 7 too).
    """

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


def make_settings(
    channels: int,
    samplerate,
    *,
    gravity,
    channel,
    min_separation,
    hop,
    threshold_db,
    rise_db,
    release,
    dynamic_range_db,
    max_drop_db,
    background,
    onset_fraction,
    lpc_order,
    window,
    subtract_tails,
    deflate,
    decay_smoothing,
    clip_samples,
    on_clipping,
) -> Settings:
    """Check the options of :func:`synth.analysis.analyze` for audio of ``channels`` channels.

    Raises
    ------
    ParameterError
        A bad option; the message names it, its value and what is allowed.
    """
    fs = checks.positive_at_most("samplerate", samplerate, MAX_SAMPLERATE, "Hz")
    g = checks.positive_at_most("gravity", gravity, MAX_GRAVITY, "m/s^2")
    ch = _channel(channel, channels)
    min_sep = _samples("min_separation", min_separation, fs, hi=MAX_SEPARATION)
    hop_n = _samples("hop", hop, fs, hi=MAX_HOP)
    thr = checks.positive_at_most("threshold_db", threshold_db, MAX_DB, "dB")
    rise = checks.positive_at_most("rise_db", rise_db, MAX_DB, "dB")
    rel = checks.positive_at_most("release", release, MAX_RELEASE, "dB/ms")
    dyn = (
        DYNAMIC_RANGE_DB
        if dynamic_range_db is None
        else checks.positive_at_most("dynamic_range_db", dynamic_range_db, MAX_DB, "dB")
    )
    drop = checks.positive_at_most("max_drop_db", max_drop_db, MAX_DB, "dB")
    bg = checks.positive_at_most("background", background, MAX_BACKGROUND, "s")
    frac = checks.in_range("onset_fraction", onset_fraction, 0.0, 1.0)
    win_n = _samples("window", window, fs, hi=MAX_WINDOW)
    dec_n = _samples("decay_smoothing", decay_smoothing, fs, lo=3, hi=MAX_SMOOTHING)
    clip_n = _integer("clip_samples", clip_samples, 2)
    checks.choice("on_clipping", on_clipping, ("warn", "raise"))
    for name, flag in (("subtract_tails", subtract_tails), ("deflate", deflate)):
        if not isinstance(flag, (bool, np.bool_)):
            raise ParameterError(f"{name}={flag!r} must be True or False")
    order = (
        max(8, int(round(WHITENING_SPAN * fs)))
        if lpc_order is None
        else _integer("lpc_order", lpc_order, 2, hi=MAX_ORDER)
    )
    settings = Settings(
        samplerate=fs,
        gravity=g,
        channel=ch,
        min_separation=min_sep,
        hop=hop_n,
        threshold_db=thr,
        rise_db=rise,
        release=rel,
        dynamic_range_db=dyn,
        fixed_range=dynamic_range_db is not None,
        max_drop_db=drop,
        background=bg,
        onset_fraction=frac,
        whitening_order=order,
        fixed_order=lpc_order is not None,
        window=win_n,
        subtract_tails=bool(subtract_tails),
        deflate=bool(deflate),
        decay_smoothing=dec_n,
        clip_samples=clip_n,
        on_clipping=on_clipping,
    )
    return settings


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


def _channel(channel, n: int) -> int | None:
    if channel is None:
        return None
    if isinstance(channel, (bool, np.bool_)) or not isinstance(channel, (int, np.integer)):
        raise ParameterError(f"channel={channel!r} must be None (mix) or a channel index")
    if not 0 <= channel < n:
        raise ParameterError(
            f"channel={channel!r} is out of range: the audio has {n} channel(s), "
            f"allowed 0..{n - 1} or None (mix)"
        )
    return int(channel)


def _integer(name: str, value, lo: int, hi: int | None = None) -> int:
    allowed = f">= {lo}" if hi is None else f"in {lo}..{hi}"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name}={value!r} must be an integer {allowed}")
    if value < lo or (hi is not None and value > hi):
        raise ParameterError(f"{name}={value!r} must be {allowed}")
    return int(value)


def _samples(name: str, value, fs: float, lo: int = 1, hi: float | None = None) -> int:
    """A duration in s (at most ``hi`` s), as a whole number of samples (at least ``lo``)."""
    t = (
        checks.positive(name, value, "s")
        if hi is None
        else checks.positive_at_most(name, value, hi, "s")
    )
    n = int(round(t * fs))
    if n < lo:
        raise ParameterError(f"{name}={value!r} is shorter than {lo} sample(s) at {fs:g} Hz (s)")
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
    """Read a sound file for :func:`synth.analysis.analyze`: every channel, as it is stored.

    Parameters
    ----------
    path : str or path-like
        The file (WAV, FLAC, OGG, AIFF, ... at any sample rate, any number of channels).

    Returns
    -------
    audio : ndarray of float64, (frames, channels)
        The samples, in units of full scale.
    samplerate : float
        Sample rate, Hz.

    Warns
    -----
    TruncatedAudioWarning
        A WAV file holds fewer frames than its header declares.

    Raises
    ------
    ParameterError
        ``path`` is not a file name, or no such file.
    AnalysisError
        An unreadable file (corrupt header, unknown format) or one without samples.
    """
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
