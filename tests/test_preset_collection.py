"""Tests of the preset collection in ``presets/``: every file loads, describes itself and
computes a physically sensible bounce sequence; the thesis presets carry the thesis' balls
and boards (docs/physics.md, "Materials", thesis Table 3.1) exactly."""

import math
import re
from pathlib import Path

import pytest

from synth import cost, simulate_scene
from synth.errors import ParameterError
from synth.io.presets import PresetError, find, load_preset, load_preset_with_options, read
from synth.physics.materials import TABLE
from synth.physics.scene import Accelerometer, HollowBall, Microphone

REPO = Path(__file__).resolve().parent.parent
FILES = sorted((REPO / "synth" / "presets").glob("*.toml"))
NAMES = [p.stem for p in FILES]
THESIS_FILES = [p for p in FILES if p.stem.startswith("thesis-") or p.stem == "default"]

# The thesis' balls: material row, radius (m, half the measured diameter) and weighed mass
# (kg), thesis Table 3.1 as quoted in docs/physics.md, "Materials".
BALLS = {
    "steel10": ("steel", 0.01000 / 2, 4.17e-3),
    "steel14": ("steel", 0.01430 / 2, 11.83e-3),
    "steel19": ("steel", 0.01900 / 2, 28.07e-3),
    "glass12": ("glass", 0.01255 / 2, 2.57e-3),
    "glass17": ("glass", 0.01700 / 2, 6.39e-3),
}
# The thesis' boards: material row, thickness, length, width (m), same table.
BOARDS = {
    "mdf18": ("mdf-18", 0.018, 1.227, 0.490),
    "mdf12": ("mdf-12", 0.012, 1.226, 0.4885),
    "mdf6": ("mdf-6", 0.00615, 1.200, 0.4895),
}
THESIS_NAME = re.compile(
    r"^thesis-(?P<ball>[a-z]+\d+)-(?P<board>mdf\d+)(?:-(?P<where>edge|corner|rolling))?$"
)


def _thesis_parts(path):
    """(ball key, board key, where) of a thesis preset; ``default`` is the thesis setup."""
    if path.stem == "default":
        return "steel10", "mdf18", None
    m = THESIS_NAME.match(path.stem)
    assert m is not None, (
        f"{path.name}: a thesis preset is named thesis-BALL-BOARD[-edge|-corner|-rolling]"
    )
    return m["ball"], m["board"], m["where"]


def _e1(name, *overrides):
    """First restitution of a preset's scene, optionally overridden."""
    return simulate_scene(load_preset(REPO / "synth" / "presets" / f"{name}.toml", overrides))[
        0
    ].result.restitution


# --------------------------------------------------------------------------- the collection


def test_collection_size():
    # The collection promises at least 12 scenes besides the default one.
    assert len([n for n in NAMES if n != "default"]) >= 12
    # And at least six thesis ball/board pairs plus the edge and corner drops.
    assert len([n for n in NAMES if n.startswith("thesis-")]) >= 8
    assert {"thesis-steel10-mdf18-edge", "thesis-steel10-mdf18-corner"} <= set(NAMES)


def test_collection_size_rejects_unknown_name():
    # A name outside the collection is an error that suggests the nearest names.
    with pytest.raises(PresetError, match="thesis-steel10-mdf6"):
        find("thesis-steel10-mdf7")


# --------------------------------------------------------------------------- every preset


@pytest.mark.parametrize("path", FILES, ids=NAMES)
def test_preset_loads(path):
    scene, render, data = load_preset_with_options(path)
    # A one-line description.
    desc = data.get("description")
    assert isinstance(desc, str) and desc.strip() and "\n" not in desc
    # Render options are limited to the sample rate (Hz) until the renderer settles the rest;
    # a rolling scene bounds its tail (a plate left ringing by a ball that rolled off it
    # rings for minutes, glass' loss factor being small).
    assert set(render) <= {"samplerate"} | ({"max_tail"} if scene.moving else set())
    if "samplerate" in render:
        assert render["samplerate"] == 48000
    # The listener hears the impact: a microphone 0.2 ... 0.5 m above the impact point, or an
    # accelerometer on the plate within 0.1 m of it (to 1e-12 m: positions are typed decimals).
    lst = scene.listener
    if isinstance(lst, Microphone):
        x, y, z = lst.position
        assert math.hypot(x - scene.position[0], y - scene.position[1]) <= 1e-12
        assert 0.2 <= z <= 0.5
    else:
        assert isinstance(lst, Accelerometer)
        x, y = lst.position
        assert math.hypot(x - scene.position[0], y - scene.position[1]) <= 0.1 + 1e-12


@pytest.mark.parametrize("path", FILES, ids=NAMES)
def test_preset_loads_rejects_unknown_key(path):
    # A misspelt key in any preset is an error naming the key (never silently ignored).
    with pytest.raises(PresetError, match=r"ball\.diameter"):
        load_preset(path, ["ball.diameter=0.01"])


@pytest.mark.parametrize("path", FILES, ids=NAMES)
def test_preset_scene_computes(path):
    scene = load_preset(path)
    seq = simulate_scene(scene)
    assert len(seq) >= 1
    assert seq.stop_reason != "solver-failure"
    g, h0 = scene.gravity, scene.drop_height
    # First impact after free fall from h0: t1 = sqrt(2 h0 / g), v1 = sqrt(2 g h0) (closed
    # form, docs/physics.md, "Bounces"), to rounding (1e-12 relative).
    assert seq[0].time == pytest.approx(math.sqrt(2.0 * h0 / g), rel=1e-12)
    assert seq[0].speed == pytest.approx(math.sqrt(2.0 * g * h0), rel=1e-12)
    from synth.physics.plate_choice import scene_plate

    ringing = scene_plate(scene).plate == "modal"  # contact.plate, or what "auto" chose
    for imp in seq:
        r = imp.result
        assert r.success
        # A plate at rest only takes energy from the ball: 0 <= e <= 1 (energy balance,
        # docs/physics.md, "Hertz contact"); a tolerance of 1e-9 covers the solver's rounding.
        # The modal plate rings after its first impact and may give energy back to the ball:
        # there its energy books must close (1e-4: second-order steps).
        if ringing and imp.index > 1:
            assert r.energy_residual < 1e-4
        else:
            assert -1e-9 <= r.restitution <= 1.0 + 1e-9
        # Contact times lie between ~10 us (steel on steel) and ~1 ms (heavy ball on a thin
        # plate), docs/physics.md, "Hertz contact"; a soft rubber ball is allowed a decade more
        # on a plate at rest. On a ringing plate a slow ball may ride the surface's motion
        # longer (the rubber ball's last bounces on its floor: 16 ms at a few cm/s). A hollow
        # ball bends instead of indenting: its contact is about its shell law's half period
        # pi sqrt(m / k0) (docs/physics.md, "Hollow balls"; 11 ms for a basketball), which
        # Pogorelov's softening lengthens.
        longest = 0.1 if ringing and imp.index > 1 else 1e-2
        if isinstance(scene.ball, HollowBall):
            longest = 2.0 * cost.hertz_contact_time(scene.ball, scene.plate, imp.speed)
        assert 1e-6 < r.contact_time < longest
    # Every scene of the collection bounces (no first-impact settling): e1 > 0.1.
    assert seq[0].result.restitution > 0.1
    # Each impact speed is the previous rebound speed (free flight is lossless, thesis A.2;
    # on the ringing modal plate the ball lands on a moving surface instead): the flight's
    # restitution, the contact's with the yield of the contact where it yields.
    for a, b in zip(seq, seq[1:]):
        if not ringing:
            assert b.speed == pytest.approx(a.restitution * a.speed, rel=1e-12)


@pytest.mark.parametrize("path", FILES, ids=NAMES)
def test_preset_scene_computes_rejects_drop_off_plate(path):
    # Moving any preset's impact point off its plate is an error naming drop.position.
    data = read(path)
    length = data["plate"]["length"]
    with pytest.raises(ParameterError, match=r"drop\.position"):
        load_preset(path, [f"drop.position=[{length + 0.1!r}, 0.0]"])


# --------------------------------------------------------------------------- thesis presets


@pytest.mark.parametrize("path", THESIS_FILES, ids=[p.stem for p in THESIS_FILES])
def test_thesis_masses(path):
    ball_key, board_key, where = _thesis_parts(path)
    material, radius, mass = BALLS[ball_key]
    scene = load_preset(path)
    # The weighed masses and measured diameters of thesis Table 3.1, exactly as printed.
    assert scene.ball.mass == mass
    assert scene.ball.radius == pytest.approx(radius, rel=1e-12)
    assert scene.ball.material is TABLE[material]
    plate_material, thickness, length, width = BOARDS[board_key]
    p = scene.plate
    assert p.material is TABLE[plate_material]
    assert (p.thickness, p.length, p.width) == pytest.approx((thickness, length, width), rel=1e-12)
    # The thesis' boards lay on air cushions (free edges) and the balls fell 10 cm.
    assert p.boundary == "free"
    assert scene.drop_height == 0.1
    x, y = scene.position
    if where in (None, "rolling"):  # the middle of the board (rolling: released from there)
        assert (x, y) == pytest.approx(p.centre, abs=1e-12)
    elif where == "edge":  # 20 mm from a long edge, mid-length
        assert (x, min(y, p.width - y)) == pytest.approx((p.length / 2, 0.020), abs=1e-12)
    else:  # 30 mm from both edges at a corner
        assert (min(x, p.length - x), min(y, p.width - y)) == pytest.approx(
            (0.030, 0.030), abs=1e-12
        )


@pytest.mark.parametrize("path", THESIS_FILES, ids=[p.stem for p in THESIS_FILES])
def test_thesis_masses_rejects_negative_mass(path):
    # A negative mass given to any thesis preset is an error naming ball.mass and its unit.
    with pytest.raises(PresetError, match=r"ball\.mass.*kg"):
        load_preset(path, ["ball.mass=-4.17e-3"])


def test_thesis_restitution_orders():
    # The thesis' model (contact.model="thesis", one key from the presets' "measured" and
    # "fitted"):
    # Zener's inelasticity lambda = K^(2/5) m^(3/5) v^(1/5) / Z grows as the board thins
    # (Z ~ h^2 sqrt(E)), so e falls from the 18 mm to the 12 mm to the 6.15 mm board
    # (docs/physics.md, "Hertz contact"); 0.05 separates them with margin (e: 0.87, 0.73, 0.30).
    model = "contact.model=thesis"
    e18 = _e1("default", model)
    e12, e6 = _e1("thesis-steel10-mdf12", model), _e1("thesis-steel10-mdf6", model)
    assert e18 - e12 > 0.05 and e12 - e6 > 0.05
    # Mid-plate 10 mm steel on 18 mm MDF: e = 0.87 at a 10 cm drop (thesis, docs/physics.md,
    # "Hertz contact"), to the figure's printed precision 0.005.
    assert e18 == pytest.approx(0.87, abs=0.005)
    # The board is softer at a free edge (Z_edge = 0.29 Z_inf) and softer still at a corner
    # (Z_corner = Z_inf / 7.5), thesis Table 3.4, so e falls from middle to edge to corner
    # (e: 0.87, 0.66, 0.52).
    e_edge = _e1("thesis-steel10-mdf18-edge", model)
    e_corner = _e1("thesis-steel10-mdf18-corner", model)
    assert e18 - e_edge > 0.05 and e_edge - e_corner > 0.05


def test_thesis_restitution_orders_rejects_bad_gravity():
    # A non-positive gravity given to a thesis preset is an error naming gravity.
    with pytest.raises(ParameterError, match="gravity"):
        _e1("default", "gravity=0")


def _contact_comments(path) -> str:
    """The comments of a preset file's ``[contact]`` section, joined."""
    section = re.search(r"^\[contact\]\n(.*?)(?=^\[|\Z)", path.read_text(), re.S | re.M)
    if section is None:
        return ""
    return " ".join(line.split("#", 1)[1] for line in section[1].splitlines() if "#" in line)


@pytest.mark.parametrize("path", FILES, ids=NAMES)
def test_contact_comments_name_the_loss_the_model_solves(path):
    # a preset's [contact] comments name the contact loss its model solves, and no
    # other: the fitted surface's (MDF's is the viscoelastic Hertz loss, not Hunt-Crossley) or
    # the law's own; an elastic contact names neither.
    from synth.physics.contact_law import resolved_surface
    from synth.physics.materials import contact_surface

    scene = load_preset(path)
    c = scene.contact
    resolved = resolved_surface(scene.plate, c.law, c.surface)
    if resolved == "fitted":
        surface = contact_surface(scene.plate.material)
        losses = {"viscoelastic" if surface.viscous_time > 0.0 else "hunt-crossley"}
    elif resolved == "material":  # the materials' loss factors as a viscoelastic loss
        losses = {"viscoelastic"}
    else:
        losses = {c.law} & {"viscoelastic", "hunt-crossley"}
    comments = _contact_comments(path).lower()
    for loss in ("viscoelastic", "hunt-crossley"):
        assert (loss in comments) == (loss in losses), (path.name, loss, comments)


def test_ping_pong_restitution_quoted_in_the_docs():
    # docs/physics.md, "Known limitations", quotes the ping-pong preset's first restitution as
    # e = 0.92 (a solid ABS sphere with ABS's loss factor as its contact loss), against about
    # 0.88 derived from the ITTF's table rule (Laws of Table Tennis 2.1.3: about 23 cm from a
    # 30 cm drop, sqrt(23 / 30)); the quoted figure is this preset's, to its two figures.
    assert _e1("ping-pong-on-wooden-table") == pytest.approx(0.92, abs=0.005)
    text = (REPO / "docs" / "physics.md").read_text()
    assert "e = 0.92" in text and "sqrt(23 / 30)" in text
