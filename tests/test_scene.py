"""Tests of synth.physics.scene: Ball, Plate, listeners and Scene."""

import dataclasses
import math

import pytest

from synth.errors import ParameterError
from synth.physics.materials import TABLE, Material
from synth.physics.scene import BOUNDARIES, Accelerometer, Ball, Microphone, Plate, Scene

BAD_POSITIVE = [0.0, -1.0, float("nan"), float("inf"), float("-inf"), "1", None, True]

# The thesis' 18 mm MDF board (docs/physics.md, "Materials"): 1227 x 490 x 18 mm.
A, B, H = 1.227, 0.490, 0.018


def mdf18():
    return Plate("mdf-18", H, A, B)


def ball10():
    return Ball("steel", 0.005)


# --------------------------------------------------------------------------- Ball


def test_ball_mass_from_density():
    # Closed form m = 4/3 pi r^3 rho; 1e-12 relative is float rounding.
    b = Ball("steel", 0.005)
    assert b.mass == pytest.approx(4.0 / 3.0 * math.pi * 0.005**3 * 7800.0, rel=1e-12)


@pytest.mark.parametrize(
    "rho, diameter, grams",
    [
        (7960.0, 10.00e-3, 4.17),
        (7730.0, 14.30e-3, 11.83),
        (7820.0, 19.00e-3, 28.07),
        (2480.0, 12.55e-3, 2.57),
        (2480.0, 17.00e-3, 6.39),
    ],
)
def test_ball_mass_matches_thesis_balls(rho, diameter, grams):
    # Published: thesis Table 3.1 lists each ball's density, diameter and weighed mass; the
    # sphere formula must reproduce the mass within 0.5 % (masses printed to 3-4 figures).
    m = Material("ball", rho, 216e9, 0.3)
    assert Ball(m, diameter / 2.0).mass == pytest.approx(grams * 1e-3, rel=5e-3)


def test_ball_explicit_mass_overrides_density():
    # An explicit mass (kg) is stored exactly, not recomputed from the density.
    b = Ball("steel", 0.005, mass=4.17e-3)
    assert b.mass == 4.17e-3


@pytest.mark.parametrize("name", ["steel", "Steel", "GLASS", " rubber "])
def test_ball_accepts_material_name(name):
    # A table name, in any case and with spaces, resolves to the table's own object.
    b = Ball(name, 0.01)
    assert b.material is TABLE[name.strip().lower()]


def test_ball_rejects_unknown_material():
    # An unknown name raises, naming ball.material and suggesting the nearest row.
    with pytest.raises(ParameterError, match=r"ball\.material.*'steel'"):
        Ball("stel", 0.005)


@pytest.mark.parametrize("bad", [None, 7800.0, ("steel",)])
def test_ball_rejects_material_of_wrong_type(bad):
    # Neither a Material nor a name: rejected, naming ball.material.
    with pytest.raises(ParameterError, match=r"ball\.material"):
        Ball(bad, 0.005)


def test_ball_is_frozen():
    # Scene objects are immutable (frozen dataclasses).
    with pytest.raises(dataclasses.FrozenInstanceError):
        ball10().radius = 1.0


# --------------------------------------------------------------------------- Plate


def test_plate_flexural_rigidity_thesis_mdf18():
    # D = E h^3 / (12 (1 - nu^2)) = 5.689e9 * 0.018^3 / (12 * 0.84) = 3291.49 N m.
    p = mdf18()
    assert p.flexural_rigidity == pytest.approx(5.689e9 * H**3 / (12.0 * (1.0 - 0.16)), rel=1e-12)
    # Printed to six figures: 1.5e-6 relative covers the rounding of 3291.49.
    assert p.flexural_rigidity == pytest.approx(3291.49, rel=1.5e-6)


def test_plate_surface_density_and_mass():
    # rho h = 700 * 0.018 = 12.6 kg/m^2; total mass rho h a b = 7.575 kg (float rounding only).
    p = mdf18()
    assert p.surface_density == pytest.approx(12.6, rel=1e-12)
    assert p.mass == pytest.approx(12.6 * A * B, rel=1e-12)


def test_plate_centre():
    # The centre is (a/2, b/2) exactly (division by two is exact in binary).
    assert mdf18().centre == (A / 2.0, B / 2.0)


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_plate_accepts_each_boundary(boundary):
    # Every documented boundary condition is accepted and stored as given.
    assert Plate("steel", 0.002, 0.5, 0.4, boundary).boundary == boundary


@pytest.mark.parametrize("bad", ["pinned", "Free", "", None, 0])
def test_plate_rejects_bad_boundary(bad):
    # Anything else (including a different case) is rejected, naming plate.boundary.
    with pytest.raises(ParameterError, match=r"plate\.boundary"):
        Plate("steel", 0.002, 0.5, 0.4, bad)


@pytest.mark.parametrize("name", ["mdf-18", "MDF-18", "Plywood"])
def test_plate_accepts_material_name(name):
    # A table name, in any case, resolves to the table's own object.
    assert Plate(name, H, A, B).material is TABLE[name.lower()]


def test_plate_rejects_unknown_material():
    # An unknown name raises, naming plate.material and suggesting the nearest row.
    with pytest.raises(ParameterError, match=r"plate\.material.*'mdf-18'"):
        Plate("mdf18", H, A, B)


@pytest.mark.parametrize("h, a, b", [(0.6, 1.0, 0.5), (0.5000001, 0.5, 1.0), (2.0, 1.0, 1.0)])
def test_plate_rejects_thickness_larger_than_side(h, a, b):
    # A thin-plate model cannot have h above the smaller side; 1e-7 m over is enough.
    with pytest.raises(ParameterError, match=r"plate\.thickness.*smaller side"):
        Plate("steel", h, a, b)


@pytest.mark.parametrize(
    "xy",
    [
        (0.0, 0.0),
        (A, 0.0),
        (0.0, B),
        (A, B),  # corners
        (A / 2.0, 0.0),
        (0.0, B / 2.0),
        (A, 0.3),
        (0.7, B),  # edges
        (0.3, 0.2),
    ],
)
def test_check_position_accepts_corners_edges_and_inside(xy):
    # The plate is closed: corners and edges are on it, returned as floats exactly.
    assert mdf18().check_position(xy) == (float(xy[0]), float(xy[1]))


@pytest.mark.parametrize(
    "xy", [(-1e-9, 0.0), (A + 1e-9, 0.0), (0.0, -1e-6), (0.1, B + 1e-6), (5.0, 5.0)]
)
def test_check_position_rejects_off_plate(xy):
    # 1 nm outside any edge is off the plate; the message starts with the field name.
    with pytest.raises(ParameterError, match=r"^position=.*off the plate"):
        mdf18().check_position(xy)


@pytest.mark.parametrize(
    "bad, match",
    [
        ((float("nan"), 0.1), r"position\.x"),
        ((0.1, float("inf")), r"position\.y"),
        ((0.1,), "2 coordinates"),
        ((0.1, 0.1, 0.1), "2 coordinates"),
        (0.1, "sequence"),
        (("a", 0.1), r"position\.x"),
    ],
)
def test_check_position_rejects_malformed(bad, match):
    # Non-finite coordinates, wrong length, non-sequences and non-numbers are rejected.
    with pytest.raises(ParameterError, match=match):
        mdf18().check_position(bad)


def test_check_position_rejects_naming_given_field():
    # The caller's field name is the one in the message.
    with pytest.raises(ParameterError, match=r"^pickup="):
        mdf18().check_position((2.0, 0.1), "pickup")


# --------------------------------------------------------------------------- listeners


def test_microphone_stores_position():
    # (x, y, z) in metres is stored exactly as a tuple of floats.
    assert Microphone((0.1, 0.2, 0.3)).position == (0.1, 0.2, 0.3)


@pytest.mark.parametrize("z", [0.0, -0.1, -1e-12])
def test_microphone_rejects_z_not_above_plate(z):
    # z is the height above the plate: z <= 0 is on or behind the baffle.
    with pytest.raises(ParameterError, match=r"listener\.position\.z"):
        Microphone((0.1, 0.1, z))


@pytest.mark.parametrize("bad", [(0.1, 0.1), (0.1, 0.1, float("nan")), None, (0.1, "y", 0.2)])
def test_microphone_rejects_malformed(bad):
    # Wrong length, non-finite or non-numeric coordinates are rejected.
    with pytest.raises(ParameterError, match=r"listener\.position"):
        Microphone(bad)


def test_accelerometer_stores_position():
    # A list (x, y) in metres is stored exactly as a tuple of floats.
    assert Accelerometer([0.1, 0.2]).position == (0.1, 0.2)


@pytest.mark.parametrize("bad", [(0.1,), (0.1, 0.2, 0.3), (float("inf"), 0.1), 3.0])
def test_accelerometer_rejects_malformed(bad):
    # Wrong length, non-finite or scalar positions are rejected.
    with pytest.raises(ParameterError, match=r"listener\.position"):
        Accelerometer(bad)


# --------------------------------------------------------------------------- Scene


def test_scene_defaults():
    # Documented defaults (exact: halves of the sides, 0.2 m, 9.81 m/s^2).
    s = Scene(ball10(), mdf18(), drop_height=0.1)
    # Default impact point: the centre; default listener: a microphone 0.2 m above it.
    assert s.position == (A / 2.0, B / 2.0)
    assert isinstance(s.listener, Microphone)
    assert s.listener.position == (A / 2.0, B / 2.0, 0.2)
    assert s.gravity == 9.81
    assert s.drop_height == 0.1


def test_scene_default_listener_follows_position():
    # The default microphone is 0.2 m above the given impact point.
    s = Scene(ball10(), mdf18(), drop_height=0.1, position=[0.2, 0.1])
    assert s.position == (0.2, 0.1)
    assert s.listener.position == (0.2, 0.1, 0.2)


def test_scene_accepts_listeners_on_corner_and_in_air():
    # An accelerometer on a corner is on the plate; a microphone needs only z > 0.
    s = Scene(ball10(), mdf18(), drop_height=0.1, listener=Accelerometer((A, B)))
    assert s.listener.position == (A, B)
    # A microphone may be anywhere above the plane, even beyond the plate's outline.
    s = Scene(ball10(), mdf18(), drop_height=0.1, listener=Microphone((-1.0, 3.0, 0.5)))
    assert s.listener.position == (-1.0, 3.0, 0.5)


def test_scene_rejects_ball_larger_than_plate():
    # Ball diameter 0.22 m > smaller side 0.2 m.
    plate = Plate("steel", 0.002, 0.3, 0.2)
    with pytest.raises(ParameterError, match=r"ball\.radius.*too large"):
        Scene(Ball("steel", 0.11), plate, drop_height=0.1)
    # Exactly the side is still allowed (diameter == 0.2 m).
    assert Scene(Ball("steel", 0.1), plate, drop_height=0.1).ball.radius == 0.1


@pytest.mark.parametrize("pos", [(-0.01, 0.1), (A + 0.01, 0.1), (0.1, B + 0.01)])
def test_scene_rejects_position_off_plate(pos):
    # An impact point 1 cm off any edge is rejected, naming drop.position.
    with pytest.raises(ParameterError, match=r"^drop\.position="):
        Scene(ball10(), mdf18(), drop_height=0.1, position=pos)


@pytest.mark.parametrize("pos", [(float("nan"), 0.1), (0.1,), "centre"])
def test_scene_rejects_malformed_position(pos):
    # Non-finite, short or non-numeric positions are rejected, naming drop.position.
    with pytest.raises(ParameterError, match=r"drop\.position"):
        Scene(ball10(), mdf18(), drop_height=0.1, position=pos)


def test_scene_rejects_accelerometer_off_plate():
    # An accelerometer must sit on the plate.
    with pytest.raises(ParameterError, match=r"^listener\.position=.*off the plate"):
        Scene(ball10(), mdf18(), drop_height=0.1, listener=Accelerometer((A + 0.1, 0.1)))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(ball="steel"), r"^ball="),
        (dict(plate="mdf-18"), r"^plate="),
        (dict(listener=(0.1, 0.1, 0.2)), r"^listener="),
    ],
)
def test_scene_rejects_wrong_object_types(kwargs, match):
    # ball, plate and listener must be the scene objects, not names or tuples.
    args = dict(ball=ball10(), plate=mdf18(), drop_height=0.1)
    args.update(kwargs)
    with pytest.raises(ParameterError, match=match):
        Scene(**args)


# --------------------------------------------------------------------------- numeric fields


def _ball(field, value):
    kwargs = dict(material="steel", radius=0.005, mass=None)
    kwargs[field] = value
    return Ball(**kwargs)


def _plate(field, value):
    kwargs = dict(material="mdf-18", thickness=H, length=A, width=B)
    kwargs[field] = value
    return Plate(**kwargs)


def _scene(field, value):
    kwargs = dict(ball=ball10(), plate=mdf18(), drop_height=0.1, gravity=9.81)
    kwargs[field] = value
    return Scene(**kwargs)


# (constructor, field, name in messages, a valid value of the field)
NUMERIC_FIELDS = [
    (_ball, "radius", "ball.radius", 0.004),
    (_ball, "mass", "ball.mass", 0.004),
    (_plate, "thickness", "plate.thickness", 0.004),
    (_plate, "length", "plate.length", 0.8),
    (_plate, "width", "plate.width", 0.3),
    (_scene, "drop_height", "drop.height", 0.05),
    (_scene, "gravity", "gravity", 1.62),
]

# Every field against every bad value, except mass=None, which means "from the density".
BAD_CASES = [
    (make, field, label, bad)
    for make, field, label, _ in NUMERIC_FIELDS
    for bad in BAD_POSITIVE
    if not (field == "mass" and bad is None)
]


@pytest.mark.parametrize("make, field, label, good", NUMERIC_FIELDS)
def test_numeric_field_accepts_positive(make, field, label, good):
    # A positive finite value is stored exactly as given.
    obj = make(field, good)
    assert getattr(obj, field) == good


@pytest.mark.parametrize("make, field, label, bad", BAD_CASES)
def test_numeric_field_rejects_bad_value(make, field, label, bad):
    # 0, negatives, NaN, infinities and non-numbers raise, naming the field first.
    with pytest.raises(ParameterError) as info:
        make(field, bad)
    assert str(info.value).startswith(label + "=")
