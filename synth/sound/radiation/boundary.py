"""Rayleigh gains of the dynamic edge effect modes as integrals over the plate's boundary.

Each edge effect shape is a sum of products ``f(x) g(y)`` with ``f'' = alpha_x f`` and
``g'' = alpha_y g`` (:mod:`synth.sound.asymptotic_modes`: interior ``cos``/``sin`` terms,
``alpha = -s``, and edge ``cosh``/``sinh`` terms, ``alpha = s + 2 s_o``), so every product
``psi`` solves the Helmholtz equation ``(lap + q^2) psi = 0`` with ``q^2 = -(alpha_x +
alpha_y)``: ``+k^2`` (interior x interior), ``-k^2`` (interior x edge) or ``-3 k^2``
(edge x edge, the corner term), ``k`` the trial's wavenumber. With ``F`` a radial solution
(about the microphone's projection ``o``, ``rho = |x - o|``) of ``(lap + q^2) F = G``,
``G = exp(-sigma R) / R``, ``R = sqrt(rho^2 + z^2)``, ``sigma = s / c``, Green's second
identity gives exactly::

    Int_P psi G dA = Oint (psi dF/dn - F dpsi/dn) ds,    dF/dn = F'(rho) d_e / rho

(``d_e`` the distance from ``o`` to the edge's line, signed positive on the plate's
side). ``F`` regular at ``rho = 0`` by variation of parameters::

    q^2 = k^2 > 0:   F = (pi/2) [Y0(k rho) Int_0^rho J0(k t) G t dt
                                - J0(k rho) Int_0^rho Y0(k t) G t dt]
    q^2 = -kappa^2:  F = -[I0(kappa rho) Int_rho^R1 K0(kappa t) G t dt
                           + K0(kappa rho) Int_0^rho I0(kappa t) G t dt]

(the second with the growing solution removed, in exponentially scaled Bessel functions).
Both radial integrals and the boundary integral are taken on one set of radial
Gauss-Legendre panels (those of the polar rule, :mod:`synth.sound.radiation`: break
points where a circle touches an edge's line, with the ``sqrt`` behaviour removed, and
at the corners' distances), a boundary node sitting where its circle crosses the edge;
the cumulative integrals inside a panel by Gauss-Legendre spectral integration. In the
decaying parts the factors ``exp(-kappa |rho - t|)`` of the scaled Bessel functions are
taken exactly: on a plain panel by product weights for the weight function
``exp(-kappa (t_a - t))`` (:func:`decay_weights`), so the panels need only resolve
``G`` and the scaled Bessel functions, as in the oscillating part; and ``R1`` lies
``40 / kappa`` beyond the farthest corner (``F`` has no boundary layer on the plate). The
three parts share one grid and each boundary node's trial values. The cost per mode is
a few Bessel functions per radial node plus the boundary nodes: it grows with the
plate's diameter times the wavenumber, not its area.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

from synth.compilation import compiled
from synth.sound.asymptotic_modes import edge_part, interior_part
from synth.sound.radiation.common import (
    GRADING,
    MAX_ORDER,
    REFINE,
    RadiationResult,
    gauss,
    half_phase,
)
from synth.sound.radiation.polar import radial_nodes, radial_orders, radial_panels
from synth.sound.radiation.refinement import refine_selective

#: Longest substituted radial panel (``r = lo + L u^2``) of the decaying tables, times
#: ``1 / kappa``: there the cumulative integrals carry ``exp(kappa (t - lo))`` across the
#: panel (error growth ``e``); plain panels take the exponential exactly
#: (:func:`decay_weights`).
_DECAY_SUBSTITUTED = 1.0
#: Ladder of the exponents ``c = kappa h / 2`` of the exact weights: a panel takes the
#: weights of the step at or below its ``c`` and carries the rest, ``exp((c - c0) (x +
#: 1))``, in its values (growth at most ``exp(2 c (1 - 1 / ladder))``, 75 at ``c = 50``).
_DECAY_LADDER = 2.0 ** (1.0 / 16.0)
#: Below this ``c`` a plain panel carries the whole exponential (growth at most ``e^0.5``).
_DECAY_MIN_C = 0.25
#: Lowest step of that ladder (``c0 = _DECAY_LADDER ** step``, about 1e-3), for its keys.
_SENTINEL = -160
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
_RATE_LADDER = 2.0 ** (1.0 / 32.0)


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


class _Grid:
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


#: Arguments above which the Bessel functions are summed from their Hankel expansions
#: (summed until a term is below 1e-17: the expansions' smallest term is about exp(-2 x); A & S
#: 9.2.5-9.2.10, 9.7.1-9.7.2).
_ASYMPTOTIC_X = 20.0
_TERMS = 40


def _hankel_coefficients(nu: int) -> np.ndarray:
    """``a_k(nu) = prod_{j=1..k} (4 nu^2 - (2j - 1)^2) / (k! 8^k)``, ``k < _TERMS``."""
    a = np.ones(_TERMS)
    for k in range(1, _TERMS):
        a[k] = a[k - 1] * (4.0 * nu * nu - (2 * k - 1) ** 2) / (8.0 * k)
    return a


_A0 = _hankel_coefficients(0)
_A1 = _hankel_coefficients(1)


@compiled()
def _hankel_pq(x, a):  # pragma: no cover
    """``(P, Q)`` of the Hankel expansion with coefficients ``a`` at ``x``, and the
    sum ``sum_k a_k / x^k`` (K) and ``sum_k (-1)^k a_k / x^k`` (I)."""
    p = 0.0
    q = 0.0
    sk = 0.0
    si = 0.0
    inv = 1.0 / x
    t = 1.0
    for k in range(a.size):
        term = a[k] * t
        sk += term
        si += term if k % 2 == 0 else -term
        if k % 4 == 0:
            p += term
        elif k % 4 == 1:
            q += term
        elif k % 4 == 2:
            p -= term
        else:
            q -= term
        t *= inv
        if abs(term) < 1e-17:
            break
    return p, q, sk, si


@compiled()
def _bessel_at(v, osc, a, shift):  # pragma: no cover
    """``(J_nu, Y_nu)`` (``osc``) or exponentially scaled ``(I_nu, K_nu)`` at ``v >=
    _ASYMPTOTIC_X`` from the Hankel expansion with coefficients ``a`` of order ``nu``
    (``shift = (2 nu + 1) pi / 4``)."""
    p, q, sk, si = _hankel_pq(v, a)
    if osc:
        amp = math.sqrt(2.0 / (math.pi * v))
        w = v - shift
        cw, sw = math.cos(w), math.sin(w)
        return amp * (p * cw - q * sw), amp * (p * sw + q * cw)
    return si / math.sqrt(2.0 * math.pi * v), sk * math.sqrt(0.5 * math.pi / v)


@compiled(parallel=True)
def _bessel_large(x, osc, a0, a1, b0, b1, c0, c1, xmin):  # pragma: no cover
    """Bessel values where ``x >= xmin`` (others untouched): ``osc`` True:
    ``J0, Y0, J1, Y1`` into ``b0, c0, b1, c1``... see :func:`_bessel`."""
    m, n = x.shape
    for r in numba.prange(m):
        for j in range(n):
            v = x[r, j]
            if v < xmin:
                continue
            b0[r, j], c0[r, j] = _bessel_at(v, osc[r], a0, 0.25 * math.pi)
            b1[r, j], c1[r, j] = _bessel_at(v, osc[r], a1, 0.75 * math.pi)


def _bessel_small(x, osc):
    """``(f0, g0, f1, g1)`` of :func:`_bessel` by scipy (for ``x < _ASYMPTOTIC_X``)."""
    import scipy.special as sp  # imported on use: a render from cached gains needs none

    if osc:
        return sp.j0(x), sp.y0(x), sp.j1(x), sp.y1(x)
    return sp.i0e(x), sp.k0e(x), sp.i1e(x), sp.k1e(x)


def _bessel(x, osc):
    """``(f0, g0, f1, g1)`` at ``x`` (rows): ``J0, Y0, J1, Y1`` for rows ``osc``,
    exponentially scaled ``I0, K0, I1, K1`` for the others."""
    f0 = np.empty_like(x)
    g0 = np.empty_like(x)
    f1 = np.empty_like(x)
    g1 = np.empty_like(x)
    _bessel_large(x, osc, _A0, _A1, f0, f1, g0, g1, _ASYMPTOTIC_X)
    small = x < _ASYMPTOTIC_X
    for kind in (True, False):
        sel = small & (osc[:, None] == kind)
        if sel.any():
            f0[sel], g0[sel], f1[sel], g1[sel] = _bessel_small(x[sel], kind)
    return f0, g0, f1, g1


@compiled()
def _small_arguments(k, rho, xmin):  # pragma: no cover
    """The arguments ``k[r] rho[j] < xmin`` (``rho`` ascending: a first run of nodes per
    row), row after row, and where each row's run starts (``starts[r] : starts[r + 1]``)."""
    m = k.size
    starts = np.zeros(m + 1, dtype=np.int64)
    for r in range(m):
        c = 0
        while c < rho.size and k[r] * rho[c] < xmin:
            c += 1
        starts[r + 1] = starts[r] + c
    x = np.empty(starts[m])
    for r in range(m):
        for c in range(starts[r + 1] - starts[r]):
            x[starts[r] + c] = k[r] * rho[c]
    return x, starts


@compiled()
def _cumulate(sflat, off, vals, out):  # pragma: no cover
    """``out[a] = sum_b S[a, b] vals[b]``: cumulative integrals inside one panel."""
    p = vals.size
    for a in range(p):
        acc = 0.0j
        row = off + a * p
        for b in range(p):
            acc += sflat[row + b] * vals[b]
        out[a] = acc


@compiled()
def _parts(x, s, so, h, n, ce, scale, interior, edge):  # pragma: no cover
    """Interior and edge parts ``(u, e)`` of a trial factor (normalised, see
    :func:`synth.sound.asymptotic_modes.factor_parts`) at ``x`` in ``[-h, h]``; a part
    not asked for (``interior``, ``edge`` False) is 0."""
    u = scale * interior_part(x, s, h, n) if interior else 0.0
    e = scale * ce * edge_part(x, s, so, h, n) if edge else 0.0
    return u, e


@compiled()
def _slopes(x, s, so, h, n, ce, scale):  # pragma: no cover
    """Derivatives ``(u', e')`` (per unit of ``x``) of the parts of :func:`_parts`."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    if s > 0.0:
        k = math.sqrt(s)
        du = math.cos(k * x) if odd else -k * math.sin(k * x)
    elif s < 0.0:
        k = math.sqrt(-s)
        du = math.cosh(k * x) if odd else k * math.sinh(k * x)
    else:
        du = 1.0 if odd else 0.0
    if m2 > 0.0:
        mu = math.sqrt(m2)
        d1 = math.exp(-mu * (h - x))
        d2 = math.exp(-mu * (h + x))
        den = 1.0 + math.exp(-2.0 * mu * h) * (-1.0 if odd else 1.0)
        if odd:
            de = mu * (d1 + d2) / den if den > 0.0 else 1.0 / h
        else:
            de = mu * (d1 - d2) / den
    elif m2 < 0.0:
        mu = math.sqrt(-m2)
        if odd:
            de = mu * math.cos(mu * x) / math.sin(mu * h)
        else:
            de = -mu * math.sin(mu * x) / math.cos(mu * h)
    else:
        de = 1.0 / h if odd else 0.0
    return scale * du, scale * ce * de


@compiled()
def _decaying_tables(
    kap, f0, g0, g, rho, starts, lo, hi, on_edge, etab, eoff, ekap, va, vb, oa, ob, ca, cb
):  # pragma: no cover
    """The radial integrals of a decaying row (``q^2 = -kap^2``) at the nodes of the
    panels ``on_edge``: ``ca = Int_0^rho exp(-kap (rho - t)) i0e(kap t) G t dt`` and
    ``cb = Int_rho^R1 exp(-kap (t - rho)) k0e(kap t) G t dt`` (``f0 = i0e``, ``g0 = k0e``,
    ``g = G t`` times the Jacobian). Panel ``i`` takes the product weights ``etab[eoff[i]
    :]`` (:func:`decay_weights`, ``(p + 1) x p``) of the rate ``ekap[i] <= kap`` (1/m)
    and carries ``exp((kap - ekap[i]) (t - lo))`` in its values (``ekap[i] = 0``: the
    whole exponential, on a short or substituted panel)."""
    n_panels = lo.size
    last = -1
    for i in range(n_panels):
        if on_edge[i]:
            last = i
    # forward, to the last panel with boundary nodes
    base = 0.0j
    for i in range(last + 1):
        s0 = starts[i]
        p = starts[i + 1] - s0
        rest = kap - ekap[i]
        off = eoff[i]
        for a in range(p):
            j = s0 + a
            va[a] = f0[j] * g[j] * math.exp(rest * (rho[j] - lo[i]))
        tot = 0.0j
        row = off + p * p
        for b in range(p):
            tot += etab[row + b] * va[b]
        if on_edge[i]:
            _cumulate(etab, off, va[:p], oa)
            for a in range(p):
                j = s0 + a
                ca[j] = base * math.exp(-kap * (rho[j] - lo[i]))
                ca[j] += oa[a] * math.exp(-rest * (rho[j] - lo[i]))
        base = base * math.exp(-kap * (hi[i] - lo[i])) + tot * math.exp(-rest * (hi[i] - lo[i]))
    # backward from the tail's end: mirrored weights (the nodes are symmetric)
    base = 0.0j
    for i in range(n_panels - 1, -1, -1):
        s0 = starts[i]
        p = starts[i + 1] - s0
        rest = kap - ekap[i]
        off = eoff[i]
        for a in range(p):
            j = s0 + p - 1 - a  # mirrored order
            vb[a] = g0[j] * g[j] * math.exp(rest * (hi[i] - rho[j]))
        tot = 0.0j
        row = off + p * p
        for b in range(p):
            tot += etab[row + b] * vb[b]
        if on_edge[i]:
            _cumulate(etab, off, vb[:p], ob)
            for a in range(p):
                j = s0 + p - 1 - a
                cb[j] = base * math.exp(-kap * (hi[i] - rho[j]))
                cb[j] += ob[a] * math.exp(-rest * (hi[i] - rho[j]))
        base = base * math.exp(-kap * (hi[i] - lo[i])) + tot * math.exp(-rest * (hi[i] - lo[i]))


@compiled()
def _row_tables(
    g,
    rho,
    gw,
    starts,
    lo,
    hi,
    on_edge,
    sflat,
    soff,
    etab,
    eoff,
    ekap,
    q2,
    small_x,
    small_at,
    small,
    a0,
    a1,
    f,
    df,
):  # pragma: no cover
    """``F`` and ``F'`` (module notes) of one row's Helmholtz part ``q2`` (1/m^2) into
    ``f``, ``df`` at the nodes of the panels ``on_edge`` (the others are left untouched:
    only their totals enter); ``g = G t`` times the Jacobian at the nodes. Bessel values
    from the Hankel expansions, below ``small_x`` from ``small`` (rows ``f0, g0, f1,
    g1``, this row's from ``small_at``); for a decaying part the product weights of each
    panel (:func:`_decaying_tables`)."""
    n = rho.size
    n_panels = lo.size
    p_max = 0
    last = -1
    for i in range(n_panels):
        p_max = max(p_max, starts[i + 1] - starts[i])
        if on_edge[i]:
            last = i
    f0 = np.empty(n)
    g0 = np.empty(n)
    ca = np.empty(n, dtype=np.complex128)
    cb = np.empty(n, dtype=np.complex128)
    va = np.empty(p_max, dtype=np.complex128)
    vb = np.empty(p_max, dtype=np.complex128)
    oa = np.empty(p_max, dtype=np.complex128)
    ob = np.empty(p_max, dtype=np.complex128)
    osc = q2 > 0.0
    kap = math.sqrt(abs(q2))
    # an oscillating part's integrals run forward only: to the last boundary node
    n_used = starts[last + 1] if osc else n
    for j in range(n_used):
        x = kap * rho[j]
        if x < small_x:
            f0[j] = small[0, small_at + j]
            g0[j] = small[1, small_at + j]
        else:
            f0[j], g0[j] = _bessel_at(x, osc, a0, 0.25 * math.pi)
    if osc:
        # (pi / 2) [Y0 Int_0^rho J0 G t dt - J0 Int_0^rho Y0 G t dt]
        base_a = 0.0j
        base_b = 0.0j
        for i in range(last + 1):
            s0, s1 = starts[i], starts[i + 1]
            p = s1 - s0
            tot_a = 0.0j
            tot_b = 0.0j
            for a in range(p):
                j = s0 + a
                va[a] = f0[j] * g[j]
                vb[a] = g0[j] * g[j]
                tot_a += gw[j] * va[a]
                tot_b += gw[j] * vb[a]
            if on_edge[i]:
                _cumulate(sflat, soff[i], va[:p], oa)
                _cumulate(sflat, soff[i], vb[:p], ob)
                for a in range(p):
                    ca[s0 + a] = base_a + oa[a]
                    cb[s0 + a] = base_b + ob[a]
            base_a += tot_a
            base_b += tot_b
    else:
        _decaying_tables(
            kap, f0, g0, g, rho, starts, lo, hi, on_edge, etab, eoff, ekap, va, vb, oa, ob, ca, cb
        )
    for i in range(last + 1):
        if not on_edge[i]:
            continue
        for j in range(starts[i], starts[i + 1]):
            x = kap * rho[j]
            if x < small_x:
                f1 = small[2, small_at + j]
                g1 = small[3, small_at + j]
            else:
                f1, g1 = _bessel_at(x, osc, a1, 0.75 * math.pi)
            if osc:
                f[j] = 0.5 * math.pi * (g0[j] * ca[j] - f0[j] * cb[j])
                df[j] = 0.5 * math.pi * kap * (-g1 * ca[j] + f1 * cb[j])
            else:
                f[j] = -(f0[j] * cb[j] + g0[j] * ca[j])
                df[j] = -kap * (f1 * cb[j] - g1 * ca[j])


@compiled(parallel=True)
def _row_integrals(
    rho,
    rbig,
    jac,
    gw,
    starts,
    lo,
    hi,
    on_edge,
    sflat,
    soff,
    etab,
    eoff,
    ekap,
    q2,
    sigma,
    r0,
    small_x,
    small_starts,
    small,
    a0,
    a1,
    edge_axis,
    edge_high,
    edge_d,
    edge_start,
    edge_idx,
    edge_pos,
    edge_w,
    sx,
    sy,
    nx,
    ny,
    hx,
    hy,
    cx,
    gx,
    cy,
    gy,
    big,
    a,
    b,
    out,
):  # pragma: no cover
    """``out[r] = Oint (psi dF/dn - F dpsi/dn) ds`` summed over the three Helmholtz parts
    of each row's trial product (``part`` 0: interior x interior, 1: interior x edge and
    edge x interior, 2: edge x edge; ``q2[part, r]``), their ``F`` (:func:`_row_tables`)
    at the boundary nodes; the trial's parts at a boundary node evaluated once for the
    three. ``etab``, ``eoff[part]``, ``ekap[part]``, ``small_starts[part]``,
    ``small[part]``: each part's product weights and small-argument Bessel values."""
    m = out.size
    n = rho.size
    for r in numba.prange(m):
        g = np.empty(n, dtype=np.complex128)
        for j in range(n):
            g[j] = np.exp(-sigma[r] * (rbig[j] - r0)) / rbig[j] * rho[j] * jac[j]
        f = np.empty((3, n), dtype=np.complex128)
        df = np.empty((3, n), dtype=np.complex128)
        for part in range(3):
            _row_tables(
                g,
                rho,
                gw,
                starts,
                lo,
                hi,
                on_edge,
                sflat,
                soff,
                etab,
                eoff[part, r],
                ekap[part, r],
                q2[part, r],
                small_x,
                small_starts[part, r],
                small[part],
                a0,
                a1,
                f[part],
                df[part],
            )
        acc = 0.0j
        for e in range(edge_axis.size):
            sign = 1.0 if edge_high[e] else -1.0
            d = edge_d[e]
            if edge_axis[e] == 0:  # x = const, along y
                xe = ((a if edge_high[e] else 0.0) - 0.5 * a) / big
                au, ae = _parts(xe, sx[r], sy[r], hx, nx[r], cx[r], gx[r], True, True)
                du, de = _slopes(xe, sx[r], sy[r], hx, nx[r], cx[r], gx[r])
            else:
                xe = ((b if edge_high[e] else 0.0) - 0.5 * b) / big
                au, ae = _parts(xe, sy[r], sx[r], hy, ny[r], cy[r], gy[r], True, True)
                du, de = _slopes(xe, sy[r], sx[r], hy, ny[r], cy[r], gy[r])
            du *= sign / big
            de *= sign / big
            for jj in range(edge_start[e], edge_start[e + 1]):
                j = edge_idx[jj]
                if edge_axis[e] == 0:
                    t = (edge_pos[jj] - 0.5 * b) / big
                    vu, ve = _parts(t, sy[r], sx[r], hy, ny[r], cy[r], gy[r], True, True)
                else:
                    t = (edge_pos[jj] - 0.5 * a) / big
                    vu, ve = _parts(t, sx[r], sy[r], hx, nx[r], cx[r], gx[r], True, True)
                geo = d / rho[j]
                val = au * vu * df[0, j] * geo - du * vu * f[0, j]
                val += (au * ve + ae * vu) * df[1, j] * geo - (du * ve + de * vu) * f[1, j]
                val += ae * ve * df[2, j] * geo - de * ve * f[2, j]
                acc += edge_w[jj] * val
        out[r] += acc


def _small_bessel(k, rho, osc, on_node):
    """Bessel values (rows ``f0, g0, f1, g1`` of :func:`_bessel`) at the arguments
    ``k[r] rho[j] < _ASYMPTOTIC_X`` (:func:`_small_arguments`; ``f1, g1`` only at the
    nodes ``on_node``, the others 0) and where each row's start."""
    import scipy.special as sp

    x, starts = _small_arguments(k, rho, _ASYMPTOTIC_X)
    out = np.zeros((4, x.size))
    if osc:
        out[0], out[1] = sp.j0(x), sp.y0(x)
    else:
        out[0], out[1] = sp.i0e(x), sp.k0e(x)
    node = np.arange(x.size) - np.repeat(starts[:-1], np.diff(starts))
    sel = on_node[node]
    if sel.any():
        out[2][sel], out[3][sel] = _bessel_small(x[sel], osc)[2:]
    return starts, out


def _decay_tables(grid, kappa):
    """Product weights of each decay rate ``kappa`` (1/m, any shape; 0 for an oscillating
    row) on each panel of ``grid`` (:func:`_decaying_tables`): the weights of the
    exponent ``c0`` on the ladder ``_DECAY_LADDER`` at or below the panel's ``c = kappa h
    / 2`` (``c0 = 0`` below ``_DECAY_MIN_C`` and on substituted panels), flattened; the
    offsets into them and the rates ``2 c0 / h`` (shape of ``kappa`` x panels)."""
    h = grid.hi - grid.lo
    c = 0.5 * kappa[..., None] * h
    exact = (c >= _DECAY_MIN_C) & (grid.kinds == 0)[None, :]
    with np.errstate(divide="ignore"):
        step = np.where(exact, np.floor(np.log(c) / math.log(_DECAY_LADDER)), 0.0).astype(np.int64)
    step -= exact & (_DECAY_LADDER ** step.astype(float) > c)  # rounding: c0 <= c
    c0 = np.where(exact, _DECAY_LADDER ** step.astype(float), 0.0)
    step = np.where(exact, step + 1 - _SENTINEL, 0)  # 0: c0 = 0, else step + 1 - sentinel
    key = step * (4 * MAX_ORDER * MAX_ORDER) + grid.orders  # orders below 4 MAX_ORDER^2
    keys, inverse = np.unique(key.ravel(), return_inverse=True)
    blocks, offsets, at = [], [], 0
    for k in keys:
        p, n = k % (4 * MAX_ORDER * MAX_ORDER), k // (4 * MAX_ORDER * MAX_ORDER)
        rung = _DECAY_LADDER ** float(n - 1 + _SENTINEL) if n > 0 else 0.0
        blocks.append(decay_weights(int(p), rung).ravel())
        offsets.append(at)
        at += blocks[-1].size
    eoff = np.asarray(offsets, dtype=np.int64)[inverse.ravel()].reshape(c.shape)
    return np.concatenate(blocks), eoff, 2.0 * c0 / h


def _entry_integrals(grid, sol, trials, sigma, r0, size, big):
    """``Int X_t Y_t exp(-sigma (R - r0)) / R dA`` for rows ``(trial t, sigma)``: the
    three Helmholtz parts (interior x interior, mixed, edge x edge) on one grid."""
    a, b = size
    hx, hy = sol.half
    (cx, gx), (cy, gy) = sol.factor_constants()
    sx, sy = sol.sx[trials], sol.sy[trials]
    omega = (sx + sy) / (big * big)
    q2 = np.stack((omega, -omega, -3.0 * omega))
    small = [
        _small_bessel(np.sqrt(np.abs(q2[part])), grid.rho, part == 0, grid.on_node)
        for part in range(3)
    ]
    width = max(t[1].shape[1] for t in small)
    small_values = np.zeros((3, 4, width))
    for part, (_, values) in enumerate(small):
        small_values[part, :, : values.shape[1]] = values
    small_starts = np.stack([t[0][:-1] for t in small])
    etab, eoff, ekap = _decay_tables(grid, np.sqrt(np.maximum(-q2, 0.0)))
    out = np.zeros(trials.size, dtype=complex)
    _row_integrals(
        grid.rho,
        grid.r_big,
        grid.jac,
        grid.gw,
        grid.starts,
        grid.lo,
        grid.hi,
        grid.on_edge,
        grid.sflat,
        grid.soff,
        etab,
        eoff,
        ekap,
        q2,
        sigma,
        r0,
        _ASYMPTOTIC_X,
        small_starts,
        small_values,
        _A0,
        _A1,
        *grid.edge_arrays,
        sx,
        sy,
        sol.nx[trials],
        sol.ny[trials],
        hx,
        hy,
        cx[trials],
        gx[trials],
        cy[trials],
        gy[trials],
        big,
        a,
        b,
        out,
    )
    return out


def _rate_steps(rate: np.ndarray) -> np.ndarray:
    """Step of each radial rate (1/m) on the ladder ``_RATE_LADDER ** step``: the
    smallest step at or above it (up to rounding)."""
    return np.ceil(np.log(rate) / math.log(_RATE_LADDER)).astype(np.int64)


def _on_ladder(rate: float) -> float:
    """``rate`` (1/m) rounded up to the ladder of :func:`_rate_steps` (0 stays 0)."""
    if rate <= 0.0:
        return 0.0
    return max(_RATE_LADDER ** float(_rate_steps(np.array([rate]))[0]), rate)


def _below_ladder(rate: float) -> float:
    """``rate`` (1/m) rounded down to the ladder of :func:`_rate_steps` (0 stays 0)."""
    if rate <= 0.0:
        return 0.0
    return min(_RATE_LADDER ** float(_rate_steps(np.array([rate]))[0] - 1), rate)


def _edge_rate(sol, trials, big) -> float:
    """Largest decay rate (1/m) along an edge of the trials' edge parts,
    ``sqrt(|s + 2 s_o|) / big`` of either factor."""
    sx, sy = sol.sx[trials], sol.sy[trials]
    return float(np.sqrt(np.maximum(np.abs(sx + 2.0 * sy), np.abs(sy + 2.0 * sx)).max()) / big)


def boundary_integrals(sol, modes_index, size, listener, q, r0, refine, tol_panel):
    """``Int phi_k exp(-q_k (R - r0)) / R dA`` of the edge effect modes ``modes_index``
    (indices into ``sol``'s modes), ``q = s / c`` per mode (1/m), on the plate ``size``
    (metres) with the microphone at ``listener``; and the number of radial nodes.

    The terms (one per mode and trial, two for a pair) are taken in groups of similar
    radial rate ``k + |q|`` (:func:`_rate_steps`), each group on radial panels sized for
    the top of its step (or for its edge parts' decay along an edge if faster), with its
    substituted panels at most ``1 / (sqrt(3) k)`` long and the decaying parts' tail,
    each rate rounded to the ladder so that neighbouring groups share panels."""
    a, b = size
    big = max(a, b)
    trial = sol.trial[modes_index]
    partner = sol.partner[modes_index]
    own = sol.own[modes_index]
    other = sol.other[modes_index]
    paired = np.flatnonzero(partner >= 0)
    rows_mode = np.concatenate([np.arange(trial.size), paired])
    rows_trial = np.concatenate([trial, partner[paired]])
    rows_weight = np.concatenate([own, other[paired]])
    k_trial = np.sqrt(np.abs(sol.sx[rows_trial] + sol.sy[rows_trial])) / big
    rate = k_trial + np.abs(q[rows_mode])
    out = np.zeros(trial.size, dtype=complex)
    nodes = 0
    w_max = half_phase(MAX_ORDER, tol_panel)
    grids_made = {}
    step = _rate_steps(rate)
    for level in np.unique(step):
        rows = np.flatnonzero(step == level)
        # the interior x interior part oscillates; the others decay at k and sqrt(3) k
        # (exactly on plain panels) and their edge parts at up to mu along the edges
        k_osc = max(_RATE_LADDER ** float(level), float(rate[rows].max()))
        trials = rows_trial[rows]
        k_dec = max(k_osc, _on_ladder(_edge_rate(sol, trials, big)))
        kappa_max = _on_ladder(math.sqrt(3.0) * float(k_trial[rows].max()))
        kappa_min = _below_ladder(float(k_trial[rows].min()))
        if kappa_min * 2.0 * w_max / k_dec <= 2.0:  # F's layer at the far corner resolved
            kappa_min = 0.0
        key = (k_dec, kappa_max, kappa_min)
        if key not in grids_made:
            grids_made[key] = _Grid(size, listener, *key, tol_panel, refine)
        grid = grids_made[key]
        nodes = max(nodes, grid.rho.size)
        vals = _entry_integrals(
            grid, sol, rows_trial[rows], np.ascontiguousarray(q[rows_mode[rows]]), r0, size, big
        )
        np.add.at(out, rows_mode[rows], rows_weight[rows] * vals)
    return out, nodes


def _inverse_distance_integral(size, listener) -> float:
    """``Int_plate 1 / R dA`` (metres) in closed form: ``x ln(y + R) + y ln(x + R) -
    z atan(x y / (z R))`` is an antiderivative in ``x`` and ``y`` (from the projection)."""
    a, b = size
    xl, yl, z = listener

    def f(x, y):
        r = math.sqrt(x * x + y * y + z * z)
        return x * math.log(y + r) + y * math.log(x + r) - z * math.atan(x * y / (z * r))

    x0, x1, y0, y1 = -xl, a - xl, -yl, b - yl
    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)


#: Largest ``k h`` whose ``cosh`` and ``sinh`` :func:`_factor_bounds` takes directly
#: (``cosh(700) = 5e303``); beyond, its bound is taken in logarithms.
_DIRECT_GROWTH = 700.0


def _factor_bounds(s, so, n, h, ce, scale):
    """Upper bounds of ``|X|`` on ``[-h, h]`` for trial factors (interior part ``cos``,
    ``sin / k``, ``cosh``, ``sinh / k``; edge part at most 1, or ``1 / |cos|``,
    ``1 / |sin|`` of the edge value for an oscillating edge part), times ``|scale|``.

    Each interior bound is evaluated for its own trials only: a growing part's ``cosh(k
    h)`` overflows float64 beyond ``k h = 710`` although the normalised factor, ``scale``
    times it, stays of order ``sqrt(k h)``. Beyond :data:`_DIRECT_GROWTH` that product is
    ``exp(log|scale| + k h - log 2)`` (``/ k`` when odd): ``cosh(k h) = exp(k h) / 2``
    and ``sinh(k h) = exp(k h) / 2`` to a relative ``exp(-2 k h) < 1e-600``. Below it the
    arithmetic is the direct one."""
    odd = n % 2 == 1
    k = np.sqrt(np.abs(s))
    kh = k * h
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(odd, h, 1.0)  # s == 0: x or 1
        osc = s > 0.0
        u[osc] = np.where(odd[osc], np.minimum(h, 1.0 / k[osc]), 1.0)
        grow = s < 0.0
        direct = grow & (kh <= _DIRECT_GROWTH)
        u[direct] = np.where(odd[direct], np.sinh(kh[direct]) / k[direct], np.cosh(kh[direct]))
        m2 = s + 2.0 * so
        mu = np.sqrt(np.abs(m2))
        e_osc = 1.0 / np.abs(np.where(odd, np.sin(mu * h), np.cos(mu * h)))
        e = np.where(m2 < 0.0, e_osc, 1.0)
        bound = np.abs(scale) * (u + np.abs(ce) * e)
        far = grow & (kh > _DIRECT_GROWTH)
        if far.any():
            log_u = kh[far] - math.log(2.0) - np.where(odd[far], np.log(k[far]), 0.0)
            weight = np.abs(scale[far])
            bound[far] = np.exp(np.log(weight) + log_u) + weight * np.abs(ce[far]) * e[far]
    return bound


def in_phase_bounds(sol, modes_index, size, listener) -> np.ndarray:
    """``max|phi_k| Int 1 / R dA`` (metres) of edge effect modes: upper bounds of
    ``Int |phi_k| / R dA`` (``S_k`` of :mod:`synth.sound.radiation.refinement` over
    ``rho |s_k| / (2 pi)``), ``|phi_k| <= |own| |X_t| |Y_t| + |other| |X_u| |Y_u|``."""
    (cx, gx), (cy, gy) = sol.factor_constants()
    hx, hy = sol.half
    bx = _factor_bounds(sol.sx, sol.sy, sol.nx, hx, cx, gx)
    by = _factor_bounds(sol.sy, sol.sx, sol.ny, hy, cy, gy)
    trial = sol.trial[modes_index]
    partner = sol.partner[modes_index]
    peak = np.abs(sol.own[modes_index]) * bx[trial] * by[trial]
    paired = partner >= 0
    peak[paired] += np.abs(sol.other[modes_index][paired]) * (
        bx[partner[paired]] * by[partner[paired]]
    )
    return peak * _inverse_distance_integral(size, listener)


def nearest_distance(size, listener) -> float:
    """Distance (m) from the microphone to the nearest point of the plate."""
    a, b = size
    xl, yl, z = listener
    dx = max(0.0, -xl, xl - a)
    dy = max(0.0, -yl, yl - b)
    return math.sqrt(dx * dx + dy * dy + z * z)


def boundary_rule(
    part,
    n_modes,
    size,
    listener,
    s,
    *,
    air_density,
    sound_speed,
    reference_distance,
    tol,
    max_points,
) -> RadiationResult:
    """Gains ``H_k(s_k)`` (times ``exp(s_k R0 / c)`` if ``reference_distance`` ``R0`` is
    given) of the edge effect modes ``part.first_mode <= k < n_modes`` by the boundary
    rule (module notes), with the tolerance, error estimate and convergence test of
    :mod:`synth.sound.radiation.refinement` (successive rules with 1.25 times the radial
    points, a passing mode keeping its gain). ``S_k`` is the bound of
    :func:`in_phase_bounds`. ``s`` one pole per edge effect mode (rad/s)."""
    sol = part.solution
    index = part.offset + np.arange(n_modes - part.first_mode)
    rho, c = air_density, sound_speed
    q = s / c
    r_ref = nearest_distance(size, listener)
    shift = r_ref - (0.0 if reference_distance is None else reference_distance)
    factor = rho * s / (2.0 * math.pi) * np.exp(-q * shift)
    scale = rho * np.abs(s) / (2.0 * math.pi)
    bounds = in_phase_bounds(sol, index, size, listener)
    tol_panel = 0.1 * tol
    nodes = {}

    def rule(level, active):
        integrals, n = boundary_integrals(
            sol, index[active], size, listener, q[active], r_ref, REFINE**level, tol_panel
        )
        nodes[level] = n
        return integrals, bounds[active]

    def npoints(level):
        # a rule not yet applied: its orders, hence its nodes, grow as REFINE per level
        if level in nodes:
            return nodes[level]
        known = max(nodes)
        return int(nodes[known] * REFINE ** (level - known))

    return refine_selective(rule, npoints, factor, scale, tol, max_points, (0, 0))
