"""numba kernels of the thin-shell contact of a hollow ball (private to synth.physics.contact).

The law of docs/physics.md, "Hollow balls", scaled like the power laws (``equations.py``) by
``theta = sqrt(m / k0)``, ``k0 = k_R + k_g``, and the length ``theta v0``:

    x' = w - lam f,   w' = G - f,   f = max(0, (f_e + a k_s w) / (1 + a k_s lam))
    f_e = r_R min(x, sqrt(x_t x)) + r_g x,   r_R = k_R / k0,  r_g = k_g / k0,  a = A / theta

with the quadratures ``I2' = f^2``, ``L' = (f - f_e) x'`` and the settling test of
``equations.py``. Smooth at first touch, it needs no series start: Dormand & Prince's 5(4)
pair (J. Comput. Appl. Math. 6, 1980) integrates it from ``x = 0, w = 1``, with a cubic
Hermite dense output per step. A row of the history: ``s0, h, x0, w0, x0', w0', x1, w1,
x1', w1'``.
"""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels.dense import find_step, grow_history
from synth.physics.contact_kernels.equations import (
    MAX_STEPS,
    SEPARATED,
    SETTLED,
    STEP_TOO_SMALL,
)
from synth.physics.contact_kernels.outcome import R_XT, End, Scales, impact_row

S_T0, S_H, S_X0, S_W0, S_DX0, S_DW0, S_X1, S_W1, S_DX1, S_DW1 = range(10)
S_COLS = 10
#: Steps before the integration reports failure.
SHELL_STEP_LIMIT = 200_000
#: Absolute tolerance of the dimensionless state relative to the local one (as the
#: power laws' ``ABSOLUTE_FACTOR``).
SHELL_ABSOLUTE_FACTOR = 1e-6


# Dormand & Prince 5(4): nodes, coupling coefficients, 5th-order weights, and the
# difference of the 5th- and 4th-order weights (the error estimate).
_C2, _C3, _C4, _C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
_A21 = 1.0 / 5.0
_A31, _A32 = 3.0 / 40.0, 9.0 / 40.0
_A41, _A42, _A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
_A51, _A52, _A53, _A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
_A61, _A62, _A63, _A64, _A65 = (
    9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0,
)  # fmt: skip
_B1, _B3, _B4, _B5, _B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
_E1, _E3, _E4, _E5, _E6, _E7 = (
    71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0,
)  # fmt: skip


@compiled()
def shell_elastic(x, rR, xt, rg):
    """The elastic force ``f_e`` and the shell's tangent stiffness ``k_s`` (dimensionless)
    at the penetration ``x >= 0``."""
    if x < xt:
        return rR * x + rg * x, rR
    r = math.sqrt(xt * x)
    return rR * r + rg * x, 0.5 * rR * r / x


@compiled()
def shell_force(x, w, lam, rR, xt, rg, a):
    """The contact force ``f`` and its elastic part ``f_e`` (both 0 for ``x < 0``)."""
    if x < 0.0:
        return 0.0, 0.0
    fe, ks = shell_elastic(x, rR, xt, rg)
    if a == 0.0:
        return fe, fe
    f = (fe + a * ks * w) / (1.0 + a * ks * lam)
    if f < 0.0:
        f = 0.0
    return f, fe


@compiled()
def shell_potential(x, rR, xt, rg):
    """The potential ``U(x)`` of ``f_e`` (dimensionless), 0 for ``x <= 0``."""
    if x <= 0.0:
        return 0.0
    if x < xt:
        u = 0.5 * rR * x * x
    else:
        rt = math.sqrt(xt)
        u = rR * (0.5 * xt * xt + 2.0 / 3.0 * rt * (x * math.sqrt(x) - xt * rt))
    return u + 0.5 * rg * x * x


@compiled()
def shell_rhs(x, w, lam, G, rR, xt, rg, a):
    """``(x', w', I2', L')``."""
    f, fe = shell_force(x, w, lam, rR, xt, rg, a)
    dx = w - lam * f
    return dx, G - f, f * f, (f - fe) * dx


@compiled()
def hermite(hist, k, s):
    """The dense output ``(x, w)`` of row ``k`` at the time ``s``."""
    h = hist[k, S_H]
    t = (s - hist[k, S_T0]) / h
    t1 = 1.0 - t
    h00 = (1.0 + 2.0 * t) * t1 * t1
    h10 = t * t1 * t1 * h
    h01 = t * t * (3.0 - 2.0 * t)
    h11 = -t * t * t1 * h
    x = h00 * hist[k, S_X0] + h10 * hist[k, S_DX0] + h01 * hist[k, S_X1] + h11 * hist[k, S_DX1]
    w = h00 * hist[k, S_W0] + h10 * hist[k, S_DW0] + h01 * hist[k, S_W1] + h11 * hist[k, S_DW1]
    return x, w


@compiled()
def _root_in_row(hist, k, lam, rR, xt, rg, a, which):
    """The time in row ``k`` where, from positive at its start, the penetration
    (``which`` 0) or the force's numerator ``f_e + a k_s w`` (``which`` 1) first reaches 0:
    bisection on the dense output to the resolution of the time axis."""
    lo = hist[k, S_T0]
    hi = lo + hist[k, S_H]
    # the first sign change on a grid of the step, then bisection inside it
    n = 16
    step = (hi - lo) / n
    a_lo = lo
    for i in range(1, n + 1):
        s = lo + i * step if i < n else hi
        if _event(hist, k, s, lam, rR, xt, rg, a, which) <= 0.0:
            hi = s
            break
        a_lo = s
    lo = a_lo
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if _event(hist, k, mid, lam, rR, xt, rg, a, which) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@compiled()
def _event(hist, k, s, lam, rR, xt, rg, a, which):
    x, w = hermite(hist, k, s)
    if which == 0 or x < 0.0:
        return x
    fe, ks = shell_elastic(x, rR, xt, rg)
    return fe + a * ks * w


@compiled()
def _golden_max(hist, nh, lo, hi, lam, rR, xt, rg, a, which):
    """The largest penetration (``which`` 0) or force (1) on ``[lo, hi]`` of the dense
    output (golden-section search)."""
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    c = hi - g * (hi - lo)
    d = lo + g * (hi - lo)
    fc = _value(hist, nh, c, lam, rR, xt, rg, a, which)
    fd = _value(hist, nh, d, lam, rR, xt, rg, a, which)
    for _ in range(100):
        if hi - lo <= 1e-15 * max(1.0, abs(hi)):
            break
        if fc >= fd:
            hi, d, fd = d, c, fc
            c = hi - g * (hi - lo)
            fc = _value(hist, nh, c, lam, rR, xt, rg, a, which)
        else:
            lo, c, fc = c, d, fd
            d = lo + g * (hi - lo)
            fd = _value(hist, nh, d, lam, rR, xt, rg, a, which)
    return max(fc, fd)


@compiled()
def _value(hist, nh, s, lam, rR, xt, rg, a, which):
    x, w = hermite(hist, find_step(hist, nh, s), s)
    if which == 0:
        return x
    f, _ = shell_force(x, w, lam, rR, xt, rg, a)
    return f


@compiled()
def dp5_step(x, w, q2, q3, k1x, k1w, k1q, k1l, h, lam, G, rR, xt, rg, a):
    """One Dormand-Prince 5(4) step of length ``h`` from ``(x, w, I2, L)`` with the slopes
    ``k1`` there: the new state, its slopes (FSAL) and the error estimates of the four."""
    x2 = x + h * _A21 * k1x
    w2 = w + h * _A21 * k1w
    k2x, k2w, _, _ = shell_rhs(x2, w2, lam, G, rR, xt, rg, a)  # B2 = 0: k2 enters no sum
    x3 = x + h * (_A31 * k1x + _A32 * k2x)
    w3 = w + h * (_A31 * k1w + _A32 * k2w)
    k3x, k3w, k3q, k3l = shell_rhs(x3, w3, lam, G, rR, xt, rg, a)
    x4 = x + h * (_A41 * k1x + _A42 * k2x + _A43 * k3x)
    w4 = w + h * (_A41 * k1w + _A42 * k2w + _A43 * k3w)
    k4x, k4w, k4q, k4l = shell_rhs(x4, w4, lam, G, rR, xt, rg, a)
    x5 = x + h * (_A51 * k1x + _A52 * k2x + _A53 * k3x + _A54 * k4x)
    w5 = w + h * (_A51 * k1w + _A52 * k2w + _A53 * k3w + _A54 * k4w)
    k5x, k5w, k5q, k5l = shell_rhs(x5, w5, lam, G, rR, xt, rg, a)
    x6 = x + h * (_A61 * k1x + _A62 * k2x + _A63 * k3x + _A64 * k4x + _A65 * k5x)
    w6 = w + h * (_A61 * k1w + _A62 * k2w + _A63 * k3w + _A64 * k4w + _A65 * k5w)
    k6x, k6w, k6q, k6l = shell_rhs(x6, w6, lam, G, rR, xt, rg, a)
    xn = x + h * (_B1 * k1x + _B3 * k3x + _B4 * k4x + _B5 * k5x + _B6 * k6x)
    wn = w + h * (_B1 * k1w + _B3 * k3w + _B4 * k4w + _B5 * k5w + _B6 * k6w)
    qn = q2 + h * (_B1 * k1q + _B3 * k3q + _B4 * k4q + _B5 * k5q + _B6 * k6q)
    ln = q3 + h * (_B1 * k1l + _B3 * k3l + _B4 * k4l + _B5 * k5l + _B6 * k6l)
    k7x, k7w, k7q, k7l = shell_rhs(xn, wn, lam, G, rR, xt, rg, a)
    ex = h * (_E1 * k1x + _E3 * k3x + _E4 * k4x + _E5 * k5x + _E6 * k6x + _E7 * k7x)
    ew = h * (_E1 * k1w + _E3 * k3w + _E4 * k4w + _E5 * k5w + _E6 * k6w + _E7 * k7w)
    eq = h * (_E1 * k1q + _E3 * k3q + _E4 * k4q + _E5 * k5q + _E6 * k6q + _E7 * k7q)
    el = h * (_E1 * k1l + _E3 * k3l + _E4 * k4l + _E5 * k5l + _E6 * k6l + _E7 * k7l)
    return xn, wn, qn, ln, k7x, k7w, k7q, k7l, ex, ew, eq, el


@compiled()
def integrate(lam, G, rR, xt, rg, a, rtol, atol):
    """Integrate one contact from first touch: returns (status, s_end, x_end, w_end, I2,
    loss, n_steps, hist) with ``hist`` the dense output's rows."""
    hist = np.zeros((64, S_COLS))
    s, x, w, q2, q3 = 0.0, 0.0, 1.0, 0.0, 0.0
    k1x, k1w, k1q, k1l = shell_rhs(x, w, lam, G, rR, xt, rg, a)
    h = 0.01 * rtol**0.2
    nh = 0
    settle = 0.5 * (lam * G) ** 2
    for _ in range(SHELL_STEP_LIMIT):
        xn, wn, qn, ln, k7x, k7w, k7q, k7l, ex, ew, eq, el = dp5_step(
            x, w, q2, q3, k1x, k1w, k1q, k1l, h, lam, G, rR, xt, rg, a
        )
        # the energy quadratures are controlled too: the loss' integrand has a kink where
        # the force ends, which the state (x, w) hardly sees
        sx = atol + rtol * max(abs(x), abs(xn))
        sw = atol + rtol * max(abs(w), abs(wn))
        sq = atol + rtol * max(abs(q2), abs(qn))
        sl = atol + rtol * max(abs(q3), abs(ln))
        err = math.sqrt(0.25 * ((ex / sx) ** 2 + (ew / sw) ** 2 + (eq / sq) ** 2 + (el / sl) ** 2))
        if not err <= 1.0:
            h *= max(0.2, 0.9 * err**-0.2)
            if h <= 1e-14 * max(1.0, s):
                return STEP_TOO_SMALL, s, x, w, q2, q3, nh, hist[:nh]
            continue
        if (x - xt) * (xn - xt) < 0.0 and abs(x - xt) > 1e-9 * xt:
            # the step crosses the kink of the law (Reissner's to Pogorelov's, where the
            # force's slope halves): shorten it to end on the kink (Newton's method on the
            # step's length), so that no step straddles it and the order is kept
            hk = h * (xt - x) / (xn - x)
            for _ in range(4):
                trial = dp5_step(x, w, q2, q3, k1x, k1w, k1q, k1l, hk, lam, G, rR, xt, rg, a)
                xk, dxk = trial[0], trial[4]
                if dxk == 0.0:
                    break
                hk = min(max(hk - (xk - xt) / dxk, 0.0), h)
            xn, wn, qn, ln = dp5_step(x, w, q2, q3, k1x, k1w, k1q, k1l, hk, lam, G, rR, xt, rg, a)[
                :4
            ]
            xn = xt
            k7x, k7w, k7q, k7l = shell_rhs(xn, wn, lam, G, rR, xt, rg, a)
            h_next = h
            h = hk
        else:
            h_next = h * (min(5.0, max(0.2, 0.9 * err**-0.2)) if err > 0.0 else 5.0)
        hist = grow_history(hist, nh)
        row = hist[nh]
        row[S_T0], row[S_H] = s, h
        row[S_X0], row[S_W0], row[S_DX0], row[S_DW0] = x, w, k1x, k1w
        row[S_X1], row[S_W1], row[S_DX1], row[S_DW1] = xn, wn, k7x, k7w
        nh += 1
        # the end of contact: the penetration returns to 0 within the step (or dips
        # below it and back: the Hermite interpolant is tested on a grid)
        ends = xn < 0.0
        if not ends and k1x < 0.0 < k7x:
            for i in range(1, 16):
                xi, _ = hermite(hist, nh - 1, s + h * i / 16.0)
                if xi < 0.0:
                    ends = True
                    break
        if ends:
            # the root on the dense output, then refined by Newton's method on steps of
            # the integrator itself from the step's start (the dense output is of order 4)
            s_end = _root_in_row(hist, nh - 1, lam, rR, xt, rg, a, 0)
            for _ in range(3):
                xe, we, qe, le, dxe, _, _, _, _, _, _, _ = dp5_step(
                    x, w, q2, q3, k1x, k1w, k1q, k1l, s_end - s, lam, G, rR, xt, rg, a
                )
                if dxe >= 0.0:
                    break
                s_end -= xe / dxe
            return SEPARATED, s_end, 0.0, we, qe, le, nh, hist[:nh]
        s, x, w, q2, q3 = s + h, xn, wn, qn, ln
        k1x, k1w, k1q, k1l = k7x, k7w, k7q, k7l
        u = lam * G - w
        if 0.5 * u * u + shell_potential(x, rR, xt, rg) - G * x < settle and x > 0.0:
            return SETTLED, s, x, w, q2, q3, nh, hist[:nh]
        h = h_next
    return MAX_STEPS, s, x, w, q2, q3, nh, hist[:nh]


@compiled()
def shell_impact(m, k0, rR, xt_si, rg, A, beta, v_in, g, v_free, rtol):
    """One impact of the shell law from SI parameters (``k0`` N/m, ``xt_si`` the
    transition deflection m, ``A`` s, ``beta`` m/(N s)): returns the result array, its
    fields named by the ``R_*`` indices of ``outcome.py``, and the dense output (``hist``)."""
    v0 = v_in + v_free
    theta = math.sqrt(m / k0)
    L = theta * v0
    lam = beta * m / theta
    G = g * theta / v0
    a = A / theta
    xt = xt_si / L
    atol = rtol * SHELL_ABSOLUTE_FACTOR
    status, s_end, x_end, w_end, i2, loss, nh, hist = integrate(lam, G, rR, xt, rg, a, rtol, atol)
    s_contact = s_end
    if status == SETTLED:
        s_force = s_end
    elif status == SEPARATED:
        s_force = s_end
        if a != 0.0:
            k = nh - 1
            while k > 0:
                f, _ = shell_force(hist[k, S_X0], hist[k, S_W0], lam, rR, xt, rg, a)
                if f > 0.0:
                    break
                k -= 1
            # the last step that starts with a force holds its end
            s_force = min(_root_in_row(hist, k, lam, rR, xt, rg, a, 1), s_end)
    else:
        s_force = s_end
    # peaks: on the dense output around the largest step ends
    kx, kf, vx, vf = 0, 0, -1.0, -1.0
    for k in range(nh):
        if hist[k, S_X1] > vx:
            vx, kx = hist[k, S_X1], k
        fk, _ = shell_force(hist[k, S_X1], hist[k, S_W1], lam, rR, xt, rg, a)
        if fk > vf:
            vf, kf = fk, k
    x_max = max(vx, _golden_max(hist, nh, hist[kx, S_T0], _row_end(hist, nh, kx, s_contact),
                                lam, rR, xt, rg, a, 0))  # fmt: skip
    f_max = max(vf, _golden_max(hist, nh, hist[kf, S_T0], _row_end(hist, nh, kf, s_contact),
                                lam, rR, xt, rg, a, 1))  # fmt: skip
    e = End(status, s_contact, s_force, s_end, w_end, x_end, i2, loss, x_max, f_max, nh)
    sc = Scales(m, v_in, v0, theta, lam, G, m * v0 / theta)
    r = impact_row(e, shell_potential(x_end, rR, xt, rg), sc)
    r[R_XT] = xt
    return r, hist


@compiled()
def _row_end(hist, nh, k, s_contact):
    """The end of the step after row ``k`` (the peak may lie in either), within the contact."""
    j = min(k + 1, nh - 1)
    return min(hist[j, S_T0] + hist[j, S_H], s_contact)


@compiled()
def shell_force_slope(d, s, out, slope):
    """The force ``f`` and its rate ``df/ds`` (dimensionless) at the times ``s`` into
    ``out`` and ``slope``, 0 outside ``(0, s_contact)``, of the dense output ``d``
    (``contact_shell.ShellDense``): on the dense state, with
    ``x' = w - lam f``, ``w' = G - f`` and ``f = N / D``, ``N = f_e + a k_s w``,
    ``D = 1 + a k_s lam``: ``f' = (N' - f D') / D``, ``N' = (k_s + r_g) x' + a (k_s' w +
    k_s w')``, ``D' = a lam k_s'``, ``k_s' = -k_s x' / (2 x)`` past the transition, else 0."""
    hist, lam, G, rR, xt, rg, a = d.hist, d.lam, d.G, d.rR, d.xt, d.rg, d.a
    nh = hist.shape[0]
    for i in range(s.shape[0]):
        si = s[i]
        if si <= 0.0 or si >= d.s_contact:
            out[i] = 0.0
            slope[i] = 0.0
            continue
        x, w = hermite(hist, find_step(hist, nh, si), si)
        f, _ = shell_force(x, w, lam, rR, xt, rg, a)
        out[i] = f
        if x <= 0.0 or f <= 0.0:
            slope[i] = 0.0
            continue
        _, ks = shell_elastic(x, rR, xt, rg)
        dx = w - lam * f
        dks = 0.0 if x < xt else -0.5 * ks * dx / x
        dn = (ks + rg) * dx + a * (dks * w + ks * (G - f))
        slope[i] = (dn - f * a * lam * dks) / (1.0 + a * ks * lam)
