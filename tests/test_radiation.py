"""Tests of synth.sound.radiation: the Rayleigh integral from plate modes to a microphone.

References are closed forms (baffled point source, Fraunhofer integrals of a
rectangular piston and of simply supported modes, the static potential of a
uniform rectangle), an independent adaptive cubature (scipy.integrate.cubature)
and exact invariants (mirror symmetry, the delay factor).
"""

import math

import numpy as np
import pytest
from scipy import integrate

from synth.errors import ParameterError
from synth.sound.radiation import common as radiation_common
from synth.sound.radiation import delay, distance, rayleigh_gains

RHO = 1.204  # kg/m^3
C = 343.0  # m/s


def piston(n_modes=1):
    """phi = 1 everywhere (a rigid piston), repeated for n_modes columns."""
    return lambda pts: np.ones((len(pts), n_modes))


def simply_supported(modes, a, b):
    """phi = 2 sin(m pi x / a) sin(n pi y / b) (mean square 1), one column per (m, n)."""
    m = np.array([mn[0] for mn in modes], float)
    n = np.array([mn[1] for mn in modes], float)

    def shape(pts):
        return (
            2.0
            * np.sin(np.outer(pts[:, 0], m * np.pi / a))
            * np.sin(np.outer(pts[:, 1], n * np.pi / b))
        )

    return shape


def direction(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def sinc(x):
    """sin(x) / x for complex x (unnormalised)."""
    return np.sinc(x / np.pi)


def cubature_gains(shape, size, listener, s, rtol=1e-11):
    """H(s) by scipy's adaptive Gauss-Kronrod cubature on the plate (independent reference)."""
    a, b = size
    xl, yl, zl = listener
    q = np.asarray(s) / C

    def f(x):
        r = np.sqrt((x[:, 0] - xl) ** 2 + (x[:, 1] - yl) ** 2 + zl * zl)
        v = shape(x) * np.exp(-np.outer(r, q)) / r[:, None]
        return np.concatenate([v.real, v.imag], axis=1)

    points = [[xl, yl]] if 0 < xl < a and 0 < yl < b else None
    res = integrate.cubature(
        f, [0.0, 0.0], [a, b], rtol=rtol, atol=0.0, points=points, max_subdivisions=100000
    )
    assert res.status == "converged"
    n = q.size
    return RHO * np.asarray(s) / (2 * np.pi) * (res.estimate[:n] + 1j * res.estimate[n:])


def rel(x, ref):
    return np.abs(np.asarray(x) / np.asarray(ref) - 1.0)


# ----------------------------------------------------------------------------------------
# Point-source limit


def test_point_source_limit():
    # A 1 cm square piston (ka = 0.18 at 1 kHz) on axis 5 m away radiates as a baffled
    # point source of volume velocity Q = a b: p = rho s Q exp(-s R / c) / (2 pi R).
    # The neglected terms are of order k d^2 / R and (d / R)^2 (d = 7 mm): < 1e-4.
    a = b = 0.01
    R = 5.0
    s = np.array([2j * np.pi * 1000.0, -40.0 + 2j * np.pi * 3000.0])
    H = rayleigh_gains(piston(2), (a, b), (a / 2, b / 2, R), s, max_wavenumber=0.0)
    ref = RHO * s * a * b * np.exp(-s * R / C) / (2 * np.pi * R)
    assert np.all(rel(H, ref) < 1e-3)


@pytest.mark.parametrize("listener", [(0.1, 0.1, 0.0), (0.1, 0.1, -0.2), (0.1, 0.1)])
def test_point_source_limit_rejects_listener_in_or_below_baffle(listener):
    with pytest.raises(ParameterError, match="listener_position"):
        rayleigh_gains(piston(), (0.01, 0.01), listener, np.array([1j]), max_wavenumber=0.0)


# ----------------------------------------------------------------------------------------
# Rectangular piston far field


@pytest.mark.parametrize(
    "theta,phi,f,sigma",
    [
        (40.0, 30.0, 4000.0, 0.0),  # beyond the first null along x
        (70.0, 120.0, 2500.0, 0.0),
        (25.0, 250.0, 6000.0, 300.0),  # a damped pole: the same formula, continued
    ],
)
def test_rectangular_piston_directivity(theta, phi, f, sigma):
    # Fraunhofer: H exp(s R/c) = rho s a b / (2 pi R) sinc(k a ux / 2) sinc(k b uy / 2)
    # with k = -i s / c, R from the centre. The neglected terms are of relative size
    # k D^2 / (2 R) (Fresnel phase) plus D / (2 R) (amplitude), D the plate diagonal.
    a, b = 0.2, 0.15
    R = 1.0e4
    u = direction(theta, phi)
    listener = np.array([a / 2, b / 2, 0.0]) + R * u
    s = np.array([-sigma + 2j * np.pi * f])
    H = rayleigh_gains(piston(), (a, b), listener, s, max_wavenumber=0.0, reference_distance=R)
    k = -1j * s / C
    ref = RHO * s * a * b / (2 * np.pi * R) * sinc(k * a * u[0] / 2) * sinc(k * b * u[1] / 2)
    D = math.hypot(a, b)
    bound = abs(k[0]) * D**2 / (2 * R) + D / (2 * R)
    assert rel(H, ref)[0] < bound


@pytest.mark.parametrize(
    "size", [(0.0, 0.1), (-0.2, 0.1), (0.2, float("nan")), (0.2,), (0.2, float("inf")), "ab"]
)
def test_rectangular_piston_directivity_rejects_bad_size(size):
    with pytest.raises(ParameterError, match="size"):
        rayleigh_gains(piston(), size, (0.1, 0.1, 1.0), np.array([1j]), max_wavenumber=0.0)


# ----------------------------------------------------------------------------------------
# Simply supported modes, far field


def _sine_transform(m, length, alpha):
    """Int_0^L sin(m pi x / L) exp(alpha (x - L/2)) dx (closed form)."""
    beta = m * np.pi / length
    return (
        beta
        * (1 - (-1) ** m * np.exp(alpha * length))
        / (alpha**2 + beta**2)
        * np.exp(-alpha * length / 2)
    )


def test_simply_supported_modes_far_field():
    # Fraunhofer integral of 2 sin(m pi x/a) sin(n pi y/b): a product of two 1-D
    # transforms, analytic. Same far-field bound as the piston (k D^2/(2R) + D/(2R)),
    # relative to the largest gain of the set (modes (2,1) and (3,2) partly cancel).
    a, b = 0.2, 0.15
    R = 1.0e4
    modes = [(1, 1), (2, 1), (3, 2)]
    u = direction(40.0, 30.0)
    s = np.full(3, 2j * np.pi * 4000.0)
    listener = np.array([a / 2, b / 2, 0.0]) + R * u
    kb = math.hypot(3 * np.pi / a, 2 * np.pi / b)
    H = rayleigh_gains(
        simply_supported(modes, a, b), (a, b), listener, s, max_wavenumber=kb, reference_distance=R
    )
    q = s / C
    ref = np.array(
        [
            RHO
            * sk
            / (2 * np.pi * R)
            * 2
            * _sine_transform(m, a, qk * u[0])
            * _sine_transform(n, b, qk * u[1])
            for (m, n), sk, qk in zip(modes, s, q)
        ]
    )
    D = math.hypot(a, b)
    bound = abs(q[0]) * D**2 / (2 * R) + D / (2 * R)
    assert np.all(np.abs(H - ref) < bound * np.abs(ref))


@pytest.mark.parametrize(
    "bad,match",
    [
        (lambda pts: np.ones((len(pts), 2)), "shape"),  # wrong number of modes
        (lambda pts: np.ones(len(pts)), "shape"),  # 1-D
        (lambda pts: np.ones((len(pts), 1)) * 1j, "complex"),
        (lambda pts: np.full((len(pts), 1), np.nan), "NaN"),
        (lambda pts: np.full((len(pts), 1), np.inf), "NaN or infinite"),
        (lambda pts: np.full((len(pts), 1), "x"), "real"),
    ],
)
def test_simply_supported_modes_far_field_rejects_bad_shape_values(bad, match):
    with pytest.raises(ParameterError, match=match):
        rayleigh_gains(bad, (0.2, 0.15), (0.1, 0.1, 1.0), np.array([1j]), max_wavenumber=0.0)


# ----------------------------------------------------------------------------------------
# Near field: static limit in closed form


def _rectangle_potential(a, b, xl, yl, z):
    """Int over [0,a]x[0,b] of 1 / R dA, R to (xl, yl, z): closed form (a uniformly
    charged rectangle), F(x, y) = x asinh(y / sqrt(x^2 + z^2)) + y asinh(x / sqrt(y^2 + z^2))
    - z atan(x y / (z r)), evaluated at the corners relative to the projection."""

    def F(x, y):
        r = math.sqrt(x * x + y * y + z * z)
        return (
            x * math.asinh(y / math.hypot(x, z))
            + y * math.asinh(x / math.hypot(y, z))
            - z * math.atan(x * y / (z * r))
        )

    x1, x2, y1, y2 = -xl, a - xl, -yl, b - yl
    return F(x2, y2) - F(x1, y2) - F(x2, y1) + F(x1, y1)


@pytest.mark.parametrize(
    "listener", [(0.17, 0.23, 0.05), (0.17, 0.23, 1e-3), (0.5, 0.1, 2e-4), (-0.05, 0.45, 0.01)]
)
def test_static_limit_near_field(listener):
    # For |s| R / c -> 0 the integral tends to the potential of a uniform rectangle
    # (closed form); with s = 1e-9 i rad/s the dynamic correction is ~ s R / c ~ 1e-12.
    # Microphones down to 0.2 mm over the plate, on an edge and off the plate: the
    # graded panels resolve the 1/R peak to the 1e-9 asked for.
    a, b = 0.5, 0.4
    s = np.array([1e-9j])
    H = rayleigh_gains(piston(), (a, b), listener, s, max_wavenumber=0.0, tol=1e-9)
    ref = RHO * s / (2 * np.pi) * _rectangle_potential(a, b, *listener)
    assert rel(H, ref)[0] < 1e-8


@pytest.mark.parametrize(
    "field,kwargs",
    [
        ("air_density", {"air_density": 0.0}),
        ("air_density", {"air_density": float("nan")}),
        ("sound_speed", {"sound_speed": -343.0}),
        ("sound_speed", {"sound_speed": float("inf")}),
        ("max_wavenumber", {"max_wavenumber": -1.0}),
        ("max_wavenumber", {"max_wavenumber": float("nan")}),
    ],
)
def test_static_limit_near_field_rejects_bad_constants(field, kwargs):
    args = {"max_wavenumber": 0.0, **kwargs}
    with pytest.raises(ParameterError, match=field):
        rayleigh_gains(piston(), (0.5, 0.4), (0.1, 0.1, 0.05), np.array([1j]), **args)


# ----------------------------------------------------------------------------------------
# Near field: smooth modes against an independent adaptive cubature


NEAR_MODES = [(1, 1), (3, 2), (6, 5), (9, 4)]
NEAR_SIZE = (0.5, 0.4)
NEAR_KB = math.hypot(9 * np.pi / 0.5, 5 * np.pi / 0.4)


@pytest.mark.parametrize("tol,bound", [(1e-6, 1e-5), (1e-9, 1e-8)])
def test_near_field_matches_cubature(tol, bound):
    # z = 0.05 m over a 0.5 x 0.4 m plate, off-centre: scipy's adaptive cubature
    # (rtol 1e-11) is the reference; the gains agree to the tolerance asked for
    # (with a factor 10 of margin for the estimate).
    shape = simply_supported(NEAR_MODES, *NEAR_SIZE)
    listener = (0.17, 0.23, 0.05)
    s = 2j * np.pi * np.array([500.0, 2000.0, 3500.0, 6000.0])
    H = rayleigh_gains(shape, NEAR_SIZE, listener, s, max_wavenumber=NEAR_KB, tol=tol)
    ref = cubature_gains(shape, NEAR_SIZE, listener, s)
    assert np.all(rel(H, ref) < bound)


@pytest.mark.parametrize(
    "listener",
    [(float("nan"), 0.1, 0.05), (0.1, float("inf"), 0.05), (0.1, 0.1, float("nan")), "xyz", None],
)
def test_near_field_matches_cubature_rejects_non_finite_listener(listener):
    with pytest.raises(ParameterError, match="listener_position"):
        rayleigh_gains(piston(), NEAR_SIZE, listener, np.array([1j]), max_wavenumber=0.0)


# ----------------------------------------------------------------------------------------
# Damped poles


@pytest.mark.parametrize("sigma", [30.0, 3000.0, 2.0e5])
def test_damped_poles_match_cubature(sigma):
    # Re s < 0: the same integral continued analytically (exp(-s R/c) grows with R).
    # sigma = 3000 1/s needs the squared-Taylor exponential, 2e5 1/s the libm one.
    shape = simply_supported(NEAR_MODES[:3], *NEAR_SIZE)
    listener = (0.31, 0.12, 0.08)
    s = -sigma + 2j * np.pi * np.array([800.0, 2500.0, 7000.0])
    H = rayleigh_gains(shape, NEAR_SIZE, listener, s, max_wavenumber=NEAR_KB, tol=1e-9)
    ref = cubature_gains(shape, NEAR_SIZE, listener, s)
    assert np.all(rel(H, ref) < 1e-8)


@pytest.mark.parametrize(
    "s",
    [
        np.array([[1j]]),
        np.array([np.nan + 1j]),
        np.array([1j, np.inf]),
        np.array(["a"]),
        1j,
        "s",
        np.array([True]),
    ],
)
def test_damped_poles_match_cubature_rejects_bad_poles(s):
    with pytest.raises(ParameterError, match=r"\bs\b"):
        rayleigh_gains(piston(), NEAR_SIZE, (0.1, 0.1, 0.1), s, max_wavenumber=0.0)


# ----------------------------------------------------------------------------------------
# Symmetry


@pytest.mark.parametrize("y,z", [(0.13, 0.04), (0.3, 0.6), (-0.2, 0.02)])
def test_mirror_symmetry(y, z):
    # Mode (m, n) with m odd is even about x = a/2, m even is odd: mirror microphones
    # (a/2 +- d, y, z) see the same integral (+-), up to round-off: 1e-12.
    a, b = NEAR_SIZE
    modes = [(1, 2), (3, 1), (2, 3), (4, 1)]
    parity = np.array([1.0, 1.0, -1.0, -1.0])
    shape = simply_supported(modes, a, b)
    s = -50.0 + 2j * np.pi * np.array([700.0, 1500.0, 2500.0, 4000.0])
    kb = math.hypot(4 * np.pi / a, 3 * np.pi / b)
    d = 0.11
    H1 = rayleigh_gains(shape, (a, b), (a / 2 + d, y, z), s, max_wavenumber=kb)
    H2 = rayleigh_gains(shape, (a, b), (a / 2 - d, y, z), s, max_wavenumber=kb)
    assert np.all(np.abs(H1 - parity * H2) <= 1e-12 * np.abs(H1))


@pytest.mark.parametrize("shape_fn", [None, 3.0, "phi"])
def test_mirror_symmetry_rejects_non_callable_shape(shape_fn):
    with pytest.raises(ParameterError, match="shape_fn"):
        rayleigh_gains(shape_fn, NEAR_SIZE, (0.1, 0.1, 0.1), np.array([1j]), max_wavenumber=0.0)


# ----------------------------------------------------------------------------------------
# Reference delay


def test_reference_delay_factoring():
    # H(s) exp(s R0/c) exp(-s R0/c) = H(s): the factored gains times the delay factor
    # equal the plain gains to round-off (1e-12), for a damped set of poles.
    shape = simply_supported(NEAR_MODES, *NEAR_SIZE)
    listener = (0.4, -0.1, 0.7)
    s = -np.array([20.0, 100.0, 400.0, 900.0]) + 2j * np.pi * np.array([300, 1200, 3000, 6500])
    R0 = distance(listener, (0.12, 0.3))
    H = rayleigh_gains(shape, NEAR_SIZE, listener, s, max_wavenumber=NEAR_KB)
    G = rayleigh_gains(shape, NEAR_SIZE, listener, s, max_wavenumber=NEAR_KB, reference_distance=R0)
    assert np.all(np.abs(G * np.exp(-s * R0 / C) - H) <= 1e-12 * np.abs(H))


@pytest.mark.parametrize("r0", [-0.1, float("nan"), "far"])
def test_reference_delay_factoring_rejects_bad_reference_distance(r0):
    with pytest.raises(ParameterError, match="reference_distance"):
        rayleigh_gains(
            piston(),
            NEAR_SIZE,
            (0.1, 0.1, 0.1),
            np.array([1j]),
            max_wavenumber=0.0,
            reference_distance=r0,
        )


def test_delay_and_distance():
    # |(0.3, 0.4, 1.2) - (0, 0, 0)| = 1.3 m exactly; delay = 1.3 / 343 s.
    assert distance((0.3, 0.4, 1.2), (0.0, 0.0)) == pytest.approx(1.3, rel=1e-15)
    assert delay((0.3, 0.4, 1.2), (0.0, 0.0)) == pytest.approx(1.3 / C, rel=1e-15)
    assert delay((0.3, 0.4, 1.2), (0.0, 0.0), sound_speed=340.0) == pytest.approx(
        1.3 / 340.0, rel=1e-15
    )


@pytest.mark.parametrize(
    "args,field",
    [
        (((0.3, 0.4, -1.0), (0.0, 0.0)), "listener_position"),
        (((0.3, 0.4, 1.0), (0.0,)), "reference_point"),
        (((0.3, 0.4, 1.0), (0.0, float("nan"))), "reference_point"),
        (((0.3, 0.4, 1.0), (0.0, 0.0), 0.0), "sound_speed"),
    ],
)
def test_delay_and_distance_rejects_bad_points(args, field):
    with pytest.raises(ParameterError, match=field):
        delay(*args)


# ----------------------------------------------------------------------------------------
# Accuracy control and memory


@pytest.mark.parametrize("tol", [1e-3, 1e-6])
def test_tol_bounds_true_error(tol):
    # The error estimate is the change between the last two rules; the true error
    # (against cubature at rtol 1e-11) must be within tol * max(|H|, 1e-4 S), the
    # documented criterion, for every mode.
    shape = simply_supported(NEAR_MODES, *NEAR_SIZE)
    listener = (0.05, 0.35, 0.03)
    s = -80.0 + 2j * np.pi * np.array([400.0, 1800.0, 4000.0, 7500.0])
    res = rayleigh_gains(
        shape, NEAR_SIZE, listener, s, max_wavenumber=NEAR_KB, tol=tol, full_output=True
    )
    assert res.success and res.status == 0
    ref = cubature_gains(shape, NEAR_SIZE, listener, s)
    allowed = tol * np.maximum(np.abs(ref), 1e-4 * res.coherent)
    assert np.all(np.abs(res.gains - ref) <= allowed)
    assert np.all(res.coherent >= np.abs(res.gains))  # S_k bounds |H_k|


@pytest.mark.parametrize(
    "kwargs,field",
    [
        ({"tol": 0.0}, "tol"),
        ({"tol": 0.5}, "tol"),
        ({"tol": 1e-12}, "tol"),
        ({"max_points": 0}, "max_points"),
        ({"max_points": 2.5}, "max_points"),
        ({"max_points": 1000, "max_wavenumber": 1e4}, "max_points"),
    ],
)
def test_tol_bounds_true_error_rejects_bad_accuracy_settings(kwargs, field):
    args = {"max_wavenumber": 0.0, **kwargs}
    with pytest.raises(ParameterError, match=field):
        rayleigh_gains(piston(), NEAR_SIZE, (0.1, 0.1, 0.1), np.array([1j]), **args)


def test_shapes_evaluated_in_bounded_chunks():
    # 20000 modes: each call of shape_fn must ask for at most 32 MB of values (the
    # documented chunk budget), and the gains must not depend on the chunking: with
    # identical columns every mode gets the same gain (to round-off).
    n_modes = 20000
    calls = []

    def shape(pts):
        calls.append(len(pts))
        return np.ones((len(pts), n_modes))

    s = np.full(n_modes, 2j * np.pi * 200.0)
    H = rayleigh_gains(shape, (0.3, 0.2), (0.1, 0.1, 0.3), s, max_wavenumber=0.0)
    assert max(calls) * n_modes * 8 <= radiation_common.CHUNK_BYTES
    assert len(calls) > 2  # the points really were split
    assert np.all(np.abs(H - H[0]) <= 1e-14 * np.abs(H[0]))


def test_shapes_evaluated_in_bounded_chunks_rejects_empty_size():
    with pytest.raises(ParameterError, match="size"):
        rayleigh_gains(piston(), (), (0.1, 0.1, 0.3), np.array([1j]), max_wavenumber=0.0)
