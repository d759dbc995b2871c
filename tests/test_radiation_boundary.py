"""Tests of synth.sound.radiation.boundary: the Rayleigh gains of dynamic edge effect modes
as integrals over the plate's boundary (Green's second identity with a radial particular
solution about the microphone), checked against the rectangle rule of rayleigh_gains; the
Bessel functions it uses; plate_gains of a plate past the Ritz crossover."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.special as sp
from scipy import integrate

from synth.physics.materials import LossFactor, Material
from synth.physics.scene import Plate
from synth.sound import asymptotic_modes as AM
from synth.sound import modes as P
from synth.sound import radiation as R
from synth.sound.modes import EdgeEffectPart, crossover
from synth.sound.radiation import boundary as B
from synth.sound.radiation import boundary_bessel as BB
from synth.sound.radiation import boundary_grid as BG
from synth.sound.radiation import rules

STEEL = Material("test-steel", 7800.0, 2.0e11, 0.3, LossFactor(1e-3))
RHO, C = 1.204, 343.0

#: every test gets empty memory caches and its own disk cache directory
pytestmark = pytest.mark.usefixtures("empty_caches")

# Microphone off the middle, 1 cm inside an edge (the feet of two edges at 1 cm and a
# corner's distance just beyond one), above an edge's line, outside the plate, close to
# the plate (the 1/R peak).
CASES = [
    ("free", (0.13, 0.11, 0.05)),
    ("clamped", (0.05, 0.29, 0.1)),
    ("free", (0.4, 0.1, 0.2)),
    ("clamped", (-0.1, 0.5, 0.3)),
    ("free", (0.2, 0.15, 0.005)),
]


def _edge_modes(boundary, omega_max=2000.0, a=0.4, b=0.3):
    """Edge effect modes of an ``a`` x ``b`` plate (dimensionless band ``omega_max``) with
    poles whose top frequency is 15 kHz (damped: sigma 5 + 1e-4 omega)."""
    sol = AM.solve(boundary, 0.3, a / b, omega_max)
    omega = sol.omega * (2.0 * math.pi * 15000.0 / omega_max)
    s = (5.0 + 1e-4 * omega) + 1j * omega
    kb = math.sqrt(omega_max) / max(a, b)
    return sol, s, kb


@pytest.mark.slow
@pytest.mark.parametrize("boundary, listener", CASES)
def test_boundary_rule_agrees_with_rectangle_rule(boundary, listener):
    """Both rules' gains of every mode agree within 2 tol (each is within tol of the
    integral: the rules' stated bound), with and without a reference distance; every
    gain is within its in-phase bound S_k."""
    a, b = 0.4, 0.3
    sol, s, kb = _edge_modes(boundary)
    n = sol.omega.size
    part = EdgeEffectPart(0, sol, 0)
    tol = 1e-7
    for r0 in (None, 0.3):

        def shape_fn(points):
            return sol.shapes(2.0 * points[:, 0] / a - 1.0, 2.0 * points[:, 1] / b - 1.0, n)

        rect = R.rayleigh_gains(
            shape_fn,
            (a, b),
            listener,
            s,
            max_wavenumber=kb,
            reference_distance=r0,
            tol=tol,
            full_output=True,
        )
        bnd = B.boundary_rule(
            part,
            n,
            (a, b),
            listener,
            s,
            air_density=RHO,
            sound_speed=C,
            reference_distance=r0,
            tol=tol,
            max_points=4_000_000,
        )
        assert rect.success and bnd.success, bnd.message
        allowed = 2.0 * tol * np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
        assert np.all(np.abs(bnd.gains - rect.gains) <= allowed)
        # S_k: the rectangle rule's in-phase integral is below the boundary rule's bound
        assert np.all(rect.coherent <= bnd.coherent * (1.0 + 1e-9))


def _bessel(x, osc):
    """``(f0, g0, f1, g1)`` at ``x`` as the boundary rule takes them: the Hankel expansions
    (``bessel_at``) at and above ``ASYMPTOTIC_X``, scipy below."""
    out = np.array(BB._bessel_small(x, osc))
    for j in np.flatnonzero(x >= BB.ASYMPTOTIC_X):
        out[0, j], out[1, j] = BB.bessel_at(x[j], osc, BB.A0, 0.25 * math.pi)
        out[2, j], out[3, j] = BB.bessel_at(x[j], osc, BB.A1, 0.75 * math.pi)
    return out


def test_bessel_functions_equal_scipy_across_the_asymptotic_threshold():
    """J0, Y0, J1, Y1 and the scaled I0, K0, I1, K1 (Hankel expansions above 20, scipy
    below) within 2e-15 of scipy's, relative to their envelope 1 / sqrt(x)."""
    x = np.concatenate((np.linspace(0.01, 40.0, 4001), np.geomspace(40.0, 1e5, 2000)))
    for osc, ref in (
        (True, (sp.j0, sp.y0, sp.j1, sp.y1)),
        (False, (sp.i0e, sp.k0e, sp.i1e, sp.k1e)),
    ):
        got = _bessel(x, osc)
        for g, f in zip(got, ref):
            assert np.max(np.abs(g - f(x)) * np.sqrt(x)) < 2e-15 * 10


def _exp_poly_cos(n, kappa, k, lo, x):
    """``Int_lo^x exp(-kappa (x - t)) t^n cos(k t) dt`` in closed form: with ``a = kappa +
    i k``, ``Int t^n e^(a t) dt = e^(a t) sum_m (-1)^m n! / (n - m)! t^(n - m) / a^(m + 1)``
    (the factor ``exp(-kappa x)`` taken into each end's exponential: no overflow)."""
    a = kappa + 1j * k

    def primitive(t, shift):
        terms = sum(
            (-1) ** m * math.factorial(n) / math.factorial(n - m) * t ** (n - m) / a ** (m + 1)
            for m in range(n + 1)
        )
        return np.exp(a * t - kappa * shift) * terms

    return (primitive(x, x) - primitive(lo, x)).real


@pytest.mark.slow
@pytest.mark.parametrize("c", [0.0, 1e-9, 1e-3, 0.25, 1.0, 10.0, 60.0, 400.0, 1e5])
def test_decay_weights_integrate_exponential_times_panel_functions(c):
    """The product weights of the decaying tables on a panel [lo, hi] (c = kappa h / 2
    from 0 to 1e5, the small and large kappa h limits included) give Int_lo^t_a
    exp(-kappa (t_a - t)) t^n cos(k t) dt at every node t_a and at hi within 1e-13 of
    the closed form (relative to Int_lo^t_a t^n dt, the scale of the integrand): the
    interpolant of t^n cos(k t) on 24 nodes is within 1e-15 of it (k h = 3)."""
    p, lo, hi, k = 24, 0.7, 1.3, 5.0
    h = hi - lo
    kappa = 2.0 * c / h
    t, _ = np.polynomial.legendre.leggauss(p)
    nodes = lo + 0.5 * h * (t + 1.0)
    ends = np.concatenate((nodes, [hi]))
    weights = B.decay_weights(p, c)
    for n in (0, 1, 3):
        got = 0.5 * h * weights @ (nodes**n * np.cos(k * nodes))
        want = np.array([_exp_poly_cos(n, kappa, k, lo, x) for x in ends])
        scale = (ends ** (n + 1) - lo ** (n + 1)) / (n + 1)
        assert np.all(np.abs(got - want) <= 1e-12 * scale)


def test_decay_weights_at_zero_rate_are_spectral_integration():
    """At c = 0 the product weights are the spectral integration matrix (rows at the
    nodes) and the Gauss-Legendre weights (last row), to round-off."""
    for p in (6, 13, 24, 37):
        weights = B.decay_weights(p, 0.0)
        np.testing.assert_allclose(weights[:p], BG._spectral(p), atol=1e-15)
        np.testing.assert_allclose(weights[p], np.polynomial.legendre.leggauss(p)[1], atol=1e-15)


def test_small_arguments_are_each_rows_first_run():
    """The arguments below the Hankel threshold are, row by row, the first nodes' k rho
    (rho ascending), and nothing else."""
    rho = np.sort(np.random.default_rng(3).uniform(0.0, 0.5, 200))
    k = np.array([10.0, 100.0, 1000.0, 1e5])
    x, starts = BB._small_arguments(k, rho, BB.ASYMPTOTIC_X)
    for r in range(k.size):
        want = k[r] * rho[k[r] * rho < BB.ASYMPTOTIC_X]
        np.testing.assert_array_equal(x[starts[r] : starts[r + 1]], want)


def test_rate_steps_bracket_each_rate():
    """Each radial rate lies on or below its step's top and above the step below (the
    panels sized for the top are at most the ladder's ratio finer than the rate needs)."""
    rate = np.geomspace(0.3, 3e4, 5001)
    top = BG.RATE_LADDER ** BG.rate_steps(rate).astype(float)
    assert np.all(rate <= top * (1.0 + 1e-12))
    assert np.all(rate > top / BG.RATE_LADDER * (1.0 - 1e-12))


def test_inverse_distance_integral_closed_form():
    """Int 1/R dA over the plate in closed form equals scipy's quadrature, the projection
    inside and outside the plate."""
    for listener in ((0.1, 0.2, 0.05), (-0.3, 0.5, 0.2)):
        z = listener[2]
        ref = integrate.dblquad(
            lambda y, x: 1.0 / math.sqrt((x - listener[0]) ** 2 + (y - listener[1]) ** 2 + z * z),
            0.0,
            0.4,
            0.0,
            0.3,
            epsabs=1e-12,
        )[0]
        assert B._inverse_distance_integral((0.4, 0.3), listener) == pytest.approx(ref, rel=1e-9)


def _hybrid_modes(monkeypatch, boundary):
    """A small plate's modes past a lowered Ritz crossover: a few Ritz modes, then edge
    effect modes (the solution for large plates, at a size a test can check against the
    rectangle rule)."""
    monkeypatch.setattr(P, "CROSSOVER_UNKNOWNS", 80)
    monkeypatch.setattr(crossover, "LOW_BAND_UNKNOWNS", 50)
    monkeypatch.setattr(rules, "RULES", (rules.BoundaryRule(),))
    m = P.modes(Plate(STEEL, 0.002, 0.3, 0.2, boundary), max_frequency=8000.0, cache=False)
    part = m.edge_effect()
    assert part is not None and 0 < part.first_mode < len(m) - 50
    return m, part


@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_plate_gains_past_the_crossover_take_the_boundary_rule(monkeypatch, boundary):
    """plate_gains of a plate with edge effect modes (the boundary rule the only one
    choose_rule may take): rule "boundary", converged, within
    2 tol of the rectangle rule over every mode (Ritz and edge effect); shapes of a subset
    of modes are those columns of all the shapes."""
    m, part = _hybrid_modes(monkeypatch, boundary)
    s = -m.decay_rates + 1j * m.angular_frequencies
    kb = (
        m.angular_frequencies.max() ** 2 * m.plate.surface_density / m.plate.flexural_rigidity
    ) ** 0.25
    listener = (0.11, 0.08, 0.1)
    res = R.plate_gains(m, listener, s, max_wavenumber=kb, tol=1e-6, full_output=True)
    assert res.rule == "boundary" and res.success, res.message
    rect = R.rayleigh_gains(
        m.shapes, (0.3, 0.2), listener, s, max_wavenumber=kb, tol=1e-6, full_output=True
    )
    allowed = 2e-6 * np.maximum(np.abs(rect.gains), 1e-4 * rect.coherent)
    assert np.all(np.abs(res.gains - rect.gains) <= allowed)
    pts = np.random.default_rng(2).uniform([0, 0], [0.3, 0.2], (30, 2))
    index = np.unique([0, part.first_mode - 1, part.first_mode, part.first_mode + 5, len(m) - 1])
    assert np.array_equal(m.shapes(pts, index=index), m.shapes(pts)[:, index])
    # cached on disk under the boundary rule's key: a second call reads it back
    R.clear_memory_cache()
    again = R.plate_gains(m, listener, s, max_wavenumber=kb, tol=1e-6, full_output=True)
    assert R.cache_info()["disk_hits"] == 1 and np.array_equal(again.gains, res.gains)
    assert again.rule == "boundary"


def test_ladder_rounding_brackets_each_rate():
    """A rate rounded up (down) to the ladder is at or above (below) it by less than the
    ladder's ratio; 0 stays 0 (no decay: no tail, no limit on substituted panels)."""
    for rate in np.geomspace(1e-3, 1e5, 97):
        up, down = BG.on_ladder(float(rate)), BG.below_ladder(float(rate))
        assert rate <= up < rate * BG.RATE_LADDER * (1.0 + 1e-12)
        assert rate / BG.RATE_LADDER * (1.0 - 1e-12) < down <= rate
    assert BG.on_ladder(0.0) == 0.0 and BG.below_ladder(0.0) == 0.0


def _factor_bounds_before(s, so, n, h, ce, scale):
    """_factor_bounds as it was before its growing bound was taken in logarithms (every
    branch evaluated for every trial): the reference where it did not overflow."""
    odd = n % 2 == 1
    k = np.sqrt(np.abs(s))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        u_osc = np.where(odd, np.minimum(h, 1.0 / k), 1.0)
        u_grow = np.where(odd, np.sinh(k * h) / k, np.cosh(k * h))
        u = np.where(s > 0.0, u_osc, np.where(s < 0.0, u_grow, np.where(odd, h, 1.0)))
        m2 = s + 2.0 * so
        mu = np.sqrt(np.abs(m2))
        e_osc = 1.0 / np.abs(np.where(odd, np.sin(mu * h), np.cos(mu * h)))
        e = np.where(m2 < 0.0, e_osc, 1.0)
    return np.abs(scale) * (u + np.abs(ce) * e)


@pytest.mark.parametrize("boundary", ["free", "clamped"])
def test_factor_bounds_are_unchanged_where_they_did_not_overflow(boundary):
    # the trials of a real edge effect solution (oscillating parts of both parities, and
    # growing ones on the free plate): the same values as the direct evaluation, to 1e-12
    # (an invariant: below k h = 700 the arithmetic is the same)
    sol, _, _ = _edge_modes(boundary)
    (cx, gx), (cy, gy) = sol.factor_constants()
    hx, hy = sol.half
    assert (boundary == "free") == bool(np.any(sol.sx < 0.0) and np.any(sol.sy < 0.0))
    for args in ((sol.sx, sol.sy, sol.nx, hx, cx, gx), (sol.sy, sol.sx, sol.ny, hy, cy, gy)):
        with np.errstate(all="raise"):
            new = B._factor_bounds(*args)
        np.testing.assert_allclose(new, _factor_bounds_before(*args), rtol=1e-12, atol=0.0)


def test_factor_bounds_of_far_growing_trials_are_finite():
    # h = 2.5 m and |s| = 1e5 m^-2: k h = 791, where cosh overflowed (a warning, and an
    # infinite bound that would let the convergence test pass any gain). A growing even
    # trial normalised to mean square 1 on [-h, h] (scale = 1 / rms, a subnormal number
    # at k h = 720) is bounded by sqrt(2 k h): cosh(k h)^2 / rms^2 -> 2 k h (closed form
    # of the mean square of cosh, (1 + sinh(2 k h) / (2 k h)) / 2)
    h, kh = 2.5, 720.0
    k = kh / h
    s = np.array([1e5, -1e5, 1e5, -(k**2)])
    n = np.array([0, 1, 1, 0])
    scale = np.array([1.0, 0.0, 1.0, math.exp(0.5 * math.log(8.0 * kh) - kh)])
    with np.errstate(all="raise"):
        bound = B._factor_bounds(s, np.full(4, 2e5), n, h, np.zeros(4), scale)
    assert np.all(np.isfinite(bound))
    assert bound[:3].tolist() == [1.0, 0.0, 1.0 / math.sqrt(1e5)]
    assert bound[3] == pytest.approx(math.sqrt(2.0 * kh), rel=1e-9)
