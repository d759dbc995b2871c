"""The defaults of the render options are declared three times for three readers: the
signature of ``synth.render``, that of ``synth.sound.render.check_options`` (which presets
use) and the ``[render]`` section documented in ``synth.io.presets``. They must agree (as
python-soundfile's test_argspec keeps its functions' defaults together)."""

import inspect
import re
import tomllib

import synth
from synth.constants import GRAVITY
from synth.io import presets
from synth.io.audio import DEFAULT_SUBTYPE
from synth.physics.scene import Scene
from synth.sound import render as render_module

#: Parameters of render() that are not options (the scene, a precomputed sequence, and the
#: budget of work, which is not a property of the sound).
NOT_OPTIONS = {"scene", "sequence", "budget"}


def defaults(func, skip=()) -> dict:
    return {
        name: p.default
        for name, p in inspect.signature(func).parameters.items()
        if name not in skip
    }


def documented_section(name: str) -> dict:
    """The keys and values of ``[name]`` in the presets module's docstring (TOML)."""
    doc = presets.__doc__
    block = doc[doc.index(f"    [{name}]") :].split("\n\n")[0]
    text = "\n".join(line[4:] for line in block.splitlines())
    return tomllib.loads(text)[name]


def test_render_and_check_options_have_the_same_defaults():
    assert defaults(synth.render, NOT_OPTIONS) == defaults(render_module.check_options)


def test_options_list_names_every_option_in_order():
    assert tuple(defaults(render_module.check_options)) == render_module.OPTIONS


def test_documented_preset_render_keys_are_the_defaults():
    doc = documented_section("render")
    opts = defaults(render_module.check_options)
    assert set(doc) == set(opts) | {"subtype"}
    assert doc.pop("subtype") == DEFAULT_SUBTYPE
    assert opts["samplerate"] is inspect.Parameter.empty  # required of every caller
    assert doc.pop("samplerate") == presets.PRESET_SAMPLERATE  # a preset's when it names none
    for key, value in doc.items():
        if opts[key] is None:  # no default (e.g. max_frequency: the Nyquist frequency)
            continue
        assert value == opts[key], key


def test_documented_gravity_is_the_default():
    line = next(s for s in presets.__doc__.splitlines() if s.strip().startswith("gravity ="))
    assert float(re.search(r"gravity = ([0-9.]+)", line)[1]) == GRAVITY
    assert defaults(Scene)["gravity"] == GRAVITY
    assert defaults(synth.simulate_bounces)["gravity"] == GRAVITY
