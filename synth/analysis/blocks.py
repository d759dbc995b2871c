"""Long recordings in blocks of :data:`BLOCK` (docs/analysis.md, Long recordings): linear time,
bounded memory; a :class:`Source` is an array or a file."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from synth import dsp
from synth.analysis.clipping import long_runs
from synth.analysis.settings import AnalysisError
from synth.errors import ParameterError

#: Recordings up to this long are analysed whole, s: every preset's render (up to 61 s of a
#: steel sheet's or an aluminium plate's ringing).
WHOLE = 64.0
#: Length of a block, s: a whole series of a drop up to 1.2 m with restitution up to 0.9 (first
#: bounce 1 s, 10 bounces' worth in all) and its ringing; a longer series doubles its block.
BLOCK = 20.0
#: Overlap of a block after one whose series ended, s: a drop there is searched whole.
OVERLAP = 2.0
#: Frames read at once in a pass over a file (bounded memory), at most.
READ_FRAMES = 1 << 20


class Source:
    """A recording read in pieces: ``frames``, ``channels``, ``samplerate`` (Hz) and
    ``read(start, stop)``, frames ``start .. stop - 1`` as float64 ``(n, channels)``."""

    frames: int
    channels: int
    samplerate: float

    def pieces(self):
        """The recording as ``(start, samples)`` of at most :data:`READ_FRAMES` frames."""
        for start in range(0, self.frames, READ_FRAMES):
            yield start, self.read(start, min(self.frames, start + READ_FRAMES))


class ArraySource(Source):
    """A recording in memory, ``(frames, channels)`` float64."""

    def __init__(self, chans: np.ndarray, samplerate: float):
        self.chans, self.samplerate = chans, samplerate
        self.frames, self.channels = chans.shape

    def read(self, start: int, stop: int) -> np.ndarray:
        return self.chans[start:stop]


class FileSource(Source):
    """A sound file read in blocks, never whole; non-finite samples raise."""

    def __init__(self, path):
        self.path = os.fspath(path)
        info = _info(self.path)
        if info is None:
            raise AnalysisError(f"cannot read {self.path!r} as sound")
        self.frames, self.channels = int(info.frames), int(info.channels)
        self.samplerate = float(info.samplerate)

    def read(self, start: int, stop: int) -> np.ndarray:
        import soundfile

        with soundfile.SoundFile(self.path) as f:
            f.seek(start)
            a = f.read(stop - start, dtype="float64", always_2d=True)
        if a.shape[0] < stop - start:  # the file holds fewer frames than it declares
            self.frames = start + a.shape[0]
        if not np.isfinite(a).all():
            raise ParameterError(
                f"{self.path!r} holds NaN or infinite samples in frames {start}..{stop - 1}; "
                f"all must be finite"
            )
        return a


def _info(path: str):
    """soundfile's description of the file at ``path``, or None when it cannot read it."""
    import soundfile

    try:
        return soundfile.info(path)
    except (soundfile.SoundFileError, RuntimeError, TypeError, ValueError):
        return None


def file_frames(path) -> int | None:
    """The frames a sound file declares, or None when soundfile cannot tell."""
    info = _info(os.fspath(path))
    return None if info is None else int(info.frames)


@dataclass(frozen=True)
class Survey:
    """One pass's findings: the analysed channels' extremes and flat tops, whether channels and mix
    are non-zero, and the mix's noise floor (signal units)."""

    highs: np.ndarray
    lows: np.ndarray
    high_tops: np.ndarray
    low_tops: np.ndarray
    any_sample: bool
    any_mix: bool
    noise_floor: float


def survey(source: Source, channel: int | None) -> Survey:
    """Two passes over ``source`` in pieces: extremes, silence and noise floor, then the flat tops
    at the extremes."""
    cols = slice(None) if channel is None else slice(channel, channel + 1)
    n_ch = source.channels if channel is None else 1
    highs, lows = np.full(n_ch, -np.inf), np.full(n_ch, np.inf)
    any_sample = any_mix = False
    powers = []
    for _, piece in source.pieces():
        used = piece[:, cols]
        highs, lows = np.maximum(highs, used.max(axis=0)), np.minimum(lows, used.min(axis=0))
        mix = mix_of(used)
        any_sample, any_mix = any_sample or bool(np.any(used)), any_mix or bool(np.any(mix))
        powers.append(np.mean(dsp.noise_frames(mix, source.samplerate) ** 2, axis=1))
    tops = np.zeros((2, n_ch), dtype=int)
    for _, piece in source.pieces():
        for c, column in enumerate(piece[:, cols].T):
            for row, level in enumerate((highs[c], lows[c])):
                if level:
                    tops[row, c] += np.count_nonzero(long_runs(column == level))
    ms = np.concatenate(powers)
    floor = float(np.sqrt(ms[dsp.quiet_frames(ms)].mean())) if ms.size else 0.0
    return Survey(highs, lows, tops[0], tops[1], any_sample, any_mix, floor)


def mix_of(used: np.ndarray) -> np.ndarray:
    """The analysed signal: the one channel, or the mean of the channels."""
    return used[:, 0] if used.shape[1] == 1 else used.mean(axis=1)


def block_frames(samplerate: float) -> int:
    """Frames of a block at ``samplerate`` (Hz)."""
    return int(math.ceil(BLOCK * samplerate))


def whole_frames(samplerate: float) -> int:
    """Frames of the longest recording analysed whole at ``samplerate`` (Hz)."""
    return int(math.ceil(WHOLE * samplerate))
