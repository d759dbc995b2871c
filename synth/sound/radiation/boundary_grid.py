"""The boundary rule's radial grid: Gauss-Legendre panels about the microphone's projection,
graded towards the edges' feet and the centre, with the exact weights of the decaying
tables' exponentials (:func:`decay_weights`) and the ladder of radial rates that groups
of terms share.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from synth.sound.radiation.common import (
    GRADING,
    MAX_ORDER,
    gauss,
    half_phase,
)
from synth.sound.radiation.radial import radial_nodes, radial_orders, radial_panels

#: Longest substituted radial panel (``r = lo + L u^2``) of the decaying tables, times
#: ``1 / kappa``: there the cumulative integrals carry ``exp(kappa (t - lo))`` across the
#: panel (error growth ``e``); plain panels take the exponential exactly
#: (:func:`decay_weights`).
_DECAY_SUBSTITUTED = 1.0


#: Ladder of the exponents ``c = kappa h / 2`` of the exact weights: a panel takes the
#: weights of the step at or below its ``c`` and carries the rest, ``exp((c - c0) (x +
#: 1))``, in its values (growth at most ``exp(2 c (1 - 1 / ladder))``, 75 at ``c = 50``).
DECAY_LADDER = 2.0 ** (1.0 / 16.0)


#: Below this ``c`` a plain panel carries the whole exponential (growth at most ``e^0.5``).
DECAY_MIN_C = 0.25


#: Lowest step of that ladder (``c0 = DECAY_LADDER ** step``, about 1e-3), for its keys.
SENTINEL = -160


#: The decaying tables' backward integrals run this many decay lengths ``1 / kappa``
#: beyond the plate's farthest radius: the neglected rest is below ``exp(-40)`` (4e-18) of
#: the integrand's scale, and ``F`` has no boundary layer at the farthest corner.
_DECAY_TAIL = 40.0


#: Dyadic panels towards the centre (``t log t`` terms: the innermost panel's share of
#: the integral is about ``4^-levels``).
_CENTRE_LEVELS = 12


#: Length of a panel beyond a foot's radius over its distance from it.
_GRADING_FEET = 2.0


#: Ratio between the radial rates that the groups of terms share (their panels are sized
#: for the top of their step: at most this much finer than a term needs).
RATE_LADDER = 2.0 ** (1.0 / 32.0)


@functools.cache
def _spectral(p: int) -> np.ndarray:
    """``S[i, j] = Int_{-1}^{t_i} l_j(t) dt``: cumulative integrals at the ``p``
    Gauss-Legendre nodes ``t_i`` of the interpolant through them."""
    t, w = gauss(p)
    n = np.arange(p)
    leg = np.polynomial.legendre.legvander(t, p)  # P_0..P_p at the nodes, (p, p + 1)
    # l_j = sum_n c_nj P_n, c_nj = (2n + 1)/2 w_j P_n(t_j)
    c = (2 * n[:, None] + 1) / 2.0 * w[None, :] * leg[:, :p].T
    # Int_{-1}^t P_0 = t + 1; Int_{-1}^t P_n = (P_{n+1} - P_{n-1}) / (2n + 1)
    integ = np.empty((p, p))
    integ[:, 0] = t + 1.0
    for k in range(1, p):
        integ[:, k] = (leg[:, k + 1] - leg[:, k - 1]) / (2 * k + 1)
    s = integ @ c
    s.setflags(write=False)
    return s


@functools.cache
def _step_rules(p: int, m: int):
    """The steps of :func:`decay_weights` between the ``p`` Gauss-Legendre nodes and the
    ends of ``[-1, 1]`` (``p + 1`` steps): their ends, ``m``-point Gauss-Legendre nodes
    in each (``(p + 1, m)``) and weights, and the Lagrange polynomials there
    (``(p + 1, m, p)``)."""
    t, w = gauss(p)
    ends = np.concatenate(([-1.0], t, [1.0]))
    step = np.diff(ends)
    u, v = gauss(m)
    pts = 0.5 * (ends[:-1] + ends[1:])[:, None] + 0.5 * step[:, None] * u[None, :]
    n = np.arange(p)
    coef = (2 * n[:, None] + 1) / 2.0 * w[None, :] * np.polynomial.legendre.legvander(t, p - 1).T
    lag = np.polynomial.legendre.legvander(pts, p - 1) @ coef
    return ends, pts, v, lag


@functools.cache
def decay_weights(p: int, c: float) -> np.ndarray:
    """Product weights of ``p``-point Gauss-Legendre panels for the weight function
    ``exp(-c (x_a - x))``: ``E[a, j] = Int_{-1}^{x_a} exp(-c (x_a - x)) l_j(x) dx`` at the
    nodes ``x_a`` (rows ``0 .. p-1``) and at ``x_p = 1`` (row ``p``), ``l_j`` the Lagrange
    polynomials through the nodes: exact for ``exp(-c (x_a - x))`` times any polynomial of
    degree below ``p``. Read only.

    Built from node to node (each step's exponential at most 1: no cancellation for
    small ``c``, underflow to 0 for large ``c``), each step by Gauss-Legendre with enough
    points for the polynomial and the exponential (phase ``c`` times the step); at
    ``c = 0`` the spectral integration matrix and the Gauss weights."""
    step = np.diff(np.concatenate(([-1.0], gauss(p)[0], [1.0])))
    m = p // 2 + 1
    while half_phase(m, 1e-15) < 0.5 * c * step.max() and m < 4 * p + 200:
        m += 4
    ends, pts, v, lag = _step_rules(p, m + 4)
    kern = 0.5 * step[:, None] * v[None, :] * np.exp(-c * (ends[1:, None] - pts))
    local = np.einsum("im,imj->ij", kern, lag)
    out = np.empty((p + 1, p))
    acc = np.zeros(p)
    for i in range(p + 1):
        acc = math.exp(-c * step[i]) * acc + local[i]
        out[i] = acc
    out.setflags(write=False)
    return out


def _graded_from_feet(panels, feet):
    """Panels beyond the radii ``feet`` where a circle touches an edge's line, graded
    from them: an edge point's distance from the foot, ``sqrt(rho^2 - d^2)``, has its
    branch points at ``rho = +-d``, so a substituted panel (``kind`` +1, starting at
    ``d``) is at most ``d`` long and a plain panel at most ``_GRADING_FEET`` times its
    distance from the nearest foot below it."""
    feet = np.sort(np.asarray([d for d in feet if d > 0.0]))
    out = []
    for lo, hi, kind in panels:
        if kind == 1 and hi - lo > lo:
            out.append((lo, 2.0 * lo, 1))
            lo, kind = 2.0 * lo, 0
        if kind != 0:
            out.append((lo, hi, kind))
            continue
        below = feet[feet <= lo * (1.0 + 1e-12)]
        if below.size == 0:
            out.append((lo, hi, kind))
            continue
        d = float(below[-1])
        t = lo
        while t < hi:
            step = _GRADING_FEET * (t - d) if t > d * (1.0 + 1e-12) else hi - t
            nxt = min(t + step, hi)
            if hi - nxt < 0.5 * (nxt - t):
                nxt = hi
            out.append((t, nxt, 0))
            t = nxt
    return out


def _tail_panels(start, h, length):
    """Plain panels at most ``h`` long from ``start`` over ``length`` (m) beyond it."""
    count = max(1, math.ceil(length / h))
    cuts = start + length * np.arange(count + 1) / count
    return [(float(u), float(v), 0) for u, v in zip(cuts[:-1], cuts[1:])]


def _feet(size, listener):
    """Radii where a circle about the microphone's projection touches an edge's line
    with the foot of the perpendicular on the edge."""
    a, b = size
    xl, yl, _ = listener
    out = []
    if 0.0 < yl < b:
        out += [abs(xl), abs(a - xl)]
    if 0.0 < xl < a:
        out += [abs(yl), abs(b - yl)]
    return out


class RadialGrid:
    """Radial panels about the microphone's projection, their nodes, and the boundary
    nodes (where the nodes' circles cross the edges)."""

    def __init__(self, size, listener, k_osc, kappa_max, kappa_min, tol_panel, refine):
        a, b = size
        xl, yl, zl = listener
        h = 2.0 * half_phase(MAX_ORDER, tol_panel) / k_osc
        h_sub = _DECAY_SUBSTITUTED / kappa_max if kappa_max > 0 else None
        panels = radial_panels(a, b, listener, h, h_sub)
        r_min = panels[0][0]
        if r_min > 0.0:
            cuts = [0.0]
            while cuts[-1] < r_min:
                t = cuts[-1]
                cuts.append(min(t + min(h, GRADING * max(zl, t)), r_min))
            panels = [(lo, hi, 0) for lo, hi in zip(cuts[:-1], cuts[1:])] + panels
        panels = _graded_from_feet(panels, _feet(size, listener))
        if kappa_min > 0.0:
            panels += _tail_panels(panels[-1][1], h, _DECAY_TAIL / kappa_min)
        lo0, hi0, kind0 = panels[0]
        if lo0 == 0.0 and kind0 <= 0:
            # Y0(k t) t and K0(k t) t behave as t log t at the centre: dyadic panels
            cuts = hi0 * 0.5 ** np.arange(_CENTRE_LEVELS, -1, -1)
            inner = [(0.0, float(cuts[0]), 0)]
            inner += [(float(u), float(v), 0) for u, v in zip(cuts[:-1], cuts[1:])]
            inner[-1] = (inner[-1][0], inner[-1][1], kind0)
            panels = inner + panels[1:]
        panels, orders = radial_orders(panels, size, listener, k_osc, 0.0, tol_panel)
        orders = np.ceil(orders * refine).astype(np.int64)
        self.panels = panels
        self.orders = orders
        self.kinds = np.array([p[2] for p in panels], dtype=np.int64)
        self.rho, self.w = radial_nodes(panels, orders)
        self.jac = np.concatenate(
            [w / gauss(int(p))[1] for w, p in zip(np.split(self.w, np.cumsum(orders)[:-1]), orders)]
        )
        self.starts = np.concatenate(([0], np.cumsum(orders))).astype(np.int64)
        self.lo = np.array([p[0] for p in panels])
        self.hi = np.array([p[1] for p in panels])
        self.r_big = np.sqrt(self.rho**2 + zl * zl)
        self.edges = self._edges(size, listener)
        self.gw = np.concatenate([gauss(int(p))[1] for p in orders])
        mats = [_spectral(int(p)).ravel() for p in orders]
        self.sflat = np.concatenate(mats)
        self.soff = np.concatenate(([0], np.cumsum([m.size for m in mats])[:-1])).astype(np.int64)
        self.edge_arrays = (
            np.array([e[0] for e in self.edges], dtype=np.int64),
            np.array([e[1] for e in self.edges], dtype=np.bool_),
            np.array([e[2] for e in self.edges], dtype=float),
            np.concatenate(([0], np.cumsum([e[3].size for e in self.edges]))).astype(np.int64),
            np.concatenate([e[3] for e in self.edges]).astype(np.int64),
            np.concatenate([e[4] for e in self.edges]),
            np.concatenate([e[5] for e in self.edges]),
        )
        # panels with boundary nodes: only there are F's values needed
        on_node = np.zeros(self.rho.size, dtype=np.bool_)
        on_node[self.edge_arrays[4]] = True
        self.on_edge = np.logical_or.reduceat(on_node, self.starts[:-1])
        self.on_node = np.repeat(self.on_edge, np.diff(self.starts))

    def _edges(self, size, listener):
        """Per edge: (axis, at_high, d, node index, coordinate along the edge (m),
        weight ds)."""
        a, b = size
        xl, yl, _ = listener
        out = []
        specs = [
            (0, False, xl, yl, b),  # x = 0: along y, foot at yl
            (0, True, a - xl, yl, b),  # x = a
            (1, False, yl, xl, a),  # y = 0: along x
            (1, True, b - yl, xl, a),
        ]
        for axis, high, d, foot, length in specs:
            pieces = []
            s0, s1 = -foot, length - foot
            if s0 < 0.0 < s1:
                pieces = [(s0, 0.0, -1.0), (0.0, s1, 1.0)]
            elif s1 <= 0.0:
                pieces = [(s0, s1, -1.0)]
            else:
                pieces = [(s0, s1, 1.0)]
            idx_all, pos_all, w_all = [], [], []
            for p0, p1, sign in pieces:
                r0 = math.hypot(d, min(abs(p0), abs(p1)) if p0 * p1 > 0 else 0.0)
                r1 = math.hypot(d, max(abs(p0), abs(p1)))
                tol_r = 1e-9 * max(r1, 1e-300)
                sel = np.flatnonzero((self.lo >= r0 - tol_r) & (self.hi <= r1 + tol_r))
                if sel.size == 0:
                    continue
                idx = np.concatenate([np.arange(self.starts[i], self.starts[i + 1]) for i in sel])
                rho = self.rho[idx]
                s = np.sqrt(np.maximum(rho * rho - d * d, 0.0))
                idx_all.append(idx)
                pos_all.append(foot + sign * s)
                w_all.append(self.w[idx] * rho / np.maximum(s, 1e-300))
            out.append(
                (
                    axis,
                    high,
                    d,
                    np.concatenate(idx_all),
                    np.concatenate(pos_all),
                    np.concatenate(w_all),
                )
            )
        return out


def rate_steps(rate: np.ndarray) -> np.ndarray:
    """Step of each radial rate (1/m) on the ladder ``RATE_LADDER ** step``: the
    smallest step at or above it (up to rounding)."""
    return np.ceil(np.log(rate) / math.log(RATE_LADDER)).astype(np.int64)


def on_ladder(rate: float) -> float:
    """``rate`` (1/m) rounded up to the ladder of :func:`rate_steps` (0 stays 0)."""
    if rate <= 0.0:
        return 0.0
    return max(RATE_LADDER ** float(rate_steps(np.array([rate]))[0]), rate)


def below_ladder(rate: float) -> float:
    """``rate`` (1/m) rounded down to the ladder of :func:`rate_steps` (0 stays 0)."""
    if rate <= 0.0:
        return 0.0
    return min(RATE_LADDER ** float(rate_steps(np.array([rate]))[0] - 1), rate)
