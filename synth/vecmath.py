"""Elementary functions for numba kernels whose loops over modes must vectorise: plain polynomials
(no libm call). :func:`cis` is within a few ulp for ``|theta| < 2^19 pi``, :func:`exp_small`
within an ulp or two on ``|u| <= 1``; compiled without fast-math, so reductions keep their order."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled

_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of pi/2 (fdlibm)
_PIO2_1T = 6.07710050650619224932e-11  # pi/2 - _PIO2_1
_INVPIO2 = 6.36619772367581382433e-01  # 2/pi
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


@compiled()
def cis(theta):
    """(cos theta, sin theta) for |theta| < 2^19 pi, within a few ulp."""
    n = np.floor(theta * _INVPIO2 + 0.5)
    r = (theta - n * _PIO2_1) - n * _PIO2_1T
    z = r * r
    sn = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    cs = 1.0 - 0.5 * z + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    q = n - 4.0 * np.floor(0.25 * n)  # quadrant 0, 1, 2 or 3 (kept in floats
    swap = q == 1.0 or q == 3.0  # so that the loop vectorises without AVX-512)
    c0 = sn if swap else cs
    s0 = cs if swap else sn
    c_sign = -1.0 if (q == 1.0 or q == 2.0) else 1.0
    s_sign = -1.0 if q >= 2.0 else 1.0
    return c0 * c_sign, s0 * s_sign


#: ``1 / k!`` for ``k = 0 .. 18``: the Taylor coefficients of :func:`exp_small` (exact
#: factorials, below 2^53).
_INV_FACTORIALS = tuple(1.0 / math.factorial(k) for k in range(19))


@compiled()
def exp_small(u):
    """exp(u) for |u| <= 1 by its Taylor series to u^18 (remainder < 2e-17), by Horner."""
    e = _INV_FACTORIALS[18]
    for k in range(17, -1, -1):  # a fixed count: unrolled, so that a loop over modes vectorises
        e = _INV_FACTORIALS[k] + u * e
    return e


@compiled()
def halvings_for(largest):
    """Fewest halvings ``J`` with ``largest / 2^J <= 1`` (``largest >= 0``): the argument
    scaling ``exp(u) = exp_small(u / 2^J)^(2^J)`` needs for exponents up to ``largest`` in
    magnitude."""
    if not largest > 1.0:
        return 0
    return int(math.ceil(math.log2(largest)))
