"""The dimensionless contact equations, their force, Jacobian and settling test (numba).

The equations of docs/physics.md, "Hertz contact" (the thesis' eq. 2.42 with a power law,
gravity and contact losses):

    x' = w - lam * f(x, w)          x = delta / (theta v0)   (penetration)
    w' = -f(x, w) + G               w = -v_rel / v0          (ball's downward speed)
    f  = x^n                        (Hertz n = 3/2, power law, elastic foundation n = 2)
    f  = max(0, (x^n (1 + c w) + b x^(1/2) w) / (1 + c lam x^n + b lam x^(1/2)))  (losses)

with Hunt-Crossley's ``c = mu v0`` and the viscoelastic ``b = (3/2) A / theta`` (Kuwabara &
Kono 1987; Brilliantov et al. 1996), time ``s = t / theta``, ``lam = beta m / theta`` and
``G = g theta / v0``; ``I2' = f^2`` and ``L' = (f - x^n) x'`` carry the energy balance.
Settling is exact: ``W = u^2 / 2 + x^(n+1) / (n+1) - G x`` (``u = lam G - w``) never
increases, and the ball cannot leave once ``W < (lam G)^2 / 2``. Also the status codes.
"""

from __future__ import annotations

import math

from synth.compilation import compiled

# Status codes shared with synth.physics.contact.
SEPARATED = 0
SETTLED = 1
MAX_STEPS = -1
STEP_TOO_SMALL = -2


@compiled()
def power(x, n):
    """x^n for x > 0, with fast paths for the usual exponents."""
    if n == 1.5:
        return x * math.sqrt(x)
    if n == 2.0:
        return x * x
    return x**n


@compiled()
def positive_power(a, n):
    """a <- max(a, 0)^n in place, the exponent tested once (so that the loop vectorises)."""
    if n == 1.5:
        for i in range(a.shape[0]):
            v = max(a[i], 0.0)
            a[i] = v * math.sqrt(v)
    else:
        for i in range(a.shape[0]):
            a[i] = max(a[i], 0.0) ** n


@compiled()
def force(x, w, lam, n, c, b):
    """Dimensionless contact force f and its elastic part x^n (both 0 out of contact):
    ``f = x^n + d(x) x'`` with the damping ``d = c x^n + b x^(1/2)`` (module docstring)."""
    if x <= 0.0:
        return 0.0, 0.0
    a = power(x, n)
    if c == 0.0 and b == 0.0:
        return a, a
    num = a * (1.0 + c * w)
    den = 1.0 + c * lam * a
    if b != 0.0:
        r = math.sqrt(x)
        num += b * r * w
        den += b * lam * r
    f = num / den
    if f < 0.0:
        f = 0.0
    return f, a


@compiled()
def rhs(x, w, lam, G, n, c, b):
    """Right-hand side (x', w', I2', L') of the module docstring."""
    f, a = force(x, w, lam, n, c, b)
    dx = w - lam * f
    return dx, G - f, f * f, (f - a) * dx


@compiled()
def jacobian(x, w, lam, n, c, b):
    """Jacobian of (x', w') with respect to (x, w): returns j11, j12, j21, j22.

    With ``f = N / D`` (``N = x^n (1 + c w) + b x^(1/2) w``, ``D = 1 + lam (c x^n + b
    x^(1/2))``): ``f_x = (N_x - f D_x) / D``, ``f_w = (c x^n + b x^(1/2)) / D``; 0 where f
    is clipped at 0."""
    if x <= 0.0:
        return 0.0, 1.0, 0.0, 0.0
    a = power(x, n)
    da = n * a / x
    if c == 0.0 and b == 0.0:
        fx, fw = da, 0.0
    elif b == 0.0:
        num = 1.0 + c * w
        den = 1.0 + c * lam * a
        if a * num / den <= 0.0:
            fx, fw = 0.0, 0.0
        else:
            fx = da * num / (den * den)
            fw = a * c / den
    else:
        r = math.sqrt(x)
        dr = 0.5 / r
        den = 1.0 + lam * (c * a + b * r)
        f = (a * (1.0 + c * w) + b * r * w) / den
        if f <= 0.0:
            fx, fw = 0.0, 0.0
        else:
            fx = (da * (1.0 + c * w) + b * dr * w - f * lam * (c * da + b * dr)) / den
            fw = (c * a + b * r) / den
    return -lam * fx, 1.0 - lam * fw, -fx, -fw


@compiled()
def settling_energy(x, w, lam, G, n):
    """Settling function W of the module docstring."""
    u = lam * G - w
    return 0.5 * u * u + power(x, n) * x / (n + 1.0) - G * x if x > 0.0 else 0.5 * u * u


#: Machine epsilon of float64.
EPS = 2.220446049250313e-16


@compiled()
def rise_ended(dx, w, atol):
    """True if the penetration rate ``dx = x' = w - lam f`` (at speed ``w``) is not
    positive to the absolute tolerance ``atol`` of the state and to the rounding of its two
    terms ``w`` and ``lam f = w - dx``: past the penetration's peak, or at the end of an
    overdamped landing, which creeps up to the static penetration without a peak."""
    return dx <= atol + 4.0 * EPS * (abs(w) + abs(w - dx))


@compiled()
def penetration_rate(x, w, lam, n, c, b):
    """x' = w - lam f, the rate of the penetration (its root is the peak penetration)."""
    f, _ = force(x, w, lam, n, c, b)
    return w - lam * f
