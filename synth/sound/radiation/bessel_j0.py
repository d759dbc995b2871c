"""The Bessel function ``J_0`` of the whole circles' closed form (numba kernels): Cephes'
rational approximations below the Hankel range and Hankel's asymptotic expansion above.
"""

from __future__ import annotations

import fractions
import math

from synth.compilation import compiled
from synth.vecmath import cis

# ----------------------------------------------------------------------------------------
# Whole circles in closed form (separable shapes): by the mean value theorem of the
# Helmholtz equation (Courant and Hilbert, Methods of Mathematical Physics vol. II, ch. IV,
# sec. 3), Int_0^2pi phi_k(xl + r cos t, yl + r sin t) dt = 2 pi phi_k(xl, yl) J_0(k_k r).
# J_0 in a loop that vectorises: for x >= 25 Hankel's expansion with ten terms of P and Q
# (Abramowitz and Stegun 9.2.5, 9.2.9, 9.2.10; remainder <= 4e-18 at x = 25), below it the
# rational approximations of Cephes (S. L. Moshier), as scipy.special.j0 evaluates them.

HANKEL_FROM = 25.0  # J_0 by its asymptotic expansion from this argument up
_HANKEL_TERMS = 10  # terms of P and of Q


def _hankel_coefficients(n: int) -> tuple[tuple, tuple]:
    """Coefficients of ``P(x) = sum_k p_k x^(-2k)`` and ``Q(x) = sum_k q_k x^(-2k-1)``
    (``k < n``) of J_0's asymptotic expansion: ``p_k = (-1)^k a_2k``,
    ``q_k = (-1)^k a_(2k+1)``, ``a_m = prod_(l <= m) (-(2l - 1)^2 / (8 l))`` (exact
    fractions, then rounded)."""
    a = [fractions.Fraction(1)]
    for m in range(1, 2 * n):
        a.append(a[-1] * fractions.Fraction(-((2 * m - 1) ** 2), 8 * m))
    p = tuple(float((-1) ** k * a[2 * k]) for k in range(n))
    q = tuple(float((-1) ** k * a[2 * k + 1]) for k in range(n))
    return p, q


_HANKEL_P, _HANKEL_Q = _hankel_coefficients(_HANKEL_TERMS)
_QUARTER_PI = 0.25 * math.pi
_SQRT_2_OVER_PI = math.sqrt(2.0 / math.pi)


# Cephes j0.c: J_0(x) = (x^2 - DR1)(x^2 - DR2) RP(x^2) / RQ(x^2) for x <= 5, and the
# modulus-phase form with PP/PQ and QP/QQ (rational in 25 / x^2) above.
_J0_DR1 = 5.78318596294678452118e0
_J0_DR2 = 3.04712623436620863991e1
_J0_RP = (
    -4.79443220978201773821e9, 1.95617491946556577543e12, -2.49248344360967716204e14,
    9.70862251047306323952e15,
)  # fmt: skip
_J0_RQ = (
    4.99563147152651017219e2, 1.73785401676374683123e5, 4.84409658339962045305e7,
    1.11855537045356834862e10, 2.11277520115489217587e12, 3.10518229857422583814e14,
    3.18121955943204943306e16, 1.71086294081043136091e18,
)  # fmt: skip
_J0_PP = (
    7.96936729297347051624e-4, 8.28352392107440799803e-2, 1.23953371646414299388e0,
    5.44725003058768775090e0, 8.74716500199817011941e0, 5.30324038235394892183e0,
    9.99999999999999997821e-1,
)  # fmt: skip
_J0_PQ = (
    9.24408810558863637013e-4, 8.56288474354474431428e-2, 1.25352743901058953537e0,
    5.47097740330417105182e0, 8.76190883237069594232e0, 5.30605288235394617618e0,
    1.00000000000000000218e0,
)  # fmt: skip
_J0_QP = (
    -1.13663838898469149931e-2, -1.28252718670509318512e0, -1.95539544257735972385e1,
    -9.32060152123768231369e1, -1.77681167980488050595e2, -1.47077505154951170175e2,
    -5.14105326766599330220e1, -6.05014350600728481186e0,
)  # fmt: skip
_J0_QQ = (
    6.43178256118178023184e1, 8.56430025976980587198e2, 3.88240183605401609683e3,
    7.24046774195652478189e3, 5.93072701187316984827e3, 2.06209331660327847417e3,
    2.42005740240291393179e2,
)  # fmt: skip


@compiled(inline="always")
def _horner(coef, z):
    """``coef[0] z^(n-1) + ... + coef[n-1]``."""
    v = coef[0]
    for c in coef[1:]:
        v = v * z + c
    return v


@compiled(inline="always")
def _horner_monic(coef, z):
    """``z^n + coef[0] z^(n-1) + ... + coef[n-1]``."""
    v = z + coef[0]
    for c in coef[1:]:
        v = v * z + c
    return v


@compiled()
def j0_cephes(x):
    """J_0(x), ``x >= 0``, by Cephes' rational approximations."""
    if x <= 5.0:
        z = x * x
        return (z - _J0_DR1) * (z - _J0_DR2) * _horner(_J0_RP, z) / _horner_monic(_J0_RQ, z)
    w = 5.0 / x
    z = w * w
    p = _horner(_J0_PP, z) / _horner(_J0_PQ, z)
    q = _horner(_J0_QP, z) / _horner_monic(_J0_QQ, z)
    xn = x - _QUARTER_PI
    cs, sn = cis(xn)
    return (p * cs - w * q * sn) * _SQRT_2_OVER_PI / math.sqrt(x)


@compiled(inline="always")
def j0_hankel(inv_x, sqrt_inv_x, x):
    """J_0(x) for ``x >= 25`` by its asymptotic expansion, from ``1 / x`` and
    ``sqrt(1 / x)`` (products only, so that a loop over modes vectorises)."""
    z = inv_x * inv_x
    p = _HANKEL_P[_HANKEL_TERMS - 1]
    q = _HANKEL_Q[_HANKEL_TERMS - 1]
    for k in range(_HANKEL_TERMS - 2, -1, -1):
        p = p * z + _HANKEL_P[k]
        q = q * z + _HANKEL_Q[k]
    cs, sn = cis(x - _QUARTER_PI)
    return (p * cs - inv_x * q * sn) * _SQRT_2_OVER_PI * sqrt_inv_x
