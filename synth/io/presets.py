"""Presets: scenes described in TOML files (docs/cli.md, "Preset files"). Their keys are the fields
of Ball, Plate, Contact and RenderOptions; a bad key, type or scene is a :class:`PresetError`."""

from __future__ import annotations

import dataclasses
import os
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import materials
from synth.physics.materials import LossFactor, Material, Rayleigh
from synth.physics.scene import (
    CONTACT_MODELS,
    DEFAULT_CONTACT_MODEL,
    DEFAULT_PLATE_THEORY,
    Accelerometer,
    Ball,
    Contact,
    HollowBall,
    Microphone,
    Plate,
    Rolling,
    Scene,
)
from synth.sound.options import PRESET_SAMPLERATE

if TYPE_CHECKING:
    from synth.sound.render import Render


class PresetError(ParameterError):
    """A preset file (or a ``--set`` override) that cannot describe a scene."""


#: The kinds of ball ``ball.kind`` names (a hollow ball's own keys apply to it only), and
#: the keys allowed in each section.
BALL_KINDS = {"solid": Ball, "hollow": HollowBall}
SECTIONS = {
    "ball": checks.names(HollowBall) + ("kind",),
    "plate": checks.names(Plate),
    "drop": ("height", "position", "velocity"),
    "listener": ("type", "position"),
    "contact": checks.names(Contact),
    "rolling": checks.names(Rolling),
    "render": None,  # the fields of synth.sound.options.RenderOptions and "subtype"
}
TOP_LEVEL = ("description", "gravity")
_MATERIAL_KEYS = ("name", "density", "young", "poisson", "damping", "source", "transverse_shear")
#: The value of ``transverse_shear`` that ties it to the material's fitted through-thickness
#: modulus (:func:`synth.physics.materials.with_transverse_shear`).
TIED_SHEAR = "tied"
#: The listener of a ``[listener]`` section that names no ``type``.
DEFAULT_LISTENER = "microphone"
#: The presets installed with the package.
PACKAGE_PRESETS = Path(__file__).resolve().parents[1] / "presets"


def preset_dirs() -> list[Path]:
    """Folders searched for a preset name, in order: ``$SYNTH_PRESETS``, ``./presets``, the
    package's."""
    env = [Path(os.environ["SYNTH_PRESETS"])] if os.environ.get("SYNTH_PRESETS") else []
    dirs = env + [Path.cwd() / "presets", PACKAGE_PRESETS]
    return [d for d in dict.fromkeys(dirs) if d.is_dir()]


def available() -> dict[str, Path]:
    """Preset names and their files (the first folder that has a name wins)."""
    found = {}
    for d in preset_dirs():
        for p in sorted(d.glob("*.toml")):
            found.setdefault(p.stem, p)
    return dict(sorted(found.items()))


def find(name_or_path) -> Path:
    """The file of a preset given as a path or a name."""
    return find_file(name_or_path, available(), "preset", PresetError)


def find_file(name_or_path, known: dict[str, Path], what: str, error=PresetError) -> Path:
    """The TOML file ``name_or_path``: a path (a regular file, or ``*.toml``) or a name of
    ``known``; else ``error`` naming the ``what`` and the nearest names."""
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise error(
            f"{what}={name_or_path!r} must be a {what} name or a file path (str or "
            f"os.PathLike), not {type(name_or_path).__name__}"
        )
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if p.is_file():
            return p
        why = (
            f"is a directory, not a {what} file"
            if p.is_dir()
            else f"is not a regular file (a device or a pipe); give a .toml {what} file"
            if p.exists()
            else "does not exist"
        )
        raise error(f"{what} file {str(p)!r} {why}")
    if str(name_or_path) in known:
        return known[str(name_or_path)]
    hint = checks.did_you_mean(name_or_path, known, n=3, cutoff=0.4)
    raise error(
        f"{what}={str(name_or_path)!r} is not a file or a known {what}{hint}; "
        f"known: {', '.join(known) or 'none'}"
    )


def read(path, error=PresetError) -> dict:
    """The raw TOML of a preset (or other TOML) file, as a dict; ``error`` if unreadable."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not valid TOML: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise error(f"{path}: cannot be read: {exc.strerror}") from None


def apply_overrides(data: dict, overrides, source="--set") -> dict:
    """Apply ``key=value`` overrides (dotted keys, TOML values) to a preset dict."""
    overrides = [] if overrides is None else overrides
    if isinstance(overrides, (str, bytes)) or not isinstance(overrides, (list, tuple)):
        raise PresetError(
            f"overrides={overrides!r} must be a list of 'section.key=value' strings "
            f"(e.g. ['ball.radius=0.007']), not {type(overrides).__name__}"
        )
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    for i, item in enumerate(overrides):
        if not isinstance(item, str):
            raise PresetError(
                f"overrides[{i}]={item!r} must be a 'section.key=value' string, "
                f"not {type(item).__name__}"
            )
        if "=" not in item:
            raise PresetError(f"{source} {item!r}: expected key=value, e.g. ball.radius=0.007")
        key, text = item.split("=", 1)
        if any(c in item for c in "\r\n"):
            raise PresetError(f"{source} {item!r}: one key=value per option (no line breaks)")
        try:
            parsed = tomllib.loads(f"v = {text}")
        except tomllib.TOMLDecodeError:
            parsed = {"v": text.strip()}  # a bare word is a string: material=glass
        if set(parsed) != {"v"}:
            raise PresetError(
                f"{source} {item!r}: the value must be one TOML value, e.g. ball.radius=0.007"
            )
        set_key(data, key.strip(), parsed["v"], source)
    return data


def set_key(data: dict, key: str, value, source="--set") -> None:
    """Set the dotted ``key`` of the preset dict ``data`` to ``value`` (a tuple as a list)
    in place, as ``--set`` and a bank's axes do; the section's table is copied, not shared."""
    value = list(value) if isinstance(value, tuple) else value
    parts = key.split(".")
    if len(parts) == 1:
        data[key] = value
    elif len(parts) == 2:
        section = data.get(parts[0], {})
        if not isinstance(section, dict):
            raise PresetError(f"{source} {key}: {parts[0]!r} is not a section")
        data[parts[0]] = {**section, parts[1]: value}
    else:
        raise PresetError(f"{source} {key}: keys are 'key' or 'section.key'")


def _material(value, where):
    if isinstance(value, str):
        return value
    if not isinstance(value, dict):
        raise PresetError(f"{where}={value!r} must be a material name or an inline table")
    _check_keys(where, value, _MATERIAL_KEYS)
    kw = dict(value)
    kw.setdefault("name", "custom")
    if not isinstance(kw["name"], str) or not kw["name"].strip():
        raise PresetError(
            f"{where}.name={kw['name']!r} must be a non-empty string (a built-in material "
            f"such as 'steel', whose keys the others change, or the inline material's label)"
        )
    shear = kw.pop("transverse_shear", None)
    if isinstance(shear, str) and shear != TIED_SHEAR:
        raise PresetError(
            f"{where}.transverse_shear={shear!r} must be a modulus in Pa (> 0) or "
            f"{TIED_SHEAR!r} (G_t = E_t / (2 (1 + nu)) from the fitted surface)"
        )
    if not {"density", "young", "poisson"} & set(kw) and kw["name"] in materials.names():
        base = materials.get(kw["name"])  # a built-in material with some keys changed
        kw = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)} | kw
        built_in = kw.pop("transverse_shear")
        shear = built_in if shear is None else shear
    damping = _damping(kw.pop("damping", None), where)
    if damping is not None:
        kw["damping"] = damping
    _require(kw, ("density", "young", "poisson"), where)
    try:
        if shear == TIED_SHEAR:
            return materials.with_transverse_shear(Material(**kw))
        return Material(**kw, **({} if shear is None else {"transverse_shear": shear}))
    except ParameterError as exc:
        raise PresetError(f"{where}: {exc}") from None


def _damping(damping, where: str):
    """The damping law of ``damping``: a law as it is, ``{eta}`` a :class:`LossFactor`,
    ``{alpha, beta}`` a :class:`Rayleigh`, or None."""
    if damping is None or isinstance(damping, LossFactor | Rayleigh):
        return damping
    laws = {frozenset({"eta"}): LossFactor, frozenset({"alpha", "beta"}): Rayleigh}
    law = laws.get(frozenset(damping)) if isinstance(damping, dict) else None
    if law is None:
        raise PresetError(
            f"{where}.damping={damping!r} must be {{eta=...}} or {{alpha=..., beta=...}}"
        )
    try:
        return law(**damping)
    except ParameterError as exc:  # "damping.eta=...": the key under this material
        raise PresetError(f"{where}.{exc}") from None


def _require(section: dict, keys, where: str) -> None:
    """Refuse ``section`` without one of ``keys`` (or, given a dataclass, its required
    positional fields)."""
    if isinstance(keys, type):
        keys = [
            f.name
            for f in dataclasses.fields(keys)
            if f.default is f.default_factory is dataclasses.MISSING and not f.kw_only
        ]
    for k in keys:
        if k not in section:
            raise PresetError(f"{where}.{k} is missing (required keys: {', '.join(keys)})")


def scene_from_dict(data: dict, source: str = "<preset>") -> tuple[Scene, dict]:
    """Build a :class:`Scene` and the render options from a preset dict."""
    try:
        return _scene_from_dict(data, source)
    except ParameterError as exc:
        text = str(exc)
        if text.startswith(f"{source}:"):
            raise
        raise PresetError(f"{source}: {text}") from None


def _scene_from_dict(data, source):
    _check_sections(data, source)
    b, p = dict(data["ball"]), dict(data["plate"])
    if "material" not in b or "material" not in p:
        raise PresetError(f"{source}: ball.material and plate.material are required")
    kind = b.pop("kind", "solid")
    if kind not in BALL_KINDS:
        raise PresetError(
            f"{source}: ball.kind={kind!r} must be one of {', '.join(map(repr, BALL_KINDS))}"
        )
    for key in b if kind == "solid" else ():
        if key not in checks.names(Ball):  # a key of HollowBall only
            raise PresetError(f"{source}: ball.{key}={b[key]!r} applies to ball.kind='hollow' only")
    for section, kw, cls in (("ball", b, Ball), ("plate", p, Plate)):
        _require(kw, cls, section)
        kw["material"] = _material(kw["material"], f"{section}.material")
        for k, v in kw.items():
            if k not in ("material", "boundary", "mass") and not isinstance(v, (int, float)):
                raise PresetError(f"{source}: {section}.{k}={v!r} must be a number")
    drop = data["drop"]
    if "height" not in drop:
        raise PresetError(f"{source}: drop.height is required (metres)")
    for key, shape in (("position", "[x, y] in metres"), ("velocity", "[vx, vy] in m/s")):
        if drop.get(key) is not None and not isinstance(drop[key], list):
            raise PresetError(f"{source}: drop.{key}={drop[key]!r} must be {shape}")
    # "shell" is a hollow ball's only contact law
    shell = {"law": "shell"} if kind == "hollow" and "law" not in data.get("contact", {}) else {}
    rolling = None
    if "rolling" in data:
        _require(data["rolling"], Rolling, "rolling")
        rolling = Rolling(**data["rolling"])
    description = data.get("description", "")
    if not isinstance(description, str):
        raise PresetError(f"{source}: description={description!r} must be a string")
    scene = Scene(
        BALL_KINDS[kind](**b),
        Plate(**p),
        drop_height=drop["height"],
        position=_vector(drop.get("position")),
        listener=_listener(data["listener"], source) if "listener" in data else None,
        gravity=data.get("gravity", GRAVITY),
        contact=Contact(**shell, **data["contact"]) if "contact" in data else None,
        velocity=_vector(drop.get("velocity")),
        rolling=rolling,
    )
    return scene, _render_section(data.get("render", {}), source)


def _vector(value):
    return None if value is None else tuple(value)


def _check_keys(where: str, table: dict, allowed) -> None:
    """Refuse a key of ``table`` (at ``where``: file and section) not in ``allowed``."""
    for k in table:
        if k not in allowed:
            raise PresetError(
                f"{where}.{k}={table[k]!r} is not a known key"
                f"{checks.did_you_mean(k, allowed)}; "
                f"allowed: {', '.join(allowed)}"
            )


def _check_sections(data: dict, source: str) -> None:
    """Refuse an unknown section or key, and a missing ``[ball]``, ``[plate]`` or ``[drop]``."""
    for key, value in data.items():
        if key in SECTIONS:
            if not isinstance(value, dict):
                raise PresetError(f"{source}: [{key}] must be a table, got {value!r}")
            if SECTIONS[key] is not None:
                _check_keys(f"{source}: {key}", value, SECTIONS[key])
        elif key not in TOP_LEVEL:
            raise PresetError(
                f"{source}: {key}={value!r} is not a known key; sections: "
                f"{', '.join(SECTIONS)}; top-level keys: {', '.join(TOP_LEVEL)}"
            )
    for required in ("ball", "plate", "drop"):
        if required not in data:
            raise PresetError(f"{source}: the [{required}] section is missing")


def _listener(section: dict, source: str):
    kind = section.get("type", DEFAULT_LISTENER)
    if kind not in ("microphone", "accelerometer"):
        raise PresetError(
            f"{source}: listener.type={kind!r} must be 'microphone' or 'accelerometer'"
        )
    lp = section.get("position")
    if not isinstance(lp, list):
        raise PresetError(f"{source}: listener.position={lp!r} must be a list of numbers (metres)")
    return Microphone(tuple(lp)) if kind == "microphone" else Accelerometer(tuple(lp))


def _render_section(section: dict, source: str) -> dict:
    """The ``[render]`` section checked: render options and a soundfile ``subtype``."""
    from synth.sound.options import OPTIONS

    _check_keys(f"{source}: render", section, OPTIONS + ("subtype",))
    try:
        render_options_of(section)
    except ParameterError as exc:
        raise PresetError(f"{source}: render.{exc}") from None
    if "subtype" in section:
        import soundfile

        st = section["subtype"]
        if not isinstance(st, str) or st.upper() not in soundfile.available_subtypes():
            raise PresetError(
                f"{source}: render.subtype={st!r} must be a soundfile subtype "
                f"such as 'PCM_16', 'PCM_24' or 'FLOAT'"
            )
    return {"samplerate": PRESET_SAMPLERATE, **section}


def render_options_of(section: dict):
    """The :class:`~synth.sound.options.RenderOptions` of a ``[render]`` section (default
    rate :data:`PRESET_SAMPLERATE`; ``subtype`` is the file's, left out)."""
    from synth.sound.options import RenderOptions

    section = {"samplerate": PRESET_SAMPLERATE, **section}
    return RenderOptions(**{k: v for k, v in section.items() if k != "subtype"})


def _fixed_defaults(cls) -> dict:
    """The fields of ``cls`` with a fixed default (None is derived from other keys)."""
    fields = dataclasses.fields(cls)
    return {f.name: f.default for f in fields if f.default not in (dataclasses.MISSING, None)}


def with_defaults(data: dict, *, varied=()) -> dict:
    """The valid preset dict ``data`` with every fixed default spelled out, so two dicts of
    one scene compare equal; defaults derived from other keys or from a key of ``varied``
    (a bank's axes) are left out, so setting those keys later still moves them."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    out.setdefault("gravity", Scene.__dataclass_fields__["gravity"].default)
    hollow = data.get("ball", {}).get("kind", "solid") == "hollow"
    ball_class = HollowBall if hollow else Ball
    for section, cls in (("ball", ball_class), ("plate", Plate), ("contact", Contact)):
        out[section] = {**_fixed_defaults(cls), **out.get(section, {})}
    contact = {"model": DEFAULT_CONTACT_MODEL, "theory": DEFAULT_PLATE_THEORY, **out["contact"]}
    if hollow:
        contact.setdefault("law", "shell")
    if "contact.model" not in varied:
        named = zip(("law", "plate", "surface"), CONTACT_MODELS[contact["model"]], strict=True)
        contact = {**dict(named), **contact}
    out["contact"] = contact
    if "rolling" in out:
        out["rolling"] = {**_fixed_defaults(Rolling), **out["rolling"]}
    if "listener" in out:
        out["listener"] = {"type": DEFAULT_LISTENER, **out["listener"]}
    section = out.get("render", {})
    subtype = {"subtype": section["subtype"]} if "subtype" in section else {}
    out["render"] = {**render_options_of(section).as_dict(), **subtype}
    return out


def canonical(data: dict, *, varied=()) -> dict:
    """The form of the valid preset ``data`` in which two presets of the same sounds are
    equal: :func:`with_defaults` without the description and the ``varied`` keys (a
    bank's axes, set by each row)."""
    out = with_defaults(data, varied=varied)
    out.pop("description", None)
    for key in varied:
        section, _, field = key.rpartition(".")
        (out.get(section, {}) if section else out).pop(field, None)
    return out


def load_preset_with_options(name_or_path, overrides=()) -> tuple[Scene, dict, dict]:
    """Scene, render options and the raw (overridden) dict of a preset."""
    path = find(name_or_path)
    data = apply_overrides(read(path), overrides)
    scene, render = scene_from_dict(data, str(path))
    return scene, render, data


def load_preset(name_or_path, overrides=()) -> Scene:
    """The :class:`Scene` of a preset (a file or a name such as ``"default"``), with
    ``"section.key=value"`` ``overrides``; its ``[render]`` section is checked too."""
    return load_preset_with_options(name_or_path, overrides)[0]


def render_preset(name_or_path, *, overrides=(), **options) -> Render:
    """Render a preset with its ``[render]`` options, overridden by ``options`` (keywords
    of :func:`synth.render`, ``samplerate`` in Hz ...)."""
    from synth.sound.render import render

    scene, section, _ = load_preset_with_options(name_or_path, overrides)
    return render(scene, **({k: v for k, v in section.items() if k != "subtype"} | options))
