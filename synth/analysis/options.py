"""The analysis options, declared once (:class:`AnalysisOptions`, fields of
:class:`~synth.checks.Option`): ``analyze``, ``analyze_file`` and the command line read them
here; recording-dependent checks are :func:`~synth.analysis.settings.make_settings`'."""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError

#: Default floor of the detection, dB under the strongest frame of the whitened signal, in
#: steps 1-6 (a guard against what the 20 ms predictor leaves of the earlier ticks, which
#: those steps do not model over their whole response) and for the test that calls step 7.
DYNAMIC_RANGE_DB = 60.0

#: The upper ends of the ranges, each past any use, so that an absurd value is named rather than
#: run into an allocation or an overflow: gravity, m/s^2 (past the Sun's 274 m/s^2); margins and
#: ranges, dB (float64 resolves 313 dB); the memory's release, dB/ms (forgotten within a sample at
#: 1 MHz); ``min_separation``, s (a first bounce of 1 s is a drop from 1.2 m); ``hop``, s (ticks
#: a few ms apart); ``background``, s; ``window``, s (a lightly damped plate rings for seconds);
#: ``decay_smoothing``, s; the whitening's order (step 7's predictor costs its square).
MAX_GRAVITY, MAX_DB, MAX_RELEASE = 300.0, 300.0, 1000.0
MAX_SEPARATION, MAX_HOP, MAX_BACKGROUND, MAX_WINDOW, MAX_SMOOTHING = 1.0, 0.01, 1.0, 2.0, 0.1
MAX_ORDER = 4096
#: What ``on_clipping`` may say.
ON_CLIPPING = ("warn", "raise")


def _real(hi: float, unit: str, metavar: str, more: str = "", optional: bool = False) -> dict:
    """The declaration of a real number in (0, hi] (or None where ``optional``)."""

    def check(name, value, checked) -> float | None:
        if optional and value is None:
            return None
        return checks.positive_at_most(name, value, hi, unit)

    return {"unit": unit, "metavar": metavar, "check": check, "allowed": f"in (0, {hi:g}]{more}"}


def _integer(lo: int | None, hi: int | None = None, optional: bool = False, allowed: str = ""):
    """The check of an integer in ``lo..hi`` (``>= lo`` without ``hi``; any without ``lo``; or
    None where ``optional``), its message naming ``allowed``."""
    allowed = allowed or (f"an integer >= {lo}" if hi is None else f"an integer in {lo}..{hi}")

    def check(name, value, checked) -> int | None:
        if optional and value is None:
            return None
        if (
            isinstance(value, (bool, np.bool_))
            or not isinstance(value, (int, np.integer))
            or (lo is not None and value < lo)
            or (hi is not None and value > hi)
        ):
            raise ParameterError(f"{name}={value!r} must be {allowed}")
        return int(value)

    return check


def _flag(name, value, checked) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name}={value!r} must be True or False")
    return bool(value)


_option = checks.option
_SAMPLE = ", at least one sample"
_SWITCH = {"unit": "", "metavar": "", "check": _flag, "parse": bool, "allowed": "True or False"}


@dataclass(frozen=True, kw_only=True)
class AnalysisOptions:
    """The options of an analysis (:func:`synth.analysis.analyze`), checked when made:
    ``AnalysisOptions(window=0.05)``; :meth:`replace` makes a checked copy. The fields:"""

    gravity: float = _option(
        GRAVITY, **_real(MAX_GRAVITY, "m/s^2", "G"),
        doc="gravity for the impact speeds v_n = g t_n / 2",
    )  # fmt: skip
    channel: int | None = _option(
        None, unit="", metavar="N", parse=lambda text: None if text == "mix" else int(text),
        check=_integer(None, optional=True, allowed="None (mix) or a channel index"),
        allowed="a channel index of the audio, from 0, or None: the mean of the channels "
        "('mix' on the command line)",
        doc="the channel analysed",
    )  # fmt: skip
    min_separation: float = _option(
        0.001, **_real(MAX_SEPARATION, "s", "S", _SAMPLE),
        doc="shortest time between two ticks: a burst closer than this to a tick is part of "
        "it (the end of a long contact); lower it (0.0002) for hard balls whose last bounces "
        "are shorter than 1 ms",
    )  # fmt: skip
    hop: float = _option(
        0.00025, **_real(MAX_HOP, "s", "S", _SAMPLE),
        doc="spacing of the detection function's frames, each at least 12 samples long",
    )  # fmt: skip
    threshold_db: float = _option(
        10.0, **_real(MAX_DB, "dB", "DB"), doc="a tick's margin above the local background",
    )  # fmt: skip
    rise_db: float = _option(
        6.0, **_real(MAX_DB, "dB", "DB"),
        doc="a tick's margin above the fading memory of the earlier frames",
    )  # fmt: skip
    release: float = _option(
        5.0, **_real(MAX_RELEASE, "dB/ms", "DB_PER_MS"), doc="how fast that memory fades",
    )  # fmt: skip
    dynamic_range_db: float | None = _option(
        None, **_real(MAX_DB, "dB", "DB", f"; None: {DYNAMIC_RANGE_DB:g} in steps 1-6 and none "
        "in the resonator's search, step 7, whose floor is the whitened noise floor raised by "
        "threshold_db and max_drop_db under the last tick", optional=True),
        doc="ticks more than this below the strongest frame of the whitened signal are "
        "ignored, in every step",
    )  # fmt: skip
    max_drop_db: float = _option(
        20.0, **_real(MAX_DB, "dB", "DB"),
        doc="a tick more than this below the previous tick is ignored (20 dB: a restitution "
        "below 0.1); the shortest plausible bounce is 10^(-max_drop_db / 20) times the "
        "previous one",
    )  # fmt: skip
    background: float = _option(
        0.02, **_real(MAX_BACKGROUND, "s", "S"),
        doc="length of the running median giving the local background",
    )  # fmt: skip
    onset_fraction: float = _option(
        0.1, unit="", metavar="F", allowed="in (0, 1)",
        check=lambda name, value, _: checks.in_range(name, value, 0.0, 1.0),
        doc="level of the onset crossing, as a fraction of the burst's peak",
    )  # fmt: skip
    lpc_order: int | None = _option(
        None, unit="", metavar="N", check=_integer(2, MAX_ORDER, optional=True), parse=int,
        allowed=f"an integer in 2..{MAX_ORDER}; None: 20 ms of samples, at least 8, and the "
        "resonator's own predictor (step 7) where the first tick rings on under it",
        doc="order of the whitening predictor; given, that order alone and no step 7",
    )  # fmt: skip
    window: float = _option(
        0.02, **_real(MAX_WINDOW, "s", "S", _SAMPLE),
        doc="every tick's measurement window (shorter only where the recording ends): "
        "energy, peak, centroid, spread and decay of the tick's own sound over it",
    )  # fmt: skip
    subtract_tails: bool = _option(
        True, **_SWITCH,
        doc="measure each tick's own sound (its excitation through the resonator's all-pole "
        "model, without the other ticks), not the recording over the window",
    )  # fmt: skip
    deflate: bool = _option(
        True, **_SWITCH,
        doc="find the ticks after the first one by one, each with the earlier ticks' "
        "whitened responses taken out (steps 5 and 7), not only those of step 3",
    )  # fmt: skip
    decay_smoothing: float = _option(
        0.002, **_real(MAX_SMOOTHING, "s", "S", ", at least 3 samples"),
        doc="length of the Hann window smoothing the envelope for the decay fit",
    )  # fmt: skip
    clip_samples: int = _option(
        4, unit="", metavar="N", check=_integer(2), parse=int, allowed="an integer >= 2",
        doc="samples at exactly a channel's largest (or smallest) value, in flat tops of at "
        "least two, that mean clipping",
    )  # fmt: skip
    on_clipping: str = _option(
        "warn", unit="", metavar="POLICY", parse=str,
        check=lambda name, value, _: checks.choice(name, value, ON_CLIPPING), choices=ON_CLIPPING,
        allowed=", ".join(ON_CLIPPING),
        doc="report clipping in Analysis.warnings, or raise AnalysisError",
    )  # fmt: skip

    def __post_init__(self):
        checks.check_fields(self)

    @classmethod
    def of(cls, options: AnalysisOptions | None = None, /, **overrides) -> AnalysisOptions:
        """``options`` (default: the defaults) with ``overrides`` (fields by name) applied;
        an unknown name is a ``TypeError`` naming the nearest option."""
        checks.check_names(cls, overrides, "an analysis option")
        if options is None:
            return cls(**overrides)
        if not isinstance(options, cls):
            raise ParameterError(f"options={options!r} must be an AnalysisOptions")
        return options.replace(**overrides) if overrides else options

    def replace(self, **changes) -> AnalysisOptions:
        """A copy with ``changes`` (fields by name), checked."""
        checks.check_names(type(self), changes, "an analysis option")
        return dataclasses.replace(self, **changes)


#: The names of the analysis options, in the order of their fields.
OPTIONS = checks.names(AnalysisOptions)
#: The :class:`~synth.checks.Option` of an analysis option by name, its ``doc (unit; allowed)``
#: and the options as a numpydoc parameter list.
declaration = functools.partial(checks.declaration, AnalysisOptions)
describe = functools.partial(checks.describe, AnalysisOptions)
parameters_doc = functools.partial(checks.parameters_doc, AnalysisOptions)


def flag(name: str) -> str:
    """The command line's flag of option ``name`` (``--no-NAME`` for a switch on by default)."""
    dashed = name.replace("_", "-")
    if declaration(name).parse is bool:
        return f"--no-{dashed}" if checks.default(AnalysisOptions, name) else f"--{dashed}"
    return f"--{dashed} {declaration(name).metavar}"


def flag_help(name: str) -> str:
    """The help of option ``name``'s flag: doc, unit, values allowed and default."""
    value = checks.default(AnalysisOptions, name)
    if declaration(name).parse is bool:
        return f"{name}={not value} (default {value}: {declaration(name).doc})"
    shown = "None" if value is None else f"{value:g}" if isinstance(value, float) else value
    return f"{describe(name)}; default {shown}"


def flag_rows() -> str:
    """The rows of the analysis options' flags (Markdown, as docs/cli.md prints them)."""
    return "\n".join(f"| `{flag(n)}` | {flag_help(n).replace('|', '/')} |" for n in OPTIONS)


def from_text(given: dict) -> AnalysisOptions:
    """The options from their command-line text, parsed as declared, then checked."""
    values = {}
    for name, text in given.items():
        parse = declaration(name).parse
        try:
            values[name] = text if parse is bool else parse(text)
        except ValueError:
            raise ParameterError(f"{name}={text!r} must be {declaration(name).allowed}") from None
    return AnalysisOptions(**values)


if AnalysisOptions.__doc__:  # None under python -OO
    AnalysisOptions.__doc__ += "\n" + parameters_doc()
