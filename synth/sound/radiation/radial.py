"""The radial panels of the polar rules: breakpoints where the set of arcs on the plate
changes (a circle touching an edge's line, a corner), the ``r = d + L u^2`` substitution
past an edge's foot, and the Gauss-Legendre orders sized for the phase of
``exp(-s R / c)`` and of the arcs' ends.
"""

from __future__ import annotations

import math

import numpy as np

from synth.sound.radiation.common import (
    GRADING,
    MAX_ORDER,
    gauss,
    half_phase,
    min_order,
)

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


def radial_panels(a, b, listener, h, h_substituted=None):
    """Radial panels ``(lo, hi, kind)``: ``kind`` 0 plain, +1 (-1) with the
    ``sqrt`` behaviour at ``lo`` (``hi``) removed by a quadratic substitution.
    At most ``h`` long and, from the microphone's projection, at most
    ``2 max(z, r)`` long (as along x and y in :mod:`synth.sound.radiation.rectangle`);
    a substituted panel at most ``h_substituted`` long (m, default ``h / 2``)."""
    xl, yl, zl = listener
    sub = 0.5 * h if h_substituted is None else min(0.5 * h, h_substituted)
    r_min, r_max, singular, kinks = radial_segments(a, b, xl, yl)
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
        orders.append(fewest_points(half, tol, p_min))
    return out, np.array(orders, dtype=np.int64)


def fewest_points(phase: float, tol: float, p_min: int) -> int:
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
