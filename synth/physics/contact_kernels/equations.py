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
increases, and the ball cannot leave once ``W < (lam G)^2 / 2``. With a yield (Thornton's
elastic-perfectly plastic Hertz contact, :func:`yield_law`) ``x^n`` and ``x^(1/2)`` are the
law's force and contact radius on the branch that the largest penetration so far selects
(docs/physics.md, "Yield of the contact"). Also the status codes.
"""

from __future__ import annotations

import math
from collections import namedtuple

from synth.compilation import compiled

#: The dimensionless law of one contact (module docstring), the kernels' one argument for it:
#: ``lam``, ``G``, ``n``, the losses ``c`` and ``b``, the yield penetration ``xy`` (None: no
#: yield, the kernels compiled without it; inf: not reached).
Law = namedtuple("Law", ("lam", "G", "n", "c", "b", "xy"))

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
def unloading_branch(xy, xm):
    """The elastic unloading of Thornton's contact from the largest penetration ``xm``
    past the yield penetration ``xy`` (docs/physics.md, "Yield of the contact"): the
    residual penetration ``xp`` and ``rho = sqrt(R_p / R)`` of ``f = rho (x - xp)^(3/2)``.

    Loading reaches ``f_m = xy^(1/2) (3 xm - xy) / 2``; the contact radius there is the
    loading one, ``a_p^2 = R delta_m``, and the unloading is Hertz's with the radius
    ``R_p = 4 E* a_p^3 / (3 F_m)`` through ``(xm, f_m)``: ``R_p / R = xm^(3/2) / f_m`` and
    ``xm - xp = f_m / xm^(1/2)`` (C. Thornton, J. Appl. Mech. 64 (1997) 383)."""
    fm = math.sqrt(xy) * (1.5 * xm - 0.5 * xy)
    return xm - fm / math.sqrt(xm), math.sqrt(xm * math.sqrt(xm) / fm)


@compiled()
def yield_law(x, xy, xm):
    """Thornton's elastic-perfectly plastic Hertz contact, dimensionless (x > 0, the
    equations' ``n = 3/2``): ``(a, r, da, dr)``, the elastic-plastic force ``a``, the
    viscous factor ``r`` (the contact radius over ``sqrt(R theta v0)``: the viscoelastic
    force is ``b r x'``, Kuwabara & Kono's ``A 2 E* a delta'``) and their x-derivatives.

    ``xy`` is the penetration at which the Hertz peak pressure reaches the limiting
    pressure ``p_y`` (inf: elastic); ``xm`` the largest penetration of the contact so far
    (0 while it loads). Loading: Hertz ``x^(3/2)`` up to ``xy``, then the tangent line
    ``xy^(1/2) (3 x - xy) / 2`` (``F = F_y + pi p_y R (delta - delta_y)``), contact radius
    ``sqrt(x)``; unloading from ``xm > xy``: :func:`unloading_branch`, contact radius
    ``rho (x - xp)^(1/2)``, both 0 below the residual penetration ``xp``."""
    top = max(x, xm)
    if top <= xy:
        r = math.sqrt(x)
        return x * r, r, 1.5 * r, 0.5 / r
    if x >= xm:
        r = math.sqrt(x)
        ry = math.sqrt(xy)
        return ry * (1.5 * x - 0.5 * xy), r, 1.5 * ry, 0.5 / r
    xp, rho = unloading_branch(xy, xm)
    y = x - xp
    if y <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    r = math.sqrt(y)
    return rho * y * r, rho * r, 1.5 * rho * r, 0.5 * rho / r


@compiled()
def yield_potential(x, xy, xm):
    """The elastic energy (dimensionless) that :func:`yield_law` stores at ``x``: Hertz's
    ``x^(5/2) / (5/2)`` without yield; while loading past ``xy`` the work of the loading
    law; on the unloading branch ``rho (x - xp)^(5/2) / (5/2)`` (0 below ``xp``). The work
    of loading to ``xm`` less the unloading branch's energy at ``xm`` is the plastic work
    (:func:`plastic_work`)."""
    if x <= 0.0:
        return 0.0
    if max(x, xm) <= xy:
        return x * x * math.sqrt(x) / 2.5
    if x >= xm:
        d = x - xy
        ry = math.sqrt(xy)
        return xy * xy * ry / 2.5 + xy * ry * d + 0.75 * ry * d * d
    xp, rho = unloading_branch(xy, xm)
    y = x - xp
    return rho * y * y * math.sqrt(y) / 2.5 if y > 0.0 else 0.0


@compiled()
def plastic_work(xy, xm):
    """The work (dimensionless) dissipated by the plastic flow of a loading to ``xm``
    (0 below the yield penetration ``xy``): the loading law's work less the energy the
    unloading branch from ``xm`` gives back."""
    if xm <= xy:
        return 0.0
    fm = math.sqrt(xy) * (1.5 * xm - 0.5 * xy)
    # the unloading branch's energy at xm: f_m (xm - xp) / (5/2), xm - xp = f_m / xm^(1/2)
    return yield_potential(xm, xy, 0.0) - fm * fm / (2.5 * math.sqrt(xm))


@compiled()
def yield_law_arrays(x, xy, xm, a, r, da, dr):
    """:func:`yield_law` at each ``x[i]`` (0 where ``x[i] <= 0``) with the largest
    penetration ``xm[i]`` so far, into ``a``, ``r``, ``da`` and ``dr`` (the modal contact's
    pulse between its steps, in metres with ``K = 1``: the law is homogeneous)."""
    for i in range(x.shape[0]):
        if x[i] > 0.0:
            a[i], r[i], da[i], dr[i] = yield_law(x[i], xy, xm[i])
        else:
            a[i], r[i], da[i], dr[i] = 0.0, 0.0, 0.0, 0.0


@compiled()
def elastic_terms(x, n, b, xy, xm):
    """``(a, r, da, dr)`` at ``x > 0``: the law's elastic force ``x^n`` and viscous factor
    ``x^(1/2)`` (0 without the viscoelastic loss ``b``) and their x-derivatives, or with a
    finite yield penetration ``xy`` (``xm`` the largest penetration so far)
    :func:`yield_law`'s. ``xy`` None: no yield, its code pruned at compile time (numba
    prunes on an argument's type, so every branch on ``xy`` takes it as an argument)."""
    if xy is not None:
        if xy != math.inf:
            return yield_law(x, xy, xm)
    a = power(x, n)
    if b == 0.0:
        return a, 0.0, n * a / x, 0.0
    r = math.sqrt(x)
    return a, r, n * a / x, 0.5 / r


@compiled()
def force(x, w, lam, n, c, b, xy=None, xm=0.0):
    """Dimensionless contact force f and its elastic part a (both 0 out of contact):
    ``f = max(0, (a (1 + c w) + b r w) / (1 + c lam a + b lam r))`` with ``a``, ``r`` of
    :func:`elastic_terms` (the module docstring)."""
    if x <= 0.0:
        return 0.0, 0.0
    a, r, _, _ = elastic_terms(x, n, b, xy, xm)
    if c == 0.0 and b == 0.0:
        return a, a
    num = a * (1.0 + c * w)
    den = 1.0 + c * lam * a
    if b != 0.0:
        num += b * r * w
        den += b * lam * r
    f = num / den
    return (f if f > 0.0 else 0.0), a


@compiled(inline="always")
def law_force(P, x, w, xm):
    """:func:`force` of the law ``P`` (:data:`Law`)."""
    return force(x, w, P.lam, P.n, P.c, P.b, P.xy, xm)


@compiled()
def rhs(P, x, w, xm):
    """Right-hand side (x', w', I2', L') of the module docstring for the law ``P``."""
    f, a = law_force(P, x, w, xm)
    dx = w - P.lam * f
    return dx, P.G - f, f * f, (f - a) * dx


@compiled()
def jacobian(P, x, w, xm):
    """Jacobian of (x', w') with respect to (x, w): returns j11, j12, j21, j22.

    With ``f = N / D`` (``N = a (1 + c w) + b r w``, ``D = 1 + lam (c a + b r)``):
    ``f_x = (N_x - f D_x) / D``, ``f_w = (c a + b r) / D``; 0 where f is clipped at 0."""
    if x <= 0.0:
        return 0.0, 1.0, 0.0, 0.0
    a, r, da, dr = elastic_terms(x, P.n, P.b, P.xy, xm)
    lam, c, b = P.lam, P.c, P.b
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
        den = 1.0 + lam * (c * a + b * r)
        f = (a * (1.0 + c * w) + b * r * w) / den
        if f <= 0.0:
            fx, fw = 0.0, 0.0
        else:
            fx = (da * (1.0 + c * w) + b * dr * w - f * lam * (c * da + b * dr)) / den
            fw = (c * a + b * r) / den
    return -lam * fx, 1.0 - lam * fw, -fx, -fw


@compiled()
def potential(x, n, xy, xm):
    """The elastic energy (dimensionless) stored at ``x``: ``x^(n+1) / (n+1)``, or with a
    finite yield penetration ``xy`` :func:`yield_potential` on the branch of ``xm``."""
    if xy is not None:
        if xy != math.inf:
            return yield_potential(x, xy, xm)
    return x * power(x, n) / (n + 1.0) if x > 0.0 else 0.0


@compiled()
def residual_penetration(xy, xm):
    """Where the unloading force from ``xm`` ends (:func:`unloading_branch`), 0 unyielded."""
    if xy is not None:
        if xm > xy:
            return unloading_branch(xy, xm)[0]
    return 0.0


@compiled()
def settling_energy(P, x, w, xm):
    """Settling function W of the module docstring; with a yield the height is measured from
    the residual penetration, where the force ends (the ball leaves from there)."""
    u = P.lam * P.G - w
    if x <= 0.0:
        return 0.5 * u * u
    return 0.5 * u * u + potential(x, P.n, P.xy, xm) - P.G * (x - residual_penetration(P.xy, xm))


@compiled()
def yield_value(xy):
    """The yield penetration ``xy`` as a float: inf for None (no yield)."""
    if xy is None:
        return math.inf
    return xy


@compiled()
def yielded_peak(xy, x, dx, xm, xp, loss):
    """``(xm, xp, loss)`` after a step that ends at ``x`` with the rate ``dx``: at a peak past
    the yield penetration ``xy`` the contact unloads from it (force and contact radius are
    continuous there), its plastic work lost; else unchanged."""
    if xy is not None:
        if xm == 0.0 and x > xy and dx <= 0.0:
            return x, unloading_branch(xy, x)[0], loss + plastic_work(xy, x)
    return xm, xp, loss


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
def penetration_rate(P, x, w, xm):
    """x' = w - lam f, the rate of the penetration (its root is the peak penetration)."""
    return w - P.lam * law_force(P, x, w, xm)[0]
