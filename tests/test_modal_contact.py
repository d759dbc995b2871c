"""The finite plate in the contact (synth.physics.modal_contact): its integrator against the
impedance model's closed-form limit, its agreement with the infinite plate far from the edges,
its energy balance, and the boundary's effect on the restitution."""

from dataclasses import replace

import numpy as np
import pytest
from reference import residual_admittance_exact

from synth.errors import ParameterError
from synth.physics import impedance
from synth.physics import modal_contact as mc
from synth.physics.bounces import simulate_bounces, simulate_scene
from synth.physics.contact import solve_contact, solve_impact
from synth.physics.contact_law import hertz_stiffness
from synth.physics.materials import LossFactor, with_transverse_shear
from synth.physics.scene import Ball, Contact, Plate, Scene
from validation.modal import band_impedance

BALL = Ball("steel", 0.005)
#: A small 18 mm MDF plate: few modes, so the tests stay fast.
SMALL = Plate("mdf-18", 0.018, 0.3, 0.2)


@pytest.mark.parametrize("speed", [1.4, 0.05])
def test_integrator_reproduces_the_impedance_model_in_its_limit(speed, dashpot_point):
    # With the plate reduced to the dashpot 1/Z_inf the modal contact is the impedance model;
    # the scheme is second order in the step: 512 steps give e and tau to 1e-5 (measured
    # 3e-6 at 256 steps on the thesis' board), against the impedance solver at rtol 1e-10.
    plate = Plate("mdf-18", 0.018, 1.227, 0.49)
    K = hertz_stiffness(BALL, plate)
    contact = mc.ModalContact(dashpot_point(plate), BALL.mass, K, 1.5, 9.81)
    r = contact.solve(speed)
    ref = solve_contact(
        mass=BALL.mass,
        stiffness=K,
        admittance=1.0 / impedance.infinite_plate_impedance(plate),
        speed=speed,
        gravity=9.81,
        rtol=1e-10,
    )
    assert r.restitution == pytest.approx(ref.restitution, abs=1e-5)
    assert r.contact_time == pytest.approx(ref.contact_time, rel=1e-5)
    assert r.energy_residual < 1e-5
    # halving the step divides the error by about four
    fine = mc.ModalContact(contact.point, BALL.mass, K, 1.5, 9.81, steps_per_contact=64)
    coarse = mc.ModalContact(contact.point, BALL.mass, K, 1.5, 9.81, steps_per_contact=32)
    ratio = abs(coarse.solve(speed).restitution - ref.restitution) / abs(
        fine.solve(speed).restitution - ref.restitution
    )
    assert 3.0 < ratio < 5.0


def test_band_impedance_of_the_dashpot_is_z_inf(dashpot_point):
    plate = Plate("mdf-18", 0.018, 1.227, 0.49)
    p = dashpot_point(plate)
    y = p.admittance(np.array([10.0, 1e3, 1e5]))
    assert np.allclose(y, 1.0 / impedance.infinite_plate_impedance(plate))


def test_energy_balance_with_a_ringing_plate():
    # Ball energy in = ball energy out + energy gained by the plate's modes + modal damping +
    # rigid body + residual spring and dashpot: the solver's bookkeeping balances to 1e-5 of
    # the energy exchanged, from rest and from a plate left ringing by a first impact.
    contact = mc.ModalContact.for_pair(BALL, SMALL, (0.05, 0.03), speed=1.0)
    first = contact.solve(1.0)
    assert first.energy_residual < 1e-5
    assert first.plate_modal_energy > 0.0
    later = contact.solve(0.3, contact.ring(first.ringing, 0.01))
    assert later.energy_residual < 1e-5
    # the plate's energy only decays while it rings freely
    e1 = contact.energy(first.ringing)
    e2 = contact.energy(contact.ring(first.ringing, 0.01))
    assert 0.0 < e2 < e1


def test_free_edge_lowers_and_clamped_edge_raises_restitution():
    # A free edge makes the plate more compliant (Eichler: Z_edge = 0.29 Z_inf), a clamped
    # edge holds it (w = 0 there): e at the edge falls below the middle's on the free plate
    # and rises above it on the clamped one.
    free_mid = mc.ModalContact.for_pair(BALL, SMALL, None, speed=1.0).solve(1.0).restitution
    free_edge = mc.ModalContact.for_pair(BALL, SMALL, (0.15, 0.0), speed=1.0).solve(1.0)
    clamped = Plate("mdf-18", 0.018, 0.3, 0.2, boundary="clamped")
    cl_mid = mc.ModalContact.for_pair(BALL, clamped, None, speed=1.0).solve(1.0).restitution
    cl_edge = mc.ModalContact.for_pair(BALL, clamped, (0.15, 0.003), speed=1.0).solve(1.0)
    assert free_edge.restitution < free_mid - 0.1
    assert cl_edge.restitution > cl_mid + 0.01


@pytest.mark.slow
def test_thesis_board_middle_equals_impedance_model_at_every_band():
    # Far from the edges the finite plate is the infinite one until reflections return: the
    # residual is the infinite plate's modes above the band, so e agrees with the impedance
    # model within 2e-4 and tau within 1e-3 relative at the default band (4 / tau; measured
    # 1.2e-4, the lumped modes' damping) and within 5e-4 already at 1.5 / tau (measured
    # 3.4e-4).
    plate = Plate("mdf-18", 0.018, 1.227, 0.49)
    ref = solve_impact(BALL, plate, 1.4, rtol=1e-10)
    r4 = mc.ModalContact.for_pair(BALL, plate, None, speed=1.4).solve(1.4)
    assert r4.restitution == pytest.approx(ref.restitution, abs=2e-4)
    assert r4.contact_time == pytest.approx(ref.contact_time, rel=1e-3)
    tau = ref.contact_time
    r15 = mc.ModalContact.for_pair(BALL, plate, None, max_frequency=1.5 / tau).solve(1.4)
    assert r15.restitution == pytest.approx(ref.restitution, abs=5e-4)
    assert r15.contact_time == pytest.approx(ref.contact_time, rel=1e-3)


#: The thesis' 18 mm board, simply supported (closed-form modes: the residual depends on the
#: material and thickness only), and the same with MDF's soft transverse shear modulus.
_SS = Plate("mdf-18", 0.018, 1.227, 0.49, boundary="simply-supported")
_SOFT = replace(_SS, material=with_transverse_shear(_SS.material))


def _infinite_re_y(plate, theory, f):
    """Re Y of the infinite plate (m/(N s)) at ``f`` (Hz): Kirchhoff's 1 / Z_inf or
    Mindlin's closed form."""
    if theory == "mindlin":
        return impedance.mindlin_point_admittance(plate, f)
    return np.full_like(f, 1.0 / impedance.infinite_plate_impedance(plate))


@pytest.mark.parametrize(
    "plate, theory", [(_SS, "kirchhoff"), (_SS, "mindlin"), (_SOFT, "mindlin")]
)
def test_residual_is_the_infinite_plates_modes_above_the_band(plate, theory):
    # The residual is the wavenumber integral of the infinite plate's modes above the band
    # (mc.residual_admittance_exact, with the plate's loss at the band limit); its lumped
    # modes hold it within 3e-3 of the infinite plate's Re Y up to half the band and 1.5e-2
    # up to 0.75 of it (three bins per octave). Below the band it is reactive but for the
    # modes' damping: its real part stays under 5e-2 of Re Y up to half the band (MDF's
    # loss; a one-pole residual taken at the band limit had 9 % for Kirchhoff). Undamped,
    # for Kirchhoff, the integral is the closed form
    # i (beta / pi) [ln((O + w) / (O - w)) - ln((W + w) / (W - w))] plus the tail.
    fmax = 20e3
    point = mc.modal_point(plate, (0.6, 0.2), max_frequency=fmax, theory=theory)
    f = np.linspace(100.0, 0.75 * fmax, 60)
    exact = residual_admittance_exact(plate, fmax, f, theory=theory)
    scale = _infinite_re_y(plate, theory, f)
    err = np.abs(point.residual(f) - exact) / scale
    low = f <= 0.5 * fmax
    assert err[low].max() < 3e-3 and err.max() < 1.5e-2
    assert np.all(np.abs(point.residual(f[low]).real) < 5e-2 * scale[low])
    if theory == "kirchhoff":
        plate = replace(plate, material=replace(plate.material, damping=LossFactor(1e-12)))
        point = mc.modal_point(plate, (0.6, 0.2), max_frequency=fmax, theory=theory)
        exact = residual_admittance_exact(plate, fmax, f, theory=theory)
        beta = 1.0 / impedance.infinite_plate_impedance(plate)
        w, o = 2 * np.pi * f, 2 * np.pi * fmax
        top = o * mc.RESIDUAL_RATIO**mc.RESIDUAL_BINS
        s = 1j * w
        closed = 1j * beta / np.pi * (np.log((o + w) / (o - w)) - np.log((top + w) / (top - w)))
        closed += beta * s / (s + point.residual_rate)
        assert np.allclose(exact, closed, rtol=1e-5, atol=0.0)  # quadrature near the band
        # with the band's own modes as a continuum (real part beta, reactive part
        # -i (beta / pi) ln((O + w) / (O - w))) the plate is the infinite one, Y = beta
        band = beta - 1j * beta / np.pi * np.log((o + w) / (o - w))
        total = band + point.residual(f)
        assert np.abs(total[low] - beta).max() < 2e-3 * beta
        assert np.abs(total - beta).max() < 1.5e-2 * beta


@pytest.mark.slow
def test_thesis_board_impedance_middle_edge_corner_table_3_4():
    # Thesis Table 3.4 (18 mm MDF, impact hammer): 389 N s/m at the edge, 168 at the corner,
    # within 10 %; the middle is the thin-plate theory, Z_inf = 1629 (measured 1271: the
    # thesis' plate is softer than Kirchhoff's in the middle, not a boundary effect).
    plate = Plate("mdf-18", 0.018, 1.227, 0.49)
    band = 4.0 / solve_impact(BALL, plate, 1.4).contact_time
    z = {
        name: band_impedance(mc.modal_point(plate, pos, max_frequency=band), 0.0, 1e4)
        for name, pos in (("middle", plate.centre), ("edge", (0.6135, 0.0)), ("corner", (0, 0)))
    }
    assert z["middle"] == pytest.approx(1629.0, rel=0.02)
    assert z["edge"] == pytest.approx(389.0, rel=0.10)
    assert z["corner"] == pytest.approx(168.0, rel=0.10)


def test_bounce_series_carries_the_ringing():
    seq = simulate_bounces(BALL, SMALL, drop_height=0.05, plate_model="modal", max_impacts=6)
    contact = mc.ModalContact.for_pair(BALL, SMALL, None, speed=seq[0].speed)
    assert seq[0].restitution == contact.solve(seq[0].speed).restitution
    # the second impact meets a ringing plate: solving it on a plate at rest differs
    assert seq[1].restitution != contact.solve(seq[1].speed).restitution
    assert all(i.result.energy_residual < 1e-5 for i in seq)
    times = [i.time for i in seq]
    assert all(b > a for a, b in zip(times, times[1:]))


def test_scene_opts_into_the_modal_plate():
    scene = Scene(BALL, SMALL, drop_height=0.05, contact=Contact(plate="modal"))
    seq = simulate_scene(scene, max_impacts=3)
    assert seq[0].result.method == "modal"
    with pytest.raises(ParameterError, match="contact.plate"):
        Contact(plate="rigid")
    with pytest.raises(ParameterError, match="max_frequency"):
        simulate_bounces(BALL, SMALL, drop_height=0.05, max_frequency=1e4)


def test_bad_input_names_the_field():
    with pytest.raises(ParameterError, match="steps_per_contact"):
        replace(mc.ModalContact.for_pair(BALL, SMALL), steps_per_contact=4)
    with pytest.raises(ParameterError, match="dissipation"):
        mc.ModalContact.for_pair(BALL, SMALL, law="hunt-crossley", dissipation=-0.1)
    with pytest.raises(ParameterError, match="position"):
        mc.ModalContact.for_pair(BALL, SMALL, (0.5, 0.1))
    with pytest.raises(ParameterError, match="speed"):
        mc.ModalContact.for_pair(BALL, SMALL).solve(-1.0)
    with pytest.raises(ParameterError, match="frequency"):
        mc.modal_point(SMALL, (0.1, 0.1), max_frequency=1e4).admittance(-5.0)


def test_live_engine_refuses_the_modal_plate():
    # a live body solves its contacts with the impedance model: asking for the modal plate
    # there is an error naming the field, not a silent substitution
    import synth

    engine = synth.Engine(samplerate=48000)
    body = engine.add(SMALL)
    with pytest.raises(ParameterError, match="contact.plate='modal'"):
        body.hit(BALL, 1.0, contact=Contact(plate="modal"))


def test_pulse_is_the_contact_law_of_the_interpolated_penetration():
    # At the solver's steps the pulse is the solver's force (to rounding); between them
    # F = K delta^n of a C1 interpolant of delta: its integral is the impulse (trapezoid of
    # the steps, second order: 1e-5) and its slope the derivative of the force (1e-3 of the
    # largest slope by central differences on 4001 points)
    c = mc.ModalContact.for_pair(BALL, SMALL, (0.05, 0.03), speed=1.0)
    r = c.solve(1.0)
    f_steps = r.force_at(r.step_times[1:-1])
    assert np.allclose(f_steps, r.step_forces[1:-1], rtol=1e-12, atol=1e-12 * r.peak_force)
    t = np.linspace(0.0, r.contact_time, 4001)
    f, slope = r.force_and_slope_at(t)
    assert np.trapezoid(f, t) == pytest.approx(r.impulse, rel=1e-5)
    fd = np.gradient(f, t)
    assert np.max(np.abs(fd[5:-5] - slope[5:-5])) < 1e-3 * np.max(np.abs(slope))
    assert r.force_at(-1e-6) == 0.0 and r.force_at(2.0 * r.contact_time) == 0.0
    forces, _ = r.pulse_samples(r.contact_time / 10, 11, 0.0, 1.0, 1)
    assert forces[0] == 0.0 and forces.size == 12


def _series_fingerprint(seq):
    """Every impact's time, speed, restitution and force pulse: equal bit for bit or not."""
    return [
        (i.time, i.speed, i.restitution, i.result.contact_time, i.result.force.tobytes())
        for i in seq.impacts
    ]


@pytest.mark.slow
def test_corner_preset_series_is_independent_of_the_mode_cache(empty_caches, tmp_path):
    # The modal contact's modes come from a solve of exactly its band: a wider band's
    # solution in the mode cache (equal within the solver's tolerance, not bit-equal) must
    # not change the bounces, which amplify any difference (to 1-3 % of full scale).
    from synth.io.presets import load_preset
    from synth.physics import modes
    from synth.store.cache import cache_dir

    scene = load_preset("thesis-steel10-mdf18-corner")
    cold = _series_fingerprint(simulate_scene(scene))
    speed = (2.0 * scene.gravity * scene.drop_height) ** 0.5
    band = mc.ModalContact.for_pair(
        scene.ball, scene.plate, scene.position, speed=speed, **scene.contact.options()
    ).point.max_frequency
    modes.modes(scene.plate, max_frequency=1.25 * band)  # a wider band, now in the mode cache
    mc.clear_memory_cache()
    disk = list(cache_dir().glob("contact-point-modes-*"))
    assert disk, "the contact's modes at the point are stored on disk"
    from_disk = _series_fingerprint(simulate_scene(scene))
    for path in disk:
        path.unlink()
    warm = _series_fingerprint(simulate_scene(scene))
    assert from_disk == cold
    assert warm == cold


def test_mindlin_modes_soften_the_plate_as_the_infinite_mindlin_plate():
    # Simply supported 18 mm MDF board (Mindlin's frequencies exact): Re Y averaged over
    # 0-10 kHz and over 49 interior points (the mean square of every shape is 1) grows from
    # Kirchhoff to Mindlin by the infinite plates' ratio (1.228). Both modal sums carry the
    # same finite-plate (boundary) share, which cancels in the ratio to about 1 %: 2 %.
    plate = Plate("mdf-18", 0.018, 1.227, 0.49, boundary="simply-supported")
    f = np.linspace(0.25, 1e4, 40000)
    ratio_inf = impedance.infinite_plate_impedance(plate) * np.mean(
        impedance.mindlin_point_admittance(plate, f)
    )

    def mean_y(theory):
        points = [
            (x * plate.length, y * plate.width)
            for x in np.linspace(0.1, 0.9, 7)
            for y in np.linspace(0.1, 0.9, 7)
        ]
        return np.mean(
            [
                1.0
                / band_impedance(mc.modal_point(plate, p, max_frequency=2e4, theory=theory), 0, 1e4)
                for p in points
            ]
        )

    assert mean_y("mindlin") / mean_y("kirchhoff") == pytest.approx(ratio_inf, rel=0.02)
    point = mc.modal_point(plate, (0.4, 0.2), max_frequency=2e4, theory="mindlin")
    assert point.theory == "mindlin"
    top = 2e4 * mc.RESIDUAL_RATIO**mc.RESIDUAL_BINS
    assert point.residual_admittance == impedance.mindlin_point_admittance(plate, top)
    assert point.omega.max() <= 2.0 * np.pi * 2e4
    with pytest.raises(ParameterError, match="theory"):
        mc.modal_point(plate, (0.4, 0.2), max_frequency=2e4, theory="reissner")


def test_impedance_contact_time_is_the_bands_time_scale():
    # The impedance model's contact (infinite plate, no gravity) that sets the modal band:
    # the same solve with the law's constants spelt out (rounding); the fitted surface's
    # softer Hertz contact lasts longer; a bad speed is refused.
    plate = Plate("mdf-18", 0.018, 1.227, 0.49)
    tau = mc.impedance_contact_time(BALL, plate, 1.4)
    ref = solve_contact(
        mass=BALL.mass,
        stiffness=hertz_stiffness(BALL, plate),
        admittance=1.0 / impedance.infinite_plate_impedance(plate),
        speed=1.4,
        gravity=0.0,
        rtol=1e-6,
    )
    assert tau == pytest.approx(ref.contact_time, rel=1e-12)
    assert mc.impedance_contact_time(BALL, plate, 1.4, surface="fitted") > 1.5 * tau
    with pytest.raises(ParameterError, match="speed"):
        mc.impedance_contact_time(BALL, plate, 0.0)
