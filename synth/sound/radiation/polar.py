"""The polar rule of the Rayleigh integral for separable shapes (:func:`separable_gains`),
and the radial and angular panels it shares with :mod:`synth.sound.radiation.summed`.

The rectangle rule costs one exponential per mode and point, about ``n_modes (k a)(k b)``
(``k`` the largest of the bending and acoustic wavenumbers): hours for tens of thousands of
modes on a 2 m plate. For shapes ``X_i(x) Y_j(y)`` (the simply supported plate)
:func:`separable_gains` integrates in polar coordinates ``(r, theta)`` about the
microphone's projection, where ``R = sqrt(r^2 + z^2)`` does not depend on ``theta``::

    Int phi_k exp(-s R / c) / R dA = Int (r / R) exp(-s R / c) Phi_k(r) dr,
    Phi_k(r) = Int_arcs phi_k(xl + r cos theta, yl + r sin theta) dtheta.

``Phi_k`` does not depend on ``s``: at each radius the angular sums of every mode are one
matrix product of the ``X`` and ``Y`` values at the arc's points, and the radial sums take
one exponential per mode and radius. A whole circle needs no points: each product of sines
solves the Helmholtz equation, whose mean value theorem gives ``Int_0^2pi phi_k dtheta = 2
pi phi_k(xl, yl) J_0(k_k r)``; at each radius the rule sums the arcs on the plate, or, when
those off the plate are shorter, that closed form minus the arcs off the plate (one ``J_0``
per mode and radius, as the exponentials). Angular points: Gauss-Legendre panels for a
trigonometric polynomial of the degree beyond which ``|J_n(k_b r)| <= tol`` (a plane wave
on a circle, Jacobi-Anger). Radial panels: as along x and y in the rectangle rule, with
breakpoints where the set of arcs changes (a circle touching an edge's line, where
``Phi_k`` behaves as ``sqrt(r - d)``, removed by ``r = d + L u^2``; a corner, a kink), and
sized for the phase of ``exp(-s R / c)`` plus that of the arcs' ends travelling along the
edges. The tolerance, the error estimate and the convergence test are those of
:mod:`synth.sound.radiation.refinement`, each mode refined alone
(:func:`~synth.sound.radiation.refinement.refine_selective`). The in-phase bounds ``S_k``
(``|phi_k| = |X_i| |Y_j|``) come from one matrix product on a rectangle rule that resolves
the shapes but not the acoustic phase. Tests compare the two rules on plates where both run
(agreement within ``2 tol``, in-phase bounds within 5 %). Blocks of radii are shared
between numba's threads (each with its own sums, added in a fixed order at the end; the
products and kernels run without the GIL).
"""

from __future__ import annotations

import dataclasses
import fractions
import functools
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from synth.compilation import compiled
from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.sound.modes import single_thread_product
from synth.sound.radiation.common import (
    CHUNK_BYTES,
    GRADING,
    MAX_ORDER,
    REFINE,
    RadiationResult,
    add_sums,
    check_listener,
    check_poles,
    check_settings,
    exp_halvings,
    gauss,
    half_phase,
    min_order,
)
from synth.sound.radiation.rectangle import first_rule, panel_nodes
from synth.sound.radiation.refinement import refine, refine_selective, warn_unconverged
from synth.vecmath import cis

# ----------------------------------------------------------------------------------------
# Separable shapes: the integral in polar coordinates about the microphone
#
# With r, theta polar coordinates in the plate's plane about the microphone's projection
# (xl, yl), R = sqrt(r^2 + z^2) depends on r alone, so
#     Int phi_k exp(-q R) / R dA = Int (r / R) exp(-q R) Phi_k(r) dr,
#     Phi_k(r) = Int phi_k(xl + r cos theta, yl + r sin theta) dtheta  (arcs inside the plate).
# Phi_k does not depend on q: for shapes X_i(x) Y_j(y) the angular sums of every mode at
# one radius are one matrix product, Phi = (X^T diag(w)) Y, and the radial sums take
# each mode's own exp(-q_k R) (common.accumulate). The angular integrand oscillates at
# most at k_b r rad/rad (a shape's wavenumber is at most k_b), the radial one at most
# at k_b + |q|; the 1/R peak under the microphone is resolved by graded radial panels.
# Phi_k(r) is analytic in r between the radii where the set of arcs changes: at a
# radius where the circle touches an edge's line Phi_k behaves as sqrt(r - d) (the arc
# grows as sqrt), removed by r = d + L u^2 on the adjacent panel; at a corner's distance
# it has a kink, a panel end.


def _radial_segments(a: float, b: float, xl: float, yl: float):
    """``(r_min, r_max, singular, kinks)``: the range of distances from ``(xl, yl)`` to
    the plate, the radii (inside the range) where a circle touches an edge's line, and
    the corners' distances."""
    dx = max(0.0, -xl, xl - a)
    dy = max(0.0, -yl, yl - b)
    r_min = math.hypot(dx, dy)
    corners = [math.hypot(xl - cx, yl - cy) for cx in (0.0, a) for cy in (0.0, b)]
    r_max = max(corners)
    singular = sorted(
        {t for t in (abs(xl), abs(xl - a), abs(yl), abs(yl - b)) if t > 0.0 and r_min <= t < r_max}
    )
    kinks = sorted({t for t in corners if r_min < t < r_max})
    return r_min, r_max, singular, kinks


def radial_panels(a, b, listener, h, h_substituted=None):
    """Radial panels ``(lo, hi, kind)``: ``kind`` 0 plain, +1 (-1) with the
    ``sqrt`` behaviour at ``lo`` (``hi``) removed by a quadratic substitution.
    At most ``h`` long and, from the microphone's projection, at most
    ``2 max(z, r)`` long (as along x and y in :mod:`synth.sound.radiation.rectangle`);
    a substituted panel at most ``h_substituted`` long (m, default ``h / 2``)."""
    xl, yl, zl = listener
    sub = 0.5 * h if h_substituted is None else min(0.5 * h, h_substituted)
    r_min, r_max, singular, kinks = _radial_segments(a, b, xl, yl)
    # breakpoints closer than 1e-12 r_max are one (rounding of equal distances)
    points = sorted(
        [(r_min, False), (r_max, False)]
        + [(t, True) for t in singular]
        + [(t, False) for t in kinks]
    )
    ends, sing = [], []
    for t, s in points:
        if ends and t - ends[-1] <= 1e-12 * r_max:
            sing[-1] = sing[-1] or s
        else:
            ends.append(t)
            sing.append(s)
    ends[-1] = r_max
    panels = []
    for t0, t1, lo_s, hi_s in zip(ends[:-1], ends[1:], sing[:-1], sing[1:]):
        pieces = [(t0, t1, lo_s, hi_s)]
        if lo_s and hi_s:
            mid = 0.5 * (t0 + t1)
            pieces = [(t0, mid, True, False), (mid, t1, False, True)]
        for p0, p1, s0, s1 in pieces:
            cuts = [p0]
            t = p0
            while t < p1:
                t = min(t + min(h, GRADING * max(zl, t)), p1)
                cuts.append(t)
            # a substituted panel doubles the phase per unit of its variable: h / 2 long
            if s0 and cuts[1] - p0 > sub:
                cuts.insert(1, p0 + sub)
            if s1 and p1 - cuts[-2] > sub:
                cuts.insert(len(cuts) - 1, p1 - sub)
            cuts = np.array(cuts)
            keep = np.concatenate(([True], np.diff(cuts) > 1e-12 * r_max))
            cuts = cuts[keep]
            cuts[-1] = p1
            n = cuts.size - 1
            for i in range(n):
                kind = 1 if (s0 and i == 0) else (-1 if (s1 and i == n - 1) else 0)
                panels.append((float(cuts[i]), float(cuts[i + 1]), kind))
    return panels


def _panel_phase(lo, hi, kind, tangents, kb, qa, z):
    """Largest phase change (rad) over a radial panel of the polar integrand's terms.

    ``exp(-q R)`` turns by at most ``|q| (R(hi) - R(lo))``; a shape's plane waves by
    at most ``k_b`` per metre of radius inside the arcs, and by ``k_b`` per metre that
    an arc's end travels along an edge's line at distance ``d``
    (``sqrt(r^2 - d^2)``, much faster than ``r`` just beyond ``d``). A substituted
    panel (``kind != 0``) is taken as twice as long in radius (``dr/du <= 2 L``).
    """
    stretch = 1.0 if kind == 0 else 2.0
    travel = max(
        (
            math.sqrt(max(hi * hi - d * d, 0.0)) - math.sqrt(max(lo * lo - d * d, 0.0))
            for d in tangents
        ),
        default=0.0,
    )
    big = math.hypot(hi, z) - math.hypot(lo, z)
    return stretch * qa * big + kb * max(stretch * (hi - lo), travel)


def radial_orders(panels, size, listener, kb, qa, tol):
    """Panels split until each one's phase (:func:`_panel_phase`) is integrated to
    ``tol`` by at most ``MAX_ORDER`` points, and their first-rule orders."""
    a, b = size
    xl, yl, _ = listener
    tangents = (abs(xl), abs(xl - a), abs(yl), abs(yl - b))
    w_max = half_phase(MAX_ORDER, tol)
    p_min = min_order(tol)
    todo = list(reversed(panels))
    out, orders = [], []
    while todo:
        lo, hi, kind = todo.pop()
        half = 0.5 * _panel_phase(lo, hi, kind, tangents, kb, qa, listener[2])
        if half > w_max and hi - lo > 1e-9 * hi:
            mid = 0.5 * (lo + hi)
            todo.append((mid, hi, -1 if kind < 0 else 0))
            todo.append((lo, mid, 1 if kind > 0 else 0))
            continue
        out.append((lo, hi, kind))
        orders.append(_fewest_points(half, tol, p_min))
    return out, np.array(orders, dtype=np.int64)


def _fewest_points(phase: float, tol: float, p_min: int) -> int:
    """Fewest Gauss-Legendre points (at least ``p_min``, at most ``MAX_ORDER``) that
    integrate ``exp(i w t)``, ``|w| <= phase``, on ``[-1, 1]`` to ``tol``."""
    p = p_min
    while p < MAX_ORDER and half_phase(p, tol) < phase:
        p += 1
    return p


def radial_nodes(panels, orders):
    """Radii (m) and weights of ``Int f(r) dr`` on the panels (substitutions applied)."""
    rs, ws = [], []
    for (lo, hi, kind), p in zip(panels, orders):
        t, w = gauss(int(p))
        u = 0.5 * (t + 1.0)
        length = hi - lo
        if kind == 0:
            rs.append(lo + length * u)
            ws.append(0.5 * length * w)
        elif kind > 0:
            rs.append(lo + length * u * u)
            ws.append(length * u * w)  # dr = 2 L u du, du = dt / 2
        else:
            rs.append(hi - length * (1.0 - u) ** 2)
            ws.append(length * (1.0 - u) * w)
    return np.concatenate(rs), np.concatenate(ws)


def _circle_arcs(r: float, a: float, b: float, xl: float, yl: float) -> tuple[list, list]:
    """Angular intervals ``(theta0, theta1)`` of the circle of radius ``r`` about
    ``(xl, yl)`` that lie on the plate ``[0, a] x [0, b]``, and those that lie off it."""
    two_pi = 2.0 * math.pi
    cuts = [0.0, two_pi]
    for c in (-xl, a - xl):
        cos_t = c / r
        if -1.0 < cos_t < 1.0:
            t = math.acos(cos_t)
            cuts += [t, two_pi - t]
    for d in (-yl, b - yl):
        sin_t = d / r
        if -1.0 < sin_t < 1.0:
            t = math.asin(sin_t)
            cuts += [t % two_pi, (math.pi - t) % two_pi]
    cuts.sort()
    on, off = [], []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        if hi - lo <= 1e-15:
            continue
        mid = 0.5 * (lo + hi)
        x, y = xl + r * math.cos(mid), yl + r * math.sin(mid)
        arcs = on if (0.0 <= x <= a and 0.0 <= y <= b) else off
        if arcs and arcs[-1][1] == lo:
            arcs[-1] = (arcs[-1][0], hi)
        else:
            arcs.append((lo, hi))
    return on, off


def _arcs(r: float, a: float, b: float, xl: float, yl: float) -> list:
    """Angular intervals ``(theta0, theta1)`` of the circle of radius ``r`` about
    ``(xl, yl)`` that lie on the plate ``[0, a] x [0, b]``."""
    return _circle_arcs(r, a, b, xl, yl)[0]


#: Revision of the polar rules' algorithm (part of the gain cache's key: a result of an
#: earlier revision is recomputed).
POLAR_REVISION = 2

_ANGLE_MIN_ORDER = 4  # Gauss-Legendre points of the shortest angular panels
# Panel accuracy of the polar rule, relative to tol (as the rectangle rule's).
_POLAR_PANEL_TOL = 0.1


@functools.lru_cache(maxsize=4096)
def _angular_band(x: float, tol: float) -> int:
    """Fewest Fourier orders ``N >= x`` beyond which ``|J_n(x)| <= tol`` (``n >= N``).

    A plane wave of wavenumber ``k <= k_b`` on a circle of radius ``r`` is
    ``exp(i k r cos(theta - theta_k)) = sum_n i^n J_n(k r) exp(i n (theta - theta_k))``,
    and ``|J_n(k r)| <= |J_n(k_b r)|`` decreases in ``n`` past ``k_b r``: a shape made
    of such waves is, to ``tol``, a trigonometric polynomial of degree ``N``.
    """
    import scipy.special  # imported on use: a render from cached gains needs none

    n = np.arange(math.floor(x), math.floor(x) + 64 + int(8 * x ** (1.0 / 3.0)))
    small = np.flatnonzero(np.abs(scipy.special.jv(n, x)) <= tol)
    return int(n[small[0]]) if small.size else int(n[-1])


def _arc_panels(r, kb, tol, refine, arcs) -> list:
    """Gauss-Legendre panels of the angular rule at radius ``r`` on ``arcs`` (a list of
    ``(theta0, theta1)``, rad): per arc ``(theta0, theta1, panels, points per panel)``,
    for shapes made of plane waves of wavenumbers at most ``kb`` (:func:`_angular_band`),
    orders times ``refine``."""
    # kb r rounded up to an integer so that neighbouring radii share the computation
    rate = float(_angular_band(float(math.ceil(kb * r)), tol))
    w24 = half_phase(MAX_ORDER, tol)
    h = 2.0 * w24 / rate if rate > 0 else math.inf
    out = []
    for lo, hi in arcs:
        n = max(1, math.ceil((hi - lo) / h))
        p = math.ceil(_fewest_points(0.5 * rate * (hi - lo) / n, tol, _ANGLE_MIN_ORDER) * refine)
        out.append((lo, hi, n, p))
    return out


@functools.cache
def _gauss_table(largest: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gauss-Legendre rules of 1 to ``largest`` points end to end: nodes, weights, and
    where the ``p``-point rule starts (``start[p]``)."""
    start = np.zeros(largest + 2, dtype=np.int64)
    start[1:] = np.cumsum(np.arange(largest + 1))
    t = np.concatenate([gauss(p)[0] for p in range(1, largest + 1)])
    w = np.concatenate([gauss(p)[1] for p in range(1, largest + 1)])
    return t, w, start


@compiled()
def _panel_points(lo, hi, count, order, table_t, table_w, table_start):  # pragma: no cover
    """Nodes and weights of ``count[a]`` equal panels of ``order[a]`` Gauss-Legendre points
    on each interval ``[lo[a], hi[a]]`` (the rules of :func:`_gauss_table`), in order."""
    total = 0
    for a in range(lo.size):
        total += count[a] * order[a]
    nodes = np.empty(total)
    weights = np.empty(total)
    j = 0
    for a in range(lo.size):
        p = order[a]
        first = table_start[p]
        half = 0.5 * (hi[a] - lo[a]) / count[a]
        for n in range(count[a]):
            mid = lo[a] + (2 * n + 1) * half
            for i in range(p):
                nodes[j] = mid + half * table_t[first + i]
                weights[j] = half * table_w[first + i]
                j += 1
    return nodes, weights


def _panels_points(panels) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the panels ``(lo, hi, count, order)`` (:func:`_arc_panels`)."""
    if not panels:
        return np.zeros(0), np.zeros(0)
    lo, hi, count, order = (np.array(v) for v in zip(*panels))
    largest = 1 << max(int(order.max()) - 1, 0).bit_length()  # few distinct tables
    return _panel_points(
        lo.astype(float),
        hi.astype(float),
        count.astype(np.int64),
        order.astype(np.int64),
        *_gauss_table(largest),
    )


def angular_rule(r, a, b, listener, kb, tol, refine, arcs=None):
    """Angles (rad) and weights of ``Int f(theta) dtheta`` over the arcs of radius ``r``
    on the plate (or over ``arcs``, a list of ``(theta0, theta1)``), for shapes made of
    plane waves of wavenumbers at most ``kb`` (:func:`_angular_band`); orders times
    ``refine``."""
    xl, yl, _ = listener
    if arcs is None:
        arcs = _arcs(r, a, b, xl, yl)
    return _panels_points(_arc_panels(r, kb, tol, refine, arcs))


# ----------------------------------------------------------------------------------------
# Whole circles in closed form (separable shapes)
#
# A simply supported shape phi_k = X_i(x) Y_j(y) = 2 sin(kx x) sin(ky y) solves the
# Helmholtz equation (lap + k_k^2) phi_k = 0, k_k^2 = kx^2 + ky^2, in the whole plane (the
# sines continued beyond the plate), and the mean value theorem of that equation (Weber's;
# Courant and Hilbert, Methods of Mathematical Physics vol. II, ch. IV, sec. 3) gives its
# integral over a whole circle of radius r about (xl, yl) exactly:
#     Int_0^2pi phi_k(xl + r cos t, yl + r sin t) dt = 2 pi phi_k(xl, yl) J_0(k_k r).
# The integral over the arcs on the plate is this minus the integral over the arcs off it;
# at each radius the polar rule sums whichever set of arcs is shorter (none while the
# circle lies on the plate), so that the angular points cover at most half of each circle.
#
# J_0 is evaluated for every mode and radius (as the exponentials), in a loop that
# vectorises: for x >= 25 Hankel's asymptotic expansion
#     J_0(x) = sqrt(2 / (pi x)) (P(x) cos(x - pi/4) - Q(x) sin(x - pi/4))
# (Abramowitz and Stegun 9.2.5, 9.2.9, 9.2.10) with ten terms of P and of Q: for real x
# the remainder is at most the first omitted term, a_20 / x^20 <= 4e-18 at x = 25; below
# 25 the rational approximations of Cephes (S. L. Moshier), as scipy.special.j0 evaluates
# them. Tests compare the kernel with scipy.special.j0 (within 2e-16 absolute) and the
# closed form with the angular rule on whole circles.

_HANKEL_FROM = 25.0  # J_0 by its asymptotic expansion from this argument up
_HANKEL_TERMS = 10  # terms of P and of Q


def _hankel_coefficients(n: int) -> tuple[tuple, tuple]:
    """Coefficients of ``P(x) = sum_k p_k x^(-2k)`` and ``Q(x) = sum_k q_k x^(-2k-1)``
    (``k < n``) of J_0's asymptotic expansion: ``p_k = (-1)^k a_2k``,
    ``q_k = (-1)^k a_(2k+1)``, ``a_m = prod_(l <= m) (-(2l - 1)^2 / (8 l))`` (exact
    fractions, then rounded)."""
    a = [fractions.Fraction(1)]
    for m in range(1, 2 * n):
        a.append(a[-1] * fractions.Fraction(-((2 * m - 1) ** 2), 8 * m))
    p = tuple(float((-1) ** k * a[2 * k]) for k in range(n))
    q = tuple(float((-1) ** k * a[2 * k + 1]) for k in range(n))
    return p, q


_HANKEL_P, _HANKEL_Q = _hankel_coefficients(_HANKEL_TERMS)
_QUARTER_PI = 0.25 * math.pi
_SQRT_2_OVER_PI = math.sqrt(2.0 / math.pi)
# Cephes j0.c: J_0(x) = (x^2 - DR1)(x^2 - DR2) RP(x^2) / RQ(x^2) for x <= 5, and the
# modulus-phase form with PP/PQ and QP/QQ (rational in 25 / x^2) above.
_J0_DR1 = 5.78318596294678452118e0
_J0_DR2 = 3.04712623436620863991e1
_J0_RP = (
    -4.79443220978201773821e9,
    1.95617491946556577543e12,
    -2.49248344360967716204e14,
    9.70862251047306323952e15,
)
_J0_RQ = (
    4.99563147152651017219e2,
    1.73785401676374683123e5,
    4.84409658339962045305e7,
    1.11855537045356834862e10,
    2.11277520115489217587e12,
    3.10518229857422583814e14,
    3.18121955943204943306e16,
    1.71086294081043136091e18,
)
_J0_PP = (
    7.96936729297347051624e-4,
    8.28352392107440799803e-2,
    1.23953371646414299388e0,
    5.44725003058768775090e0,
    8.74716500199817011941e0,
    5.30324038235394892183e0,
    9.99999999999999997821e-1,
)
_J0_PQ = (
    9.24408810558863637013e-4,
    8.56288474354474431428e-2,
    1.25352743901058953537e0,
    5.47097740330417105182e0,
    8.76190883237069594232e0,
    5.30605288235394617618e0,
    1.00000000000000000218e0,
)
_J0_QP = (
    -1.13663838898469149931e-2,
    -1.28252718670509318512e0,
    -1.95539544257735972385e1,
    -9.32060152123768231369e1,
    -1.77681167980488050595e2,
    -1.47077505154951170175e2,
    -5.14105326766599330220e1,
    -6.05014350600728481186e0,
)
_J0_QQ = (
    6.43178256118178023184e1,
    8.56430025976980587198e2,
    3.88240183605401609683e3,
    7.24046774195652478189e3,
    5.93072701187316984827e3,
    2.06209331660327847417e3,
    2.42005740240291393179e2,
)


@compiled(inline="always")
def _horner(coef, z):
    """``coef[0] z^(n-1) + ... + coef[n-1]``."""
    v = coef[0]
    for c in coef[1:]:
        v = v * z + c
    return v


@compiled(inline="always")
def _horner_monic(coef, z):
    """``z^n + coef[0] z^(n-1) + ... + coef[n-1]``."""
    v = z + coef[0]
    for c in coef[1:]:
        v = v * z + c
    return v


@compiled()
def _j0_cephes(x):
    """J_0(x), ``x >= 0``, by Cephes' rational approximations."""
    if x <= 5.0:
        z = x * x
        return (z - _J0_DR1) * (z - _J0_DR2) * _horner(_J0_RP, z) / _horner_monic(_J0_RQ, z)
    w = 5.0 / x
    z = w * w
    p = _horner(_J0_PP, z) / _horner(_J0_PQ, z)
    q = _horner(_J0_QP, z) / _horner_monic(_J0_QQ, z)
    xn = x - _QUARTER_PI
    cs, sn = cis(xn)
    return (p * cs - w * q * sn) * _SQRT_2_OVER_PI / math.sqrt(x)


@compiled(inline="always")
def _j0_hankel(inv_x, sqrt_inv_x, x):
    """J_0(x) for ``x >= 25`` by its asymptotic expansion, from ``1 / x`` and
    ``sqrt(1 / x)`` (products only, so that a loop over modes vectorises)."""
    z = inv_x * inv_x
    p = _HANKEL_P[_HANKEL_TERMS - 1]
    q = _HANKEL_Q[_HANKEL_TERMS - 1]
    for k in range(_HANKEL_TERMS - 2, -1, -1):
        p = p * z + _HANKEL_P[k]
        q = q * z + _HANKEL_Q[k]
    cs, sn = cis(x - _QUARTER_PI)
    return (p * cs - inv_x * q * sn) * _SQRT_2_OVER_PI * sqrt_inv_x


@compiled()
def bessel_j0(x):  # pragma: no cover
    """J_0 of every entry of the 1-D array ``x`` (each ``>= 0``), as
    :func:`_add_circle_sums` evaluates it (tests compare it with scipy.special.j0)."""
    out = np.empty(x.size)
    for k in range(x.size):
        if x[k] >= _HANKEL_FROM:
            out[k] = _j0_hankel(1.0 / x[k], math.sqrt(1.0 / x[k]), x[k])
        else:
            out[k] = _j0_cephes(x[k])
    return out


@compiled(nogil=True)
def _add_circle_sums(radii, signs, wavenumbers, amplitudes, out):  # pragma: no cover
    """``out[i, k] += signs[i] amplitudes[k] J_0(wavenumbers[k] radii[i])`` for the rows
    with ``signs[i] != 0`` (radii > 0 m, wavenumbers >= 0 rad/m).

    The Hankel expansion for every mode at ``max(k r, 25)`` (a loop that vectorises:
    ``1 / (k r)`` and ``sqrt(1 / (k r))`` from per-mode and per-radius factors), then
    Cephes for the modes below 25 (the smallest wavenumbers: taken in increasing order).
    """
    m = wavenumbers.size
    order = np.argsort(wavenumbers)
    inv_k = np.empty(m)
    sqrt_inv_k = np.empty(m)
    for k in range(m):
        inv_k[k] = 1.0 / max(wavenumbers[k], 1e-300)
        sqrt_inv_k[k] = math.sqrt(inv_k[k])
    row = np.empty(m)
    cap = 1.0 / _HANKEL_FROM
    sqrt_cap = math.sqrt(cap)
    for i in range(radii.size):
        if signs[i] == 0.0:
            continue
        r = radii[i]
        inv_r = 1.0 / r
        sqrt_inv_r = math.sqrt(inv_r)
        for k in range(m):
            x = wavenumbers[k] * r
            big = x >= _HANKEL_FROM
            row[k] = _j0_hankel(
                inv_k[k] * inv_r if big else cap,
                sqrt_inv_k[k] * sqrt_inv_r if big else sqrt_cap,
                x if big else _HANKEL_FROM,
            )
        for j in range(m):
            k = order[j]
            x = wavenumbers[k] * r
            if x >= _HANKEL_FROM:
                break
            row[k] = _j0_cephes(x)
        s = signs[i]
        dest = out[i]
        for k in range(m):
            dest[k] += s * amplitudes[k] * row[k]


# Modes times this below the factor pairs of a separable rule: angular sums mode by mode
# (gathered factors, about this many times slower per multiply-add than a matrix product).
_DIRECT_RATIO = 10


def _factor_subset(rows, in_use):
    """``rows`` (sorted factor indices) for ``x_values`` / ``y_values``, or None when they
    are every factor of the table (``0 .. max(in_use)``: the whole table, no copy)."""
    return None if rows.size == int(in_use.max()) + 1 else rows


def _circle_points(radii, size, listener, kb, tol, refine):
    """Angular points of the separable rule at each of ``radii`` (m): ``(whole, theta,
    weights, ends)``. At radius ``i`` the points ``ends[i] : ends[i + 1]`` of ``theta``
    (rad) and ``weights`` lie on the arcs on the plate (``whole[i] = 0``) or, when those
    off the plate are shorter, on the arcs off it (``whole[i] = 1``: the whole circle in
    closed form minus these)."""
    a, b = size
    xl, yl, _ = listener
    whole = np.zeros(radii.size)
    panels, counts = [], np.zeros(radii.size, dtype=np.int64)
    for i, r in enumerate(radii):
        on, off = _circle_arcs(float(r), a, b, xl, yl)
        if sum(hi - lo for lo, hi in off) < sum(hi - lo for lo, hi in on):
            whole[i], arcs = 1.0, off
        else:
            arcs = on
        these = _arc_panels(float(r), kb, tol, refine, arcs)
        counts[i] = sum(n * p for _, _, n, p in these)
        panels += these
    theta, weights = _panels_points(panels)
    ends = np.concatenate(([0], np.cumsum(counts)))
    return whole, theta, weights, ends


def _apply_separable_rule(
    sep, size, listener, radii, wr, kb, tol, refine, q, r_mid, halvings, active
):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` of the separable shapes ``k``
    in ``active`` (indices), and the number of points, by the polar rule (radii
    ``radii`` with weights ``wr``). At each radius the angular sums are over the arcs on
    the plate, or, when those off the plate are shorter, the whole circle in closed form
    minus the arcs off the plate (see the comment above :data:`_HANKEL_FROM`). Only the
    factors those modes use enter the angular products."""
    a, b = size
    xl, yl, zl = listener
    m = active.size
    rows_x, xi = np.unique(sep.x_index[active], return_inverse=True)
    rows_y, yi = np.unique(sep.y_index[active], return_inverse=True)
    take_x = _factor_subset(rows_x, sep.x_index)
    take_y = _factor_subset(rows_y, sep.y_index)
    wavenumbers = np.ascontiguousarray(sep.mode_wavenumbers()[active])
    # 2 pi phi_k(xl, yl): the whole circle's integral over J_0(k r)
    centre = (
        2.0
        * math.pi
        * (
            sep.x_values(np.array([xl]), take_x)[0, xi]
            * sep.y_values(np.array([yl]), take_y)[0, yi]
        )
    )
    q = q[active]
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    # blocks of radii (one block of shape values at most CHUNK_BYTES), at least two per
    # worker; worker w takes blocks w, w + workers, ... into its own accumulators, so that
    # the result does not depend on the timing
    workers = max(1, numba.get_num_threads())
    rows = max(1, min(int(CHUNK_BYTES // (8 * m)), -(-radii.size // (2 * workers))))
    blocks = list(range(0, radii.size, rows))
    workers = min(workers, len(blocks))
    acc = np.zeros((workers, 3, m))  # per worker: real, imaginary, unused
    # few modes (a refinement of the failing ones): each mode's own angular sum costs
    # less than the product of every pair of their factors
    direct = _DIRECT_RATIO * m < rows_x.size * rows_y.size

    def block_sums(start, sums, acc_w):
        """Add the radii ``start : start + rows`` to ``acc_w``; their points."""
        rr = radii[start : start + rows]
        phi = np.zeros((rr.size, m))
        whole, theta, w, ends = _circle_points(rr, size, listener, kb, tol, refine)
        # points on the plate up to rounding; those of a whole circle's arcs off it count
        # negatively
        on = np.repeat(whole == 0.0, np.diff(ends))
        r_point = np.repeat(rr, np.diff(ends))
        x = xl + r_point * np.cos(theta)
        y = yl + r_point * np.sin(theta)
        x[on] = np.clip(x[on], 0.0, a)
        y[on] = np.clip(y[on], 0.0, b)
        w[~on] *= -1.0
        for i in np.flatnonzero(ends[1:] > ends[:-1]):
            pts = slice(ends[i], ends[i + 1])
            fx = sep.x_values(x[pts], take_x)
            fy = np.ascontiguousarray(sep.y_values(y[pts], take_y))
            if direct:
                phi[i] = w[pts] @ (fx[:, xi] * fy[:, yi])
            else:
                single_thread_product(np.ascontiguousarray((fx * w[pts, None]).T), fy, sums)
                phi[i] = sums[xi, yi]
        _add_circle_sums(rr, whole, wavenumbers, centre, phi)
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        add_sums(0, rr.size, big_r - r_mid, weight, phi, qr, qi, halvings, *acc_w)
        return theta.size

    def worker(w):
        sums = np.empty((rows_x.size, rows_y.size))
        return sum(block_sums(start, sums, acc[w]) for start in blocks[w::workers])

    if workers == 1:
        n_points = worker(0)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            n_points = sum(pool.map(worker, range(workers)))
    acc_re, acc_im, _ = acc.sum(axis=0)
    total = acc_re + 1j * acc_im
    if not np.isfinite(total).all():
        k = int(active[np.flatnonzero(~np.isfinite(total))[0]])
        raise ParameterError(f"separable shapes gave NaN or infinite values for mode {k}")
    return total, n_points


def _separable_in_phase(sep, size, listener, kb, tol):
    """``Int |phi_k| / R dA`` of separable shapes on the refined rectangle rule of
    wavenumber ``2 kb`` (as :mod:`synth.sound.radiation.summed`): with ``|phi_k| = |X_i| |Y_j|``
    one matrix product for every mode, ``|X|^T W |Y|``, ``W`` the grid's weights over
    ``R``."""
    a, b = size
    xl, yl, zl = listener
    ex, ey, px0, py0 = first_rule(a, b, listener, 2.0 * kb, tol)
    xs, wx = panel_nodes(ex, np.ceil(px0 * REFINE).astype(np.int64))
    ys, wy = panel_nodes(ey, np.ceil(py0 * REFINE).astype(np.int64))
    weights = (wx[:, None] * wy[None, :]) / np.sqrt(
        (xs[:, None] - xl) ** 2 + (ys[None, :] - yl) ** 2 + zl * zl
    )
    abs_x = np.abs(sep.x_values(xs))
    abs_y = np.abs(sep.y_values(ys))
    inner = np.empty((xs.size, abs_y.shape[1]))
    single_thread_product(weights, abs_y, inner)
    sums = np.empty((abs_x.shape[1], abs_y.shape[1]))
    single_thread_product(np.ascontiguousarray(abs_x.T), inner, sums)
    mag = sums[sep.x_index, sep.y_index]
    if not np.isfinite(mag).all():
        k = int(np.flatnonzero(~np.isfinite(mag))[0])
        raise ParameterError(f"separable shapes gave NaN or infinite values for mode {k}")
    return mag


@dataclass(frozen=True)
class _PolarSetup:
    """What a polar rule about the microphone needs (see :func:`separable_gains`): the
    plate's size (m), the listener (m), the settings as :func:`check_settings` returns
    them, ``q = s / c`` (1/m), the panel tolerance, the radial panels and their first
    orders, the middle distance ``r_mid`` (m) and the exponentials' halvings."""

    size: tuple
    listener: tuple
    q_s: np.ndarray
    kb: float
    rho: float
    c: float
    r0: float | None
    tol: float
    max_points: int
    q: np.ndarray
    tol_panel: float
    panels: list
    orders: np.ndarray
    r_mid: float
    halvings: int


def polar_setup(
    size,
    n_modes,
    listener_position,
    s,
    max_wavenumber,
    air_density,
    sound_speed,
    reference_distance,
    tol,
    max_points,
) -> _PolarSetup:
    """The arguments of a polar rule checked (a ParameterError names the field), and its
    radial panels about the listener (none without modes)."""
    a, b = size
    listener = check_listener(listener_position)
    q_s = check_poles(s)
    if q_s.size != n_modes:
        raise ParameterError(
            f"s has {q_s.size} poles for {n_modes} modes: one complex "
            f"frequency (rad/s) per mode is needed"
        )
    kb, rho, c, r0, tol = check_settings(
        max_wavenumber, air_density, sound_speed, reference_distance, tol, max_points
    )
    q = q_s / c
    tol_panel = _POLAR_PANEL_TOL * tol
    if q.size == 0:
        return _PolarSetup(
            size, listener, q_s, kb, rho, c, r0, tol, max_points, q, tol_panel, [], None, 0.0, 0
        )
    kappa = kb + float(np.max(np.abs(q)))
    h = 2.0 * half_phase(MAX_ORDER, tol_panel) / kappa if kappa > 0 else math.inf
    xl, yl, zl = listener
    panels, orders0 = radial_orders(
        radial_panels(a, b, listener, h), (a, b), listener, kb, kappa - kb, tol_panel
    )
    r_min, r_max, _, _ = _radial_segments(a, b, xl, yl)
    big_min, big_max = math.hypot(r_min, zl), math.hypot(r_max, zl)
    r_mid = 0.5 * (big_min + big_max)
    halvings = exp_halvings(q, 0.5 * (big_max - big_min))
    return _PolarSetup(
        size,
        listener,
        q_s,
        kb,
        rho,
        c,
        r0,
        tol,
        max_points,
        q,
        tol_panel,
        panels,
        orders0,
        r_mid,
        halvings,
    )


def polar_gains(setup: _PolarSetup, rule, caller: str, full_output: bool, selective=False):
    """The gains of a polar rule, refined until converged (:func:`refine`). ``rule(level)``
    applies the rule refined ``level`` times and returns its integrals, their in-phase
    bounds and its number of points; with ``selective``, ``rule(level, active)`` does so
    for the modes ``active`` alone (:func:`refine_selective`)."""
    if setup.q.size == 0:
        empty = np.zeros(0, complex)
        res = RadiationResult(empty, np.zeros(0), np.zeros(0), 0, 0, (0, 0), True, 0, "no modes")
        return res if full_output else empty
    counts = {}

    def counted(level, *active):
        total, mag, points = rule(level, *active)
        counts.setdefault(level, points)
        return total, mag

    def npoints(level):
        if level in counts:
            return counts[level]
        known = max(counts)  # not yet applied: points grow as 1.25^2 per level
        return int(counts[known] * REFINE ** (2 * (level - known)))

    q_s, q, rho = setup.q_s, setup.q, setup.rho
    shift = setup.r_mid - (0.0 if setup.r0 is None else setup.r0)
    factor = rho * q_s / (2.0 * math.pi) * np.exp(-q * shift)
    scale = rho * np.abs(q_s) / (2.0 * math.pi)
    result = dataclasses.replace(
        (refine_selective if selective else refine)(
            counted,
            npoints,
            factor,
            scale,
            setup.tol,
            setup.max_points,
            (len(setup.panels), 0),
        ),
        rule="polar",
    )
    if full_output:
        return result
    if not result.success:
        warn_unconverged(caller, result, setup.tol)
    return result.gains


def separable_gains(
    shapes,
    listener_position,
    s,
    *,
    max_wavenumber,
    air_density=AIR_DENSITY,
    sound_speed=SOUND_SPEED,
    reference_distance=None,
    tol=1e-6,
    max_points=4_000_000,
    full_output=False,
):
    """:func:`rayleigh_gains` of shapes ``X_i(x) Y_j(y)``, in polar coordinates.

    Parameters
    ----------
    shapes : synth.sound.modes.SeparableShapes
        The modes' shapes (see :meth:`synth.sound.modes.Modes.separable`) and the
        plate's size.
    listener_position, s, max_wavenumber, air_density, sound_speed
        As for :func:`rayleigh_gains` (``max_wavenumber`` bounds every shape's
        wavenumber, rad/m).
    reference_distance, tol, max_points, full_output
        As for :func:`rayleigh_gains` (``max_points`` counts the points of one rule).

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity; or a :class:`RadiationResult`
        (``panels`` holds the radial panels and 0).

    Notes
    -----
    The same integral, tolerance and convergence test (successive rules with 1.25
    times the points per axis, the error estimate their difference) as
    :func:`rayleigh_gains`; only the rule differs: polar coordinates about the
    microphone (see the comment above :func:`_radial_segments`). The angular sums
    of all modes at one radius are one matrix product of ``X`` and ``Y`` values on
    the shorter of the arcs on and off the plate (the whole circle in closed form,
    see the comment above :data:`_HANKEL_FROM`), and the radial sums cost one
    exponential and at most one ``J_0`` per mode and radius: about
    ``N_theta I J + N_r n_modes`` operations per rule (``N_theta`` the points, at
    most half of each circle, ``N_r`` the radii, ``I, J`` the numbers of factors)
    instead of ``N n_modes`` exponentials. Measured on a simply supported 1.86 m
    square plate to 22 kHz (39 797 modes): see ``synth bench scale``.
    """
    from synth.sound.modes import SeparableShapes

    if not isinstance(shapes, SeparableShapes):
        raise ParameterError(f"shapes={shapes!r} must be a synth.sound.modes.SeparableShapes")
    setup = polar_setup(
        (shapes.length, shapes.width),
        shapes.x_index.size,
        listener_position,
        s,
        max_wavenumber,
        air_density,
        sound_speed,
        reference_distance,
        tol,
        max_points,
    )

    if setup.q.size == 0:
        return polar_gains(setup, None, "separable_gains", full_output)
    in_phase = _separable_in_phase(shapes, setup.size, setup.listener, setup.kb, setup.tol_panel)

    def rule(level, active):
        f = REFINE**level
        radii, wr = radial_nodes(setup.panels, np.ceil(setup.orders * f).astype(np.int64))
        total, n = _apply_separable_rule(
            shapes,
            setup.size,
            setup.listener,
            radii,
            wr,
            setup.kb,
            setup.tol_panel,
            f,
            setup.q,
            setup.r_mid,
            setup.halvings,
            active,
        )
        return total, in_phase[active], n

    return polar_gains(setup, rule, "separable_gains", full_output, selective=True)
