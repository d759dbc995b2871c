"""The edge effect shapes' factors ``X(x)``, ``Y(y)``: interior and edge parts, edge
coefficients, normalisation and the tables the shapes are gathered from (numba kernels)."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics.asymptotic_modes.ritz import factor_exponentials, factor_moments
from synth.physics.asymptotic_modes.roots import edge_terms, entire_terms

#: 8-point Gauss-Legendre nodes and weights on [-1, 1], for :func:`_norm`.
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(8)


@compiled()
def _coefficients(s, so, h, n, free, nu):  # pragma: no cover
    """``c_edge`` of ``u(x) + c_edge e(x)`` from the better-conditioned edge condition."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    c, ks, sk = entire_terms(s, h)
    mt, tm = edge_terms(m2, h)
    if free:
        p = s + nu * so
        q = s + (2.0 - nu) * so
        if not odd:
            # M: -P c + C Q = 0 (e(h) = 1); V: Q ks' + C P mu tanh = 0
            if abs(q) >= abs(p * mt) * 1e-3:
                ce = p * c / q
            else:
                ce = -q * ks / (p * mt)
        else:
            # M: -P sk... u = sin(kx)/k: u(h) = sk, u''(h) = -s sk; e(h) = 1, e'' = m2
            # M: u'' - nu so u + C (m2 - nu so) = -(s + nu so) sk + C q = 0
            if abs(q) >= 1e-3 * abs(p):
                ce = p * sk / q
            else:
                # V: u''' - (2-nu) so u' + C (mu^3 coth - (2-nu) so mu coth) = 0
                # u' = c, u''' = -s c: -(s + (2-nu) so) c + C P / tm = 0
                ce = q * c * tm / p
    else:
        ce = -(sk if odd else c)
    return ce


@compiled()
def interior_part(x, s, h, n):  # pragma: no cover
    """Interior part ``u`` of a factor at ``x``: ``cos``, ``sin / k`` (``cosh``, ``sinh / k``)."""
    odd = n % 2 == 1
    if s > 0.0:
        k = math.sqrt(s)
        return math.sin(k * x) / k if odd else math.cos(k * x)
    if s < 0.0:
        k = math.sqrt(-s)
        return math.sinh(k * x) / k if odd else math.cosh(k * x)
    return x if odd else 1.0


@compiled()
def edge_part(x, s, so, h, n):  # pragma: no cover
    """Edge part ``e`` of a factor at ``x``: ``cosh(mu x) / cosh(mu h)`` or ``sinh(mu x) / sinh(mu
    h)``, ``mu^2 = s + 2 so`` (``cos``, ``sin`` for ``mu^2 < 0``), 1 at ``x = h``."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    if m2 > 0.0:
        m = math.sqrt(m2)
        # cosh(m x) / cosh(m h) and sinh(m x) / sinh(m h) without overflow
        d1 = math.exp(-m * (h - x))
        d2 = math.exp(-m * (h + x))
        den = 1.0 + math.exp(-2.0 * m * h) * (-1.0 if odd else 1.0)
        if odd:
            return (d1 - d2) / den if den > 0.0 else x / h
        return (d1 + d2) / den
    if m2 < 0.0:
        m = math.sqrt(-m2)
        return math.sin(m * x) / math.sin(m * h) if odd else math.cos(m * x) / math.cos(m * h)
    return x / h if odd else 1.0


@compiled()
def _factor(x, s, so, h, n, ce):  # pragma: no cover
    """A factor's value ``u + ce e`` at ``x`` (unnormalised)."""
    return interior_part(x, s, h, n) + ce * edge_part(x, s, so, h, n)


@compiled()
def _norm(s, so, h, n, ce):  # pragma: no cover
    """Root mean square of a factor over ``[-h, h]`` (Gauss-Legendre panels)."""
    k = math.sqrt(abs(s)) + math.sqrt(abs(s + 2.0 * so)) + 1.0 / h
    panels = int(k * h / 2.0) + 2
    t, w = _GAUSS_NODES, _GAUSS_WEIGHTS
    total = 0.0
    half = h / panels
    for p in range(panels):
        mid = -h + (2 * p + 1) * half
        for i in range(8):
            v = _factor(mid + half * t[i], s, so, h, n, ce)
            total += w[i] * half * v * v
    return math.sqrt(total / (2.0 * h))


@compiled()
def factor_edge_constants(s, so, n, h, free, nu):  # pragma: no cover
    """Edge coefficient and ``1 / rms`` of every factor (the mean square in closed form, or by
    :func:`_norm` for the measure-zero polynomial cases)."""
    ce = np.empty(s.size)
    scale = np.empty(s.size)
    coef = np.zeros(4, dtype=np.complex128)
    rate = np.zeros(4, dtype=np.complex128)
    shift = np.zeros(4, dtype=np.complex128)
    mom = np.zeros(5)
    for k in range(s.size):
        ce[k] = _coefficients(s[k], so[k], h, n[k], free, nu)
        if factor_exponentials(s[k], so[k], h, n[k], ce[k], 1.0, coef, rate, shift) == 4:
            factor_moments(coef, rate, shift, coef, rate, shift, h, mom)
            mean_square = mom[0] / (2.0 * h)
            if mean_square > 0.0 and math.isfinite(mean_square):
                scale[k] = 1.0 / math.sqrt(mean_square)
                continue
        scale[k] = 1.0 / _norm(s[k], so[k], h, n[k], ce[k])
    return ce, scale


@compiled()
def factor_table(x, s, so, n, h, ce, scale):  # pragma: no cover
    """``out[p, k]``: factor ``k`` (normalised) at ``x[p]`` in ``[-h, h]``."""
    out = np.empty((x.size, s.size))
    for p in range(x.size):
        for k in range(s.size):
            out[p, k] = scale[k] * _factor(x[p], s[k], so[k], h, n[k], ce[k])
    return out


@compiled()
def gather_modes(fx, fy, ix, iy, trial, partner, own, other, out, column):  # noqa: PLR0913  # pragma: no cover
    """``out[p, column + k] = own[k] X_t Y_t + other[k] X_u Y_u`` at point ``p``."""
    m = trial.size
    gx = np.zeros((fx.shape[0], m))
    hx = np.zeros((fx.shape[0], m))
    gy = np.zeros((fy.shape[0], m))
    hy = np.zeros((fy.shape[0], m))
    paired = False
    for k in range(m):
        paired = paired or partner[k] >= 0
    for a in range(fx.shape[0]):
        for k in range(m):
            gx[a, k] = own[k] * fx[a, trial[k]]
            if partner[k] >= 0:
                hx[a, k] = other[k] * fx[a, partner[k]]
    for b in range(fy.shape[0]):
        for k in range(m):
            gy[b, k] = fy[b, trial[k]]
            if partner[k] >= 0:
                hy[b, k] = fy[b, partner[k]]
    for p in range(ix.size):
        ga, ha = gx[ix[p]], hx[ix[p]]
        gb, hb = gy[iy[p]], hy[iy[p]]
        row = out[p, column : column + m]
        if paired:
            for k in range(m):
                row[k] = ga[k] * gb[k] + ha[k] * hb[k]
        else:
            for k in range(m):
                row[k] = ga[k] * gb[k]
