"""Every material's contact loss (synth.physics.contact_law.material_viscous_time): the table's
loss factors as a viscoelastic Hertz loss, and balls that settle."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks.docs import UNSETTLED_PAIRS
from synth.constants import DEFAULT_FLOOR_DB, GRAVITY
from synth.errors import ParameterError
from synth.physics import materials
from synth.physics.bounces import simulate_bounces
from synth.physics.contact import ContactSolver, solve_impact
from synth.physics.contact_law import (
    LOSS_REFERENCE_SPEED,
    TABOR_CONSTRAINT,
    contact_parameters,
    effective_modulus,
    hertz_contact_time,
    hertz_stiffness,
    material_loss_factor,
    material_viscous_time,
    model_yield_speed,
    plastic_restitution,
    yield_pressure,
    yield_rebound,
    yield_speed,
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


def test_yield_speed_is_where_the_hertz_peak_pressure_meets_the_hardness():
    # closed form of the elastic Hertz impact on a rigid flat: delta_m = (15 m v^2 /
    # (16 E* R^(1/2)))^(2/5), peak pressure p0 = (2 / pi) E* (delta_m / R)^(1/2); at V_y it is
    # the limiting pressure, the softer body's 2.8 Y (Tabor), either way round
    ball, plate = Ball("steel", RADIUS), _massive("copper")
    Y, e_star = plate.material.yield_stress, effective_modulus(ball, plate)
    assert yield_pressure(ball, plate) == TABOR_CONSTRAINT * Y
    assert yield_pressure(Ball("copper", RADIUS), _massive("steel")) == TABOR_CONSTRAINT * Y
    v_y = yield_speed(ball, plate)
    delta_m = (15.0 * ball.mass * v_y**2 / (16.0 * e_star * math.sqrt(RADIUS))) ** 0.4
    p0 = 2.0 / math.pi * e_star * math.sqrt(delta_m / RADIUS)
    assert p0 == pytest.approx(TABOR_CONSTRAINT * Y, rel=1e-12)
    # elastic up to V_y, continuous there (closed form: e(V_y) = 1), and v^(-1/4) far above
    assert plastic_restitution(0.5 * v_y, v_y) == 1.0
    assert plastic_restitution(v_y * (1.0 + 1e-12), v_y) == pytest.approx(1.0, abs=1e-9)
    far = [plastic_restitution(k * v_y, v_y) * k**0.25 for k in (1e6, 1e8)]
    assert far[0] == pytest.approx(far[1], rel=1e-3)
    assert plastic_restitution(3.0, None) == 1.0


#: The Leeb hardness tester's impact device D: an impact body of 5.5 g with a 3 mm tungsten
#: carbide ball launched with 11 mJ (2.0 m/s); HLD = 1000 v_rebound / v_impact is its
#: coefficient of restitution (PCE Instruments PCE-2800 and Mitech MH310 manuals, Table 3).
LEEB_D = dict(mass=5.5e-3, radius=1.5e-3, energy=11e-3)
#: Tungsten carbide: E 600-720 GPa, nu 0.18-0.24, rho 15300-15900 kg/m^3, middles taken
#: (Ashby, Materials Selection in Mechanical Design, 4th ed., 2011, Appendix C).
TUNGSTEN_CARBIDE = Material("tungsten-carbide", 15600.0, 660e9, 0.21)
#: Published pairings of a Leeb D reading with a static hardness of steel (N/m^2 from kgf/mm^2):
#: 600 HLD on a steel of about 400 HBW (Wikipedia, "Leeb rebound hardness test", on the
#: probe D's indentation), and 890 HLD, about 955 HV, the device's upper limit (Proceq,
#: Equotip 3 operating instructions, 2012, section 2.3).
LEEB_STEELS = ((0.600, 400.0 * 9.80665e6), (0.890, 955.0 * 9.80665e6))


def _leeb_restitution(hardness, pressure_ratio=1.0):
    """Thornton's e of the Leeb D probe on a massive steel of that hardness (Pa), its
    limiting pressure ``pressure_ratio`` times the hardness."""
    tip = Ball(TUNGSTEN_CARBIDE, LEEB_D["radius"], LEEB_D["mass"])
    steel = replace(
        materials.get("steel"), yield_stress=pressure_ratio * hardness / TABOR_CONSTRAINT
    )
    speed = math.sqrt(2.0 * LEEB_D["energy"] / LEEB_D["mass"])
    return plastic_restitution(speed, yield_speed(tip, _massive(steel)))


def test_thorntons_restitution_at_the_hardness_meets_the_leeb_rebound_of_steels():
    # published measurements: the Leeb rebound of a tungsten carbide tip on two steels.
    # Tolerance 0.1 in e, a bound of the closed form's error (elastic-perfectly plastic, no
    # hardening, no elastic-plastic transition), not a measured scatter: the sources quote
    # the pairings as approximate. The limiting pressure at the onset of yield instead
    # (Johnson's 1.6 Y, 0.57 of the hardness) misses both by more than 0.2
    page = (Path(__file__).parents[1] / "docs" / "validation.md").read_text()
    for measured, hardness in LEEB_STEELS:
        engine = _leeb_restitution(hardness)
        assert engine == pytest.approx(measured, abs=0.1)
        assert _leeb_restitution(hardness, 1.6 / TABOR_CONSTRAINT) < measured - 0.2
        # docs/validation.md's Leeb table holds these figures
        assert f"| {measured:.2f} | {engine:.2f} | {engine - measured:+.2f} |" in page


def test_brittle_materials_have_no_yield_and_a_bad_yield_stress_is_refused():
    for name in ("glass", "granite", "concrete", "porcelain"):
        assert materials.get(name).yield_stress is None
    assert yield_speed(Ball("glass", RADIUS), _massive("porcelain")) is None
    with pytest.raises(ParameterError, match="hard.yield_stress"):
        Material("hard", 7800.0, 200e9, 0.3, yield_stress=-1.0)
    with pytest.raises(ParameterError, match="v_yield"):
        plastic_restitution(1.0, -0.1)


def test_every_yield_stress_is_in_the_materials_page():
    # docs/materials.md, "Yield of the contact", prints each row's Y with its source
    page = (Path(__file__).parents[1] / "docs" / "materials.md").read_text()
    for name in materials.names():
        Y = materials.get(name).yield_stress
        if Y is not None:
            assert f"| {name} | {Y / 1e6:g} |" in page


def test_the_measured_model_yields_and_the_thesis_model_does_not():
    # an aluminium pair from 10 cm (1.40 m/s, above its yield speed of 0.30 m/s): the measured
    # surface's first flight is the contact solver's e times Thornton's (the closed form,
    # contact_law.plastic_restitution); the thesis' ideal surface stays elastic, and the
    # opt-in rule gives the same plastic loss on it
    ball, plate = Ball("aluminium", 0.006), _massive("aluminium")
    v_y = yield_speed(ball, plate)
    measured = simulate_bounces(ball, plate, drop_height=0.1, surface="auto", max_impacts=2)
    first = measured[0]
    assert first.speed > v_y
    thornton = plastic_restitution(first.speed, v_y)
    assert thornton < 0.9
    ideal = simulate_bounces(ball, plate, drop_height=0.1, max_impacts=2)
    assert ideal[0].restitution == ideal[0].result.restitution > 0.99
    # the yield is in the contact law: the solver's own rebound, Thornton's loss with the
    # small viscous and plate losses (0.1 % here) composed inside the force law, so within
    # that size of their product
    assert first.restitution == first.result.restitution
    elastic_loss = 1.0 - ideal[0].result.restitution
    assert first.restitution == pytest.approx(
        ideal[0].result.restitution * thornton, abs=elastic_loss
    )
    assert measured[1].speed == pytest.approx(first.restitution * first.speed, rel=1e-12)
    ruled = simulate_bounces(
        ball, plate, drop_height=0.1, max_impacts=2, rebound=yield_rebound(ball, plate)
    )
    assert ruled[0].restitution == pytest.approx(ideal[0].result.restitution * thornton, 1e-12)
    assert model_yield_speed(ball, plate, None, "ideal") is None
    assert model_yield_speed(ball, plate, "hunt-crossley", "auto") is None
    assert model_yield_speed(ball, plate, None, "auto") == pytest.approx(v_y, rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("ball_material", materials.names())
def test_every_pair_but_the_documented_near_elastic_ones_settles_from_one_metre(ball_material):
    # The measured contact model (its surface and the materials' yield) on every table
    # material: a drop from 1 m ends by a physical or perceptual rule before the scheduler's
    # max_duration (60 s) or its impact guard. A real pair of near-elastic materials does
    # (a small steel ball on a heavy steel plate "bounces dozens of times before its energy
    # is exhausted", UCLA Physics & Astronomy lecture demonstrations, "20. Coefficient of
    # Restitution"). A series ends within 60 s only if the mean of 1 - e over the speeds
    # from 0 to 4.43 m/s exceeds 2 v1 / (g 60 s) = 0.015 (the flights' sum, (2 / g) times
    # the integral of dv / (1 - e)): the fast bounces take the time. The pairs whose
    # contact yields there (Thornton, the table's yield stresses) settle; those that do not
    # (benchmarks.docs.UNSETTLED_PAIRS, docs/materials.md, "Coming to rest", which prints
    # their 1 - e) keep the elastic contact's 1 - e below that (the materials' bending-wave
    # loss factors and the plate's waves) and still bounce at 60 s: the loss of their
    # elastic range has no law here without a measured e(v) of such a ball. That set is
    # pinned, so that a fix shows; the target is every pair settling.
    ball = Ball(ball_material, RADIUS)
    v1 = math.sqrt(2.0 * GRAVITY * 1.0)
    floor_speed = v1 * 10.0 ** (DEFAULT_FLOOR_DB / 20.0)
    still = []
    for surface in materials.names():
        plate = _massive(surface)
        seq = simulate_bounces(ball, plate, drop_height=1.0, surface="auto")
        if seq.stop_reason not in ("max-duration", "max-impacts"):
            continue
        still.append(surface)
        # only near-elastic pairs whose slow impacts do not yield may go on
        assert _near_elastic(ball_material) and _near_elastic(surface), surface
        v_y = yield_speed(ball, plate)
        assert v_y is None or v_y >= floor_speed, (ball_material, surface, v_y)
        # below its yield speed the pair loses less than a series ending in 60 s needs
        need = 2.0 * v1 / (GRAVITY * 60.0)
        assert 1.0 - solve_impact(ball, plate, 1.0, surface="auto").restitution < need
    assert tuple(still) == UNSETTLED_PAIRS.get(ball_material, ())


# Thornton's elastic-perfectly plastic law inside the contact kernels: a 10 g ball of Hertz
# constant 1e10 N/m^1.5 on a rigid flat without gravity, yielding at 1 um
YIELD_MASS, YIELD_K, YIELD_DELTA = 0.01, 1e10, 1e-6
#: Yield speed of that contact: 1/2 m V_y^2 = (2/5) K delta_y^(5/2) (closed form).
YIELD_SPEED = math.sqrt(0.8 * YIELD_K * YIELD_DELTA**2.5 / YIELD_MASS)


def _yield_solver(method="auto", viscous_time=0.0, yield_penetration=YIELD_DELTA, **kw):
    return ContactSolver(
        YIELD_MASS, YIELD_K, 1.5, 0.0, gravity=0.0, method=method, viscous_time=viscous_time,
        yield_penetration=yield_penetration, **kw,
    )  # fmt: skip


@pytest.mark.parametrize("method", ["DOP853", "Radau"])
def test_the_kernels_restitute_as_thorntons_closed_form(method):
    # closed form (contact_law.plastic_restitution, Thornton 1997): the integrated
    # elastic-plastic contact rebounds at e(v / V_y), to the solver's tolerance
    solver = _yield_solver(method, rtol=1e-8)
    for ratio in (2.0, 10.0, 100.0):
        v = ratio * YIELD_SPEED
        res = solver.solve(v, admittance=0.0)
        assert res.restitution == pytest.approx(plastic_restitution(v, YIELD_SPEED), abs=1e-7)


def test_below_the_yield_penetration_the_law_is_hertz():
    # invariant: a contact that does not reach delta_y is the elastic law's, to rounding.
    # At 1.05 V_y on a plate of admittance 3e-4 m/(N s) the plate takes enough of the
    # energy that the peak stays below delta_y, while the energy bound alone (the rigid
    # flat's) would let it reach it: the kernels run the yield law's elastic branch
    v = 1.05 * YIELD_SPEED
    for A in (0.0, 1e-7):
        hertz = _yield_solver(viscous_time=A, yield_penetration=math.inf).solve(v, admittance=3e-4)
        law = _yield_solver(viscous_time=A).solve(v, admittance=3e-4)
        assert hertz.max_penetration < YIELD_DELTA
        assert law.restitution == pytest.approx(hertz.restitution, rel=1e-12)
        assert law.contact_time == pytest.approx(hertz.contact_time, rel=1e-12)
        assert law.peak_force == pytest.approx(hertz.peak_force, rel=1e-12)


def _elastic_plastic_force(delta, delta_max):
    """Thornton's force (N) at ``delta`` (m) after the largest penetration ``delta_max``."""
    dy, K = YIELD_DELTA, YIELD_K
    loading = np.where(
        delta <= dy, K * np.maximum(delta, 0.0) ** 1.5, K * dy**0.5 * (1.5 * delta - 0.5 * dy)
    )
    f_m = K * dy**0.5 * (1.5 * delta_max - 0.5 * dy)
    rho = math.sqrt(K * delta_max**1.5 / f_m)  # (R_p / R)^(1/2)
    residual = delta_max - f_m / (K * delta_max**0.5)
    unloading = K * rho * np.maximum(delta - residual, 0.0) ** 1.5
    return loading, unloading, f_m, residual


def test_the_lost_energy_is_the_plastic_work_and_the_viscous_loss():
    # invariant (energy balance on a rigid flat without gravity): 1/2 m (v_in^2 - v_out^2)
    # is the work of the elastic-plastic force around its loading and unloading path
    # (Thornton's law, closed form from the peak penetration) plus the viscous surface's
    # loss, the integral of the rest of the force over the penetration (from the pulse,
    # delta by integrating -F / m twice: the trapezoid rule on 8192 samples, ~1e-5)
    v = 10.0 * YIELD_SPEED
    res = _yield_solver(viscous_time=2e-7, rtol=1e-9, n_points=8192).solve(v, admittance=0.0)
    t, F = res.time, res.force
    speed = v - np.concatenate([[0.0], np.cumsum(0.5 * (F[1:] + F[:-1]) * np.diff(t))]) / YIELD_MASS
    delta = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    peak = int(np.argmax(delta))
    d_max = res.max_penetration
    loading, unloading, f_m, residual = _elastic_plastic_force(delta, d_max)
    elastic = np.where(np.arange(delta.size) <= peak, loading, unloading)
    viscous = np.sum(0.5 * ((F - elastic)[1:] + (F - elastic)[:-1]) * np.diff(delta))
    dy, K = YIELD_DELTA, YIELD_K
    loading_work = K * (dy**2.5 / 2.5 + dy**1.5 * (d_max - dy) + 0.75 * dy**0.5 * (d_max - dy) ** 2)
    plastic = loading_work - f_m * (d_max - residual) / 2.5
    lost = 0.5 * YIELD_MASS * v * v * (1.0 - res.restitution**2)
    assert viscous > 0.05 * plastic
    assert lost == pytest.approx(plastic + viscous, rel=1e-4)
