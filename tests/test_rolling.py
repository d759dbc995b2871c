"""Rolling contact: the speed at which contact is lost, the energy balance, reproducibility
(synth.physics.rolling; docs/rolling.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from synth import ParameterError
from synth.physics import rolling, surface
from synth.physics.scene import Ball, Plate

G = 9.81
AMPLITUDE = 2e-5  # m
WAVELENGTH = 5e-3  # m
SAMPLERATE = 48000


@pytest.fixture(scope="module")
def pair():
    return Ball("steel", 0.01), Plate("glass", 0.006, 1.0, 0.6)


def sinusoid_envelope(radius, length=0.1):
    # troughs at x = 0, wavelength, ...: h = -A cos(k x)
    profile = surface.sinusoidal_profile(
        amplitude=AMPLITUDE,
        wavelength=WAVELENGTH,
        length=length,
        spacing=WAVELENGTH / 200,
        phase=-math.pi / 2,
    )
    return surface.contact_envelope(profile, radius)


def closed_form_loss_speed(radius):
    """Rigid contact: the centre rides the envelope, whose radius of curvature over a crest
    of the sinusoid is rho + R (rho = 1 / (A k^2)); it stays down while its centripetal
    acceleration v^2 / (rho + R) is at most g: v_c = sqrt(g (rho + R))."""
    k = 2.0 * math.pi / WAVELENGTH
    return math.sqrt(G * (1.0 / (AMPLITUDE * k * k) + radius))


@pytest.mark.parametrize("radius", [0.01, 0.002])
def test_contact_loss_speed_matches_closed_form(pair, radius):
    """The speed at which a ball starts to lose contact on a sinusoid: within 1 % of
    sqrt(g (rho + R)). The Hertz compliance lowers it by a dynamic correction of order
    (k v / omega_c)^2 (omega_c the contact's natural angular frequency at rest, 1.1e4
    rad/s for the 10 mm ball; k v = 800 rad/s): 5e-3; bisection to 1e-3."""
    ball = Ball("steel", radius)
    env = sinusoid_envelope(radius)
    vc = closed_form_loss_speed(radius)
    # from a trough (where the start is quasi-static), over three crests
    roller = rolling.Roller.over(
        ball, pair[1], env, samplerate=SAMPLERATE, origin=(0.1, 0.3), admittance=0.0
    )
    found = rolling.loss_of_contact_speed(
        roller, start=WAVELENGTH, stop=4.5 * WAVELENGTH, low=0.9 * vc, high=1.05 * vc
    )
    assert found.success, found.message
    assert found.high - found.low <= 1e-3 * found.high
    assert abs(found.speed / vc - 1.0) < 0.01
    # the point-contact estimate sqrt(g rho) ignores the ball's size: 13 % off for R = 10 mm
    k = 2.0 * math.pi / WAVELENGTH
    point = math.sqrt(G / (AMPLITUDE * k * k))
    if radius == 0.01:
        assert abs(found.speed / point - 1.0) > 0.1


def test_loss_of_contact_speed_reports_a_bad_bracket(pair):
    ball, plate = pair
    env = sinusoid_envelope(ball.radius)
    vc = closed_form_loss_speed(ball.radius)
    roller = rolling.Roller.over(ball, plate, env, samplerate=SAMPLERATE, origin=(0.1, 0.3))
    kw = dict(start=WAVELENGTH, stop=3 * WAVELENGTH)
    low_too_high = rolling.loss_of_contact_speed(roller, low=1.2 * vc, high=1.5 * vc, **kw)
    assert not low_too_high.success and "already leaves" in low_too_high.message
    high_too_low = rolling.loss_of_contact_speed(roller, low=0.5 * vc, high=0.6 * vc, **kw)
    assert not high_too_low.success and "stays on" in high_too_low.message
    with pytest.raises(ParameterError, match="high"):
        rolling.loss_of_contact_speed(roller, low=1.0, high=0.5, **kw)
    with pytest.raises(ParameterError, match="roller"):
        rolling.loss_of_contact_speed(ball, low=0.5, high=1.0, **kw)


def test_envelope_curvature_over_crest_and_trough():
    """The envelope's curvature: -1/(rho + R) over a crest, 1/(rho - R) in a trough
    (offset curves of the sinusoid's osculating circles), to the grid's O(dx^2) (1e-3)."""
    R = 0.01
    env = sinusoid_envelope(R)
    dx = env.spacing
    rho = 1.0 / (AMPLITUDE * (2.0 * math.pi / WAVELENGTH) ** 2)
    crest = int(round(1.5 * WAVELENGTH / dx))
    trough = int(round(2.0 * WAVELENGTH / dx))
    for i, expected in ((crest, -1.0 / (rho + R)), (trough, 1.0 / (rho - R))):
        curvature = surface.envelope_at(env.coefficients, dx, i * dx)[2]
        assert curvature == pytest.approx(expected, rel=1e-3)


def test_envelope_bridges_a_dip_narrower_than_the_ball():
    """A ball wider than the trough's curvature allows (R > rho) rests on the two crests'
    flanks: its lowest point stays above the trough's bottom, where the closed form of a
    sphere between two circles puts it; a ball that fits touches the bottom."""
    profile = surface.sinusoidal_profile(
        amplitude=AMPLITUDE, wavelength=WAVELENGTH, length=0.02, spacing=WAVELENGTH / 400,
        phase=-math.pi / 2,
    )  # fmt: skip
    rho = 1.0 / (AMPLITUDE * (2.0 * math.pi / WAVELENGTH) ** 2)
    i = int(round(2 * WAVELENGTH / profile.spacing))
    small = surface.contact_envelope(profile, 0.5 * rho)
    assert small.heights[i] == pytest.approx(-AMPLITUDE, abs=1e-12)
    assert small.contact_offsets[i] == pytest.approx(0.0, abs=1e-9)
    big = surface.contact_envelope(profile, 5.0 * rho)
    assert big.heights[i] > -AMPLITUDE + 1e-7
    assert abs(big.contact_offsets[i]) > 10 * profile.spacing


def roll_sinusoid(pair, speed, **kw):
    ball, plate = pair
    env = sinusoid_envelope(ball.radius)
    kw.setdefault("duration", 4.0 * WAVELENGTH / speed)
    return rolling.roll(
        ball, plate, env, speed=speed, samplerate=SAMPLERATE, origin=(0.1, 0.3),
        start=WAVELENGTH, **kw,
    )  # fmt: skip


@pytest.mark.parametrize(
    "speed_ratio, options",
    [
        (0.5, dict(admittance=0.0)),
        (1.3, dict(admittance=0.0)),
        (0.5, dict(contact="hunt-crossley", dissipation=0.5)),
        (1.3, dict(contact="hunt-crossley", dissipation=0.5)),
        (1.3, dict(contact="viscoelastic", viscous_time=1e-6)),
    ],
)
def test_energy_balance(pair, speed_ratio, options):
    """Mechanical energy, the drive's work, the contact's loss and the plate's share
    balance to 1e-5 of the energy exchanged at rtol 1e-8 (the quadratures ride the same
    Runge-Kutta stages as the state; micro-bounces above v_c included); with a loss or
    an impedance, each takes a positive share."""
    v = speed_ratio * closed_form_loss_speed(pair[0].radius)
    r = roll_sinusoid(pair, v, rtol=1e-8, **options)
    assert r.success, r.message
    assert r.energy.residual < 1e-5
    if speed_ratio > 1.0:
        assert r.flights > 0
    else:
        assert r.flights == 0
    if "contact" in options:
        assert r.energy.loss_work > 0.0
        assert r.energy.plate_energy > 0.0
        # what the loss and the plate take, the drive supplies: a positive drag
        assert r.mean_drag > 0.0
    else:
        assert r.energy.loss_work == 0.0 and r.energy.plate_energy == 0.0


def test_force_averages_to_the_weight(pair):
    """Over whole periods of a steady roll below v_c the mean force is the weight (the
    ball's mean vertical momentum does not change), to the integrator's tolerance and the
    start's small transient (1e-4)."""
    ball = pair[0]
    v = 0.5 * closed_form_loss_speed(ball.radius)
    periods = 4
    r = roll_sinusoid(pair, v, duration=periods * WAVELENGTH / v, admittance=0.0)
    n = int(round(periods * WAVELENGTH / v * SAMPLERATE))
    assert np.mean(r.force[:n]) == pytest.approx(ball.mass * G, rel=1e-3)


def test_rolling_is_reproducible(pair):
    """The same inputs give the same bytes."""
    ball, plate = pair
    spec = surface.RoughnessSpectrum(rms_height=2e-6, correlation_length=2e-4, hurst=0.8)
    runs = []
    for _ in range(2):
        profile = surface.rough_profile(spec, length=0.05, spacing=5e-6, seed=7)
        env = surface.contact_envelope(profile, ball.radius)
        r = rolling.roll(
            ball, plate, env, speed=0.3, duration=0.05, samplerate=SAMPLERATE,
            origin=(0.2, 0.3), start=0.01,
        )  # fmt: skip
        assert r.success, r.message
        runs.append(r)
    assert runs[0].force.tobytes() == runs[1].force.tobytes()
    assert runs[0].contact_point.tobytes() == runs[1].contact_point.tobytes()


def test_roll_rejects_bad_input(pair):
    ball, plate = pair
    env = sinusoid_envelope(ball.radius)
    ok = dict(speed=0.3, duration=0.01, samplerate=SAMPLERATE, origin=(0.1, 0.3))
    cases = [
        (dict(speed=-1.0), "speed"),
        (dict(duration=0.0), "duration"),
        (dict(samplerate=44100.5), "samplerate"),
        (dict(duration=1.0), "beyond the envelope"),
        (dict(origin=(0.999, 0.3)), "leaves the plate"),
        (dict(direction=(0.0, 0.0)), "direction"),
        (dict(admittance=-1.0), "admittance"),
        (dict(rtol=0.5), "rtol"),
        (dict(contact="hunt-crossley"), "dissipation"),
    ]
    for change, words in cases:
        with pytest.raises(ParameterError, match=words):
            rolling.roll(ball, plate, env, **{**ok, **change})
    with pytest.raises(ParameterError, match="radius"):
        rolling.roll(Ball("steel", 0.005), plate, env, **ok)


@pytest.mark.parametrize("admittance", [0.0, None])
def test_flat_surface_carries_the_weight(pair, admittance):
    """On a flat surface the ball rests: the force is its weight in every sample (to
    rounding, 1e-9), no flight; on the plate's impedance (a dashpot) it sinks at
    beta m g, and the plate takes beta (m g)^2 per second."""
    ball, plate = pair
    profile = surface.Profile(np.zeros(2001), 1e-4, "flat")
    env = surface.contact_envelope(profile, ball.radius)
    T = 0.05
    r = rolling.roll(
        ball, plate, env, speed=0.5, duration=T, samplerate=SAMPLERATE, origin=(0.1, 0.3),
        start=0.01, admittance=admittance,
    )  # fmt: skip
    assert r.success, r.message
    weight = ball.mass * G
    assert np.max(np.abs(r.force / weight - 1.0)) < 1e-9
    assert r.flights == 0 and not np.any(r.contact_lost)
    assert r.energy.plate_energy == pytest.approx(r.admittance * weight**2 * T, rel=1e-9)
    assert r.energy.residual < 1e-9


def test_rolling_in_pieces_equals_one_call(pair):
    """A rolling cut into calls at sample boundaries, each continuing from the last one's
    final_state with its own speeds, gives the bits of one call over the same speeds."""
    ball, plate = pair
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.8)
    env = surface.contact_envelope(
        surface.rough_profile(spec, length=0.05, spacing=5e-6, seed=2), ball.radius
    )
    speeds = np.concatenate([np.full(800, 0.2), np.linspace(0.2, 0.6, 1600), np.full(800, 0.6)])
    kw = dict(samplerate=SAMPLERATE, origin=(0.1, 0.3))
    whole = rolling.roll(ball, plate, env, speed=speeds, start=0.01, **kw)
    assert whole.success, whole.message
    pieces, state = [], None
    for a, b in ((0, 768), (768, 1536), (1536, 3200)):
        part = rolling.roll(
            ball, plate, env, speed=speeds[a:b], state=state, start=None if state else 0.01,
            **kw,
        )  # fmt: skip
        pieces.append(part)
        state = part.final_state
    assert np.concatenate([p.force for p in pieces]).tobytes() == whole.force.tobytes()
    assert state.vector.tobytes() == whole.final_state.vector.tobytes()
    assert state.path_position == pytest.approx(0.01 + np.sum(speeds) / SAMPLERATE, rel=1e-12)


def test_energy_balance_with_a_changing_speed(pair):
    """The balance holds while the drive accelerates the ball (speed per sample), to 1e-5
    of the energy exchanged at rtol 1e-8 (as with a constant speed)."""
    ball, plate = pair
    v_c = closed_form_loss_speed(ball.radius)
    speeds = np.linspace(0.3 * v_c, 1.3 * v_c, 4000)
    env = sinusoid_envelope(ball.radius)
    r = rolling.roll(
        ball, plate, env, speed=speeds, samplerate=SAMPLERATE, origin=(0.1, 0.3),
        start=WAVELENGTH, rtol=1e-8, contact="hunt-crossley", dissipation=0.5,
    )  # fmt: skip
    assert r.success, r.message
    assert r.energy.residual < 1e-5
    assert r.flights > 0  # it passed v_c


def test_rolling_state_rejects_bad_input(pair):
    env = sinusoid_envelope(pair[0].radius)
    with pytest.raises(ParameterError, match="path_position"):
        rolling.RollingState.at(env, path_position=-0.1, height=0.0, vertical_velocity=0.0)
    with pytest.raises(ParameterError, match="height"):
        rolling.RollingState.at(env, path_position=0.01, height=math.nan, vertical_velocity=0.0)
    with pytest.raises(ParameterError, match="envelope"):
        rolling.RollingState.at("flat", path_position=0.01, height=0.0, vertical_velocity=0.0)


def test_roll_rejects_bad_speeds_and_states(pair):
    ball, plate = pair
    env = sinusoid_envelope(ball.radius)
    kw = dict(samplerate=SAMPLERATE, origin=(0.1, 0.3))
    with pytest.raises(ParameterError, match="duration"):
        rolling.roll(ball, plate, env, speed=np.full(10, 0.1), duration=0.01, **kw)
    with pytest.raises(ParameterError, match="duration"):
        rolling.roll(ball, plate, env, speed=0.1, **kw)
    with pytest.raises(ParameterError, match=r"speed\[3\]"):
        rolling.roll(ball, plate, env, speed=np.array([0.1, 0.1, 0.1, -0.1]), **kw)
    done = rolling.roll(ball, plate, env, speed=0.1, duration=0.001, **kw)
    with pytest.raises(ParameterError, match="start or state"):
        rolling.roll(ball, plate, env, speed=0.1, duration=0.001, start=0.0,
                     state=done.final_state, **kw)  # fmt: skip
    with pytest.raises(ParameterError, match="state"):
        rolling.roll(ball, plate, env, speed=0.1, duration=0.001, state="here", **kw)


# the impact solver's kernels compile in about 30 s on a cold cache
@pytest.mark.slow
@pytest.mark.parametrize(
    "radius, v_in, options",
    [
        (0.01, 0.05, dict(admittance=0.0)),
        (0.01, 0.05, dict(contact="hunt-crossley", dissipation=0.5)),
        (0.01, 0.05, dict(contact="viscoelastic", viscous_time=1e-6)),
        (0.01, 0.05, dict()),
        # a contact of a few microseconds, shorter than a sample period
        (0.0005, 1.0, dict(admittance=0.0)),
    ],
    ids=[
        "rigid-elastic",
        "impedance-hunt-crossley",
        "impedance-viscoelastic",
        "impedance-elastic",
        "small-fast-rigid",
    ],
)
def test_landing_on_a_flat_surface_is_the_impact_solvers_impact(pair, radius, v_in, options):
    """A ball landing on a flat surface is an impact of the same equations: the rolling
    solver's impulse and rebound speed equal those of the impact solver (solve_contact,
    its own integrators, the same law and admittance) to 1e-5 (both meet rtol 1e-8), also
    for a contact shorter than a sample period."""
    from synth.physics.contact import solve_contact

    ball, plate = Ball("steel", radius), pair[1]
    env = surface.contact_envelope(surface.Profile(np.zeros(1001), 1e-4, "flat"), ball.radius)
    landing = rolling.RollingState.at(env, path_position=0.02, height=0.0, vertical_velocity=-v_in)
    T = 0.002  # the contacts last 0.2 ms at most; the ball is in flight at the end
    r = rolling.roll(
        ball, plate, env, speed=0.1, duration=T, samplerate=SAMPLERATE, origin=(0.1, 0.3),
        state=landing, rtol=1e-8, **options,
    )  # fmt: skip
    assert r.success, r.message
    impact = solve_contact(
        mass=ball.mass, stiffness=r.law.stiffness, admittance=r.admittance, speed=v_in,
        dissipation=r.law.dissipation, viscous_time=r.law.viscous_time, rtol=1e-8,
    )  # fmt: skip
    assert impact.success and impact.contact_time < 0.5 * T
    assert r.flights == 1
    impulse = np.sum(r.force) / SAMPLERATE
    assert impulse == pytest.approx(impact.impulse, rel=1e-5)
    rebound = r.final_state.vertical_velocity + G * (T - impact.separation_time)  # flies from there
    assert rebound == pytest.approx(impact.rebound_speed, rel=1e-5)


def test_rolling_force_on_a_sinusoid_is_the_closed_form(pair):
    """Slow rolling on a shallow sinusoid (A k^2 R << 1): the force's fundamental is the
    centre path's, m w^2 |E_1| (|E_1| the envelope's fundamental amplitude), amplified by
    the linearised Hertz spring, 1 / (1 - (w / omega_c)^2) with omega_c^2 = (3/2) g /
    delta_static, and scaled by the sample mean's sinc(w / 2 fs): to 1e-5 (the next
    terms: (w / omega_c)^4 = 1.4e-6, and the spring's nonlinearity, (w / omega_c)^2 times
    the force's relative swing, 3e-2: 4e-5 of the correction, 4e-8 of the force), while the
    Hertz correction itself is 1.2e-3."""
    ball, plate = pair
    A, periods = 2e-6, 6
    profile = surface.sinusoidal_profile(
        amplitude=A, wavelength=WAVELENGTH, length=0.1, spacing=WAVELENGTH / 200,
        phase=-math.pi / 2,
    )  # fmt: skip
    env = surface.contact_envelope(profile, ball.radius)
    k = 2.0 * math.pi / WAVELENGTH
    i0, i1 = (int(round(p * WAVELENGTH / env.spacing)) for p in (2, 10))
    x = np.arange(i0, i1) * env.spacing
    E1 = abs(2.0 * np.mean(env.heights[i0:i1] * np.exp(-1j * k * x)))
    per_period = 800  # samples: v = 0.3 m/s
    v = WAVELENGTH * SAMPLERATE / per_period
    n = periods * per_period
    r = rolling.roll(
        ball, plate, env, speed=v, duration=n / SAMPLERATE, samplerate=SAMPLERATE,
        origin=(0.1, 0.3), start=2 * WAVELENGTH, admittance=0.0, rtol=1e-9,
    )  # fmt: skip
    assert r.success, r.message
    w = k * v
    t = (np.arange(n) + 0.5) / SAMPLERATE
    F1 = abs(2.0 * np.mean(r.force * np.exp(-1j * w * t)))
    correction = w * w * r.static_penetration / (1.5 * G)
    half = w / (2 * SAMPLERATE)
    expected = ball.mass * w * w * E1 / (1.0 - correction) * math.sin(half) / half
    assert F1 == pytest.approx(expected, rel=1e-5)
    assert correction > 1e-3


def test_roller_blocks_give_the_bits_of_one_roll(pair):
    """A rolling integrated in blocks by one ``Roller`` (the path's way: its checks made once,
    the contact points and energies taken at the end) gives the bytes of one ``roll`` call
    over the same speeds: forces, centres, touching points, quadratures and final state."""
    ball, plate = pair
    spec = surface.RoughnessSpectrum(rms_height=2e-6, correlation_length=2e-4, hurst=0.8)
    env = surface.contact_envelope(
        surface.rough_profile(spec, length=0.05, spacing=5e-6, seed=7), ball.radius
    )
    speeds = np.linspace(0.35, 0.25, 2400)  # a speed per sample, as the path gives
    kw = dict(samplerate=SAMPLERATE, origin=(0.2, 0.3))
    whole = rolling.roll(ball, plate, env, speed=speeds, start=0.01, **kw)
    assert whole.success, whole.message
    roller = rolling.Roller.over(ball, plate, env, **kw)
    roller.check_reach(0.01, 0.01 + float(np.sum(speeds)) / SAMPLERATE)
    blocks, state = [], None
    for part in np.split(speeds, [480, 481, 1500]):
        block = roller.roll(part, state=state, start=None if state else 0.01)
        assert block.success, block.message
        blocks.append(block)
        state = block.final_state
    forces = np.concatenate([b.force for b in blocks])
    centres = np.concatenate([b.path_position for b in blocks])
    assert forces.tobytes() == whole.force.tobytes()
    assert centres.tobytes() == whole.path_position.tobytes()
    coordinates = roller.contact_coordinates(centres)
    assert coordinates.tobytes() == whole.contact_coordinate.tobytes()
    assert state.vector.tobytes() == whole.final_state.vector.tobytes()
    assert sum(b.flights for b in blocks) == whole.flights
    assert roller.mechanical_energy(roller.initial_state(speeds[0], 0.01)) == whole.energy.initial
    assert roller.mechanical_energy(state) == whole.energy.final


def test_an_unknown_option_is_named_with_every_allowed_one(pair):
    # Roller.over takes its settings and the contact law's options as keywords: a misspelt
    # one is refused naming it, its value and both lists (not the law's list alone).
    ball, plate = pair
    env = sinusoid_envelope(ball.radius)
    with pytest.raises(
        ParameterError,
        match=r"^gravty=9.8 is no option of a rolling: .*"
        r"admittance, gravity, rtol, landing_speed, surface, dissipation, .*layer_depth$",
    ):
        rolling.roll(ball, plate, env, speed=0.1, samplerate=SAMPLERATE, origin=(0.1, 0.3),
                     duration=0.01, gravty=9.8)  # fmt: skip
