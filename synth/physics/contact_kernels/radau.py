"""Radau IIA stepper of the contact, 3 stages, order 5 (numba; Hairer & Wanner, "Solving ODEs
II", IV.8, as scipy.integrate.Radau), for the stiff range (lam >> 1); Newton's 2x2 systems
solved in closed form.
"""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels import dense as _d
from synth.physics.contact_kernels import equations as _eq

# Radau IIA (order 5) constants, as scipy.integrate.Radau
_S6 = 6.0**0.5
_RC = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
_RE = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0
_MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)
_MU_C_RE = 3.0 + 0.5 * (3.0 ** (1.0 / 3.0) - 3.0 ** (2.0 / 3.0))
_MU_C_IM = -0.5 * (3.0 ** (5.0 / 6.0) + 3.0 ** (7.0 / 6.0))
_RT = np.array([
    [0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
    [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
    [1.0, 1.0, 0.0],
])  # fmt: skip
_RTI = np.array([
    [4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
    [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
    [0.50287263494578682, -2.57192694985560522, 0.59603920482822492],
])  # fmt: skip
_RP = np.array([
    [13.0 / 3.0 + 7.0 * _S6 / 3.0, -23.0 / 3.0 - 22.0 * _S6 / 3.0, 10.0 / 3.0 + 5.0 * _S6],
    [13.0 / 3.0 - 7.0 * _S6 / 3.0, -23.0 / 3.0 + 22.0 * _S6 / 3.0, 10.0 / 3.0 - 5.0 * _S6],
    [1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0],
])  # fmt: skip
# Quadrature weights of the Radau IIA collocation (last row of its A matrix).
_RB = np.array([(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0])
_NEWTON_MAXITER = 6


@compiled(inline="always")
def _solve2(a, b, c, d, det, u0, u1):
    """``z`` of ``[[a, b], [c, d]] z = u`` by Cramer's rule (``det = a d - b c``)."""
    return (d * u0 - b * u1) / det, (a * u1 - c * u0) / det


@compiled(inline="always")
def _newton_rhs(F, Wt, q, mr, mc):
    """Component ``q`` of the real and complex transformed Newton systems' ``T^-1 F - mu W``."""
    fr = _RTI[0, 0] * F[0, q] + _RTI[0, 1] * F[1, q] + _RTI[0, 2] * F[2, q] - mr * Wt[0, q]
    fc = (
        complex(_RTI[1, 0], _RTI[2, 0]) * F[0, q]
        + complex(_RTI[1, 1], _RTI[2, 1]) * F[1, q]
        + complex(_RTI[1, 2], _RTI[2, 2]) * F[2, q]
        - mc * complex(Wt[1, q], Wt[2, q])
    )
    return fr, fc


@compiled()
def integrate_radau(P, rtol, atol, max_steps, hist, s, x, w, q2, q3, h):
    """Radau IIA on (x, w), I2 and the loss by collocation; as ``integrate_dop853``."""
    lam, G, c, b = P.lam, P.G, P.c, P.b
    xm = 0.0  # the largest penetration once past a yielded peak (0 while loading)
    xp = 0.0  # the residual penetration, where the unloading force ends
    y = np.array([x, w, q2, q3])
    Z = np.zeros((3, 2))
    Wt = np.zeros((3, 2))
    F = np.zeros((3, 2))
    fq = np.zeros((3, 2))  # f and (f - a) x' at the stages, for the quadratures
    f0 = np.empty(4)
    f0[0], f0[1], f0[2], f0[3] = _eq.rhs(P, y[0], y[1], xm)
    h_old = -1.0
    err_old = -1.0
    nst = np.int64(1)  # not the literal 1: numba would compile grow_history for it too
    settle = G > 0.0 and (lam > 0.0 or c > 0.0 or b > 0.0)  # W falls: the ball can settle
    wthr = 0.5 * (lam * G) ** 2
    peaked = False
    have_dense = False
    newton_tol = max(10.0 * 2.220446049250313e-16 / rtol, min(0.03, rtol**0.5))
    j11, j12, j21, j22 = _eq.jacobian(P, y[0], y[1], xm)
    rejected = False
    while True:
        if nst > max_steps or not math.isfinite(s + h):
            # an unbounded step (a state that no event ends) counts as the step limit
            return _eq.Integration(_eq.MAX_STEPS, s, y[0], y[1], y[2], y[3], nst, hist)
        if not (h >= 1e-14 * s and h >= 1e-300):
            return _eq.Integration(_eq.STEP_TOO_SMALL, s, y[0], y[1], y[2], y[3], nst, hist)
        sc0 = atol + rtol * abs(y[0])
        sc1 = atol + rtol * abs(y[1])
        # initial guess from the previous step's collocation polynomial
        for i in range(3):
            if have_dense:
                xg, wg = _d.radau_dense(hist, nst - 1, s + h * _RC[i])
                Z[i, 0] = xg - y[0]
                Z[i, 1] = wg - y[1]
            else:
                Z[i, 0] = 0.0
                Z[i, 1] = 0.0
        mr = _MU_REAL / h
        mc_re = _MU_C_RE / h
        mc_im = _MU_C_IM / h
        # real system (mr I - J), complex system (mc I - J): 2x2, solved in closed form
        ra, rb, rc_, rd = mr - j11, -j12, -j21, mr - j22
        rdet = ra * rd - rb * rc_
        ca = complex(mc_re, mc_im) - j11
        cd = complex(mc_re, mc_im) - j22
        cb = complex(-j12, 0.0)
        cc = complex(-j21, 0.0)
        cdet = ca * cd - cb * cc
        for i in range(3):
            for q in range(2):
                Wt[i, q] = _RTI[i, 0] * Z[0, q] + _RTI[i, 1] * Z[1, q] + _RTI[i, 2] * Z[2, q]
        converged = False
        rate = -1.0
        dw_old = -1.0
        n_iter = 0
        for it in range(_NEWTON_MAXITER):
            n_iter = it + 1
            ok = True
            for i in range(3):
                F[i, 0], F[i, 1], _, _ = _eq.rhs(P, y[0] + Z[i, 0], y[1] + Z[i, 1], xm)
                if not (math.isfinite(F[i, 0]) and math.isfinite(F[i, 1])):
                    ok = False
            if not ok:
                break
            mcx = complex(mc_re, mc_im)
            fr0, fc0 = _newton_rhs(F, Wt, 0, mr, mcx)
            fr1, fc1 = _newton_rhs(F, Wt, 1, mr, mcx)
            d0, d1 = _solve2(ra, rb, rc_, rd, rdet, fr0, fr1)
            z0, z1 = _solve2(ca, cb, cc, cd, cdet, fc0, fc1)
            dn = (
                (d0 / sc0) ** 2
                + (d1 / sc1) ** 2
                + (z0.real / sc0) ** 2
                + (z0.imag / sc0) ** 2
                + (z1.real / sc1) ** 2
                + (z1.imag / sc1) ** 2
            )
            dn = math.sqrt(dn / 6.0)
            if dw_old >= 0.0:
                rate = dn / dw_old if dw_old > 0.0 else 0.0
            if rate >= 0.0 and (
                rate >= 1.0 or rate ** (_NEWTON_MAXITER - it) / (1.0 - rate) * dn > newton_tol
            ):
                break
            Wt[0, 0] += d0
            Wt[0, 1] += d1
            Wt[1, 0] += z0.real
            Wt[1, 1] += z1.real
            Wt[2, 0] += z0.imag
            Wt[2, 1] += z1.imag
            for i in range(3):
                for q in range(2):
                    Z[i, q] = _RT[i, 0] * Wt[0, q] + _RT[i, 1] * Wt[1, q] + _RT[i, 2] * Wt[2, q]
            if dn == 0.0 or (rate >= 0.0 and rate / (1.0 - rate) * dn < newton_tol):
                converged = True
                break
            dw_old = dn
        if not converged:
            # refresh the Jacobian at the step start and halve the step
            j11, j12, j21, j22 = _eq.jacobian(P, y[0], y[1], xm)
            h *= 0.5
            rejected = True
            continue
        xn = y[0] + Z[2, 0]
        wn = y[1] + Z[2, 1]
        ze0 = (_RE[0] * Z[0, 0] + _RE[1] * Z[1, 0] + _RE[2] * Z[2, 0]) / h
        ze1 = (_RE[0] * Z[0, 1] + _RE[1] * Z[1, 1] + _RE[2] * Z[2, 1]) / h
        e0, e1 = _solve2(ra, rb, rc_, rd, rdet, f0[0] + ze0, f0[1] + ze1)
        s0 = atol + rtol * max(abs(y[0]), abs(xn))
        s1 = atol + rtol * max(abs(y[1]), abs(wn))
        err = math.sqrt(((e0 / s0) ** 2 + (e1 / s1) ** 2) / 2.0)
        if rejected and err > 1.0:
            r0, r1, _, _ = _eq.rhs(P, y[0] + e0, y[1] + e1, xm)
            e0, e1 = _solve2(ra, rb, rc_, rd, rdet, r0 + ze0, r1 + ze1)
            err = math.sqrt(((e0 / s0) ** 2 + (e1 / s1) ** 2) / 2.0)
        safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
        if err > 1.0 or not math.isfinite(err):
            if h_old > 0.0 and err_old > 0.0 and math.isfinite(err):
                mult = min(1.0, h / h_old * (err_old / err) ** 0.25)
            else:
                mult = 1.0
            fac = mult * err**-0.25 if math.isfinite(err) and err > 0 else 0.2
            h *= max(0.2, safety * fac)
            rejected = True
            j11, j12, j21, j22 = _eq.jacobian(P, y[0], y[1], xm)
            continue
        dxn = _eq.rhs(P, xn, wn, xm)[0]
        if xn > 0.0 and _d.hermite_dips(y[0], xn, h * f0[0], h * dxn):
            # separated and landed again inside the step (see ``integrate_dop853``)
            h *= 0.5
            rejected = True
            j11, j12, j21, j22 = _eq.jacobian(P, y[0], y[1], xm)
            continue
        if _d.yield_peak_at_start(y[0], h * f0[0], h * dxn, P.xy, xm):
            # the yielded peak is here (``integrate_dop853``): redo the step unloading from it
            xm, xp, y[3] = _eq.yielded_peak(P.xy, y[0], 0.0, xm, xp, y[3])
            rejected = True
            j11, j12, j21, j22 = _eq.jacobian(P, y[0], y[1], xm)
            continue
        # land on the yielded peak or the end of the unloading force (``yield_fraction``)
        th = _d.yield_fraction(y[0], xn, h * f0[0], h * dxn, P.xy, xm, xp)
        if th < 0.999:
            h *= th * 1.0001 + 1e-9
            rejected = True
            continue
        hist = _d.grow_history(hist, nst)
        hist[nst, _d.H_T0] = s
        hist[nst, _d.H_H] = h
        hist[nst, _d.H_X0] = y[0]
        hist[nst, _d.H_W0] = y[1]
        hist[nst, _d.H_XM] = xm
        for q in range(2):
            for r in range(3):
                hist[nst, _d.H_COEF + 3 * q + r] = (
                    Z[0, q] * _RP[0, r] + Z[1, q] * _RP[1, r] + Z[2, q] * _RP[2, r]
                )
        # quadratures by the collocation rule (exact for the collocation polynomial)
        for i in range(3):
            fi, ai = _eq.law_force(P, y[0] + Z[i, 0], y[1] + Z[i, 1], xm)
            dxi = y[1] + Z[i, 1] - lam * fi
            fq[i, 0] = fi * fi
            fq[i, 1] = (fi - ai) * dxi
        y[2] += h * (_RB[0] * fq[0, 0] + _RB[1] * fq[1, 0] + _RB[2] * fq[2, 0])
        y[3] += h * (_RB[0] * fq[0, 1] + _RB[1] * fq[1, 1] + _RB[2] * fq[2, 1])
        y[0] = xn
        y[1] = wn
        nst += 1
        s += h
        have_dense = True
        f0[0], f0[1], f0[2], f0[3] = _eq.rhs(P, y[0], y[1], xm)
        xm, xp, y[3] = _eq.yielded_peak(P.xy, y[0], f0[0], xm, xp, y[3])
        if y[0] <= 0.0:
            return _eq.Integration(_eq.SEPARATED, s, y[0], y[1], y[2], y[3], nst, hist)
        if _eq.rise_ended(f0[0], y[1], atol):  # past the peak or the end of a creep
            peaked = True
        if settle and peaked and _eq.settling_energy(P, y[0], y[1], xm) < wthr:
            return _eq.Integration(_eq.SETTLED, s, y[0], y[1], y[2], y[3], nst, hist)
        if h_old > 0.0 and err_old > 0.0 and err > 0.0:
            mult = min(1.0, h / h_old * (err_old / err) ** 0.25)
        else:
            mult = 1.0
        fac = mult * err**-0.25 if err > 0.0 else 10.0
        fac = min(10.0, safety * fac)
        if rejected:
            fac = min(1.0, fac)
            rejected = False
        h_old = h
        err_old = max(err, 1e-10)
        # the analytic 2x2 Jacobian is cheap: refresh it at every step
        j11, j12, j21, j22 = _eq.jacobian(P, y[0], y[1], xm)
        h *= fac
