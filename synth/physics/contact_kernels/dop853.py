"""DOP853 stepper of the contact (numba; Hairer, Norsett & Wanner, "Solving ODEs I", II.10, their
dop853.f coefficients, scipy's error norm). The end of contact is a singularity (the force ~
(tau - s)^n switches off): steps land just past it so that none integrates across the kink.
"""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics import dop853_tableau as _dop
from synth.physics.contact_kernels import dense as _d
from synth.physics.contact_kernels import equations as _eq

# DOP853 tableau (Hairer's dop853.f)
_NS = _dop.N_STAGES  # 12
_A = np.ascontiguousarray(_dop.A[:_NS, :_NS])
_B = np.ascontiguousarray(_dop.B)
_C = np.ascontiguousarray(_dop.C[:_NS])
_E3 = np.ascontiguousarray(_dop.E3)
_E5 = np.ascontiguousarray(_dop.E5)
_D = np.ascontiguousarray(_dop.D)
_A_EXTRA = np.ascontiguousarray(_dop.A[_NS + 1 :])


@compiled()
def end_force_factor(w, c, b):
    """phi of the end force ``phi x^n`` at speed -w: ``1 + c w`` clipped at 0 (Hertz 1); 0
    with the viscoelastic loss, whose force ends before the contact (a free flight)."""
    if b != 0.0:
        return 0.0
    return max(0.0, 1.0 + c * w)


@compiled()
def _time_to_end(x, w, dx, P):
    """Time left to the end of contact after a step ending with x > 0, dx < 0, and the implied
    separation speed v; (inf, 0) while the ball moves down. Newton on the leading-order expansion
    of ``x`` and ``v`` in the force near the end, from ``sigma = x / (-x')``."""
    lam, G, n = P.lam, P.G, P.n
    u = -w
    if u <= 0.0:
        return np.inf, 0.0
    phi = end_force_factor(w, P.c, P.b)
    un = phi * _eq.power(u, n)
    sig = x / -dx
    for _ in range(6):
        sn = _eq.power(sig, n)
        v = u - G * sig + un * sn * sig / (n + 1.0)
        vn = phi * _eq.power(max(v, 0.0), n)
        g = u * sig - 0.5 * G * sig * sig + vn * sn * sig * (lam / (n + 1.0) + sig / (n + 2.0)) - x
        dg = u - G * sig + vn * sn * (lam + sig)
        if not dg > 0.0:
            break
        step = g / dg
        sig -= step
        if not sig > 0.0:
            return x / -dx, u
        if abs(step) <= 1e-12 * sig:
            break
    return sig, u - G * sig + un * _eq.power(sig, n) * sig / (n + 1.0)


@compiled()
def _switch_fraction(x0, w0, x1, w1, dx0, dw0, dx1, dw1, h, c, b):
    """Fraction of a step where the viscoelastic force switches off or on (``q = x (1 + c w) +
    b w`` changes sign, cubic Hermite estimate); 1 if it does not."""
    q0 = x0 * (1.0 + c * w0) + b * w0
    q1 = x1 * (1.0 + c * w1) + b * w1
    if (q0 > 0.0) == (q1 > 0.0):
        return 1.0
    dq0 = h * (dx0 * (1.0 + c * w0) + (x0 * c + b) * dw0)
    dq1 = h * (dx1 * (1.0 + c * w1) + (x1 * c + b) * dw1)
    if q0 > 0.0:
        return _d.hermite_root(q0, q1, dq0, dq1)
    return _d.hermite_root(-q0, -q1, -dq0, -dq1)


@compiled()
def _landing_factor(n):
    """kappa(n): scipy's error norm of a step ending where ``f ~ (v (tau - s))^n`` switches off
    is ``kappa v^(n-1) h^(n+1) / rtol``; 0 for an integer n (integrated exactly)."""
    e5 = 0.0
    e3 = 0.0
    for i in range(_NS + 1):
        g = _eq.power(1.0 - _C[i], n) if i < _NS else 0.0
        e5 += _E5[i] * g
        e3 += _E3[i] * g
    if e5 == 0.0:
        return 0.0
    return e5 * e5 / math.sqrt(3.0 * (e5 * e5 + 0.01 * e3 * e3))


@compiled(inline="always")
def _weighted(weights, K, m, q):
    """``sum_{i < m} weights[i] K[i, q]``, summed in order of ``i``."""
    acc = weights[0] * K[0, q]
    for i in range(1, m):
        acc += weights[i] * K[i, q]
    return acc


@compiled(inline="always")
def _stage(A, row, K, i, x, w, h, P, xm):
    """Stage ``i`` from ``(x, w)`` into ``K[i]`` (I2 and the loss are quadratures)."""
    a0 = 0.0
    a1 = 0.0
    for j in range(i):
        a0 += A[row, j] * K[j, 0]
        a1 += A[row, j] * K[j, 1]
    K[i, 0], K[i, 1], K[i, 2], K[i, 3] = _eq.rhs(P, x + h * a0, w + h * a1, xm)


@compiled()
def integrate_dop853(P, rtol, atol, max_steps, hist, s, x, w, q2, q3, h):
    """DOP853 on (x, w, I2, L) of law ``P`` from time s, state (x, w, q2, q3), first step h,
    history row 0 filled; its :data:`~.equations.Integration`."""
    lam, G, n, c, b = P.lam, P.G, P.n, P.c, P.b
    xm = 0.0  # the largest penetration once past a yielded peak (0 while loading)
    xp = 0.0  # the residual penetration, where the unloading force ends
    K = np.empty((16, 4))
    K[0, 0], K[0, 1], K[0, 2], K[0, 3] = _eq.rhs(P, x, w, xm)
    nst = np.int64(1)  # not the literal 1: numba would compile grow_history for it too
    settle = G > 0.0 and (lam > 0.0 or c > 0.0 or b > 0.0)  # W falls: the ball can settle
    wthr = 0.5 * (lam * G) ** 2
    # past the first peak or an overdamped creep's end: a settled pulse keeps its landing
    peaked = False
    rejected = False
    h_rej = 0.0
    err_rej = 0.0
    landing = False  # this step is meant to end just past the end of contact
    land_max = np.inf  # farthest a landing may start from, once one has failed
    kappa = -1.0  # _landing_factor(n), when first needed
    # x is measured against its largest value so far: near the end of contact an error
    # dx moves the end by dx / x', and the contact time is of order one
    x_top = x
    while True:
        if nst > max_steps or not math.isfinite(s + h):
            # an unbounded step (a state that no event ends) counts as the step limit
            return _eq.Integration(_eq.MAX_STEPS, s, x, w, q2, q3, nst, hist)
        if not (h >= 1e-14 * s and h >= 1e-300):
            return _eq.Integration(_eq.STEP_TOO_SMALL, s, x, w, q2, q3, nst, hist)
        for i in range(1, _NS):
            _stage(_A, i, K, i, x, w, h, P, xm)
        xn = x + h * _weighted(_B, K, _NS, 0)
        wn = w + h * _weighted(_B, K, _NS, 1)
        q2n = q2 + h * _weighted(_B, K, _NS, 2)
        q3n = q3 + h * _weighted(_B, K, _NS, 3)
        K[_NS, 0], K[_NS, 1], K[_NS, 2], K[_NS, 3] = _eq.rhs(P, xn, wn, xm)
        # scipy's norm on x, w, I2, and with the viscoelastic loss on L too: L' = -x^n x'
        # ends like (tau - s)^n, and the landing steps are sized for it
        components = 4.0 if b != 0.0 else 3.0
        old = (x, w, q2, q3)
        new = (xn, wn, q2n, q3n)
        e5 = 0.0
        e3 = 0.0
        for q in range(int(components)):
            sc = atol + rtol * (max(x_top, abs(xn)) if q == 0 else max(abs(old[q]), abs(new[q])))
            e5 += (_weighted(_E5, K, _NS + 1, q) / sc) ** 2
            e3 += (_weighted(_E3, K, _NS + 1, q) / sc) ** 2
        if e5 == 0.0 and e3 == 0.0:
            err = 0.0
        else:
            err = h * e5 / math.sqrt((e5 + 0.01 * e3) * components)
        if err >= 1.0 or not math.isfinite(err):
            if landing and math.isfinite(err):
                # The landing failed (its error ~ h^(n+1)): step to where one should pass.
                land_max = 0.9 * h * err ** (-1.0 / (n + 1.0))
                h = max(h - 0.9 * land_max, 0.5 * h)
                landing = False
                rejected = True
                continue
            # near the end the error falls slower than h^8: after a second rejection at the
            # same point, shrink by the order observed between the two trials
            p = 8.0
            if rejected and h_rej > h and err_rej > err and math.isfinite(err):
                p = min(8.0, max(1.0, math.log(err_rej / err) / math.log(h_rej / h)))
            fac = 0.9 * err ** (-1.0 / p) if math.isfinite(err) else 0.2
            h_rej = h
            err_rej = err
            h *= max(0.1, fac)
            landing = False
            rejected = True
            continue
        if xn > 0.0 and _d.hermite_dips(x, xn, h * K[0, 0], h * K[_NS, 0]):
            # separated and landed again inside the step: redo it shorter
            h *= 0.5
            landing = False
            rejected = True
            continue
        th = 1.0
        if xn < 0.0:
            # the step crosses the end of contact, a kink its error estimate and dense output
            # do not trust: redo it to land just past the root (cubic Hermite estimate)
            th = _d.hermite_root(x, xn, h * K[0, 0], h * K[_NS, 0])
        if _d.yield_peak_at_start(x, h * K[0, 0], h * K[_NS, 0], P.xy, xm):
            # the yielded peak is here (force continuous): redo the step unloading from it
            xm, xp, q3 = _eq.yielded_peak(P.xy, x, 0.0, xm, xp, q3)
            continue
        th = min(th, _d.yield_fraction(x, xn, h * K[0, 0], h * K[_NS, 0], P.xy, xm, xp))
        if b != 0.0:
            # the viscoelastic force switches off (or on) inside the contact: a kink of the
            # same kind, landed on as well (the earlier of the two)
            th = min(
                th,
                _switch_fraction(
                    x - xp, w, xn - xp, wn, K[0, 0], K[0, 1], K[_NS, 0], K[_NS, 1], h, c, b
                ),
            )
        if th < 0.999:
            h *= th * 1.0001 + 1e-9
            continue
        hist = _d.grow_history(hist, nst)
        for i in range(_NS + 1, 16):
            _stage(_A_EXTRA, i - _NS - 1, K, i, x, w, h, P, xm)
        hist[nst, _d.H_T0] = s
        hist[nst, _d.H_XM] = xm
        hist[nst, _d.H_H] = h
        hist[nst, _d.H_X0] = x
        hist[nst, _d.H_W0] = w
        for q in range(2):
            base = _d.H_COEF + 7 * q
            dy = xn - x if q == 0 else wn - w
            hist[nst, base] = dy
            hist[nst, base + 1] = h * K[0, q] - dy
            hist[nst, base + 2] = 2.0 * dy - h * (K[_NS, q] + K[0, q])
            for r in range(4):
                acc = 0.0
                for j in range(16):
                    acc += _D[r, j] * K[j, q]
                hist[nst, base + 3 + r] = h * acc
        nst += 1
        s += h
        x = xn
        w = wn
        q2 = q2n
        q3 = q3n
        x_top = max(x_top, x)
        for q in range(4):
            K[0, q] = K[_NS, q]
        # on a yielded peak the first stage stands: force and contact radius are continuous
        xm, xp, q3 = _eq.yielded_peak(P.xy, x, K[0, 0], xm, xp, q3)
        if x <= 0.0:
            return _eq.Integration(_eq.SEPARATED, s, x, w, q2, q3, nst, hist)
        if _eq.rise_ended(K[0, 0], w, atol):
            peaked = True
        if settle and peaked and _eq.settling_energy(P, x, w, xm) < wthr:
            return _eq.Integration(_eq.SETTLED, s, x, w, q2, q3, nst, hist)
        fac = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
        if rejected:
            fac = min(1.0, fac)
            rejected = False
        h_done = h
        h *= fac
        landing = False
        if K[0, 0] < 0.0:
            # moving apart: a step ending at the singular end has an error ~ h^(n+1) of known
            # size (_landing_factor): land just past the end, or stop where a landing may start
            sig = x / -K[0, 0]  # a first estimate, sharpened near the end
            reach = land_max
            if h >= 0.5 * sig:
                sig, v = _time_to_end(x, w, K[0, 0], P)
                if kappa < 0.0:
                    kappa = _landing_factor(n)
                size = kappa * end_force_factor(-v, c, b) * _eq.power(v, n - 1.0)
                size *= 1.0 + lam * v / x_top
                if size > 0.0:
                    reach = min(reach, (0.8 * rtol / size) ** (1.0 / (n + 1.0)))
                if sig <= min(h, reach):
                    h = sig * 1.0001
                    landing = True
            if not landing and sig < np.inf:
                # the error constant grows as the end nears: keep the step's ratio to the time left
                h *= sig / (sig + h_done)
                if h >= sig:
                    h = max(sig - 0.9 * reach, 0.5 * sig)
