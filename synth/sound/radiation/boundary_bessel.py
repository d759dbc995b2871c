"""Bessel functions of the boundary rule's radial solutions (numba kernels): ``J0`` and
``Y0`` by their power series for small arguments and Hankel's asymptotic expansion for
large ones, and the modified functions of the decaying terms.
"""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled

#: Arguments above which the Bessel functions are summed from their Hankel expansions
#: (summed until a term is below 1e-17: the expansions' smallest term is about exp(-2 x); A & S
#: 9.2.5-9.2.10, 9.7.1-9.7.2).
ASYMPTOTIC_X = 20.0


_TERMS = 40


def _hankel_coefficients(nu: int) -> np.ndarray:
    """``a_k(nu) = prod_{j=1..k} (4 nu^2 - (2j - 1)^2) / (k! 8^k)``, ``k < _TERMS``."""
    a = np.ones(_TERMS)
    for k in range(1, _TERMS):
        a[k] = a[k - 1] * (4.0 * nu * nu - (2 * k - 1) ** 2) / (8.0 * k)
    return a


A0 = _hankel_coefficients(0)


A1 = _hankel_coefficients(1)


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
def bessel_at(v, osc, a, shift):  # pragma: no cover
    """``(J_nu, Y_nu)`` (``osc``) or exponentially scaled ``(I_nu, K_nu)`` at ``v >=
    ASYMPTOTIC_X`` from the Hankel expansion with coefficients ``a`` of order ``nu``
    (``shift = (2 nu + 1) pi / 4``)."""
    p, q, sk, si = _hankel_pq(v, a)
    if osc:
        amp = math.sqrt(2.0 / (math.pi * v))
        w = v - shift
        cw, sw = math.cos(w), math.sin(w)
        return amp * (p * cw - q * sw), amp * (p * sw + q * cw)
    return si / math.sqrt(2.0 * math.pi * v), sk * math.sqrt(0.5 * math.pi / v)


def _bessel_small(x, osc):
    """``(f0, g0, f1, g1)`` at ``x < ASYMPTOTIC_X`` by scipy: ``J0, Y0, J1, Y1`` where
    ``osc``, else the exponentially scaled ``I0, K0, I1, K1``."""
    import scipy.special as sp  # imported on use: a render from cached gains needs none

    if osc:
        return sp.j0(x), sp.y0(x), sp.j1(x), sp.y1(x)
    return sp.i0e(x), sp.k0e(x), sp.i1e(x), sp.k1e(x)


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


def small_bessel(k, rho, osc, on_node):
    """Bessel values (rows ``f0, g0, f1, g1`` of :func:`_bessel_small`) at the arguments
    ``k[r] rho[j] < ASYMPTOTIC_X`` (:func:`_small_arguments`; ``f1, g1`` only at the
    nodes ``on_node``, the others 0) and where each row's start."""
    import scipy.special as sp

    x, starts = _small_arguments(k, rho, ASYMPTOTIC_X)
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
