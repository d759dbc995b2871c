"""The result of an analysis: :class:`Tick` and :class:`Analysis`, and their presentation as a
terminal table, JSON-ready data, CSV (SI units throughout) and a plot (matplotlib, written
atomically)."""

from __future__ import annotations

import csv
import io
import os
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from synth import checks
from synth.analysis.settings import audio_array
from synth.errors import ParameterError, SynthError
from synth.store.atomic import write_atomically

#: Flag of a tick whose bounce time is not shorter than the one before (``e_n >= 1``).
GROWN_BOUNCE = "restitution>=1"
#: Flag of a tick whose restitution divides by a bounce that had grown (a missed tick).
AFTER_GROWN = "after-restitution>=1"
#: Flag of a tick whose own sound does not decay (a step or edge, not an impact).
NO_DECAY = "no-decay"
#: Flag of a tick whose restitution spans a missed bounce.
MISSED_BOUNCE = "missed-bounce"
#: The flags that withhold a tick's restitution (and keep it out of means).
RESTITUTION_FLAGS = (GROWN_BOUNCE, AFTER_GROWN, MISSED_BOUNCE)


@dataclass(frozen=True)
class Tick:
    """One detected tick (SI units; ``None`` where undefined or withheld by a flag).

    ``index`` (1 first); ``time`` onset, s from the recording's start; ``bounce_time`` ``t_n``,
    s since the previous onset; ``restitution`` ``e_n = t_n / t_(n-1)`` (the thesis,
    docs/physics.md, References, section 3.1), above the physical one by about contact time over
    bounce time (docs/analysis.md); ``speed`` ``v_n = g t_n / 2``, m/s; ``energy`` sum of squares
    of the tick's own signal over its ``window`` (s) over the rate, units^2 s; ``peak``, signal
    units; ``centroid``, ``spread`` of the power spectrum, Hz; ``decay_time`` to 1/e of the
    envelope's peak, s; ``strength`` margin of the whitened energy over its threshold, dB (step
    7: the fall of the description length, dB per sample); ``flags``
    (:mod:`~synth.analysis.validity`): ``"restitution>=1"``, ``"after-restitution>=1"`` and
    ``"missed-bounce"`` withhold the restitution, ``"no-decay"`` marks a sound that does not
    ring down."""

    index: int
    time: float
    bounce_time: float | None
    restitution: float | None
    speed: float | None
    energy: float
    peak: float
    centroid: float
    spread: float
    decay_time: float | None
    window: float
    strength: float
    flags: tuple[str, ...] = ()


@dataclass(frozen=True)
class Analysis:
    """The ticks found in one recording, in time order: ``samplerate`` (Hz), ``duration`` (s),
    ``noise_floor`` (RMS, signal units), ``gravity`` of the speeds (m/s^2), ``channel`` (None:
    the mix), ``clipped``, ``warnings`` (what to read the figures with) and ``series`` (the
    drops, :mod:`~synth.analysis.validity`)."""

    ticks: list[Tick]
    samplerate: float
    duration: float
    noise_floor: float
    gravity: float
    channel: int | None
    clipped: bool
    warnings: tuple[str, ...]
    series: list = field(default_factory=list)

    @property
    def mean_restitution(self) -> float | None:
        """Mean of the defined ``e_n`` that are not flagged (physically possible), over every
        series, dimensionless; ``None`` when there is none."""
        e = [
            t.restitution
            for t in self.ticks
            if t.restitution is not None and not set(RESTITUTION_FLAGS) & set(t.flags)
        ]
        return float(np.mean(e)) if e else None


def checked_analysis(name: str, value) -> Analysis:
    """``value`` when it is an :class:`Analysis`; else ParameterError naming ``name``."""
    if not isinstance(value, Analysis):
        raise ParameterError(
            f"{name} must be an Analysis (from analyze or analyze_file), not {type(value).__name__}"
        )
    return value


#: Columns of :func:`format_table`: (field, heading, scale, format).
_COLUMNS = (
    ("index", "n", 1.0, "d"),
    ("time", "time (s)", 1.0, ".5f"),
    ("bounce_time", "bounce (ms)", 1e3, ".3f"),
    ("restitution", "e", 1.0, ".4f"),
    ("speed", "speed (m/s)", 1.0, ".4f"),
    ("energy", "energy (u^2 s)", 1.0, ".4g"),
    ("peak", "peak (u)", 1.0, ".4g"),
    ("centroid", "centroid (Hz)", 1.0, ".0f"),
    ("spread", "spread (Hz)", 1.0, ".0f"),
    ("decay_time", "decay (ms)", 1e3, ".2f"),
    ("strength", "strength (dB)", 1.0, ".1f"),
    ("flags", "flags", 1.0, "s"),
)


def _text(value, scale: float, fmt: str) -> str:
    """A table cell: ``-`` where undefined, the flags joined by commas."""
    if isinstance(value, tuple):
        value = ",".join(value) or None
    return "-" if value is None else format(value * scale if scale != 1.0 else value, fmt)


def format_table(analysis, *, warnings=True) -> str:
    """A terminal table of the ticks under a summary header and, with ``warnings``, the warnings;
    columns :data:`_COLUMNS`, undefined values ``-``."""
    an = checked_analysis("analysis", analysis)
    if not isinstance(warnings, (bool, np.bool_)):
        raise ParameterError(f"warnings={warnings!r} must be True or False")
    e = an.mean_restitution
    lines = [
        f"{len(an.ticks)} ticks in {an.duration:.3f} s at {an.samplerate:g} Hz, "
        f"channel {'mix' if an.channel is None else an.channel}, "
        f"noise floor {an.noise_floor:.3g}, mean e "
        f"{'-' if e is None else format(e, '.4f')}, g {an.gravity:g} m/s^2"
    ]
    lines += [f"warning: {w}" for w in an.warnings] if warnings else []
    table = [[h for _, h, _, _ in _COLUMNS]]
    table += [[_text(getattr(t, n), sc, f) for n, _, sc, f in _COLUMNS] for t in an.ticks]
    widths = [max(len(row[j]) for row in table) for j in range(len(_COLUMNS))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(row, widths)) for row in table]
    return "\n".join(lines)


#: The units of :func:`to_dict`'s fields.
_UNITS = dict.fromkeys(("time", "bounce_time", "decay_time", "window", "duration"), "s") | {
    "speed": "m/s",
    "energy": "signal units^2 s",
    "peak": "signal units",
    "centroid": "Hz",
    "spread": "Hz",
    "strength": "dB",
    "samplerate": "Hz",
    "noise_floor": "signal units",
    "gravity": "m/s^2",
}


def to_dict(analysis) -> dict:
    """The analysis as plain JSON-ready data (SI units; ``None`` where undefined)."""
    an = checked_analysis("analysis", analysis)
    out = {f.name: getattr(an, f.name) for f in fields(an) if f.name not in ("ticks", "series")}
    out |= {"warnings": list(an.warnings), "mean_restitution": an.mean_restitution}
    out["units"] = dict(_UNITS)
    out["ticks"] = [asdict(t) | {"flags": list(t.flags)} for t in an.ticks]
    out["series"] = [
        {"first": s.first, "last": s.last, "ticks": [t.index for t in s.ticks]}
        | {"mean_restitution": s.mean_restitution}
        for s in an.series
    ]
    return out


def to_csv(analysis) -> str:
    """The ticks as CSV: a header of the :class:`Tick` field names, one row each in SI units;
    undefined values empty, flags joined by ``;``, numbers as their exact ``repr``."""
    an = checked_analysis("analysis", analysis)
    names = [f.name for f in fields(Tick)]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    for t in an.ticks:
        cells = [getattr(t, n) for n in names]
        w.writerow(
            ["" if v is None else ";".join(v) if isinstance(v, tuple) else repr(v) for v in cells]
        )
    return buf.getvalue()


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
