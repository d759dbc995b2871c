"""A bank spec's record (:class:`BankSpec`, its axes), its keys and defaults, its stored
and compared forms, and the error a spec's mistake raises (:class:`BankSpecError`)."""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass

import numpy as np

import synth
from synth.errors import ParameterError
from synth.io import presets

#: Top-level keys of a spec.
TOP_LEVEL = tuple(
    "preset description count seed name format vary render trim sampling labels min_distance "
    "tags".split()
)

#: Keys of a stored spec that change no sound: left out when specs are compared.
NOT_AUDIO = ("preset", "name", "labels", "tags")

#: Key of a stored spec naming the engine that rendered the bank (``synth.__version__``),
#: compared on its own (:func:`synth.bank.runner.engine_problem`).
ENGINE = "engine"

#: Keys of ``[trim]`` and their defaults: the tail is cut where the sound stays below
#: ``below_db`` (dB re its peak, < 0), with a raised-cosine fade of ``fade`` s ending
#: there, and at ``max_length`` s at most (None: no bound).
TRIM_DEFAULTS = {"below_db": -60.0, "fade": 0.01, "max_length": None}

#: File formats: suffix and soundfile format name, and the default subtype of each.
FORMATS = {
    "wav": ("wav", "WAV", "PCM_24"),
    "flac": ("flac", "FLAC", "PCM_24"),
    "ogg": ("ogg", "OGG", "VORBIS"),
}

#: The axis key of the perception stimuli's restitution scaling.
RESTITUTION_SCALE = "restitution_scale"

#: The bank's level default: one calibration for every file (see synth.store.audio).
DEFAULT_NORMALIZE = "physical"

#: The bank's impact limit (``[render] max_impacts``), a stop rule for a ball that loses
#: little per bounce: energy falls by e^2 a bounce, so with e <= 0.89 impact 64 is
#: 20 * 63 * log10(1 / 0.89) = 64 dB down, past the -60 dB rule that ends a series anyway.
BANK_MAX_IMPACTS = 64

#: What a bank's ``[render]`` takes when neither the spec nor the preset sets it.
RENDER_DEFAULTS = {"normalize": DEFAULT_NORMALIZE, "max_impacts": BANK_MAX_IMPACTS}

#: Largest plan accepted (rows), a guard against a mistyped count or grid (about a day of
#: one core).
MAX_ROWS = 100_000

#: Version of the plan's drawing rules, stored with a bank (other rules, another bank): 3
#: draws the combinations of the list axes without replacement, 2 each list axis (the same
#: rows with fewer than two list axes or without ``count``: :func:`_plan_rules`).
PLAN_VERSION = 3


class BankSpecError(ParameterError):
    """A bank spec that cannot be run; the message names the key and value."""


@dataclass(frozen=True)
class ListAxis:
    """A grid axis (or, with ``count``, a list sampled uniformly): ``key``, ``values``."""

    key: str
    values: tuple


@dataclass(frozen=True)
class RangeAxis:
    """A range drawn uniformly (``log``: log-uniformly) between ``low`` and ``high``,
    scalars or vectors of one length (``tuple``), in the key's units."""

    key: str
    low: float | tuple
    high: float | tuple
    log: bool = False
    steps: int | None = None

    def position(self, u: np.ndarray):
        """The value at fractions ``u`` (one per component, in [0, 1]) of the range."""
        lo, hi = (np.atleast_1d(np.asarray(b, dtype=float)) for b in (self.low, self.high))
        if self.log:
            v = np.exp(np.log(lo) + u * (np.log(hi) - np.log(lo)))
        else:
            v = lo + u * (hi - lo)
        v = np.clip(v, lo, hi)  # rounding of lo + u (hi - lo) may cross hi by an ulp
        return [float(x) for x in v] if isinstance(self.low, tuple) else float(v[0])

    def draw(self, rng: np.random.Generator):
        """One value, drawn uniformly (log: log-uniformly) with ``rng``."""
        return self.position(rng.random(np.atleast_1d(np.asarray(self.low)).size))


@dataclass(frozen=True)
class BankSpec:
    """A checked bank spec: ``base`` the preset's dict with the spec's ``[render]``,
    ``render`` the render options, ``subtype`` the files'."""

    preset: str
    preset_name: str
    base: dict
    description: str
    count: int | None
    seed: int
    name: str
    format: str
    subtype: str
    render: dict
    axes: tuple
    trim: dict | None = None
    sampling: str = "random"
    labels: dict = dataclasses.field(default_factory=dict)
    min_distance: float | None = None
    tags: list | dict | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        """The varied keys, in the spec's order."""
        return tuple(a.key for a in self.axes)

    @property
    def suffix(self) -> str:
        return FORMATS[self.format][0]

    def as_dict(self) -> dict:
        """Everything that determines the bank's files, as JSON-able data."""
        axes = {}
        for a in self.axes:
            if isinstance(a, ListAxis):
                axes[a.key] = list(a.values)
            else:  # vectors as tuples: JSON lists once stored (:func:`canonical`)
                steps = {} if a.steps is None else {"steps": a.steps}
                axes[a.key] = {"min": a.low, "max": a.high, "log": a.log} | steps
        return {
            "preset": self.preset_name,
            "preset_data": self.base,
            "count": self.count,
            "seed": self.seed,
            "name": self.name,
            "format": self.format,
            "subtype": self.subtype,
            "render": self.render,
            "vary": axes,
            "plan": PLAN_VERSION,
            "trim": self.trim,
            "sampling": self.sampling,
            "labels": self.labels,
            "min_distance": self.min_distance,
            "tags": self.tags,
            ENGINE: synth.__version__,
        }

    def stored_form(self) -> dict:
        """:meth:`as_dict` in its :func:`canonical` form, stored with the bank."""
        return canonical(self.as_dict())


def canonical(data: dict) -> dict:
    """The form (idempotent) of a stored spec ``data`` in which two specs that make the
    same files are equal: the base preset's :func:`synth.io.presets.canonical` form, the
    files' subtype, the plan's rules (:func:`_plan_rules`). A ``data`` that is no valid
    spec is returned as it is."""
    try:
        base = presets.canonical(data["preset_data"], varied=tuple(data["vary"]))
        plan_rules = _plan_rules(data)
    except (ParameterError, KeyError, TypeError, ValueError, AttributeError):
        return data
    base["render"]["subtype"] = data["subtype"]
    out = dict(data, preset_data=base, plan=plan_rules)
    out["render"] = {k: v for k, v in base["render"].items() if k != "subtype"}
    return json.loads(json.dumps(out))  # tuples as lists, as the stored JSON holds them


def _plan_rules(data: dict):
    """The plan version ``data`` is compared by: plan 2 counts as 3 where 3 draws its rows
    alike (without ``count`` or with fewer than two list axes), so its bank resumes."""
    version = data.get("plan")
    lists = [v for v in data["vary"].values() if isinstance(v, list)]
    if version == 2 and (data.get("count") is None or len(lists) < 2):
        return PLAN_VERSION
    return version


def compared_form(data: dict) -> dict:
    """The part of a stored spec that makes the sounds: :func:`canonical` without
    :data:`NOT_AUDIO` and :data:`ENGINE`."""
    return {k: v for k, v in canonical(data).items() if k not in NOT_AUDIO + (ENGINE,)}


def spec_error(key: str, value, allowed: str) -> BankSpecError:
    return BankSpecError(f"{key}={value!r} {allowed}")


def spec_number(key: str, value, allowed: str = "must be a finite number") -> float:
    """``value`` as a float if it is a finite number (not a bool), else :func:`spec_error`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise spec_error(key, value, allowed)
    return float(value)


def spec_integer(key: str, value, least: int, allowed: str) -> int:
    """``value`` if it is an integer (not a bool) ``>= least``, else :func:`spec_error`."""
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise spec_error(key, value, allowed)
    return value
