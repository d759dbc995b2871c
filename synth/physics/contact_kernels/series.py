"""The series start of a contact (numba), in powers s^(i + j n) (Miller's recurrence, Knuth TAOCP
2, 4.7), used up to where its truncation error reaches the tolerance (docs/physics.md)."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels.equations import power

#: Terms s^(i + j n) of the start series with i + j n <= this degree are kept.
SERIES_DEGREE = 9.0
#: Coefficients [i, j] of the start series: i, j < SERIES_SIZE (i, j <= degree).
SERIES_SIZE = int(SERIES_DEGREE) + 1
#: The series is used at most up to this dimensionless time (the contact lasts ~3).
SERIES_MAX_TIME = 1.0
#: Terms s^(k/2), k <= this degree, of the viscoelastic start series (of x / s and w).
HALF_SERIES_DEGREE = 19
#: Columns of the coefficient arrays, room for either series.
SERIES_COLS = max(SERIES_SIZE, HALF_SERIES_DEGREE + 1)
#: Last degrees of the s^(1/2) series whose terms estimate its error: a recurrence link raises
#: the degree by at most 3, so the band holds every chain's leading term.
HALF_SERIES_BAND = 5


@compiled()
def new_series(b):
    """Coefficient array: ``SERIES_COLS`` columns with ``b > 0``, else ``SERIES_SIZE``."""
    return np.empty((7, SERIES_SIZE, SERIES_COLS if b != 0.0 else SERIES_SIZE))


@compiled()
def series_rows(n):
    """Highest j of the start series' terms s^(i + j n) (i, j >= 0, i + j n <= degree)."""
    return int(SERIES_DEGREE / n + 1e-9)


@compiled()
def series_len(j, n):
    """Highest i of row j of the start series."""
    return int(SERIES_DEGREE - j * n + 1e-9)


@compiled()
def half_series_coefficients(lam, G, c, b, S):
    """Coefficients of the series in sigma = s^(1/2) (n = 3/2, b > 0, any c).

    With x = sigma^2 Y, x^(1/2) = sigma R, x^(3/2) = sigma^3 A, x' = P, w = W:

        F[k] = T[k-3] + b Q[k-1],   T = A (1 + c P),  Q = R P,
        W[k] = 2 (G [k = 2] - F[k-2]) / k  (W[0] = 1, W[1] = 0),   P[k] = W[k] - lam F[k],
        Y[k] = 2 P[k] / (k + 2),   R[k] = (Y[k] - sum_{0<i<k} R[i] R[k-i]) / 2  (R[0] = 1),

    each from lower degrees. Fills ``S[q, 0, k]`` for q = Y, W, A, F, P, R, Q.
    """
    S[:] = 0.0
    Y = S[0, 0]
    W = S[1, 0]
    A = S[2, 0]
    F = S[3, 0]
    P = S[4, 0]
    R = S[5, 0]
    Q = S[6, 0]
    for k in range(HALF_SERIES_DEGREE + 1):
        f = b * Q[k - 1] if k >= 1 else 0.0
        if k >= 3:
            j = k - 3
            t = 0.0
            for i in range(j + 1):
                t += A[i] * P[j - i]
            f += A[j] + c * t
        F[k] = f
        if k == 0:
            W[0] = 1.0
        elif k >= 2:
            W[k] = 2.0 * ((G if k == 2 else 0.0) - F[k - 2]) / k
        P[k] = W[k] - lam * F[k]
        Y[k] = 2.0 * P[k] / (k + 2.0)
        if k == 0:
            R[0] = 1.0
        else:
            r = Y[k]
            for i in range(1, k):
                r -= R[i] * R[k - i]
            R[k] = 0.5 * r
        a = 0.0
        q = 0.0
        for i in range(k + 1):
            a += R[i] * Y[k - i]
            q += R[i] * P[k - i]
        A[k] = a
        Q[k] = q


@compiled()
def half_series_eval(S, s):
    """(x, w) at time s from the series in s^(1/2) (Horner)."""
    sg = math.sqrt(s) if s > 0.0 else 0.0
    y = 0.0
    w = 0.0
    for kk in range(HALF_SERIES_DEGREE + 1):
        k = HALF_SERIES_DEGREE - kk
        y = y * sg + S[0, 0, k]
        w = w * sg + S[1, 0, k]
    return s * y, w


@compiled()
def half_series_start(rtol, S, s_max):
    """``series_start`` for the series in s^(1/2); I2 and L term by term (ds = 2 sigma dsigma)."""
    A = S[2, 0]
    F = S[3, 0]
    P = S[4, 0]
    s1 = min(start_time(S, rtol, 1.5, 1.0), s_max)
    x1, w1 = half_series_eval(S, s1)
    sg = math.sqrt(s1)
    i2 = 0.0
    loss = 0.0
    sk = sg * sg
    for k in range(HALF_SERIES_DEGREE + 1):
        p = 0.0
        q = 0.0
        for i in range(k + 1):
            p += F[i] * F[k - i]
            d = F[i] - (A[i - 3] if i >= 3 else 0.0)
            q += d * P[k - i]
        i2 += 2.0 * p * sk / (k + 2.0)
        loss += 2.0 * q * sk / (k + 2.0)
        sk *= sg
    return s1, x1, w1, i2, loss


@compiled()
def start_time(S, rtol, n, b):
    """Where the truncation error reaches ``rtol``: Newton in log s down (e convex there)."""
    s1 = SERIES_MAX_TIME
    for _ in range(30):
        e, de = truncation_error(S, s1, n, b)
        if e <= 1.01 * rtol:
            break
        s1 *= math.exp(-math.log(e / rtol) * e / de)
    return s1


@compiled()
def truncation_error(S, s1, n, b):
    """``(e, s de/ds)`` at ``s1`` from the last degrees' terms (every chain's leading term)."""
    e = 0.0
    de = 0.0
    if b != 0.0:
        sg = math.sqrt(s1)
        term_power = sg ** (HALF_SERIES_DEGREE - HALF_SERIES_BAND + 1)
        for k in range(HALF_SERIES_DEGREE - HALF_SERIES_BAND + 1, HALF_SERIES_DEGREE + 1):
            term = (abs(S[0, 0, k]) + abs(S[1, 0, k])) * term_power
            e += term
            de += 0.5 * k * term
            term_power *= sg
        return e, de
    band = SERIES_DEGREE - n - 1.0
    b1 = power(s1, n)
    bj = 1.0
    for j in range(series_rows(n) + 1):
        si = bj
        for i in range(series_len(j, n) + 1):
            d = i + j * n
            if d > band:
                term = (abs(S[0, i, j]) + abs(S[1, i, j])) * si
                e += term
                de += d * term
            si *= s1
        bj *= b1
    return e, de


@compiled()
def series_coefficients(P, S):
    """Coefficients of the series in s and b = s^n (``d = i + j n``):

        W[i, j] = [i = j = 0] + G [i = 1, j = 0] - F[i-1, j-1] / d
        X[i, j] = (W[i, j] - lam F[i, j-1]) / (d + 1)
        A[i, j] = 1/d sum_{(a,b) != 0} X[a, b] A[i-a, j-b] ((n+1) (a + b n) - d)

    (A = X^n by Miller's recurrence, Knuth TAOCP 2, eq. 4.7-(6)). Hertz and power laws: F =
    A; Hunt-Crossley: F = A (1 + c W) / (1 + c lam b A). With b > 0:
    ``half_series_coefficients``.
    """
    lam, G, n, c, b = P.lam, P.G, P.n, P.c, P.b
    if b != 0.0:
        half_series_coefficients(lam, G, c, b, S)
        return
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
    for j in range(series_rows(n) + 1):
        for i in range(1 if j == 0 else 0, series_len(j, n) + 1):
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


@compiled()
def series_eval(S, s, n, b):
    """(x, w) at time s from the start series (nested Horner)."""
    if b != 0.0:
        return half_series_eval(S, s)
    sn = power(s, n) if s > 0.0 else 0.0
    X = 0.0
    W = 0.0
    jm = series_rows(n)
    for jj in range(jm + 1):
        j = jm - jj
        im = series_len(j, n)
        px = 0.0
        pw = 0.0
        for ii in range(im + 1):
            px = px * s + S[0, im - ii, j]
            pw = pw * s + S[1, im - ii, j]
        X = X * sn + px
        W = W * sn + pw
    return s * X, W


@compiled()
def series_start(P, rtol, S, s_max):
    """Fill ``S`` and return ``(s1, x, w, I2, L)`` at ``s1`` where the truncation error
    reaches ``rtol``, at most ``SERIES_MAX_TIME`` and ``s_max`` (before a yield)."""
    series_coefficients(P, S)
    n, c, b = P.n, P.c, P.b
    if b != 0.0:
        return half_series_start(rtol, S, s_max)
    s1 = min(start_time(S, rtol, n, 0.0), s_max)
    x1, w1 = series_eval(S, s1, n, 0.0)
    # I2 = int f^2, L = int b (F - A) x', term by term up to the degree of x
    b1 = power(s1, n)
    i2 = 0.0
    loss = 0.0
    bj = b1 * s1
    for j in range(series_rows(n) + 1):
        si = bj
        for i in range(series_len(j, n) + 1):
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
