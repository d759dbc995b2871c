"""The edge effect method's one-dimensional equations (numba kernels): the characteristic
function of each edge condition and symmetry, its ``N``-th root, and the alternation of the
two directions' equations for every index pair."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled

#: Alternations of the two one-dimensional equations (each a contraction; the
#: frequencies stop changing to 1e-13 relative after about 8 for every tested plate).
_ALTERNATIONS = 30


_BISECTIONS = 100


@compiled()
def entire_terms(s, h):  # pragma: no cover
    """``(cos(k h), k sin(k h), sin(k h) / k)``, ``k = sqrt(s)``, entire in ``s``."""
    if s > 0.0:
        k = math.sqrt(s)
        c, sn = math.cos(k * h), math.sin(k * h)
        return c, k * sn, sn / k
    if s < 0.0:
        k = math.sqrt(-s)
        c, sn = math.cosh(k * h), math.sinh(k * h)
        return c, -k * sn, sn / k
    return 1.0, 0.0, h


@compiled()
def edge_terms(m2, h):  # pragma: no cover
    """``(mu tanh(mu h), tanh(mu h) / mu)``, ``mu = sqrt(m2)``, entire in ``m2``."""
    if m2 > 0.0:
        m = math.sqrt(m2)
        t = math.tanh(m * h)
        return m * t, t / m
    if m2 < 0.0:
        m = math.sqrt(-m2)
        t = math.tan(m * h)
        return -m * t, t / m
    return 0.0, h


@compiled()
def _characteristic(s, so, h, free, odd, nu):  # pragma: no cover
    """The 1-D characteristic function at ``s_x = s`` for ``s_y = so``, half-length ``h``."""
    c, ks, sk = entire_terms(s, h)
    mt, tm = edge_terms(s + 2.0 * so, h)
    if free:
        p = s + nu * so
        q = s + (2.0 - nu) * so
        if odd:
            return -p * p * sk + q * q * c * tm
        return q * q * ks + p * p * c * mt
    if odd:
        return sk - c * tm
    return ks + c * mt


@compiled()
def _illinois(lo, hi, flo, fhi, so, h, free, odd, nu, squared):  # noqa: PLR0913  # pragma: no cover
    """Root of the characteristic function in ``[lo, hi]`` (values of opposite signs) by
    Illinois' regula falsi; ``squared``: the variable is ``k``, ``s = k^2``."""
    side = 0
    for _ in range(_BISECTIONS):
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < x < hi):
            x = 0.5 * (lo + hi)
        fx = _characteristic(x * x if squared else x, so, h, free, odd, nu)
        if fx == 0.0 or hi - lo <= 4e-16 * max(abs(lo), abs(hi)):
            return x
        if (fx > 0.0) == (flo > 0.0):
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
    return 0.5 * (lo + hi)


@compiled()
def _root(n, so, h, free, nu):  # pragma: no cover
    """``s`` of the ``n``-th root for ``s_y = so`` (bracketed on ``k``, or by a scan for free ``n
    <= 1``); NaN if none is bracketed."""
    odd = n % 2 == 1
    if n >= 2:
        lo = (n - 1) * math.pi / (2.0 * h) * (1.0 + 1e-15)
        hi = n * math.pi / (2.0 * h)
        flo = _characteristic(lo * lo, so, h, free, odd, nu)
        fhi = _characteristic(hi * hi, so, h, free, odd, nu)
        if flo == 0.0:
            return lo * lo
        if fhi == 0.0:
            return hi * hi
        if (flo > 0.0) == (fhi > 0.0):
            return math.nan
        return _illinois(lo, hi, flo, fhi, so, h, free, odd, nu, np.bool_(True)) ** 2
    # free, n = 0 or 1: scan s downwards from the top of the bracket
    top = (math.pi / (2.0 * h)) ** 2 if odd else 0.0
    bottom = -2.0 * so if so > 0.0 else top - (math.pi / h) ** 2
    if bottom >= top:
        return math.nan
    steps = 256
    prev_s = top * (1.0 - 1e-12) if top > 0.0 else -1e-300
    prev_f = _characteristic(prev_s, so, h, free, odd, nu)
    for i in range(1, steps + 1):
        s = top + (bottom - top) * (i / steps) * (1.0 - 1e-9)
        f = _characteristic(s, so, h, free, odd, nu)
        if (f > 0.0) != (prev_f > 0.0):
            # a bool, not a literal: one specialisation of _illinois for both calls
            return _illinois(s, prev_s, f, prev_f, so, h, free, odd, nu, np.bool_(False))
        prev_s, prev_f = s, f
    return math.nan


@compiled()
def solve_pairs(nx, ny, hx, hy, free, nu, sx, sy):  # pragma: no cover
    """``(s_x, s_y)`` of every index pair by alternating the two equations, in place from the
    values in ``sx``, ``sy``."""
    for k in range(nx.size):
        a, b = sx[k], sy[k]
        for _ in range(_ALTERNATIONS):
            a_new = _root(nx[k], b, hx, free, nu)
            b_new = _root(ny[k], a_new, hy, free, nu)
            if not (math.isfinite(a_new) and math.isfinite(b_new)):
                a, b = math.nan, math.nan
                break
            done = abs(a_new - a) <= 1e-14 * abs(a_new + b_new) and abs(b_new - b) <= 1e-14 * abs(
                a_new + b_new
            )
            a, b = a_new, b_new
            if done:
                break
        sx[k], sy[k] = a, b


def starting_s(n, h, free):
    """Starting ``s`` of index ``n``: Bolotin's phase ``(n - 1/2) pi``, 0 for free low families."""
    k = (n - 0.5) * math.pi / (2.0 * h)
    if free:
        k = np.where(n >= 2, k, np.where(n == 1, 0.5 * math.pi / (2.0 * h), 0.0))
    return np.asarray(k * k, dtype=float)
