"""numba kernels of the contact solver (private).

They integrate the dimensionless contact equations of PHYSICS.md section 4
(thesis eq. 2.42 generalised to a power law, gravity, Hunt-Crossley loss):

    x' = w - lam * f(x, w)          x = delta / (theta v0)   (penetration)
    w' = -f(x, w) + G               w = -v_rel / v0          (ball's downward speed)
    f  = x^n                        (Hertz n = 3/2, power law, elastic foundation n = 2)
    f  = max(0, x^n (1 + c w) / (1 + c lam x^n))     (Hunt-Crossley, c = mu v0)

with x(0) = 0, w(0) = 1, time s = t / theta, theta = (m / (K v0^(n-1)))^(1/(n+1)),
lam = beta m / theta (Zener's inelasticity) and G = g theta / v0. Two more
components carry the quadratures of the energy balance:

    I2' = f^2                       (energy radiated into the plate: lam I2)
    L'  = (f - x^n) x'              (Hunt-Crossley loss)

Two integrators share one driver: DOP853 (Hairer, Norsett & Wanner, "Solving ODEs
I", II.10; the coefficients are scipy's) for the non-stiff range, and the
3-stage Radau IIA method of order 5 (Hairer & Wanner, "Solving ODEs II", IV.8,
following scipy's implementation) for the stiff range (lam >> 1, where the
penetration relaxes much faster than the ball slows down). Both keep a dense
output of every step, from which the end of contact (x = 0) is located, the
peak penetration and force are found, and the pulse is sampled.

Settling (gravity): with u = lam G - w, the function
    W = u^2 / 2 + x^(n+1) / (n+1) - G x
never increases (dW/ds = -lam (f - G)^2 - loss) and a separation needs
W >= (lam G)^2 / 2 (x = 0 while moving apart). Once W falls below that value
the ball can never leave the plate: it has settled. This test is exact.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop

# --- DOP853 tableau (scipy's copy of Hairer's coefficients) ----------------------------
_NS = _dop.N_STAGES  # 12
_A = np.ascontiguousarray(_dop.A[:_NS, :_NS])
_B = np.ascontiguousarray(_dop.B)
_C = np.ascontiguousarray(_dop.C[:_NS])
_E3 = np.ascontiguousarray(_dop.E3)
_E5 = np.ascontiguousarray(_dop.E5)
_D = np.ascontiguousarray(_dop.D)
_A_EXTRA = np.ascontiguousarray(_dop.A[_NS + 1:])
_C_EXTRA = np.ascontiguousarray(_dop.C[_NS + 1:])

# --- Radau IIA (order 5) constants, as in scipy.integrate.Radau ------------------------
_S6 = 6.0 ** 0.5
_RC = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
_RE = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0
_MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)
_MU_C_RE = 3.0 + 0.5 * (3.0 ** (1.0 / 3.0) - 3.0 ** (2.0 / 3.0))
_MU_C_IM = -0.5 * (3.0 ** (5.0 / 6.0) + 3.0 ** (7.0 / 6.0))
_RT = np.array([
    [0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
    [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
    [1.0, 1.0, 0.0]])
_RTI = np.array([
    [4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
    [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
    [0.50287263494578682, -2.57192694985560522, 0.59603920482822492]])
_RP = np.array([
    [13.0 / 3.0 + 7.0 * _S6 / 3.0, -23.0 / 3.0 - 22.0 * _S6 / 3.0, 10.0 / 3.0 + 5.0 * _S6],
    [13.0 / 3.0 - 7.0 * _S6 / 3.0, -23.0 / 3.0 + 22.0 * _S6 / 3.0, 10.0 / 3.0 - 5.0 * _S6],
    [1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0]])
# Quadrature weights of the Radau IIA collocation (last row of its A matrix).
_RB = np.array([(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0])
_NEWTON_MAXITER = 6

# Status codes shared with synth.contact.
SEPARATED = 0
SETTLED = 1
MAX_STEPS = -1
STEP_TOO_SMALL = -2
NEWTON_FAILED = -3

# Columns of the dense-output history, one row per accepted step.
_H_T0, _H_H, _H_X0, _H_W0 = 0, 1, 2, 3
_H_COEF = 4           # DOP853: F[0..6] for x then w (14); Radau: Q[x,0..2], Q[w,0..2] (6)
_H_COLS = _H_COEF + 14


@numba.njit(cache=True, inline="always")
def _power(x, n):
    """x^n for x > 0, with fast paths for the usual exponents."""
    if n == 1.5:
        return x * math.sqrt(x)
    if n == 2.0:
        return x * x
    return x ** n


@numba.njit(cache=True, inline="always")
def _force(x, w, lam, n, c):
    """Dimensionless contact force f and its elastic part x^n (both 0 out of contact)."""
    if x <= 0.0:
        return 0.0, 0.0
    a = _power(x, n)
    if c == 0.0:
        return a, a
    f = a * (1.0 + c * w) / (1.0 + c * lam * a)
    if f < 0.0:
        f = 0.0
    return f, a


@numba.njit(cache=True, inline="always")
def _rhs(y, lam, G, n, c, out):
    f, a = _force(y[0], y[1], lam, n, c)
    dx = y[1] - lam * f
    out[0] = dx
    out[1] = G - f
    out[2] = f * f
    out[3] = (f - a) * dx


@numba.njit(cache=True)
def _jac2(x, w, lam, n, c):
    """Jacobian of (x', w') with respect to (x, w): returns j11, j12, j21, j22."""
    if x <= 0.0:
        return 0.0, 1.0, 0.0, 0.0
    a = _power(x, n)
    da = n * a / x
    if c == 0.0:
        fx, fw = da, 0.0
    else:
        num = 1.0 + c * w
        den = 1.0 + c * lam * a
        if a * num / den <= 0.0:
            fx, fw = 0.0, 0.0
        else:
            fx = da * num / (den * den)
            fw = a * c / den
    return -lam * fx, 1.0 - lam * fw, -fx, -fw


@numba.njit(cache=True)
def _energy_w(x, w, lam, G, n):
    """Settling function W of the module docstring."""
    u = lam * G - w
    return 0.5 * u * u + _power(x, n) * x / (n + 1.0) - G * x if x > 0.0 else 0.5 * u * u


@numba.njit(cache=True)
def _hermite_root(x0, x1, d0, d1):
    """Fraction of a step at which the cubic Hermite interpolant of x (values x0 > 0,
    x1 <= 0; d0, d1 the derivatives times the step) crosses zero, by bisection."""
    a = 0.0
    b = 1.0
    for _ in range(50):
        m = 0.5 * (a + b)
        t2 = m * m
        t3 = t2 * m
        v = ((2.0 * t3 - 3.0 * t2 + 1.0) * x0 + (t3 - 2.0 * t2 + m) * d0
             + (3.0 * t2 - 2.0 * t3) * x1 + (t3 - t2) * d1)
        if v > 0.0:
            a = m
        else:
            b = m
    return b


@numba.njit(cache=True)
def _grow(hist, k):
    if k < hist.shape[0]:
        return hist
    new = np.empty((2 * hist.shape[0], hist.shape[1]))
    new[:hist.shape[0]] = hist
    return new


# ---------------------------------------------------------------------------------------
# Dense output
# ---------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _dense(hist, k, s, radau):
    """(x, w) at dimensionless time s inside step k of the history."""
    t0 = hist[k, _H_T0]
    h = hist[k, _H_H]
    th = (s - t0) / h
    if radau:
        p1 = th
        p2 = th * th
        p3 = p2 * th
        c = _H_COEF
        x = hist[k, _H_X0] + hist[k, c] * p1 + hist[k, c + 1] * p2 + hist[k, c + 2] * p3
        w = hist[k, _H_W0] + hist[k, c + 3] * p1 + hist[k, c + 4] * p2 + hist[k, c + 5] * p3
        return x, w
    # DOP853 continuous extension (scipy's Dop853DenseOutput, Horner form)
    x = 0.0
    w = 0.0
    for i in range(7):
        j = 6 - i
        x += hist[k, _H_COEF + j]
        w += hist[k, _H_COEF + 7 + j]
        if i % 2 == 0:
            x *= th
            w *= th
        else:
            x *= 1.0 - th
            w *= 1.0 - th
    return x + hist[k, _H_X0], w + hist[k, _H_W0]


@numba.njit(cache=True)
def _find_step(hist, nst, s):
    lo = 0
    hi = nst - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if hist[mid, _H_T0] <= s:
            lo = mid
        else:
            hi = mid - 1
    return lo


@numba.njit(cache=True)
def _force_at(hist, nst, s, radau, lam, n, c):
    k = _find_step(hist, nst, s)
    x, w = _dense(hist, k, s, radau)
    f, a = _force(x, w, lam, n, c)
    return x, f


@numba.njit(cache=True)
def _golden_max(hist, nst, lo, hi, radau, lam, n, c, which):
    """Maximum of x (which=0) or f (which=1) over [lo, hi] by golden-section search."""
    g = 0.6180339887498949
    a = lo
    b = hi
    x1 = b - g * (b - a)
    x2 = a + g * (b - a)
    p = _force_at(hist, nst, x1, radau, lam, n, c)
    v1 = p[which]
    p = _force_at(hist, nst, x2, radau, lam, n, c)
    v2 = p[which]
    # The peak is quadratic: locating it to 1e-8 of its bracket gives the value to ~1e-16.
    for _ in range(80):
        if b - a <= 1e-8 * (hi - lo):
            break
        if v1 < v2:
            a = x1
            x1 = x2
            v1 = v2
            x2 = a + g * (b - a)
            p = _force_at(hist, nst, x2, radau, lam, n, c)
            v2 = p[which]
        else:
            b = x2
            x2 = x1
            v2 = v1
            x1 = b - g * (b - a)
            p = _force_at(hist, nst, x1, radau, lam, n, c)
            v1 = p[which]
    return max(v1, v2)


@numba.njit(cache=True, inline="always")
def _xdot(x, w, lam, n, c):
    f, _ = _force(x, w, lam, n, c)
    return w - lam * f


@numba.njit(cache=True)
def _event(which, x, w, lam, G, n, c, thr):
    """The functions whose roots end or mark a contact: 0, the penetration x (end of
    contact); 1, x' = w - lam f (peak penetration); 2, W - thr (settling, see the module
    docstring)."""
    if which == 0:
        return x
    if which == 1:
        return _xdot(x, w, lam, n, c)
    return _energy_w(x, w, lam, G, n) - thr


@numba.njit(cache=True)
def _root(hist, k, radau, which, lam, G, n, c, thr):
    """Where the event function ``which`` falls through 0 inside step k (positive at the
    step's start, not positive at its end): Illinois (modified regula falsi) on the dense
    output, to machine precision. If it is not positive at the start, the step's end."""
    a = hist[k, _H_T0]
    b = a + hist[k, _H_H]
    fa = _event(which, hist[k, _H_X0], hist[k, _H_W0], lam, G, n, c, thr)
    xb, wb = _dense(hist, k, b, radau)
    fb = _event(which, xb, wb, lam, G, n, c, thr)
    if fa <= 0.0 or fb >= 0.0:
        return b
    side = 0
    for _ in range(200):
        m = (a * fb - b * fa) / (fb - fa)
        if not (a < m < b):
            m = 0.5 * (a + b)
        xm, wm = _dense(hist, k, m, radau)
        fm = _event(which, xm, wm, lam, G, n, c, thr)
        if fm > 0.0:
            a, fa = m, fm
            if side == 1:
                fb *= 0.5
            side = 1
        elif fm < 0.0:
            b, fb = m, fm
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            return m
        # the peak (which 1) is quadratic: 1e-10 of the step places it to ~1e-20 in value
        if b - a <= (1e-10 * hist[k, _H_H] if which == 1 else 4e-16 * b):
            break
    return b if -fb < fa else a


# ---------------------------------------------------------------------------------------
# Integrators. Each returns (status, s_end, y_end, n_steps, n_rejected, hist, nst).
# ---------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _dop853(lam, G, n, c, rtol, atol, max_steps, h0):
    y = np.array([0.0, 1.0, 0.0, 0.0])
    K = np.zeros((16, 4))
    ynew = np.empty(4)
    tmp = np.empty(4)
    hist = np.empty((64, _H_COLS))
    _rhs(y, lam, G, n, c, K[0])
    s = 0.0
    h = h0
    nst = 0
    nrej = 0
    settle = G > 0.0 and lam > 0.0
    wthr = 0.5 * (lam * G) ** 2
    started = False
    peaked = False   # past the first penetration peak (a settled pulse keeps its landing)
    rejected = False
    h_rej = 0.0
    err_rej = 0.0
    while True:
        if nst >= max_steps:
            return MAX_STEPS, s, y, nst, nrej, hist, nst
        if h < 1e-14 * max(s, 1e-300) or h < 1e-300:
            return STEP_TOO_SMALL, s, y, nst, nrej, hist, nst
        # one DOP853 step
        for i in range(1, _NS):
            # only x and w enter the right-hand side; I2 and the loss are quadratures
            a0 = 0.0
            a1 = 0.0
            for j in range(i):
                a0 += _A[i, j] * K[j, 0]
                a1 += _A[i, j] * K[j, 1]
            tmp[0] = y[0] + h * a0
            tmp[1] = y[1] + h * a1
            _rhs(tmp, lam, G, n, c, K[i])
        for q in range(4):
            acc = 0.0
            for j in range(_NS):
                acc += _B[j] * K[j, q]
            ynew[q] = y[q] + h * acc
        _rhs(ynew, lam, G, n, c, K[_NS])
        # error estimate (scipy's DOP853 norm) on x, w and I2
        e5 = 0.0
        e3 = 0.0
        for q in range(3):
            sc = atol + rtol * max(abs(y[q]), abs(ynew[q]))
            a5 = 0.0
            a3 = 0.0
            for j in range(_NS + 1):
                a5 += _E5[j] * K[j, q]
                a3 += _E3[j] * K[j, q]
            e5 += (a5 / sc) ** 2
            e3 += (a3 / sc) ** 2
        if e5 == 0.0 and e3 == 0.0:
            err = 0.0
        else:
            err = h * e5 / math.sqrt((e5 + 0.01 * e3) * 3.0)
        if err >= 1.0 or not math.isfinite(err):
            # Near the ends of the contact the solution behaves like s^(n+1) (force
            # switching on or off), so the local error falls more slowly than h^8. After
            # a second rejection at the same point, shrink by the order observed between
            # the two trials instead of the nominal one.
            p = 8.0
            if rejected and h_rej > h and err_rej > err and math.isfinite(err):
                p = min(8.0, max(1.0, math.log(err_rej / err) / math.log(h_rej / h)))
            fac = 0.9 * err ** (-1.0 / p) if math.isfinite(err) else 0.2
            h_rej = h
            err_rej = err
            h *= max(0.1, fac)
            nrej += 1
            rejected = True
            continue
        if started and ynew[0] < 0.0:
            # The step crosses the end of contact, where the force switches off: its
            # error estimate and dense output assume a smooth right-hand side and are
            # not to be trusted across that kink. Redo it to land just past the root
            # (cubic Hermite estimate), so that its stages see a smooth problem.
            th = _hermite_root(y[0], ynew[0], h * K[0, 0], h * K[_NS, 0])
            if th < 0.999:
                h *= th * 1.0001 + 1e-9
                nrej += 1
                continue
        # accepted: dense output coefficients for x and w
        hist = _grow(hist, nst)
        for i in range(_NS + 1, 16):
            ii = i - _NS - 1
            a0 = 0.0
            a1 = 0.0
            for j in range(i):
                a0 += _A_EXTRA[ii, j] * K[j, 0]
                a1 += _A_EXTRA[ii, j] * K[j, 1]
            tmp[0] = y[0] + h * a0
            tmp[1] = y[1] + h * a1
            _rhs(tmp, lam, G, n, c, K[i])
        hist[nst, _H_T0] = s
        hist[nst, _H_H] = h
        hist[nst, _H_X0] = y[0]
        hist[nst, _H_W0] = y[1]
        for q in range(2):
            base = _H_COEF + 7 * q
            dy = ynew[q] - y[q]
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
        for q in range(4):
            y[q] = ynew[q]
            K[0, q] = K[_NS, q]
        if y[0] > 0.0:
            started = True
        elif started:
            return SEPARATED, s, y, nst, nrej, hist, nst
        if K[0, 0] <= 0.0:
            peaked = True
        if settle and peaked and _energy_w(y[0], y[1], lam, G, n) < wthr:
            return SETTLED, s, y, nst, nrej, hist, nst
        fac = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
        if rejected:
            fac = min(1.0, fac)
            rejected = False
        h *= fac


@numba.njit(cache=True)
def _radau(lam, G, n, c, rtol, atol, max_steps, h0):
    """3-stage Radau IIA on (x, w); I2 and the loss are its collocation quadratures."""
    y = np.array([0.0, 1.0, 0.0, 0.0])
    hist = np.empty((64, _H_COLS))
    Z = np.zeros((3, 2))
    Wt = np.zeros((3, 2))
    F = np.zeros((3, 2))
    fq = np.zeros((3, 2))       # f and (f - a) x' at the stages, for the quadratures
    f0 = np.empty(4)
    _rhs(y, lam, G, n, c, f0)
    s = 0.0
    h = h0
    h_old = -1.0
    err_old = -1.0
    nst = 0
    nrej = 0
    settle = G > 0.0 and lam > 0.0
    wthr = 0.5 * (lam * G) ** 2
    started = False
    peaked = False
    have_dense = False
    newton_tol = max(10.0 * 2.220446049250313e-16 / rtol, min(0.03, rtol ** 0.5))
    j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
    rejected = False
    while True:
        if nst >= max_steps:
            return MAX_STEPS, s, y, nst, nrej, hist, nst
        if h < 1e-14 * max(s, 1e-300) or h < 1e-300:
            return STEP_TOO_SMALL, s, y, nst, nrej, hist, nst
        sc0 = atol + rtol * abs(y[0])
        sc1 = atol + rtol * abs(y[1])
        # initial guess from the previous step's collocation polynomial
        for i in range(3):
            if have_dense:
                xg, wg = _dense(hist, nst - 1, s + h * _RC[i], True)
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
        tmp = np.empty(4)
        out = np.empty(4)
        for it in range(_NEWTON_MAXITER):
            n_iter = it + 1
            ok = True
            for i in range(3):
                tmp[0] = y[0] + Z[i, 0]
                tmp[1] = y[1] + Z[i, 1]
                _rhs(tmp, lam, G, n, c, out)
                F[i, 0] = out[0]
                F[i, 1] = out[1]
                if not (math.isfinite(out[0]) and math.isfinite(out[1])):
                    ok = False
            if not ok:
                break
            fr0 = _RTI[0, 0] * F[0, 0] + _RTI[0, 1] * F[1, 0] + _RTI[0, 2] * F[2, 0] - mr * Wt[0, 0]
            fr1 = _RTI[0, 0] * F[0, 1] + _RTI[0, 1] * F[1, 1] + _RTI[0, 2] * F[2, 1] - mr * Wt[0, 1]
            mcx = complex(mc_re, mc_im)
            fc0 = (complex(_RTI[1, 0], _RTI[2, 0]) * F[0, 0] + complex(_RTI[1, 1], _RTI[2, 1]) * F[1, 0]
                   + complex(_RTI[1, 2], _RTI[2, 2]) * F[2, 0] - mcx * complex(Wt[1, 0], Wt[2, 0]))
            fc1 = (complex(_RTI[1, 0], _RTI[2, 0]) * F[0, 1] + complex(_RTI[1, 1], _RTI[2, 1]) * F[1, 1]
                   + complex(_RTI[1, 2], _RTI[2, 2]) * F[2, 1] - mcx * complex(Wt[1, 1], Wt[2, 1]))
            d0 = (rd * fr0 - rb * fr1) / rdet
            d1 = (ra * fr1 - rc_ * fr0) / rdet
            z0 = (cd * fc0 - cb * fc1) / cdet
            z1 = (ca * fc1 - cc * fc0) / cdet
            dn = ((d0 / sc0) ** 2 + (d1 / sc1) ** 2 + (z0.real / sc0) ** 2 + (z0.imag / sc0) ** 2
                  + (z1.real / sc1) ** 2 + (z1.imag / sc1) ** 2)
            dn = math.sqrt(dn / 6.0)
            if dw_old >= 0.0:
                rate = dn / dw_old if dw_old > 0.0 else 0.0
            if rate >= 0.0 and (rate >= 1.0 or rate ** (_NEWTON_MAXITER - it) / (1.0 - rate) * dn > newton_tol):
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
            j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
            h *= 0.5
            nrej += 1
            rejected = True
            continue
        xn = y[0] + Z[2, 0]
        wn = y[1] + Z[2, 1]
        ze0 = (_RE[0] * Z[0, 0] + _RE[1] * Z[1, 0] + _RE[2] * Z[2, 0]) / h
        ze1 = (_RE[0] * Z[0, 1] + _RE[1] * Z[1, 1] + _RE[2] * Z[2, 1]) / h
        b0 = f0[0] + ze0
        b1 = f0[1] + ze1
        e0 = (rd * b0 - rb * b1) / rdet
        e1 = (ra * b1 - rc_ * b0) / rdet
        s0 = atol + rtol * max(abs(y[0]), abs(xn))
        s1 = atol + rtol * max(abs(y[1]), abs(wn))
        err = math.sqrt(((e0 / s0) ** 2 + (e1 / s1) ** 2) / 2.0)
        if rejected and err > 1.0:
            tmp[0] = y[0] + e0
            tmp[1] = y[1] + e1
            _rhs(tmp, lam, G, n, c, out)
            b0 = out[0] + ze0
            b1 = out[1] + ze1
            e0 = (rd * b0 - rb * b1) / rdet
            e1 = (ra * b1 - rc_ * b0) / rdet
            err = math.sqrt(((e0 / s0) ** 2 + (e1 / s1) ** 2) / 2.0)
        safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
        if err > 1.0 or not math.isfinite(err):
            if h_old > 0.0 and err_old > 0.0 and math.isfinite(err):
                mult = min(1.0, h / h_old * (err_old / err) ** 0.25)
            else:
                mult = 1.0
            fac = mult * err ** -0.25 if math.isfinite(err) and err > 0 else 0.2
            h *= max(0.2, safety * fac)
            nrej += 1
            rejected = True
            j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
            continue
        # accepted
        hist = _grow(hist, nst)
        hist[nst, _H_T0] = s
        hist[nst, _H_H] = h
        hist[nst, _H_X0] = y[0]
        hist[nst, _H_W0] = y[1]
        for q in range(2):
            for r in range(3):
                hist[nst, _H_COEF + 3 * q + r] = Z[0, q] * _RP[0, r] + Z[1, q] * _RP[1, r] + Z[2, q] * _RP[2, r]
        # quadratures by the collocation rule (exact for the collocation polynomial)
        for i in range(3):
            fi, ai = _force(y[0] + Z[i, 0], y[1] + Z[i, 1], lam, n, c)
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
        _rhs(y, lam, G, n, c, f0)
        if y[0] > 0.0:
            started = True
        elif started:
            return SEPARATED, s, y, nst, nrej, hist, nst
        if f0[0] <= 0.0:
            peaked = True
        if settle and peaked and _energy_w(y[0], y[1], lam, G, n) < wthr:
            return SETTLED, s, y, nst, nrej, hist, nst
        if h_old > 0.0 and err_old > 0.0 and err > 0.0:
            mult = min(1.0, h / h_old * (err_old / err) ** 0.25)
        else:
            mult = 1.0
        fac = mult * err ** -0.25 if err > 0.0 else 10.0
        fac = min(10.0, safety * fac)
        if rejected:
            fac = min(1.0, fac)
            rejected = False
        h_old = h
        err_old = max(err, 1e-10)
        # the analytic 2x2 Jacobian is cheap: refresh it at every step
        j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
        h *= fac


@numba.njit(cache=True)
def solve(lam, G, n, c, rtol, atol, max_steps, stiff, times, forces, t_scale, f_scale):
    """Integrate one contact and post-process it.

    Fills ``times`` and ``forces`` (same length) with the pulse sampled uniformly
    over the contact, multiplied by ``t_scale`` and ``f_scale``, and returns
    (status, s_contact, s_end, w_end, x_end, I2, loss, x_max, f_max, n_steps,
    n_rejected), all dimensionless: ``s_contact`` is the contact's duration (to
    separation, or to the moment the ball was proven unable to separate), and
    ``s_end, w_end, x_end, I2, loss`` the state where the energy balance is taken.
    """
    h0 = 0.5 * rtol ** (1.0 / (n + 1.0))
    if stiff:
        status, s_end, y, nst, nrej, hist, nh = _radau(lam, G, n, c, rtol, atol, max_steps, h0)
    else:
        status, s_end, y, nst, nrej, hist, nh = _dop853(lam, G, n, c, rtol, atol, max_steps, h0)
    radau = stiff
    x_end = y[0]
    w_end = y[1]
    s_contact = s_end
    if status == SEPARATED:
        # f = 0 for x <= 0, so I2 and the loss need no correction past the root.
        s_end = _root(hist, nh - 1, radau, 0, lam, G, n, c, 0.0)
        x_end, w_end = _dense(hist, nh - 1, s_end, radau)
        x_end = 0.0
        s_contact = s_end
    elif status == SETTLED:
        s_contact = _root(hist, nh - 1, radau, 2, lam, G, n, c, 0.5 * (lam * G) ** 2)
    # peak penetration and force: bracket by step ends, refine on the dense output
    ibest = 0
    vbest = -1.0
    for k in range(nh):
        if hist[k, _H_X0] > vbest:
            vbest = hist[k, _H_X0]
            ibest = k
    # the maximum is where x' = w - lam f changes sign: in the step before or after
    # the largest step start
    x_max = vbest
    for k in (ibest - 1, ibest):
        if k < 0 or k >= nh:
            continue
        g0 = _xdot(hist[k, _H_X0], hist[k, _H_W0], lam, n, c)
        xe, we = _dense(hist, k, hist[k, _H_T0] + hist[k, _H_H], radau)
        if g0 > 0.0 and _xdot(xe, we, lam, n, c) <= 0.0:
            xr, _ = _dense(hist, k, _root(hist, k, radau, 1, lam, G, n, c, 0.0), radau)
            x_max = max(x_max, xr)
    if c == 0.0:
        f_max = _power(x_max, n) if x_max > 0.0 else 0.0
    else:
        ibest = 0
        vbest = -1.0
        for k in range(nh):
            fk, _ = _force(hist[k, _H_X0], hist[k, _H_W0], lam, n, c)
            if fk > vbest:
                vbest = fk
                ibest = k
        lo = hist[max(ibest - 1, 0), _H_T0]
        hi = min(hist[ibest, _H_T0] + hist[ibest, _H_H], s_contact)
        if ibest + 1 < nh:
            hi = min(hist[ibest + 1, _H_T0] + hist[ibest + 1, _H_H], s_contact)
        f_max = max(_golden_max(hist, nh, lo, hi, radau, lam, n, c, 1), vbest)
    # the pulse on its own uniform grid over [0, s_contact]
    n_points = times.shape[0]
    k = 0
    for i in range(n_points):
        si = s_contact * i / (n_points - 1)
        while k + 1 < nh and hist[k + 1, _H_T0] <= si:
            k += 1
        xi, wi = _dense(hist, k, si, radau)
        fi, _ = _force(xi, wi, lam, n, c)
        times[i] = si * t_scale
        forces[i] = fi * f_scale
    if status == SEPARATED:
        forces[0] = 0.0
        forces[n_points - 1] = 0.0
    return (status, s_contact, s_end, w_end, x_end, y[2], y[3], x_max, f_max, nst, nrej, hist[:nh])


@numba.njit(cache=True)
def force_at(hist, radau, lam, n, c, s_contact, s, out):
    """Dimensionless force at dimensionless times ``s`` (sorted or not) from the dense
    output ``hist``; 0 outside ``[0, s_contact]``. Written into ``out``."""
    nh = hist.shape[0]
    for i in range(s.shape[0]):
        si = s[i]
        if si <= 0.0 or si >= s_contact:
            out[i] = 0.0
            continue
        k = _find_step(hist, nh, si)
        x, w = _dense(hist, k, si, radau)
        f, _ = _force(x, w, lam, n, c)
        out[i] = f
