"""Auditioning a finished bank from its files (rows ``ok`` with the recorded SHA-256):
:func:`preview`, every sound in one audio file, and :func:`sheet`, a PNG contact sheet of
waveforms over spectrograms (the optional ``plot`` extra); both written atomically."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.bank import manifest as mf
from synth.bank.executors import BankRunError

#: Silence between two sounds of a preview, s.
PREVIEW_GAP = 0.25
#: Thumbnails per row of a contact sheet, and the most sounds one sheet shows.
SHEET_COLUMNS = 4
SHEET_MAX_SOUNDS = 400


@dataclass
class Sound:
    """A finished row of a bank: its manifest row and decoded samples (frames x
    channels, full scale 1.0) at ``samplerate`` Hz."""

    row: dict
    audio: np.ndarray
    samplerate: int


def sounds(bank_dir) -> list[Sound]:
    """The bank's finished sounds, in index order (a BankRunError if none)."""
    import soundfile

    folder = Path(bank_dir)
    out = []
    for row in mf.read_rows(folder):
        if row.get("status") != "ok" or not mf.intact(folder, row):
            continue
        audio, fs = soundfile.read(folder / row["file"], dtype="float64", always_2d=True)
        out.append(Sound(row, audio, int(fs)))
    if not out:
        raise BankRunError(f"bank_dir={str(folder)!r} holds no finished sound")
    return out


def preview(bank_dir, path, *, gap: float = PREVIEW_GAP) -> Path:
    """Write every finished sound of ``bank_dir`` into one file ``path`` (WAV or FLAC),
    ``gap`` s of silence between two; returns ``path``."""
    from synth.store.audio import write_audio

    if isinstance(gap, bool) or not isinstance(gap, (int, float)) or not 0 <= gap <= 10:
        raise BankRunError(f"gap={gap!r} must be a number of seconds in [0, 10]")
    items = sounds(bank_dir)
    rates = {s.samplerate for s in items}
    channels = {s.audio.shape[1] for s in items}
    if len(rates) != 1 or len(channels) != 1:
        raise BankRunError(
            f"bank_dir={str(bank_dir)!r}: the sounds differ in sample rate {sorted(rates)} or "
            f"channels {sorted(channels)}; a preview needs one of each"
        )
    fs, ch = rates.pop(), channels.pop()
    silence = np.zeros((round(gap * fs), ch))
    joined = np.concatenate([part for s in items for part in (silence, s.audio)][1:])
    subtype = "FLOAT" if Path(path).suffix.lower() == ".wav" else "PCM_24"
    return write_audio(path, joined[:, 0] if ch == 1 else joined, fs, subtype=subtype)


def _title(row: dict, keys: list[str]) -> str:
    values = []
    for k in keys:
        v = row.get(k)
        if isinstance(v, float):
            v = f"{v:.4g}"
        elif isinstance(v, list):
            v = "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
        values.append(f"{k.rsplit('.', 1)[-1]}={v}")
    return f"{row['index']}: {row['file']}\n" + " ".join(values)


def sheet(bank_dir, path, *, columns: int = SHEET_COLUMNS) -> Path:
    """Write a contact sheet of ``bank_dir``'s finished sounds to the PNG ``path``:
    per sound a waveform over a spectrogram (up to :data:`SHEET_MAX_SOUNDS` sounds)."""
    from synth.io.plot import import_matplotlib
    from synth.store.atomic import write_atomically

    figure_class, canvas_class = import_matplotlib()
    items = sounds(bank_dir)[:SHEET_MAX_SOUNDS]
    stored = mf.read_spec(Path(bank_dir)) or {}
    keys = list(stored.get("vary", {}))
    rows = math.ceil(len(items) / columns)
    fig = figure_class(figsize=(3.2 * columns, 2.6 * rows))
    canvas_class(fig)
    grid = fig.add_gridspec(2 * rows, columns, height_ratios=[1, 1.4] * rows, hspace=0.6)
    for i, s in enumerate(items):
        r, c = divmod(i, columns)
        mono = s.audio.mean(axis=1)
        t = np.arange(mono.size) / s.samplerate
        wave = fig.add_subplot(grid[2 * r, c])
        wave.plot(t, mono, linewidth=0.4)
        wave.set_title(_title(s.row, keys), fontsize=6)
        wave.tick_params(labelsize=5)
        spec = fig.add_subplot(grid[2 * r + 1, c], sharex=wave)
        nfft = 512 if mono.size >= 512 else max(16, mono.size)
        spec.specgram(mono, NFFT=nfft, Fs=s.samplerate, noverlap=nfft // 2, cmap="magma")
        spec.tick_params(labelsize=5)
    return write_atomically(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=80))
