"""One row of a bank: its scene rendered, trimmed and encoded, its file written atomically
and its manifest row measured (level, loudness, centroid, duration, hash)."""

from __future__ import annotations

import contextlib
import io
import math
import resource
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.bank import manifest as mf
from synth.bank import spec as bank_spec
from synth.bank.spec import RESTITUTION_SCALE, BankSpec, BankSpecError, PlanItem
from synth.store.reproducible import reproducible


@dataclass
class RowResult:
    """A worker's answer: the manifest ``row``, or ``fatal`` (a file that could not be
    written), and its peak memory, bytes."""

    row: dict | None
    fatal: str | None = None
    max_rss: int = 0


def _max_rss() -> int:
    """Peak resident memory of this process, bytes."""
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(r if sys.platform == "darwin" else r * 1024)


def integrated_loudness(audio: np.ndarray, samplerate: int) -> float | None:
    """Integrated loudness (ITU-R BS.1770, LUFS) of ``audio`` zero-padded to one 400 ms
    gating block, or None without pyloudnorm or below the -70 LUFS gate."""
    try:
        import pyloudnorm
    except ImportError:
        return None
    from synth.store.audio import LOUDNESS_BLOCK, padded_to_block

    x = padded_to_block(np.asarray(audio, dtype=np.float64), samplerate)
    value = float(pyloudnorm.Meter(samplerate, block_size=LOUDNESS_BLOCK).integrated_loudness(x))
    return round(value, 6) if math.isfinite(value) else None


#: What to change when a row's PCM audio would clip.
CLIP_ADVICE = "use render.normalize = 'peak', or format = 'wav' with render.subtype = 'FLOAT'"


def encode(
    audio: np.ndarray, samplerate: int, fmt: str, subtype: str, identity: str, advice: str
) -> bytes:
    """The bytes of a bank's file (``samplerate`` Hz), a function of the samples and
    ``identity`` (its name) alone (:func:`synth.store.reproducible.reproducible`); PCM
    that would clip is refused with ``advice``."""
    import soundfile

    from synth.store.audio import FLOAT_SUBTYPES

    peak = float(np.max(np.abs(audio))) if audio.size else 0.0
    if subtype not in FLOAT_SUBTYPES and peak > 1.0:
        raise BankSpecError(
            f"{identity!r} peaks at {20 * math.log10(peak):+.2f} dBFS, above full scale, "
            f"and subtype {subtype!r} would clip it: {advice}"
        )
    buf = io.BytesIO()
    soundfile.write(buf, audio, samplerate, subtype=subtype, format=bank_spec.FORMATS[fmt][1])
    return reproducible(buf.getvalue(), fmt, identity)


def render_scene(spec: BankSpec, item: PlanItem):
    """Render row ``item``: the Render, the file's bytes, and the row's figures."""
    from synth.io.presets import scene_from_dict
    from synth.sound.options import RenderOptions
    from synth.sound.render import render
    from synth.stimuli.sequences import scaled_sequence

    data = bank_spec.scene_data(spec, item.values)
    scene, section = scene_from_dict(data, f"row {item.index}")
    subtype = str(section.pop("subtype", spec.subtype)).upper()
    options = RenderOptions(**section)
    k = item.values.get(RESTITUTION_SCALE)
    sequence = None if k is None else scaled_sequence(scene, k, **options.bounces())
    rendered = render(scene, options=options, sequence=sequence)
    audio, length_reason = trim_tail(rendered.audio, rendered.samplerate, spec.trim)
    encoded = encode(audio, rendered.samplerate, spec.format, subtype, item.file, CLIP_ADVICE)
    peak = float(np.max(np.abs(audio))) if audio.size else 0.0
    first = rendered.impacts[0] if len(rendered.impacts) else None
    contact = None if first is None else first.result
    figures = {
        "duration": audio.shape[0] / rendered.samplerate,
        "stop_reason": rendered.impacts.stop_reason,
        "length_reason": length_reason,
        "audible_duration": _last_above(audio, AUDIBLE_BELOW_DB) / rendered.samplerate,
        "ticks": len(rendered.impacts),
        "first_restitution": getattr(first, "restitution", None),
        "first_speed": getattr(first, "speed", None),
        "first_contact_time": getattr(contact, "contact_time", None),
        "first_peak_force": getattr(contact, "peak_force", None),
        "peak_dbfs": round(20 * math.log10(peak), 6) if peak > 0 else None,
        "true_peak_dbtp": _true_peak_db(audio),
        "loudness_lufs": integrated_loudness(audio, rendered.samplerate),
        "spectral_centroid": _spectral_centroid(audio, rendered.samplerate),
        "scene": data,
    }
    return rendered, encoded, figures


#: Level below the peak that ends a sound's ``audible_duration``, dB.
AUDIBLE_BELOW_DB = -60.0


def _last_above(audio: np.ndarray, below_db: float) -> int:
    """Index after the last sample within ``below_db`` dB of the peak (0 for silence)."""
    mag = np.abs(audio) if audio.ndim == 1 else np.max(np.abs(audio), axis=1)
    peak = float(mag.max()) if mag.size else 0.0
    if not peak > 0:
        return 0
    above = np.flatnonzero(mag >= peak * 10.0 ** (below_db / 20.0))
    return int(above[-1]) + 1


def trim_tail(audio: np.ndarray, samplerate: int, trim: dict | None):
    """``audio`` cut after its last sample within ``trim["below_db"]`` dB of its peak (at
    most ``trim["max_length"]`` s), the last ``trim["fade"]`` s faded by a raised cosine;
    and why: "tail-cut", "max-length" or "whole"."""
    if trim is None:
        return audio, "whole"
    n = audio.shape[0]
    end, reason = min(n, _last_above(audio, trim["below_db"])), "tail-cut"
    if trim["max_length"] is not None and end > round(trim["max_length"] * samplerate):
        end, reason = round(trim["max_length"] * samplerate), "max-length"
    if end >= n:
        return audio, "whole"
    out = np.array(audio[:end], dtype=np.float64)
    k = min(end, round(trim["fade"] * samplerate))
    if k > 0:
        ramp = 0.5 * (1.0 + np.cos(np.pi * (np.arange(1, k + 1) / k)))
        out[end - k :] *= ramp if out.ndim == 1 else ramp[:, None]
    return out, reason


#: Oversampling of the true-peak estimate (ITU-R BS.1770-4, Annex 2: 4 at 48 kHz).
TRUE_PEAK_OVERSAMPLING = 4


def _true_peak_db(audio: np.ndarray) -> float | None:
    """True peak, dBTP: the peak of ``audio`` upsampled by polyphase interpolation, as
    ITU-R BS.1770-4 Annex 2 estimates it."""
    from scipy.signal import resample_poly

    x = np.asarray(audio, dtype=np.float64)
    if not x.size:
        return None
    peak = float(np.max(np.abs(resample_poly(x, TRUE_PEAK_OVERSAMPLING, 1, axis=0))))
    peak = max(peak, float(np.max(np.abs(x))))
    return round(20 * math.log10(peak), 6) if peak > 0 else None


def _spectral_centroid(audio: np.ndarray, samplerate: int) -> float | None:
    """Spectral centroid, Hz: sum f |X(f)|^2 / sum |X(f)|^2 of the channels' sum, padded
    to a fast FFT length."""
    from scipy import fft

    x = np.asarray(audio, dtype=np.float64)
    x = x.sum(axis=1) if x.ndim > 1 else x
    n = fft.next_fast_len(max(x.size, 1), real=True)
    power = np.abs(fft.rfft(x, n)) ** 2
    total = float(power.sum())
    if not total > 0:
        return None
    f = fft.rfftfreq(n, 1.0 / samplerate)
    return round(float(np.dot(f, power) / total), 6)


def base_row(spec: BankSpec, item: PlanItem, status: str) -> dict:
    row = {"index": item.index, "file": item.file, "seed": spec.seed, "status": status}
    row.update((k, list(v) if isinstance(v, tuple) else v) for k, v in item.values.items())
    return described(spec, item, row)


def described(spec: BankSpec, item: PlanItem, row: dict) -> dict:
    """``row`` with its labels and tags as the spec gives them now."""
    return dict(row, labels=bank_spec.row_labels(spec, item.values), tags=spec.tags)


def render_item(spec: BankSpec, item: PlanItem, out_dir: str) -> RowResult:
    """Every worker's task: render row ``item`` and publish its file in ``out_dir`` once
    (:func:`synth.store.atomic.write_once`). A scene that fails gives a ``failed`` row, a
    file that cannot be written ``fatal``."""
    try:
        _, data, figures = render_scene(spec, item)
    except Exception as exc:  # noqa: BLE001 - any error of one scene is recorded, the rest go on
        row = base_row(spec, item, "failed")
        row["error"] = f"{type(exc).__name__}: {exc}"
        return RowResult(row, max_rss=_max_rss())
    target = Path(out_dir) / item.file
    try:
        target.parent.mkdir(parents=True, exist_ok=True)  # a subfolder of the template
        if not mf.write_once(target, data):  # another attempt's (a recomputed Dask task)
            data = target.read_bytes()
    except OSError as exc:
        return RowResult(None, fatal=f"cannot write {item.file!r}: {exc}", max_rss=_max_rss())
    row = base_row(spec, item, "ok")
    row.update(figures, **mf.file_hashes(data))
    return RowResult(row, max_rss=_max_rss())


def warm(spec: BankSpec) -> None:
    """Render the base scene once (kernels, modes and gains into the caches); errors are
    left to the rows."""
    with contextlib.suppress(Exception):  # a base scene that fails is reported by its rows
        render_scene(spec, PlanItem(-1, "warm", {}))
