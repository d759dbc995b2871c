"""Tests of synth.sound.radiation.separable_gains: the Rayleigh integral of separable
(simply supported) mode shapes by the polar rule about the microphone, checked against
the rectangle rule of rayleigh_gains, and the crossover of plate_gains between them."""

from __future__ import annotations

import numpy as np
import pytest

from synth.errors import ParameterError
from synth.physics import modes as P
from synth.physics.materials import LossFactor, Material
from synth.physics.scene import Plate
from synth.sound import radiation as R
from synth.sound.radiation import angular
from synth.sound.radiation.common import refine

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))


pytestmark = pytest.mark.usefixtures("empty_caches")  # tests/conftest.py


def _ss_modes(a=0.3, b=0.2, h=0.002, max_frequency=6000.0):
    return P.modes(Plate(STEEL, h, a, b, "simply-supported"), max_frequency=max_frequency)


def _poles(m):
    s = -m.decay_rates + 1j * m.angular_frequencies
    kb = (
        m.angular_frequencies.max() ** 2 * m.plate.surface_density / m.plate.flexural_rigidity
    ) ** 0.25
    return s, kb


# Microphone above the middle, above an edge's line, outside the plate, close to the
# plate (the 1/R peak), and where a corner's distance equals an edge's (0.4, 0.3 from
# the corner (0, 0): both 0.5 m on a 0.9 m plate).
LISTENERS = [
    ((0.3, 0.2), (0.1, 0.05, 0.2)),
    ((0.3, 0.2), (0.3, 0.0, 0.1)),
    ((0.3, 0.2), (0.5, -0.2, 0.05)),
    ((0.3, 0.2), (0.12, 0.13, 0.01)),
    ((0.9, 0.7), (0.4, 0.3, 0.3)),
]


@pytest.mark.slow
@pytest.mark.parametrize("size, listener", LISTENERS)
def test_polar_rule_equals_rectangle_rule(size, listener):
    """Both rules estimate the same integral to tol (relative to max(|H|, 1e-4 S)): they
    differ by at most the sum of their errors, 2 tol, here with tol = 1e-6."""
    m = _ss_modes(*size, max_frequency=6000.0 if size[0] < 0.5 else 2500.0)
    s, kb = _poles(m)
    rect = R.rayleigh_gains(m.shapes, size, listener, s, max_wavenumber=kb, full_output=True)
    polar = R.separable_gains(m.separable(), listener, s, max_wavenumber=kb, full_output=True)
    assert rect.success and polar.success and polar.rule == "polar"
    scale = np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
    assert np.max(np.abs(polar.gains - rect.gains) / scale) <= 2e-6
    # the in-phase bound is the same integral of |phi| / R (|sin| has kinks: 5 %)
    assert np.allclose(polar.coherent, rect.coherent, rtol=0.05)


def test_polar_rule_with_damping_and_reference_distance():
    """The mirror poles and a reference distance, as render() asks for them."""
    m = _ss_modes()
    s, kb = _poles(m)
    mirror = -np.conj(s) * (1.0 + 0.05)  # strongly damped: sigma = 5 % omega
    mirror = mirror.real * 50 + 1j * mirror.imag
    listener = (0.2, 0.1, 0.3)
    r0 = R.distance(listener, (0.2, 0.1))
    rect = R.rayleigh_gains(
        m.shapes,
        (0.3, 0.2),
        listener,
        mirror,
        max_wavenumber=kb,
        reference_distance=r0,
        full_output=True,
    )
    polar = R.separable_gains(
        m.separable(), listener, mirror, max_wavenumber=kb, reference_distance=r0, full_output=True
    )
    scale = np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
    assert np.max(np.abs(polar.gains - rect.gains) / scale) <= 2e-6


def test_separable_shapes_equal_shapes():
    m = _ss_modes()
    sep = m.separable()
    pts = np.random.default_rng(1).uniform([0, 0], [0.3, 0.2], (50, 2))
    prod = sep.x_values(pts[:, 0])[:, sep.x_index] * sep.y_values(pts[:, 1])[:, sep.y_index]
    assert np.allclose(prod, m.shapes(pts), rtol=0, atol=1e-12)
    free = P.modes(Plate(STEEL, 0.002, 0.3, 0.2, "free"), max_frequency=2000.0)
    assert free.separable() is None


def test_plate_gains_crossover():
    """plate_gains takes the rule choose_rule names: the rectangle rule for a few modes
    of a small plate (its cost below the polar rule's, whose angular sums every mode
    shares), the polar rule for a large plate's many modes; cached under the rule."""
    from synth.sound.radiation import rules
    from synth.sound.radiation.common import check_settings

    small = _ss_modes(max_frequency=1500.0)
    s, kb = _poles(small)
    res = R.plate_gains(small, (0.1, 0.05, 0.2), s, max_wavenumber=kb, full_output=True)
    checked = check_settings(kb, max_points=R.DEFAULT_MAX_POINTS)
    problem = R._problem(small, (0.1, 0.05, 0.2), s, checked)
    assert res.rule == rules.choose_rule(problem).rule.name == "rectangle"
    big = _ss_modes(1.0, 0.8, 0.001, 10000.0)
    s, kb = _poles(big)
    res = R.plate_gains(big, (0.5, 0.4, 0.3), s, max_wavenumber=kb, full_output=True)
    assert res.rule == "polar" and res.success
    again = R.plate_gains(big, (0.5, 0.4, 0.3), s, max_wavenumber=kb, full_output=True)
    assert again is res
    R.clear_memory_cache()
    loaded = R.plate_gains(big, (0.5, 0.4, 0.3), s, max_wavenumber=kb, full_output=True)
    assert loaded.rule == "polar" and np.array_equal(loaded.gains, res.gains)
    assert R.cache_info()["disk_hits"] == 1


def test_separable_gains_bad_input():
    m = _ss_modes()
    s, kb = _poles(m)
    with pytest.raises(ParameterError, match="shapes"):
        R.separable_gains(m.shapes, (0.1, 0.1, 0.1), s, max_wavenumber=kb)
    with pytest.raises(ParameterError, match="poles"):
        R.separable_gains(m.separable(), (0.1, 0.1, 0.1), s[:-1], max_wavenumber=kb)
    with pytest.raises(ParameterError, match="listener_position.z"):
        R.separable_gains(m.separable(), (0.1, 0.1, 0.0), s, max_wavenumber=kb)


def test_selective_refinement_refines_only_the_failing_modes():
    """refine(selective=True) on a rule whose integrals converge as ``1 + c_k 16^-level`` (mode
    ``k`` with its own ``c_k``): every mode ends within tol of the limit 1 by its own
    test, each rule after the first check is applied to the modes still failing alone,
    and a mode that passed keeps the gain of the rule where it passed."""
    c = np.array([0.0, 1e-9, 1e-7, 1e-5, 1e-3])
    calls = []

    def rule(level, active):
        calls.append(active.copy())
        return 1.0 + c[active] * 16.0**-level, np.ones(active.size)

    tol = 1e-6
    res = refine(rule, lambda level: 100 * level, np.ones(5), np.ones(5), tol, 10**9, (1, 0), True)
    assert res.success and res.status == 0
    assert np.all(np.abs(res.gains - 1.0) <= 2 * tol)  # the true error: within the test's
    assert np.all(res.error <= tol * np.maximum(np.abs(res.gains), 1e-4))
    # levels 0 and 1 take every mode; then only those whose change exceeded tol
    assert [a.tolist() for a in calls[:2]] == [list(range(5))] * 2
    # the change from level L - 1 to L is 15 c_k / 16^L: 1e-5 and 1e-3 fail at level 1,
    # 1e-3 again at levels 2 and 3
    assert [a.tolist() for a in calls[2:]] == [[3, 4], [4], [4]]
    assert res.refinements == 4
    assert res.gains[2] == 1.0 + c[2] / 16.0  # passed on the first check: that rule's gain


def test_polar_rule_after_selective_refinement_equals_rectangle_rule():
    """For this microphone the polar rule needs a second refinement (some modes fail the
    first check); the modes refined alone still agree with the rectangle rule within
    2 tol."""
    size, listener = (0.3, 0.2), (0.2, 0.15, 0.4)
    m = _ss_modes(*size, max_frequency=6000.0)
    s, kb = _poles(m)
    rect = R.rayleigh_gains(m.shapes, size, listener, s, max_wavenumber=kb, full_output=True)
    polar = R.separable_gains(m.separable(), listener, s, max_wavenumber=kb, full_output=True)
    assert rect.success and polar.success and polar.refinements >= 2
    scale = np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
    assert np.max(np.abs(polar.gains - rect.gains) / scale) <= 2e-6


def test_bessel_j0_equals_scipy():
    """The kernel's J_0 (Hankel's expansion from 25 up, Cephes below) against
    scipy.special.j0 (Cephes throughout): both within a few ulp, so within 1e-15."""
    from reference import bessel_j0
    from scipy.special import j0

    x = np.concatenate(
        (
            np.linspace(0.0, 60.0, 60001),
            np.random.default_rng(2).uniform(0.0, 3000.0, 20000),
            [5.0, np.nextafter(5.0, 6.0), 25.0, np.nextafter(25.0, 0.0), 1e-12],
        )
    )
    assert np.max(np.abs(bessel_j0(x) - j0(x))) <= 1e-15
    rows = np.zeros((3, x.size))
    radii, signs = np.array([1.0, 0.5, 2.0]), np.array([1.0, 0.0, -1.0])
    R.polar._add_circle_sums(radii, signs, x, 0.5 * np.ones(x.size), rows)
    assert np.max(np.abs(rows[0] - 0.5 * j0(x))) <= 1e-15
    assert np.all(rows[1] == 0.0)
    assert np.max(np.abs(rows[2] + 0.5 * j0(2.0 * x))) <= 1e-15


@pytest.mark.parametrize("radius", [0.04, 0.085, 0.13, 0.19])
def test_whole_circle_in_closed_form(radius):
    """Simply supported shapes solve the Helmholtz equation in the whole plane: their
    integral over a whole circle is 2 pi phi(centre) J_0(k r) (the mean value theorem),
    and over the arcs on the plate that minus the integral over the arcs off it. Both
    angular sums (Gauss-Legendre at the rule's tolerance 1e-7) agree within 1e-9 of
    2 pi max|phi|."""
    from scipy.special import j0

    m = _ss_modes()
    sep = m.separable()
    listener = (0.12, 0.09, 0.2)
    kb = sep.wavenumber * np.sqrt(2.0)
    a, b = 0.3, 0.2
    on, off = angular.circle_arcs(radius, a, b, listener[0], listener[1])
    assert abs(sum(h - lo for lo, h in on + off) - 2.0 * np.pi) < 1e-12

    def arc_sums(arcs):
        theta, w = R.polar.angular_rule(radius, a, b, listener, kb, 1e-7, 1.0, arcs)
        x, y = listener[0] + radius * np.cos(theta), listener[1] + radius * np.sin(theta)
        prod = sep.x_values(x)[:, sep.x_index] * sep.y_values(y)[:, sep.y_index]
        return w @ prod

    centre = sep.x_values(np.array([listener[0]]))[0, sep.x_index]
    centre = centre * sep.y_values(np.array([listener[1]]))[0, sep.y_index]
    whole = 2.0 * np.pi * centre * j0(sep.mode_wavenumbers() * radius)
    assert np.max(np.abs(arc_sums(on) - (whole - arc_sums(off)))) <= 1e-9 * 2.0 * np.pi * 2.0
    if not off:  # the circle lies on the plate
        assert np.max(np.abs(arc_sums(on) - whole)) <= 1e-9 * 2.0 * np.pi * 2.0


def test_bessel_orders_by_recurrence_match_scipy_and_give_its_angular_bands():
    # Miller's backward recurrence against scipy's jv (an independent implementation, Amos'
    # algorithm): within 1e-7 of the largest order's magnitude at every order (near a zero
    # of J_n a relative error means nothing), and the angular band it sets (the first order
    # past x below tol) the same as scipy's values set, up to the recurrence's range
    import scipy.special

    for x in [0.0, 0.5, 1.0, 7.0, 40.0, 333.0, 1000.0, angular.RECURRENCE_MAX_X]:
        n_max = int(x) + 80 + int(8 * x ** (1.0 / 3.0))
        ref = scipy.special.jv(np.arange(n_max + 1), x)
        got = angular.bessel_orders(x, n_max)
        scale = np.maximum(np.abs(ref), 1e-16 * np.abs(ref).max())
        assert np.max(np.abs(got - ref) / scale) < 1e-7, x
        for tol in (1e-3, 1e-6, 1e-9, 1e-12):
            n = np.arange(np.floor(x), np.floor(x) + 64 + int(8 * x ** (1.0 / 3.0)))
            small = np.flatnonzero(np.abs(scipy.special.jv(n, x)) <= tol)
            expected = int(n[small[0]]) if small.size else int(n[-1])
            assert angular._angular_band(x, tol) == expected, (x, tol)
