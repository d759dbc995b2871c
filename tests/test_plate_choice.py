"""The measured model by default: the plate in the contact chosen per scene
(``contact.plate = "auto"``, :mod:`synth.physics.plate_choice`), the material's fitted surface
where it has one (``contact.surface = "auto"``), and the thesis' model one option away."""

import math

import pytest

from synth.errors import ParameterError
from synth.io.presets import available, load_preset
from synth.physics import modal_contact as mc
from synth.physics.bounces import simulate_scene
from synth.physics.contact import solve_impact
from synth.physics.path import path_bounces
from synth.physics.plate_choice import (
    TOLERANCE,
    energy_shares_above,
    return_frequency,
    scene_plate,
)
from synth.physics.scene import DEFAULT_CONTACT_MODEL, Ball, Contact, HollowBall, Plate

#: The thesis' first impact, 10 mm steel ball on the 18 mm board from 10 cm: measured
#: restitution (section 3.2) and contact time (Table 3.3, force pulse), and the thesis' model's
#: restitution (section 3.2).
MEASURED_E, MEASURED_TAU, THESIS_MODEL_E = 0.76, 219e-6, 0.87


def _speed(scene):
    return math.sqrt(2.0 * scene.gravity * scene.drop_height)


def _full_modal_first(scene, position=None):
    """The scene's first impact with the finite plate's modes in the contact (its law and
    surface, the modal contact's default band and steps), at ``position`` (m; default the
    drop's)."""
    c = scene.contact
    v = _speed(scene)
    contact = mc.ModalContact.for_pair(
        scene.ball, scene.plate, scene.position if position is None else position,
        gravity=scene.gravity, law=c.law, speed=v, **c.options(),
    )  # fmt: skip
    return contact.solve(v)


def _first_impact(scene):
    """The scene's first impact as it renders it and where it lands (m from the plate's
    corner). A moving scene (a horizontal velocity) lands downstream of its release point and
    its path always takes the plate's impedance in the contact (its points move: no single
    point's modes); the vertical impact is a straight drop's at its landing point (the
    horizontal motion does not enter the normal contact, :mod:`synth.physics.path`)."""
    if scene.moving:
        bounces = path_bounces(scene)
        return bounces.impacts[0].result, tuple(bounces.points[0])
    return simulate_scene(scene, max_impacts=1)[0].result, scene.position


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(available()))
def test_every_presets_first_impact_agrees_with_the_full_modal_contact(name):
    # wherever the choice leaves the modes out, the first impact equals the full
    # modal contact's within its tolerance (1e-3 in e and relative in tau). One preset misses,
    # the 2 mm bead on acrylic: 2.1e-3 in e whatever the plate's size and boundary (a plate
    # three times larger, whose edges are three times farther, gives the same offset to 5e-5),
    # so the offset is the modal contact's own (its residual against the infinite plate for
    # that ball), not the reflections the choice weighs; asserted as that miss, under 2.5e-3.
    # A moving scene's first impact is checked at its landing point (_first_impact): the
    # impedance its path takes there must be the modes' answer too.
    scene = load_preset(name)
    if isinstance(scene.ball, HollowBall):
        # the modal contact integrates the power laws only: a hollow ball's shell law is
        # solved on the impedance plate everywhere, and the modes refuse it by name
        assert scene_plate(scene).plate == "impedance"
        with pytest.raises(ParameterError, match="hollow ball"):
            _full_modal_first(scene)
        return
    first, point = _first_impact(scene)
    full = _full_modal_first(scene, point)
    de = first.restitution - full.restitution
    dtau = first.contact_time / full.contact_time - 1.0
    assert abs(dtau) <= TOLERANCE, (name, dtau)
    if name != "small-click-on-acrylic":
        assert abs(de) <= TOLERANCE, (name, de)
        return
    assert scene_plate(scene).plate == "impedance"
    assert TOLERANCE < -de < 2.5e-3
    wide = load_preset(
        name,
        ["plate.length=0.6", "plate.width=0.45", "drop.position=[0.3, 0.225]",
         "listener.position=[0.3, 0.225, 0.3]"],
    )  # fmt: skip
    wide_de = simulate_scene(wide, max_impacts=1)[0].result.restitution
    wide_de -= _full_modal_first(wide).restitution
    assert wide_de == pytest.approx(de, abs=5e-5)


def test_default_preset_is_the_measured_model_on_the_impedance_plate():
    # the default preset's first impact within 0.02 of the measured
    # e = 0.76 and within 15 % of the measured 219 us (the bare ball: the thesis' 1 g
    # accelerometer lengthened its contact), on the impedance plate (the middle of the board:
    # no reflection returns within the contact; bound well below the tolerance).
    scene = load_preset("default")
    assert scene.contact.model == "measured"
    choice = scene_plate(scene)
    assert choice.plate == "impedance" and choice.bound < 0.5 * TOLERANCE
    first = simulate_scene(scene, max_impacts=1)[0].result
    assert first.restitution == pytest.approx(MEASURED_E, abs=0.02)
    assert first.contact_time == pytest.approx(MEASURED_TAU, rel=0.15)
    # the thesis' model is one option away, and unchanged (0.87, section 3.2)
    thesis = load_preset("default", ["contact.model=thesis"])
    assert simulate_scene(thesis, max_impacts=1)[0].result.restitution == pytest.approx(
        THESIS_MODEL_E, abs=0.01
    )


@pytest.mark.parametrize("name", ["thesis-steel10-mdf18-edge", "thesis-steel10-mdf18-corner"])
def test_modes_enter_the_contact_near_an_edge_and_a_corner(name):
    # 20 mm from an edge and 30 mm from a corner the reflections of most of the pulse return
    # within the contact: the measured model takes the finite plate's modes there.
    scene = load_preset(name, ["contact.model=measured"])
    choice = scene_plate(scene)
    assert choice.plate == "modal" and choice.bound > 10.0 * TOLERANCE


def test_return_frequency_is_the_round_trip_within_the_contact():
    # At omega_d the group speed 2 sqrt(omega) (D / rho h)^(1/4) carries the wave to the edge
    # and back in exactly the contact time (closed form, to rounding).
    plate = Plate("mdf-18", 0.018, 1.227, 0.49)
    d, tau = 0.1, 2e-4
    w = return_frequency(plate, d, tau)
    kappa = (plate.flexural_rigidity / plate.surface_density) ** 0.25
    assert 2.0 * d / (2.0 * math.sqrt(w) * kappa) == pytest.approx(tau, rel=1e-12)


def test_energy_share_falls_from_one_with_the_frequency():
    # The share of the pulse's energy above omega: all of it above 0, none above the
    # transform's Nyquist frequency, and never rising with omega (an invariant).
    r = solve_impact(Ball("steel", 0.005), Plate("mdf-18", 0.018, 1.227, 0.49), 1.4)
    shares = energy_shares_above(r, (0.0, 1e4, 3e4, 1e5, 3e5, 1e12))
    assert shares[0] == pytest.approx(1.0, abs=1e-12) and shares[-1] == 0.0
    assert all(a >= b for a, b in zip(shares, shares[1:]))


def test_auto_surface_is_the_fitted_one_where_the_material_has_one():
    # contact.surface = "auto": MDF's fitted surface, the materials' own losses for a
    # material without one (steel); a contact that names its surface keeps it.
    ball = Ball("steel", 0.005, 4.17e-3)
    mdf = Plate("mdf-18", 0.018, 1.227, 0.49)
    steel = Plate("steel", 0.002, 0.5, 0.4)
    for plate in (mdf, steel):
        auto = solve_impact(ball, plate, 1.4, surface="auto", rtol=1e-9)
        fitted_or_material = "fitted" if plate is mdf else "material"
        own = solve_impact(ball, plate, 1.4, surface=fitted_or_material, rtol=1e-9)
        assert auto.restitution == own.restitution
    assert Contact(model="measured").surface == "auto" and Contact().surface == "auto"
    # a scene built in Python gets the measured model unless it names another
    assert DEFAULT_CONTACT_MODEL == "measured" and Contact().plate == "auto"
    assert Contact(model="thesis").surface == "ideal"
