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
one exponential per mode and radius. Angular points: Gauss-Legendre panels for a
trigonometric polynomial of the degree beyond which ``|J_n(k_b r)| <= tol`` (a plane wave
on a circle, Jacobi-Anger). Radial panels: as along x and y in the rectangle rule, with
breakpoints where the set of arcs changes (a circle touching an edge's line, where
``Phi_k`` behaves as ``sqrt(r - d)``, removed by ``r = d + L u^2``; a corner, a kink), and
sized for the phase of ``exp(-s R / c)`` plus that of the arcs' ends travelling along the
edges. The tolerance, the error estimate and the convergence test are those of
:mod:`synth.sound.radiation.refinement`, each mode refined alone
(:func:`~synth.sound.radiation.refinement.refine_selective`). The in-phase bounds ``S_k``
(``|phi_k| = |X_i| |Y_j|``) come from one matrix product on a rectangle rule that resolves
the shapes but not the acoustic phase. Tests compare the two rules on plates where both
run (agreement within ``2 tol``, in-phase bounds within 5 %).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.special

from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.sound.modes import single_thread_product
from synth.sound.radiation.common import (
    CHUNK_BYTES,
    GRADING,
    MAX_ORDER,
    REFINE,
    RadiationResult,
    accumulate,
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


def radial_panels(a, b, listener, h):
    """Radial panels ``(lo, hi, kind)``: ``kind`` 0 plain, +1 (-1) with the
    ``sqrt`` behaviour at ``lo`` (``hi``) removed by a quadratic substitution.
    At most ``h`` long and, from the microphone's projection, at most
    ``2 max(z, r)`` long (as along x and y in :mod:`synth.sound.radiation.rectangle`)."""
    xl, yl, zl = listener
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
            if s0 and cuts[1] - p0 > 0.5 * h:
                cuts.insert(1, p0 + 0.5 * h)
            if s1 and p1 - cuts[-2] > 0.5 * h:
                cuts.insert(len(cuts) - 1, p1 - 0.5 * h)
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


def _arcs(r: float, a: float, b: float, xl: float, yl: float) -> list:
    """Angular intervals ``(theta0, theta1)`` of the circle of radius ``r`` about
    ``(xl, yl)`` that lie on the plate ``[0, a] x [0, b]``."""
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
    arcs = []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        if hi - lo <= 1e-15:
            continue
        mid = 0.5 * (lo + hi)
        x, y = xl + r * math.cos(mid), yl + r * math.sin(mid)
        if 0.0 <= x <= a and 0.0 <= y <= b:
            if arcs and arcs[-1][1] == lo:
                arcs[-1] = (arcs[-1][0], hi)
            else:
                arcs.append((lo, hi))
    return arcs


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
    n = np.arange(math.floor(x), math.floor(x) + 64 + int(8 * x ** (1.0 / 3.0)))
    small = np.flatnonzero(np.abs(scipy.special.jv(n, x)) <= tol)
    return int(n[small[0]]) if small.size else int(n[-1])


def angular_rule(r, a, b, listener, kb, tol, refine):
    """Angles (rad) and weights of ``Int f(theta) dtheta`` over the arcs of radius ``r``
    on the plate, for shapes made of plane waves of wavenumbers at most ``kb``
    (:func:`_angular_band`); orders times ``refine``."""
    xl, yl, _ = listener
    arcs = _arcs(r, a, b, xl, yl)
    # kb r rounded up to an integer so that neighbouring radii share the computation
    rate = float(_angular_band(float(math.ceil(kb * r)), tol))
    w24 = half_phase(MAX_ORDER, tol)
    h = 2.0 * w24 / rate if rate > 0 else math.inf
    ts, ws = [], []
    for lo, hi in arcs:
        n = max(1, math.ceil((hi - lo) / h))
        ends = np.linspace(lo, hi, n + 1)
        p = math.ceil(_fewest_points(0.5 * rate * (hi - lo) / n, tol, _ANGLE_MIN_ORDER) * refine)
        t, w = gauss(p)
        half = 0.5 * (ends[1:] - ends[:-1])
        mid = 0.5 * (ends[1:] + ends[:-1])
        ts.append((mid[:, None] + half[:, None] * t[None, :]).ravel())
        ws.append((half[:, None] * w[None, :]).ravel())
    if not ts:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(ts), np.concatenate(ws)


# Modes times this below the factor pairs of a separable rule: angular sums mode by mode
# (gathered factors, about this many times slower per multiply-add than a matrix product).
_DIRECT_RATIO = 10


def _apply_separable_rule(
    sep, size, listener, radii, wr, kb, tol, refine, q, r_mid, halvings, active
):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` of the separable shapes ``k``
    in ``active`` (indices), and the number of points, by the polar rule (radii
    ``radii`` with weights ``wr``). Only the factors those modes use enter the angular
    products."""
    a, b = size
    xl, yl, zl = listener
    m = active.size
    rows_x, xi = np.unique(sep.x_index[active], return_inverse=True)
    rows_y, yi = np.unique(sep.y_index[active], return_inverse=True)
    q = q[active]
    acc_re, acc_im, unused = np.zeros(m), np.zeros(m), np.zeros(m)
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    rows = max(1, int(CHUNK_BYTES // (8 * m)))
    n_points = 0
    sums = np.empty((rows_x.size, rows_y.size))
    # few modes (a refinement of the failing ones): each mode's own angular sum costs
    # less than the product of every pair of their factors
    direct = _DIRECT_RATIO * m < rows_x.size * rows_y.size
    for start in range(0, radii.size, rows):
        rr = radii[start : start + rows]
        phi = np.empty((rr.size, m))
        for i, r in enumerate(rr):
            theta, w = angular_rule(float(r), a, b, listener, kb, tol, refine)
            n_points += theta.size
            if theta.size == 0:
                phi[i] = 0.0
                continue
            x = np.clip(xl + r * np.cos(theta), 0.0, a)
            y = np.clip(yl + r * np.sin(theta), 0.0, b)
            fx = sep.x_values(x, rows_x)
            fy = np.ascontiguousarray(sep.y_values(y, rows_y))
            if direct:
                phi[i] = w @ (fx[:, xi] * fy[:, yi])
            else:
                single_thread_product(np.ascontiguousarray((fx * w[:, None]).T), fy, sums)
                phi[i] = sums[xi, yi]
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        dist = big_r - r_mid
        accumulate(0, rr.size, dist, weight, phi, qr, qi, halvings, acc_re, acc_im, unused)
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
    of all modes at one radius are one matrix product of ``X`` and ``Y`` values,
    and the radial sums cost one exponential per mode and radius: about
    ``N_theta I J + N_r n_modes`` operations per rule (``N_theta`` the points,
    ``N_r`` the radii, ``I, J`` the numbers of factors) instead of
    ``N n_modes`` exponentials. Measured on a simply supported 1.86 m square
    plate to 22 kHz (34 161 modes): see ``synth bench scale``.
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
