"""Free and clamped plate modes by the dynamic edge effect method (docs/physics.md,
"Plate modes", "Large free and clamped plates").

Bolotin's method (Bolotin 1960; Elishakoff 1976; Vijayakumar 1973) writes a mode of a
rectangle ``[0, a] x [0, b]`` as a product ``w = X(x) Y(y)``. Along x, with the
y-dependence of the interior solution ``Y'' = -s_y Y``, Kirchhoff's equation
``D lap^2 w = rho h omega^2 w`` becomes the beam-like equation

    X'''' - 2 s_y X'' + s_y^2 X = k^4 X,   k^2 = s_x + s_y = omega sqrt(rho h / D),

whose solutions are ``cos(k_x x)``, ``sin(k_x x)`` (``k_x^2 = s_x``; ``cosh``/``sinh`` when
``s_x < 0``) and the edge terms ``cosh(mu_x x)``, ``sinh(mu_x x)``,
``mu_x^2 = s_x + 2 s_y``, which decay away from the edges. Symmetric (``cos``, ``cosh``)
and antisymmetric (``sin``, ``sinh``) solutions about the middle ``x' = x - a/2``
satisfying the two edge conditions at ``x' = a/2`` (free: ``X'' - nu s_y X = 0`` and
``X''' - (2 - nu) s_y X' = 0``; clamped: ``X = X' = 0``) give one transcendental equation
in ``s_x`` for each ``s_y``; the same along y gives ``s_y`` for each ``s_x``. With
``P = s_x + nu s_y``, ``Q = s_x + (2 - nu) s_y``, ``h = a/2``:

    free, symmetric:      Q^2 k_x sin(k_x h) + mu P^2 cos(k_x h) tanh(mu h) = 0
    free, antisymmetric:  -P^2 sin(k_x h) / k_x + Q^2 cos(k_x h) tanh(mu h) / mu = 0
    clamped, symmetric:   k_x sin(k_x h) + mu cos(k_x h) tanh(mu h) = 0
    clamped, antisymmetric: sin(k_x h) / k_x - cos(k_x h) tanh(mu h) / mu = 0

(left sides entire in ``s_x``). For ``k_x > 0`` they read
``k_x a = N pi - 2 arctan(r)``, ``0 <= 2 arctan(r) < pi``: the ``N``-th root lies in
``((N - 1) pi / a, N pi / a]`` (``N`` even symmetric, odd antisymmetric); with
``tanh(mu h) = 1`` this is Bolotin's asymptotic phase condition. Each mode is a pair of
indices ``(N_x, N_y)`` (``>= 2`` clamped; ``>= 0`` free, without the three rigid-body
motions ``(0, 0)``, ``(1, 0)``, ``(0, 1)``) and the pair of equations is solved by
alternating the two one-dimensional solutions (a contraction: each depends on the other
only through the edge terms). The cost is linear in the number of modes; the shapes
``X(x) Y(y)`` are separable, one factor pair per trial.

Rayleigh-Ritz step. The products ``X Y`` are then used as trial shapes of Kirchhoff's
energy functional (the standard Rayleigh-Ritz step on a small subspace; Leissa 1969,
chapter 1; Bolotin's shapes as trial functions: Elishakoff 1976). Two trials of one
symmetry class whose frequencies lie within ``_PAIR_GAP`` (1 %) of each other are solved
together: the 2 x 2 problem ``K v = omega^2 M v`` with ``M_ij = Int psi_i psi_j`` and
``K_ij`` the strain energy's bilinear form, separable into one-dimensional integrals of
the factors and their derivatives, taken in closed form (each factor is a sum of four
exponentials). This is what splits the degenerate pairs ``(m, n)``, ``(n, m)`` of a square,
which the corners couple and the method alone leaves equal. A clamped trial alone takes
its Rayleigh quotient: its shape meets the clamped conditions exactly, so the quotient's
error is second order in the shape's (measured 5 to 20 times closer to the Ritz
frequencies than the edge effect value); a free trial alone keeps the edge effect value
(its quotient, with the free conditions unmet at the corners, was measured no closer).
The step costs a fixed number of operations per mode.

Accuracy. Against the exact (Ritz) solver, frequencies agree within 0.5 % for all but the
lowest modes of each family (tests/test_asymptotic_modes.py states the measured figures
and which modes are excluded); the simply supported limit and the beam limit
(``b -> 0``: the Euler-Bernoulli beam's ``k a = 4.730, 7.853, ...``) are exact.

References
----------
V. V. Bolotin, "The edge effect in the oscillations of elastic shells", PMM 24 (1960)
831-843; I. Elishakoff, "Bolotin's dynamic edge effect method", Shock Vib. Dig. 8 (1976);
K. Vijayakumar, "A new method for analysis of flexural vibration of rectangular orthotropic
plates", J. Aeronaut. Soc. India 25 (1973); A. W. Leissa, *Vibration of Plates*, NASA SP-160
(1969).
"""

from __future__ import annotations

import cmath
import json
import math

import numpy as np

from synth.compilation import compiled

__all__ = ["EdgeEffectSolution", "solve", "mode_count_estimate"]

#: Alternations of the two one-dimensional equations (each a contraction; the
#: frequencies stop changing to 1e-13 relative after about 8 for every tested plate).
_ALTERNATIONS = 30
_BISECTIONS = 100
#: Two modes of one symmetry class whose edge effect frequencies differ by less than this
#: (relative) are a near-degenerate pair, solved together by the Rayleigh-Ritz step.
_PAIR_GAP = 0.01
_VERSION = 3


@compiled()
def _entire(s, h):  # pragma: no cover
    """``(cos(k h), k sin(k h), sin(k h) / k)`` for ``k = sqrt(s)``, entire in ``s``
    (``cosh``, ``-kappa sinh``, ``sinh / kappa`` for ``s = -kappa^2 < 0``)."""
    if s > 0.0:
        k = math.sqrt(s)
        c, sn = math.cos(k * h), math.sin(k * h)
        return c, k * sn, sn / k
    if s < 0.0:
        k = math.sqrt(-s)
        c, sn = math.cosh(k * h), math.sinh(k * h)
        return c, -k * sn, sn / k
    return 1.0, 0.0, h


@compiled()
def _edge(m2, h):  # pragma: no cover
    """``(mu tanh(mu h), tanh(mu h) / mu)`` for ``mu = sqrt(m2)``, entire in ``m2``."""
    if m2 > 0.0:
        m = math.sqrt(m2)
        t = math.tanh(m * h)
        return m * t, t / m
    if m2 < 0.0:
        m = math.sqrt(-m2)
        t = math.tan(m * h)
        return -m * t, t / m
    return 0.0, h


@compiled()
def _characteristic(s, so, h, free, odd, nu):  # pragma: no cover
    """Left side of the one-dimensional characteristic equation (module notes) at
    ``s_x = s`` for ``s_y = so``, half-length ``h``."""
    c, ks, sk = _entire(s, h)
    mt, tm = _edge(s + 2.0 * so, h)
    if free:
        p = s + nu * so
        q = s + (2.0 - nu) * so
        if odd:
            return -p * p * sk + q * q * c * tm
        return q * q * ks + p * p * c * mt
    if odd:
        return sk - c * tm
    return ks + c * mt


@compiled()
def _illinois(lo, hi, flo, fhi, so, h, free, odd, nu, squared):  # pragma: no cover
    """Root of the characteristic function in the bracket ``[lo, hi]`` (values ``flo``,
    ``fhi`` of opposite signs) by the Illinois variant of regula falsi (superlinear,
    never leaves the bracket). ``squared``: the variable is ``k`` and ``s = k^2``."""
    side = 0
    for _ in range(_BISECTIONS):
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < x < hi):
            x = 0.5 * (lo + hi)
        fx = _characteristic(x * x if squared else x, so, h, free, odd, nu)
        if fx == 0.0 or hi - lo <= 4e-16 * max(abs(lo), abs(hi)):
            return x
        if (fx > 0.0) == (flo > 0.0):
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
    return 0.5 * (lo + hi)


@compiled()
def _root(n, so, h, free, nu):  # pragma: no cover
    """``s`` of the ``n``-th root of the one-dimensional equation for ``s_y = so``.

    ``n >= 2``: bisection in ``k = sqrt(s)`` on ``((n - 1) pi / (2h), n pi / (2h)]``,
    where the equation changes sign (module notes). Free ``n = 0, 1`` (the beam-like and
    torsion-like families, ``s`` near 0 and possibly negative): the root is bracketed
    by scanning ``s`` from ``(pi / (2h))^2`` (``n = 1``) or 0 (``n = 0``) downwards to
    the edge terms' limit ``s + 2 so > 0``. Returns NaN if no root is bracketed.
    """
    odd = n % 2 == 1
    if n >= 2:
        lo = (n - 1) * math.pi / (2.0 * h) * (1.0 + 1e-15)
        hi = n * math.pi / (2.0 * h)
        flo = _characteristic(lo * lo, so, h, free, odd, nu)
        fhi = _characteristic(hi * hi, so, h, free, odd, nu)
        if flo == 0.0:
            return lo * lo
        if fhi == 0.0:
            return hi * hi
        if (flo > 0.0) == (fhi > 0.0):
            return math.nan
        return _illinois(lo, hi, flo, fhi, so, h, free, odd, nu, True) ** 2
    # free, n = 0 or 1: scan s downwards from the top of the bracket
    top = (math.pi / (2.0 * h)) ** 2 if odd else 0.0
    bottom = -2.0 * so if so > 0.0 else top - (math.pi / h) ** 2
    if bottom >= top:
        return math.nan
    steps = 256
    prev_s = top * (1.0 - 1e-12) if top > 0.0 else -1e-300
    prev_f = _characteristic(prev_s, so, h, free, odd, nu)
    for i in range(1, steps + 1):
        s = top + (bottom - top) * (i / steps) * (1.0 - 1e-9)
        f = _characteristic(s, so, h, free, odd, nu)
        if (f > 0.0) != (prev_f > 0.0):
            return _illinois(s, prev_s, f, prev_f, so, h, free, odd, nu, False)
        prev_s, prev_f = s, f
    return math.nan


@compiled()
def _solve_pairs(nx, ny, hx, hy, free, nu, sx, sy):  # pragma: no cover
    """``(s_x, s_y)`` of every index pair by alternating the two equations, in place.
    Starts from the values in ``sx``, ``sy``."""
    for k in range(nx.size):
        a, b = sx[k], sy[k]
        for _ in range(_ALTERNATIONS):
            a_new = _root(nx[k], b, hx, free, nu)
            b_new = _root(ny[k], a_new, hy, free, nu)
            if not (math.isfinite(a_new) and math.isfinite(b_new)):
                a, b = math.nan, math.nan
                break
            done = abs(a_new - a) <= 1e-14 * abs(a_new + b_new) and abs(b_new - b) <= 1e-14 * abs(
                a_new + b_new
            )
            a, b = a_new, b_new
            if done:
                break
        sx[k], sy[k] = a, b


def _start(n, h, free):
    """Starting ``s`` of index ``n``: Bolotin's phase with ``2 arctan(r) = pi / 2``
    (the beam's ``(n - 1/2) pi``), 0 for the free low families."""
    k = (n - 0.5) * math.pi / (2.0 * h)
    if free:
        k = np.where(n >= 2, k, np.where(n == 1, 0.5 * math.pi / (2.0 * h), 0.0))
    return np.asarray(k * k, dtype=float)


def _ratios(aspect: float):
    """``(L/a, L/b)`` for ``aspect = a/b`` and ``L = max(a, b)``."""
    return (1.0, aspect) if aspect >= 1.0 else (1.0 / aspect, 1.0)


def mode_count_estimate(aspect: float, omega: float) -> float:
    """Modes below the dimensionless frequency ``omega`` (``omega L^2 sqrt(rho h / D)``,
    ``L = max(a, b)``): the plate's modal density ``N ~ omega a b / (4 pi)`` (Cremer,
    Heckl & Petersson, Structure-Borne Sound, 3rd ed., eq. 5.118) in units of ``L``."""
    rx, ry = _ratios(aspect)
    return omega / (4.0 * math.pi * rx * ry)


class EdgeEffectSolution:
    """Modes of a free or clamped plate of aspect ``a/b`` and Poisson ``nu`` up to the
    dimensionless ``omega_max`` by the dynamic edge effect method and the Rayleigh-Ritz
    step on its shapes (module notes).

    Lengths are in units of ``L = max(a, b)``: the plate is ``[-A/2, A/2] x [-B/2, B/2]``,
    ``A = a / L``, ``B = b / L``. The trial shapes ``X_t(x) Y_t(y)`` have indices
    ``(nx[t], ny[t])`` and ``s_x = sx[t]``, ``s_y = sy[t]``, in the order of their edge
    effect frequencies ``sx + sy``. ``omega`` ascending; mode ``k`` is
    ``own[k] * trial[k] + other[k] * trial[partner[k]]`` (``partner[k] = -1``: the trial
    alone), of mean square 1.
    """

    def __init__(self, boundary: str, nu: float, aspect: float, omega_max: float):
        self.boundary = boundary
        self.nu = nu
        self.aspect = aspect
        self.omega_max = omega_max
        rx, ry = _ratios(aspect)
        self.half = (0.5 / rx, 0.5 / ry)
        free = boundary == "free"
        hx, hy = self.half
        # trials up to a margin above the band: the Rayleigh-Ritz step moves a pair's
        # frequencies by at most about the pair's gap
        omega_trials = omega_max * (1.0 + 2.0 * _PAIR_GAP)
        # indices: k_x >= (N_x - 1) pi / A and k_x^2 + k_y^2 <= omega (s >= 0 families);
        # free N = 0, 1 families have s <= (pi / A)^2.
        first = 0 if free else 2
        kmax = math.sqrt(omega_trials)
        nx_max = int(kmax * 2.0 * hx / math.pi) + 2
        ny_max = int(kmax * 2.0 * hy / math.pi) + 2
        ix = np.arange(first, nx_max + 1)
        iy = np.arange(first, ny_max + 1)
        kx_lo = np.maximum(ix - 1, 0) * math.pi / (2.0 * hx)
        ky_lo = np.maximum(iy - 1, 0) * math.pi / (2.0 * hy)
        keep = kx_lo[:, None] ** 2 + ky_lo[None, :] ** 2 <= omega_trials * (1.0 + 1e-9)
        gi, gj = np.nonzero(keep)
        nx, ny = ix[gi].astype(np.int64), iy[gj].astype(np.int64)
        if free:
            rigid = ((nx == 0) & (ny == 0)) | ((nx == 1) & (ny == 0)) | ((nx == 0) & (ny == 1))
            nx, ny = nx[~rigid], ny[~rigid]
        sx = _start(nx, hx, free).copy()
        sy = _start(ny, hy, free).copy()
        _solve_pairs(nx, ny, hx, hy, free, float(nu), sx, sy)
        om = sx + sy
        ok = np.isfinite(om) & (om > 0.0) & (om <= omega_trials)
        self.unsolved = int(np.sum(~np.isfinite(om)))
        order = np.lexsort((ny[ok], nx[ok], om[ok]))
        trial_omega = np.ascontiguousarray(om[ok][order])
        self.nx = np.ascontiguousarray(nx[ok][order])
        self.ny = np.ascontiguousarray(ny[ok][order])
        self.sx = np.ascontiguousarray(sx[ok][order])
        self.sy = np.ascontiguousarray(sy[ok][order])
        self._factor_constants = None
        (cx, gx), (cy, gy) = self.factor_constants()
        partner = _pairs(trial_omega, self.nx % 2 * 2 + self.ny % 2, _PAIR_GAP)
        omega, own, other = _rayleigh_ritz(
            self.sx,
            self.sy,
            self.nx,
            self.ny,
            hx,
            hy,
            free,
            float(nu),
            cx,
            gx,
            cy,
            gy,
            trial_omega,
            partner,
        )
        by_omega = np.argsort(omega, kind="stable")
        n = int(np.searchsorted(omega[by_omega], omega_max, side="right"))
        modes = by_omega[:n]
        self.omega = np.ascontiguousarray(omega[modes])
        self.trial = np.ascontiguousarray(modes)
        self.partner = np.ascontiguousarray(partner[modes])
        self.own = np.ascontiguousarray(own[modes])
        self.other = np.ascontiguousarray(other[modes])
        self.n_paired = int(np.sum(self.partner >= 0))
        arrays = (self.omega, self.nx, self.ny, self.sx, self.sy, self.trial, self.partner)
        arrays += (self.own, self.other)
        for arr in arrays:
            arr.setflags(write=False)
        self.nbytes = sum(a.nbytes for a in arrays)
        self._tables = ({}, {})  # factor tables along x and along y (see _table)
        self.key = json.dumps(
            {
                "method": "edge-effect",
                "version": _VERSION,
                "boundary": boundary,
                "nu": float(nu).hex(),
                "aspect": float(aspect).hex(),
                "omega_max": float(omega_max).hex(),
                "pair_gap": float(_PAIR_GAP).hex(),
            },
            sort_keys=True,
        )

    def factor_constants(self):
        """``((ce_x, scale_x), (ce_y, scale_y))``: edge coefficient and normalising factor of
        every trial's two factors (computed once; a factor is ``scale (u + ce e)``, see
        :func:`_factor`)."""
        if self._factor_constants is None:
            free = self.boundary == "free"
            hx, hy = self.half
            nu = float(self.nu)
            self._factor_constants = (
                _factor_constants(self.sx, self.sy, self.nx, hx, free, nu),
                _factor_constants(self.sy, self.sx, self.ny, hy, free, nu),
            )
        return self._factor_constants

    def factors(self, xi: np.ndarray, eta: np.ndarray, n_trials: int):
        """The factors ``X_t(xi)`` and ``Y_t(eta)`` of the first ``n_trials`` trial shapes
        at ``xi, eta`` in [-1, 1] (``x = a (xi + 1) / 2``): arrays ``(len(xi), n_trials)``
        and ``(len(eta), n_trials)``, each factor of mean square 1 on [-1, 1]."""
        (cx, gx), (cy, gy) = self.factor_constants()
        hx, hy = self.half
        m = slice(0, n_trials)
        fx = _factor_table(
            np.ascontiguousarray(xi, dtype=float) * hx,
            self.sx[m],
            self.sy[m],
            self.nx[m],
            hx,
            cx[m],
            gx[m],
        )
        fy = _factor_table(
            np.ascontiguousarray(eta, dtype=float) * hy,
            self.sy[m],
            self.sx[m],
            self.ny[m],
            hy,
            cy[m],
            gy[m],
        )
        return fx, fy

    def _table(self, axis, u, trials):
        """Factors along ``axis`` (0: x, 1: y) of the trials ``trials`` (ascending indices)
        at the distinct coordinates ``u``; the last two tables of each axis are kept (a
        grid is evaluated chunk by chunk, each chunk with the same coordinates along one
        axis: that axis' table is computed once whatever the other's)."""
        tables = self._tables[axis]
        key = (trials.size, u.size, hash(u.tobytes()), hash(trials.tobytes()))
        held = tables.get(key)
        if held is not None and np.array_equal(held[0], u) and np.array_equal(held[1], trials):
            return held[2]
        (cx, gx), (cy, gy) = self.factor_constants()
        m = trials
        if axis == 0:
            h, s, so, n, c, g = self.half[0], self.sx[m], self.sy[m], self.nx[m], cx[m], gx[m]
        else:
            h, s, so, n, c, g = self.half[1], self.sy[m], self.sx[m], self.ny[m], cy[m], gy[m]
        table = _factor_table(u * h, s, so, n, h, c, g)
        if len(tables) >= 2:
            tables.clear()
        tables[key] = (u.copy(), trials.copy(), table)
        return table

    def shapes(self, xi, eta, n_modes, first=0, out=None, column=0, index=None):
        """Shapes of modes ``first <= k < n_modes`` (or of the modes ``index``, ascending
        integers, if given) at the points ``(xi, eta)``: an array ``(len(xi), n)``, ``n``
        the number of modes, or written into ``out[:, column:column + n]`` (C-ordered)
        and ``out`` returned. The factors of the trials these modes use are evaluated once
        per distinct coordinate (points of a grid share them)."""
        ux, inv_x = np.unique(xi, return_inverse=True)
        uy, inv_y = np.unique(eta, return_inverse=True)
        pick = slice(first, n_modes) if index is None else np.asarray(index, dtype=np.int64)
        trial = self.trial[pick]
        partner = self.partner[pick]
        used = np.unique(np.concatenate((trial, partner[partner >= 0])))
        fx = self._table(0, ux, used)
        fy = self._table(1, uy, used)
        if out is None:
            out, column = np.empty((xi.size, trial.size)), 0
        _gather_modes(
            fx,
            fy,
            inv_x.ravel(),
            inv_y.ravel(),
            np.searchsorted(used, trial),
            np.where(partner >= 0, np.searchsorted(used, partner), -1),
            self.own[pick],
            self.other[pick],
            out,
            column,
        )
        return out

    def product_factors(self, xi, eta, index):
        """The modes ``index`` (ascending integers) as tables of their factors at the
        distinct coordinates ``xi`` and ``eta`` (in [-1, 1]): ``(x_own, y_own, x_other,
        y_other)``, shapes ``(len(xi), n)`` and ``(len(eta), n)``, with mode ``index[k]`` at
        ``(xi[a], eta[b])`` equal to ``x_own[a, k] y_own[b, k] + x_other[a, k] y_other[b, k]``
        (the second product zero for a trial alone; the values of :meth:`shapes`)."""
        index = np.asarray(index, dtype=np.int64)
        trial = self.trial[index]
        partner = self.partner[index]
        paired = partner >= 0
        used = np.unique(np.concatenate((trial, partner[paired])))
        fx = self._table(0, np.asarray(xi, dtype=float), used)
        fy = self._table(1, np.asarray(eta, dtype=float), used)
        own = np.searchsorted(used, trial)
        other = np.searchsorted(used, np.where(paired, partner, trial))
        x_own = self.own[index] * fx[:, own]
        x_other = np.where(paired, self.other[index] * fx[:, other], 0.0)
        y_other = np.where(paired, fy[:, other], 0.0)
        return x_own, np.ascontiguousarray(fy[:, own]), x_other, y_other


def _pairs(omega: np.ndarray, cls: np.ndarray, gap: float) -> np.ndarray:
    """``partner[t]``: the trial paired with trial ``t`` (-1 if none). In ascending order
    of ``omega``, each unpaired trial takes the nearest unpaired one above it of the same
    symmetry class ``cls`` within the relative ``gap``."""
    partner = np.full(omega.size, -1, dtype=np.int64)
    for c in np.unique(cls):
        idx = np.flatnonzero(cls == c)
        w = omega[idx]
        i = 0
        while i + 1 < idx.size:
            if partner[idx[i]] < 0 and w[i + 1] - w[i] <= gap * w[i]:
                partner[idx[i]], partner[idx[i + 1]] = idx[i + 1], idx[i]
                i += 2
            else:
                i += 1
    return partner


@compiled()
def _exponentials(s, so, h, n, ce, scale, coef, rate, shift):  # pragma: no cover
    """A factor ``scale (u + ce e)`` (see :func:`_factor`) as ``sum_t coef[t] exp(rate[t]
    x + shift[t])`` on ``[-h, h]``, written into the arrays (4 entries); returns the
    number of terms, 0 for the measure-zero cases ``s = 0`` or ``s + 2 so = 0`` (a
    polynomial term)."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    if s == 0.0 or m2 == 0.0:
        return 0
    # u = cosh(k x) (even) or sinh(k x) / k (odd), k = sqrt(-s): cos(sqrt(s) x) and
    # sin(sqrt(s) x) / sqrt(s) for s > 0
    k = cmath.sqrt(complex(-s))
    coef[0] = 0.5 * scale
    coef[1] = (0.5 if not odd else -0.5) * scale
    if odd:
        coef[0] = coef[0] / k
        coef[1] = coef[1] / k
    rate[0], rate[1] = k, -k
    shift[0], shift[1] = 0.0, 0.0
    if m2 > 0.0:
        m = math.sqrt(m2)
        sign = -1.0 if odd else 1.0
        den = 1.0 + sign * math.exp(-2.0 * m * h)
        coef[2] = scale * ce / den
        coef[3] = sign * scale * ce / den
        rate[2], rate[3] = m, -m
        shift[2], shift[3] = -m * h, -m * h
    else:
        mu = math.sqrt(-m2)
        den = math.sin(mu * h) if odd else math.cos(mu * h)
        c = complex(scale * ce / (2.0 * den))
        if odd:
            c = -1j * c
        coef[2] = c
        coef[3] = -c if odd else c
        rate[2], rate[3] = 1j * mu, -1j * mu
        shift[2], shift[3] = 0.0, 0.0
    return 4


@compiled()
def _span(a, b, h):  # pragma: no cover
    """``Int_{-h}^{h} exp(a x + b) dx`` for complex ``a``, ``b``."""
    z = a * h
    if abs(z) < 1e-3:
        return cmath.exp(b) * 2.0 * h * (1.0 + z * z / 6.0 + z * z * z * z / 120.0)
    return (cmath.exp(b + z) - cmath.exp(b - z)) / a


@compiled()
def _moments(c1, a1, b1, c2, a2, b2, h, out):  # pragma: no cover
    """``out = (Int f g, Int f' g', Int f'' g'', Int f'' g, Int f g'')`` over ``[-h, h]``
    of two factors in exponential form (:func:`_exponentials`), in closed form."""
    for i in range(5):
        out[i] = 0.0
    for i in range(4):
        for j in range(4):
            v = c1[i] * c2[j] * _span(a1[i] + a2[j], b1[i] + b2[j], h)
            p = a1[i] * a1[i]
            q = a2[j] * a2[j]
            out[0] += v.real
            out[1] += (a1[i] * a2[j] * v).real
            out[2] += (p * q * v).real
            out[3] += (p * v).real
            out[4] += (q * v).real


@compiled()
def _pair_eigen(kk, mm):  # pragma: no cover
    """Eigenpairs of ``K v = lam M v`` (2 x 2, symmetric, ``M`` positive definite):
    ``(lam, v0, v1)``, ``lam`` ascending, column ``j`` the vector ``(v0[j], v1[j])`` with
    ``v^T M v = 1``. Cholesky ``M = L L^T`` and one Jacobi rotation of ``L^-1 K L^-T``:
    orthogonal to rounding even for a nearly degenerate pair (where the quadratic
    formula's roots, and vectors from them, lose half the digits)."""
    l00 = math.sqrt(mm[0, 0])
    l10 = mm[0, 1] / l00
    l11 = math.sqrt(mm[1, 1] - l10 * l10)
    k01 = 0.5 * (kk[0, 1] + kk[1, 0])
    # C = L^-1 K L^-T
    a00 = kk[0, 0] / l00
    a01 = k01 / l00
    a10 = (k01 - l10 * a00) / l11
    a11 = (kk[1, 1] - l10 * a01) / l11
    c00 = a00 / l00
    c01 = (a01 - l10 * c00) / l11
    c11 = (a11 - l10 * (a10 / l00)) / l11
    if c01 == 0.0:
        t = 0.0
    else:
        tau = (c11 - c00) / (2.0 * c01)
        t = (1.0 if tau >= 0.0 else -1.0) / (abs(tau) + math.sqrt(1.0 + tau * tau))
    cs = 1.0 / math.sqrt(1.0 + t * t)
    sn = t * cs
    lam = np.array([c00 - t * c01, c11 + t * c01])
    q0 = np.array([cs, sn])  # first components of the two eigenvectors of C
    q1 = np.array([-sn, cs])
    if lam[0] > lam[1]:
        lam = lam[::-1].copy()
        q0 = q0[::-1].copy()
        q1 = q1[::-1].copy()
    v1 = q1 / l11
    v0 = (q0 - l10 * v1) / l00
    return lam, v0, v1


@compiled()
def _rayleigh_ritz(
    sx, sy, nx, ny, hx, hy, free, nu, cx, gx, cy, gy, omega, partner
):  # pragma: no cover
    """Frequencies and shape coefficients of the Rayleigh-Ritz step (module notes):
    ``(omega, own, other)`` per trial. A pair ``(t, partner[t])`` solves the 2 x 2
    problem ``K v = omega^2 M v`` on its two trial shapes, the lower root going to the
    lower trial; a clamped trial alone takes its Rayleigh quotient; a free one alone keeps
    its edge effect frequency. Trials whose factors have a polynomial term keep theirs."""
    n = omega.size
    out = omega.copy()
    own = np.ones(n)
    other = np.zeros(n)
    area = 4.0 * hx * hy
    cf = np.zeros((4, 4), dtype=np.complex128)
    rf = np.zeros((4, 4), dtype=np.complex128)
    bf = np.zeros((4, 4), dtype=np.complex128)
    mx = np.zeros(5)
    my = np.zeros(5)
    kk = np.zeros((2, 2))
    mm = np.zeros((2, 2))
    for t in range(n):
        u = partner[t]
        if u >= 0 and u < t:
            continue  # solved with its partner
        if u < 0 and free:
            continue
        members = (t, u) if u >= 0 else (t, t)
        size = 2 if u >= 0 else 1
        good = True
        for j in range(size):
            r = members[j]
            good &= (
                _exponentials(
                    sx[r], sy[r], hx, nx[r], cx[r], gx[r], cf[2 * j], rf[2 * j], bf[2 * j]
                )
                == 4
            )
            good &= (
                _exponentials(
                    sy[r],
                    sx[r],
                    hy,
                    ny[r],
                    cy[r],
                    gy[r],
                    cf[2 * j + 1],
                    rf[2 * j + 1],
                    bf[2 * j + 1],
                )
                == 4
            )
        if not good:
            continue
        for i in range(size):
            for j in range(size):
                _moments(cf[2 * i], rf[2 * i], bf[2 * i], cf[2 * j], rf[2 * j], bf[2 * j], hx, mx)
                _moments(
                    cf[2 * i + 1],
                    rf[2 * i + 1],
                    bf[2 * i + 1],
                    cf[2 * j + 1],
                    rf[2 * j + 1],
                    bf[2 * j + 1],
                    hy,
                    my,
                )
                mm[i, j] = mx[0] * my[0] / area
                kk[i, j] = (
                    mx[2] * my[0]
                    + mx[0] * my[2]
                    + nu * (mx[3] * my[4] + mx[4] * my[3])
                    + 2.0 * (1.0 - nu) * mx[1] * my[1]
                ) / area
        if size == 1:
            out[t] = math.sqrt(kk[0, 0] / mm[0, 0])
            own[t] = 1.0 / math.sqrt(mm[0, 0])
            continue
        lam, v0, v1 = _pair_eigen(kk, mm)
        for j in range(2):
            slot = members[j]
            out[slot] = math.sqrt(lam[j])
            if j == 0:  # the lower root stays with the lower trial
                own[slot], other[slot] = v0[j], v1[j]
            else:
                own[slot], other[slot] = v1[j], v0[j]
    return out, own, other


@compiled()
def _coefficients(s, so, h, n, free, nu):  # pragma: no cover
    """``(c_edge, norm)`` of the factor ``u(x) + c_edge e(x)``: ``u = cos(k x)`` or
    ``sin(k x) / k`` (entire in ``s``), ``e = cosh(mu x) / cosh(mu h)`` or
    ``sinh(mu x) / sinh(mu h)``, the edge coefficient from the better-conditioned edge
    condition and ``norm`` making the mean square over ``[-h, h]`` 1 (Gauss-Legendre
    sum over panels fine enough for ``k`` and ``mu``)."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    c, ks, sk = _entire(s, h)
    mt, tm = _edge(m2, h)
    if free:
        p = s + nu * so
        q = s + (2.0 - nu) * so
        if not odd:
            # M: -P c + C Q = 0 (e(h) = 1); V: Q ks' + C P mu tanh = 0
            if abs(q) >= abs(p * mt) * 1e-3:
                ce = p * c / q
            else:
                ce = -q * ks / (p * mt)
        else:
            # M: -P sk... u = sin(kx)/k: u(h) = sk, u''(h) = -s sk; e(h) = 1, e'' = m2
            # M: u'' - nu so u + C (m2 - nu so) = -(s + nu so) sk + C q = 0
            if abs(q) >= 1e-3 * abs(p):
                ce = p * sk / q
            else:
                # V: u''' - (2-nu) so u' + C (mu^3 coth - (2-nu) so mu coth) = 0
                # u' = c, u''' = -s c: -(s + (2-nu) so) c + C P / tm = 0
                ce = q * c * tm / p
    else:
        ce = -(sk if odd else c)
    return ce


@compiled()
def interior_part(x, s, h, n):  # pragma: no cover
    """Interior part ``u`` of one factor at ``x`` in ``[-h, h]`` (unnormalised, see
    :func:`factor_parts`): ``cos``, ``sin / k`` (``cosh``, ``sinh / k`` for ``s < 0``)."""
    odd = n % 2 == 1
    if s > 0.0:
        k = math.sqrt(s)
        return math.sin(k * x) / k if odd else math.cos(k * x)
    if s < 0.0:
        k = math.sqrt(-s)
        return math.sinh(k * x) / k if odd else math.cosh(k * x)
    return x if odd else 1.0


@compiled()
def edge_part(x, s, so, h, n):  # pragma: no cover
    """Edge part ``e`` of one factor at ``x`` in ``[-h, h]`` (see :func:`factor_parts`):
    ``cosh(mu x) / cosh(mu h)`` or ``sinh(mu x) / sinh(mu h)``, ``mu^2 = s + 2 so``
    (``cos``, ``sin`` for ``mu^2 < 0``), 1 at the edge ``x = h``."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    if m2 > 0.0:
        m = math.sqrt(m2)
        # cosh(m x) / cosh(m h) and sinh(m x) / sinh(m h) without overflow
        d1 = math.exp(-m * (h - x))
        d2 = math.exp(-m * (h + x))
        den = 1.0 + math.exp(-2.0 * m * h) * (-1.0 if odd else 1.0)
        if odd:
            return (d1 - d2) / den if den > 0.0 else x / h
        return (d1 + d2) / den
    if m2 < 0.0:
        m = math.sqrt(-m2)
        return math.sin(m * x) / math.sin(m * h) if odd else math.cos(m * x) / math.cos(m * h)
    return x / h if odd else 1.0


@compiled()
def factor_parts(x, s, so, h, n):  # pragma: no cover
    """Interior and edge parts ``(u, e)`` of one factor at ``x`` in ``[-h, h]``
    (unnormalised): the factor is ``u + ce e``. Each part solves a Helmholtz equation
    along its axis (the boundary rule of synth.sound.radiation integrates them apart)."""
    return interior_part(x, s, h, n), edge_part(x, s, so, h, n)


@compiled()
def _factor(x, s, so, h, n, ce):  # pragma: no cover
    """One factor's value at ``x`` in ``[-h, h]`` (unnormalised)."""
    u, e = factor_parts(x, s, so, h, n)
    return u + ce * e


@compiled()
def _norm(s, so, h, n, ce):  # pragma: no cover
    """Root mean square of a factor over ``[-h, h]`` (Gauss-Legendre panels)."""
    k = math.sqrt(abs(s)) + math.sqrt(abs(s + 2.0 * so)) + 1.0 / h
    panels = int(k * h / 2.0) + 2
    # 8-point Gauss-Legendre
    t = np.array(
        [
            -0.9602898564975363,
            -0.7966664774136267,
            -0.5255324099163290,
            -0.1834346424956498,
            0.1834346424956498,
            0.5255324099163290,
            0.7966664774136267,
            0.9602898564975363,
        ]
    )
    w = np.array(
        [
            0.1012285362903763,
            0.2223810344533745,
            0.3137066458778873,
            0.3626837833783620,
            0.3626837833783620,
            0.3137066458778873,
            0.2223810344533745,
            0.1012285362903763,
        ]
    )
    total = 0.0
    half = h / panels
    for p in range(panels):
        mid = -h + (2 * p + 1) * half
        for i in range(8):
            v = _factor(mid + half * t[i], s, so, h, n, ce)
            total += w[i] * half * v * v
    return math.sqrt(total / (2.0 * h))


@compiled()
def _factor_constants(s, so, n, h, free, nu):  # pragma: no cover
    """Edge coefficient and ``1 / rms`` of every factor (:func:`_coefficients`; the mean
    square in closed form, :func:`_exponentials` and :func:`_moments`, or by
    :func:`_norm`'s quadrature for the measure-zero polynomial cases)."""
    ce = np.empty(s.size)
    scale = np.empty(s.size)
    coef = np.zeros(4, dtype=np.complex128)
    rate = np.zeros(4, dtype=np.complex128)
    shift = np.zeros(4, dtype=np.complex128)
    mom = np.zeros(5)
    for k in range(s.size):
        ce[k] = _coefficients(s[k], so[k], h, n[k], free, nu)
        if _exponentials(s[k], so[k], h, n[k], ce[k], 1.0, coef, rate, shift) == 4:
            _moments(coef, rate, shift, coef, rate, shift, h, mom)
            mean_square = mom[0] / (2.0 * h)
            if mean_square > 0.0 and math.isfinite(mean_square):
                scale[k] = 1.0 / math.sqrt(mean_square)
                continue
        scale[k] = 1.0 / _norm(s[k], so[k], h, n[k], ce[k])
    return ce, scale


@compiled()
def _factor_table(x, s, so, n, h, ce, scale):  # pragma: no cover
    """``out[p, k]``: factor ``k`` (normalised) at ``x[p]`` in ``[-h, h]``."""
    out = np.empty((x.size, s.size))
    for p in range(x.size):
        for k in range(s.size):
            out[p, k] = scale[k] * _factor(x[p], s[k], so[k], h, n[k], ce[k])
    return out


@compiled()
def _gather_modes(fx, fy, ix, iy, trial, partner, own, other, out, column):  # pragma: no cover
    """``out[p, column + k] = own[k] X_t Y_t + other[k] X_u Y_u`` at point ``p`` (tables
    ``fx``, ``fy`` of the trials' factors at the distinct coordinates ``ix[p]``,
    ``iy[p]``; ``t = trial[k]``, ``u = partner[k]``, none if -1).

    The factors are first laid out in the modes' order, ``own[k] X_t`` and
    ``other[k] X_u`` per distinct x and ``Y_t``, ``Y_u`` per distinct y (0 without a
    partner), so that each point's row is two products and a sum over contiguous arrays
    (the same operations, in the same order, as term by term)."""
    m = trial.size
    gx = np.zeros((fx.shape[0], m))
    hx = np.zeros((fx.shape[0], m))
    gy = np.zeros((fy.shape[0], m))
    hy = np.zeros((fy.shape[0], m))
    paired = False
    for k in range(m):
        paired = paired or partner[k] >= 0
    for a in range(fx.shape[0]):
        for k in range(m):
            gx[a, k] = own[k] * fx[a, trial[k]]
            if partner[k] >= 0:
                hx[a, k] = other[k] * fx[a, partner[k]]
    for b in range(fy.shape[0]):
        for k in range(m):
            gy[b, k] = fy[b, trial[k]]
            if partner[k] >= 0:
                hy[b, k] = fy[b, partner[k]]
    for p in range(ix.size):
        ga, ha = gx[ix[p]], hx[ix[p]]
        gb, hb = gy[iy[p]], hy[iy[p]]
        row = out[p, column : column + m]
        if paired:
            for k in range(m):
                row[k] = ga[k] * gb[k] + ha[k] * hb[k]
        else:
            for k in range(m):
                row[k] = ga[k] * gb[k]


def solve(boundary: str, nu: float, aspect: float, omega_max: float) -> EdgeEffectSolution:
    """Modes up to the dimensionless ``omega_max`` (see :class:`EdgeEffectSolution`)."""
    return EdgeEffectSolution(boundary, nu, aspect, omega_max)
