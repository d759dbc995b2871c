"""A contact's step history, dense output and events (numba): DOP853's continuous extension of
order 7 (Hairer, Norsett & Wanner, "Solving ODEs I", II.6) or Radau IIA's collocation
polynomial, both as scipy's; events by the Illinois method (Dowell & Jarratt, BIT 11, 1971).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels.series import series_eval

# Columns of the dense-output history, one row per accepted step (row 0: the series).
H_T0, H_H, H_X0, H_W0 = 0, 1, 2, 3
H_COEF = 4  # DOP853: F[0..6] for x then w (14); Radau: Q[x,0..2], Q[w,0..2] (6)
H_XM = H_COEF + 14  # the largest penetration before the step (0 while loading), the yield's
H_COLS = H_COEF + 15

#: A contact's dense output: step ``hist``, series coefficients ``S``, ``radau`` (else
#: DOP853) and the law ``P``.
Dense = namedtuple("Dense", ("hist", "S", "radau", "P"))


@compiled()
def grow_history(hist, k):
    """The history with room for row ``k``: itself, or a copy of twice its rows."""
    if k < hist.shape[0]:
        return hist
    new = np.zeros((2 * hist.shape[0], hist.shape[1]))  # see ``start``: no uninitialised column
    # element by element: a slice assignment compiles numba's shape-error path (seconds)
    for i in range(hist.shape[0]):
        for j in range(hist.shape[1]):
            new[i, j] = hist[i, j]
    return new


@compiled()
def hermite_dips(x0, x1, d0, d1):
    """True if the cubic Hermite interpolant of x over a step (x0, x1 > 0; d0, d1 scaled
    derivatives) reaches 0 inside it: the ball left and came back within one step."""
    if not (d0 < 0.0 < d1):
        return False
    a = 2.0 * x0 + d0 - 2.0 * x1 + d1  # x(t) = a t^3 + b t^2 + d0 t + x0, t in [0, 1]
    b = -3.0 * x0 - 2.0 * d0 + 3.0 * x1 - d1
    # x'(t) = 3 a t^2 + 2 b t + d0: its roots in (0, 1)
    qa = 3.0 * a
    qb = 2.0 * b
    lowest = min(x0, x1)
    if qa == 0.0:
        roots = (-d0 / qb if qb != 0.0 else -1.0, -1.0)
    else:
        disc = qb * qb - 4.0 * qa * d0
        if disc < 0.0:
            return False
        r = math.sqrt(disc)
        roots = ((-qb - r) / (2.0 * qa), (-qb + r) / (2.0 * qa))
    for t in roots:
        if 0.0 < t < 1.0:
            lowest = min(lowest, ((a * t + b) * t + d0) * t + x0)
    return lowest <= 0.0


@compiled()
def hermite_root(x0, x1, d0, d1):
    """Fraction of a step where x's Hermite interpolant crosses 0, to 1e-6 (places a redo)."""
    a = 0.0
    b = 1.0
    for _ in range(20):
        m = 0.5 * (a + b)
        t2 = m * m
        t3 = t2 * m
        v = (
            (2.0 * t3 - 3.0 * t2 + 1.0) * x0
            + (t3 - 2.0 * t2 + m) * d0
            + (3.0 * t2 - 2.0 * t3) * x1
            + (t3 - t2) * d1
        )
        if v > 0.0:
            a = m
        else:
            b = m
    return b


@compiled()
def yield_fraction(x0, x1, d0, d1, xy, xm, xp):
    """Fraction of a step at which the yielded law changes: the peak of x past ``xy`` while
    loading, the residual penetration ``xp`` while unloading; 1 if neither."""
    if xm == 0.0:
        if not (d0 > 0.0 and d1 < 0.0):
            return 1.0
        a = 2.0 * x0 + d0 - 2.0 * x1 + d1  # x(t) = a t^3 + b t^2 + d0 t + x0, t in [0, 1]
        q = -3.0 * x0 - 2.0 * d0 + 3.0 * x1 - d1
        # x'(t) = 3 a t^2 + 2 q t + d0, positive at 0 and negative at 1: its root between
        lo = 0.0
        hi = 1.0
        for _ in range(40):
            t = 0.5 * (lo + hi)
            if (3.0 * a * t + 2.0 * q) * t + d0 > 0.0:
                lo = t
            else:
                hi = t
        peak = ((a * hi + q) * hi + d0) * hi + x0
        return hi if peak > xy else 1.0
    if x0 > xp > x1 and xm > xy:
        return hermite_root(x0 - xp, x1 - xp, d0, d1)
    return 1.0


@compiled()
def yield_peak_at_start(x0, d0, d1, xy, xm):
    """Whether a loading step from ``x0`` past ``xy`` (scaled rates ``d0 > 0 > d1`` at its
    ends) starts on the peak to the resolution of x: the rise left to the root of x' (by x'
    linear over the step) is below x's rounding, so no shorter step can land past the peak
    and the peak is ``x0`` as exactly as x is stored."""
    if xm != 0.0 or not (x0 > xy and d0 > 0.0 > d1):
        return False
    return 0.5 * d0 * d0 / (d0 - d1) <= _eq.EPS * x0


@compiled()
def radau_dense(hist, k, s):
    """(x, w) at time s inside Radau step k: its collocation polynomial."""
    p1 = (s - hist[k, H_T0]) / hist[k, H_H]
    p2 = p1 * p1
    p3 = p2 * p1
    c = H_COEF
    x = hist[k, H_X0] + hist[k, c] * p1 + hist[k, c + 1] * p2 + hist[k, c + 2] * p3
    w = hist[k, H_W0] + hist[k, c + 3] * p1 + hist[k, c + 4] * p2 + hist[k, c + 5] * p3
    return x, w


@compiled()
def dense_state(D, k, s):
    """(x, w) at time s inside step k of the dense output ``D`` (step 0: the series)."""
    hist = D.hist
    if k == 0:
        return series_eval(D.S, s, D.P.n, D.P.b)
    if D.radau:
        return radau_dense(hist, k, s)
    # DOP853 continuous extension (scipy's Dop853DenseOutput, Horner form)
    th = (s - hist[k, H_T0]) / hist[k, H_H]
    x = 0.0
    w = 0.0
    for i in range(7):
        j = 6 - i
        x += hist[k, H_COEF + j]
        w += hist[k, H_COEF + 7 + j]
        if i % 2 == 0:
            x *= th
            w *= th
        else:
            x *= 1.0 - th
            w *= 1.0 - th
    return x + hist[k, H_X0], w + hist[k, H_W0]


@compiled()
def find_step(hist, nst, s):
    """The step of the first ``nst`` rows whose span holds time s (bisection)."""
    lo = 0
    hi = nst - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if hist[mid, H_T0] <= s:
            lo = mid
        else:
            hi = mid - 1
    return lo


@compiled()
def penetration_and_force(D, nst, s):
    """(x, f) at time s from the dense output of the first ``nst`` rows of the history."""
    k = find_step(D.hist, nst, s)
    x, w = dense_state(D, k, s)
    return x, _eq.law_force(D.P, x, w, D.hist[k, H_XM])[0]


@compiled()
def golden_max(D, nst, lo, hi, which):
    """Maximum of x (which=0) or f (which=1) over [lo, hi] by golden-section search."""
    g = 0.6180339887498949
    ta = lo
    tb = hi
    x1 = tb - g * (tb - ta)
    x2 = ta + g * (tb - ta)
    v1 = penetration_and_force(D, nst, x1)[which]
    v2 = penetration_and_force(D, nst, x2)[which]
    # The peak is quadratic: locating it to 1e-8 of its bracket gives the value to ~1e-16.
    for _ in range(80):
        if tb - ta <= 1e-8 * (hi - lo):
            break
        if v1 < v2:
            ta = x1
            x1 = x2
            v1 = v2
            x2 = ta + g * (tb - ta)
            v2 = penetration_and_force(D, nst, x2)[which]
        else:
            tb = x2
            x2 = x1
            v2 = v1
            x1 = tb - g * (tb - ta)
            v1 = penetration_and_force(D, nst, x1)[which]
    return max(v1, v2)


#: Whether a history holds Radau IIA's steps. numpy booleans: numba would compile every
#: function once per literal True, literal False and run-time flag.
DOP853_STEPS = np.bool_(False)
RADAU_STEPS = np.bool_(True)

#: Event functions of :func:`event`. numpy integers: numba compiles a literal int once per value.
END_OF_CONTACT = np.int64(0)
PEAK_PENETRATION = np.int64(1)
SETTLING = np.int64(2)
FORCE_END = np.int64(3)


@compiled()
def event(which, x, w, P, thr, xm):
    """Event functions: 0, x (end of contact); 1, ``w - lam f`` (peak); 2, ``W - thr`` (settling);
    3, :func:`force_numerator` (end of the force pulse). ``xm``: the largest penetration so far."""
    if which == 0:
        return x
    if which == 1:
        return _eq.penetration_rate(P, x, w, xm)
    if which == 3:
        return force_numerator(x, w, P.n, P.c, P.b, P.xy, xm)
    return _eq.settling_energy(P, x, w, xm) - thr


@compiled()
def force_numerator(x, w, n, c, b, xy, xm):
    """Numerator of the lossy force before its clip at 0 (its sign is the force's), or x where
    ``x <= 0``; with a yield, ``yield_law``'s, or ``x - xp`` below ``xp``."""
    if x <= 0.0:
        return x
    if xy != math.inf:
        a, r, _, _ = _eq.yield_law(x, xy, xm)
        if r == 0.0:
            return x - _eq.unloading_branch(xy, xm)[0]
        return a * (1.0 + c * w) + b * r * w
    return _eq.power(x, n) * (1.0 + c * w) + b * math.sqrt(x) * w


@compiled()
def event_root(D, k, which, thr):
    """Where event ``which`` falls through 0 in step k (Illinois); else the step's end."""
    hist = D.hist
    P = D.P
    xm = hist[k, H_XM]
    ta = hist[k, H_T0]
    tb = ta + hist[k, H_H]
    fa = event(which, hist[k, H_X0], hist[k, H_W0], P, thr, xm)
    xb, wb = dense_state(D, k, tb)
    fb = event(which, xb, wb, P, thr, xm)
    if fa <= 0.0 or fb >= 0.0:
        return tb
    side = 0
    for _ in range(200):
        m = (ta * fb - tb * fa) / (fb - fa)
        if not (ta < m < tb):
            m = 0.5 * (ta + tb)
        xq, wq = dense_state(D, k, m)
        fm = event(which, xq, wq, P, thr, xm)
        if fm > 0.0:
            ta, fa = m, fm
            if side == 1:
                fb *= 0.5
            side = 1
        elif fm < 0.0:
            tb, fb = m, fm
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            return m
        # the peak (which 1) is quadratic: 1e-10 of the step places it to ~1e-20 in value
        if tb - ta <= (1e-10 * hist[k, H_H] if which == 1 else 4e-16 * tb):
            break
    return tb if -fb < fa else ta
