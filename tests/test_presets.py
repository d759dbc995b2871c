"""Tests of synth.io.presets: loading TOML presets, ``--set`` overrides and their errors."""

import copy
import json
import math
import tomllib
from pathlib import Path

import pytest

from synth.errors import ParameterError, SynthError
from synth.io.presets import (
    PACKAGE_PRESETS,
    PresetError,
    apply_overrides,
    available,
    find,
    load_preset,
    load_preset_with_options,
    preset_dirs,
    read,
)
from synth.physics.materials import TABLE, LossFactor, Rayleigh
from synth.physics.scene import Accelerometer, Microphone

REPO = Path(__file__).resolve().parent.parent
DEFAULT = PACKAGE_PRESETS / "default.toml"  # the installed preset

# The thesis setup (docs/physics.md, "Materials" and "Hertz contact"; thesis Table 3.1) written as
# a preset dict.
THESIS = {
    "description": "thesis setup",
    "ball": {"material": "steel", "radius": 0.005, "mass": 4.17e-3},
    "plate": {
        "material": "mdf-18",
        "thickness": 0.018,
        "length": 1.227,
        "width": 0.49,
        "boundary": "free",
    },
    "drop": {"height": 0.1, "position": [0.6135, 0.245]},
    "listener": {"type": "microphone", "position": [0.6135, 0.245, 0.2]},
    "contact": {"model": "measured", "law": "hertz", "rtol": 1e-9},
}

# An inline material: a hard wood board (values of the table's "hardwood" row, Bies et al.).
OAK = {
    "name": "oak-board",
    "density": 700.0,
    "young": 12e9,
    "poisson": 0.35,
    "damping": {"eta": 0.01},
}


def _toml(value) -> str:
    """A Python value as a TOML value (the few types a preset uses)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string for ASCII text
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    raise TypeError(value)


def write(tmp_path, data, name="preset.toml") -> Path:
    """Write a preset dict (top-level keys, then one table per section) to tmp_path."""
    lines = [f"{k} = {_toml(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for section, table in data.items():
        if isinstance(table, dict):
            lines.append(f"[{section}]")
            lines += [f"{k} = {_toml(v)}" for k, v in table.items()]
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def thesis(**changes):
    """A deep copy of THESIS with ``section={key: value}`` merged in (value None deletes)."""
    data = copy.deepcopy(THESIS)
    for section, table in changes.items():
        if isinstance(table, dict) and isinstance(data.get(section), dict):
            for k, v in table.items():
                if v is None:
                    data[section].pop(k, None)
                else:
                    data[section][k] = v
        elif table is None:
            data.pop(section, None)
        else:
            data[section] = table
    return data


def error_of(tmp_path, data) -> tuple[str, Path]:
    """The PresetError message of a preset written to tmp_path, and its path."""
    path = write(tmp_path, data)
    with pytest.raises(PresetError) as info:
        load_preset(path)
    return str(info.value), path


def assert_names(message, path, *parts):
    """A preset error must name the file and every given part (key, value)."""
    assert str(path) in message, message
    for part in parts:
        assert part in message, (part, message)


# --------------------------------------------------------------------------- the default preset


def check_thesis_scene(scene):
    # Thesis Table 3.1 and section 3: 10 mm steel ball of 4.17 g (weighed), 18 mm MDF board of
    # 1227 x 490 mm on air cushions (free edges), 10 cm drop on the middle, microphone 20 cm
    # above; Hertz contact at rtol 1e-9 (a scene's default: timing along the series). Every
    # number is stored exactly (== on floats).
    assert scene.ball.material is TABLE["steel"]
    assert scene.ball.radius == 0.005
    assert scene.ball.mass == 4.17e-3
    plate = scene.plate
    assert plate.material is TABLE["mdf-18"]
    assert plate.material.young == 5.689e9  # the measured modulus of the 18 mm board
    assert (plate.thickness, plate.length, plate.width) == (0.018, 1.227, 0.49)
    assert plate.boundary == "free"
    assert scene.drop_height == 0.1
    # The impact point is the centre of the board (a/2, b/2) to float rounding.
    assert scene.position == pytest.approx(plate.centre, rel=1e-15)
    assert isinstance(scene.listener, Microphone)
    assert scene.listener.position == pytest.approx((*scene.position, 0.2), rel=1e-15)
    assert scene.contact.law == "hertz"
    assert scene.contact.rtol == 1e-9
    assert scene.gravity == 9.81


def test_load_default_by_name_is_thesis_setup():
    # The shipped preset "default" is the thesis' measured setup.
    check_thesis_scene(load_preset("default"))


def test_load_default_by_path_is_thesis_setup(monkeypatch):
    # The same file by relative path (from the repository root) and absolute path gives the
    # same scene as by name (frozen dataclasses compare field by field).
    monkeypatch.chdir(REPO)
    by_rel = load_preset("synth/presets/default.toml")
    check_thesis_scene(by_rel)
    assert by_rel == load_preset(DEFAULT) == load_preset("default")


def test_load_default_rejects_unknown_name():
    # A misspelt name is a PresetError that suggests the nearest known name.
    with pytest.raises(PresetError, match=r"preset='defualt'.*did you mean 'default'"):
        load_preset("defualt")


def test_preset_error_is_a_parameter_error():
    # One exception tree: PresetError < ParameterError < SynthError, ValueError.
    assert issubclass(PresetError, ParameterError)
    assert issubclass(PresetError, SynthError)
    assert issubclass(PresetError, ValueError)


def test_load_written_thesis_dict_equals_default(tmp_path):
    # The test's own THESIS dict written as TOML describes the same scene as the shipped file
    # (checks the writer used by every error test below).
    assert load_preset(write(tmp_path, THESIS)) == load_preset("default")


def test_load_defaults_when_optional_keys_are_left_out(tmp_path):
    # Without mass, drop.position, [listener], [contact] and gravity the scene takes its
    # documented defaults: mass = 4/3 pi r^3 rho (closed form, float rounding 1e-12), the centre
    # of the plate, a microphone 0.2 m above the impact point, Hertz at rtol 1e-9, g = 9.81.
    data = thesis(ball={"mass": None}, drop={"position": None}, listener=None, contact=None)
    scene = load_preset(write(tmp_path, data))
    assert scene.ball.mass == pytest.approx(4.0 / 3.0 * math.pi * 0.005**3 * 7800.0, rel=1e-12)
    assert scene.position == pytest.approx((1.227 / 2, 0.49 / 2), rel=1e-15)
    assert scene.listener.position == pytest.approx((1.227 / 2, 0.49 / 2, 0.2), rel=1e-15)
    assert (scene.contact.law, scene.contact.rtol) == ("hertz", 1e-9)
    assert scene.gravity == 9.81


def test_load_defaults_rejects_missing_material(tmp_path):
    # ball.material has no default: leaving it out names the file and the key.
    msg, path = error_of(tmp_path, thesis(ball={"material": None}))
    assert_names(msg, path, "ball.material")


def test_render_options_pass_through(tmp_path):
    # [render] holds options of synth.render (and the file's subtype): they come back
    # unchanged (48 kHz as an int).
    data = thesis(render={"samplerate": 48000, "normalize": "peak", "subtype": "FLOAT"})
    scene, render, raw = load_preset_with_options(write(tmp_path, data))
    assert render == {"samplerate": 48000, "normalize": "peak", "subtype": "FLOAT"}
    assert raw["render"]["samplerate"] == 48000
    assert scene.drop_height == 0.1


@pytest.mark.parametrize(
    "section, words",
    [
        ({"level": "peak"}, ["render.level='peak'", "not a known key", "normalize"]),
        ({"samplerate": "48k"}, ["render.samplerate='48k'", "integer number of Hz"]),
        ({"floor_db": 3}, ["render.floor_db=3", "< 0 (dB)"]),
        ({"normalize": "loud"}, ["render.normalize='loud'", "'loudness'"]),
        ({"max_frequency": 30000.0}, ["render.max_frequency=30000.0", "Nyquist"]),
        ({"subtype": "MP3_SUPER"}, ["render.subtype='MP3_SUPER'", "PCM_24"]),
    ],
)
def test_render_options_rejects_bad_keys_and_values(tmp_path, section, words):
    # A bad [render] option is found when the preset is read, by the API as by the CLI, and
    # the message names the file, the full key, the value and what is allowed.
    msg, path = error_of(tmp_path, thesis(render=section))
    assert_names(msg, path, *words)


def test_description_rejects_non_string(tmp_path):
    msg, path = error_of(tmp_path, dict(thesis(), description=5))
    assert_names(msg, path, "description=5", "string")


def test_render_options_rejects_render_not_a_table(tmp_path):
    # render = 48000 (not a table) is an error naming the file, the section and the value.
    msg, path = error_of(tmp_path, thesis(render=48000))
    assert_names(msg, path, "[render]", "48000")


# --------------------------------------------------------------------------- overrides (--set)


def test_override_number():
    # A TOML number replaces the file's value exactly; the explicit mass stays 4.17 g.
    scene = load_preset("default", overrides=["ball.radius=0.007"])
    assert scene.ball.radius == 0.007
    assert scene.ball.mass == 4.17e-3


def test_override_number_rejects_bad_value():
    # An override is validated like the file: the error names the file, key and value.
    with pytest.raises(PresetError) as info:
        load_preset("default", overrides=["ball.radius=-1"])
    assert_names(str(info.value), find("default"), "ball.radius=-1")


@pytest.mark.parametrize(
    "item",
    [
        "plate.material=glass",
        'plate.material="glass"',
        "plate.material='glass'",
        "plate.material = glass ",
    ],
)
def test_override_string(item):
    # A bare word is a string (material=glass); TOML basic and literal strings too; spaces
    # around key and value are ignored. The table row is used as it is.
    assert load_preset("default", overrides=[item]).plate.material is TABLE["glass"]


def test_override_string_bare_word_with_hyphen():
    # "mdf-12" is not a TOML value: it is taken as a bare word (the 12 mm board).
    assert (
        load_preset("default", overrides=["plate.material=mdf-12"]).plate.material
        is TABLE["mdf-12"]
    )


def test_override_string_rejects_number_with_unit():
    # "0.007m" is a bare word, so a string: a radius must be a number and the error says so.
    with pytest.raises(PresetError, match=r"ball\.radius='0\.007m' must be a number"):
        load_preset("default", overrides=["ball.radius=0.007m"])


def test_override_list():
    # A TOML array sets a position (metres); the scene stores it as a tuple.
    assert load_preset("default", overrides=["drop.position=[0.1, 0.1]"]).position == (0.1, 0.1)


def test_override_list_rejects_off_plate():
    # [2.0, 0.1] lies beyond the 1.227 m board: the error names drop.position and the value.
    with pytest.raises(PresetError, match=r"drop\.position=\(2\.0, 0\.1\) is off the plate"):
        load_preset("default", overrides=["drop.position=[2.0, 0.1]"])


def test_override_top_level():
    # A one-part key sets a top-level value: lunar gravity 1.62 m/s^2.
    assert load_preset("default", overrides=["gravity=1.62"]).gravity == 1.62


def test_override_top_level_rejects_bad_gravity():
    # Gravity must be > 0: the error names the key and the value.
    with pytest.raises(PresetError, match=r"gravity=-9\.81 must be > 0"):
        load_preset("default", overrides=["gravity=-9.81"])


def test_override_adds_section_and_later_wins(tmp_path):
    # Overrides apply in order (the last one wins) and may create a section the file lacks.
    path = write(tmp_path, thesis(contact=None))
    scene = load_preset(
        path,
        overrides=[
            "ball.radius=0.006",
            "ball.radius=0.0075",
            "contact.law=hunt-crossley",
            "contact.dissipation=0.2",
        ],
    )
    assert scene.ball.radius == 0.0075
    assert (scene.contact.law, scene.contact.dissipation) == ("hunt-crossley", 0.2)


def test_apply_overrides_leaves_input_unchanged():
    # apply_overrides returns a new dict; the caller's dict (and its sections) are not touched.
    data = copy.deepcopy(THESIS)
    out = apply_overrides(data, ["ball.radius=0.007", "gravity=1.62"])
    assert data == THESIS
    assert out["ball"]["radius"] == 0.007 and out["gravity"] == 1.62


@pytest.mark.parametrize(
    "item, part",
    [
        ("ball.radius", "'ball.radius'"),  # no '='
        ("ball.material.density=7800", "ball.material.density"),  # three-part key
        ("description.x=1", "'description' is not a section"),  # a top-level value is no section
    ],
)
def test_apply_overrides_rejects_bad_items(item, part):
    # Malformed overrides are PresetErrors naming the offending item.
    with pytest.raises(PresetError) as info:
        apply_overrides(THESIS, [item])
    assert part in str(info.value)


@pytest.mark.parametrize("item", ["ball.radius", "ball.material.density=7800"])
def test_load_preset_rejects_bad_overrides(item):
    # The same through load_preset(..., overrides=[...]).
    with pytest.raises(PresetError):
        load_preset("default", overrides=[item])


# --------------------------------------------------------------------------- key errors


def test_unknown_top_level_key(tmp_path):
    # An unknown top-level key names the file, the key and its value.
    msg, path = error_of(tmp_path, thesis(colour="red"))
    assert_names(msg, path, "colour='red'", "is not a known key")


def test_unknown_section_key_suggests_near_name(tmp_path):
    # A misspelt key in a section names file, dotted key, value and the nearest field.
    msg, path = error_of(tmp_path, thesis(ball={"radious": 0.005}))
    assert_names(msg, path, "ball.radious=0.005", "did you mean 'radius'?")


@pytest.mark.parametrize("section", ["ball", "plate", "drop", "listener", "contact"])
def test_section_not_a_table(tmp_path, section):
    # `ball = 3` instead of a [ball] table names the file, the section and the value.
    msg, path = error_of(tmp_path, thesis(**{section: 3}))
    assert_names(msg, path, f"[{section}] must be a table", "3")


@pytest.mark.parametrize("section", ["ball", "plate", "drop"])
def test_missing_required_section(tmp_path, section):
    # [ball], [plate] and [drop] have no defaults: a missing one is named with the file.
    msg, path = error_of(tmp_path, thesis(**{section: None}))
    assert_names(msg, path, f"[{section}] section is missing")


def test_missing_drop_height(tmp_path):
    # drop.height has no default.
    msg, path = error_of(tmp_path, thesis(drop={"height": None}))
    assert_names(msg, path, "drop.height")


@pytest.mark.parametrize(
    "changes, parts",
    [
        ({"ball": {"radius": "0.005"}}, ["ball.radius='0.005'", "number"]),
        ({"ball": {"mass": "4.17 g"}}, ["ball.mass='4.17 g'"]),
        ({"plate": {"thickness": [0.018]}}, ["plate.thickness=[0.018]", "number"]),
        ({"drop": {"height": "0.1"}}, ["drop.height='0.1'"]),
        ({"drop": {"position": "centre"}}, ["drop.position='centre'", "[x, y]"]),
        (
            {"drop": {"position": [0.5, 0.2, 0.1]}},
            ["drop.position=(0.5, 0.2, 0.1)", "2 coordinates"],
        ),
        ({"listener": {"position": "above"}}, ["listener.position='above'"]),
        ({"listener": {"type": "ear"}}, ["listener.type='ear'"]),
        ({"gravity": "9.81"}, ["gravity='9.81'"]),
        ({"contact": {"rtol": "1e-6"}}, ["contact.rtol='1e-6'"]),
    ],
)
def test_wrong_types(tmp_path, changes, parts):
    # A value of the wrong type is an error naming the file, the key and the value.
    msg, path = error_of(tmp_path, thesis(**changes))
    assert_names(msg, path, *parts)


@pytest.mark.parametrize(
    "changes, parts",
    [
        # impact point beyond the 1.227 m board
        ({"drop": {"position": [1.5, 0.2]}}, ["drop.position=(1.5, 0.2)", "off the plate"]),
        # a 0.6 m ball on a 0.49 m wide board
        ({"ball": {"radius": 0.3}}, ["ball.radius=0.3", "too large"]),
        # an accelerometer must sit on the plate
        (
            {"listener": {"type": "accelerometer", "position": [0.6, 0.6]}},
            ["listener.position=(0.6, 0.6)", "off the plate"],
        ),
        # a microphone must be above the plate (z > 0)
        ({"listener": {"position": [0.6, 0.2, 0.0]}}, ["listener.position.z=0.0"]),
        ({"plate": {"boundary": "pinned"}}, ["plate.boundary='pinned'", "'free'"]),
        ({"contact": {"law": "coulomb"}}, ["contact.law='coulomb'", "'hertz'"]),
        (
            {"contact": {"law": "hunt-crossley"}},
            ["contact.law='hunt-crossley'", "contact.dissipation"],
        ),
        ({"contact": {"dissipation": 0.5}}, ["contact.dissipation=0.5", "'hertz'"]),
        ({"contact": {"rtol": 0.5}}, ["contact.rtol=0.5"]),
        ({"plate": {"thickness": 0.6}}, ["plate.thickness=0.6"]),
        ({"ball": {"material": "unobtainium"}}, ["ball.material", "'unobtainium'"]),
        ({"drop": {"height": 0.0}}, ["drop.height=0.0", "> 0"]),
    ],
)
def test_impossible_scenes(tmp_path, changes, parts):
    # A scene the physics cannot hold is a PresetError naming the file, the key and the value.
    msg, path = error_of(tmp_path, thesis(**changes))
    assert_names(msg, path, *parts)


def test_accelerometer_on_plate(tmp_path):
    # The accepted counterpart: an accelerometer on the board is stored at its (x, y), metres.
    data = thesis(listener={"type": "accelerometer", "position": [0.3, 0.1]})
    listener = load_preset(write(tmp_path, data)).listener
    assert isinstance(listener, Accelerometer) and listener.position == (0.3, 0.1)


# --------------------------------------------------------------------------- inline materials


def test_inline_material_loss_factor(tmp_path):
    # An inline table builds a Material with exactly the given constants and a loss factor.
    scene = load_preset(write(tmp_path, thesis(plate={"material": OAK})))
    m = scene.plate.material
    assert (m.name, m.density, m.young, m.poisson) == ("oak-board", 700.0, 12e9, 0.35)
    assert m.damping == LossFactor(0.01)


def test_inline_material_rayleigh(tmp_path):
    # {alpha, beta} is Rayleigh damping: the MDF fit alpha = 35 1/s, beta = 5e-7 s
    # (docs/physics.md, "Materials").
    mat = dict(OAK, damping={"alpha": 35.0, "beta": 5e-7})
    m = load_preset(write(tmp_path, thesis(plate={"material": mat}))).plate.material
    assert m.damping == Rayleigh(35.0, 5e-7)


def test_inline_material_ball_mass_from_density(tmp_path):
    # An unnamed inline ball material is called "custom"; without a mass the ball's mass is
    # 4/3 pi r^3 rho of the inline density (closed form, 1e-12 relative is float rounding).
    mat = {"density": 7960.0, "young": 216e9, "poisson": 0.3}
    scene = load_preset(write(tmp_path, thesis(ball={"material": mat, "mass": None})))
    assert scene.ball.material.name == "custom"
    assert scene.ball.mass == pytest.approx(4.0 / 3.0 * math.pi * 0.005**3 * 7960.0, rel=1e-12)


def test_inline_material_rejects_unknown_key(tmp_path):
    # An unknown key of an inline table names the file, the dotted key and its value.
    msg, path = error_of(tmp_path, thesis(ball={"material": dict(OAK, colour="red")}))
    assert_names(msg, path, "ball.material.colour", "'red'")


@pytest.mark.parametrize(
    "damping", [{"eta": 0.01, "alpha": 35.0}, {"alpha": 35.0}, {}, 0.01, {"q": 100.0}]
)
def test_inline_material_rejects_bad_damping(tmp_path, damping):
    # damping must be exactly {eta} or {alpha, beta}; anything else names file and key.
    msg, path = error_of(tmp_path, thesis(plate={"material": dict(OAK, damping=damping)}))
    assert_names(msg, path, "plate.material.damping")


def test_inline_material_rejects_non_table(tmp_path):
    # A material that is neither a name nor a table names the file, the key and the value.
    msg, path = error_of(tmp_path, thesis(ball={"material": 7800}))
    assert_names(msg, path, "ball.material=7800")


@pytest.mark.parametrize("key, value", [("density", -700.0), ("young", 0.0), ("poisson", 0.5)])
def test_inline_material_rejects_bad_constant(tmp_path, key, value):
    # A bad constant of an inline plate material names the file, the preset key (the plate's
    # material: both ball and plate may hold an inline "custom" material) and the value.
    mat = {"density": 700.0, "young": 12e9, "poisson": 0.35, key: value}
    msg, path = error_of(tmp_path, thesis(plate={"material": mat}))
    assert_names(msg, path, "plate.material", f"{key}={value!r}")


@pytest.mark.parametrize(
    "damping, part", [({"eta": -0.01}, "-0.01"), ({"alpha": 35.0, "beta": -1.0}, "-1.0")]
)
def test_inline_material_rejects_bad_damping_value(tmp_path, damping, part):
    # A negative loss factor or Rayleigh coefficient is rejected, naming the file and value.
    msg, path = error_of(tmp_path, thesis(plate={"material": dict(OAK, damping=damping)}))
    assert_names(msg, path, part)


# --------------------------------------------------------------------------- files


def test_read_returns_toml():
    # read() is tomllib on the file: the same dict as parsing the shipped file directly.
    with open(DEFAULT, "rb") as fh:
        assert read(DEFAULT) == tomllib.load(fh)


def test_read_rejects_invalid_toml(tmp_path):
    # Broken TOML is a PresetError with the path (not tomllib's own exception).
    path = tmp_path / "broken.toml"
    path.write_text("[ball\nradius = 0.005\n", encoding="utf-8")
    with pytest.raises(PresetError) as info:
        load_preset(path)
    assert_names(str(info.value), path, "not valid TOML")


def test_read_rejects_non_utf8(tmp_path):
    # TOML is UTF-8: a Latin-1 byte (0xe9) is a PresetError with the path, like any bad TOML.
    path = tmp_path / "latin1.toml"
    path.write_bytes(b'description = "b\xe9ton"\n')
    with pytest.raises(PresetError) as info:
        read(path)
    assert str(path) in str(info.value)


def test_read_rejects_missing_file(tmp_path):
    # A missing file (by path) is a PresetError with the path, from load_preset and read.
    path = tmp_path / "nope.toml"
    with pytest.raises(PresetError) as info:
        load_preset(path)
    assert str(path) in str(info.value)
    with pytest.raises(PresetError, match="cannot be read") as info:
        read(path)
    assert str(path) in str(info.value)


def test_read_rejects_unreadable(tmp_path):
    # A directory cannot be read as a file (works whatever the user's permissions): PresetError
    # with the path; find() refuses a directory called *.toml.
    folder = tmp_path / "dir.toml"
    folder.mkdir()
    with pytest.raises(PresetError, match="cannot be read") as info:
        read(folder)
    assert str(folder) in str(info.value)
    with pytest.raises(PresetError) as info:
        find(folder)
    assert str(folder) in str(info.value)


# --------------------------------------------------------------------------- find / available


def test_find_by_name():
    # "default" is the repository's presets/default.toml.
    assert find("default").resolve() == DEFAULT


def test_find_rejects_unknown_name_suggesting_near_names():
    # An unknown name suggests the nearest known names and lists the known ones.
    with pytest.raises(PresetError) as info:
        find("defualt")
    msg = str(info.value)
    assert "preset='defualt'" in msg and "did you mean 'default'" in msg and "known:" in msg


def test_available_lists_default():
    # The shipped preset is listed with its file.
    names = available()
    assert "default" in names
    assert names["default"].resolve() == DEFAULT


def test_available_ignores_missing_env_dir(monkeypatch, tmp_path):
    # $SYNTH_PRESETS naming no folder is skipped (not an error); "default" is still found.
    monkeypatch.setenv("SYNTH_PRESETS", str(tmp_path / "absent"))
    assert tmp_path / "absent" not in preset_dirs()
    assert available()["default"].resolve() == DEFAULT


def test_env_presets_searched_first(monkeypatch, tmp_path):
    # $SYNTH_PRESETS comes first: its "default" shadows the shipped one, and its own names
    # are listed and loadable.
    write(tmp_path, thesis(drop={"height": 0.2}), name="default.toml")
    write(tmp_path, thesis(gravity=1.62), name="moon.toml")
    monkeypatch.setenv("SYNTH_PRESETS", str(tmp_path))
    assert preset_dirs()[0] == tmp_path
    names = available()
    assert names["default"] == tmp_path / "default.toml"
    assert names["moon"] == tmp_path / "moon.toml"
    assert load_preset("default").drop_height == 0.2
    assert load_preset("moon").gravity == 1.62


def test_env_presets_rejects_broken_file(monkeypatch, tmp_path):
    # A broken preset found through $SYNTH_PRESETS reports its path in the error.
    (tmp_path / "broken.toml").write_text("ball = [\n", encoding="utf-8")
    monkeypatch.setenv("SYNTH_PRESETS", str(tmp_path))
    with pytest.raises(PresetError) as info:
        load_preset("broken")
    assert str(tmp_path / "broken.toml") in str(info.value)


def test_render_preset_uses_the_render_section(tmp_path):
    # The [render] section's options reach the renderer through the API too; keywords win.
    import synth

    path = write(tmp_path, thesis(render={"samplerate": 22050, "max_frequency": 5000.0}))
    r = synth.render_preset(path, overrides=["drop.height=0.02"])
    assert r.samplerate == 22050 and r.settings["max_frequency"] == 5000.0
    r = synth.render_preset(path, samplerate=16000, overrides=["drop.height=0.02"])
    assert r.samplerate == 16000


# --------------------------------------------------------------------------- plate theory


def test_transverse_shear_and_plate_theory_keys(tmp_path):
    # A built-in material named in an inline table with none of density, young, poisson is
    # that material with the given keys changed: transverse_shear in Pa, or "tied" to the
    # fitted through-thickness modulus, G_t = E_t / (2 (1 + nu)) (materials.with_transverse_
    # shear: the same value to the last bit); contact.theory reaches the modal plate.
    from synth.physics.materials import get, with_transverse_shear

    tied = {"name": "mdf-18", "transverse_shear": "tied"}
    contact = {"model": "fitted", "theory": "mindlin"}
    scene = load_preset(write(tmp_path, thesis(plate={"material": tied}, contact=contact)))
    assert scene.plate.material == with_transverse_shear(get("mdf-18"))
    assert scene.contact.theory == "mindlin" and scene.contact.plate == "modal"
    given = {"name": "mdf-18", "transverse_shear": 3e8}
    m = load_preset(write(tmp_path, thesis(plate={"material": given}))).plate.material
    assert m.transverse_shear == 3e8 and m.damping == get("mdf-18").damping
    assert load_preset(write(tmp_path, thesis())).contact.theory == "kirchhoff"


@pytest.mark.parametrize(
    "changes, parts",
    [
        ({"contact": {"model": "fitted", "theory": "reissner"}}, ["contact.theory", "reissner"]),
        ({"contact": {"plate": "impedance", "theory": "mindlin"}}, ["contact.theory", "'modal'"]),
        (
            {"plate": {"material": {"name": "mdf-18", "transverse_shear": "soft"}}},
            ["plate.material.transverse_shear", "'soft'", "'tied'"],
        ),
        (
            {"plate": {"material": {"name": "mdf-18", "transverse_shear": -1.0}}},
            ["transverse_shear=-1.0", "> 0"],
        ),
        (
            {"plate": {"material": dict(OAK, transverse_shear="tied")}},
            ["plate.material", "fitted contact surface"],
        ),
    ],
)
def test_transverse_shear_and_plate_theory_reject_bad_values(tmp_path, changes, parts):
    # Each bad value names the file, the key, the value and what is allowed.
    msg, path = error_of(tmp_path, thesis(**changes))
    assert_names(msg, path, *parts)


def test_canonical_preset_fills_defaults_and_drops_what_rows_set():
    # One home for the canonical preset (synth.io.presets.canonical, which the bank's
    # stored spec uses): a preset that spells out defaults and a description equals the
    # bare one, and the values of varied keys (set by every row) are left out.
    from synth.io.presets import canonical, read

    bare = read(find("default"))
    spelled = copy.deepcopy(bare)
    spelled["description"] = "said otherwise"
    spelled["gravity"] = 9.81
    spelled.setdefault("render", {})["normalize"] = "peak"
    spelled.setdefault("contact", {})["law"] = "hertz"
    bare.setdefault("render", {})["normalize"] = "peak"
    assert canonical(spelled) == canonical(bare)
    varied = canonical(spelled, varied=("ball.radius", "gravity"))
    assert "radius" not in varied["ball"] and "gravity" not in varied
    assert "description" not in varied
    assert varied["render"]["samplerate"] > 0  # a default filled in


def test_set_key_sets_dotted_keys_without_touching_a_shared_section():
    from synth.io.presets import set_key

    shared = {"radius": 0.005}
    data = {"ball": shared}
    set_key(data, "ball.radius", 0.007)
    set_key(data, "drop.position", (0.1, 0.2))
    set_key(data, "gravity", 9.0)
    assert data == {"ball": {"radius": 0.007}, "drop": {"position": [0.1, 0.2]}, "gravity": 9.0}
    assert shared == {"radius": 0.005}
    with pytest.raises(ParameterError, match="a.b.c"):
        set_key(data, "a.b.c", 1)
    with pytest.raises(ParameterError, match="'gravity' is not a section"):
        set_key(data, "gravity.x", 1)
