"""The contact solver against published values, closed forms and invariants."""

import dataclasses
import math

import numpy as np
import pytest

from benchmarks import contact_cases
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import contact, impedance
from synth.physics import contact_law as laws
from synth.physics.materials import TABLE
from synth.physics.scene import Ball, Plate

STEEL10 = Ball("steel", 0.005)  # rho 7800, E 216 GPa, nu 0.3 (thesis Fig. 2.8)
MDF18 = Plate("mdf-18", 0.018, 1.227, 0.49)  # E 5.689 GPa, rho 700, nu 0.4


def lumped(ball=STEEL10, plate=MDF18):
    return dict(
        mass=ball.mass,
        stiffness=laws.hertz_stiffness(ball, plate),
        admittance=1.0 / impedance.infinite_plate_impedance(plate),
    )


# --- published values (thesis) ---------------------------------------------------------
def test_thesis_figure_2_8_no_gravity():
    # Thesis Fig. 2.8: 10 mm steel ball on 18 mm MDF at 1 m/s, no gravity:
    # e = 0.88, tau ~ 110 us, delta_max ~ 35 um (tolerances: the figure's reading
    # precision).
    r = contact.solve_impact(STEEL10, MDF18, 1.0, gravity=0.0)
    assert r.success and not r.settled
    assert r.restitution == pytest.approx(0.88, abs=0.005)
    assert r.contact_time == pytest.approx(110e-6, abs=3e-6)
    assert r.max_penetration == pytest.approx(35e-6, abs=1e-6)


def test_thesis_mid_plate_with_gravity():
    # Thesis: e = 0.87 at 1.4 m/s (10 cm drop) with gravity, mid-plate (+- 0.01).
    r = contact.solve_impact(STEEL10, MDF18, 1.4, position=MDF18.centre)
    assert r.restitution == pytest.approx(0.87, abs=0.01)


def settled_penetration(ball, plate, gravity=GRAVITY):
    """Static Hertz penetration ``(m g / K)^(2/3)`` (thesis 2.48), m; ``gravity`` in m/s^2."""
    return (ball.mass * gravity / laws.hertz_stiffness(ball, plate)) ** (2.0 / 3.0)


def test_settled_penetration_thesis_value():
    # Thesis eq. 2.48: delta_eq = (m g / K)^(2/3) = 1.6e-7 m for the 10 mm ball on MDF
    # (two significant digits printed: +- 0.05e-7).
    d = settled_penetration(STEEL10, MDF18)
    assert d == pytest.approx(1.6e-7, abs=0.05e-7)


def test_settled_impact_penetration_between_static_and_sudden_load():
    # A ball arriving far below the speed needed to separate settles (e = 0). Its peak
    # penetration lies between the static one and that of a suddenly applied weight with
    # the arrival energy added: (m g d - 0 ... ) => d_eq <= d_max <= (2.5 (m g d + KE) / K)^(2/3)
    # bounded here by 1.9 d_eq (the sudden-load value 2.5^(2/3) = 1.842 plus the tiny KE).
    r = contact.solve_impact(STEEL10, MDF18, 1e-5)
    d_eq = settled_penetration(STEEL10, MDF18)
    assert r.settled and r.restitution == 0.0 and r.success
    assert d_eq <= r.max_penetration <= 1.9 * d_eq


def test_overdamped_landing_settles_without_a_penetration_peak():
    # A heavy ball (37 mm ABS, 0.23 kg) arriving at 0.16 mm/s near the edge of a 0.77 mm
    # brass panel: lam ~ 44 and lam G ~ 2600, so the landing is overdamped and the
    # penetration creeps up to its static value (m g / K)^(1/n) without ever peaking. The
    # ball settles (e = 0) by Radau IIA, which the automatic choice takes here (DOP853,
    # outside its stable range, ends at its own oscillation); the static penetration is
    # reached to the solver's tolerance (rel 1e-6, the default rtol; the creep ends when
    # its rise falls below atol) and the energy balance closes to 1e-5 (as in the sweep
    # below). Radau IIA never ended such a contact: its steps grew without bound.
    m, K = 0.22964903565422534, 652937150.3118063
    d_eq = (m * 9.81 / K) ** (1.0 / 1.5)
    for method in ("Radau", "auto"):
        r = contact.solve_contact(
            mass=m, stiffness=K, admittance=0.18241691291720857, speed=1.5539364348368133e-4,
            method=method,
        )  # fmt: skip
        assert r.success and r.settled and r.restitution == 0.0, (method, r.message)
        assert r.max_penetration == pytest.approx(d_eq, rel=1e-6), method
        assert r.energy_residual < 1e-5, method


# --- closed forms ----------------------------------------------------------------------
@pytest.mark.parametrize("v", [0.01, 1.0, 10.0])
def test_rigid_plate_closed_forms(v):
    # Rigid plate, no gravity (docs/physics.md, "Hertz contact"): e = 1 (1e-6); delta_max, tau,
    # F_max from
    # Hertz's closed forms within 1e-4 (the constants 2.9433 and 1.2827 have 5 digits).
    m = STEEL10.mass
    R = STEEL10.radius
    E = laws.effective_modulus(STEEL10, MDF18)
    r = contact.solve_contact(
        mass=m,
        stiffness=laws.hertz_stiffness(STEEL10, MDF18),
        admittance=0.0,
        speed=v,
        gravity=0.0,
    )
    d_max = (15 * m * v**2 / (16 * E * math.sqrt(R))) ** 0.4
    assert r.restitution == pytest.approx(1.0, abs=1e-6)
    assert r.max_penetration == pytest.approx(d_max, rel=1e-4)
    assert r.contact_time == pytest.approx(2.9433 * d_max / v, rel=1e-4)
    assert r.peak_force == pytest.approx(1.2827 * E**0.4 * R**0.2 * m**0.6 * v**1.2, rel=1e-4)


def test_inelasticity_is_zeners_lambda():
    # lambda = K^(2/5) m^(3/5) v^(1/5) / Z (thesis 2.42), exactly (1e-12).
    p = lumped()
    r = contact.solve_contact(speed=2.0, **p)
    lam = p["stiffness"] ** 0.4 * p["mass"] ** 0.6 * 2.0**0.2 * p["admittance"]
    assert r.inelasticity == pytest.approx(lam, rel=1e-12)


def test_no_gravity_restitution_depends_on_lambda_only():
    # Without gravity the problem has one parameter (docs/physics.md, "Hertz contact"): two impacts
    # with
    # different m, K, beta, v but the same lambda have the same e (1e-7, 10x rtol).
    a = contact.solve_contact(mass=0.004, stiffness=1e9, admittance=1e-3, speed=1.0, gravity=0.0)
    m, K, v = 0.1, 3e10, 5.0
    beta = a.inelasticity / (K**0.4 * m**0.6 * v**0.2)
    b = contact.solve_contact(mass=m, stiffness=K, admittance=beta, speed=v, gravity=0.0)
    assert b.inelasticity == pytest.approx(a.inelasticity, rel=1e-12)
    assert b.restitution == pytest.approx(a.restitution, rel=1e-7)


# --- invariants ------------------------------------------------------------------------
@pytest.mark.parametrize("speed, gravity", [(1.0, 0.0), (1.4, 9.81), (1e-3, 9.81), (20.0, 9.81)])
def test_energy_balance_residual(speed, gravity):
    # The energy balance (docs/physics.md, "Hertz contact"), computed from independent quadratures:
    # residual
    # below 1e-6 of the impact energy at the default rtol.
    r = contact.solve_impact(STEEL10, MDF18, speed, gravity=gravity)
    assert r.energy_residual < 1e-6


def test_restitution_rises_as_speed_falls_without_gravity():
    # lambda ~ v^(1/5) falls with v and e falls with lambda (thesis Fig. 2.9): strictly
    # monotone over four decades.
    es = [
        contact.solve_impact(STEEL10, MDF18, v, gravity=0.0).restitution
        for v in (30.0, 3.0, 0.3, 0.03, 0.003)
    ]
    assert all(b > a for a, b in zip(es, es[1:]))


def test_restitution_drops_to_zero_at_very_low_speed_with_gravity():
    # With gravity e falls again at low speed and is 0 (settled) when the approach speed is
    # below what a separation needs (thesis 2.4.3).
    es = [contact.solve_impact(STEEL10, MDF18, v).restitution for v in (1e-2, 3e-3, 1e-3, 1e-5)]
    assert es[0] > es[1] > es[2] > es[3]
    assert es[3] == 0.0


def test_momentum_balance_gives_impulse():
    # The ball's momentum balance Int F dt = m (v_in + v_out) + m g tau, with Int F dt
    # taken independently of the solver's velocity: the trapezoid rule over 20001 points
    # of the dense force output (its error, ~(tau/N)^2 inside and (1/N)^(5/2) at the
    # u^(3/2) ends, is below 1e-8 of the impulse; the solver's own error is ~rtol = 1e-8).
    r = contact.solve_impact(STEEL10, MDF18, 1.4, rtol=1e-8)
    m = STEEL10.mass
    t = np.linspace(0.0, r.contact_time, 20001)
    integral = np.trapezoid(r.force_at(t), t)
    assert integral == pytest.approx(
        m * (1.4 + r.rebound_speed) + m * 9.81 * r.contact_time, rel=1e-7
    )
    assert r.impulse == pytest.approx(integral, rel=1e-7)


def test_pulse_sampling():
    # The pulse is on its own grid: >= 64 points over [0, tau], F >= 0, zero at both ends,
    # its peak no larger than the located peak force, and its trapezoid integral equal to
    # the impulse to the trapezoid rule's accuracy at 128 points (1e-3).
    r = contact.solve_impact(STEEL10, MDF18, 1.4)
    assert r.time.size >= 64 and r.time.shape == r.force.shape
    assert r.time[0] == 0.0 and r.time[-1] == pytest.approx(r.contact_time, rel=1e-12)
    assert np.all(r.force >= 0.0) and r.force[0] == 0.0 and r.force[-1] == 0.0
    assert r.force.max() <= r.peak_force * (1 + 1e-12)
    assert np.trapezoid(r.force, r.time) == pytest.approx(r.impulse, rel=1e-3)


def test_plate_velocity_is_a_change_of_frame():
    # A plate moving up at V: in the plate's frame the ball arrives at v + V (no gravity),
    # so the relative rebound speed equals that of an impact at v + V on a plate at rest.
    p = lumped()
    moving = contact.solve_contact(speed=1.0, plate_velocity=0.3, gravity=0.0, **p)
    still = contact.solve_contact(speed=1.3, gravity=0.0, **p)
    assert moving.rebound_speed == pytest.approx(still.rebound_speed, rel=1e-9)
    assert moving.restitution == pytest.approx(still.rebound_speed / 1.0, rel=1e-9)


def test_integrators_agree():
    # DOP853 and Radau IIA are independent integrators: same e and tau within 1e-6.
    p = lumped()
    a = contact.solve_contact(speed=1.0, method="DOP853", **p)
    b = contact.solve_contact(speed=1.0, method="Radau", **p)
    assert a.method == "DOP853" and b.method == "Radau"
    assert b.restitution == pytest.approx(a.restitution, rel=1e-6)
    assert b.contact_time == pytest.approx(a.contact_time, rel=1e-6)


@pytest.mark.parametrize("i", range(len(contact_cases())))
@pytest.mark.parametrize("rtol", [1e-4, 1e-6, 1e-8])
def test_error_against_reference_honours_rtol(rtol, i, assert_honours_rtol):
    # On every case of synth bench contact (thesis, steel on steel, lambda > 1,
    # gravity-dominated, stiff, Hunt-Crossley), against scipy's Radau at rtol 1e-12.
    assert_honours_rtol(contact_cases()[i], rtol)


# --- other contact laws ----------------------------------------------------------------
def test_elastic_foundation_raises_restitution_and_lengthens_contact():
    # Thesis 4.3.2: the elastic foundation shifts e up and lengthens the contact.
    h = contact.solve_impact(STEEL10, MDF18, 1.4)
    f = contact.solve_impact(STEEL10, MDF18, 1.4, contact="elastic-foundation")
    assert f.restitution > h.restitution
    assert f.contact_time > h.contact_time


def test_hunt_crossley_loss_in_energy_balance():
    # Hunt-Crossley adds a viscoelastic loss: e falls as mu grows, and the energy balance
    # including that loss still closes (1e-6).
    es = []
    for mu in (0.05, 0.2, 0.8):
        r = contact.solve_impact(STEEL10, MDF18, 1.4, contact="hunt-crossley", dissipation=mu)
        assert r.energy_residual < 1e-6
        es.append(r.restitution)
    hertz = contact.solve_impact(STEEL10, MDF18, 1.4).restitution
    assert hertz > es[0] > es[1] > es[2]


def test_power_law_with_hertz_exponent_equals_hertz():
    # "power-law" with n = 3/2 and K = Hertz's K is the Hertz law (1e-12).
    K = laws.hertz_stiffness(STEEL10, MDF18)
    a = contact.solve_impact(STEEL10, MDF18, 1.0, contact="power-law", exponent=1.5, stiffness=K)
    b = contact.solve_impact(STEEL10, MDF18, 1.0)
    assert a.restitution == pytest.approx(b.restitution, rel=1e-12)


# --- extreme and stiff cases -----------------------------------------------------------
def test_sweep_extreme_cases():
    # A few thousand combinations over radius 0.5-50 mm, every material pair (each pair at
    # least five times), thickness 0.3-50 mm, speed 1e-4-30 m/s, mid-plate, on an edge, at
    # a corner and near an edge or corner: no exception, no NaN or inf, 0 <= e <= 1 + rtol,
    # and the energy balance closes to 1e-5 of the impact energy (10x the default rtol:
    # the bound holds with margin over the sweep; the stiffest, lambda ~ 1e5, contacts are
    # integrated over 1e6 of their own time units).
    rng = np.random.default_rng(20261122)
    names = sorted(TABLE)
    pairs = [(a, b) for a in names for b in names]
    n = max(2500, 5 * len(pairs))
    worst = 0.0
    for i in range(n):
        ball_name, plate_name = pairs[i % len(pairs)]
        ball = Ball(ball_name, 10 ** rng.uniform(np.log10(5e-4), np.log10(5e-2)))
        h = 10 ** rng.uniform(np.log10(3e-4), np.log10(5e-2))
        plate = Plate(plate_name, h, 1.2, 0.8)
        v = 10 ** rng.uniform(-4, np.log10(30.0))
        d = 10 ** rng.uniform(-4, -1)
        pos = [plate.centre, (0.0, 0.4), (0.0, 0.0), (d, 0.4), (1.2 - d, 0.8 - d)][i % 5]
        r = contact.solve_impact(ball, plate, v, position=pos)
        scalars = [
            r.restitution,
            r.contact_time,
            r.max_penetration,
            r.peak_force,
            r.impulse,
            r.inelasticity,
            r.energy_residual,
            r.plate_energy,
        ]
        assert r.success, (ball, plate, v, pos, r.message)
        assert all(math.isfinite(x) for x in scalars), (ball, plate, v, pos)
        assert np.all(np.isfinite(r.force)) and np.all(np.isfinite(r.time))
        assert 0.0 <= r.restitution <= 1.0 + 1e-6
        worst = max(worst, r.energy_residual)
    assert len({(a, b) for a, b in pairs[:n]}) == len(pairs)
    assert worst < 1e-5


def test_yielded_peak_reached_to_the_rounding_of_the_penetration():
    # A 6.7 mm aluminium ball at 13 mm/s on 20.6 mm clamped brass, with the viscoelastic loss
    # and the yield of the surfaces: DOP853 reaches the yielded peak (x' = 0) to within the
    # rounding of the penetration, where no shorter step can land past it. The impact is
    # solved, and by invariants: past the yield (the case exercised), 0 < e <= 1 (the contact
    # gives no energy back), the rebound's kinetic energy at most the incoming one, and both
    # integrators agree within the sum of their tolerances (2 rtol).
    ball = Ball("aluminium", 0.003369160012714407)
    plate = Plate("brass", 0.020582662476117924, 0.3448694169469478, 0.5310081950141492, "clamped")
    solver = contact.ContactSolver.for_pair(ball, plate, law="hertz", rtol=1e-9, surface="auto")
    speed = 0.013210251239669056
    r = solver.solve(speed)
    assert r.success, r.message
    assert r.method == "DOP853"
    assert r.max_penetration > solver.yield_penetration
    assert 0.0 < r.restitution <= 1.0
    assert 0.5 * ball.mass * r.rebound_speed**2 <= 0.5 * ball.mass * speed**2
    radau = dataclasses.replace(solver, method="Radau").solve(speed)
    assert radau.success, radau.message
    assert r.restitution == pytest.approx(radau.restitution, rel=2e-9)


def _admittance_of(result, ball, plate, speed):
    """beta (m/(N s)) that ``result`` was solved with, from Zener's lambda = beta m / theta."""
    K = laws.hertz_stiffness(ball, plate)
    theta = (ball.mass / (K * speed**0.5)) ** 0.4
    return result.inelasticity * theta / ball.mass


def test_edge_admittance_is_self_consistent_near_edges():
    # Near an edge the admittance depends on the contact time and the contact time on the
    # admittance: the solution returned is their fixed point, A(tau) = beta to 1e-6
    # (10x the stopping rule's 0.1 rtol, for the rounding of beta recovered from lambda),
    # for every contact that separates; for one that settles (e = 0 whatever the
    # admittance) the message says when no consistent value exists. Never "did not converge".
    rng = np.random.default_rng(7)
    names = sorted(TABLE)
    separated = 0
    for i in range(600):
        ball = Ball(
            names[rng.integers(len(names))], 10 ** rng.uniform(np.log10(5e-4), np.log10(5e-2))
        )
        plate = Plate(
            names[rng.integers(len(names))],
            10 ** rng.uniform(np.log10(3e-4), np.log10(5e-2)),
            1.2,
            0.8,
        )
        v = 10 ** rng.uniform(-3, np.log10(30.0))
        d = 10 ** rng.uniform(-4, -1.3)
        pos = [(d, 0.4), (d, d), (0.6, 0.8 - d)][i % 3]
        r = contact.solve_impact(ball, plate, v, position=pos)
        assert r.success and "did not converge" not in r.message, (ball, plate, v, pos, r.message)
        if r.settled:
            continue
        assert "no consistent value" not in r.message, (ball, plate, v, pos, r.message)
        separated += 1
        beta = _admittance_of(r, ball, plate, v)
        assert impedance.point_admittance(plate, pos, r.contact_time) == pytest.approx(
            beta, rel=1e-6
        )
    assert separated > 300


# --- bad input -------------------------------------------------------------------------
GOOD = dict(mass=0.004, stiffness=1e9, admittance=1e-3, speed=1.0)


@pytest.mark.parametrize("field", ["mass", "stiffness", "speed"])
@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), "1", None])
def test_solve_contact_rejects_bad_positive_fields(field, bad):
    with pytest.raises(ParameterError, match=field):
        contact.solve_contact(**{**GOOD, field: bad})


@pytest.mark.parametrize(
    "field, bad",
    [
        ("admittance", -1e-3),
        ("admittance", float("nan")),
        ("gravity", -9.81),
        ("gravity", float("inf")),
        ("exponent", 1.0),
        ("exponent", 4.5),
        ("dissipation", -0.1),
        ("plate_velocity", float("nan")),
        ("rtol", 0.0),
        ("rtol", 1e-14),
        ("rtol", 0.5),
        ("n_points", 8),
        ("n_points", 63),
        ("n_points", 64.0),
        ("method", "euler"),
    ],
)
def test_solve_contact_rejects_bad_fields(field, bad):
    with pytest.raises(ParameterError, match=field):
        contact.solve_contact(**{**GOOD, field: bad})


def test_solve_contact_rejects_plate_moving_away_faster_than_ball():
    with pytest.raises(ParameterError, match="plate_velocity"):
        contact.solve_contact(**{**GOOD, "plate_velocity": -2.0})


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(contact="glue"), "contact"),
        (dict(contact="hunt-crossley"), "dissipation"),
        (dict(contact="hertz", dissipation=0.1), "dissipation"),
        (dict(contact="power-law", exponent=1.5), "power-law"),
        (dict(contact="elastic-foundation", layer_depth=-1.0), "layer_depth"),
        (dict(position=(2.0, 0.1)), "position"),
    ],
)
def test_solve_impact_rejects_bad_options(kw, word):
    with pytest.raises(ParameterError, match=word):
        contact.solve_impact(STEEL10, MDF18, 1.0, **kw)


def test_solve_impact_rejects_non_objects():
    with pytest.raises(ParameterError, match="ball"):
        contact.solve_impact("steel", MDF18, 1.0)
    with pytest.raises(ParameterError, match="plate"):
        contact.solve_impact(STEEL10, "mdf-18", 1.0)


# --- the solver object (the seam the bounce scheduler calls) ---------------------------
SAME_FIELDS = (
    "restitution",
    "contact_time",
    "max_penetration",
    "peak_force",
    "impulse",
    "inelasticity",
    "settled",
    "rebound_speed",
    "plate_energy",
    "energy_residual",
    "status",
    "message",
    "n_steps",
    "method",
)


def same(a, b):
    return all(getattr(a, f) == getattr(b, f) for f in SAME_FIELDS)


def test_contact_solver_equals_the_functions():
    # One computation behind both doors: the solver's impacts equal those of solve_impact
    # (middle and near a corner) and of solve_contact (lumped) to the last bit.
    solver = contact.ContactSolver.for_pair(STEEL10, MDF18)
    assert same(solver.solve(1.4), contact.solve_impact(STEEL10, MDF18, 1.4))
    corner = (0.01, 0.02)
    assert same(
        solver.solve(1.4, position=corner),
        contact.solve_impact(STEEL10, MDF18, 1.4, position=corner),
    )
    lump = lumped()
    assert same(
        solver.solve(0.7, admittance=lump["admittance"], free_velocity=0.1),
        contact.solve_contact(speed=0.7, plate_velocity=0.1, **lump),
    )
    np.testing.assert_array_equal(
        solver.solve(1.4).force, contact.solve_impact(STEEL10, MDF18, 1.4).force
    )


def test_contact_solver_rejects_bad_input():
    solver = contact.ContactSolver.for_pair(STEEL10, MDF18)
    for kw, field in (
        (dict(speed=-1.0), "speed"),
        (dict(speed=1.0, free_velocity=-2.0), "free"),
        (dict(speed=1.0, admittance=-1.0), "admittance"),
        (dict(speed=1.0, position=(5.0, 0.1)), "position"),
    ):
        with pytest.raises(ParameterError, match=field):
            solver.solve(**kw)
    with pytest.raises(ParameterError, match="admittance"):
        contact.ContactSolver(1e-3, 1e9, 1.5).solve(1.0)
    with pytest.raises(ParameterError, match="n_points"):
        contact.ContactSolver.for_pair(STEEL10, MDF18, n_points=10)
    with pytest.raises(ParameterError, match="rtol"):
        contact.ContactSolver(1e-3, 1e9, 1.5, rtol=0.5)
