"""Property-based tests (hypothesis): any value of any scene key, render option, ``--set``
text or audio write either works or is refused with a ParameterError that names the
field; nothing else escapes and nothing is left on disk."""

import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from synth.errors import ParameterError
from synth.io.presets import PresetError, apply_overrides, load_preset_with_options
from synth.sound.render import OPTIONS, RenderOptions
from synth.store import audio as audio_io

BOUNDED = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)

NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([0, 1e-300, 1e-6, 1e308, -1.0, 0.5, 2**63 - 1]),
)
SCENE_KEYS = [
    "ball.radius",
    "ball.mass",
    "plate.thickness",
    "plate.length",
    "plate.width",
    "drop.height",
    "gravity",
    "contact.rtol",
]
# the numeric render options (normalize is a choice of words)
RENDER_KEYS = [key for key in OPTIONS if key != "normalize"]


def toml_number(x) -> str:
    if isinstance(x, float) and math.isnan(x):
        return "nan"
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


@BOUNDED
@given(key=st.sampled_from(SCENE_KEYS), value=NUMBERS)
def test_any_scene_number_is_accepted_or_named(key, value):
    try:
        load_preset_with_options("default", [f"{key}={toml_number(value)}"])
    except PresetError as exc:
        # the key itself, or a key whose range it moved (a shorter plate leaves the drop
        # position off it; a thinner one ...), named with its value
        assert key in str(exc) or re.search(r"(ball|plate|drop|contact)\.\w+=", str(exc)), str(exc)


@BOUNDED
@given(key=st.sampled_from(RENDER_KEYS), value=NUMBERS)
def test_any_render_option_is_accepted_or_named(key, value):
    try:
        opts = RenderOptions.of(**{"samplerate": 48000, key: value}).as_dict()
    except ParameterError as exc:
        assert key in str(exc), str(exc)
    else:
        # what passes is finite and inside the documented ranges
        assert all(v is None or isinstance(v, str) or math.isfinite(v) for v in opts.values())
        assert 0 <= opts["preroll"] <= 10 and 0 < opts["max_tail"] <= 600
        assert 5 <= opts["pulse_points"] <= 4097 and -120 <= opts["peak_db"] <= 0


@pytest.mark.slow
@BOUNDED
@given(text=st.text(max_size=40))
def test_any_set_text_gives_a_dict_or_a_preset_error(text):
    try:
        out = apply_overrides({"ball": {"radius": 0.005}}, [text])
    except PresetError:
        return
    assert isinstance(out, dict)


@BOUNDED
@given(
    samples=st.lists(st.floats(min_value=-1.0, max_value=1.0), min_size=1, max_size=64),
    samplerate=st.one_of(
        st.integers(min_value=-10, max_value=2**41), st.sampled_from([1, 8000, 768000, 768001])
    ),
    subtype=st.sampled_from(["PCM_16", "PCM_24", "FLOAT", "PCM_99"]),
)
def test_write_audio_writes_whole_or_refuses(tmp_path, samples, samplerate, subtype):
    target = tmp_path / "x.wav"
    try:
        audio_io.write_audio(target, np.array(samples), samplerate, subtype=subtype)
    except ParameterError as exc:
        assert any(w in str(exc) for w in ("samplerate", "subtype", "silence")), str(exc)
    else:
        audio, sr = audio_io.read_audio(target)
        assert sr == samplerate and audio.shape[0] == len(samples)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e309"])
def test_non_finite_scene_numbers_are_named(value):
    with pytest.raises(PresetError, match="drop.height"):
        load_preset_with_options("default", [f"drop.height={value}"])
