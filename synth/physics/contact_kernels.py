"""numba kernels of the contact solver (private).

They integrate the dimensionless contact equations of docs/physics.md, "Hertz contact"
(the thesis, docs/physics.md, References, eq. 2.42 generalised to a power law, gravity,
Hunt-Crossley loss):

    x' = w - lam * f(x, w)          x = delta / (theta v0)   (penetration)
    w' = -f(x, w) + G               w = -v_rel / v0          (ball's downward speed)
    f  = x^n                        (Hertz n = 3/2, power law, elastic foundation n = 2)
    f  = max(0, x^n (1 + c w) / (1 + c lam x^n))     (Hunt-Crossley, c = mu v0)

with x(0) = 0, w(0) = 1, time s = t / theta, theta = (m / (K v0^(n-1)))^(1/(n+1)),
lam = beta m / theta (Zener's inelasticity) and G = g theta / v0. Two more
components carry the quadratures of the energy balance:

    I2' = f^2                       (energy radiated into the plate: lam I2)
    L'  = (f - x^n) x'              (Hunt-Crossley loss)

Start of contact: x^n is not smooth at x = 0, so a Runge-Kutta method would
have to start with tiny steps. Instead the solution is expanded in powers
s^(i + j n) (a series in s and s^n, see ``_series``) and taken from that series
up to the point ``s1`` where its truncation error is below the local tolerance.

Two integrators share one driver from there: DOP853 (Hairer, Norsett & Wanner,
"Solving ODEs I", II.10; the coefficients of their dop853.f, in
``synth/physics/dop853_tableau.py``) for the non-stiff range,
and the 3-stage Radau IIA method of order 5 (Hairer & Wanner, "Solving ODEs II",
IV.8, following scipy's implementation) for the stiff range (lam >> 1, where the
penetration relaxes much faster than the ball slows down). Both keep a dense
output of every step (row 0 of the history is the series), from which the end of
contact (x = 0) is located, the peak penetration and force are found, and the
pulse is sampled.

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

from synth.physics import dop853_tableau as _dop

# --- DOP853 tableau (Hairer's coefficients, synth/physics/dop853_tableau.py) ------------
_NS = _dop.N_STAGES  # 12
_A = np.ascontiguousarray(_dop.A[:_NS, :_NS])
_B = np.ascontiguousarray(_dop.B)
_C = np.ascontiguousarray(_dop.C[:_NS])
_E3 = np.ascontiguousarray(_dop.E3)
_E5 = np.ascontiguousarray(_dop.E5)
_D = np.ascontiguousarray(_dop.D)
_A_EXTRA = np.ascontiguousarray(_dop.A[_NS + 1 :])

# --- Radau IIA (order 5) constants, as in scipy.integrate.Radau ------------------------
_S6 = 6.0**0.5
_RC = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
_RE = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0
_MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)
_MU_C_RE = 3.0 + 0.5 * (3.0 ** (1.0 / 3.0) - 3.0 ** (2.0 / 3.0))
_MU_C_IM = -0.5 * (3.0 ** (5.0 / 6.0) + 3.0 ** (7.0 / 6.0))
_RT = np.array(
    [
        [0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
        [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
        [1.0, 1.0, 0.0],
    ]
)
_RTI = np.array(
    [
        [4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
        [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
        [0.50287263494578682, -2.57192694985560522, 0.59603920482822492],
    ]
)
_RP = np.array(
    [
        [13.0 / 3.0 + 7.0 * _S6 / 3.0, -23.0 / 3.0 - 22.0 * _S6 / 3.0, 10.0 / 3.0 + 5.0 * _S6],
        [13.0 / 3.0 - 7.0 * _S6 / 3.0, -23.0 / 3.0 + 22.0 * _S6 / 3.0, 10.0 / 3.0 - 5.0 * _S6],
        [1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0],
    ]
)
# Quadrature weights of the Radau IIA collocation (last row of its A matrix).
_RB = np.array([(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0])
_NEWTON_MAXITER = 6

# --- series start ----------------------------------------------------------------------
#: Terms s^(i + j n) of the start series with i + j n <= this degree are kept.
SERIES_DEGREE = 9.0
_SN = int(SERIES_DEGREE) + 1  # coefficient arrays are (_SN, _SN): i, j <= degree
#: The series is used at most up to this dimensionless time (the contact lasts ~3).
SERIES_MAX_TIME = 1.0

# Status codes shared with synth.physics.contact.
SEPARATED = 0
SETTLED = 1
MAX_STEPS = -1
STEP_TOO_SMALL = -2
NEWTON_FAILED = -3

# Columns of the dense-output history, one row per accepted step (row 0: the series).
_H_T0, _H_H, _H_X0, _H_W0 = 0, 1, 2, 3
_H_COEF = 4  # DOP853: F[0..6] for x then w (14); Radau: Q[x,0..2], Q[w,0..2] (6)
_H_COLS = _H_COEF + 14


@numba.njit(cache=True, inline="always")
def _power(x, n):
    """x^n for x > 0, with fast paths for the usual exponents."""
    if n == 1.5:
        return x * math.sqrt(x)
    if n == 2.0:
        return x * x
    return x**n


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
def _rhs(x, w, lam, G, n, c):
    """Right-hand side (x', w', I2', L') of the module docstring."""
    f, a = _force(x, w, lam, n, c)
    dx = w - lam * f
    return dx, G - f, f * f, (f - a) * dx


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
def _hermite_dips(x0, x1, d0, d1):
    """True if the cubic Hermite interpolant of x over a step (values x0, x1 > 0; d0, d1
    the derivatives times the step) reaches 0 inside it: the ball left the plate and came
    back within one step (a flight of length 2 |w| / G, short where gravity dominates).
    Such a step hides the end of contact from a test on its end points. A flight is a
    parabola, which the cubic reproduces exactly; the test looks only where x' turns
    from negative to positive, at the interpolant's minimum (a root of its derivative)."""
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


@numba.njit(cache=True)
def _hermite_root(x0, x1, d0, d1):
    """Fraction of a step at which the cubic Hermite interpolant of x (values x0 > 0,
    x1 <= 0; d0, d1 the derivatives times the step) crosses zero, by bisection to 1e-6
    (it only places the step that is redone to end just past the root)."""
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


@numba.njit(cache=True)
def _time_to_end(x, w, dx, lam, G, n, c):
    """Time left until the end of contact, predicted after a step that ends with x > 0
    moving apart (x' = dx < 0), and the separation speed v it implies; (inf, 0) if the
    ball still moves down.

    Near the end the force is f = phi x^n, phi = 1 + c w (Hertz: 1), and x ~ v sigma
    with sigma the time left. Integrating u' = f - G (u = -w) and x' = -(u + lam f)
    back from the end with f = phi (v sigma)^n gives, to leading order in the force,

        x = u sigma - G sigma^2 / 2 + phi v^n (lam sigma^(n+1) / (n+1) + sigma^(n+2) / (n+2)),
        v = u - G sigma + phi v^n sigma^(n+1) / (n+1),

    solved for sigma by Newton's method from sigma = x / (-x'). The neglected terms
    are of relative order sigma^(n+1): the prediction is sharp where it matters, close
    to the end.
    """
    u = -w
    if u <= 0.0:
        return np.inf, 0.0
    phi = max(0.0, 1.0 + c * w)
    un = phi * _power(u, n)
    sig = x / -dx
    for _ in range(6):
        sn = _power(sig, n)
        v = u - G * sig + un * sn * sig / (n + 1.0)
        vn = phi * _power(max(v, 0.0), n)
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
    return sig, u - G * sig + un * _power(sig, n) * sig / (n + 1.0)


@numba.njit(cache=True)
def _landing_factor(n):
    """kappa(n) of the error of a DOP853 step that ends where the force switches off.

    There f ~ (v (tau - s))^n, and w' = G - f gives the step's stages the derivatives
    -v^n h^n (1 - C_i)^n: scipy's error norm of that singular part alone (the rest of
    the solution is smooth) is kappa v^(n-1) h^(n+1) / rtol, relative to |w| = v.
    0 for an integer n (a polynomial, integrated exactly).
    """
    e5 = 0.0
    e3 = 0.0
    for i in range(_NS + 1):
        g = _power(1.0 - _C[i], n) if i < _NS else 0.0
        e5 += _E5[i] * g
        e3 += _E3[i] * g
    if e5 == 0.0:
        return 0.0
    return e5 * e5 / math.sqrt(3.0 * (e5 * e5 + 0.01 * e3 * e3))


@numba.njit(cache=True)
def _grow(hist, k):
    if k < hist.shape[0]:
        return hist
    new = np.empty((2 * hist.shape[0], hist.shape[1]))
    new[: hist.shape[0]] = hist
    return new


# ---------------------------------------------------------------------------------------
# Series start
# ---------------------------------------------------------------------------------------
@numba.njit(cache=True, inline="always")
def _series_rows(n):
    """Highest j of the start series' terms s^(i + j n) (i, j >= 0, i + j n <= degree)."""
    return int(SERIES_DEGREE / n + 1e-9)


@numba.njit(cache=True, inline="always")
def _series_len(j, n):
    """Highest i of row j of the start series."""
    return int(SERIES_DEGREE - j * n + 1e-9)


@numba.njit(cache=True)
def _series(lam, G, n, c, S):
    """Coefficients of the solution at first touch as a series in s and s^n.

    Near s = 0 the solution is a power series in the two variables s and b = s^n:

        x = s X,  w = W,  x^n = b A,  f = b F,   with  X = sum_ij X[i, j] s^i b^j, ...

    Integrating w' = G - f and x' = w - lam f term by term (``d`` = i + j n):

        W[i, j] = [i = j = 0] + G [i = 1, j = 0] - F[i-1, j-1] / d
        X[i, j] = (W[i, j] - lam F[i, j-1]) / (d + 1)

    and A = X^n by J.C.P. Miller's recurrence for powers of series (Knuth, TAOCP 2,
    4.7, eq. 4.7-(6)), here with the degree operator s d/ds, which maps s^i b^j to
    d s^i b^j (from X (s d/ds) A = n A (s d/ds) X):

        A[i, j] = 1/d sum_{(a,b) != 0} X[a, b] A[i-a, j-b] ((n+1) (a + b n) - d).

    Hertz and power laws: F = A. Hunt-Crossley: F = A (1 + c W) R with
    R = 1 / (1 + c lam b A). Each coefficient needs only coefficients of lower
    degree, so one pass in order of j, then i, gives them all, exactly: X and W up
    to ``SERIES_DEGREE``, A and F up to ``SERIES_DEGREE - n`` (all X and W need).

    Fills ``S`` (7, _SN, _SN): X, W, A, F, then X (n+1) (i + j n), and for
    Hunt-Crossley R and A (1 + c W).
    """
    S[:] = 0.0
    X = S[0]
    W = S[1]
    A = S[2]
    F = S[3]
    XD = S[4]
    R = S[5]
    T = S[6]
    X[0, 0] = W[0, 0] = A[0, 0] = R[0, 0] = 1.0
    T[0, 0] = F[0, 0] = 1.0 + c
    for j in range(_series_rows(n) + 1):
        for i in range(1 if j == 0 else 0, _series_len(j, n) + 1):
            d = i + j * n
            if j == 0:
                W[i, 0] = G if i == 1 else 0.0
                X[i, 0] = W[i, 0] / (d + 1.0)
            else:
                if i > 0:
                    W[i, j] = -F[i - 1, j - 1] / d
                X[i, j] = (W[i, j] - lam * F[i, j - 1]) / (d + 1.0)
            XD[i, j] = (n + 1.0) * d * X[i, j]
            if d > SERIES_DEGREE - n + 1e-9:
                continue
            p = 0.0
            q = 0.0
            for bb in range(j + 1):
                for aa in range(1 if bb == 0 else 0, i + 1):
                    p += XD[aa, bb] * A[i - aa, j - bb]
                    q += X[aa, bb] * A[i - aa, j - bb]
            A[i, j] = p / d - q
            if c == 0.0:
                F[i, j] = A[i, j]
                continue
            r = 0.0
            t = 0.0
            for bb in range(j + 1):
                for aa in range(i + 1):
                    t += A[aa, bb] * W[i - aa, j - bb]
                    if bb > 0:
                        r += A[aa, bb - 1] * R[i - aa, j - bb]
            R[i, j] = -c * lam * r
            T[i, j] = A[i, j] + c * t
            f = 0.0
            for bb in range(j + 1):
                for aa in range(i + 1):
                    f += T[aa, bb] * R[i - aa, j - bb]
            F[i, j] = f


@numba.njit(cache=True)
def _series_eval(S, s, n):
    """(x, w) at time s from the start series (nested Horner in s, then in s^n)."""
    b = _power(s, n) if s > 0.0 else 0.0
    X = 0.0
    W = 0.0
    jm = _series_rows(n)
    for jj in range(jm + 1):
        j = jm - jj
        im = _series_len(j, n)
        px = 0.0
        pw = 0.0
        for ii in range(im + 1):
            px = px * s + S[0, im - ii, j]
            pw = pw * s + S[1, im - ii, j]
        X = X * b + px
        W = W * b + pw
    return s * X, W


@numba.njit(cache=True)
def _series_start(lam, G, n, c, rtol, S):
    """Fill ``S`` by ``_series`` and choose where the integrators take over.

    The truncation error is estimated by the terms of the last ``n + 1`` degrees
    kept (each integration of the equations raises the degree by at most n + 1, so
    that band holds the leading terms of every chain, even when lam or G is 0):

        e(s) = sum_band (|X[i, j]| + |W[i, j]|) s^(i + j n)

    (x / s and w are of order one there). The series is used up to the time ``s1``
    where e = ``rtol``, at most up to ``SERIES_MAX_TIME``: e is convex in log s, so
    Newton's method in log s from above reaches s1 without overshooting.

    Returns (s1, x, w, I2, L) at s1; the quadratures are integrated term by term.
    """
    _series(lam, G, n, c, S)
    band = SERIES_DEGREE - n - 1.0
    s1 = SERIES_MAX_TIME
    for _ in range(30):
        b1 = _power(s1, n)
        e = 0.0
        de = 0.0
        bj = 1.0
        for j in range(_series_rows(n) + 1):
            si = bj
            for i in range(_series_len(j, n) + 1):
                d = i + j * n
                if d > band:
                    term = (abs(S[0, i, j]) + abs(S[1, i, j])) * si
                    e += term
                    de += d * term
                si *= s1
            bj *= b1
        if e <= 1.01 * rtol:
            break
        s1 *= math.exp(-math.log(e / rtol) * e / de)
    x1, w1 = _series_eval(S, s1, n)
    # I2 = int f^2 = sum (F F)[i, j] s^(d + 2n + 1) / (d + 2n + 1) and
    # L = int b (F - A) x' = sum ((F - A) X')[i, j] s^(d + n + 1) / (d + n + 1),
    # with their terms up to the degree of those of x (SERIES_DEGREE + 1)
    b1 = _power(s1, n)
    i2 = 0.0
    loss = 0.0
    bj = b1 * s1
    for j in range(_series_rows(n) + 1):
        si = bj
        for i in range(_series_len(j, n) + 1):
            d = i + j * n
            if d > SERIES_DEGREE - n + 1e-9:
                break
            if d <= SERIES_DEGREE - 2.0 * n + 1e-9:
                p = 0.0
                for bb in range(j + 1):
                    for aa in range(i + 1):
                        p += S[3, aa, bb] * S[3, i - aa, j - bb]
                i2 += p * si * b1 / (d + 2.0 * n + 1.0)
            if c != 0.0:
                q = 0.0
                for bb in range(j + 1):
                    for aa in range(i + 1):
                        q += (
                            (S[3, aa, bb] - S[2, aa, bb])
                            * (i - aa + (j - bb) * n + 1.0)
                            * S[0, i - aa, j - bb]
                        )
                loss += q * si / (d + n + 1.0)
            si *= s1
        bj *= b1
    return s1, x1, w1, i2, loss


# ---------------------------------------------------------------------------------------
# Dense output
# ---------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _radau_dense(hist, k, s):
    """(x, w) at time s inside Radau step k: its collocation polynomial."""
    p1 = (s - hist[k, _H_T0]) / hist[k, _H_H]
    p2 = p1 * p1
    p3 = p2 * p1
    c = _H_COEF
    x = hist[k, _H_X0] + hist[k, c] * p1 + hist[k, c + 1] * p2 + hist[k, c + 2] * p3
    w = hist[k, _H_W0] + hist[k, c + 3] * p1 + hist[k, c + 4] * p2 + hist[k, c + 5] * p3
    return x, w


@numba.njit(cache=True)
def _dense(hist, S, k, s, radau, n):
    """(x, w) at dimensionless time s inside step k of the history (step 0: the series)."""
    if k == 0:
        return _series_eval(S, s, n)
    if radau:
        return _radau_dense(hist, k, s)
    # DOP853 continuous extension (scipy's Dop853DenseOutput, Horner form)
    th = (s - hist[k, _H_T0]) / hist[k, _H_H]
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
def _force_at(hist, S, nst, s, radau, lam, n, c):
    k = _find_step(hist, nst, s)
    x, w = _dense(hist, S, k, s, radau, n)
    f, a = _force(x, w, lam, n, c)
    return x, f


@numba.njit(cache=True)
def _golden_max(hist, S, nst, lo, hi, radau, lam, n, c, which):
    """Maximum of x (which=0) or f (which=1) over [lo, hi] by golden-section search."""
    g = 0.6180339887498949
    a = lo
    b = hi
    x1 = b - g * (b - a)
    x2 = a + g * (b - a)
    p = _force_at(hist, S, nst, x1, radau, lam, n, c)
    v1 = p[which]
    p = _force_at(hist, S, nst, x2, radau, lam, n, c)
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
            p = _force_at(hist, S, nst, x2, radau, lam, n, c)
            v2 = p[which]
        else:
            b = x2
            x2 = x1
            v2 = v1
            x1 = b - g * (b - a)
            p = _force_at(hist, S, nst, x1, radau, lam, n, c)
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
def _root(hist, S, k, radau, which, lam, G, n, c, thr):
    """Where the event function ``which`` falls through 0 inside step k (positive at the
    step's start, not positive at its end): Illinois (modified regula falsi) on the dense
    output, to machine precision. If it is not positive at the start, the step's end."""
    a = hist[k, _H_T0]
    b = a + hist[k, _H_H]
    fa = _event(which, hist[k, _H_X0], hist[k, _H_W0], lam, G, n, c, thr)
    xb, wb = _dense(hist, S, k, b, radau, n)
    fb = _event(which, xb, wb, lam, G, n, c, thr)
    if fa <= 0.0 or fb >= 0.0:
        return b
    side = 0
    for _ in range(200):
        m = (a * fb - b * fa) / (fb - fa)
        if not (a < m < b):
            m = 0.5 * (a + b)
        xm, wm = _dense(hist, S, k, m, radau, n)
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
# Integrators. Both start at s with state (x, w, I2, L) and step h, with row 0 of the
# history (the series) filled in; each returns (status, s_end, x, w, I2, L, n_rows,
# n_rejected, hist) with n_rows the rows of the history in use.
# ---------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath={"contract"})
def _dop853(lam, G, n, c, rtol, atol, max_steps, hist, s, x, w, q2, q3, h):
    K = np.empty((16, 4))
    K[0, 0], K[0, 1], K[0, 2], K[0, 3] = _rhs(x, w, lam, G, n, c)
    nst = 1
    nrej = 0
    settle = G > 0.0 and lam > 0.0
    wthr = 0.5 * (lam * G) ** 2
    peaked = False  # past the first penetration peak (a settled pulse keeps its landing)
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
        if nst > max_steps:
            return MAX_STEPS, s, x, w, q2, q3, nst, nrej, hist
        if not (h >= 1e-14 * s and h >= 1e-300):
            return STEP_TOO_SMALL, s, x, w, q2, q3, nst, nrej, hist
        # one DOP853 step; the solution (B) and error (E5, E3) sums gather each stage as it
        # comes, in the shadow of the next stage's evaluation
        b0 = _B[0] * K[0, 0]
        b1 = _B[0] * K[0, 1]
        b2 = _B[0] * K[0, 2]
        b3 = _B[0] * K[0, 3]
        e5x = _E5[0] * K[0, 0]
        e5w = _E5[0] * K[0, 1]
        e5q = _E5[0] * K[0, 2]
        e3x = _E3[0] * K[0, 0]
        e3w = _E3[0] * K[0, 1]
        e3q = _E3[0] * K[0, 2]
        for i in range(1, _NS):
            # only x and w enter the right-hand side; I2 and the loss are quadratures
            a0 = 0.0
            a1 = 0.0
            for j in range(i):
                a0 += _A[i, j] * K[j, 0]
                a1 += _A[i, j] * K[j, 1]
            k0, k1, k2, k3 = _rhs(x + h * a0, w + h * a1, lam, G, n, c)
            K[i, 0] = k0
            K[i, 1] = k1
            K[i, 2] = k2
            K[i, 3] = k3
            b0 += _B[i] * k0
            b1 += _B[i] * k1
            b2 += _B[i] * k2
            b3 += _B[i] * k3
            e5x += _E5[i] * k0
            e5w += _E5[i] * k1
            e5q += _E5[i] * k2
            e3x += _E3[i] * k0
            e3w += _E3[i] * k1
            e3q += _E3[i] * k2
        xn = x + h * b0
        wn = w + h * b1
        q2n = q2 + h * b2
        q3n = q3 + h * b3
        k0, k1, k2, k3 = _rhs(xn, wn, lam, G, n, c)
        K[_NS, 0] = k0
        K[_NS, 1] = k1
        K[_NS, 2] = k2
        K[_NS, 3] = k3
        # error estimate (scipy's DOP853 norm) on x, w and I2
        e5x += _E5[_NS] * k0
        e5w += _E5[_NS] * k1
        e5q += _E5[_NS] * k2
        e3x += _E3[_NS] * k0
        e3w += _E3[_NS] * k1
        e3q += _E3[_NS] * k2
        scx = atol + rtol * max(x_top, abs(xn))
        scw = atol + rtol * max(abs(w), abs(wn))
        scq = atol + rtol * max(abs(q2), abs(q2n))
        e5 = (e5x / scx) ** 2 + (e5w / scw) ** 2 + (e5q / scq) ** 2
        e3 = (e3x / scx) ** 2 + (e3w / scw) ** 2 + (e3q / scq) ** 2
        if e5 == 0.0 and e3 == 0.0:
            err = 0.0
        else:
            err = h * e5 / math.sqrt((e5 + 0.01 * e3) * 3.0)
        if err >= 1.0 or not math.isfinite(err):
            nrej += 1
            if landing and math.isfinite(err):
                # The landing failed (its error ~ h^(n+1)): step to where one should pass.
                land_max = 0.9 * h * err ** (-1.0 / (n + 1.0))
                h = max(h - 0.9 * land_max, 0.5 * h)
                landing = False
                rejected = True
                continue
            # Near the end of the contact the local error falls more slowly than h^8.
            # After a second rejection at the same point, shrink by the order observed
            # between the two trials instead of the nominal one.
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
        if xn > 0.0 and _hermite_dips(x, xn, h * K[0, 0], h * K[_NS, 0]):
            # The ball separated and landed again inside the step: redo it shorter, so
            # that the end of contact is seen (and located) by the test below.
            h *= 0.5
            nrej += 1
            landing = False
            rejected = True
            continue
        if xn < 0.0:
            # The step crosses the end of contact, where the force switches off: its
            # error estimate and dense output assume a smooth right-hand side and are
            # not to be trusted across that kink. Redo it to land just past the root
            # (cubic Hermite estimate), so that its stages see a smooth problem.
            th = _hermite_root(x, xn, h * K[0, 0], h * K[_NS, 0])
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
            K[i, 0], K[i, 1], K[i, 2], K[i, 3] = _rhs(x + h * a0, w + h * a1, lam, G, n, c)
        hist[nst, _H_T0] = s
        hist[nst, _H_H] = h
        hist[nst, _H_X0] = x
        hist[nst, _H_W0] = w
        for q in range(2):
            base = _H_COEF + 7 * q
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
        if x <= 0.0:
            return SEPARATED, s, x, w, q2, q3, nst, nrej, hist
        if K[0, 0] <= 0.0:
            peaked = True
        if settle and peaked and _energy_w(x, w, lam, G, n) < wthr:
            return SETTLED, s, x, w, q2, q3, nst, nrej, hist
        fac = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
        if rejected:
            fac = min(1.0, fac)
            rejected = False
        h_done = h
        h *= fac
        landing = False
        if K[0, 0] < 0.0:
            # Moving apart. The end of contact is a singularity (the force ~ (tau - s)^n
            # switches off), and a step ending there has an error ~ h^(n+1) of known
            # size (``_landing_factor``). If this step would reach the end, make it land
            # just past it, or, if the end is farther than a landing may start from,
            # stop short at a point from which it may.
            sig = x / -K[0, 0]  # a first estimate, sharpened near the end
            reach = land_max
            if h >= 0.5 * sig:
                sig, v = _time_to_end(x, w, K[0, 0], lam, G, n, c)
                if kappa < 0.0:
                    kappa = _landing_factor(n)
                size = kappa * max(0.0, 1.0 - c * v) * _power(v, n - 1.0) * (1.0 + lam * v / x_top)
                if size > 0.0:
                    reach = min(reach, (0.8 * rtol / size) ** (1.0 / (n + 1.0)))
                if sig <= min(h, reach):
                    h = sig * 1.0001
                    landing = True
            if not landing and sig < np.inf:
                # the error constant grows as the end nears: keep the step's ratio to
                # the time left, rather than its length
                h *= sig / (sig + h_done)
                if h >= sig:
                    h = max(sig - 0.9 * reach, 0.5 * sig)


@numba.njit(cache=True)
def _radau(lam, G, n, c, rtol, atol, max_steps, hist, s, x, w, q2, q3, h):
    """3-stage Radau IIA on (x, w); I2 and the loss are its collocation quadratures."""
    y = np.array([x, w, q2, q3])
    Z = np.zeros((3, 2))
    Wt = np.zeros((3, 2))
    F = np.zeros((3, 2))
    fq = np.zeros((3, 2))  # f and (f - a) x' at the stages, for the quadratures
    f0 = np.empty(4)
    f0[0], f0[1], f0[2], f0[3] = _rhs(y[0], y[1], lam, G, n, c)
    h_old = -1.0
    err_old = -1.0
    nst = 1
    nrej = 0
    settle = G > 0.0 and lam > 0.0
    wthr = 0.5 * (lam * G) ** 2
    peaked = False
    have_dense = False
    newton_tol = max(10.0 * 2.220446049250313e-16 / rtol, min(0.03, rtol**0.5))
    j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
    rejected = False
    while True:
        if nst > max_steps:
            return MAX_STEPS, s, y[0], y[1], y[2], y[3], nst, nrej, hist
        if not (h >= 1e-14 * s and h >= 1e-300):
            return STEP_TOO_SMALL, s, y[0], y[1], y[2], y[3], nst, nrej, hist
        sc0 = atol + rtol * abs(y[0])
        sc1 = atol + rtol * abs(y[1])
        # initial guess from the previous step's collocation polynomial
        for i in range(3):
            if have_dense:
                xg, wg = _radau_dense(hist, nst - 1, s + h * _RC[i])
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
                F[i, 0], F[i, 1], _, _ = _rhs(y[0] + Z[i, 0], y[1] + Z[i, 1], lam, G, n, c)
                if not (math.isfinite(F[i, 0]) and math.isfinite(F[i, 1])):
                    ok = False
            if not ok:
                break
            fr0 = _RTI[0, 0] * F[0, 0] + _RTI[0, 1] * F[1, 0] + _RTI[0, 2] * F[2, 0] - mr * Wt[0, 0]
            fr1 = _RTI[0, 0] * F[0, 1] + _RTI[0, 1] * F[1, 1] + _RTI[0, 2] * F[2, 1] - mr * Wt[0, 1]
            mcx = complex(mc_re, mc_im)
            fc0 = (
                complex(_RTI[1, 0], _RTI[2, 0]) * F[0, 0]
                + complex(_RTI[1, 1], _RTI[2, 1]) * F[1, 0]
                + complex(_RTI[1, 2], _RTI[2, 2]) * F[2, 0]
                - mcx * complex(Wt[1, 0], Wt[2, 0])
            )
            fc1 = (
                complex(_RTI[1, 0], _RTI[2, 0]) * F[0, 1]
                + complex(_RTI[1, 1], _RTI[2, 1]) * F[1, 1]
                + complex(_RTI[1, 2], _RTI[2, 2]) * F[2, 1]
                - mcx * complex(Wt[1, 1], Wt[2, 1])
            )
            d0 = (rd * fr0 - rb * fr1) / rdet
            d1 = (ra * fr1 - rc_ * fr0) / rdet
            z0 = (cd * fc0 - cb * fc1) / cdet
            z1 = (ca * fc1 - cc * fc0) / cdet
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
            r0, r1, _, _ = _rhs(y[0] + e0, y[1] + e1, lam, G, n, c)
            b0 = r0 + ze0
            b1 = r1 + ze1
            e0 = (rd * b0 - rb * b1) / rdet
            e1 = (ra * b1 - rc_ * b0) / rdet
            err = math.sqrt(((e0 / s0) ** 2 + (e1 / s1) ** 2) / 2.0)
        safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
        if err > 1.0 or not math.isfinite(err):
            if h_old > 0.0 and err_old > 0.0 and math.isfinite(err):
                mult = min(1.0, h / h_old * (err_old / err) ** 0.25)
            else:
                mult = 1.0
            fac = mult * err**-0.25 if math.isfinite(err) and err > 0 else 0.2
            h *= max(0.2, safety * fac)
            nrej += 1
            rejected = True
            j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
            continue
        if xn > 0.0 and _hermite_dips(y[0], xn, h * f0[0], h * _rhs(xn, wn, lam, G, n, c)[0]):
            # separated and landed again inside the step (see the DOP853 driver)
            h *= 0.5
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
                hist[nst, _H_COEF + 3 * q + r] = (
                    Z[0, q] * _RP[0, r] + Z[1, q] * _RP[1, r] + Z[2, q] * _RP[2, r]
                )
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
        f0[0], f0[1], f0[2], f0[3] = _rhs(y[0], y[1], lam, G, n, c)
        if y[0] <= 0.0:
            return SEPARATED, s, y[0], y[1], y[2], y[3], nst, nrej, hist
        if f0[0] <= 0.0:
            peaked = True
        if settle and peaked and _energy_w(y[0], y[1], lam, G, n) < wthr:
            return SETTLED, s, y[0], y[1], y[2], y[3], nst, nrej, hist
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
        j11, j12, j21, j22 = _jac2(y[0], y[1], lam, n, c)
        h *= fac


@numba.njit(cache=True)
def _positive_power(a, n):
    """a <- max(a, 0)^n in place, the exponent tested once (so that the loop vectorises)."""
    if n == 1.5:
        for i in range(a.shape[0]):
            v = max(a[i], 0.0)
            a[i] = v * math.sqrt(v)
    else:
        for i in range(a.shape[0]):
            a[i] = max(a[i], 0.0) ** n


@numba.njit(cache=True)
def _series_x(S, n, s, out):
    """x from the start series at the times ``s`` (into ``out``), all times at once."""
    b = s.copy()
    _positive_power(b, n)
    p = np.empty(s.shape[0])
    out[:] = 0.0
    jm = _series_rows(n)
    for jj in range(jm + 1):
        j = jm - jj
        im = _series_len(j, n)
        p[:] = 0.0
        for ii in range(im + 1):
            coef = S[0, im - ii, j]
            for q in range(s.shape[0]):
                p[q] = p[q] * s[q] + coef
        for q in range(s.shape[0]):
            out[q] = out[q] * b[q] + p[q]
    for q in range(s.shape[0]):
        out[q] *= s[q]


@numba.njit(cache=True)
def _sample_pulse(hist, S, nh, radau, lam, n, c, s_contact, times, forces):
    """Pulse f at ``len(times)`` uniform times over [0, s_contact] (written into ``times``
    and ``forces``). For DOP853 and a Hertz or power law only x is needed: it is
    evaluated step by step, in loops that the compiler vectorises, then raised to n."""
    n_points = times.shape[0]
    ds = s_contact / (n_points - 1)
    for i in range(n_points):
        times[i] = i * ds
    if radau or c != 0.0:
        k = 0
        for i in range(n_points):
            while k + 1 < nh and hist[k + 1, _H_T0] <= times[i]:
                k += 1
            x, w = _dense(hist, S, k, times[i], radau, n)
            forces[i], _ = _force(x, w, lam, n, c)
        return
    i = 0
    for k in range(nh):
        i1 = n_points
        if k + 1 < nh:
            i1 = i
            while i1 < n_points and times[i1] < hist[k + 1, _H_T0]:
                i1 += 1
        if k == 0:
            _series_x(S, n, times[i:i1], forces[i:i1])
        else:
            t0 = hist[k, _H_T0]
            rh = 1.0 / hist[k, _H_H]
            x0 = hist[k, _H_X0]
            c0, c1, c2, c3, c4, c5, c6 = hist[k, _H_COEF : _H_COEF + 7]
            for j in range(i, i1):
                th = (times[j] - t0) * rh
                u = 1.0 - th
                # scipy's Dop853DenseOutput, Horner form (as in _dense)
                forces[j] = x0 + th * (
                    c0 + u * (c1 + th * (c2 + u * (c3 + th * (c4 + u * (c5 + th * c6)))))
                )
        i = i1
    _positive_power(forces, n)


@numba.njit(cache=True)
def solve(lam, G, n, c, rtol, atol, max_steps, stiff):
    """Integrate one contact and find its peak.

    Returns (status, s_contact, s_end, w_end, x_end, I2, loss, x_max, f_max, n_steps,
    n_rejected, hist), all dimensionless: ``s_contact`` is the contact's duration (to
    separation, or to the moment the ball was proven unable to separate), ``s_end,
    w_end, x_end, I2, loss`` the state where the energy balance is taken, ``n_steps``
    the integrator's accepted steps after the series start, and ``hist`` the dense
    output (row 0: the series, whose coefficients ``pulse`` and ``force_at``
    recompute).
    """
    S = np.empty((7, _SN, _SN))
    s1, x1, w1, i2, loss = _series_start(lam, G, n, c, rtol, S)
    hist = np.empty((32, _H_COLS))
    hist[0, _H_T0] = 0.0
    hist[0, _H_H] = s1
    hist[0, _H_X0] = 0.0
    hist[0, _H_W0] = 1.0
    # The series' validity ends at s1 like a step's: the next step is of the same length.
    if stiff:
        status, s_end, x_end, w_end, i2, loss, nh, nrej, hist = _radau(
            lam, G, n, c, rtol, atol, max_steps, hist, s1, x1, w1, i2, loss, s1
        )
    else:
        status, s_end, x_end, w_end, i2, loss, nh, nrej, hist = _dop853(
            lam, G, n, c, rtol, atol, max_steps, hist, s1, x1, w1, i2, loss, s1
        )
    radau = stiff
    s_contact = s_end
    if status == SEPARATED:
        # f = 0 for x <= 0, so I2 and the loss need no correction past the root.
        s_end = _root(hist, S, nh - 1, radau, 0, lam, G, n, c, 0.0)
        x_end, w_end = _dense(hist, S, nh - 1, s_end, radau, n)
        x_end = 0.0
        s_contact = s_end
    elif status == SETTLED:
        s_contact = _root(hist, S, nh - 1, radau, 2, lam, G, n, c, 0.5 * (lam * G) ** 2)
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
        xe, we = _dense(hist, S, k, hist[k, _H_T0] + hist[k, _H_H], radau, n)
        if g0 > 0.0 and _xdot(xe, we, lam, n, c) <= 0.0:
            xr, _ = _dense(hist, S, k, _root(hist, S, k, radau, 1, lam, G, n, c, 0.0), radau, n)
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
        f_max = max(_golden_max(hist, S, nh, lo, hi, radau, lam, n, c, 1), vbest)
    return (status, s_contact, s_end, w_end, x_end, i2, loss, x_max, f_max, nh - 1, nrej, hist[:nh])


# Integrator choice of ``impact``.
AUTO = 0
DOP853 = 1
RADAU = 2

# Fields of the result array of ``impact``: the one place that names their order.
R_STATUS = 0  # SEPARATED, SETTLED or a failure code
R_TINY_REBOUND = 1  # 1: separated with a rebound below the solver's resolution
R_STIFF = 2  # 1: integrated by Radau IIA, 0: by DOP853
R_RESTITUTION = 3  # v_out / v_in
R_CONTACT_TIME = 4  # s
R_MAX_PENETRATION = 5  # m
R_PEAK_FORCE = 6  # N
R_IMPULSE = 7  # N s
R_INELASTICITY = 8  # Zener's lam = beta m / theta
R_REBOUND_SPEED = 9  # m/s
R_PLATE_ENERGY = 10  # J
R_ENERGY_RESIDUAL = 11  # relative error of the energy balance
R_N_STEPS = 12  # accepted steps
R_G = 13  # dimensionless gravity g theta / v0 (dense output)
R_C = 14  # dimensionless Hunt-Crossley loss mu v0 (dense output)
R_S_CONTACT = 15  # dimensionless end of contact (dense output)
R_THETA = 16  # Zener's time scale, s
R_F_SCALE = 17  # force scale m v0 / theta, N
N_RESULT = 18


@numba.njit(cache=True)
def impact(
    m,
    K,
    beta,
    v_in,
    g,
    n,
    mu,
    v_free,
    rtol,
    atol_factor,
    stiff_lambda,
    method,
    max_explicit,
    max_implicit,
):
    """One impact from lumped parameters (SI units, checked by the caller).

    Scales the equations of docs/physics.md, "Hertz contact" by Zener's time ``theta`` and
    length ``theta v0`` (v0 = v_in + v_free, the approach speed in the plate's frame),
    integrates them by ``solve`` (``method``: AUTO picks Radau IIA above
    ``stiff_lambda`` and falls back to it when DOP853 reaches ``max_explicit`` steps),
    and takes the energy balance (docs/physics.md, "Hertz contact"; Hunt-Crossley loss included).
    ``rtol`` is the integrators' local tolerance, ``atol_factor`` the absolute one
    relative to it.

    Returns ``(result, hist)``: ``result`` a float array of ``N_RESULT`` values whose
    fields are named by the ``R_*`` indices above (flags and counts stored as
    floats), ``hist`` the dense output that ``pulse`` and ``force_at`` read.
    """
    v0 = v_in + v_free
    theta = (m / (K * v0 ** (n - 1.0))) ** (1.0 / (n + 1.0))
    lam = beta * m / theta
    G = g * theta / v0
    c = mu * v0
    atol = rtol * atol_factor
    stiff = (lam > stiff_lambda) if method == AUTO else (method == RADAU)
    f_scale = m * v0 / theta
    out = solve(lam, G, n, c, rtol, atol, max_implicit if stiff else max_explicit, stiff)
    if out[0] == MAX_STEPS and not stiff and method == AUTO:
        stiff = True
        out = solve(lam, G, n, c, rtol, atol, max_implicit, True)
    status, s_contact, s_end, w_end, x_end, i2, loss, x_max, f_max, nst, _, hist = out
    separated = status == SEPARATED
    tiny_rebound = separated and w_end > 0.0
    if tiny_rebound:
        # The contact ended with the ball still (barely) approaching: the rebound is
        # below the solver's absolute resolution (atol of v0).
        w_end = 0.0
    i1 = 1.0 - w_end + G * s_end  # from w' = G - f
    # energy balance, dimensionless (docs/physics.md, "Hertz contact", in the plate's frame)
    elastic = x_end * _power(x_end, n) / (n + 1.0) if x_end > 0.0 else 0.0
    lhs = 0.5 * w_end * w_end + elastic - G * x_end - 0.5
    rhs = G * lam * i1 - lam * i2 - loss
    # relative to the energy exchanged: the arrival energy, or the work of gravity and the
    # energy carried away when they are larger (a slow, heavy ball sinking with the plate)
    scale = max(0.5, abs(G * lam * i1), lam * i2, abs(loss), abs(G * x_end))
    v_out = -w_end * v0 if separated else 0.0
    r = np.empty(N_RESULT)
    r[R_STATUS] = status
    r[R_TINY_REBOUND] = 1.0 if tiny_rebound else 0.0
    r[R_STIFF] = 1.0 if stiff else 0.0
    r[R_RESTITUTION] = v_out / v_in
    r[R_CONTACT_TIME] = s_contact * theta
    r[R_MAX_PENETRATION] = x_max * theta * v0
    r[R_PEAK_FORCE] = f_max * f_scale
    r[R_IMPULSE] = i1 * m * v0
    r[R_INELASTICITY] = lam
    r[R_REBOUND_SPEED] = v_out
    r[R_PLATE_ENERGY] = lam * i2 * m * v0 * v0
    r[R_ENERGY_RESIDUAL] = abs(lhs - rhs) / scale
    r[R_N_STEPS] = nst
    r[R_G] = G
    r[R_C] = c
    r[R_S_CONTACT] = s_contact
    r[R_THETA] = theta
    r[R_F_SCALE] = f_scale
    return r, hist


@numba.njit(cache=True)
def pulse(hist, radau, lam, G, n, c, s_contact, separated, t_scale, f_scale, times, forces):
    """The pulse of ``solve``'s dense output ``hist`` (same lam, G, n, c) at
    ``len(times)`` uniform times over [0, s_contact], scaled by ``t_scale`` and
    ``f_scale``, into ``times`` and ``forces``; the ends of a separated contact are 0."""
    S = np.empty((7, _SN, _SN))
    _series(lam, G, n, c, S)
    _sample_pulse(hist, S, hist.shape[0], radau, lam, n, c, s_contact, times, forces)
    times *= t_scale
    forces *= f_scale
    if separated:
        forces[0] = 0.0
        forces[-1] = 0.0


@numba.njit(cache=True)
def force_at(hist, radau, lam, G, n, c, s_contact, s, out):
    """Dimensionless force at dimensionless times ``s`` (sorted or not) from the dense
    output ``hist`` of ``solve`` (same lam, G, n, c); 0 outside ``[0, s_contact]``.
    Written into ``out``."""
    S = np.empty((7, _SN, _SN))
    _series(lam, G, n, c, S)
    nh = hist.shape[0]
    for i in range(s.shape[0]):
        si = s[i]
        if si <= 0.0 or si >= s_contact:
            out[i] = 0.0
            continue
        k = _find_step(hist, nh, si)
        x, w = _dense(hist, S, k, si, radau, n)
        f, _ = _force(x, w, lam, n, c)
        out[i] = f


@numba.njit(cache=True)
def force_slope_at(hist, radau, lam, G, n, c, s_contact, s, out, slope):
    """As ``force_at``, with the force's rate of change ``df/ds`` into ``slope``.

    ``x' = w - lam f`` and ``w' = G - f`` (module docstring); with ``a = x^n``,
    ``a' = n x^(n-1) x'``. Hertz and power laws: ``f' = a'``. Hunt-Crossley:
    ``f = a (1 + c w) / D``, ``D = 1 + c lam a``, so
    ``f' = (a' (1 + c w) + a c w') / D - f c lam a' / D`` (0 where f is clipped at 0).
    """
    S = np.empty((7, _SN, _SN))
    _series(lam, G, n, c, S)
    nh = hist.shape[0]
    for i in range(s.shape[0]):
        si = s[i]
        if si <= 0.0 or si >= s_contact:
            out[i] = 0.0
            slope[i] = 0.0
            continue
        k = _find_step(hist, nh, si)
        x, w = _dense(hist, S, k, si, radau, n)
        f, a = _force(x, w, lam, n, c)
        out[i] = f
        if x <= 0.0 or f <= 0.0:
            slope[i] = 0.0
            continue
        dx = w - lam * f
        da = n * _power(x, n - 1.0) * dx
        if c == 0.0:
            slope[i] = da
        else:
            D = 1.0 + c * lam * a
            slope[i] = (da * (1.0 + c * w) + a * c * (G - f)) / D - f * c * lam * da / D


@numba.njit(cache=True)
def pulse_samples(
    hist, radau, lam, G, n, c, s_contact, theta, f_scale, step, points, offset, period, samples,
    out, slope,
):  # fmt: skip
    """The force (N) and its rate (N/s) at ``u_j = j step`` (``j < points``) and then at
    ``offset + m period`` (``m < samples``), times in s from first touch: ``force_slope_at``
    on those times, scaled to SI units (``theta`` s, ``f_scale`` N), written into
    ``out[:points + samples]`` and ``slope[:points + samples]``."""
    total = points + samples
    s = np.empty(total)
    for j in range(points):
        s[j] = (j * step) / theta
    for m in range(samples):
        s[points + m] = (offset + m * period) / theta
    f = out[:total]
    r = slope[:total]
    force_slope_at(hist, radau, lam, G, n, c, s_contact, s, f, r)
    rate = f_scale / theta
    for i in range(total):
        f[i] *= f_scale
        r[i] *= rate
