"""The grids of the polar rules: the arcs of circles about the microphone's projection that lie on
the plate and their Gauss-Legendre panels, and radial panels broken where the arcs change."""

from __future__ import annotations

import functools
import math

import numpy as np

from synth.compilation import compiled
from synth.sound.radiation.common import (
    GRADING,
    MAX_ORDER,
    fewest_points,
    gauss,
    half_phase,
    min_order,
    panel_length,
)


def circle_arcs(r: float, a: float, b: float, xl: float, yl: float) -> tuple[list, list]:
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


def shorter_arcs(r: float, a: float, b: float, xl: float, yl: float) -> tuple[bool, list]:
    """Whether the arcs of :func:`circle_arcs` off the plate are shorter than those on it
    (the separable rule then sums those: the whole circle in closed form minus them), and
    the shorter arcs."""
    on, off = circle_arcs(r, a, b, xl, yl)
    if sum(hi - lo for lo, hi in off) < sum(hi - lo for lo, hi in on):
        return True, off
    return False, on


_ANGLE_MIN_ORDER = 4  # Gauss-Legendre points of the shortest angular panels
POLAR_PANEL_TOL = 0.1  # panel accuracy of the polar rules, relative to tol (as the rectangle's)
#: Largest argument whose Bessel orders :func:`bessel_orders` takes by recurrence (checked
#: against scipy's ``jv`` up to here: tests/test_radiation_polar.py); above it, scipy.
RECURRENCE_MAX_X = 1200.0


def bessel_orders(x: float, n_max: int) -> np.ndarray:
    """``J_0(x) .. J_n_max(x)`` for ``x >= 0`` by Miller's backward recurrence
    (``J_(k-1) = (2k / x) J_k - J_(k+1)`` from an order well past ``max(n_max, x)``,
    normalised by ``J_0 + 2 sum_k J_2k = 1``; Abramowitz & Stegun 9.1.27 and 9.1.46), with
    no scipy import: a plain render's rule choice counts the angular orders with it."""
    out = np.zeros(n_max + 1)
    if x == 0.0:
        out[0] = 1.0
        return out
    top = max(n_max, math.ceil(x))
    m = top + 20 + int(math.sqrt(160.0 * top))
    m += m % 2
    j = np.zeros(m + 2)
    j[m] = 1e-30
    total = 0.0
    for k in range(m, 0, -1):
        j[k - 1] = (2.0 * k / x) * j[k] - j[k + 1]
        if abs(j[k - 1]) > 1e250:  # rescaled: the recurrence grows past the decaying orders
            j[k - 1 : m + 1] *= 1e-250
            total *= 1e-250
        if k - 1 > 0 and (k - 1) % 2 == 0:
            total += 2.0 * j[k - 1]
    total += j[0]
    out[:] = j[: n_max + 1] / total
    return out


@functools.lru_cache(maxsize=4096)
def _angular_band(x: float, tol: float) -> int:
    """Fewest Fourier orders ``N >= x`` beyond which ``|J_n(x)| <= tol`` (``n >= N``): by
    Jacobi-Anger, a shape made of plane waves of wavenumber ``k <= k_b`` on a circle of radius
    ``r`` is, to ``tol``, a trigonometric polynomial of degree ``N``."""
    n = np.arange(math.floor(x), math.floor(x) + 64 + int(8 * x ** (1.0 / 3.0)))
    if x <= RECURRENCE_MAX_X:
        j = bessel_orders(x, int(n[-1]))[n[0] :]
    else:
        import scipy.special  # imported on use: only plates far larger than the presets'

        j = scipy.special.jv(n, x)
    small = np.flatnonzero(np.abs(j) <= tol)
    return int(n[small[0]]) if small.size else int(n[-1])


def arc_panels(r, kb, tol, refine, arcs) -> list:
    """Gauss-Legendre panels of the angular rule at radius ``r`` on ``arcs`` (a list of
    ``(theta0, theta1)``, rad): per arc ``(theta0, theta1, panels, points per panel)``,
    for shapes made of plane waves of wavenumbers at most ``kb`` (:func:`_angular_band`),
    orders times ``refine``."""
    # kb r rounded up to an integer so that neighbouring radii share the computation
    rate = float(_angular_band(float(math.ceil(kb * r)), tol))
    h = panel_length(rate, tol)
    out = []
    for lo, hi in arcs:
        n = max(1, math.ceil((hi - lo) / h))
        p = math.ceil(fewest_points(0.5 * rate * (hi - lo) / n, tol, _ANGLE_MIN_ORDER) * refine)
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


def panels_points(panels) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the panels ``(lo, hi, count, order)`` (:func:`arc_panels`)."""
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
    if arcs is None:
        arcs = circle_arcs(r, a, b, listener[0], listener[1])[0]
    return panels_points(arc_panels(r, kb, tol, refine, arcs))


# ----------------------------------------------------------------------------------------
# Separable shapes: the integral in polar coordinates about the microphone
# (:mod:`synth.sound.radiation.polar`). The angular integrand oscillates at most at k_b r
# rad/rad, the radial one at k_b + |q|; Phi_k(r) behaves as sqrt(r - d) where a circle
# touches an edge's line (removed by r = d + L u^2) and has a kink at a corner's distance.


def radial_segments(a: float, b: float, xl: float, yl: float):
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
    """Radial panels ``(lo, hi, kind)``: ``kind`` 0 plain, +1 (-1) with the ``sqrt``
    behaviour at ``lo`` (``hi``) removed by a quadratic substitution. At most ``h`` long (a
    substituted one ``h / 2``: it doubles the phase per unit of its variable) and, from the
    microphone's projection, at most ``2 max(z, r)`` long (as along x and y in
    :mod:`synth.sound.radiation.rectangle`)."""
    xl, yl, zl = listener
    sub = 0.5 * h
    r_min, r_max, singular, kinks = radial_segments(a, b, xl, yl)
    points = sorted([(r_min, False), (r_max, False), *((t, True) for t in singular),
                     *((t, False) for t in kinks)])  # fmt: skip
    ends, sing = [], []
    for t, s in points:  # breakpoints closer than 1e-12 r_max are one (rounding)
        if ends and t - ends[-1] <= 1e-12 * r_max:
            sing[-1] = sing[-1] or s
        else:
            ends.append(t)
            sing.append(s)
    ends[-1] = r_max
    pieces = []
    for t0, t1, lo_s, hi_s in zip(ends[:-1], ends[1:], sing[:-1], sing[1:]):
        if lo_s and hi_s:
            mid = 0.5 * (t0 + t1)
            pieces += [(t0, mid, True, False), (mid, t1, False, True)]
        else:
            pieces.append((t0, t1, lo_s, hi_s))
    panels = []
    for p0, p1, s0, s1 in pieces:
        cuts, t = [p0], p0
        while t < p1:
            t = min(t + min(h, GRADING * max(zl, t)), p1)
            cuts.append(t)
        if s0 and cuts[1] - p0 > sub:
            cuts.insert(1, p0 + sub)
        if s1 and p1 - cuts[-2] > sub:
            cuts.insert(len(cuts) - 1, p1 - sub)
        cuts = np.array(cuts)
        cuts = cuts[np.concatenate(([True], np.diff(cuts) > 1e-12 * r_max))]
        cuts[-1] = p1
        n = cuts.size - 1
        for i in range(n):
            kind = 1 if (s0 and i == 0) else (-1 if (s1 and i == n - 1) else 0)
            panels.append((float(cuts[i]), float(cuts[i + 1]), kind))
    return panels


def _panel_phase(lo, hi, kind, tangents, kb, qa, z):
    """Largest phase change (rad) over a radial panel of the polar integrand's terms: of
    ``exp(-q R)``, and of a shape's plane waves inside the arcs and at an arc's end travelling
    along an edge's line (a substituted panel counts twice as long, ``dr/du <= 2 L``)."""
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
        orders.append(fewest_points(half, tol, p_min))
    return out, np.array(orders, dtype=np.int64)


def radial_rule(size, listener, kb: float, qa: float, tol: float):
    """The radial panels about ``listener`` and their first-rule orders
    (:func:`radial_orders`) for bending wavenumbers up to ``kb`` and acoustic ones up to
    ``qa`` (rad/m)."""
    h = panel_length(kb + qa, tol)
    return radial_orders(radial_panels(*size, listener, h), size, listener, kb, qa, tol)


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
