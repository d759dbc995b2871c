"""Drawing of an analysis to an image file (matplotlib, written atomically)."""

from __future__ import annotations

import os

import numpy as np

from synth import checks
from synth.analysis.report import Analysis, checked_analysis
from synth.analysis.settings import audio_array
from synth.errors import ParameterError, SynthError
from synth.store.atomic import write_atomically


def check_plot_path(path) -> str:
    """Check that an image can be written to ``path`` before any work: an existing writable
    directory and a suffix naming a format matplotlib writes. Returns the format (the lower-case
    suffix). Raises ParameterError (naming ``path``), or SynthError without matplotlib."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file name, not {type(path).__name__}")
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ParameterError(f"path={path!r}: directory {folder!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError(f"path={path!r}: directory {folder!r} is not writable")
    if os.path.isdir(path):
        raise ParameterError(f"path={path!r} is a directory, not an image file name")
    fmt = os.path.splitext(path)[1].lstrip(".").lower()
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
    except ImportError:
        raise SynthError("plotting needs matplotlib: pip install matplotlib") from None
    formats = FigureCanvasAgg.get_supported_filetypes()
    if fmt not in formats:
        raise ParameterError(
            f"path={path!r}: image format {fmt!r} is not one of {', '.join(sorted(formats))}"
        )
    return fmt


#: The two panels of two fields per tick on twin axes: title, then ``(field, scale, label,
#: colour)`` of each axis.
_TWIN_PANELS = (
    ("bounce time and restitution", ("bounce_time", 1e3, "bounce time (ms)", "tab:blue"),
     ("restitution", 1.0, "restitution e", "tab:orange")),
    ("centroid and decay time", ("centroid", 1.0, "centroid (Hz)", "tab:purple"),
     ("decay_time", 1e3, "decay time (ms)", "tab:brown")),
)  # fmt: skip


def plot_analysis(analysis, audio, samplerate, path):
    """Draw the analysis to an image file (format from the suffix), written whole or not at all
    (:func:`synth.store.atomic.write_atomically`); returns the matplotlib Figure. Four panels:
    the analysed signal with the onsets; bounce time (ms) and restitution per bounce; tick energy
    (log) against bounce number with ``E_1 ebar^(2 (n - 1))`` (``ebar`` the mean restitution);
    centroid (Hz) and decay time (ms) per bounce. ``audio`` (frames[, channels]) is the
    recording ``analysis`` was made of, at its ``samplerate`` (Hz). SynthError without
    matplotlib."""
    an = checked_analysis("analysis", analysis)
    x = _analysed_signal(an, audio, samplerate)
    fmt = check_plot_path(path)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    fig = Figure(figsize=(11, 8), layout="constrained")
    FigureCanvasAgg(fig)
    (signal, bounces), (energies, spectra) = fig.subplots(2, 2)
    signal.plot(np.arange(x.size) / an.samplerate, x, lw=0.5, color="0.3")
    for tk in an.ticks:
        signal.axvline(tk.time, color="tab:red", lw=0.6, alpha=0.7)
    signal.set(xlabel="time (s)", ylabel="signal", title=f"{len(an.ticks)} ticks detected")
    n = np.array([tk.index for tk in an.ticks])
    for ax, (title, left, right) in zip((bounces, spectra), _TWIN_PANELS):
        ax.plot(n, _column(an, left[0], left[1]), "o-", color=left[3], ms=3)
        ax.set(xlabel="tick", ylabel=left[2], title=title)
        twin = ax.twinx()
        twin.plot(n, _column(an, right[0], right[1]), "s-", color=right[3], ms=3)
        twin.set_ylabel(right[2], color=right[3])
    energy = _column(an, "energy")
    energies.semilogy(n, energy, "o", color="tab:green", ms=4, label="tick energy")
    e = an.mean_restitution
    if e is not None and energy.size:
        label = f"slope e^2, e = {e:.3f}"
        energies.semilogy(n, energy[0] * (e * e) ** (n - 1.0), "--", color="0.4", label=label)
    energies.set(xlabel="tick", ylabel="energy (signal units^2 s)", title="energy per tick")
    energies.legend(loc="upper right")
    for ax in (bounces, energies, spectra):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    write_atomically(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=110), error=ParameterError)
    return fig


def _analysed_signal(an: Analysis, audio, samplerate) -> np.ndarray:
    """The signal the analysis used (its channel, or the mix), checked against its rate, channels
    and length."""
    chans = audio_array(audio)
    fs = checks.positive("samplerate", samplerate, "Hz")
    frames = int(round(an.duration * fs))
    if fs != an.samplerate:
        raise ParameterError(
            f"samplerate={samplerate!r} differs from the analysis' {an.samplerate:g} Hz"
        )
    if an.channel is not None and an.channel >= chans.shape[1]:
        raise ParameterError(
            f"audio has {chans.shape[1]} channel(s) but the analysis used channel {an.channel}"
            f" (pass the recording with all its channels)"
        )
    if chans.shape[0] != frames:
        raise ParameterError(f"audio has {chans.shape[0]} frames but the analysis was of {frames}")
    return chans.mean(axis=1) if an.channel is None else chans[:, an.channel]


def _column(an: Analysis, name: str, scale: float = 1.0) -> np.ndarray:
    """One field of every tick, NaN where undefined."""
    values = (getattr(tk, name) for tk in an.ticks)
    return np.array([np.nan if v is None else v * scale for v in values])
