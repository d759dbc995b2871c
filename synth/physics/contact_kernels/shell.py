"""numba kernels of a hollow ball's thin-shell contact (docs/physics.md, "Hollow balls"), scaled by
``theta = sqrt(m / k0)``: Dormand & Prince's 5(4) pair with a cubic Hermite dense output.
History row: ``s0, h, x0, w0, x0', w0', x1, w1, x1', w1'``."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels.dense import find_step, grow_history

S_T0, S_H, S_X0, S_W0, S_DX0, S_DW0, S_X1, S_W1, S_DX1, S_DW1 = range(10)
S_COLS = 10
#: ``which`` of the root and peak searches: the deflection or the force. numpy integers: numba
#: compiles a literal int once per value.
_DEFLECTION = np.int64(0)
_FORCE = np.int64(1)
#: Steps before the integration reports failure.
SHELL_STEP_LIMIT = 200_000
#: Absolute tolerance relative to the local one (as the power laws' ``ABSOLUTE_FACTOR``).
SHELL_ABSOLUTE_FACTOR = 1e-6

#: The dimensionless shell law (docs/physics.md, "Hollow balls"), the kernels' one argument for it.
Shell = namedtuple("Shell", ("lam", "G", "rR", "xt", "rg", "a"))

#: Dormand & Prince 5(4): coupling rows, the last the 5th-order weights (its stage is the next
#: step's first), and the error weights; the rolling contact's too (:mod:`~synth.physics.
#: rolling_kernels`).
DP5_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
])  # fmt: skip
DP5_E = np.array([
    71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
    -1.0 / 40.0,
])  # fmt: skip


@compiled()
def shell_elastic(x, law):
    """Elastic force ``f_e`` and tangent stiffness ``k_s`` (dimensionless) at ``x >= 0``."""
    if x < law.xt:
        return law.rR * x + law.rg * x, law.rR
    r = math.sqrt(law.xt * x)
    return law.rR * r + law.rg * x, 0.5 * law.rR * r / x


@compiled()
def shell_force(x, w, law):
    """The contact force ``f`` and its elastic part ``f_e`` (both 0 for ``x < 0``)."""
    if x < 0.0:
        return 0.0, 0.0
    fe, ks = shell_elastic(x, law)
    if law.a == 0.0:
        return fe, fe
    f = (fe + law.a * ks * w) / (1.0 + law.a * ks * law.lam)
    return (f if f > 0.0 else 0.0), fe


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
def shell_rhs(y, law, out):
    """``(x', w', I2', L')`` at the state ``y = (x, w, ...)`` into ``out``."""
    f, fe = shell_force(y[0], y[1], law)
    dx = y[1] - law.lam * f
    out[0], out[1], out[2], out[3] = dx, law.G - f, f * f, (f - fe) * dx


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
def _root_in_row(hist, k, law, which):
    """Time in row ``k`` where x (``which`` 0) or the force's numerator (1) first reaches 0."""
    lo = hist[k, S_T0]
    hi = lo + hist[k, S_H]
    step = (hi - lo) / 16
    a_lo = lo
    for i in range(1, 17):
        s = lo + i * step if i < 16 else hi
        if _event(hist, k, s, law, which) <= 0.0:
            hi = s
            break
        a_lo = s
    lo = a_lo
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if _event(hist, k, mid, law, which) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@compiled()
def _event(hist, k, s, law, which):
    x, w = hermite(hist, k, s)
    if which == 0 or x < 0.0:
        return x
    fe, ks = shell_elastic(x, law)
    return fe + law.a * ks * w


@compiled()
def _golden_max(hist, nh, k, s_contact, law, which):
    """Largest x (``which`` 0) or force (1) from row ``k`` to the next's end (golden section)."""
    j = min(k + 1, nh - 1)
    lo = hist[k, S_T0]
    hi = min(hist[j, S_T0] + hist[j, S_H], s_contact)
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    c = hi - g * (hi - lo)
    d = lo + g * (hi - lo)
    fc = _value(hist, nh, c, law, which)
    fd = _value(hist, nh, d, law, which)
    for _ in range(100):
        if hi - lo <= 1e-15 * max(1.0, abs(hi)):
            break
        if fc >= fd:
            hi, d, fd = d, c, fc
            c = hi - g * (hi - lo)
            fc = _value(hist, nh, c, law, which)
        else:
            lo, c, fc = c, d, fd
            d = lo + g * (hi - lo)
            fd = _value(hist, nh, d, law, which)
    return max(fc, fd)


@compiled()
def _value(hist, nh, s, law, which):
    x, w = hermite(hist, find_step(hist, nh, s), s)
    return x if which == 0 else shell_force(x, w, law)[0]


@compiled()
def dp5_step(y, K, h, law, yn, err):
    """One Dormand-Prince 5(4) step ``h`` from ``y`` with slopes ``K[0]``: state into ``yn``,
    stages into ``K`` (``K[6]`` at ``yn``), error estimates into ``err``."""
    for q in range(4):  # (h a21) k1, as Dormand & Prince's second stage is written
        yn[q] = y[q] + h * DP5_A[1, 0] * K[0, q]
    shell_rhs(yn, law, K[1])
    for i in range(2, 7):
        for q in range(4):
            acc = DP5_A[i, 0] * K[0, q]
            for j in range(1, i):
                acc += DP5_A[i, j] * K[j, q]
            yn[q] = y[q] + h * acc
        shell_rhs(yn, law, K[i])
    for q in range(4):
        acc = DP5_E[0] * K[0, q]
        for j in range(1, 7):
            acc += DP5_E[j] * K[j, q]
        err[q] = h * acc


@compiled()
def _kink_step(y, K, h, law, yn, err):
    """Length of the step from ``y`` ending on the kink ``x = x_t`` (Newton); state in ``yn``."""
    xt = law.xt
    hk = h * (xt - y[0]) / (yn[0] - y[0])
    for _ in range(4):
        dp5_step(y, K, hk, law, yn, err)
        if K[6, 0] == 0.0:
            break
        hk = min(max(hk - (yn[0] - xt) / K[6, 0], 0.0), h)
    dp5_step(y, K, hk, law, yn, err)
    return hk


@compiled()
def integrate(law, rtol, atol):
    """One contact from first touch: its :data:`~.equations.Integration`."""
    hist = np.zeros((64, S_COLS))
    s = 0.0
    y = np.array([0.0, 1.0, 0.0, 0.0])
    yn = np.empty(4)
    err = np.empty(4)
    K = np.empty((7, 4))
    shell_rhs(y, law, K[0])
    h = 0.01 * rtol**0.2
    nh = np.int64(0)  # not the literal 0: numba would compile grow_history for it too
    settle = 0.5 * (law.lam * law.G) ** 2
    xt = law.xt
    for _ in range(SHELL_STEP_LIMIT):
        dp5_step(y, K, h, law, yn, err)
        # the quadratures are controlled too: the loss has a kink where the force ends
        e = 0.0
        for q in range(4):
            e += (err[q] / (atol + rtol * max(abs(y[q]), abs(yn[q])))) ** 2
        e = math.sqrt(0.25 * e)
        if not e <= 1.0:
            h *= max(0.2, 0.9 * e**-0.2)
            if h <= 1e-14 * max(1.0, s):
                return _eq.Integration(_eq.STEP_TOO_SMALL, s, y[0], y[1], y[2], y[3], nh, hist[:nh])
            continue
        x, xn = y[0], yn[0]
        if (x - xt) * (xn - xt) < 0.0 and abs(x - xt) > 1e-9 * xt:
            # the step crosses the law's kink (Reissner's to Pogorelov's): end it on the kink
            # so that the order is kept
            hk = _kink_step(y, K, h, law, yn, err)
            yn[0] = xt
            shell_rhs(yn, law, K[6])
            h_next = h
            h = hk
        else:
            h_next = h * (min(5.0, max(0.2, 0.9 * e**-0.2)) if e > 0.0 else 5.0)
        hist = grow_history(hist, nh)
        row = hist[nh]
        row[S_T0], row[S_H] = s, h
        row[S_X0], row[S_W0], row[S_DX0], row[S_DW0] = y[0], y[1], K[0, 0], K[0, 1]
        row[S_X1], row[S_W1], row[S_DX1], row[S_DW1] = yn[0], yn[1], K[6, 0], K[6, 1]
        nh += 1
        # end of contact: x returns to 0 in the step, or dips and returns (grid test)
        ends = yn[0] < 0.0
        if not ends and K[0, 0] < 0.0 < K[6, 0]:
            for i in range(1, 16):
                if hermite(hist, nh - 1, s + h * i / 16.0)[0] < 0.0:
                    ends = True
                    break
        if ends:
            # the root on the dense output (order 4), refined by Newton on integrator steps
            s_end = _root_in_row(hist, nh - 1, law, _DEFLECTION)
            for _ in range(3):
                dp5_step(y, K, s_end - s, law, yn, err)
                if K[6, 0] >= 0.0:
                    break
                s_end -= yn[0] / K[6, 0]
            return _eq.Integration(_eq.SEPARATED, s_end, 0.0, yn[1], yn[2], yn[3], nh, hist[:nh])
        s += h
        for q in range(4):
            y[q] = yn[q]
            K[0, q] = K[6, q]
        u = law.lam * law.G - y[1]
        if (
            y[0] > 0.0
            and 0.5 * u * u + shell_potential(y[0], law.rR, xt, law.rg) - law.G * y[0] < settle
        ):
            return _eq.Integration(_eq.SETTLED, s, y[0], y[1], y[2], y[3], nh, hist[:nh])
        h = h_next
    return _eq.Integration(_eq.MAX_STEPS, s, y[0], y[1], y[2], y[3], nh, hist[:nh])


@compiled()
def shell_impact(m, k0, rR, xt_si, rg, A, beta, v_in, g, v_free, rtol):
    """A shell impact (``k0`` N/m, ``xt_si`` m, ``A`` s, ``beta`` m/(N s)): result, dense output."""
    v0 = v_in + v_free
    theta = math.sqrt(m / k0)
    lam = beta * m / theta
    G = g * theta / v0
    law = Shell(lam, G, rR, xt_si / (theta * v0), rg, A / theta)
    atol = rtol * SHELL_ABSOLUTE_FACTOR
    out = integrate(law, rtol, atol)
    status, s_end, nh, hist = out.status, out.s, out.nh, out.hist
    s_contact = s_end
    s_force = s_end
    if status == _eq.SEPARATED and law.a != 0.0:
        # the last step that starts with a force holds its end
        k = nh - 1
        while k > 0 and shell_force(hist[k, S_X0], hist[k, S_W0], law)[0] <= 0.0:
            k -= 1
        s_force = min(_root_in_row(hist, k, law, _FORCE), s_end)
    # peaks: on the dense output around the largest step ends
    # int64 from the start: a literal 0 would compile _golden_max a second time
    kx, kf, vx, vf = np.int64(0), np.int64(0), -1.0, -1.0
    for k in range(nh):
        if hist[k, S_X1] > vx:
            vx, kx = hist[k, S_X1], k
        fk, _ = shell_force(hist[k, S_X1], hist[k, S_W1], law)
        if fk > vf:
            vf, kf = fk, k
    x_max = max(vx, _golden_max(hist, nh, kx, s_contact, law, _DEFLECTION))
    f_max = max(vf, _golden_max(hist, nh, kf, s_contact, law, _FORCE))
    e = _eq.End(status, s_contact, s_force, s_end, out.w, out.x, out.i2, out.loss, x_max, f_max, nh)
    sc = _eq.Scales(m, v_in, v0, theta, lam, G, m * v0 / theta)
    r = _eq.impact_row(e, shell_potential(out.x, rR, law.xt, rg), sc)
    r[_eq.R_XT] = law.xt
    return r, hist


@compiled()
def shell_force_slope(d, s, out, slope):
    """Force ``f`` and rate ``df/ds`` (dimensionless) at times ``s`` into ``out``, ``slope``, 0
    outside ``(0, s_contact]``: ``f' = (N' - f D') / D`` with ``N = f_e + a k_s w``, ``D = 1 +
    a k_s lam``, ``k_s' = -k_s x' / (2 x)`` past the transition."""
    hist, law = d.hist, d.law
    lam, G, rg, a = law.lam, law.G, law.rg, law.a
    nh = hist.shape[0]
    for i in range(s.shape[0]):
        si = s[i]
        if si <= 0.0 or si > d.s_contact:
            out[i] = 0.0
            slope[i] = 0.0
            continue
        x, w = hermite(hist, find_step(hist, nh, si), si)
        f, _ = shell_force(x, w, law)
        out[i] = f
        if x <= 0.0 or f <= 0.0:
            slope[i] = 0.0
            continue
        _, ks = shell_elastic(x, law)
        dx = w - lam * f
        dks = 0.0 if x < law.xt else -0.5 * ks * dx / x
        dn = (ks + rg) * dx + a * (dks * w + ks * (G - f))
        slope[i] = (dn - f * a * lam * dks) / (1.0 + a * ks * lam)
