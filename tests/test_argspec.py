"""The render options are declared once, in ``synth.RenderOptions``; its three front ends
read them from there: ``synth.render``'s signature and docstring are generated from the
fields, ``synth render`` has a flag per field, and a preset's ``[render]`` table (documented
in ``synth.io.presets``, the one copy written by hand) holds them. The analysis options
likewise, in ``synth.AnalysisOptions``, for ``synth.analyze``, ``synth.analyze_file`` and
the flags of ``synth analyze`` and ``synth alter``. These tests keep the
front ends on the fields (as python-soundfile's test_argspec keeps its functions' defaults
together)."""

import dataclasses
import inspect
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import synth
from synth.analysis import options as analysis_options
from synth.analysis.options import OPTIONS as ANALYSIS_OPTIONS
from synth.analysis.options import AnalysisOptions
from synth.cli import build_parser
from synth.constants import GRAVITY
from synth.io import presets
from synth.physics.scene import Scene
from synth.sound import options as render_options
from synth.sound.options import OPTIONS, RenderOptions
from synth.store.audio import DEFAULT_SUBTYPE

#: Parameters of render() that are not options (the scene, the options as one object, a
#: precomputed sequence, and the budget of work, which is not a property of the sound).
NOT_OPTIONS = ("scene", "options", "sequence", "budget")

#: docs/cli.md, whose "Preset files" section lists every key of a preset with its unit.
PRESET_DOC = (Path(__file__).parent.parent / "docs" / "cli.md").read_text()


def documented_section(name: str) -> tuple[dict, dict]:
    """The keys and values of ``[name]`` in docs/cli.md's preset reference (TOML), and each
    key's comment."""
    doc = PRESET_DOC
    block = doc[doc.index(f"    [{name}]") :].split("\n\n")[0]
    lines = [line[4:] for line in block.splitlines()]
    comments = {
        line.split("=")[0].strip(): line.split("#", 1)[1].strip() for line in lines if "=" in line
    }
    return tomllib.loads("\n".join(lines))[name], comments


def test_render_signature_is_the_fields():
    params = inspect.signature(synth.render).parameters
    assert tuple(p for p in params if p not in NOT_OPTIONS) == OPTIONS
    for name in OPTIONS:
        assert params[name].default == render_options.default(name), name
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY
    assert params["samplerate"].default is inspect.Parameter.empty  # required of every caller


def test_render_docstring_documents_every_field():
    words = " ".join(synth.render.__doc__.split())
    for name in OPTIONS:
        assert f"    {name} : " in synth.render.__doc__, name
        assert " ".join(render_options.describe(name).split()) in words, name


def test_documented_preset_render_keys_are_the_defaults_and_units():
    doc, comments = documented_section("render")
    assert tuple(doc) == OPTIONS + ("subtype",)
    assert doc.pop("subtype") == DEFAULT_SUBTYPE
    assert doc.pop("samplerate") == presets.PRESET_SAMPLERATE  # a preset's when it names none
    for key, value in doc.items():
        unit = render_options.declaration(key).unit
        if unit:  # the comment starts with the unit
            assert comments[key].split()[0].rstrip(",:") == unit, key
        if render_options.default(key) is None:  # derived (max_frequency: the Nyquist)
            continue
        assert value == render_options.default(key), key


def test_cli_render_has_a_flag_per_field_in_order():
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    flags = [a for a in sub.choices["render"]._actions if a.dest in OPTIONS]
    assert tuple(a.dest for a in flags) == OPTIONS
    for action in flags:
        assert action.default is None  # unset: the preset's value holds
        assert render_options.describe(action.dest) in action.help


def test_cli_page_prints_the_flags_of_the_fields():
    # docs/cli.md's rows of the render options are synth.sound.options.flag_rows()' output
    text = (Path(__file__).parent.parent / "docs" / "cli.md").read_text()
    for row in render_options.flag_rows().splitlines():
        assert row in text, row


def test_options_check_once_and_convert():
    o = RenderOptions(samplerate=48000, peak_db=-3, max_impacts=5)
    assert (o.peak_db, type(o.peak_db), o.max_impacts) == (-3.0, float, 5)
    assert o.top_frequency == 24000.0
    with pytest.raises(synth.ParameterError, match=r"max_frequency=30000\.0 must be <= the"):
        o.replace(max_frequency=30000.0)  # a copy is checked again
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.peak_db = 0.0
    with pytest.raises(TypeError, match="did you mean 'peak_db'"):
        RenderOptions.of(samplerate=48000, peak_dB=-3)
    with pytest.raises(TypeError, match="samplerate"):
        RenderOptions.of(peak_db=-3)
    assert RenderOptions.of(o, fade=0.0) == o.replace(fade=0.0)


def test_documented_gravity_is_the_default():
    line = next(s for s in PRESET_DOC.splitlines() if s.strip().startswith("gravity ="))
    assert float(re.search(r"gravity = ([0-9.]+)", line)[1]) == GRAVITY
    assert inspect.signature(Scene).parameters["gravity"].default == GRAVITY
    assert inspect.signature(synth.simulate_bounces).parameters["gravity"].default == GRAVITY


# The analysis options: declared once in synth.AnalysisOptions; analyze and analyze_file take
# them as keywords (generated signatures and docstrings), synth analyze and synth alter have a
# flag per field, docs/cli.md prints the flags' rows.


@pytest.mark.parametrize("function, leading", [("analyze", 2), ("analyze_file", 1)])
def test_analysis_signatures_are_the_fields(function, leading):
    f = getattr(synth, function)
    params = list(inspect.signature(f).parameters.values())
    assert tuple(p.name for p in params[leading:-1]) == ANALYSIS_OPTIONS
    assert params[-1].name == "options" and params[-1].default is None
    for p in params[leading:]:
        assert p.kind is inspect.Parameter.KEYWORD_ONLY
        if p.name != "options":
            assert p.default == getattr(AnalysisOptions(), p.name), p.name
    words = " ".join(f.__doc__.split())
    for name in ANALYSIS_OPTIONS:
        assert f"    {name} : " in f.__doc__, name
        assert " ".join(analysis_options.describe(name).split()) in words, name


@pytest.mark.parametrize("command", ["analyze", "alter"])
def test_cli_analysis_commands_have_a_flag_per_field_in_order(command):
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    flags = [a for a in sub.choices[command]._actions if a.dest in ANALYSIS_OPTIONS]
    assert tuple(a.dest for a in flags) == ANALYSIS_OPTIONS
    for action in flags:
        assert action.default is None  # unset: the option's default holds
        assert action.option_strings == [analysis_options.flag(action.dest).split()[0]]
        assert action.help == analysis_options.flag_help(action.dest)


def test_cli_page_prints_the_flags_of_the_analysis_fields():
    text = (Path(__file__).parent.parent / "docs" / "cli.md").read_text()
    for row in analysis_options.flag_rows().splitlines():
        assert row in text, row


def test_analysis_options_check_once_and_name_the_nearest():
    o = AnalysisOptions(window=1, clip_samples=np.int64(3))
    assert (o.window, type(o.window), o.clip_samples, type(o.clip_samples)) == (1.0, float, 3, int)
    assert o.gravity == GRAVITY and AnalysisOptions.of(o, hop=0.001) == o.replace(hop=0.001)
    with pytest.raises(synth.ParameterError, match=r"window=3\.0 must be > 0 and <= 2 \(s\)"):
        o.replace(window=3.0)  # a copy is checked again
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.window = 0.0
    with pytest.raises(TypeError, match="did you mean 'threshold_db'"):
        synth.analyze(np.zeros(10), 44100, treshold_db=12)  # before the audio is checked
    with pytest.raises(TypeError, match="did you mean 'window'"):
        synth.analyze_file("none.wav", windw=0.01)  # before the file is looked for
    with pytest.raises(TypeError, match="did you mean 'deflate'"):
        o.replace(deflat=False)
    with pytest.raises(synth.ParameterError, match="options=.*must be an AnalysisOptions"):
        synth.analyze(np.zeros(10), 44100, options={"window": 0.01})


def test_analysis_options_from_the_command_line_text():
    assert analysis_options.from_text({"channel": "mix", "lpc_order": "32"}) == AnalysisOptions(
        channel=None, lpc_order=32
    )
    assert analysis_options.from_text({"deflate": False}).deflate is False
    with pytest.raises(synth.ParameterError, match="channel='left' must be a channel index"):
        analysis_options.from_text({"channel": "left"})
    with pytest.raises(synth.ParameterError, match="window='abc' must be in"):
        analysis_options.from_text({"window": "abc"})


def test_cli_analysis_flags_reach_the_analysis(tmp_path, monkeypatch, capsys):
    # synth analyze passes the flags given, parsed as their fields declare, and no others
    import soundfile

    from synth import analysis
    from synth.cli import main

    path = tmp_path / "x.wav"
    soundfile.write(path, np.zeros(100), 8000)
    got = {}

    def fake(file, *, options):
        got["options"] = options
        raise synth.SynthError("stop")

    monkeypatch.setattr(analysis, "analyze_file", fake)
    argv = ["analyze", str(path), "--no-deflate", "--lpc-order", "32", "--channel", "mix"]
    assert main([*argv, "--window", "0.05", "--on-clipping", "raise"]) != 0
    assert got["options"] == AnalysisOptions(
        deflate=False, lpc_order=32, window=0.05, on_clipping="raise"
    )
    assert main(["analyze", str(path), "--hop", "x"]) == 2  # before any analysis
    assert "hop='x' must be in (0, 0.01]" in capsys.readouterr().err
