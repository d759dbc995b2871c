"""The dimensionless contact equations of docs/physics.md, "Hertz contact", "Contact losses" and
"Yield of the contact" (numba): their force, Jacobian, exact settling test, status codes and the
result row of one impact (:func:`impact_row`, with its energy balance)."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from synth.compilation import compiled

#: Dimensionless law of one contact: ``lam``, ``G``, ``n``, losses ``c``, ``b``, yield
#: penetration ``xy`` (inf: none, or not reached).
Law = namedtuple("Law", ("lam", "G", "n", "c", "b", "xy"))

#: How an integration ended (dimensionless): ``status``, at time ``s`` in state ``x``, ``w`` with
#: the quadratures ``i2`` and ``loss``; its dense output is the first ``nh`` rows of ``hist``.
Integration = namedtuple("Integration", ("status", "s", "x", "w", "i2", "loss", "nh", "hist"))

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
    """Thornton's elastic unloading from ``xm > xy``: residual penetration ``xp`` and ``rho =
    sqrt(R_p / R)`` of ``f = rho (x - xp)^(3/2)``, through ``(xm, f_m)``, ``f_m = xy^(1/2) (3
    xm - xy) / 2`` (C. Thornton, J. Appl. Mech. 64 (1997) 383)."""
    fm = math.sqrt(xy) * (1.5 * xm - 0.5 * xy)
    return xm - fm / math.sqrt(xm), math.sqrt(xm * math.sqrt(xm) / fm)


@compiled()
def yield_law(x, xy, xm):
    """Thornton's elastic-perfectly plastic Hertz contact (x > 0, n = 3/2): ``(a, r, da,
    dr)``, force ``a``, viscous factor ``r`` (contact radius over ``sqrt(R theta v0)``) and
    their x-derivatives. Loading: ``x^(3/2)`` up to ``xy``, then ``xy^(1/2) (3 x - xy) / 2``;
    unloading from ``xm > xy``: :func:`unloading_branch`, 0 below ``xp``."""
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
    """Elastic energy (dimensionless) stored at ``x`` on the branch of ``xm``."""
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
    """Work (dimensionless) lost to plastic flow in a loading to ``xm``."""
    if xm <= xy:
        return 0.0
    fm = math.sqrt(xy) * (1.5 * xm - 0.5 * xy)
    # the unloading branch's energy at xm: f_m (xm - xp) / (5/2), xm - xp = f_m / xm^(1/2)
    return yield_potential(xm, xy, 0.0) - fm * fm / (2.5 * math.sqrt(xm))


@compiled()
def yield_law_arrays(x, xy, xm, a, r, da, dr):
    """:func:`yield_law` at each ``x[i]``, ``xm[i]`` (in metres with ``K = 1``: homogeneous)."""
    for i in range(x.shape[0]):
        if x[i] > 0.0:
            a[i], r[i], da[i], dr[i] = yield_law(x[i], xy, xm[i])
        else:
            a[i], r[i], da[i], dr[i] = 0.0, 0.0, 0.0, 0.0


@compiled()
def elastic_terms(x, n, b, xy, xm):
    """``(a, r, da, dr)`` at ``x > 0`` (:func:`yield_law`'s with a finite ``xy``)."""
    if xy != math.inf:
        return yield_law(x, xy, xm)
    a = power(x, n)
    if b == 0.0:
        return a, 0.0, n * a / x, 0.0
    r = math.sqrt(x)
    return a, r, n * a / x, 0.5 / r


@compiled()
def force(x, w, lam, n, c, b, xy=math.inf, xm=0.0):
    """Dimensionless contact force f and its elastic part a (0 out of contact)."""
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
    """Right-hand side (x', w', I2', L') of the scaled equations (docs/physics.md,
    "Numerics") for the law ``P``."""
    f, a = law_force(P, x, w, xm)
    dx = w - P.lam * f
    return dx, P.G - f, f * f, (f - a) * dx


@compiled()
def jacobian(P, x, w, xm):
    """Jacobian ``(j11, j12, j21, j22)`` of (x', w'); 0 where f is clipped at 0."""
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
    """Elastic energy (dimensionless) stored at ``x`` on the branch of ``xm``."""
    if xy != math.inf:
        return yield_potential(x, xy, xm)
    return x * power(x, n) / (n + 1.0) if x > 0.0 else 0.0


@compiled()
def residual_penetration(xy, xm):
    """Where the unloading force from ``xm`` ends (:func:`unloading_branch`), 0 unyielded."""
    if xm > xy:
        return unloading_branch(xy, xm)[0]
    return 0.0


@compiled()
def settling_energy(P, x, w, xm):
    """Settling function W; with a yield, heights from the residual penetration."""
    u = P.lam * P.G - w
    if x <= 0.0:
        return 0.5 * u * u
    return 0.5 * u * u + potential(x, P.n, P.xy, xm) - P.G * (x - residual_penetration(P.xy, xm))


@compiled()
def yielded_peak(xy, x, dx, xm, xp, loss):
    """``(xm, xp, loss)`` after a step to ``x`` at rate ``dx``: a peak past ``xy`` unloads."""
    if xm == 0.0 and x > xy and dx <= 0.0:
        return x, unloading_branch(xy, x)[0], loss + plastic_work(xy, x)
    return xm, xp, loss


#: Machine epsilon of float64.
EPS = 2.220446049250313e-16


@compiled()
def rise_ended(dx, w, atol):
    """True if ``dx = w - lam f`` is not positive to ``atol`` and the rounding of ``w`` and
    ``lam f``: past the peak, or at the end of an overdamped landing (no peak)."""
    return dx <= atol + 4.0 * EPS * (abs(w) + abs(w - dx))


@compiled()
def penetration_rate(P, x, w, xm):
    """x' = w - lam f, the rate of the penetration (its root is the peak penetration)."""
    return w - P.lam * law_force(P, x, w, xm)[0]


# Fields of the result array: the one place that names their order.
R_STATUS = 0  # SEPARATED, SETTLED or a failure code
R_TINY_REBOUND = 1  # 1: separated with a rebound below the solver's resolution
R_STIFF = 2  # 1: integrated by Radau IIA, 0: by DOP853 (power laws)
R_RESTITUTION = 3  # v_out / v_in
R_CONTACT_TIME = 4  # s, the force pulse's length (force > 0)
R_MAX_PENETRATION = 5  # m
R_PEAK_FORCE = 6  # N
R_IMPULSE = 7  # N s
R_INELASTICITY = 8  # Zener's lam = beta m / theta
R_REBOUND_SPEED = 9  # m/s
R_PLATE_ENERGY = 10  # J
R_ENERGY_RESIDUAL = 11  # relative error of the energy balance
R_N_STEPS = 12  # accepted steps
R_G = 13  # dimensionless gravity g theta / v0 (dense output)
R_C = 14  # dimensionless Hunt-Crossley loss mu v0 (dense output; power laws)
R_S_CONTACT = 15  # dimensionless end of contact (dense output)
R_THETA = 16  # the time scale, s
R_F_SCALE = 17  # force scale m v0 / theta, N
R_B = 18  # dimensionless viscoelastic loss (3/2) A / theta (dense output; power laws)
R_SEPARATION_TIME = 19  # s, to the penetration's return to 0 (the dense output's end)
R_XT = 20  # dimensionless transition deflection delta_t / (theta v0) (shell law)
R_XY = 21  # dimensionless yield penetration delta_y / (theta v0) (power laws; inf: none)
N_RESULT = 22


#: How a contact ended (dimensionless): ``status``; ``s_contact`` (separation, or proof it
#: cannot), ``s_force`` (force pulse's end); ``s_end, w_end, x_end``; ``i2 = Int f^2``,
#: ``loss``; ``x_max``, ``f_max``; ``n_steps``.
End = namedtuple("End", "status s_contact s_force s_end w_end x_end i2 loss x_max f_max n_steps")
#: Scales of one impact: ``m`` (kg), ``v_in``, ``v0`` (m/s), ``theta`` (s), ``f_scale`` (N),
#: Zener's ``lam``, dimensionless gravity ``G``.
Scales = namedtuple("Scales", "m v_in v0 theta lam G f_scale")


@compiled(inline="always")
def impact_row(e, elastic_end, sc):
    """The result array of the contact that ended as ``e`` at the scales ``sc``."""
    w_end, x_end, G, lam, v0, theta = e.w_end, e.x_end, sc.G, sc.lam, sc.v0, sc.theta
    separated = e.status == SEPARATED
    tiny_rebound = separated and w_end > 0.0
    if tiny_rebound:
        # still (barely) approaching: the rebound is below the absolute resolution
        w_end = 0.0
    i1 = 1.0 - w_end + G * e.s_end  # from w' = G - f
    # energy balance, dimensionless (docs/physics.md, "Hertz contact", in the plate's frame)
    lhs = 0.5 * w_end * w_end + elastic_end - G * x_end - 0.5
    rhs = G * lam * i1 - lam * e.i2 - e.loss
    # relative to the energy exchanged: arrival energy, or gravity's work and the energy
    # carried away when larger (a slow heavy ball sinking with the plate)
    scale = max(0.5, abs(G * lam * i1), lam * e.i2, abs(e.loss), abs(G * x_end))
    v_out = -w_end * v0 if separated else 0.0
    r = np.zeros(N_RESULT)
    r[R_STATUS] = e.status
    r[R_TINY_REBOUND] = 1.0 if tiny_rebound else 0.0
    r[R_RESTITUTION] = v_out / sc.v_in
    r[R_CONTACT_TIME] = e.s_force * theta
    r[R_SEPARATION_TIME] = e.s_contact * theta
    r[R_MAX_PENETRATION] = e.x_max * theta * v0
    r[R_PEAK_FORCE] = e.f_max * sc.f_scale
    r[R_IMPULSE] = i1 * sc.m * v0
    r[R_INELASTICITY] = lam
    r[R_REBOUND_SPEED] = v_out
    r[R_PLATE_ENERGY] = lam * e.i2 * sc.m * v0 * v0
    r[R_ENERGY_RESIDUAL] = abs(lhs - rhs) / scale
    r[R_N_STEPS] = e.n_steps
    r[R_G] = G
    r[R_S_CONTACT] = e.s_contact
    r[R_THETA] = theta
    r[R_F_SCALE] = sc.f_scale
    return r
