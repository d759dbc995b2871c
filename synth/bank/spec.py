"""Bank specs: a TOML file describing many variations of one preset, and their plan.

A spec (every key; only ``preset`` is required)::

    preset = "default"              # a preset name or a .toml file (relative to the spec)
    description = "..."             # text
    count = 200                     # random variations; leave out for the full grid of lists
    seed = 7                        # integer >= 0 for the draws (default 0)
    name = "{preset}-{index:04d}"   # file name template, without the suffix
    format = "flac"                 # "wav", "flac" (default) or "ogg" (Vorbis)
    sampling = "random"             # ranges: "random", "lhs" (Latin hypercube) or "grid"
    tags = ["impact", "glass"]      # free tags for every row: keywords, or a table of
                                    # name = text/number/boolean ({ category = "impact" })

    [vary]                          # axes: any preset key, dotted as in `synth render --set`
    "drop.height" = { min = 0.05, max = 0.3 }              # a range, drawn uniformly
    "drop.position" = { min = [0.2, 0.1], max = [1.0, 0.4] }  # vectors: per component
    "ball.radius" = [0.004, 0.005, 0.006]                   # a list: a grid axis
    "plate.thickness" = { min = 0.006, max = 0.018, log = true }  # log-uniform
    restitution_scale = [0.5, 1.0, 1.5]   # perception stimuli: 1 - e' = k (1 - e)

    [trim]                          # optional: cut the tails (see TRIM_DEFAULTS)
    below_db = -60.0

    [render]                        # overrides the preset's [render] (synth.render options)
    samplerate = 48000              # Hz
    normalize = "physical"          # "physical" (default for banks), "peak", "loudness", "none"
    max_impacts = 64                # the bounces end after this many impacts (bank default 64,
                                    # BANK_MAX_IMPACTS); bounce_floor_db = -60.0 their level rule
    subtype = "PCM_24"              # the files' sample format (soundfile subtype)

With ``count``, variation ``i`` draws its ranges from its own generator
``numpy.random.default_rng([seed, i])`` (uniformly or log-uniformly; with
``sampling = "lhs"`` within strata dealt block by block, :func:`_lhs_fraction`) and its
lists' combinations without replacement block by block (:class:`_ListDraws`), so a
variation does not depend on the count or on the rows after it: raising ``count`` adds
rows. A ``count`` above the distinct rows of a spec without ranges (its lists'
combinations) repeats them, with a :class:`RepeatedRowsWarning`.
Without ``count``, the plan is the grid of the list axes (the first axis varies
slowest) and the ranges are drawn per grid point the same way.

The name template is a Python format string over ``preset`` (the preset's name),
``index`` and the axes; ``/`` makes subfolders (``"h{drop.height:.2f}/{index:04d}"``; no
empty, hidden or ``..`` part, no absolute path). A dotted key is both ``{drop.height}``
and ``{drop_height}`` (``{drop.position[0]:.2f}`` for a vector's component). The suffix
comes from ``format``.

Every manifest row carries the spec's ``tags`` and its values' labels from ``[labels]``
(:func:`row_labels`). Neither they, the preset's name nor the name template change a
sound: a bank resumes across a change of them (:func:`compared_form`), its files taking
their new names.

``restitution_scale`` (dimensionless ``k >= 0``) is the bank's one key that is not a preset
key: the impacts are :func:`synth.stimuli.sequences.scaled_sequence` of the scene, as
``synth render --restitution-scale`` renders them (thesis section 5.2.2, see
docs/physics.md).

A spec that cannot be run is a :class:`BankSpecError` naming the key, its value and what is
allowed, raised before any work (the first scene is built too).
"""

from __future__ import annotations

import dataclasses
import difflib
import itertools
import json
import math
import string
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import synth
from synth import cost
from synth.errors import ParameterError
from synth.io import presets

#: Top-level keys of a spec.
TOP_LEVEL = (
    "preset",
    "description",
    "count",
    "seed",
    "name",
    "format",
    "vary",
    "render",
    "trim",
    "sampling",
    "labels",
    "min_distance",
    "tags",
)

#: Keys of a stored spec that do not change any sound (they name the files or describe
#: them): left out when a spec is compared with the one a bank was made by.
NOT_AUDIO = ("preset", "name", "labels", "tags")

#: Key of a stored spec naming the engine that renders the bank (``synth.__version__``):
#: compared on its own, not with the spec (:func:`synth.bank.run.engine_problem`), since
#: another engine may make other bytes of the same spec.
ENGINE = "engine"

#: Draws tried for a row before a ``min_distance`` is declared too large.
MIN_DISTANCE_ATTEMPTS = 1000

#: Largest ``count`` with ``min_distance`` (each row is compared with every earlier one).
MIN_DISTANCE_MAX_ROWS = 20_000

#: How ranges are drawn with ``count`` ("random", "lhs": Latin hypercube block by block)
#: or set without it ("grid": ``steps`` values per range, spaced evenly or, with log,
#: geometrically).
SAMPLINGS = ("random", "lhs", "grid")

#: Rows of one Latin-hypercube block (``sampling = "lhs"``): within each block of this
#: many consecutive rows every range axis has one row in each of as many equal strata.
LHS_BLOCK = 32

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

#: The bank's level default: one calibration for every file (see synth.io.audio).
DEFAULT_NORMALIZE = "physical"

#: The bank's impact limit (``[render] max_impacts``; a plain render's is
#: :data:`synth.physics.bounces.DEFAULT_MAX_IMPACTS`): a stated stop rule for a ball that
#: loses little per bounce (rubber or ABS with the lossless Hertz contact, e near 0.99,
#: which would bounce to ``max_duration``), not a change of its restitution. Kinetic energy
#: falls by e^2 per bounce (docs/physics.md, "Bounces"), so a ball with e <= 0.89 is
#: 20 * 63 * log10(1 / 0.89) = 64 dB below its first impact by impact 64, past the
#: series' level rule (``bounce_floor_db``, -60 dB) that ends it by itself; a ball that
#: keeps more (near-elastic, or a glass marble on a wooden floor) stops here, its
#: ``stop_reason`` "max-impacts".
BANK_MAX_IMPACTS = 64

#: What a bank's ``[render]`` takes when neither the spec nor the preset sets it.
RENDER_DEFAULTS = {"normalize": DEFAULT_NORMALIZE, "max_impacts": BANK_MAX_IMPACTS}

#: Largest plan accepted (rows), a guard against a mistyped count or grid: every row's
#: scene is built and checked before the bank starts, and a bank of this many sounds of
#: about 0.1 s of rendering each is already a day of one core's work.
MAX_ROWS = 100_000

#: Version of the plan's drawing rules, stored with a bank (a bank drawn by other rules
#: is another bank): 2 drew each list axis without replacement block by block, 3 draws
#: the combinations of the list axes without replacement (:class:`_ListDraws`), which
#: makes the rows of 2 for a spec with fewer than two list axes or without ``count``
#: (a bank of 2 of such a spec resumes, :func:`canonical`).
PLAN_VERSION = 3

#: Most combinations of the list axes drawn as whole permutations, block by block
#: (:class:`_ListDraws`); not below :data:`MAX_ROWS`, so that beyond it a count never
#: fills a block. Part of the plan's rules (:data:`PLAN_VERSION`).
PERMUTED_COMBINATIONS = 100_000

#: Longest file name most file systems take, bytes (NAME_MAX of ext4, APFS, NTFS).
MAX_NAME_BYTES = 255

#: Where the example specs installed with the package are (usable by name).
PACKAGE_BANKS = Path(__file__).resolve().parents[1] / "presets" / "banks"


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
        lo = np.atleast_1d(np.asarray(self.low, dtype=float))
        hi = np.atleast_1d(np.asarray(self.high, dtype=float))
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
    """A checked bank spec (see the module docstring for the keys).

    ``base`` is the preset's raw dict with the spec's ``[render]`` applied, ``render``
    the render options (``normalize`` defaulted to "physical"), ``subtype`` the files'.
    """

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
        """Everything that determines the bank's files, as JSON-able data (stored with
        the bank to refuse a changed spec)."""
        axes = {}
        for a in self.axes:
            if isinstance(a, ListAxis):
                axes[a.key] = list(a.values)
            else:
                axes[a.key] = {"min": _jsonable(a.low), "max": _jsonable(a.high), "log": a.log}
                if a.steps is not None:
                    axes[a.key]["steps"] = a.steps
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
        """:meth:`as_dict` in its canonical form (:func:`canonical`): what is stored with
        the bank and compared with the spec of a later run."""
        return canonical(self.as_dict())


def canonical(data: dict) -> dict:
    """The canonical form of a stored spec ``data`` (:meth:`BankSpec.as_dict`, or this
    form itself: the function is idempotent), in which two specs that make the same
    files are equal: the base preset with every fixed default spelled out
    (:func:`synth.io.presets.canonical`: render options, gravity, plate boundary,
    contact model ...; not those derived from a varied key; without the preset's
    description and the base values of the varied keys, which every row sets), its
    ``render.subtype`` the files' subtype, its ``plan`` the rules that draw its rows
    (:func:`_plan_rules`). A value that changes the
    files still differs, under its dotted key (:func:`differences`). A ``data`` that is
    no valid spec is returned as it is (it then differs from any valid one)."""
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
    """The plan version a stored spec ``data`` is compared by: its own, except that one
    of plan 2 whose rows plan 3 draws alike (without ``count``, or with fewer than two
    list axes: 3 changed only how the combinations of several lists are drawn) counts as
    :data:`PLAN_VERSION`, so its bank resumes."""
    version = data.get("plan")
    lists = [v for v in data["vary"].values() if isinstance(v, list)]
    if version == 2 and (data.get("count") is None or len(lists) < 2):
        return PLAN_VERSION
    return version


def compared_form(data: dict) -> dict:
    """The part of a stored spec ``data`` that makes the sounds: its :func:`canonical`
    form without :data:`NOT_AUDIO` (the preset's name, the name template, the labels
    and the tags), so that a bank resumes across a change of them, and without the
    :data:`ENGINE` that rendered it (checked on its own)."""
    return {k: v for k, v in canonical(data).items() if k not in NOT_AUDIO + (ENGINE,)}


@dataclass(frozen=True)
class PlanItem:
    """One sound of the bank: ``index``, ``file`` (relative to the bank's folder) and
    ``values`` (the varied keys and their values)."""

    index: int
    file: str
    values: dict


def _jsonable(v):
    return list(v) if isinstance(v, tuple) else v


def _error(key: str, value, allowed: str) -> BankSpecError:
    return BankSpecError(f"{key}={value!r} {allowed}")


def available() -> dict[str, Path]:
    """The example specs installed with the package, by name (the file's stem)."""
    return {p.stem: p for p in sorted(PACKAGE_BANKS.glob("*.toml"))}


def find(path_or_name) -> Path:
    """The spec file ``path_or_name``: a file, or the name of an installed example."""
    p = Path(path_or_name)
    if p.exists() or p.suffix == ".toml":
        return p
    known = available()
    if str(path_or_name) in known:
        return known[str(path_or_name)]
    near = difflib.get_close_matches(str(path_or_name), known, n=2, cutoff=0.4)
    hint = f" (did you mean {', '.join(map(repr, near))}?)" if near else ""
    raise BankSpecError(
        f"spec={str(path_or_name)!r} is not a file nor an example spec{hint}; examples: "
        f"{', '.join(known) or 'none'}"
    )


def load(path) -> BankSpec:
    """Read and check the spec file ``path`` (TOML), or the installed example of that
    name (:func:`available`)."""
    p = find(path)
    try:
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise BankSpecError(f"{p}: not valid TOML: {exc}") from None
    except OSError as exc:
        raise BankSpecError(f"spec={str(p)!r} cannot be read: {exc.strerror}") from None
    return from_dict(data, base_dir=p.parent, source=str(p))


def from_dict(data: dict, *, base_dir=".", source: str = "<spec>") -> BankSpec:
    """Check a spec given as a dict (``base_dir``: where a relative preset file is)."""
    try:
        return _from_dict(data, Path(base_dir))
    except BankSpecError as exc:
        raise BankSpecError(f"{source}: {exc}") from None


def _from_dict(data: dict, base_dir: Path) -> BankSpec:
    for key, value in data.items():
        if key not in TOP_LEVEL:
            near = difflib.get_close_matches(key, TOP_LEVEL, n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise _error(key, value, f"is not a known key{hint}; allowed: {', '.join(TOP_LEVEL)}")
    if "preset" not in data:
        raise BankSpecError("preset is required: a preset name or a .toml file")
    preset_path, preset_name = _preset(data["preset"], base_dir)
    count = data.get("count")
    if count is not None and (isinstance(count, bool) or not isinstance(count, int) or count < 1):
        raise _error("count", count, "must be an integer >= 1 (or left out for the full grid)")
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise _error("seed", seed, "must be an integer >= 0")
    fmt = data.get("format", "flac")
    if fmt not in FORMATS:
        raise _error("format", fmt, f"must be one of {', '.join(map(repr, FORMATS))}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise _error("description", description, "must be a string")
    vary = data.get("vary", {})
    if not isinstance(vary, dict):
        raise _error("vary", vary, "must be a table of axes")
    base_raw = presets.read(preset_path)
    sampling = data.get("sampling", "random")
    if sampling not in SAMPLINGS:
        raise _error("sampling", sampling, f"must be one of {', '.join(map(repr, SAMPLINGS))}")
    axes = tuple(_axis(key, value, base_raw) for key, value in vary.items())
    if sampling == "grid":
        if count is not None:
            raise _error("count", count, "must be left out with sampling = 'grid'")
        axes = tuple(_grid_axis(a) for a in axes)
    elif any(isinstance(a, RangeAxis) and a.steps is not None for a in axes):
        raise BankSpecError("vary: 'steps' of a range needs sampling = 'grid'")
    render_section = data.get("render", {})
    if not isinstance(render_section, dict):
        raise _error("render", render_section, "must be a table of render options")
    base = dict(base_raw)
    base["render"] = {
        **RENDER_DEFAULTS,
        **base_raw.get("render", {}),
        **render_section,
    }
    try:
        _, options = presets.scene_from_dict(base, str(preset_path))
    except ParameterError as exc:
        raise BankSpecError(str(exc)) from None
    subtype = options.pop("subtype", FORMATS[fmt][2]).upper()
    _check_subtype(fmt, subtype)
    name = data.get("name", "{preset}-{index:05d}" if axes else "{preset}")
    if not isinstance(name, str) or not name:
        raise _error(
            "name", name, "must be a non-empty format string such as '{preset}-{index:04d}'"
        )
    spec = BankSpec(
        preset=str(preset_path),
        preset_name=preset_name,
        base=base,
        description=description,
        count=count,
        seed=seed,
        name=name,
        format=fmt,
        subtype=subtype,
        render=options,
        axes=axes,
        trim=_trim(data.get("trim")),
        sampling=sampling,
        labels=_labels(data.get("labels", {}), axes),
        min_distance=_min_distance(data.get("min_distance"), count, sampling, axes),
        tags=_tags(data.get("tags")),
    )
    _check_template(spec)
    return spec


def _trim(value) -> dict | None:
    """The checked ``[trim]`` table (see :data:`TRIM_DEFAULTS`), or None."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise _error("trim", value, "must be a table: { below_db = -60, fade = 0.01 }")
    for k in value:
        if k not in TRIM_DEFAULTS:
            raise _error(
                f"trim.{k}", value[k], f"is not a key; allowed: {', '.join(TRIM_DEFAULTS)}"
            )
    out = dict(TRIM_DEFAULTS, **value)

    def number(key):
        v = out[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise _error(f"trim.{key}", v, "must be a finite number")
        return float(v)

    out["below_db"] = number("below_db")
    if not out["below_db"] < 0.0:
        raise _error("trim.below_db", out["below_db"], "must be < 0 (dB below the peak)")
    out["fade"] = number("fade")
    if not 0.0 <= out["fade"] <= 1.0:
        raise _error("trim.fade", out["fade"], "must be in [0, 1] (s)")
    if out["max_length"] is not None:
        out["max_length"] = number("max_length")
        if not out["max_length"] > out["fade"]:
            raise _error("trim.max_length", out["max_length"], "must be > trim.fade (s)")
    return out


def _tag_value(where: str, value) -> None:
    if isinstance(value, str) and value:
        return
    if isinstance(value, bool) or (isinstance(value, (int, float)) and math.isfinite(value)):
        return
    raise _error(where, value, "must be a non-empty text, a finite number or a boolean")


def _tags(value) -> list | dict | None:
    """The checked ``tags``: a list of keywords (non-empty texts) or a table of
    name = text, number or boolean; None if left out."""
    if value is None:
        return None
    if isinstance(value, list) and all(isinstance(v, str) and v for v in value):
        return list(value)
    if isinstance(value, dict):
        for name, v in value.items():
            _tag_value(f"tags.{name}", v)
        return dict(value)
    raise _error(
        "tags",
        value,
        'must be a list of keywords (["impact", "glass"]) or a table of name = text, '
        'number or boolean ({ category = "impact" })',
    )


def _preset(value, base_dir: Path) -> tuple[Path, str]:
    if not isinstance(value, str) or not value:
        raise _error("preset", value, "must be a preset name or a .toml file")
    candidate = base_dir / value
    try:
        path = presets.find(candidate if value.endswith(".toml") and candidate.is_file() else value)
    except ParameterError as exc:
        raise BankSpecError(str(exc)) from None
    return path, path.stem


def _check_subtype(fmt: str, subtype: str) -> None:
    import soundfile

    if not soundfile.check_format(FORMATS[fmt][1], subtype):
        raise _error(
            "render.subtype",
            subtype,
            f"is not a subtype of format={fmt!r}; allowed: "
            f"{', '.join(soundfile.available_subtypes(FORMATS[fmt][1]))}",
        )


def _allowed_keys() -> list[str]:
    from synth.sound.render import OPTIONS

    keys = [RESTITUTION_SCALE] + list(presets.TOP_LEVEL)
    for section, fields in presets.SECTIONS.items():
        for f in OPTIONS + ("subtype",) if fields is None else fields:
            keys.append(f"{section}.{f}")
    return [k for k in keys if k != "description"]


def _axis(key: str, value, base_raw: dict):
    where = f"vary.{key}"
    allowed = _allowed_keys()
    if key not in allowed:
        near = difflib.get_close_matches(key, allowed, n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise BankSpecError(
            f"{where}: {key!r} is not a preset key{hint}; keys are "
            f"'section.key' as in synth render --set (e.g. drop.height), or "
            f"{RESTITUTION_SCALE}"
        )
    if isinstance(value, list):
        if not value:
            raise _error(where, value, "is an empty list: give at least one value")
        return ListAxis(key, tuple(value))
    if isinstance(value, dict):
        return _range_axis(where, key, value)
    raise _error(
        where,
        value,
        "must be a list of values (a grid axis) or a range { min = ..., max = ..., log = false }",
    )


def _range_axis(where: str, key: str, value: dict) -> RangeAxis:
    for k, v in value.items():
        if k not in ("min", "max", "log", "steps"):
            raise _error(f"{where}.{k}", v, "is not a range key; allowed: min, max, log, steps")
    steps = value.get("steps")
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int) or steps < 2):
        raise _error(f"{where}.steps", steps, "must be an integer >= 2 (values of the grid)")
    if "min" not in value or "max" not in value:
        raise _error(where, value, "needs both min and max")
    log = value.get("log", False)
    if not isinstance(log, bool):
        raise _error(f"{where}.log", log, "must be true or false")
    lo, hi = _bound(f"{where}.min", value["min"]), _bound(f"{where}.max", value["max"])
    if isinstance(lo, tuple) != isinstance(hi, tuple) or (
        isinstance(lo, tuple) and len(lo) != len(hi)
    ):
        raise _error(
            where, value, "needs min and max of one shape (two numbers, or two lists of one length)"
        )
    for a, b in zip(np.atleast_1d(lo), np.atleast_1d(hi)):
        if a > b:
            raise _error(where, value, f"has min > max ({a!r} > {b!r})")
        if log and a <= 0.0:
            raise _error(where, value, "with log = true needs min > 0")
    return RangeAxis(key, lo, hi, log, steps)


def _bound(where: str, v):
    def number(x):
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            raise _error(where, v, "must be a finite number or a list of them")
        return float(x)

    if isinstance(v, list):
        if not v:
            raise _error(where, v, "is an empty list")
        return tuple(number(x) for x in v)
    return number(v)


# ----------------------------------------------------------------------------- the plan


def _grid_axis(axis):
    """With ``sampling = "grid"``: a range as the list of its ``steps`` values (both
    ends included, evenly or, with log, geometrically spaced, per component)."""
    if isinstance(axis, ListAxis):
        return axis
    if axis.steps is None:
        raise _error(f"vary.{axis.key}.steps", None, "is needed by sampling = 'grid'")
    n = np.atleast_1d(np.asarray(axis.low, dtype=float)).size
    fractions = np.linspace(0.0, 1.0, axis.steps)
    return ListAxis(axis.key, tuple(axis.position(np.full(n, f)) for f in fractions))


def _lhs_fraction(spec: BankSpec, number: int, size: int, index: int, rng) -> np.ndarray:
    """Row ``index``'s fractions (one per component) of range axis ``number`` with
    ``sampling = "lhs"``: in each block of :data:`LHS_BLOCK` rows, each component's
    strata ``[j, j + 1) / LHS_BLOCK`` are dealt to the rows by a permutation drawn from
    ``default_rng([seed, number, block, 2])`` (one per component), and the row's point in
    its stratum by ``rng``; a row depends on its index alone."""
    block, position = divmod(index, LHS_BLOCK)
    perms = np.random.default_rng([spec.seed, number, block, 2])
    strata = np.array([perms.permutation(LHS_BLOCK)[position] for _ in range(size)])
    return (strata + rng.random(size)) / LHS_BLOCK


class _ListDraws:
    """The values of the list axes of the rows with ``count``, drawn without replacement
    over their combinations: the product of the lists, ``total`` combinations numbered
    as in the grid (the first list axis varying slowest).

    With ``total`` <= :data:`PERMUTED_COMBINATIONS`, rows ``k total .. k total + total - 1``
    (block ``k``) take the combinations in the order of a permutation drawn from
    ``default_rng([seed, a, b, ..., k, 1])`` (``a, b, ...``: the list axes' positions in
    ``[vary]``), so every combination comes once per block and a row depends on its index
    alone; with one list axis these are plan 2's draws. With more combinations than that
    (a count, at most :data:`MAX_ROWS`, never fills a block), row ``i`` draws a combination
    from ``default_rng([seed, a, b, ..., i, 3])`` (each axis uniformly) until it finds
    one no earlier row has: it depends on its index and the rows before it. Either way a
    larger count keeps the first rows."""

    def __init__(self, spec: BankSpec):
        self.axes = [a for a in spec.axes if isinstance(a, ListAxis)]
        self.entropy = [spec.seed] + [
            n for n, a in enumerate(spec.axes) if isinstance(a, ListAxis)
        ]  # the generators' seed: the spec's seed and the list axes' positions
        self.total = math.prod(len(a.values) for a in self.axes)
        self._block, self._order = None, None
        self._drawn: list[int] = []  # beyond PERMUTED_COMBINATIONS: each row's combination
        self._taken: set[int] = set()

    def values(self, index: int) -> dict:
        """Row ``index``'s values of the list axes (varied key: value)."""
        if not self.axes:
            return {}
        c = self._combination(index)
        out = {}
        for axis in reversed(self.axes):
            c, k = divmod(c, len(axis.values))
            out[axis.key] = axis.values[k]
        return out

    def _combination(self, index: int) -> int:
        if self.total <= PERMUTED_COMBINATIONS:
            block, position = divmod(index, self.total)
            if block != self._block:
                rng = np.random.default_rng(self.entropy + [block, 1])
                self._block, self._order = block, rng.permutation(self.total)
            return int(self._order[position])
        while len(self._drawn) <= index:
            c = self._unused(len(self._drawn))
            self._drawn.append(c)
            self._taken.add(c)
        return self._drawn[index]

    def _unused(self, index: int) -> int:
        """A combination no row before ``index`` has, drawn from row ``index``'s generator
        (each draw is new with probability 1 - ``index`` / ``total`` > 0)."""
        rng = np.random.default_rng(self.entropy + [index, 3])
        while True:
            c = 0
            for axis in self.axes:
                c = c * len(axis.values) + int(rng.integers(len(axis.values)))
            if c not in self._taken:
                return c


def _min_distance(value, count, sampling, axes) -> float | None:
    """The checked ``min_distance``: the least distance between two rows' range values,
    each component scaled to [0, 1] over its range (log ranges in log), with ``count``
    and random sampling."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise _error("min_distance", value, "must be a number > 0 (in the unit cube of the ranges)")
    if count is None or sampling != "random":
        raise _error("min_distance", value, "needs count and sampling = 'random'")
    if count > MIN_DISTANCE_MAX_ROWS:
        raise _error("count", count, f"must be <= {MIN_DISTANCE_MAX_ROWS} with min_distance")
    if not any(isinstance(a, RangeAxis) for a in axes):
        raise _error("min_distance", value, "needs a range axis in [vary]")
    return float(value)


def _unit_point(spec: BankSpec, values: dict) -> np.ndarray:
    """A row's range values as a point of the unit cube (log ranges in log)."""
    out = []
    for axis in spec.axes:
        if not isinstance(axis, RangeAxis):
            continue
        v = np.atleast_1d(np.asarray(values[axis.key], dtype=float))
        lo = np.atleast_1d(np.asarray(axis.low, dtype=float))
        hi = np.atleast_1d(np.asarray(axis.high, dtype=float))
        if axis.log:
            v, lo, hi = np.log(v), np.log(lo), np.log(hi)
        span = np.where(hi > lo, hi - lo, 1.0)
        out.extend((v - lo) / span)
    return np.array(out)


def _spaced_variations(spec: BankSpec):
    """Rows with ``min_distance``: row ``i`` draws its ranges from ``default_rng([seed,
    i])`` until its point is at least ``min_distance`` from every earlier row's (so it
    depends on its index and the rows before it, not on the count); its lists are
    drawn as without it (:class:`_ListDraws`)."""
    points = []
    lists = _ListDraws(spec)
    for i in range(spec.count):
        rng = np.random.default_rng([spec.seed, i])
        for _ in range(MIN_DISTANCE_ATTEMPTS):
            values = _draw(spec, i, lists.values(i), rng)
            p = _unit_point(spec, values)
            if not points or np.min(np.linalg.norm(np.array(points) - p, axis=1)) >= (
                spec.min_distance
            ):
                break
        else:
            raise _error(
                "min_distance",
                spec.min_distance,
                f"leaves no room for row {i} after {MIN_DISTANCE_ATTEMPTS} draws: lower it "
                f"or the count",
            )
        points.append(p)
        yield values


def _draw(spec: BankSpec, index: int, lists: dict, rng=None) -> dict:
    """Row ``index``'s values: its list axes' ``lists`` (a grid point, or drawn by
    :class:`_ListDraws`) and its ranges drawn with ``rng`` (default
    ``default_rng([seed, index])``), in the spec's order of the axes."""
    rng = np.random.default_rng([spec.seed, index]) if rng is None else rng
    values = {}
    for number, axis in enumerate(spec.axes):
        if isinstance(axis, ListAxis):
            values[axis.key] = lists[axis.key]
        elif spec.sampling == "lhs":
            size = np.atleast_1d(np.asarray(axis.low)).size
            values[axis.key] = axis.position(_lhs_fraction(spec, number, size, index, rng))
        else:
            values[axis.key] = axis.draw(rng)
    return values


def _combinations(spec: BankSpec) -> int:
    """How many distinct combinations the list axes have (1 without lists)."""
    return math.prod(len(a.values) for a in spec.axes if isinstance(a, ListAxis))


def _rows(spec: BankSpec) -> int:
    return spec.count if spec.count is not None else _combinations(spec)


class RepeatedRowsWarning(UserWarning):
    """A ``count`` above the number of distinct rows a spec can make: rows repeat."""


def _warn_repeated_rows(spec: BankSpec) -> None:
    """Warn when ``count`` asks for more rows than the spec has distinct ones: without a
    range axis a row is one of the list axes' combinations, so rows beyond them repeat
    earlier ones (each combination once in every block of them, a randomised block
    design; identical sounds under other names). Not refused: repeated stimuli are a
    valid design, a container of game sounds wants the count lowered."""
    distinct = _combinations(spec)
    if spec.count is None or spec.count <= distinct:
        return
    if any(isinstance(a, RangeAxis) for a in spec.axes):
        return
    lists = " x ".join(f"{a.key} ({len(a.values)})" for a in spec.axes) or "no axis"
    warnings.warn(
        f"count={spec.count} is more than the {distinct} distinct rows of the list axes "
        f"({lists}) with no range axis: rows repeat, each combination once in every "
        f"{distinct} rows; lower count to {distinct} for distinct sounds",
        RepeatedRowsWarning,
        stacklevel=3,
    )


def variations(spec: BankSpec):
    """The varied values of every row, in index order (a generator of dicts)."""
    if spec.count is not None and spec.min_distance is not None:
        yield from _spaced_variations(spec)
        return
    if spec.count is not None:
        lists = _ListDraws(spec)
        for i in range(spec.count):
            yield _draw(spec, i, lists.values(i))
        return
    lists = [a for a in spec.axes if isinstance(a, ListAxis)]
    for i, combo in enumerate(itertools.product(*(a.values for a in lists))):
        yield _draw(spec, i, {a.key: v for a, v in zip(lists, combo)})


class _Labelled:
    """A row's value in the name template: formatted as the value itself, or with the
    format spec ``label`` as its label from the spec's ``[labels]`` table."""

    def __init__(self, key: str, value, table: dict | None):
        self.key, self.value, self.table = key, value, table

    def __getitem__(self, i):
        return self.value[i]

    def __format__(self, fmt: str) -> str:
        if fmt != "label":
            return format(self.value, fmt)
        label = _label_of(self.table or {}, self.value)
        if label is None:
            raise ValueError(
                f"labels.{self.key} has no label for {self.value!r} "
                f"(labels: {', '.join(self.table or {}) or 'none'})"
            )
        return label


def _label_of(table: dict, value):
    """The label of ``value`` in a ``[labels]`` table keyed by the values as text."""
    for text, label in table.items():
        if text == str(value):
            return label
        try:
            if float(text) == float(value):
                return label
        except (TypeError, ValueError):
            continue
    return None


def row_labels(spec: BankSpec, values: dict) -> dict | None:
    """The labels of a row's values (varied key: label) from the spec's ``[labels]``,
    for the keys whose table labels the row's value; None if the spec has none."""
    if not spec.labels:
        return None
    out = {}
    for key, table in spec.labels.items():
        label = _label_of(table, values.get(key))
        if label is not None:
            out[key] = label
    return out


def _labels(value, axes) -> dict:
    """The checked ``[labels]`` table: for a varied key, a table of its values (as text)
    and their labels (``{ "0.004" = "small" }``), used by ``{key:label}`` in ``name``."""
    if not isinstance(value, dict):
        raise _error("labels", value, "must be a table of varied keys")
    keys = {a.key for a in axes}
    for key, table in value.items():
        if key not in keys:
            raise _error(f"labels.{key}", table, f"is not a varied key; varied: {sorted(keys)}")
        if not isinstance(table, dict) or not all(isinstance(v, str) and v for v in table.values()):
            raise _error(f"labels.{key}", table, 'must be a table of value = "label"')
    return {k: dict(v) for k, v in value.items()}


def _mapping(spec: BankSpec, index: int, values: dict) -> dict:
    m = {"preset": spec.preset_name, "index": index}
    sections: dict = {}
    for key, v in values.items():
        v = _Labelled(key, v, spec.labels.get(key))
        m[key.replace(".", "_")] = v
        if "." in key:
            section, field = key.split(".", 1)
            sections.setdefault(section, {})[field] = v
    for section, fields in sections.items():
        m[section] = SimpleNamespace(**fields)
    return m


def file_name(spec: BankSpec, index: int, values: dict) -> str:
    """The file of row ``index`` (relative to the bank's folder), from the template."""
    try:
        stem = spec.name.format_map(_mapping(spec, index, values))
    except (KeyError, AttributeError, IndexError, ValueError, TypeError) as exc:
        raise _error(
            "name",
            spec.name,
            f"cannot be filled ({type(exc).__name__}: {exc}); "
            f"fields: preset, index, {', '.join(_field_names(spec))}",
        ) from None
    parts = stem.split("/")
    if "\\" in stem or "\0" in stem or any(not part or part.startswith(".") for part in parts):
        raise _error(
            "name",
            spec.name,
            f"makes the file name {stem!r}: a name's folders and file must not be empty or "
            f"start with '.' (no '..', no absolute path), and '/' is the only separator",
        )
    name = f"{stem}.{spec.suffix}"
    longest = max((p for p in name.split("/")), key=lambda p: len(p.encode("utf-8")))
    if len(longest.encode("utf-8")) > MAX_NAME_BYTES:
        raise _error(
            "name",
            spec.name,
            f"makes the name {longest!r} of {len(longest.encode('utf-8'))} bytes for row "
            f"{index}: a file or folder name may have at most {MAX_NAME_BYTES} bytes",
        )
    return name


def _field_names(spec: BankSpec) -> list[str]:
    out = []
    for k in spec.keys:
        out.append(k.replace(".", "_"))
        if "." in k:
            out.append(k)
    return out


def _check_template(spec: BankSpec) -> None:
    allowed_roots = (
        {"preset", "index"}
        | {k.replace(".", "_") for k in spec.keys}
        | {k.split(".", 1)[0] for k in spec.keys if "." in k}
    )
    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(spec.name) if f is not None]
    except ValueError as exc:
        raise _error("name", spec.name, f"is not a format string: {exc}") from None
    for f in fields:
        root = f.split(".", 1)[0].split("[", 1)[0]
        if root not in allowed_roots:
            raise _error(
                "name",
                spec.name,
                f"names {{{f}}}, which is not an axis; fields: preset, index, "
                f"{', '.join(_field_names(spec)) or '(no axes)'}",
            )
        if (
            root not in ("preset", "index")
            and f.startswith(root + ".")
            and f.split("[", 1)[0] not in spec.keys
        ):
            raise _error(
                "name",
                spec.name,
                f"names {{{f}}}, which is not an axis; axes: {', '.join(spec.keys)}",
            )


def plan(spec: BankSpec, *, check_scenes: bool = True) -> tuple[PlanItem, ...]:
    """Every row of the bank, checked: the file names are distinct and short enough,
    and (``check_scenes``) every row's scene and render options are valid
    (:func:`check_rows`), so that a bank either starts clean or is refused; a plan whose
    rows repeat (:func:`_warn_repeated_rows`) is warned of."""
    n = _rows(spec)
    if n > MAX_ROWS:
        raise _error(
            "count" if spec.count is not None else "vary",
            n if spec.count is not None else f"a grid of {n} rows",
            f"is more than the {MAX_ROWS} rows a bank may have: split it into several "
            f"banks (seeds or folders)",
        )
    items, seen = [], {}
    for index, values in enumerate(variations(spec)):
        f = file_name(spec, index, values)
        if f in seen:
            raise _error(
                "name",
                spec.name,
                f"makes two files the same name {f!r} (rows "
                f"{seen[f]} and {index}): use {{index}} or more axes in it",
            )
        seen[f] = index
        items.append(PlanItem(index, f, values))
    if check_scenes:
        check_rows(spec, items)
    _warn_repeated_rows(spec)
    return tuple(items)


#: Rows named in the message of a plan refused for its rows' values.
ROWS_NAMED = 5


def row_problem(spec: BankSpec, item: PlanItem, budget: cost.Budget | None = None) -> str | None:
    """Why row ``item``'s scene cannot be rendered (None if it can): its preset dict and
    render options are built and checked as a render checks them, and its render's cost
    estimate (:func:`synth.cost.estimate_render`: modes, longest contact, pulse grid, mode
    solver, radiation, memory) held to ``budget`` (default: the environment's) as the
    render will hold it, without solving anything but the first contact by the impedance
    model (milliseconds; no modes)."""
    k = item.values.get(RESTITUTION_SCALE)
    if k is not None and (
        isinstance(k, bool) or not isinstance(k, (int, float)) or not math.isfinite(k) or k < 0
    ):
        return f"{RESTITUTION_SCALE}={k!r} must be a finite number >= 0 (dimensionless)"
    budget = cost.Budget.from_environment() if budget is None else budget
    try:
        scene, options = presets.scene_from_dict(scene_data(spec, item.values), f"row {item.index}")
        cost.estimate_render(scene, options, budget).check(budget)
    except ParameterError as exc:
        return str(exc).removeprefix(f"row {item.index}: ")
    except (TypeError, ValueError) as exc:  # a value of the wrong type deep in a section
        return f"{type(exc).__name__}: {exc}"
    return None


def check_rows(spec: BankSpec, items) -> None:
    """Refuse the plan if a row's scene cannot be rendered (:func:`row_problem`), naming
    the rows, their varied values and what is wrong."""
    bad = []
    budget = cost.Budget.from_environment()
    for item in items:
        problem = row_problem(spec, item, budget)
        if problem is not None:
            bad.append((item, problem))
    if not bad:
        return
    lines = [
        f"row {item.index} ({', '.join(f'{k}={v!r}' for k, v in item.values.items())}): {why}"
        for item, why in bad[:ROWS_NAMED]
    ]
    more = f"\n  ... and {len(bad) - ROWS_NAMED} more rows" if len(bad) > ROWS_NAMED else ""
    raise BankSpecError(
        f"vary: {len(bad)} of {len(items)} rows cannot be rendered:\n  " + "\n  ".join(lines) + more
    )


def scene_data(spec: BankSpec, values: dict) -> dict:
    """The preset dict of a row: the base with the row's values set under their dotted
    keys, as ``synth render --set`` sets them (the restitution scale is not a preset key
    and is left out)."""
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in spec.base.items()}
    for key, value in values.items():
        if key != RESTITUTION_SCALE:
            presets.set_key(data, key, value, f"vary.{key}")
    return data


def differences(old: dict, new: dict, prefix: str = "") -> list[str]:
    """The dotted keys whose values differ between two spec dicts (:func:`canonical`)."""
    out = []
    for k in sorted(set(old) | set(new), key=str):
        a, b = old.get(k, dataclasses.MISSING), new.get(k, dataclasses.MISSING)
        key = f"{prefix}{k}"
        if isinstance(a, dict) and isinstance(b, dict):
            out.extend(differences(a, b, key + "."))
        elif a != b:
            out.append(key)
    return out


def parse_rows(text, planned: int) -> frozenset[int]:
    """The row indices of ``text`` (``"17,40-45"``: indices and inclusive ranges, as
    ``--redo`` takes them), each in ``0 .. planned - 1``."""
    if isinstance(text, (set, frozenset, list, tuple)):
        parts = [str(v) for v in text]
    elif isinstance(text, str):
        parts = [p.strip() for p in text.split(",")]
    else:
        raise _error("redo", text, "must be row indices such as '17,40-45'")
    rows = set()
    for part in parts:
        lo, sep, hi = part.partition("-")
        try:
            first = int(lo)
            last = int(hi) if sep else first
        except ValueError:
            raise _error("redo", text, f"has {part!r}, not an index or a range a-b") from None
        if first < 0 or last < first or last >= planned:
            raise _error(
                "redo", text, f"has {part!r}: rows are 0 to {planned - 1}, ranges ascending"
            )
        rows.update(range(first, last + 1))
    return frozenset(rows)
