"""Pictures of a render: waveform, spectrogram and force pulses in one PNG, drawn by the Agg canvas
(no display, no pyplot state); matplotlib is optional (``pip install 'impact-synth[plot]'``)."""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.store.atomic import write_atomically
from synth.store.audio import PHYSICAL_FULL_SCALE, check_output_path

if TYPE_CHECKING:
    from synth.sound.render import Render

#: Size of the figure, inches (width, height), and its resolution, dots per inch:
#: the PNG is ``FIGSIZE * DPI`` pixels.
FIGSIZE = (11.0, 11.0)
DPI = 100
#: Force pulses drawn, at most (the first impacts).
MAX_PULSES = 8
#: Length of a spectrogram frame, s (rounded to a power of two samples): about
#: 20 ms resolves the ticks in time and the plate's modes to ~50 Hz.
SPECTROGRAM_FRAME = 0.02
#: Dynamic range shown by the spectrogram, dB below its maximum.
SPECTROGRAM_RANGE_DB = 100.0
#: Above this many frames per channel the waveform is drawn as its min/max
#: envelope over ENVELOPE_BINS bins (what a screen can show anyway).
ENVELOPE_THRESHOLD = 20_000
ENVELOPE_BINS = 4_000

_QUANTITY = {"Pa": ("Sound pressure", "Pa"), "m/s^2": ("Acceleration", "m/s²")}


def import_matplotlib():
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise SynthError(
            "plotting needs the optional package matplotlib: pip install matplotlib "
            "(or pip install 'impact-synth[plot]')"
        ) from None
    return Figure, FigureCanvasAgg


def _attr(render, name):
    try:
        return getattr(render, name)
    except AttributeError:
        raise ParameterError(
            f"render={type(render).__name__} has no attribute {name!r}; it needs audio, "
            f"samplerate, impacts, onsets, settings, units and gain"
        ) from None


def _onsets(onsets, n_impacts: int) -> np.ndarray:
    try:
        t = np.asarray(onsets, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError("render.onsets must be an array of times (s)") from None
    if t.size != n_impacts or not np.all(np.isfinite(t)):
        raise ParameterError(
            f"render.onsets has {t.size} times for {n_impacts} impacts; each must be finite (s)"
        )
    return t


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _title(settings, samplerate, units, gain, n_impacts, frames, channels) -> str:
    settings = {} if settings is None else settings
    if not hasattr(settings, "get"):
        raise ParameterError(f"render.settings={settings!r} must be a mapping")
    parts = [f"samplerate={settings.get('samplerate', samplerate)} Hz"]
    parts += [f"{key}={settings[key]}" for key in ("normalize", "listener") if key in settings]
    return (
        f"{textwrap.fill(', '.join(parts), width=120)}\n{_count(n_impacts, 'impact')}, "
        f"{frames / samplerate:.4g} s, {_count(channels, 'channel')}, gain {gain:.4g} full "
        f"scale per {units}"
    )


def plot_render(render: Render, path: str | os.PathLike, *, max_pulses: int = MAX_PULSES) -> Path:
    """Draw a render into the PNG ``path`` (written atomically; returned): (a) the waveform in
    physical units with each impact marked, (b) the spectrogram of the first channel (PSD,
    dB re 1 unit^2/Hz, to Nyquist), (c) the force (N) of the first ``max_pulses`` impacts
    against time from first touch (s), with speed (m/s), restitution and contact time (s).
    ``render``: a :class:`~synth.sound.render.Render` or any object with its ``audio``,
    ``samplerate`` (Hz), ``impacts``, ``onsets`` (s), ``settings``, ``units``, ``gain``."""
    p = check_output_path(path, "path", (".png",))
    checks.integer_at_least("max_pulses", max_pulses, 0)
    audio = checks.audio_array("render.audio", _attr(render, "audio"))
    sr = checks.samplerate(_attr(render, "samplerate"), "render.samplerate")
    units = checks.choice("render.units", _attr(render, "units"), tuple(PHYSICAL_FULL_SCALE))
    gain = checks.positive("render.gain", _attr(render, "gain"), "full scale per physical unit")
    impacts = list(_attr(render, "impacts"))
    times = _onsets(_attr(render, "onsets"), len(impacts))
    settings = _attr(render, "settings")
    Figure, FigureCanvasAgg = import_matplotlib()

    x = audio.astype(np.float64).reshape(audio.shape[0], -1) / gain
    frames, channels = x.shape
    t = np.arange(frames) / sr

    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    # A narrow second column holds the spectrogram's colour bar, so that the three
    # panels share one time-axis width.
    grid = fig.add_gridspec(3, 2, height_ratios=(1.0, 1.3, 1.0), width_ratios=(1.0, 0.025))
    ax_w, ax_s, ax_f, ax_bar = (
        fig.add_subplot(grid[i, j]) for i, j in ((0, 0), (1, 0), (2, 0), (1, 1))
    )
    fig.suptitle(_title(settings, sr, units, gain, len(impacts), frames, channels), fontsize=10)

    _waveform_panel(ax_w, t, x, times, sr, gain, units)
    _spectrogram_panel(fig, ax_s, ax_bar, x, sr, times, units)
    _pulses_panel(ax_f, impacts, max_pulses)

    def write(tmp):
        try:
            fig.savefig(tmp, format="png", dpi=DPI)
        except (OSError, ValueError, RuntimeError) as exc:
            raise SynthError(f"cannot write {str(p)!r}: {exc}") from exc

    write_atomically(p, write, error=ParameterError)
    return p


def _waveform_panel(ax_w, t, x, times, sr, gain, units) -> None:
    """Panel (a): the waveform ``x`` (frames x channels, physical units) against ``t`` (s),
    a red line at each impact time (s), the full scale (``gain`` per unit) on the right; a
    channel too long to see is drawn as its min/max envelope."""
    frames, channels = x.shape
    quantity, unit_label = _QUANTITY[units]
    starts = np.linspace(0, frames, ENVELOPE_BINS + 1).astype(int)[:-1]
    for c in range(channels):
        if frames > ENVELOPE_THRESHOLD:
            lo, hi = np.minimum.reduceat(x[:, c], starts), np.maximum.reduceat(x[:, c], starts)
            band = dict(step="post", linewidth=0.3, alpha=0.8)
            ax_w.fill_between(t[starts], lo, hi, label=f"channel {c + 1}", **band)
        else:
            ax_w.plot(t, x[:, c], linewidth=0.6, label=f"channel {c + 1}")
    for ti in times:
        ax_w.axvline(ti, color="tab:red", linewidth=0.6, alpha=0.5)
    ax_w.set_xlim(0.0, frames / sr)
    ax_w.set_xlabel("Time (s)")
    ax_w.set_ylabel(f"{quantity} ({unit_label})")
    ax_w.set_title(
        f"(a) Waveform; red lines: {_count(len(times), 'impact')}", fontsize=10, loc="left"
    )
    fs_axis = ax_w.secondary_yaxis("right", functions=(lambda y: y * gain, lambda y: y / gain))
    fs_axis.set_ylabel("Full scale")
    if channels > 1:
        ax_w.legend(loc="upper right", fontsize=8)
    ax_w.grid(alpha=0.3)


def _spectrogram_panel(fig, ax_s, ax_bar, x, sr, times, units) -> None:
    """Panel (b): the spectrogram of the first channel of ``x`` (power spectral density, dB
    re 1 unit^2/Hz, up to the Nyquist frequency ``sr / 2``), impacts marked on its top
    edge, and its colour bar in ``ax_bar``."""
    from scipy import signal

    frames, channels = x.shape
    _, unit_label = _QUANTITY[units]
    # Frames of about SPECTROGRAM_FRAME, but short enough for at least 13 frames
    # (hop = nper / 4) when the audio is short; never longer than the audio.
    nper = 2 ** max(5, int(round(math.log2(SPECTROGRAM_FRAME * sr))))
    nper = min(nper, max(32, 2 ** int(math.floor(math.log2(max(frames // 4, 1))))), frames)
    f, ts, sxx = signal.spectrogram(
        x[:, 0], fs=sr, window="hann", nperseg=nper, noverlap=(3 * nper) // 4, mode="psd"
    )  # power spectral density
    with np.errstate(divide="ignore"):
        db = 10.0 * np.log10(sxx)
    top = float(np.max(db[np.isfinite(db)])) if np.any(np.isfinite(db)) else 0.0
    db = np.where(np.isfinite(db), db, top - SPECTROGRAM_RANGE_DB)
    # Each column is centred on its frame and one hop wide; a single frame spans the audio.
    hop = (nper - (3 * nper) // 4) / sr
    t0, t1 = (ts[0] - hop / 2, ts[-1] + hop / 2) if ts.size > 1 else (0.0, frames / sr)
    image = ax_s.imshow(
        db, origin="lower", aspect="auto", cmap="magma", extent=(t0, t1, 0.0, sr / 2000.0),
        interpolation="nearest", vmin=top - SPECTROGRAM_RANGE_DB, vmax=top,
    )  # fmt: skip
    ax_s.set_xlim(0.0, frames / sr)
    ax_s.set_ylim(0.0, sr / 2000.0)
    marks = dict(color="tab:cyan", markersize=5, transform=ax_s.get_xaxis_transform())
    ax_s.plot(times, np.ones_like(times), "v", clip_on=False, **marks)
    ax_s.set_xlabel("Time (s)")
    ax_s.set_ylabel("Frequency (kHz)")
    ax_s.set_title(
        f"(b) Spectrogram{' of channel 1' if channels > 1 else ''} "
        f"(Hann, {nper} samples = {1000 * nper / sr:.3g} ms, 75 % overlap); "
        f"triangles: impacts",
        fontsize=10,
        loc="left",
    )
    bar = fig.colorbar(image, cax=ax_bar)
    bar.set_label(f"PSD (dB re 1 {unit_label}²/Hz)")


def _pulses_panel(ax_f, impacts, max_pulses) -> None:
    """Panel (c): the contact force (N) of the first ``max_pulses`` impacts against time
    from first touch (us), with their speed, restitution and contact time."""
    shown = impacts[:max_pulses]
    for imp in shown:
        r = imp.result
        ax_f.plot(
            np.asarray(r.time) * 1e6,
            np.asarray(r.force),
            linewidth=1.2,
            label=(
                f"#{getattr(imp, 'index', '?')}: v = {imp.speed:.3g} m/s, "
                f"e = {r.restitution:.3f}, τ = {r.contact_time * 1e6:.4g} µs"
            ),
        )
    if shown:
        ax_f.legend(fontsize=8, loc="upper right")
    else:
        ax_f.text(0.5, 0.5, "no impacts", transform=ax_f.transAxes, ha="center")
    ax_f.set_xlabel("Time from first touch (µs)")
    ax_f.set_ylabel("Contact force (N)")
    ax_f.set_title(
        f"(c) Force pulses of the first {len(shown)} of {_count(len(impacts), 'impact')}",
        fontsize=10,
        loc="left",
    )
    ax_f.grid(alpha=0.3)
