"""The Rayleigh-Ritz step on the edge effect shapes (numba kernels): near-degenerate pairs,
the factors' moments in closed form, and each pair's 2 x 2 problem."""

from __future__ import annotations

import cmath
import math

import numpy as np

from synth.compilation import compiled


def near_pairs(omega: np.ndarray, cls: np.ndarray, gap: float) -> np.ndarray:
    """``partner[t]`` (-1 if none): in ascending ``omega``, each unpaired trial takes the next
    unpaired one of its symmetry class ``cls`` within the relative ``gap``."""
    partner = np.full(omega.size, -1, dtype=np.int64)
    for c in np.unique(cls):
        idx = np.flatnonzero(cls == c)
        w = omega[idx]
        i = 0
        while i + 1 < idx.size:
            if partner[idx[i]] < 0 and w[i + 1] - w[i] <= gap * w[i]:
                partner[idx[i]], partner[idx[i + 1]] = idx[i + 1], idx[i]
                i += 2
            else:
                i += 1
    return partner


@compiled()
def factor_exponentials(s, so, h, n, ce, scale, coef, rate, shift):  # noqa: PLR0913  # pragma: no cover
    """A factor ``scale (u + ce e)`` as ``sum_t coef[t] exp(rate[t] x + shift[t])``: the number of
    terms (4), 0 for the polynomial cases ``s = 0`` or ``s + 2 so = 0``."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    if s == 0.0 or m2 == 0.0:
        return 0
    # u = cosh(k x) (even) or sinh(k x) / k (odd), k = sqrt(-s): cos(sqrt(s) x) and
    # sin(sqrt(s) x) / sqrt(s) for s > 0
    k = cmath.sqrt(complex(-s))
    coef[0] = 0.5 * scale
    coef[1] = (0.5 if not odd else -0.5) * scale
    if odd:
        coef[0] = coef[0] / k
        coef[1] = coef[1] / k
    rate[0], rate[1] = k, -k
    shift[0], shift[1] = 0.0, 0.0
    if m2 > 0.0:
        m = math.sqrt(m2)
        sign = -1.0 if odd else 1.0
        den = 1.0 + sign * math.exp(-2.0 * m * h)
        coef[2] = scale * ce / den
        coef[3] = sign * scale * ce / den
        rate[2], rate[3] = m, -m
        shift[2], shift[3] = -m * h, -m * h
    else:
        mu = math.sqrt(-m2)
        den = math.sin(mu * h) if odd else math.cos(mu * h)
        c = complex(scale * ce / (2.0 * den))
        if odd:
            c = -1j * c
        coef[2] = c
        coef[3] = -c if odd else c
        rate[2], rate[3] = 1j * mu, -1j * mu
        shift[2], shift[3] = 0.0, 0.0
    return 4


@compiled()
def _span(a, b, h):  # pragma: no cover
    """``Int_{-h}^{h} exp(a x + b) dx`` for complex ``a``, ``b``."""
    z = a * h
    if abs(z) < 1e-3:
        return cmath.exp(b) * 2.0 * h * (1.0 + z * z / 6.0 + z * z * z * z / 120.0)
    return (cmath.exp(b + z) - cmath.exp(b - z)) / a


@compiled()
def factor_moments(c1, a1, b1, c2, a2, b2, h, out):  # pragma: no cover
    """``(Int f g, Int f' g', Int f'' g'', Int f'' g, Int f g'')`` over ``[-h, h]`` of two
    factors in exponential form, in closed form."""
    for i in range(5):
        out[i] = 0.0
    for i in range(4):
        for j in range(4):
            v = c1[i] * c2[j] * _span(a1[i] + a2[j], b1[i] + b2[j], h)
            p = a1[i] * a1[i]
            q = a2[j] * a2[j]
            out[0] += v.real
            out[1] += (a1[i] * a2[j] * v).real
            out[2] += (p * q * v).real
            out[3] += (p * v).real
            out[4] += (q * v).real


@compiled()
def _pair_eigen(kk, mm):  # pragma: no cover
    """Eigenpairs ``(lam, v0, v1)`` of the 2 x 2 ``K v = lam M v``, ascending, ``v^T M v = 1``:
    Cholesky and one Jacobi rotation (orthogonal even for a nearly degenerate pair)."""
    l00 = math.sqrt(mm[0, 0])
    l10 = mm[0, 1] / l00
    l11 = math.sqrt(mm[1, 1] - l10 * l10)
    k01 = 0.5 * (kk[0, 1] + kk[1, 0])
    # C = L^-1 K L^-T
    a00 = kk[0, 0] / l00
    a01 = k01 / l00
    a10 = (k01 - l10 * a00) / l11
    a11 = (kk[1, 1] - l10 * a01) / l11
    c00 = a00 / l00
    c01 = (a01 - l10 * c00) / l11
    c11 = (a11 - l10 * (a10 / l00)) / l11
    if c01 == 0.0:
        t = 0.0
    else:
        tau = (c11 - c00) / (2.0 * c01)
        t = (1.0 if tau >= 0.0 else -1.0) / (abs(tau) + math.sqrt(1.0 + tau * tau))
    cs = 1.0 / math.sqrt(1.0 + t * t)
    sn = t * cs
    lam = np.array([c00 - t * c01, c11 + t * c01])
    q0 = np.array([cs, sn])  # first components of the two eigenvectors of C
    q1 = np.array([-sn, cs])
    if lam[0] > lam[1]:
        lam = lam[::-1].copy()
        q0 = q0[::-1].copy()
        q1 = q1[::-1].copy()
    v1 = q1 / l11
    v0 = (q0 - l10 * v1) / l00
    return lam, v0, v1


@compiled()
def rayleigh_ritz(  # noqa: PLR0913
    sx, sy, nx, ny, hx, hy, free, nu, cx, gx, cy, gy, omega, partner
):  # pragma: no cover
    """``(omega, own, other)`` per trial: a pair solves its 2 x 2 problem, a clamped trial alone
    its Rayleigh quotient, a free one alone keeps its edge effect frequency."""
    n = omega.size
    out = omega.copy()
    own = np.ones(n)
    other = np.zeros(n)
    area = 4.0 * hx * hy
    cf = np.zeros((4, 4), dtype=np.complex128)
    rf = np.zeros((4, 4), dtype=np.complex128)
    bf = np.zeros((4, 4), dtype=np.complex128)
    mx = np.zeros(5)
    my = np.zeros(5)
    kk = np.zeros((2, 2))
    mm = np.zeros((2, 2))
    for t in range(n):
        u = partner[t]
        if u >= 0 and u < t:
            continue  # solved with its partner
        if u < 0 and free:
            continue
        members = (t, u) if u >= 0 else (t, t)
        size = 2 if u >= 0 else 1
        good = True
        for j in range(size):
            r = members[j]
            x, y = 2 * j, 2 * j + 1
            good &= (
                factor_exponentials(sx[r], sy[r], hx, nx[r], cx[r], gx[r], cf[x], rf[x], bf[x]) == 4
            )
            good &= (
                factor_exponentials(sy[r], sx[r], hy, ny[r], cy[r], gy[r], cf[y], rf[y], bf[y]) == 4
            )
        if not good:
            continue
        for i in range(size):
            for j in range(size):
                a, b = 2 * i, 2 * j
                factor_moments(cf[a], rf[a], bf[a], cf[b], rf[b], bf[b], hx, mx)
                factor_moments(
                    cf[a + 1], rf[a + 1], bf[a + 1], cf[b + 1], rf[b + 1], bf[b + 1], hy, my
                )
                mm[i, j] = mx[0] * my[0] / area
                kk[i, j] = (
                    mx[2] * my[0]
                    + mx[0] * my[2]
                    + nu * (mx[3] * my[4] + mx[4] * my[3])
                    + 2.0 * (1.0 - nu) * mx[1] * my[1]
                ) / area
        if size == 1:
            out[t] = math.sqrt(kk[0, 0] / mm[0, 0])
            own[t] = 1.0 / math.sqrt(mm[0, 0])
            continue
        lam, v0, v1 = _pair_eigen(kk, mm)
        for j in range(2):
            slot = members[j]
            out[slot] = math.sqrt(lam[j])
            if j == 0:  # the lower root stays with the lower trial
                own[slot], other[slot] = v0[j], v1[j]
            else:
                own[slot], other[slot] = v1[j], v0[j]
    return out, own, other
