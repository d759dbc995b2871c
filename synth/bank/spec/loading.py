"""Reading a spec (an installed example, a TOML file or a dict) checked key by key into a
:class:`~synth.bank.spec.model.BankSpec`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from synth import checks
from synth.bank.spec.model import (
    FORMATS,
    RENDER_DEFAULTS,
    RESTITUTION_SCALE,
    TOP_LEVEL,
    TRIM_DEFAULTS,
    BankSpec,
    BankSpecError,
    ListAxis,
    RangeAxis,
    spec_error,
    spec_integer,
    spec_number,
)
from synth.bank.spec.naming import check_template
from synth.bank.spec.sampling import MIN_DISTANCE_MAX_ROWS, SAMPLINGS, grid_axis
from synth.errors import ParameterError
from synth.io import presets

#: Where the example specs installed with the package are (usable by name).
PACKAGE_BANKS = Path(__file__).resolve().parents[2] / "presets" / "banks"


def available() -> dict[str, Path]:
    """The example specs installed with the package, by name (the file's stem)."""
    return {p.stem: p for p in sorted(PACKAGE_BANKS.glob("*.toml"))}


def find(path_or_name) -> Path:
    """The spec file ``path_or_name``: a file, or the name of an installed example."""
    return presets.find_file(path_or_name, available(), "spec", BankSpecError)


def load(path) -> BankSpec:
    """Read and check the spec file ``path`` (TOML) or the installed example of that name."""
    p = find(path)
    return from_dict(presets.read(p, BankSpecError), base_dir=p.parent, source=str(p))


def from_dict(data: dict, *, base_dir=".", source: str = "<spec>") -> BankSpec:
    """Check a spec given as a dict (``base_dir``: where a relative preset file is)."""
    try:
        return _from_dict(data, Path(base_dir))
    except BankSpecError as exc:
        raise BankSpecError(f"{source}: {exc}") from None


def _from_dict(data: dict, base_dir: Path) -> BankSpec:
    import soundfile

    for key, value in data.items():
        if key not in TOP_LEVEL:
            hint = checks.did_you_mean(key, TOP_LEVEL)
            raise spec_error(
                key, value, f"is not a known key{hint}; allowed: {', '.join(TOP_LEVEL)}"
            )
    if "preset" not in data:
        raise BankSpecError("preset is required: a preset name or a .toml file")
    preset_path, preset_name = _preset(data["preset"], base_dir)
    count = data.get("count")
    if count is not None:
        spec_integer("count", count, 1, "must be an integer >= 1 (or left out for the full grid)")
    seed = spec_integer("seed", data.get("seed", 0), 0, "must be an integer >= 0")
    fmt = data.get("format", "flac")
    if fmt not in FORMATS:
        raise spec_error("format", fmt, f"must be one of {', '.join(map(repr, FORMATS))}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise spec_error("description", description, "must be a string")
    base_raw = presets.read(preset_path)
    sampling = data.get("sampling", "random")
    axes = _axes(data.get("vary", {}), sampling, count, base_raw)
    base, options = _base(base_raw, data.get("render", {}), preset_path)
    subtype = options.pop("subtype", FORMATS[fmt][2]).upper()
    if not soundfile.check_format(FORMATS[fmt][1], subtype):
        allowed = ", ".join(soundfile.available_subtypes(FORMATS[fmt][1]))
        raise spec_error(
            "render.subtype", subtype, f"is not a subtype of format={fmt!r}; allowed: {allowed}"
        )
    name = data.get("name", "{preset}-{index:05d}" if axes else "{preset}")
    if not isinstance(name, str) or not name:
        raise spec_error(
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
    check_template(spec)
    return spec


def _axes(vary, sampling, count, base_raw: dict) -> tuple:
    """The checked axes of ``[vary]`` (grids with ``sampling = "grid"``)."""
    if not isinstance(vary, dict):
        raise spec_error("vary", vary, "must be a table of axes")
    if sampling not in SAMPLINGS:
        raise spec_error("sampling", sampling, f"must be one of {', '.join(map(repr, SAMPLINGS))}")
    axes = tuple(_axis(key, value, base_raw) for key, value in vary.items())
    if sampling == "grid":
        if count is not None:
            raise spec_error("count", count, "must be left out with sampling = 'grid'")
        return tuple(grid_axis(a) for a in axes)
    if any(isinstance(a, RangeAxis) and a.steps is not None for a in axes):
        raise BankSpecError("vary: 'steps' of a range needs sampling = 'grid'")
    return axes


def _base(base_raw: dict, render_section, preset_path) -> tuple[dict, dict]:
    """The preset dict with the spec's ``[render]`` over the preset's over the bank's
    defaults, and its checked render options."""
    if not isinstance(render_section, dict):
        raise spec_error("render", render_section, "must be a table of render options")
    base = dict(base_raw, render=RENDER_DEFAULTS | base_raw.get("render", {}) | render_section)
    try:
        _, options = presets.scene_from_dict(base, str(preset_path))
    except ParameterError as exc:
        raise BankSpecError(str(exc)) from None
    return base, options


def _trim(value) -> dict | None:
    """The checked ``[trim]`` table (see :data:`TRIM_DEFAULTS`), or None."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise spec_error("trim", value, "must be a table: { below_db = -60, fade = 0.01 }")
    for k in value:
        if k not in TRIM_DEFAULTS:
            raise spec_error(
                f"trim.{k}", value[k], f"is not a key; allowed: {', '.join(TRIM_DEFAULTS)}"
            )
    out = dict(TRIM_DEFAULTS, **value)
    for key in ("below_db", "fade", "max_length"):
        if out[key] is not None or key != "max_length":
            out[key] = spec_number(f"trim.{key}", out[key])
    if not out["below_db"] < 0.0:
        raise spec_error("trim.below_db", out["below_db"], "must be < 0 (dB below the peak)")
    if not 0.0 <= out["fade"] <= 1.0:
        raise spec_error("trim.fade", out["fade"], "must be in [0, 1] (s)")
    if out["max_length"] is not None and not out["max_length"] > out["fade"]:
        raise spec_error("trim.max_length", out["max_length"], "must be > trim.fade (s)")
    return out


def _tags(value) -> list | dict | None:
    """The checked ``tags``: a list of keywords or a table of name = text, number or bool."""
    if value is None:
        return None
    if isinstance(value, list) and all(isinstance(v, str) and v for v in value):
        return list(value)
    if isinstance(value, dict):
        for name, v in value.items():
            number = isinstance(v, (int, float)) and math.isfinite(v)
            if not ((isinstance(v, str) and v) or isinstance(v, bool) or number):
                raise spec_error(
                    f"tags.{name}", v, "must be a non-empty text, a finite number or a boolean"
                )
        return dict(value)
    raise spec_error(
        "tags",
        value,
        'must be a list of keywords (["impact", "glass"]) or a table of name = text, '
        'number or boolean ({ category = "impact" })',
    )


def _preset(value, base_dir: Path) -> tuple[Path, str]:
    if not isinstance(value, str) or not value:
        raise spec_error("preset", value, "must be a preset name or a .toml file")
    candidate = base_dir / value
    try:
        path = presets.find(candidate if value.endswith(".toml") and candidate.is_file() else value)
    except ParameterError as exc:
        raise BankSpecError(str(exc)) from None
    return path, path.stem


def _allowed_keys() -> list[str]:
    from synth.sound.options import OPTIONS

    keys = [RESTITUTION_SCALE] + [k for k in presets.TOP_LEVEL if k != "description"]
    for section, fields in presets.SECTIONS.items():
        keys += [f"{section}.{f}" for f in (OPTIONS + ("subtype",) if fields is None else fields)]
    return keys


def _axis(key: str, value, base_raw: dict):
    where = f"vary.{key}"
    allowed = _allowed_keys()
    if key not in allowed:
        raise BankSpecError(
            f"{where}: {key!r} is not a preset key{checks.did_you_mean(key, allowed)}; keys are "
            f"'section.key' as in synth render --set (e.g. drop.height), or "
            f"{RESTITUTION_SCALE}"
        )
    if isinstance(value, list):
        if not value:
            raise spec_error(where, value, "is an empty list: give at least one value")
        return ListAxis(key, tuple(value))
    if isinstance(value, dict):
        return _range_axis(where, key, value)
    raise spec_error(
        where,
        value,
        "must be a list of values (a grid axis) or a range { min = ..., max = ..., log = false }",
    )


def _range_axis(where: str, key: str, value: dict) -> RangeAxis:
    for k, v in value.items():
        if k not in ("min", "max", "log", "steps"):
            raise spec_error(f"{where}.{k}", v, "is not a range key; allowed: min, max, log, steps")
    steps = value.get("steps")
    if steps is not None:
        spec_integer(f"{where}.steps", steps, 2, "must be an integer >= 2 (values of the grid)")
    if "min" not in value or "max" not in value:
        raise spec_error(where, value, "needs both min and max")
    log = value.get("log", False)
    if not isinstance(log, bool):
        raise spec_error(f"{where}.log", log, "must be true or false")
    lo, hi = _bound(f"{where}.min", value["min"]), _bound(f"{where}.max", value["max"])
    if np.shape(lo) != np.shape(hi):
        raise spec_error(
            where, value, "needs min and max of one shape (two numbers, or two lists of one length)"
        )
    for a, b in zip(np.atleast_1d(lo), np.atleast_1d(hi)):
        if a > b or (log and a <= 0.0):
            why = f"has min > max ({a!r} > {b!r})" if a > b else "with log = true needs min > 0"
            raise spec_error(where, value, why)
    return RangeAxis(key, lo, hi, log, steps)


def _bound(where: str, v):
    if isinstance(v, list) and not v:
        raise spec_error(where, v, "is an empty list")
    try:
        xs = [spec_number(where, x) for x in (v if isinstance(v, list) else [v])]
    except BankSpecError:
        raise spec_error(where, v, "must be a finite number or a list of them") from None
    return tuple(xs) if isinstance(v, list) else xs[0]


def _min_distance(value, count, sampling, axes) -> float | None:
    """The checked ``min_distance`` between rows' range values in the unit cube."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise spec_error(
            "min_distance", value, "must be a number > 0 (in the unit cube of the ranges)"
        )
    if count is None or sampling != "random":
        raise spec_error("min_distance", value, "needs count and sampling = 'random'")
    if count > MIN_DISTANCE_MAX_ROWS:
        raise spec_error("count", count, f"must be <= {MIN_DISTANCE_MAX_ROWS} with min_distance")
    if not any(isinstance(a, RangeAxis) for a in axes):
        raise spec_error("min_distance", value, "needs a range axis in [vary]")
    return float(value)


def _labels(value, axes) -> dict:
    """The checked ``[labels]``: per varied key, ``{ "0.004" = "small" }``."""
    if not isinstance(value, dict):
        raise spec_error("labels", value, "must be a table of varied keys")
    keys = {a.key for a in axes}
    for key, table in value.items():
        if key not in keys:
            raise spec_error(f"labels.{key}", table, f"is not a varied key; varied: {sorted(keys)}")
        if not isinstance(table, dict) or not all(isinstance(v, str) and v for v in table.values()):
            raise spec_error(f"labels.{key}", table, 'must be a table of value = "label"')
    return {k: dict(v) for k, v in value.items()}
