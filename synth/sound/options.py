"""The render options, declared once (:class:`RenderOptions`): :func:`synth.render`'s
signature and docstring, a preset's ``[render]`` table and ``synth render``'s flags are made
from its fields, and constructing it is the one check."""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.constants import DEFAULT_FLOOR_DB, DEFAULT_MAX_IMPACTS, PULSE_POINTS
from synth.errors import ParameterError

#: Hz: the rate of a preset whose ``[render]`` table names none (the table a preset's loader
#: returns always holds a rate, since a render requires one), and of ``synth render`` then.
PRESET_SAMPLERATE = 48000
#: The level stages (see :func:`synth.store.audio.normalize`).
NORMALIZE = ("peak", "loudness", "physical", "none")
#: Range of the sample rate, Hz.
MIN_SAMPLERATE, MAX_SAMPLERATE = 8000, 384000
#: Longest preroll and fade, s.
MAX_PREROLL = 10.0
#: Longest bounce series and tail, s each (10 minutes each: the longest render, 20 minutes,
#: is a float64 buffer of 3.7 GB at 384 kHz, 0.46 GB at 48 kHz).
MAX_DURATION = 600.0
#: Lowest peak level and loudness, dBFS and LUFS: a peak at -120 dBFS spans a few levels
#: of a 24-bit file (its step is 2^-23, -138 dBFS); below it the file is silence.
MIN_LEVEL_DB = -120.0
#: Most points of a pulse's grid: the rule's error falls as ``n^-2.5`` (see
#: :mod:`synth.sound.modal_bank`) from 2e-6 of the impulse at 65 points, so at 4097 it is
#: below 1e-10, far under float32 audio's resolution (6e-8); more points only cost time.
MAX_PULSE_POINTS = 4097
#: Most impacts a render's bounce series may be given (``max_impacts``): each impact is a
#: contact solve and a pulse, so this many is minutes of work; a guard against a typo.
MAX_IMPACTS = 100_000


_option = checks.option


def _negative_db(unit: str, least: float | None = None, closed: bool = False, why: str = ""):
    """The check of a level below 0, or in ``[least, 0)`` (``[least, 0]`` when ``closed``)."""

    def check(name, value, checked) -> float:
        if least is not None:
            return checks.in_range(name, value, least, 0.0, unit, lo_open=False, hi_open=not closed)
        x = checks.real(name, value, unit, "< 0")
        if not x < 0.0:
            raise ParameterError(f"{name}={value!r} must be < 0 ({unit}{why})")
        return x

    return check


def _max_frequency(name, value, checked) -> float | None:
    if value is None:
        return None
    f_max = checks.positive(name, value, "Hz")
    fs = checked["samplerate"]
    if f_max > 0.5 * fs:
        raise ParameterError(
            f"{name}={value!r} must be <= the Nyquist frequency "
            f"{0.5 * fs:g} Hz at samplerate={fs} (Hz)"
        )
    return f_max


def _seconds(hi: float, lo_open: bool = True):
    """The check of a time in s: in (0, hi], or [0, hi] unless ``lo_open``."""

    def check(name, value, checked) -> float:
        return checks.in_range(name, value, 0.0, hi, "s", lo_open=lo_open, hi_open=False)

    return check


def _integer(lo: int, hi: int, what: str = "an integer"):
    """The check of an integer in ``[lo, hi]`` (``what``: how the message names it)."""

    def check(name, value, checked) -> int:
        integer = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if not (integer and lo <= value <= hi):
            raise ParameterError(f"{name}={value!r} must be {what} in [{lo}, {hi}]")
        return int(value)

    return check


@dataclass(frozen=True, kw_only=True)
class RenderOptions:
    """The options of a render (:func:`synth.render`): checked and converted when made,
    immutable after. ``samplerate`` has no default: every caller names the rate.

    ``RenderOptions(samplerate=48000, max_tail=2.0)``; :meth:`replace` makes a changed copy,
    checked again. The fields, each with its unit and the values allowed:
    """

    samplerate: int = _option(
        dataclasses.MISSING, unit="Hz", metavar="HZ", doc="sample rate",
        check=_integer(MIN_SAMPLERATE, MAX_SAMPLERATE, "an integer number of Hz"),
        allowed=f"an integer in [{MIN_SAMPLERATE}, {MAX_SAMPLERATE}]",
    )  # fmt: skip
    normalize: str = _option(
        "peak", unit="", metavar="MODE", choices=NORMALIZE,
        check=lambda name, value, checked: checks.choice(name, value, NORMALIZE),
        allowed=", ".join(NORMALIZE),
        doc="level: peak (to peak_db dBFS), loudness (to loudness_lufs LUFS, needs "
        "pyloudnorm), physical (1000 Pa or 10 000 m/s^2 full scale), none (Pa or m/s^2; a "
        "file then needs subtype FLOAT)",
    )  # fmt: skip
    peak_db: float = _option(
        -1.0, unit="dBFS", metavar="DBFS", check=_negative_db("dBFS", MIN_LEVEL_DB, True),
        allowed=f"in [{MIN_LEVEL_DB:g}, 0]", doc="peak level for normalize peak",
    )  # fmt: skip
    loudness_lufs: float = _option(
        -23.0, unit="LUFS", metavar="LUFS", check=_negative_db("LUFS", MIN_LEVEL_DB),
        allowed=f"in [{MIN_LEVEL_DB:g}, 0)",
        doc="integrated loudness (ITU-R BS.1770) for normalize loudness; a bouncing "
        "sound's crest factor is 30-40 dB, so a PCM file may need -40 or lower",
    )  # fmt: skip
    floor_db: float = _option(
        -80.0, unit="dB", metavar="DB", check=_negative_db("dB"), allowed="< 0",
        doc="omission floor below the reference amplitude (the bound on the loudest "
        "tick's peak): omitted modes and tails add up to at most this",
    )  # fmt: skip
    max_frequency: float | None = _option(
        None, unit="Hz", metavar="HZ", check=_max_frequency,
        allowed="> 0 and <= samplerate / 2; None: samplerate / 2",
        doc="highest mode rendered; below the plate's lowest mode the render would be "
        "silent and is refused",
    )  # fmt: skip
    preroll: float = _option(
        0.005, unit="s", metavar="S", check=_seconds(MAX_PREROLL, lo_open=False),
        allowed=f"in [0, {MAX_PREROLL:g}]", doc="silence before the first tick",
    )  # fmt: skip
    fade: float = _option(
        0.005, unit="s", metavar="S", check=_seconds(MAX_PREROLL, lo_open=False),
        allowed=f"in [0, {MAX_PREROLL:g}]",
        doc="raised-cosine fade at the end (the tail there is already below the floor); "
        "one longer than the audio is refused",
    )  # fmt: skip
    max_duration: float = _option(
        30.0, unit="s", metavar="S", check=_seconds(MAX_DURATION),
        allowed=f"in (0, {MAX_DURATION:g}]",
        doc="longest bounce series from release; the first impact must fall inside it",
    )  # fmt: skip
    max_tail: float = _option(
        60.0, unit="s", metavar="S", check=_seconds(MAX_DURATION),
        allowed=f"in (0, {MAX_DURATION:g}]",
        doc="longest ringing after the last impact: the audio ends when every tail is "
        "below the floor or here (a cut is reported: RenderInfo.tail_cut, left_at_end)",
    )  # fmt: skip
    pulse_points: int = _option(
        PULSE_POINTS, unit="", metavar="N", check=_integer(5, MAX_PULSE_POINTS),
        allowed=f"an integer in [5, {MAX_PULSE_POINTS}]",
        doc="fewest points of each force pulse's grid for its Laplace transforms (the "
        "default keeps their error below 2e-6 of the impulse)",
    )  # fmt: skip
    bounce_floor_db: float = _option(
        DEFAULT_FLOOR_DB, unit="dB", metavar="DB", allowed="< 0",
        check=_negative_db("dB", why=": an impact's kinetic energy re the first impact's"),
        doc="a drop's bounces end before an impact whose kinetic energy would be this far "
        "below the first's (not floor_db, which bounds the synthesis' omissions)",
    )  # fmt: skip
    max_impacts: int = _option(
        DEFAULT_MAX_IMPACTS, unit="", metavar="N", check=_integer(1, MAX_IMPACTS),
        allowed=f"an integer in [1, {MAX_IMPACTS}]",
        doc="a drop's bounces end after this many impacts (a scene with drop.velocity "
        "follows its path until the ball rolls and uses neither rule)",
    )  # fmt: skip

    def __post_init__(self):
        checks.check_fields(self)

    @classmethod
    def of(cls, options: RenderOptions | None = None, /, **overrides) -> RenderOptions:
        """``options`` (default: only ``overrides``) with ``overrides`` (fields by name)
        applied; an unknown name is a ``TypeError`` naming the nearest option."""
        checks.check_names(cls, overrides, "a render option")
        if options is None:
            if "samplerate" not in overrides:
                raise TypeError("samplerate (Hz) is required: there is no default rate")
            return cls(**overrides)
        if not isinstance(options, cls):
            raise ParameterError(f"options={options!r} must be a RenderOptions")
        return options.replace(**overrides) if overrides else options

    def replace(self, **changes) -> RenderOptions:
        """A copy with ``changes`` (fields by name), checked."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """The options by name, in the order of the fields."""
        return {name: getattr(self, name) for name in OPTIONS}

    @property
    def top_frequency(self) -> float:
        """``max_frequency``, or the Nyquist frequency where it is None, Hz."""
        return 0.5 * self.samplerate if self.max_frequency is None else self.max_frequency

    def bounces(self) -> dict:
        """The keywords of :func:`synth.physics.bounces.simulate_scene` these options set:
        the series' duration, level and impact rules."""
        return dict(
            max_duration=self.max_duration,
            floor_db=self.bounce_floor_db,
            max_impacts=self.max_impacts,
        )


#: The names of the render options, in the order of their fields.
OPTIONS = checks.names(RenderOptions)


#: The :class:`~synth.checks.Option` of a render option by name, its default
#: (``inspect.Parameter.empty`` for none) and its ``doc (unit; allowed)``; the options as a
#: numpydoc parameter list and as keyword-only parameters (for a generated signature).
declaration = functools.partial(checks.declaration, RenderOptions)
default = functools.partial(checks.default, RenderOptions)
describe = functools.partial(checks.describe, RenderOptions)
parameters_doc = functools.partial(checks.parameters_doc, RenderOptions)
keyword_parameters = functools.partial(checks.keyword_parameters, RenderOptions)


def flag_rows() -> str:
    """The rows of ``synth render``'s flags for the render options (Markdown, as
    docs/cli.md prints them: flag, doc, unit, values allowed, default)."""
    rows = []
    for name in OPTIONS:
        d = declaration(name)
        value = PRESET_SAMPLERATE if name == "samplerate" else default(name)
        shown = "samplerate / 2" if value is None else value
        shown = f"{shown:g}" if isinstance(shown, float) else shown
        text = describe(name).replace("|", "/")
        rows.append(f"| `--{name.replace('_', '-')} {d.metavar}` | {text}; default {shown} |")
    return "\n".join(rows)


if RenderOptions.__doc__:  # None under python -OO
    RenderOptions.__doc__ += "\n" + parameters_doc()
