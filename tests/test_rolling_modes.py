"""The rolling force driving the plate's modes at a moving point (synth.sound.rolling)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from synth import ParameterError
from synth.physics import rolling, surface
from synth.physics.scene import Accelerometer, Ball, Plate
from synth.sound import rolling as sound
from synth.sound.modal_bank import bank_coefficients
from synth.sound.render import modal_model

FS = 48000


def one_mode(frequency=440.0, sigma=20.0):
    omega = 2.0 * math.pi * frequency
    return np.array([-sigma + 1j * math.sqrt(omega**2 - sigma**2)]), omega, sigma


def mean_sinusoid(amplitude, angular_frequency, n):
    """The mean of ``amplitude sin(w t)`` over each sample period, N (exact)."""
    t = np.arange(n + 1) / FS
    c = np.cos(angular_frequency * t)
    return amplitude * (c[:-1] - c[1:]) / (angular_frequency / FS)


def test_stationary_sinusoidal_force_excites_a_mode_as_the_closed_form():
    """A force F0 sin(W t) at a fixed point drives a mode in steady state to
    b F0 sinc(W / 2 fs)^2 / (omega^2 - W^2 + 2 i sigma W) (the sample mean, then its hold;
    images at fs +- W reach the mode off resonance, below 1e-6 of it): to 1e-5, while the
    sinc^2 factor itself is 2.3e-4 away from 1."""
    poles, omega, sigma = one_mode()
    b, F0, W = 0.5, 2.0, 2.0 * math.pi * 400.0
    n = FS * 6 // 5
    force = mean_sinusoid(F0, W, n)
    path = sound.PathExcitation(0.0, 1.0, np.array([[b], [b]]), None)
    q = sound.drive_modes(force, np.zeros(n), path, poles, np.ones(1), FS)
    sinc = math.sin(W / (2 * FS)) / (W / (2 * FS))
    t = np.arange(n) / FS
    steady = (b * F0 * sinc**2 * np.exp(1j * W * t) / (omega**2 - W**2 + 2j * sigma * W)).imag
    tail = t > 1.0  # the free transient has decayed by exp(-20)
    amplitude = np.max(np.abs(steady[tail]))
    assert np.max(np.abs(q[tail] - steady[tail])) < 1e-5 * amplitude
    assert abs(sinc**2 - 1.0) > 2e-4


def test_accelerometer_hears_the_direct_term():
    """An accelerometer (output p^2, direct term b) under F0 sin(W t) at a fixed point: the
    mode's acceleration -W^2 q_ss under the held force (sinc^2), less that force's
    fundamental b F0 sinc^2 sin(W t), plus the direct term of the mean of the two held
    values at each sample, b F0 sinc cos(W / 2 fs) sin(W t): to 1e-5 of the amplitude (the
    images' share is (omega / 2 pi fs)^2 of the direct term, 1e-4 of it, and the direct
    term is a fifth of the amplitude). A direct term taken on one side of the step would be
    half a sample off: 5e-3 of the amplitude."""
    poles, omega, sigma = one_mode()
    b, F0, W = 0.5, 2.0, 2.0 * math.pi * 400.0
    n = FS * 6 // 5
    force = mean_sinusoid(F0, W, n)
    path = sound.PathExcitation(0.0, 1.0, np.array([[b], [b]]), np.array([[b], [b]]))
    a = sound.drive_modes(force, np.zeros(n), path, poles, poles**2, FS)
    x = W / (2 * FS)
    sinc = math.sin(x) / x
    t = np.arange(n) / FS
    q_ss = (b * F0 * sinc**2 * np.exp(1j * W * t) / (omega**2 - W**2 + 2j * sigma * W)).imag
    expected = -(W**2) * q_ss + b * F0 * (sinc * math.cos(x) - sinc**2) * np.sin(W * t)
    tail = t > 1.0
    amplitude = np.max(np.abs(expected[tail]))
    assert np.max(np.abs(a[tail] - expected[tail])) < 1e-5 * amplitude


def test_preloaded_plate_stays_in_its_static_deflection():
    """A constant force on a plate preloaded with it: the mode stays at its static
    deflection b F / omega^2 (displacement listener) and an accelerometer hears nothing
    (to rounding); without the preload the step rings."""
    poles, omega, _ = one_mode()
    b, F0, n = 0.5, 3.0, 4800
    table = np.array([[b], [b]])
    displacement = sound.PathExcitation(0.0, 1.0, table, None)
    acceleration = sound.PathExcitation(0.0, 1.0, table, table)  # with the direct term
    force, where = np.full(n, F0), np.full(n, 0.25)
    q = sound.drive_modes(force, where, displacement, poles, np.ones(1), FS, preload=F0)
    assert np.max(np.abs(q / (b * F0 / omega**2) - 1.0)) < 1e-12
    a = sound.drive_modes(force, where, acceleration, poles, poles**2, FS, preload=F0)
    assert np.max(np.abs(a)) < 1e-12 * b * F0
    ringing = sound.drive_modes(force, where, acceleration, poles, poles**2, FS)
    assert np.max(np.abs(ringing)) > 0.5 * b * F0


def test_force_moving_across_a_sinusoidal_shape():
    """A constant force F0 moving at speed v across b(s) = b0 sin(kappa s) drives the mode
    like the stationary force F0 b0 sin(W t), W = kappa v, sampled in the middle of each
    period and held (sinc(W / 2 fs)), with the table's linear interpolation every step
    (sinc(kappa step / 2)^2, the triangle kernel's): the steady state to 1e-4, while
    the interpolation's factor is 3.2e-3 away from 1 (its images reach the 50 Hz mode at
    1.3 kHz: below 1e-6)."""
    poles, omega, sigma = one_mode(frequency=50.0, sigma=10.0)
    b0, F0, kappa, v = 0.5, 2.0, 2.0 * math.pi / 0.1, 4.0
    W = kappa * v
    n = 2 * FS
    step = 2.0 * math.pi / (32 * kappa)
    rows = int(math.ceil(v * n / FS / step)) + 2
    table = b0 * np.sin(kappa * step * np.arange(rows))[:, None]
    path = sound.PathExcitation(0.0, step, np.ascontiguousarray(table), None)
    coordinate = v * (np.arange(n) + 0.5) / FS
    q = sound.drive_modes(np.full(n, F0), coordinate, path, poles, np.ones(1), FS)
    held = math.sin(W / (2 * FS)) / (W / (2 * FS))
    interpolated = (math.sin(kappa * step / 2) / (kappa * step / 2)) ** 2
    t = np.arange(n) / FS
    gain = b0 * F0 * held * interpolated / (omega**2 - W**2 + 2j * sigma * W)
    steady = (gain * np.exp(1j * W * t)).imag
    tail = t > 1.5  # the free transient has decayed by exp(-15)
    amplitude = np.max(np.abs(steady[tail]))
    assert np.max(np.abs(q[tail] - steady[tail])) < 1e-4 * amplitude
    assert abs(interpolated - 1.0) > 3e-3


def test_rolling_on_a_sinusoid_excites_a_mode_as_the_closed_form():
    """End to end: a steel ball rolling slowly over a shallow sinusoid on glass, at a fixed
    point of one mode: the mode's response at the rolling frequency w = k v is
    b F_1 sinc(w / 2 fs)^2 / (omega^2 - w^2 + 2 i sigma w), with F_1 = m w^2 |E_1| /
    (1 - (w / omega_c)^2) the closed form of the rolling force's fundamental
    (tests/test_rolling.py): to 1e-5 of it, over the last half second (the mode's start
    transient decayed by exp(-15))."""
    ball, plate = Ball("steel", 0.01), Plate("glass", 0.006, 1.0, 0.6)
    A, lam = 2e-6, 5e-3
    profile = surface.sinusoidal_profile(
        amplitude=A, wavelength=lam, length=0.35, spacing=lam / 200, phase=-math.pi / 2
    )
    env = surface.contact_envelope(profile, ball.radius)
    k = 2.0 * math.pi / lam
    i0, i1 = (int(round(p * lam / env.spacing)) for p in (2, 10))
    x = np.arange(i0, i1) * env.spacing
    E1 = abs(2.0 * np.mean(env.heights[i0:i1] * np.exp(-1j * k * x)))
    per_period = 800  # samples: v = 0.3 m/s, w = 2 pi 60 Hz
    v = lam * FS / per_period
    n = 60 * per_period
    r = rolling.roll(
        ball, plate, env, speed=v, duration=n / FS, samplerate=FS, origin=(0.1, 0.3),
        start=2 * lam, admittance=0.0, rtol=1e-9,
    )  # fmt: skip
    assert r.success, r.message
    poles, omega, sigma = one_mode(frequency=70.0, sigma=30.0)
    b = 0.5
    path = sound.PathExcitation(0.0, 1.0, np.array([[b], [b]]), None)
    q = sound.drive_modes(r.force, np.zeros(n), path, poles, np.ones(1), FS, preload=r.force[0])
    w = k * v
    half = w / (2 * FS)
    F1 = ball.mass * w * w * E1 / (1.0 - w * w * r.static_penetration / (1.5 * 9.81))
    expected = b * F1 * (math.sin(half) / half) ** 2 / abs(omega**2 - w**2 + 2j * sigma * w)
    tail = slice(n - 30 * per_period, n)
    t = np.arange(n)[tail] / FS
    measured = abs(2.0 * np.mean(q[tail] * np.exp(-1j * w * t)))
    assert measured == pytest.approx(expected, rel=1e-5)


def test_rolling_sound_on_a_plate():
    """A steel ball rolling over a rough glass plate is heard by an accelerometer: finite,
    not silent, the same bytes twice."""
    ball = Ball("steel", 0.01)
    plate = Plate("glass", 0.006, 0.5, 0.4, boundary="simply-supported")
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.8)
    env = surface.contact_envelope(
        surface.rough_profile(spec, length=0.06, spacing=5e-6, seed=3), ball.radius
    )
    model = modal_model(plate, Accelerometer((0.1, 0.1)), samplerate=FS, max_frequency=5000.0)
    outs = []
    for _ in range(2):
        r = rolling.roll(
            ball, plate, env, speed=0.2, duration=0.1, samplerate=FS, origin=(0.1, 0.2),
            start=0.01,
        )  # fmt: skip
        outs.append(sound.rolling_sound(r, model))
    assert np.all(np.isfinite(outs[0])) and np.max(np.abs(outs[0])) > 0.0
    assert outs[0].tobytes() == outs[1].tobytes()
    check_mode_bounds(r, model, outs[0])


def check_mode_bounds(r, model, full):
    """Each mode's part of the signal stays within its bound (sound.mode_bounds: a geometric
    series, an invariant of the recursion), and the modes that sound.audible_modes leaves
    out change no sample by more than ``floor * reference`` (the omission budget)."""
    c = r.contact_coordinate
    path = sound.path_excitation(
        model, origin=r.origin, direction=r.direction, start=c.min(), stop=c.max()
    )
    preload = float(r.force[0])
    bounds = sound.mode_bounds(r.force, path, model.poles, model.output, FS, preload=preload)
    for k in range(model.poles.size):
        one = np.arange(model.poles.size) == k
        part = sound.drive_modes(
            r.force, c, path.modes(one), model.poles[one], model.output[one], FS,
            preload=preload,
        )  # fmt: skip
        assert np.max(np.abs(part)) <= bounds[k]
    # a floor that leaves out the modes of the smaller bounds, some of them audible
    reference = float(np.max(np.abs(full)))
    floor = np.median(bounds) * bounds.size / reference
    keep = sound.audible_modes(
        r.force, path, model.poles, model.output, FS, floor=floor, reference=reference,
        preload=preload,
    )  # fmt: skip
    assert 0 < keep.sum() < keep.size
    kept = sound.rolling_sound(r, model, floor=floor, reference=reference)
    assert np.max(np.abs(kept - full)) > 0.0
    assert np.max(np.abs(kept - full)) <= floor * reference


def test_drive_modes_rejects_bad_input():
    poles, _, _ = one_mode()
    path = sound.PathExcitation(0.0, 1.0, np.array([[1.0], [1.0]]), None)
    with pytest.raises(ParameterError, match="coordinate"):
        sound.drive_modes(np.ones(3), np.array([0.0, 0.5, 2.0]), path, poles, np.ones(1), FS)
    with pytest.raises(ParameterError, match="modes"):
        sound.drive_modes(np.ones(3), np.zeros(3), path, np.r_[poles, poles], np.ones(2), FS)
    with pytest.raises(ParameterError, match="Nyquist"):
        sound.drive_modes(np.ones(3), np.zeros(3), path, np.array([-1 + 4e5j]), np.ones(1), FS)
    with pytest.raises(ParameterError, match="samplerate"):
        sound.drive_modes(np.ones(3), np.zeros(3), path, poles, np.ones(1), 0)


def test_drive_modes_is_the_sample_by_sample_recursion():
    """drive_modes (the modes as heard, the interval's gains once, four samples per pass)
    against the module docstring's update written out sample by sample: zeta_k <- e_k zeta_k
    + b_k(x_j) F_j h_k, heard as sum_k Re(l_k zeta_k) plus the accelerometer's direct term,
    (scipy's lfilter, mode by mode), over a second of a rough force with flights (no
    force) crossing many table intervals, one mode unheard (l_k = 0) and the state
    carried out. The same operations
    rearranged: relative L2 and the state within 1e-12 (float rounding; the recursion is
    stable, |e_k| < 1)."""
    plate = Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported")
    model = modal_model(plate, Accelerometer((0.3, 0.2)), samplerate=FS, max_frequency=2000.0)
    output = model.output.copy()
    output[3] = 0.0  # a mode the listener does not hear
    path = sound.path_excitation(model, origin=(0.1, 0.3), direction=(1.0, 0.0), start=0.0,
                                 stop=0.3)  # fmt: skip
    rng = np.random.default_rng(2)
    force = np.maximum(0.05 + 0.05 * rng.standard_normal(FS), 0.0)
    force[np.sin(2.0 * math.pi * 30.0 * np.arange(FS) / FS) < 0.0] = 0.0  # flights
    coordinate = np.linspace(0.0, 0.3, FS)
    state = sound.ModeState.at_rest(model.poles.size)
    audio = sound.drive_modes(force, coordinate, path, model.poles, output, FS, state=state)
    p = model.poles
    co = bank_coefficients(p, np.ones(p.size), output, FS)
    ring, heard = co.step_re + 1j * co.step_im, co.coef_re + 1j * co.coef_im
    hold = (np.exp(p / FS) - 1.0) / p
    direct = np.sum(path.direct, axis=1)
    # the table's rows interpolated at each sample, and the drive of each mode
    rows = path.excitation.shape[0]
    u = np.clip((coordinate - path.start) / path.step, 0.0, None)
    i = np.minimum(np.floor(u).astype(int), rows - 2)
    t = (u - i)[:, None]
    b = (1.0 - t) * path.excitation[i] + t * path.excitation[i + 1]
    drive = hold * b * force[:, None]
    # each mode's state at the start of each period: zeta[j] = e zeta[j-1] + drive[j-1]
    zeta = np.column_stack([lfilter([0.0, 1.0], [1.0, -ring[k]], drive[:, k])
                            for k in range(p.size)])  # fmt: skip
    direct = np.sum(path.direct, axis=1)
    d = (1.0 - t[:, 0]) * direct[i] + t[:, 0] * direct[i + 1]
    held = 0.5 * (force + np.r_[0.0, force[:-1]])  # the held force's two sides at t_j
    exact = np.sum((heard * zeta).real, axis=1) + held * d
    zeta = ring * zeta[-1] + drive[-1]
    assert np.linalg.norm(audio - exact) <= 1e-12 * np.linalg.norm(exact)
    assert np.max(np.abs(state.zeta - zeta)) <= 1e-12 * np.max(np.abs(zeta))
    assert abs(state.zeta[3]) > 0.0  # the unheard mode is driven all the same
