"""The output stage: levels, fades and audio files (WAV, FLAC) via soundfile.

Audio arrays are ``(frames,)`` or ``(frames, channels)`` floats; ``samplerate`` is always
explicit, Hz. :func:`normalize` maps the physical signal (Pa or m/s^2) to full scale by
"peak", "loudness" (ITU-R BS.1770, optional ``pyloudnorm``), "physical" (one fixed
calibration, :data:`PHYSICAL_FULL_SCALE`, keeping true level relations) or "none".
:func:`write_audio` writes a temporary file and renames it into place, and refuses to let
a PCM subtype clip.
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

#: Digital full scale (|sample| = 1.0) of the ``"physical"`` calibration, per unit of
#: the listener's signal. ``"Pa"``: 1000 Pa, i.e. 154 dB SPL re 20 uPa
#: (20 log10(1000 / 20e-6) = 154): an impact heard from a few tens of centimetres
#: peaks at 100-200 Pa (the loudest preset, a 17 mm glass ball on 12 mm MDF at
#: 0.2 m, at 182 Pa), so every preset keeps at least 14 dB of headroom while a tick
#: 100 dB quieter still spans 6 bits of a 24-bit file. ``"m/s^2"``: 10 000 m/s^2
#: (about 1000 g), the range of a shock-rated piezoelectric accelerometer (the
#: thesis presets peak at 1800-3300 m/s^2 on the plate).
PHYSICAL_FULL_SCALE = {"Pa": 1000.0, "m/s^2": 10000.0}

#: Level modes of :func:`normalize`.
NORMALIZE_MODES = ("peak", "loudness", "physical", "none")

#: File formats written by :func:`write_audio`, by file suffix.
FORMATS = {".wav": "WAV", ".flac": "FLAC"}

#: Subtype written when none is given (WAV and FLAC alike).
DEFAULT_SUBTYPE = "PCM_24"

#: Subtypes that store floats and so can hold samples beyond full scale.
FLOAT_SUBTYPES = ("FLOAT", "DOUBLE")

#: Gating block of ITU-R BS.1770 integrated loudness, s.
LOUDNESS_BLOCK = 0.4

#: Most channels the BS.1770 channel weights are defined for (L, R, C, Ls, Rs).
LOUDNESS_MAX_CHANNELS = 5


class AudioFileError(ParameterError):
    """An audio file that cannot be read or written: missing, corrupt, unsupported
    format, or a directory that does not exist. The message names the path."""


# --------------------------------------------------------------------------- checks


#: Highest sample rate of a written file, Hz (libsndfile stores the rate as a 32-bit int;
#: the engine renders at most 384 kHz, and no converter exceeds 768 kHz).
MAX_FILE_SAMPLERATE = 768_000


#: Quantisation step of the integer subtypes, in units of full scale.
PCM_STEP = {
    "PCM_S8": 2.0**-7,
    "PCM_U8": 2.0**-7,
    "PCM_16": 2.0**-15,
    "PCM_24": 2.0**-23,
    "PCM_32": 2.0**-31,
}


def _system_reason(path: Path, reason: str, nbytes: int = 0, reading: bool = False) -> str:
    """libsndfile's bare "System error" made specific: the operating system's own reason
    (permission denied, no space left on device, ...), found by doing the same access
    with Python."""
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
            limit = _file_size_limit()
            if limit is not None and nbytes > limit:
                return (
                    f"the file, about {nbytes} bytes, is larger than this process may write "
                    f"(file size limit {limit} bytes: ulimit -f)"
                )
    except OSError as exc:
        return exc.strerror or str(exc)
    return reason


def _file_size_limit() -> int | None:
    """The largest file this process may write (``RLIMIT_FSIZE``, bytes), or None."""
    try:
        import resource
    except ImportError:  # not on Windows
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def _check_units(units) -> str:
    return checks.choice("units", units, tuple(PHYSICAL_FULL_SCALE))


def _peak(a: np.ndarray) -> float:
    return float(np.max(np.abs(a)))


def output_path(path, kinds: dict, what: str, error=None) -> tuple[Path, str]:
    """Validate an output path: a known suffix and an existing directory.

    ``kinds`` maps lower-case suffixes to format names; ``error`` is the exception
    class for a missing directory (default :class:`AudioFileError`).
    """
    error = AudioFileError if error is None else error
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file path (str or os.PathLike)")
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in kinds:
        raise ParameterError(
            f"path={str(p)!r}: suffix {p.suffix!r} is not a {what} format; use one of "
            f"{', '.join(map(repr, kinds))}"
        )
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise error(
            f"path={str(p)!r}: directory {str(parent)!r} does not exist (it is not "
            f"created automatically)"
        )
    if p.is_dir():
        raise error(f"path={str(p)!r} is a directory, not a file")
    return p, kinds[suffix]


def check_output_path(path, field: str = "path", suffixes=None) -> Path:
    """Check, before any work, that a file can be written at ``path``: its suffix is one
    of ``suffixes`` (if given, e.g. :data:`FORMATS`), it is not a directory, its folder
    exists and a file can be created there (tried: this catches a read-only folder or
    file system). Stale temporaries there are removed. Returns the path; raises
    :class:`AudioFileError` (or ``ParameterError`` for the suffix) naming ``field``."""
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


# --------------------------------------------------------------------------- files


def write_audio(
    path: str | os.PathLike, audio: np.ndarray, samplerate: int, subtype: str | None = None
) -> Path:
    """Write audio to a WAV or FLAC file, chosen by the file suffix, through a temporary
    file renamed onto ``path`` (a failure leaves no partial file and ``path`` untouched).

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its suffix (``.wav`` or ``.flac``, any case) sets the format.
        Its directory must exist.
    audio : ndarray of float, shape (frames,) or (frames, channels)
        Samples in units of digital full scale (1.0 = 0 dBFS), finite, not empty.
    samplerate : int > 0
        Sample rate, Hz.
    subtype : str, optional
        A soundfile subtype the format supports (``soundfile.available_subtypes``):
        e.g. ``"PCM_16"``, ``"PCM_24"``, ``"FLOAT"`` (WAV only). Default
        ``"PCM_24"`` for WAV and FLAC alike. Any subtype but ``"FLOAT"`` and
        ``"DOUBLE"`` stores integers: samples beyond +-1.0 would clip, so they are
        refused (``ParameterError``) rather than clipped.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    p, fmt = output_path(path, FORMATS, "sound file")
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
    """A sound file holds fewer samples than its header declares (a cut-off copy or an
    interrupted write): what is read is only the part that is there."""


def wav_shortfall(path: str | os.PathLike) -> str | None:
    """Why a RIFF/WAVE file's ``data`` chunk is shorter than its header says, or None.

    The header's ``data`` size (bytes) over the ``fmt`` block alignment gives the frames
    declared; soundfile reads only the frames the file holds, without a word, so a
    truncated file would pass for a shorter recording. Files that are not RIFF/WAVE, and
    headers that leave the size open (0 or 0xFFFFFFFF, as streaming writers do), give None.
    """
    try:
        with open(path, "rb") as f:
            head = f.read(12)
            if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
                return None
            size = os.fstat(f.fileno()).st_size
            align = None
            while True:
                chunk = f.read(8)
                if len(chunk) < 8:
                    return None
                cid, n = chunk[:4], struct.unpack("<I", chunk[4:])[0]
                if cid == b"fmt ":
                    fmt = f.read(min(n, 16))
                    if len(fmt) >= 14:
                        align = struct.unpack("<H", fmt[12:14])[0]
                    f.seek(n - len(fmt) + (n & 1), os.SEEK_CUR)
                elif cid == b"data":
                    break
                else:
                    f.seek(n + (n & 1), os.SEEK_CUR)
            held = size - f.tell()
    except OSError:
        return None
    if n in (0, 0xFFFFFFFF) or held >= n or not align:
        return None
    return (
        f"{os.fspath(path)!r} is truncated: its header declares {n // align} frames "
        f"({n} bytes of data) but the file holds {held // align}; only those were read"
    )


def read_audio(
    path: str | os.PathLike, *, channel: int | str | None = None
) -> tuple[np.ndarray, int]:
    """Read an audio file (WAV, FLAC or any format soundfile reads).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    channel : None, int or "mix"
        ``None`` keeps every channel (shape ``(frames,)`` for a mono file,
        ``(frames, channels)`` otherwise); an int ``0 <= channel < channels``
        returns that channel, shape ``(frames,)``; ``"mix"`` returns the mean of
        the channels, shape ``(frames,)``.

    Returns
    -------
    audio : ndarray of float64
        Samples in units of full scale (as stored for float files).
    samplerate : int
        Sample rate, Hz.

    Warns
    -----
    TruncatedAudioWarning
        A WAV file holds fewer frames than its header declares (:func:`wav_shortfall`).

    Raises
    ------
    AudioFileError
        The file is missing, not a file, corrupt or in a format soundfile cannot read.
    ParameterError
        ``channel`` is not None, "mix" or a channel index of the file.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file path (str or os.PathLike)")
    if not (
        channel is None
        or (isinstance(channel, str) and channel == "mix")
        or (isinstance(channel, numbers.Integral) and not isinstance(channel, bool))
    ):
        raise ParameterError(
            f"channel={channel!r} must be None (all channels), 'mix' or a channel index"
        )
    p = Path(path)
    if p.is_dir():
        raise AudioFileError(f"path={str(p)!r} is a directory, not a file")
    if not p.exists():
        raise AudioFileError(f"path={str(p)!r}: no such file")
    if not p.is_file():
        raise AudioFileError(f"path={str(p)!r} is not a file")
    try:
        audio, sr = soundfile.read(p, dtype="float64", always_2d=True)
    except (soundfile.SoundFileError, RuntimeError, TypeError, ValueError) as exc:
        reason = _system_reason(p, getattr(exc, "error_string", None) or str(exc), reading=True)
        if reason != (getattr(exc, "error_string", None) or str(exc)):
            raise AudioFileError(f"cannot read {str(p)!r}: {reason}") from exc
        raise AudioFileError(
            f"cannot read {str(p)!r} as audio (corrupt or unsupported format): {reason}"
        ) from exc
    short = wav_shortfall(p)
    if short is not None:
        warnings.warn(short, TruncatedAudioWarning, stacklevel=2)
    n_ch = audio.shape[1]
    if channel is None:
        out = audio[:, 0] if n_ch == 1 else audio
    elif isinstance(channel, str):
        out = audio.mean(axis=1)
    else:
        if not 0 <= channel < n_ch:
            raise ParameterError(
                f"channel={channel!r} is out of range: {str(p)!r} has {n_ch} channel"
                f"{'s' if n_ch != 1 else ''} (0 to {n_ch - 1})"
            )
        out = audio[:, int(channel)]
    return np.ascontiguousarray(out), int(sr)


# --------------------------------------------------------------------------- levels


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
    """Scale a physical signal to digital full scale.

    Parameters
    ----------
    audio : ndarray of float, shape (frames,) or (frames, channels)
        The listener's signal in physical units (``units``), finite, not empty.
    mode : {"peak", "loudness", "physical", "none"}
        ``"peak"``: the largest ``|sample|`` becomes ``10^(peak_db/20)`` (sample
        peak, not true peak). All-zero audio is returned with gain 1.
        ``"loudness"``: the integrated loudness of ITU-R BS.1770-4 (K-weighted,
        gated, via the optional ``pyloudnorm``) becomes ``loudness_lufs``. BS.1770
        needs at least one 400 ms gating block: shorter audio is padded with zeros
        for the measurement only, so a short tick's loudness is its energy spread
        over 400 ms. Because the -70 LUFS absolute gate is not scale invariant,
        the gain is refined by measuring the scaled audio again until it is within
        0.001 LU of the target. All-zero audio is returned with gain 1.
        ``"physical"``: gain ``1 / PHYSICAL_FULL_SCALE[units]`` whatever the
        audio, so different scenes keep their true level relation; samples above
        full scale are kept as they are (write them with a float subtype).
        ``"none"``: gain 1, the physical units.
    samplerate : int > 0
        Sample rate, Hz.
    units : {"Pa", "m/s^2"}
        Units of ``audio``: sound pressure (microphone) or acceleration
        (accelerometer).
    peak_db : float <= 0
        Target sample peak of ``"peak"``, dBFS.
    loudness_lufs : float <= 0
        Target integrated loudness of ``"loudness"``, LUFS (EBU R128: -23).
    max_peak : float > 0 or None
        Largest ``|sample|`` allowed after ``"loudness"`` scaling, full scale
        units; beyond it a ``ParameterError`` is raised (the audio is never
        clipped). ``None`` lifts the limit, for float output files.

    Returns
    -------
    scaled : ndarray
        ``audio * gain``, same shape and float dtype as ``audio``.
    gain : float
        Full-scale units per physical unit (per Pa or per m/s^2).
    """
    mode = checks.choice("mode", mode, NORMALIZE_MODES)
    a = checks.audio_array("audio", audio)
    sr = checks.samplerate(samplerate)
    u = _check_units(units)
    target_peak_db = checks.real("peak_db", peak_db, "dBFS")
    if target_peak_db > 0.0:
        raise ParameterError(f"peak_db={peak_db!r} must be <= 0 (dBFS)")
    target_lufs = checks.real("loudness_lufs", loudness_lufs, "LUFS")
    if target_lufs > 0.0:
        raise ParameterError(f"loudness_lufs={loudness_lufs!r} must be <= 0 (LUFS)")
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
        target = 10.0 ** (target_peak_db / 20.0)
        # (x / peak) is exactly +-1 at the peak and below it elsewhere (correct
        # rounding is monotonic), so the result never overshoots the target.
        return ((x / peak) * target).astype(dtype), target / peak
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


def _loudness_gain(x: np.ndarray, sr: int, target: float) -> float:
    """Gain that puts the BS.1770 integrated loudness of ``x`` (peak 1) at ``target``."""
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
    need = int(math.ceil(LOUDNESS_BLOCK * sr))
    if x.shape[0] < need:
        pad = [(0, need - x.shape[0])] + [(0, 0)] * (x.ndim - 1)
        x = np.pad(x, pad)

    def measure(g):
        return float(meter.integrated_loudness(x * g))

    gain = 1.0
    for _ in range(8):
        lufs = measure(gain)
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
    """The raised-cosine fade-out ``w[k] = (1 + cos(pi (k + 1) / frames)) / 2``,
    ``k = 0 .. frames-1``: the falling half of a Hann window, continuing smoothly from
    1 on the frame before it to exactly 0 on its last frame."""
    return 0.5 * (1.0 + np.cos(np.linspace(0.0, np.pi, frames + 1)[1:]))


def apply_fade_out(audio: np.ndarray, frames: int) -> None:
    """Multiply the last ``frames`` frames of ``audio`` (axis 0) by
    :func:`fade_out_window`, in place. 0 frames: nothing changes."""
    if frames <= 0:
        return
    w = fade_out_window(frames)
    if audio.ndim == 2:
        w = w[:, None]
    audio[audio.shape[0] - frames :] *= w
