"""Every material's contact loss (synth.physics.contact_law.material_viscous_time): the table's
loss factors as a viscoelastic Hertz loss, and balls that settle."""

import math

import pytest

from synth.errors import ParameterError
from synth.physics import materials
from synth.physics.bounces import simulate_bounces
from synth.physics.contact import solve_impact
from synth.physics.contact_law import (
    LOSS_REFERENCE_SPEED,
    contact_parameters,
    hertz_contact_time,
    hertz_stiffness,
    material_loss_factor,
    material_viscous_time,
)
from synth.physics.materials import MDF_SURFACE, LossFactor, Material, Rayleigh
from synth.physics.scene import Ball, Contact, Plate

#: A massive surface: a 1 m square, 0.1 m thick plate of the surface's material (its
#: impedance is 10^3 to 10^6 times the contact's, so the plate takes little of the energy).
MASSIVE = dict(thickness=0.1, length=1.0, width=1.0)
#: The ball of the settling test: a solid sphere of 20 mm radius.
RADIUS = 0.02
#: Loss factor below which a table material is near-elastic (metals, glass, ceramics,
#: stone, polycarbonate: 1e-4 ... 7e-3 in the table).
NEAR_ELASTIC = 0.01


def _massive(name):
    return Plate(name, **MASSIVE)


def test_viscous_time_is_each_body_loss_weighted_by_its_share_of_the_indentation():
    # A = E* (A_b / E'_b + A_p / E'_p), A_i = eta_i tau_c / pi, tau_c the elastic Hertz
    # contact time at the reference speed (the definition, computed by hand)
    ball, plate = Ball("rubber", RADIUS), _massive("oak")
    K = hertz_stiffness(ball, plate)
    tau_c = 2.9433 * (5.0 * ball.mass * LOSS_REFERENCE_SPEED**2 / (4.0 * K)) ** 0.4
    tau_c /= LOSS_REFERENCE_SPEED
    assert hertz_contact_time(ball.mass, K, LOSS_REFERENCE_SPEED) == pytest.approx(tau_c, 1e-14)
    eb, ep = ball.material.effective_modulus, plate.material.effective_modulus
    e_star = 1.0 / (1.0 / eb + 1.0 / ep)
    want = e_star * (0.05 / eb + 0.01 / ep) * tau_c / math.pi
    assert material_viscous_time(ball, plate) == pytest.approx(want, rel=1e-12)
    law = contact_parameters(ball, plate, "hertz", surface="material")
    assert (law.exponent, law.dissipation) == (1.5, 0.0)
    assert law.viscous_time == material_viscous_time(ball, plate)
    # the soft ball takes nearly all the indentation, so its loss is nearly all of A
    assert material_viscous_time(ball, plate) == pytest.approx(0.05 * tau_c / math.pi, rel=1e-2)


def test_loss_factor_of_a_rayleigh_law_at_a_frequency():
    # sigma = alpha/2 + beta omega^2 / 2 is eta omega / 2 with eta = alpha/omega + beta omega
    mdf = materials.get("mdf-18")
    omega = 2.0 * math.pi * 1000.0
    assert material_loss_factor(mdf, omega) == pytest.approx(35.0 / omega + 5e-7 * omega)
    assert material_loss_factor(materials.get("steel"), omega) == 1e-4
    elastic = Material("elastic", 7800.0, 200e9, 0.3)  # a ball's material without damping
    assert material_loss_factor(elastic, omega) == 0.0


def test_lossless_materials_bounce_as_the_thesis_model():
    # without a damping law on either side the material surface is the elastic Hertz law
    glassy = Material("glassy", 2480.0, 70e9, 0.2)
    ball = Ball(glassy, 0.006)
    plate = Plate(Material("board", 700.0, 5e9, 0.4, Rayleigh(0.0, 0.0)), 0.018, 1.0, 0.5)
    assert material_viscous_time(ball, plate) == 0.0
    a = solve_impact(ball, plate, 1.4, surface="material", rtol=1e-9)
    b = solve_impact(ball, plate, 1.4, surface="ideal", rtol=1e-9)
    assert a.restitution == b.restitution


def test_fitted_surface_keeps_its_fit_for_steel_and_takes_another_ball_loss():
    mdf = Plate("mdf-18", 0.018, 1.227, 0.49)
    steel = Ball("steel", 0.005, 4.17e-3)
    assert contact_parameters(steel, mdf, surface="fitted").viscous_time == MDF_SURFACE.viscous_time
    # a rubber ball takes most of the indentation: its own loss dominates, the board's fitted
    # term falls with its share E*/E'_t (about 0.06)
    rubber = Ball("rubber", 0.02)
    A = contact_parameters(rubber, mdf, surface="fitted").viscous_time
    own = material_viscous_time(rubber, mdf, MDF_SURFACE.transverse_ratio, plate_share=0.0)
    assert own < A < own + 0.1 * MDF_SURFACE.viscous_time


def test_material_surface_applies_to_hertz_only():
    ball, plate = Ball("abs", 0.02), _massive("oak")
    with pytest.raises(ParameterError, match="surface='material'"):
        contact_parameters(ball, plate, "elastic-foundation", surface="material")
    with pytest.raises(ParameterError, match="contact.surface='material'"):
        Contact(law="power-law", exponent=1.5, stiffness=1e9, surface="material")
    with pytest.raises(ParameterError, match="surface"):
        contact_parameters(ball, plate, "hertz", surface="best")


def _near_elastic(name):
    damping = materials.get(name).damping
    return isinstance(damping, LossFactor) and damping.eta < NEAR_ELASTIC


@pytest.mark.slow
@pytest.mark.parametrize("ball_material", materials.names())
def test_every_material_pair_settles_from_one_metre_on_a_massive_surface(ball_material):
    # The measured contact (the default model's surface) on every table material: a drop
    # from 1 m ends by a physical or perceptual rule before the scheduler's max_duration
    # (60 s) or its impact guard. Pairs of two near-elastic materials (loss factors of
    # 1e-4 to 7e-3, measured on bending waves) lose too little in the contact to settle by
    # then, and that is a miss, not a property of such pairs: a small steel ball on a heavy
    # steel plate "bounces dozens of times before its energy is exhausted" (UCLA Physics &
    # Astronomy lecture demonstrations, "20. Coefficient of Restitution"), and a steel ball
    # "can be locally compressed beyond its elastic limit in a relatively low-speed
    # collision" (R. Cross, "The bounce of a ball", Am. J. Phys. 67 (1999) 222, section I).
    # The engine has no yield law, and no published e(v) of a metal or glass ball has been
    # read to check one against (docs/validation.md, "Restitution of solid balls"); those
    # pairs are reported as the expected failure, the others asserted.
    ball = Ball(ball_material, RADIUS)
    stuck = []
    for surface in materials.names():
        seq = simulate_bounces(ball, _massive(surface), drop_height=1.0, surface="auto")
        if seq.stop_reason in ("max-duration", "max-impacts"):
            stuck.append(surface)
    lossy = [s for s in stuck if not (_near_elastic(ball_material) and _near_elastic(s))]
    assert lossy == [], f"{ball_material} does not settle on {lossy}"
    if stuck:
        pytest.xfail(
            f"near-elastic pairs still bouncing at 60 s, where measured ones come to rest "
            f"(no yield law): {ball_material} on {stuck}"
        )
