"""The angular rule of the polar rules: the arcs of a circle about the microphone's
projection that lie on the plate (or off it, when shorter), and their Gauss-Legendre panels
for the trigonometric degree beyond which ``|J_n(k_b r)| <= tol`` (Jacobi-Anger).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from synth.compilation import compiled
from synth.sound.radiation.common import (
    MAX_ORDER,
    gauss,
    half_phase,
)
from synth.sound.radiation.radial import fewest_points


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


def _arcs(r: float, a: float, b: float, xl: float, yl: float) -> list:
    """Angular intervals ``(theta0, theta1)`` of the circle of radius ``r`` about
    ``(xl, yl)`` that lie on the plate ``[0, a] x [0, b]``."""
    return circle_arcs(r, a, b, xl, yl)[0]


_ANGLE_MIN_ORDER = 4  # Gauss-Legendre points of the shortest angular panels


# Panel accuracy of the polar rule, relative to tol (as the rectangle rule's).
POLAR_PANEL_TOL = 0.1


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
    """Fewest Fourier orders ``N >= x`` beyond which ``|J_n(x)| <= tol`` (``n >= N``).

    A plane wave of wavenumber ``k <= k_b`` on a circle of radius ``r`` is
    ``exp(i k r cos(theta - theta_k)) = sum_n i^n J_n(k r) exp(i n (theta - theta_k))``,
    and ``|J_n(k r)| <= |J_n(k_b r)|`` decreases in ``n`` past ``k_b r``: a shape made
    of such waves is, to ``tol``, a trigonometric polynomial of degree ``N``.
    """
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
    w24 = half_phase(MAX_ORDER, tol)
    h = 2.0 * w24 / rate if rate > 0 else math.inf
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
    xl, yl, _ = listener
    if arcs is None:
        arcs = _arcs(r, a, b, xl, yl)
    return panels_points(arc_panels(r, kb, tol, refine, arcs))
