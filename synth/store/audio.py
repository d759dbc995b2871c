"""The output stage: levels (:func:`normalize`: "peak", "loudness" by ITU-R BS.1770,
"physical" by one fixed calibration, or "none"), fades and audio files (WAV, FLAC) written
atomically, with a PCM subtype never allowed to clip.
"""

from __future__ import annotations

import math
import numbers
import os
import struct
import warnings
from pathlib import Path

import numpy as np
import soundfile

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.store.atomic import temporary_sibling, write_atomically
from synth.store.reproducible import riff_chunks

try:
    import resource  # the file size limit (ulimit -f), not on Windows
except ImportError:
    resource = None

#: Digital full scale of the ``"physical"`` calibration, per unit of the listener's signal:
#: 1000 Pa (154 dB SPL; an impact at a few tens of cm peaks at 100-200 Pa, so 14 dB of
#: headroom, and a tick 100 dB quieter still spans 6 bits of PCM_24), and 10 000 m/s^2
#: (about 1000 g, a shock-rated piezoelectric accelerometer's range).
PHYSICAL_FULL_SCALE = {"Pa": 1000.0, "m/s^2": 10000.0}

#: Level modes of :func:`normalize`; file formats by suffix; the default subtype (WAV and
#: FLAC); subtypes that store floats (samples beyond full scale).
NORMALIZE_MODES = ("peak", "loudness", "physical", "none")
FORMATS = {".wav": "WAV", ".flac": "FLAC"}
DEFAULT_SUBTYPE = "PCM_24"
FLOAT_SUBTYPES = ("FLOAT", "DOUBLE")
#: Gating block of ITU-R BS.1770 integrated loudness, s; most channels it weights (L, R, C,
#: Ls, Rs).
LOUDNESS_BLOCK = 0.4
LOUDNESS_MAX_CHANNELS = 5
#: Highest sample rate of a written file, Hz (no converter exceeds 768 kHz).
MAX_FILE_SAMPLERATE = 768_000
#: Quantisation step of the integer subtypes, in units of full scale.
PCM_STEP = {f"PCM_{n}": 2.0 ** (1 - bits) for n, bits in (("S8", 8), ("U8", 8), ("16", 16),
                                                          ("24", 24), ("32", 32))}  # fmt: skip


class AudioFileError(ParameterError):
    """An audio file that cannot be read or written; the message names the path."""


def _system_reason(path: Path, reason: str, nbytes: int = 0, reading: bool = False) -> str:
    """libsndfile's bare "System error" made specific: the system's own reason, found by
    doing the same access with Python."""
    if "system error" not in reason.lower():
        return reason
    import shutil

    try:
        if reading:
            with open(path, "rb") as fh:
                fh.read(1)
        else:
            free = shutil.disk_usage(path.parent if str(path.parent) else ".").free
            if free < nbytes + 65536:
                return f"no space left on the device ({free} bytes free, about {nbytes} needed)"
            limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0] if resource else None
            if limit not in (None, getattr(resource, "RLIM_INFINITY", None)) and nbytes > limit:
                return (
                    f"the file, about {nbytes} bytes, is larger than this process may write "
                    f"(file size limit {limit} bytes: ulimit -f)"
                )
    except OSError as exc:
        return exc.strerror or str(exc)
    return reason


def _peak(a: np.ndarray) -> float:
    return float(np.max(np.abs(a)))


def check_output_path(path, field: str = "path", suffixes=None) -> Path:
    """Check before any work that a file can be written at ``path``: a suffix of
    ``suffixes`` (if given), not a directory, in an existing folder where a file can be
    created (tried: a read-only file system is caught). Raises :class:`AudioFileError`
    (``ParameterError`` for the suffix) naming ``field``."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"{field}={path!r} must be a file path (str or os.PathLike)")
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if p.is_dir():
        raise AudioFileError(f"{field}={str(p)!r} is a directory, not a file")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise ParameterError(
            f"{field}={str(p)!r}: suffix {p.suffix!r} is not one of "
            f"{', '.join(map(repr, suffixes))}"
        )
    if not parent.is_dir():
        raise AudioFileError(
            f"{field}={str(p)!r}: directory {str(parent)!r} does not exist "
            f"(it is not created automatically)"
        )
    with temporary_sibling(p, AudioFileError, field, suffix=".probe"):
        pass  # a file can be created there (and is removed, whatever interrupts)
    return p


def write_audio(
    path: str | os.PathLike, audio: np.ndarray, samplerate: int, subtype: str | None = None
) -> Path:
    """Write ``audio`` (float, ``(frames,)`` or ``(frames, channels)``, in units of digital
    full scale, finite, not empty) at ``samplerate`` Hz to the WAV or FLAC file ``path`` (by
    its suffix, in an existing folder) through a temporary renamed onto it: a failure leaves
    no partial file. ``subtype``: a soundfile subtype (default ``"PCM_24"``); one that stores
    integers refuses samples beyond +-1.0, never clips them. Returns the path written."""
    p = check_output_path(path, "path", FORMATS)
    fmt = FORMATS[p.suffix.lower()]
    a = checks.audio_array("audio", audio)
    sr = checks.samplerate(samplerate)
    if sr > MAX_FILE_SAMPLERATE:
        raise ParameterError(
            f"samplerate={samplerate!r} must be an integer in [1, {MAX_FILE_SAMPLERATE}] (Hz)"
        )
    st = DEFAULT_SUBTYPE if subtype is None else subtype
    if not isinstance(st, str) or not soundfile.check_format(fmt, st.upper()):
        raise ParameterError(
            f"subtype={subtype!r} is not supported by {fmt} ({str(p)!r}); use one of "
            f"{', '.join(map(repr, soundfile.available_subtypes(fmt)))}"
        )
    st = st.upper()
    if st not in FLOAT_SUBTYPES:
        peak = _peak(a)
        if peak > 1.0:
            hint = "or subtype='FLOAT'" if fmt == "WAV" else "or a .wav file with subtype='FLOAT'"
            raise ParameterError(
                f"audio peak {peak:.6g} ({20 * math.log10(peak):+.2f} dBFS) exceeds full "
                f"scale 1.0 and subtype {st!r} of {str(p)!r} would clip it; scale it down "
                f"(normalize='peak') {hint}"
            )
        step = PCM_STEP.get(st)
        if step is not None and 0.0 < peak < 0.5 * step:
            raise ParameterError(
                f"audio peak {peak:.6g} ({20 * math.log10(peak):+.1f} "
                f"dBFS) is below half a step of subtype {st!r} ({0.5 * step:.3g}): "
                f"{str(p)!r} would hold only silence; raise the level or use subtype='FLOAT'"
            )
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)

    def write(tmp):
        try:
            soundfile.write(tmp, a, sr, subtype=st, format=fmt)
        except OSError as exc:  # the system's refusal (a full disk): of the path asked for
            if exc.filename is not None and str(exc.filename) == str(tmp):
                exc.filename = str(p)
            raise
        except (soundfile.SoundFileError, RuntimeError) as exc:
            reason = getattr(exc, "error_string", None) or str(exc)
            raise AudioFileError(
                f"cannot write {str(p)!r} ({fmt} {st}, {sr} Hz, "
                f"{1 if a.ndim == 1 else a.shape[1]} channels): "
                f"{_system_reason(tmp, reason, a.nbytes)}"
            ) from exc

    write_atomically(p, write, error=AudioFileError)
    return p


class TruncatedAudioWarning(UserWarning):
    """A sound file holds fewer samples than its header declares: only those were read."""


def wav_shortfall(path: str | os.PathLike) -> str | None:
    """Why a RIFF/WAVE file's ``data`` chunk is shorter than its header says, or None
    (soundfile reads the frames there without a word). Not RIFF/WAVE, or a size left open
    (0 or 0xFFFFFFFF, as streaming writers do): None.
    """
    align = held = None
    try:
        with open(path, "rb") as f:
            for cid, n, at in riff_chunks(f):
                if cid == b"fmt " and len(fmt := f.read(min(n, 16))) >= 14:
                    align = struct.unpack("<H", fmt[12:14])[0]
                elif cid == b"data":
                    held = os.fstat(f.fileno()).st_size - at
    except OSError:
        return None
    if held is None or n in (0, 0xFFFFFFFF) or held >= n or not align:
        return None
    return (
        f"{os.fspath(path)!r} is truncated: its header declares {n // align} frames "
        f"({n} bytes of data) but the file holds {held // align}; only those were read"
    )


def read_audio(
    path: str | os.PathLike, *, channel: int | str | None = None
) -> tuple[np.ndarray, int]:
    """Read an audio file (any format soundfile reads): samples (float64, full scale) and
    the sample rate, Hz. ``channel``: None keeps every channel (``(frames,)`` for mono), an
    index that channel, ``"mix"`` their mean. A missing, corrupt or unreadable file is an
    :class:`AudioFileError`; a truncated WAV warns (:class:`TruncatedAudioWarning`)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file path (str or os.PathLike)")
    index = isinstance(channel, numbers.Integral) and not isinstance(channel, bool)
    if not (channel is None or (isinstance(channel, str) and channel == "mix") or index):
        raise ParameterError(
            f"channel={channel!r} must be None (all channels), 'mix' or a channel index"
        )
    p = Path(path)
    if not p.is_file():
        why = " is a directory, not a" if p.is_dir() else " is not a" if p.exists() else ": no such"
        raise AudioFileError(f"path={str(p)!r}{why} file")
    try:
        audio, sr = soundfile.read(p, dtype="float64", always_2d=True)
    except (soundfile.SoundFileError, RuntimeError, TypeError, ValueError) as exc:
        said = getattr(exc, "error_string", None) or str(exc)
        reason = _system_reason(p, said, reading=True)
        what = " as audio (corrupt or unsupported format)" if reason == said else ""
        raise AudioFileError(f"cannot read {str(p)!r}{what}: {reason}") from exc
    short = wav_shortfall(p)
    if short is not None:
        warnings.warn(short, TruncatedAudioWarning, stacklevel=2)
    n_ch = audio.shape[1]
    if index and not 0 <= channel < n_ch:
        raise ParameterError(
            f"channel={channel!r} is out of range: {str(p)!r} has {n_ch} channel"
            f"{'s' if n_ch != 1 else ''} (0 to {n_ch - 1})"
        )
    if channel is None:
        out = audio[:, 0] if n_ch == 1 else audio
    else:
        out = audio[:, int(channel)] if index else audio.mean(axis=1)
    return np.ascontiguousarray(out), int(sr)


def normalize(
    audio: np.ndarray,
    mode: str,
    *,
    samplerate: int,
    units: str,
    peak_db: float = -1.0,
    loudness_lufs: float = -23.0,
    max_peak: float | None = 1.0,
) -> tuple[np.ndarray, float]:
    """Scale ``audio`` (``samplerate`` Hz, in ``units``: "Pa" or "m/s^2") to digital full
    scale: ``(audio * gain, gain)``, gain in full scale per unit, same shape and dtype.
    ``mode``: "peak" to ``peak_db`` dBFS; "loudness" to ``loudness_lufs`` LUFS of ITU-R
    BS.1770-4 (optional ``pyloudnorm``; refused if the peak passes ``max_peak``, None: no
    limit); "physical" divides by :data:`PHYSICAL_FULL_SCALE`, so scenes keep their level
    relation; "none" keeps the units. All-zero audio keeps gain 1."""
    mode = checks.choice("mode", mode, NORMALIZE_MODES)
    a = checks.audio_array("audio", audio)
    sr = checks.samplerate(samplerate)
    u = checks.choice("units", units, tuple(PHYSICAL_FULL_SCALE))
    for name, value, unit in (
        ("peak_db", peak_db, "dBFS"),
        ("loudness_lufs", loudness_lufs, "LUFS"),
    ):
        if checks.real(name, value, unit) > 0.0:
            raise ParameterError(f"{name}={value!r} must be <= 0 ({unit})")
    limit = None if max_peak is None else checks.positive("max_peak", max_peak, "full scale")
    dtype = a.dtype if a.dtype in (np.float32, np.float64) else np.dtype(np.float64)
    x = a.astype(np.float64)

    if mode == "none":
        return x.astype(dtype), 1.0
    if mode == "physical":
        gain = 1.0 / PHYSICAL_FULL_SCALE[u]
        return (x * gain).astype(dtype), gain
    peak = _peak(x)
    if peak == 0.0:
        return x.astype(dtype), 1.0
    if mode == "peak":
        target = 10.0 ** (float(peak_db) / 20.0)
        # (x / peak) is exactly +-1 at the peak and below it elsewhere (correct
        # rounding is monotonic), so the result never overshoots the target.
        return ((x / peak) * target).astype(dtype), target / peak
    target_lufs = float(loudness_lufs)
    gain = _loudness_gain(x / peak, sr, target_lufs) / peak
    y = x * gain
    out_peak = _peak(y)
    if limit is not None and out_peak > limit:
        highest = target_lufs - 20.0 * math.log10(out_peak / limit)
        raise ParameterError(
            f"loudness_lufs={loudness_lufs!r} puts the sample peak at {out_peak:.4g} "
            f"({20 * math.log10(out_peak):+.2f} dBFS), above max_peak={limit!r}: "
            f"lower loudness_lufs to <= {math.floor(highest * 100) / 100:.2f} LUFS, use "
            f"mode 'peak', or pass max_peak=None and write a float subtype "
            f"(subtype='FLOAT', WAV only); the audio is never clipped"
        )
    return y.astype(dtype), gain


def padded_to_block(x: np.ndarray, samplerate: int) -> np.ndarray:
    """``x`` zero-padded to one BS.1770 gating block (:data:`LOUDNESS_BLOCK` s) if shorter:
    a shorter sound has no block to measure."""
    need = math.ceil(LOUDNESS_BLOCK * samplerate)
    return np.pad(x, [(0, max(0, need - x.shape[0]))] + [(0, 0)] * (x.ndim - 1))


def _loudness_gain(x: np.ndarray, sr: int, target: float) -> float:
    """Gain that puts the BS.1770 integrated loudness of ``x`` (peak 1, zero-padded to one
    gating block) at ``target``, refined to 0.001 LU (the -70 LUFS gate is not scale
    invariant)."""
    try:
        import pyloudnorm
    except ImportError:
        raise SynthError(
            "normalize='loudness' needs the optional package pyloudnorm: "
            "pip install pyloudnorm (or pip install 'impact-synth[loudness]')"
        ) from None
    if x.ndim == 2 and x.shape[1] > LOUDNESS_MAX_CHANNELS:
        raise ParameterError(
            f"audio has {x.shape[1]} channels; BS.1770 loudness is defined for at most "
            f"{LOUDNESS_MAX_CHANNELS} (L, R, C, Ls, Rs): use mode 'peak' or 'physical'"
        )
    meter = pyloudnorm.Meter(sr, block_size=LOUDNESS_BLOCK)
    x = padded_to_block(x, sr)
    gain = 1.0
    for _ in range(8):
        lufs = float(meter.integrated_loudness(x * gain))
        if not math.isfinite(lufs) or lufs < -70.0:
            raise ParameterError(
                f"audio has no measurable loudness ({lufs:.1f} LUFS at gain {gain:.3g}: every "
                f"400 ms block is below the -70 LUFS absolute gate of BS.1770, e.g. only "
                f"content below about 40 Hz, which K-weighting removes); use mode 'peak'"
            )
        step = target - lufs
        gain *= 10.0 ** (step / 20.0)
        if abs(step) < 1e-3:
            return gain
    raise SynthError(
        f"BS.1770 loudness did not settle at {target} LUFS (last step {step:.3g} LU): "
        f"blocks keep crossing the gates; use mode 'peak'"
    )


def fade_out_window(frames: int) -> np.ndarray:
    """The falling half of a Hann window, ``w[k] = (1 + cos(pi (k + 1) / frames)) / 2``:
    from 1 on the frame before it to exactly 0 on its last frame."""
    return 0.5 * (1.0 + np.cos(np.linspace(0.0, np.pi, frames + 1)[1:]))


def apply_fade_out(audio: np.ndarray, frames: int) -> None:
    """Multiply the last ``frames`` frames of ``audio`` (axis 0) by :func:`fade_out_window`."""
    if frames > 0:
        w = fade_out_window(frames)
        audio[audio.shape[0] - frames :] *= w[:, None] if audio.ndim == 2 else w
