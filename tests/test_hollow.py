"""Hollow balls: the thin-shell contact law's closed forms, its energy balance, its checks,
the rule books' bounce tests (docs/validation.md, "Hollow balls") and a preset's render."""

import functools
import math
import re
from pathlib import Path

import numpy as np
import pytest

import synth
from benchmarks.hollow import RULE_BOOK_TESTS, format_hollow, shell_elastic_force
from benchmarks.hollow import rule_book_row as _rule_book_row
from synth.constants import AIR_DENSITY
from synth.io.presets import PresetError, load_preset, scene_from_dict
from synth.physics.contact import ContactSolver, solve_impact
from synth.physics.contact_law import POGORELOV_CONSTANT, shell_law
from synth.physics.materials import Material
from synth.physics.scene import Contact, HollowBall, Plate, Scene


@functools.cache
def rule_book_row(test):
    """:func:`benchmarks.hollow.rule_book_row` of ``test`` (two shell contacts at rtol 1e-9),
    computed once for the module: a pure function of the test, read by several tests."""
    return _rule_book_row(test)


#: A lossless shell material (no damping law: the shell's loss is 0), ABS's elastic constants.
ELASTIC_SHELL = Material("elastic-shell", 1050.0, 2.2e9, 0.39)
#: A massive, rigid-like surface: a 0.5 m steel plate takes ~1e-7 of a light ball's energy.
RIGID = Plate("steel", 0.5, 1.0, 1.0)


def _ball(pressure=0.0, material=ELASTIC_SHELL):
    return HollowBall(material, 0.02, thickness=5e-4, pressure=pressure)


def _lumped(ball, speed, **kw):
    """The impact on a perfectly rigid flat (admittance 0) without gravity."""
    solver = ContactSolver.for_pair(ball, RIGID, law="shell", gravity=0.0, **kw)
    return solver.solve(speed, admittance=0.0)


def test_mass_is_the_shells_and_the_gas():
    b = _ball(pressure=1e5)
    shell = 1050.0 * 4.0 / 3.0 * math.pi * (0.02**3 - 0.0195**3)
    gas = (101325.0 + 1e5) / (287.05 * 293.15) * 4.0 / 3.0 * math.pi * 0.0195**3
    assert b.mass == pytest.approx(shell + gas, rel=1e-12)


def test_reissner_stiffness_sets_the_small_deflection_contact():
    # Reissner: k_R = 4 E h^2 / (R sqrt(3 (1 - nu^2))); below delta_t the contact is a linear
    # spring on a rigid flat: a half period pi sqrt(m / k_R), e = 1, delta_max = v sqrt(m / k)
    b = _ball()
    law = shell_law(b)
    k = 4.0 * 2.2e9 * 5e-4**2 / (0.02 * math.sqrt(3.0 * (1.0 - 0.39**2)))
    assert law.reissner_stiffness == pytest.approx(k, rel=1e-14)
    v = 0.5 * law.transition * math.sqrt(k / b.mass)  # peak deflection delta_t / 2
    r = _lumped(b, v, rtol=1e-9)
    assert r.contact_time == pytest.approx(math.pi * math.sqrt(b.mass / k), rel=1e-8)
    assert r.max_penetration == pytest.approx(0.5 * law.transition, rel=1e-8)
    assert r.restitution == pytest.approx(1.0, abs=1e-8)


def test_pogorelov_law_at_large_deflection():
    # Pogorelov: F = 3.56 E h^(5/2) delta^(1/2) / (R (1 - nu^2)^(3/4)) beyond delta_t. On a
    # rigid flat the energy m v^2 / 2 = k_R dt^2 / 2 + 2/3 C_P (d^(3/2) - dt^(3/2)) gives
    # the peak deflection d and the peak force C_P d^(1/2) in closed form.
    b = _ball()
    law = shell_law(b)
    cP = POGORELOV_CONSTANT * 2.2e9 * 5e-4**2.5 / (0.02 * (1.0 - 0.39**2) ** 0.75)
    assert law.pogorelov_constant == pytest.approx(cP, rel=1e-14)
    dt = law.transition
    assert shell_elastic_force(law, 10.0 * dt) == pytest.approx(
        cP * math.sqrt(10.0 * dt), rel=1e-14
    )
    assert shell_elastic_force(law, 0.1 * dt) == pytest.approx(law.reissner_stiffness * 0.1 * dt)
    v = 20.0  # m/s, a smash
    energy = 0.5 * b.mass * v * v
    d = ((energy - 0.5 * law.reissner_stiffness * dt * dt) * 1.5 / cP + dt**1.5) ** (2.0 / 3.0)
    assert d > 2.0 * dt  # the contact goes well into Pogorelov's range
    r = _lumped(b, v, rtol=1e-9)
    assert r.max_penetration == pytest.approx(d, rel=1e-7)
    assert r.peak_force == pytest.approx(cP * math.sqrt(d), rel=1e-7)


def test_gas_pressure_on_the_flat_contact():
    # k_g = 2 pi R p: the gauge pressure on the flat contact's area pi (2 R delta)
    b = _ball(pressure=5e4)
    law = shell_law(b)
    assert law.gas_stiffness == pytest.approx(2.0 * math.pi * 0.02 * 5e4, rel=1e-14)
    assert shell_elastic_force(law, 1e-4) == pytest.approx(
        law.reissner_stiffness * 1e-4 + law.gas_stiffness * 1e-4, rel=1e-14
    )


@pytest.mark.parametrize("speed", [0.3, 3.0, 8.0])
@pytest.mark.parametrize("pressure", [0.0, 8e4])
@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_no_loss_gives_e_one_within_the_tolerance(speed, pressure, rtol):
    # energy balance: without loss (a shell material without damping) on a rigid flat,
    # with gravity, the ball leaves at its impact speed within the solver's tolerance
    b = _ball(pressure)
    solver = ContactSolver.for_pair(b, RIGID, law="shell", rtol=rtol)
    r = solver.solve(speed, admittance=0.0)
    assert r.success and r.status == 0
    assert r.restitution == pytest.approx(1.0, abs=rtol)
    assert r.energy_residual < rtol


def test_shell_loss_is_the_materials_loss_factor():
    # A = eta / omega_c with omega_c = sqrt(k0 / m) (docs/physics.md, "Hollow balls")
    b = HollowBall("abs", 0.02, thickness=5.2e-4)
    law = shell_law(b)
    omega = math.sqrt(law.stiffness / b.mass)
    assert law.viscous_time == pytest.approx(0.02 / omega, rel=1e-14)
    # a small loss: to first order the linear Kelvin-Voigt oscillator's e = exp(-pi eta / 2)
    # (zeta = eta / 2); at a small deflection (linear range) within its second-order terms
    speed = 0.2 * law.transition * omega
    r = _lumped(b, speed, rtol=1e-9)
    assert r.restitution == pytest.approx(math.exp(-math.pi * 0.02 / 2.0), abs=2e-3)
    assert r.energy_residual < 1e-8


def test_solve_impact_and_the_force_pulse():
    b = HollowBall("abs", 0.02, thickness=5.2e-4)
    plate = Plate("plywood", 0.025, 2.74, 1.525)
    r = solve_impact(b, plate, 2.45, contact="shell", position=(0.685, 0.7625))
    assert r.success
    # the pulse integrates to the impulse (trapezoid on the dense output, fine grid)
    t = np.linspace(0.0, r.separation_time, 20001)
    assert np.trapezoid(r.force_at(t), t) == pytest.approx(r.impulse, rel=1e-4)
    assert r.force.max() <= r.peak_force * (1 + 1e-9)


def test_parameter_errors_name_the_field():
    with pytest.raises(synth.ParameterError, match=r"ball\.thickness=0\.02 must be in"):
        HollowBall("abs", 0.02, thickness=0.02)
    with pytest.raises(synth.ParameterError, match=r"ball\.pressure=-1\.0 must be in"):
        HollowBall("abs", 0.02, thickness=5e-4, pressure=-1.0)
    with pytest.raises(synth.ParameterError, match=r"ball\.mass=0\.0027: a hollow ball's mass"):
        HollowBall("abs", 0.02, 0.0027, thickness=5e-4)
    with pytest.raises(synth.ParameterError, match=r"ball\.thickness is required"):
        HollowBall("abs", 0.02)
    b = _ball()
    with pytest.raises(synth.ParameterError, match=r"contact='hertz': a HollowBall's contact"):
        solve_impact(b, RIGID, 1.0, contact="hertz")
    # no law named: the ball's own
    assert (
        solve_impact(b, RIGID, 1.0).restitution
        == solve_impact(b, RIGID, 1.0, contact="shell").restitution
    )
    with pytest.raises(synth.ParameterError, match=r"the modal contact integrates the power"):
        synth.simulate_bounces(b, RIGID, drop_height=0.3, plate_model="modal")
    with pytest.raises(synth.ParameterError, match=r"contact='shell' applies to a HollowBall"):
        solve_impact(synth.Ball("steel", 0.01), RIGID, 1.0, contact="shell")
    with pytest.raises(synth.ParameterError, match=r"contact\.law='hertz': a hollow ball"):
        Scene(b, RIGID, drop_height=0.3, contact=Contact(law="hertz"))
    with pytest.raises(synth.ParameterError, match=r"contact\.plate='modal' does not take"):
        Scene(b, RIGID, drop_height=0.3, contact=Contact(law="shell", plate="modal"))
    assert Scene(b, RIGID, drop_height=0.3).contact.law == "shell"


def test_preset_ball_kind():
    data = {
        "ball": {"kind": "hollow", "material": "abs", "radius": 0.02, "thickness": 5e-4},
        "plate": {"material": "steel", "thickness": 0.01, "length": 1.0, "width": 1.0},
        "drop": {"height": 0.3},
        "contact": {"plate": "impedance"},
    }
    scene, _ = scene_from_dict(data)
    assert isinstance(scene.ball, HollowBall) and scene.contact.law == "shell"
    with pytest.raises(PresetError, match=r"ball\.kind='hollo' must be one of"):
        scene_from_dict({**data, "ball": {**data["ball"], "kind": "hollo"}})
    solid = {"material": "abs", "radius": 0.02, "thickness": 5e-4}
    with pytest.raises(PresetError, match=r"ball\.thickness=0\.0005 applies to ball\.kind="):
        scene_from_dict({**data, "ball": solid})


#: The rule books' bounce tests: every hollow ball of the presets rebounds above the rule
#: book's range, the air's drag on its fall and rise taken in (a published drag coefficient
#: per ball), because the shell's published loss factor is the only loss of its impact (a
#: real ball also loses energy to its felt (tennis), its wall's ringing and its seams;
#: docs/physics.md, "Hollow balls"). The engine's rebound (m, as the rule book measures it,
#: through the air) and without the air's drag, with the tolerance of the solver (rtol 1e-9)
#: and of the printed digits: these figures are the ones docs/validation.md prints.
ENGINE_REBOUND = {
    "table-tennis-ball-on-table": (0.267, 0.287),
    "tennis-ball-on-concrete": (2.214, 2.416),
    "basketball-on-wooden-floor": (1.641, 1.744),
}


@pytest.mark.parametrize("test", RULE_BOOK_TESTS, ids=lambda t: t.preset)
def test_rule_book_bounce_is_missed_high(test):
    row = rule_book_row(test)
    in_air, in_vacuum = ENGINE_REBOUND[test.preset]
    assert row.rebound == pytest.approx(in_air, abs=5e-4)
    assert row.rebound_in_vacuum == pytest.approx(in_vacuum, abs=5e-4)
    # the miss, asserted as one: above the range's upper end
    assert row.rebound > test.rebound_high
    assert row.error > 0.0


def _flight_with_drag(v_t, up_speed=None, height=None, step=1e-5):
    """RK4 of ``dv/dt = -g - g v |v| / v_t^2`` (quadratic drag against the motion) and
    ``dz/dt = v``: thrown up at ``up_speed`` (m/s), the height reached (m); released from rest
    at ``height`` (m), the speed at the ground (m/s). The crossing is interpolated linearly
    within the last step (its error is far below the test's tolerance)."""
    g = 9.81

    def rate(state):
        v = state[1]
        return np.array([v, -g - g * v * abs(v) / v_t**2])

    up = up_speed is not None
    state = np.array([0.0, up_speed]) if up else np.array([height, 0.0])
    i = 1 if up else 0  # the component that crosses 0 at the end
    last = state
    while state[i] > 0.0 or state is last:
        k1 = rate(state)
        k2 = rate(state + 0.5 * step * k1)
        k3 = rate(state + 0.5 * step * k2)
        k4 = rate(state + step * k3)
        last, state = state, state + step / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    w = last[i] / (last[i] - state[i])
    end = last + w * (state - last)
    return end[0] if up else abs(end[1])


def test_flights_through_the_air_are_the_closed_forms():
    # the rule books measure heights in air: the fall's speed and the rise's height with
    # quadratic drag against a direct integration, and their limits without drag
    from benchmarks.hollow import fall_speed, rise_height, terminal_speed

    v_t = terminal_speed(0.0027, 0.02, 0.445)
    # m g = rho C_D pi R^2 v_t^2 / 2 at the terminal speed
    drag = 0.5 * AIR_DENSITY * 0.445 * math.pi * 0.02**2 * v_t**2
    assert drag == pytest.approx(0.0027 * 9.81, rel=1e-14)
    assert fall_speed(0.305, v_t) == pytest.approx(_flight_with_drag(v_t, height=0.305), rel=1e-6)
    assert rise_height(2.3, v_t) == pytest.approx(_flight_with_drag(v_t, up_speed=2.3), rel=1e-6)
    # without drag (v_t -> infinity): sqrt(2 g h) and v^2 / (2 g)
    assert fall_speed(0.305, 1e6) == pytest.approx(math.sqrt(2.0 * 9.81 * 0.305), rel=1e-9)
    assert rise_height(2.3, 1e6) == pytest.approx(2.3**2 / (2.0 * 9.81), rel=1e-9)


def test_table_tennis_rebound_over_the_shells_published_loss_range():
    # ABS's published loss factors, 0.0138-0.0446 (Granta MaterialUniverse), move the table
    # tennis ball's rebound through the air across the ITTF's range (0.24-0.26 m): the
    # table's 0.02 is near the range's lively end. Figures as docs/validation.md prints them
    from benchmarks.hollow import rebounds_over_loss_range

    (test,) = [t for t in RULE_BOOK_TESTS if t.preset == "table-tennis-ball-on-table"]
    most, least = rebounds_over_loss_range(test)
    assert (least, most) == pytest.approx((0.248, 0.272), abs=5e-4)
    assert least < test.rebound_high and most > test.rebound_high
    assert least < rule_book_row(test).rebound < most


def test_tennis_contact_time_is_brodys():
    # Brody: a tennis ball is in contact with a court for "five milliseconds" in play; the
    # engine's pulse in the ITF drop test is within that one-figure value's rounding
    # (4.5-5.5 ms), its construction from its sources (docs/materials.md, "The tennis ball")
    (test,) = [t for t in RULE_BOOK_TESTS if t.preset == "tennis-ball-on-concrete"]
    row = rule_book_row(test)
    assert test.contact_time == 5e-3
    assert row.contact_time_error == pytest.approx(row.contact_time / 5e-3 - 1.0)
    assert abs(row.contact_time_error) < 0.1
    others = [rule_book_row(t) for t in RULE_BOOK_TESTS if t is not test]
    assert all(r.contact_time_error is None for r in others)


def test_loss_budget_of_the_hollow_balls():
    # the share of the elastic energy the shell's loss acts on: below the transition both
    # potentials are quadratic, k_R d^2 / 2 and k_g d^2 / 2, so the wall's share is
    # k_R / (k_R + k_g) (closed form); without gas it is all of it
    from benchmarks.hollow import rebound_with_shell_loss, shell_loss_to_land, wall_energy_share

    tennis = load_preset("tennis-ball-on-concrete").ball
    law = shell_law(tennis)
    d = 0.5 * law.transition
    share = law.reissner_stiffness / (law.reissner_stiffness + law.gas_stiffness)
    assert wall_energy_share(tennis, d) == pytest.approx(share, rel=1e-12)
    assert wall_energy_share(_ball(), 3.0 * _ball().thickness) == 1.0
    # the diagnosis' loss factor gives back the rebound it was asked for, to brentq's xtol
    # (1e-4 on eta; the rebound moves about 2 m per unit of eta), and the figures
    # docs/validation.md prints (to their digits): the tennis ball's wall would need ten
    # times its rubber's loss factor to carry the missing loss by itself
    (test,) = [t for t in RULE_BOOK_TESTS if t.preset == "tennis-ball-on-concrete"]
    top, bottom = (shell_loss_to_land(test, h) for h in (test.rebound_high, test.rebound_low))
    assert rebound_with_shell_loss(test, top) == pytest.approx(test.rebound_high, abs=1e-3)
    assert (top, bottom) == pytest.approx((0.494, 0.590), abs=5e-4)
    assert top > 9.0 * tennis.material.damping.eta


def test_shell_modes_are_hayeks():
    # Hayek's frequency equation without its bending term (a -> 0) is the membrane sphere's,
    # lambda^2 roots of L^2 - L (n^2 + n + 1 + 3 nu) + (1 - nu^2) (n^2 + n - 2) = 0 (the
    # code_aster validation manual V2.03.007): a wall of h / R = 1e-3 is within a b^2 ~ 1e-5
    from benchmarks.hollow import shell_mode_frequencies

    b = HollowBall(ELASTIC_SHELL, 0.02, thickness=2e-5)
    radius = 0.02 - 1e-5
    scale = math.sqrt(2.2e9 / (1050.0 * (1.0 - 0.39**2))) / radius
    for n in (2, 3, 5):
        c = n * n + n + 1.0 + 3.0 * 0.39
        root = math.sqrt(c * c - 4.0 * (1.0 - 0.39**2) * (n * n + n - 2.0))
        membrane = [scale * math.sqrt(0.5 * (c - root)), scale * math.sqrt(0.5 * (c + root))]
        assert shell_mode_frequencies(b, n) == pytest.approx(membrane, rel=1e-4)
    # n = 0, the breathing mode, has one root; n = 1 leaves out the translation (0)
    assert len(shell_mode_frequencies(b, 0)) == 1 and len(shell_mode_frequencies(b, 1)) == 1


def test_pulse_spectrum_of_a_half_sine():
    # |F(omega)| of F0 sin(pi t / tau) on [0, tau]: F0 (pi / tau) 2 |cos(omega tau / 2)| /
    # |(pi / tau)^2 - omega^2| (closed form), to the trapezoid rule's error on 20001 points
    from benchmarks.hollow import pulse_spectrum

    class HalfSine:
        separation_time = 1e-3

        def force_at(self, t):
            return 10.0 * np.sin(math.pi * t / 1e-3)

    wc = math.pi / 1e-3
    for omega in (0.5 * wc, 2.7 * wc, 10.3 * wc):
        exact = 10.0 * wc * 2.0 * abs(math.cos(0.5 * omega * 1e-3)) / abs(wc * wc - omega**2)
        assert pulse_spectrum(HalfSine(), [omega])[0] == pytest.approx(exact, rel=1e-6)


def test_radial_shares_of_an_orders_modes_sum_to_one():
    # the membrane sphere's two modes of an order are orthogonal: their radial shares sum to 1
    # (a thin wall: to Hayek's bending correction); n = 1 leaves the translation's 1/3 out,
    # n = 0 (breathing) is all radial
    from benchmarks.hollow import radial_share, shell_mode_frequencies

    b = HollowBall(ELASTIC_SHELL, 0.02, thickness=2e-5)
    for n in (2, 3, 7):
        shares = [radial_share(b, n, w) for w in shell_mode_frequencies(b, n)]
        assert sum(shares) == pytest.approx(1.0, rel=1e-4)
    (w1,) = shell_mode_frequencies(b, 1)
    assert radial_share(b, 1, w1) == pytest.approx(2.0 / 3.0, rel=1e-4)
    assert radial_share(b, 0, shell_mode_frequencies(b, 0)[0]) == 1.0


def test_ringing_against_the_missing_loss():
    # the energy the engine's pulse leaves in the shell's modes (estimate and upper bound),
    # the loss the impact misses for the range's top, and the rebound with the estimate taken
    # off (figures as docs/validation.md prints them): only the basketball's would land in its
    # range, and the table tennis ball's ringing is below a third of its miss; with every mode
    # 10 % higher the estimate falls by half and more (its sensitivity to the frequencies)
    # (docs/validation.md, "Hollow balls")
    from benchmarks.hollow import (
        fall_speed,
        missing_loss_share,
        ringing,
        rise_height,
        rise_speed,
        terminal_speed,
    )

    assert rise_height(rise_speed(1.4, 9.0), 9.0) == pytest.approx(1.4, rel=1e-12)
    printed = {  # to the digits docs/validation.md prints
        "table-tennis-ball-on-table": ("10.0", "7.1e-03", "8.1e-03", "3.5e-03", "2.5e-02", "0.265"),
        "tennis-ball-on-concrete": ("2.7", "3.1e-01", "3.7e-01", "1.5e-01", "3.3e-01", "1.523"),
        "basketball-on-wooden-floor": ("4.5", "2.0e-01", "2.2e-01", "1.1e-01", "1.5e-01", "1.320"),
    }
    for test in RULE_BOOK_TESTS:
        ball, row = load_preset(test.preset).ball, rule_book_row(test)
        ring = ringing(test, ball)
        missing = missing_loss_share(test, row, ball)
        figures = (
            f"{ring.ratio:.1f}",
            f"{ring.estimate:.1e}",
            f"{ring.bound:.1e}",
            f"{ring.raised:.1e}",
            f"{missing:.1e}",
            f"{ring.rebound:.3f}",
        )
        assert figures == printed[test.preset]
        assert ring.raised < ring.estimate < ring.bound
        if test.preset == "table-tennis-ball-on-table":
            assert ring.bound < missing / 3.0
        inside = test.rebound_low <= ring.rebound <= test.rebound_high
        assert inside == (test.preset == "basketball-on-wooden-floor")
        # the missing loss is the one that lands the rebound on the range's top
        v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
        e_top = math.sqrt(row.restitution**2 - missing)
        top = 2.0 * ball.radius if test.to_top else 0.0
        landed = rise_height(e_top * fall_speed(test.drop, v_t), v_t) + top
        assert landed == pytest.approx(test.rebound_high, rel=1e-12)


def test_gas_thermal_loss_is_negligible():
    # the thermal boundary layer's loss factor of the gas spring, (gamma - 1) S d / (2 V) =
    # 0.6 d / R_i for air, and the estimate's share of the impact energy: far below the
    # misses (docs/validation.md, "Hollow balls"), which is why the engine's gas is lossless
    from benchmarks.hollow import fall_speed, gas_thermal_loss_share, terminal_speed

    for test in RULE_BOOK_TESTS:
        row = rule_book_row(test)
        ball = load_preset(test.preset).ball
        speed = fall_speed(test.drop, terminal_speed(ball.mass, ball.radius, test.drag_coefficient))
        share = gas_thermal_loss_share(ball, row, speed)
        assert 0.0 < share < 2e-3
    # the closed form at one point: the tennis ball's, from its pieces
    (test,) = [t for t in RULE_BOOK_TESTS if t.preset == "tennis-ball-on-concrete"]
    row, ball = rule_book_row(test), load_preset(test.preset).ball
    absolute = 101325.0 + ball.pressure
    layer = math.sqrt(2.0 * 22.5e-6 * 101325.0 / absolute * row.contact_time / math.pi)
    ri, d = ball.inner_radius, row.deflection
    volume = 4.0 / 3.0 * math.pi * ri**3
    cap = math.pi * d * d * (ri - d / 3.0)
    loss = math.pi * 0.6 * layer / ri * 1.4 * absolute * cap * cap / (2.0 * volume)
    assert gas_thermal_loss_share(ball, row, 7.0) == pytest.approx(
        loss / (0.5 * ball.mass * 49.0), rel=1e-12
    )


def test_prestressed_modes_at_zero_pressure_are_hayeks():
    # without gauge pressure the prestressed frequency equation is Hayek's (the same roots);
    # the radial share from the tangential equation is the membrane's from the radial one to
    # Hayek's bending correction (h / R = 1e-3)
    from benchmarks.hollow import radial_share, shell_mode_frequencies
    from benchmarks.hollow_modes import prestressed_mode_frequencies, prestressed_radial_share

    b = HollowBall(ELASTIC_SHELL, 0.02, thickness=2e-5)
    for n in (1, 2, 3, 6):
        omegas = prestressed_mode_frequencies(b, n)
        assert omegas == pytest.approx(shell_mode_frequencies(b, n), rel=1e-12)
        for w in omegas:
            assert prestressed_radial_share(b, n, w) == pytest.approx(
                radial_share(b, n, w), rel=1e-4
            )


def test_prestress_raises_the_modes_by_its_closed_form():
    # the membrane tension p R / 2 (Laplace's law) adds (n - 1)(n + 2) p / (2 R) per area to
    # the radial stiffness: to first order in p each mode's omega^2 rises by its radial share
    # times p (n - 1)(n + 2) / (2 rho h R) (the Rayleigh quotient, closed form, with the
    # membrane's share); at 100 Pa on a wall of h / R = 1e-3 the second order and Hayek's
    # bending correction are below 1e-4 of the rise. n = 1 is a translation and does not feel it
    from benchmarks.hollow import radial_share, shell_mode_frequencies
    from benchmarks.hollow_modes import prestress_pole_stiffness, prestressed_mode_frequencies

    p, h = 100.0, 2e-5
    b0 = HollowBall(ELASTIC_SHELL, 0.02, thickness=h)
    b = HollowBall(ELASTIC_SHELL, 0.02, thickness=h, pressure=p)
    radius = 0.02 - 0.5 * h
    for n in (1, 2, 3, 5):
        rise = p * (n - 1) * (n + 2) / (2.0 * 1050.0 * h * radius)
        for w0, w in zip(shell_mode_frequencies(b0, n), prestressed_mode_frequencies(b, n)):
            share = radial_share(b0, n, w0)
            assert w * w - w0 * w0 == pytest.approx(share * rise, rel=1e-4, abs=1e-12 * w0 * w0)
        # at the pole: k_g (n - 1)(n + 2) / (2 n + 1), k_g = 2 pi R p the gas' stiffness
        kg = 2.0 * math.pi * radius * p
        assert prestress_pole_stiffness(b, n) == pytest.approx(
            kg * (n - 1) * (n + 2) / (2 * n + 1), rel=1e-12
        )


def test_contact_with_the_wall_modes_balances_its_energy():
    # kinetic energy in plus gravity's work = kinetic energy out + the law's loss + the modes'
    # loss + the plate's + the energy left ringing in the modes, to the integration's
    # tolerance (an invariant); without modes it is the engine's shell contact (the same
    # restitution to the tolerance); the tennis ball with orders 1-2 in it still rebounds far
    # above the ITF's range (docs/validation.md, "Hollow balls")
    from benchmarks.hollow import fall_speed, rise_height, terminal_speed
    from benchmarks.hollow_modes import WallModes, modal_bounce, wall_modes

    (test,) = [t for t in RULE_BOOK_TESTS if t.preset == "tennis-ball-on-concrete"]
    ball = load_preset(test.preset).ball
    v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
    speed = fall_speed(test.drop, v_t)
    none = modal_bounce(ball, test.surface, speed, WallModes((), (), (), (), 1.0))
    engine = solve_impact(ball, test.surface, speed, contact="shell", rtol=1e-10)
    assert none.restitution == pytest.approx(engine.restitution, rel=1e-8)
    for resonant in (False, True):
        b = modal_bounce(ball, test.surface, speed, wall_modes(ball, 2), resonant)
        assert abs(b.balance) < 1e-8
        assert b.ringing > 0.01 and b.mode_loss > 0.01
        assert rise_height(b.rebound_speed, v_t) > 1.2 * test.rebound_high
    # orders 1-4: the modes are more compliant at the pole than the whole law, 1-3 are not
    assert wall_modes(ball, 3).admissible and not wall_modes(ball, 4).admissible
    with pytest.raises(synth.ParameterError, match="modes="):
        modal_bounce(ball, test.surface, speed, wall_modes(ball, 4))


@pytest.mark.parametrize("test", RULE_BOOK_TESTS, ids=lambda t: t.preset)
def test_rule_book_bounce_above_range_as_documented(test):
    # The known miss, pinned so that a fix shows (the target is inside the range): the
    # shells' published loss factors alone leave the balls too lively, the air's drag taken
    # in. The table tennis ball's wall ringing takes less than a third of its miss (its
    # shell's modes an order above its contact's frequency); with the wall's lowest modes
    # integrated in the contact (prestressed, their static compliance taken off the law's)
    # the tennis ball still rebounds to 1.84-1.96 m and the basketball to 1.53-1.63 m; the
    # felt's loss and the seams are not in the engine (docs/validation.md, 'Hollow balls').
    row = rule_book_row(test)
    assert row.rebound > test.rebound_high


def test_validation_page_prints_the_engines_table():
    text = (Path(__file__).parents[1] / "docs" / "validation.md").read_text()
    block = re.search(r"<!-- bench:hollow -->\n(.*?)<!-- /bench:hollow -->", text, re.S)
    assert block is not None
    table = format_hollow([rule_book_row(t) for t in RULE_BOOK_TESTS])
    assert table.strip() in block.group(1)


@pytest.mark.slow
@pytest.mark.preset("table-tennis-ball-on-table")
def test_table_tennis_preset_renders(preset_run):
    # the session's render of the preset (tests/conftest.py), which the frozen renders
    # (tests/test_frozen_renders.py) compare with its recording: a render of its own repeated
    # the contacts and the plate's synthesis
    run = preset_run("table-tennis-ball-on-table")
    scene, r = run.scene, run.render
    assert r.audio.size > 0 and np.all(np.isfinite(r.audio)) and np.abs(r.audio).max() > 0.0
    first = r.impacts[0]
    own = solve_impact(
        scene.ball,
        scene.plate,
        first.speed,
        contact="shell",
        position=scene.position,
        rtol=scene.contact.rtol,
    )
    assert first.result.restitution == pytest.approx(own.restitution, rel=1e-12)


def test_cost_estimate_takes_the_shell_contact():
    # a hollow ball's rigid-plate contact time in the cost estimate is its shell law's at
    # small deflection, pi sqrt(m / k0): the solver's at a slow impact, to its tolerance
    from synth import cost

    b = HollowBall("abs", 0.02, thickness=5.2e-4)
    tau = cost.hertz_contact_time(b, RIGID, 0.05)
    assert tau == pytest.approx(math.pi * math.sqrt(b.mass / shell_law(b).stiffness), rel=1e-14)
    # the same ball without its loss (ELASTIC_SHELL: ABS's elastic constants and density)
    solved = _lumped(HollowBall(ELASTIC_SHELL, 0.02, thickness=5.2e-4), 0.05, rtol=1e-9)
    assert solved.contact_time == pytest.approx(tau, rel=1e-8)


def test_bank_axes_reach_the_hollow_ball():
    # a bank's ``ball.*`` axes are preset overrides: the hollow ball's own fields vary too
    from synth.io.presets import canonical, read

    base = load_preset("tennis-ball-on-concrete")
    softer = load_preset("tennis-ball-on-concrete", ["ball.pressure=4e4", "ball.thickness=0.003"])
    assert (softer.ball.pressure, softer.ball.thickness) == (4e4, 0.003)
    assert softer.ball.mass < base.ball.mass
    data = read(synth.io.presets.find("tennis-ball-on-concrete"))
    c = canonical(data, varied=("ball.pressure",))
    assert c["ball"]["kind"] == "hollow" and "pressure" not in c["ball"]
    assert c["contact"]["law"] == "shell"


@pytest.mark.slow
def test_bank_varies_the_hollow_balls_pressure(tmp_path):
    # a real bank (one worker process) over a hollow ball's own field: a softer ball (less
    # gas) has a longer first contact (k0 = k_R + 2 pi R p, tau ~ pi sqrt(m / k0))
    import json

    from synth import bank
    from synth.bank import spec as bank_spec

    spec = bank_spec.from_dict(
        {
            "preset": "basketball-on-wooden-floor",
            "vary": {"ball.pressure": [4e4, 6e4]},
            "render": {"max_duration": 1.0, "max_tail": 0.2},
        },
        base_dir=tmp_path,
    )
    result = bank.run(spec, tmp_path / "out", jobs=1)
    assert "2 done" in result.summary()
    rows = [json.loads(line) for line in (tmp_path / "out" / "manifest.jsonl").open()]
    assert [r["ball.pressure"] for r in rows] == [4e4, 6e4]
    assert rows[0]["first_contact_time"] > rows[1]["first_contact_time"]


def test_a_shell_result_keeps_its_class_with_another_message():
    # the edge iteration reports its best solution with a new message (with_message): a
    # hollow ball's result must keep its own pulse (it failed before: the power laws' pulse
    # kernel read the shell's dense output)
    from synth.physics.contact import with_message

    r = solve_impact(_ball(), RIGID, 1.0)
    copy = with_message(r, "another message")
    assert type(copy) is type(r) and copy.message == "another message"
    np.testing.assert_array_equal(copy.force, r.force)


def test_tennis_ball_passes_the_itfs_static_test():
    # the ITF's forward deformation (80.1 N along a diameter): 5.59-7.37 mm. The engine's
    # ball, built from its sources and not fitted to this test, shortens inside it
    from benchmarks.hollow import (
        ITF_DEFORMATION_LOAD,
        ITF_FORWARD_DEFORMATION,
        static_compression,
    )

    ball = load_preset("tennis-ball-on-concrete").ball
    law = shell_law(ball)
    engine = static_compression(ball, ITF_DEFORMATION_LOAD)
    # below the transition the law is linear: 2 F / k0
    assert engine / 2.0 < law.transition
    assert engine == pytest.approx(2.0 * ITF_DEFORMATION_LOAD / law.stiffness, rel=1e-12)
    # the figure docs/validation.md prints, to its digits
    assert engine == pytest.approx(7.11e-3, abs=5e-6)
    low, high = ITF_FORWARD_DEFORMATION
    assert low <= engine <= high


def test_tennis_ball_is_the_itfs_and_its_rubber_the_abaqus_examples():
    # the ITF's mass (56.0-59.4 g) and diameter (65.4-68.6 mm); the felt 20 % of the ITF's
    # middle mass (Artengo); the core's rubber the small-strain E and nu of the Mooney-Rivlin
    # rubber of the Abaqus example (C10 0.690 MPa, C01 0.173 MPa, D1 0.0145 1/MPa), to the
    # preset's printed digits
    ball = load_preset("tennis-ball-on-concrete").ball
    assert 0.056 <= ball.mass <= 0.0594
    assert 0.0654 <= 2.0 * ball.radius <= 0.0686
    assert ball.cover_mass == pytest.approx(0.2 * 0.0577, abs=5e-6)
    mu, bulk = 2.0 * (0.690e6 + 0.173e6), 2.0 / 0.0145e-6
    young = 9.0 * bulk * mu / (3.0 * bulk + mu)
    poisson = (3.0 * bulk - 2.0 * mu) / (2.0 * (3.0 * bulk + mu))
    assert ball.material.young == pytest.approx(young, abs=50.0)
    assert ball.material.poisson == pytest.approx(poisson, abs=5e-5)


def test_a_cover_carries_mass_and_size_but_no_force():
    # the felt sets the ball's radius and adds its mass; the shell law is the bare shell's
    # of the shell's radius R_s = R - c (docs/physics.md, "Hollow balls")
    bare = HollowBall("rubber", 0.0305, thickness=4e-3, pressure=8e4)
    felted = HollowBall(
        "rubber", 0.0335, thickness=4e-3, pressure=8e4, cover_thickness=3e-3, cover_mass=0.01
    )
    assert felted.shell_radius == pytest.approx(0.0305, rel=1e-15)
    assert felted.mass == pytest.approx(bare.mass + 0.01, rel=1e-14)
    a, b = shell_law(bare), shell_law(felted)
    assert (b.reissner_stiffness, b.pogorelov_constant, b.gas_stiffness) == pytest.approx(
        (a.reissner_stiffness, a.pogorelov_constant, a.gas_stiffness), rel=1e-14
    )
    with pytest.raises(synth.ParameterError, match=r"ball\.cover_thickness=0\.02 must be in"):
        HollowBall("rubber", 0.04, thickness=4e-3, cover_thickness=0.02)
    with pytest.raises(synth.ParameterError, match=r"ball\.cover_mass=-0\.001 must be in"):
        HollowBall("rubber", 0.04, thickness=4e-3, cover_mass=-0.001)
    # the wall: at most half the shell's radius (0.025 m here)
    with pytest.raises(synth.ParameterError, match=r"ball\.thickness=0\.013 must be in"):
        HollowBall("rubber", 0.04, thickness=0.013, cover_thickness=0.015)
