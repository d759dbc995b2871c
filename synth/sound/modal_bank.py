"""Exact pulse-to-mode synthesis (docs/physics.md, "Modal synthesis").

A force ``F(t)`` at ``x0`` drives each mode ``k`` of the plate (pole
``p_k = -sigma_k + i omega_dk``, shape ``phi_k``, modal mass ``M_k``)::

    q_k'' + 2 sigma_k q_k' + omega_k^2 q_k = b_k F(t),       b_k = phi_k(x0) / M_k

After a pulse that starts at ``t_n`` the mode rings exactly as

    q_k(t) = Re[A_nk exp(p_k (t - t_n))],    A_nk = -i b_k L_nk / omega_dk,
    L_nk = Int_0^tau F(u) exp(-p_k u) du         (the pulse's Laplace transform at the pole)

and a listener hears ``Re[G_k p_k A_nk exp(...)]`` (velocity times the
microphone's Rayleigh gain ``G_k``, Pa per m/s) or ``Re[phi_k(xp) p_k^2 A_nk
exp(...)]`` (an accelerometer, m/s^2). Samples inside a contact get the exact
partial transform ``Int_0^(t - t_n)`` instead, plus, for acceleration, the
direct term ``b_k F(t)``. Every impact is a complex amplitude injected into one
pass of the modal bank, so overlapping tails add exactly and every onset sits at
its true (sub-sample) time: nothing is rounded to the sample grid. A mode at or
above the Nyquist frequency is never rendered, so nothing aliases.

The transform is computed on a uniform grid of the pulse (from the contact
solver's dense output, an odd number of points, at least ``PULSE_POINTS``, fine
enough that ``omega_max h <= pi/4`` so the exponential is resolved at every
mode's frequency). The pulse vanishes like ``u^n`` at both ends (``n`` the
contact law's exponent, 3/2 for Hertz), so the trapezoid rule's leading error is
``C h^(n+1)`` (Navot's endpoint expansion, the ``zeta(-n)`` term; 1.5e-5 of the
impulse for the thesis pulse on 65 points, measured) and no ``h^2`` term arises.
One Richardson step on the grid and on every other point removes it for every
mode with ``omega h <= 1/2`` (above that the step-2h rule no longer resolves the
oscillation and the plain rule is kept); what is left is of order ``|p|
h^(n+2)``: below 1e-7 of the impulse under 3 kHz and 2e-6 at 23 kHz for the
thesis pulse on 65 points (``tests/test_render.py`` checks this against adaptive
quadrature of the dense output). The in-contact samples' partial transforms
``Int_0^d`` end inside the pulse, where it is smooth: the trapezoid rule there has
an ``h^2`` term, removed by the Euler-Maclaurin end corrections with the force's
slope from the dense output (see ``_impact``).

Leaving out, with a budget. ``reference`` is the largest, over the impacts, of
the sum of the amplitudes ``|C_nk|`` of one impact (it bounds the peak of a
tick); each of the ``K`` modes below Nyquist gets the share ``floor * reference
/ K`` of the budget ``floor * reference``:

* a mode whose amplitudes add up, over all impacts, to at most its share is not
  rendered (it could never add more than that at any sample);
* a rendered mode stops, at an injection or when its state has fallen below its
  share (checked every ``SUB`` samples), if its state plus what it has already
  left out (decayed to now) is within its share; it restarts at the next impact;
* the audio ends when every mode has stopped (or at the caller's length cap,
  reported as ``left_at_end``).

So at every sample the omitted modes and tails add up to at most ``floor *
reference``, for any number of impacts.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from synth.errors import ParameterError
from synth.vecmath import cis, exp_small, halvings_for

#: Fewest points of the uniform grid on which a pulse's transforms are taken.
PULSE_POINTS = 65

#: Largest phase step ``omega h`` (rad) of the pulse grid at which a mode's transform is
#: extrapolated (see ``_impact``); the grid keeps ``omega_max h <= pi / 4``.
RICHARDSON_MAX_PHASE = 0.5

#: Samples a mode writes from its power table before its state is advanced (and the
#: tail floor checked).
SUB = 32
#: Samples per tile of the modal bank's output (16 kB of float64: stays in cache).
TILE = 2048


# fast-math without approximate transcendental functions ("afn"): exp, cos, sin stay exact
_FAST = {"nnan", "ninf", "nsz", "arcp", "contract", "reassoc"}


@numba.njit(cache=True, fastmath=_FAST)
def _magnitude_sum(amps):
    """``sum_k |amps_k|`` of complex amplitudes (bounds the peak of what they ring)."""
    total = 0.0
    for k in range(amps.shape[0]):
        total += math.sqrt(amps[k].real * amps[k].real + amps[k].imag * amps[k].imag)
    return total


@numba.njit(cache=True)
def _sample_due(m, M, j, N, uj, h, d0, period):
    """Whether in-contact sample ``m`` (of ``M``) falls in ``[u_j, u_j + h)`` (or at or
    after ``u_j``, the last of ``N`` points)."""
    return m < M and (j == N - 1 or d0 + m * period < uj + h)


@numba.njit(cache=True, fastmath=_FAST)
def _in_contact(
    m, j, N, h, d0, period, forces, slopes, offset_forces, offset_slopes,
    pr, pi, cr, ci, ur, ui, vr, vi, er, ei, qr, qi, gr, gi, tr, ti, resp,
):  # fmt: skip
    """The responses ``resp[m], ...`` of the in-contact samples that fall in ``[u_j,
    u_j + h)`` (see :func:`_impact`): from ``E = e^(-p u_j)`` (er, ei) and the rule to
    ``u_j`` (qr, qi), each the partial panel to the sample with its end corrections.
    Advances ``e^(p d)`` (gr, gi) and ``e^(-p d)`` (tr, ti) past each; returns the next
    ``m``."""
    K = pr.shape[0]
    M = offset_forces.shape[0]
    uj = j * h
    fj = forces[j]
    sj = slopes[j]
    while _sample_due(m, M, j, N, uj, h, d0, period):
        dd = d0 + m * period - uj
        if dd < 0.0:
            dd = 0.0
        fd = offset_forces[m]
        sd = offset_slopes[m]
        wj = (dd * dd - h * h) / 12.0
        wd = dd * dd / 12.0
        acc = 0.0
        for k in range(K):
            yr = qr[k] + 0.5 * dd * (fj * er[k] + fd * tr[k])
            yi = qi[k] + 0.5 * dd * (fj * ei[k] + fd * ti[k])
            # end corrections: g'(u) = (F'(u) - p F(u)) e^(-p u)
            a1 = sj - pr[k] * fj
            b1 = -pi[k] * fj
            a2 = sd - pr[k] * fd
            b2 = -pi[k] * fd
            yr += wj * (a1 * er[k] - b1 * ei[k]) - wd * (a2 * tr[k] - b2 * ti[k])
            yi += wj * (a1 * ei[k] + b1 * er[k]) - wd * (a2 * ti[k] + b2 * tr[k])
            # Re[c y e^(p d)]
            zr = yr * gr[k] - yi * gi[k]
            zi = yr * gi[k] + yi * gr[k]
            acc += cr[k] * zr - ci[k] * zi
            # advance e^(p d) and e^(-p d) by one sample
            nr = gr[k] * ur[k] - gi[k] * ui[k]
            gi[k] = gr[k] * ui[k] + gi[k] * ur[k]
            gr[k] = nr
            nr = tr[k] * vr[k] - ti[k] * vi[k]
            ti[k] = tr[k] * vi[k] + ti[k] * vr[k]
            tr[k] = nr
        resp[m] = acc
        m += 1
    return m


@numba.njit(cache=True, fastmath=_FAST)
def _impact(
    pr,
    pi,
    cr,
    ci,
    ur,
    ui,
    period,
    h,
    forces,
    slopes,
    d0,
    offset_forces,
    offset_slopes,
    weight,
    tau,
    order,
    amps,
    resp,
    work,
):
    """One impact's contribution (vectorised over the K modes).

    pr, pi: poles (real, imaginary parts), rad/s; cr, ci: listener response per unit
    transform (``-i b_k output_k / omega_dk``); ur, ui: ``e^(p_k period)``, the ringing
    over one sample; period: ``1 / fs``, s; h, forces: the pulse on a uniform grid
    ``u_j = j h`` (s, N), slopes: ``dF/du`` there (N/s); d0: time from first touch to
    the first audio sample at or after it (s, in ``[0, period)``); offset_forces (M,):
    the force at the M audio samples inside the contact, at ``d0 + m period`` from
    first touch (N), offset_slopes (M,): ``dF/du`` there (N/s); weight: the
    weight ``m g`` (N) left on the plate after a settled contact (0 otherwise); tau:
    contact time, s.

    Writes amps (K,) complex: the ringing injected at the first sample after the
    contact, ``d0 + M period`` from first touch; resp (M,): the exact response at the
    in-contact samples (partial transforms ``Int_0^d``: the trapezoid rule on the grid
    to ``u_j <= d`` and on the partial panel ``[u_j, d]``, with the Euler-Maclaurin end
    corrections ``h^2/12 (g'(0) - g'(u_j)) + dd^2/12 (g'(u_j) - g'(d))`` of the
    integrand ``g = F e^(-p u)``, ``dd = d - u_j``, which make both exact for cubics;
    ``g'(0) = 0`` as the pulse starts like ``u^n``, ``n > 1``).

    order: the exponent ``q`` of the trapezoid rule's leading error ``C h^q`` (the pulse
    vanishes like ``u^n`` at both ends, so ``q = n + 1``; see the module docstring). The
    whole transform is extrapolated from the rules on the grid and on every other point,
    ``(2^q T_h - T_2h) / (2^q - 1)`` (``len(forces)`` odd); 0 turns this off. work: a
    (``WORK_ROWS``, K) workspace (allocated by the caller, so that the live engine's
    audio thread allocates nothing).

    Returns ``sum_k |amps_k|``.

    Per mode, two complex exponentials (``e^(-p h)``, the transform's step, and
    ``e^(p d0)``) by the polynomials of :mod:`synth.vecmath`, so that every loop over
    the modes vectorises; everything else follows by products: ``e^(-p u_j)`` by powers
    of the step, the in-contact samples and the injection time by powers of
    ``e^(+-p period)``.
    """
    K = pr.shape[0]
    N = forces.shape[0]
    M = offset_forces.shape[0]
    # arguments of the real exponentials, scaled into [-1, 1] (vecmath.exp_squared)
    sigma = 0.0
    for k in range(K):
        sigma = max(sigma, abs(pr[k]))
    halvings = halvings_for(sigma * max(h, d0))
    scale = 0.5**halvings
    # the K-vectors below are rows of the workspace
    er, ei = work[0], work[1]  # e^(-p u_j)
    sr, si = work[2], work[3]  # e^(-p h)
    gr, gi = work[4], work[5]  # e^(p d), d the next in-contact sample (then the injection)
    tr, ti = work[6], work[7]  # e^(-p d)
    vr, vi = work[8], work[9]  # e^(-p period)
    s2r, s2i = work[10], work[11]  # e^(-2 p h)
    evr, evi = work[12], work[13]  # sums over the even and the odd points (see below)
    odr, odi = work[14], work[15]
    qr, qi = work[16], work[17]  # scratch for an in-contact sample: the rule to u_j
    xr, xi = work[18], work[19]  # and E at an odd point
    work[0] = 1.0
    work[1] = 0.0
    work[12:16] = 0.0
    for k in range(K):  # |e^(-p h)|, |e^(p d0)| (loops kept apart so that each vectorises)
        sr[k] = exp_small(-pr[k] * h * scale)
        gr[k] = exp_small(pr[k] * d0 * scale)
    for _ in range(halvings):
        for k in range(K):
            sr[k] *= sr[k]
            gr[k] *= gr[k]
    for k in range(K):
        c, s = cis(pi[k] * h)
        si[k] = -sr[k] * s
        sr[k] *= c
        c, s = cis(pi[k] * d0)
        mag = gr[k]
        gr[k] = mag * c
        gi[k] = mag * s
        inv = 1.0 / mag
        tr[k] = c * inv
        ti[k] = -s * inv
        u2 = ur[k] * ur[k] + ui[k] * ui[k]
        vr[k] = ur[k] / u2
        vi[k] = -ui[k] / u2
    # The grid's points are taken two at a time from an even one, u_j and u_(j+1):
    #   ev += c_j E_j,   od += F_(j+1) E_j,   E_(j+2) = E_j s^2,
    # with E_j = e^(-p u_j), s = e^(-p h), c_j = F_j (F_0 / 2 at the first point); the
    # odd points' sum is s od. Then the trapezoid rule is h (ev + s od) (half weight at
    # the last point) and the rule of step 2h is 2 h ev.
    for k in range(K):
        s2r[k] = sr[k] * sr[k] - si[k] * si[k]
        s2i[k] = 2.0 * sr[k] * si[k]
    m = 0
    for j in range(0, N, 2):
        fj = forces[j]
        c_j = 0.5 * fj if (j == 0 or j == N - 1) else fj
        if _sample_due(m, M, j, N, j * h, h, d0, period):
            end = 0.5 * fj if j > 0 else 0.0  # u_j as the end of the rule (0 at u_0)
            for k in range(K):
                qr[k] = h * (evr[k] + odr[k] * sr[k] - odi[k] * si[k] + end * er[k])
                qi[k] = h * (evi[k] + odr[k] * si[k] + odi[k] * sr[k] + end * ei[k])
            m = _in_contact(
                m, j, N, h, d0, period, forces, slopes, offset_forces, offset_slopes,
                pr, pi, cr, ci, ur, ui, vr, vi, er, ei, qr, qi, gr, gi, tr, ti, resp,
            )  # fmt: skip
        if j == N - 1:
            for k in range(K):
                evr[k] += c_j * er[k]
                evi[k] += c_j * ei[k]
            break
        fo = forces[j + 1]
        c_o = 0.5 * fo if j + 1 == N - 1 else fo
        if _sample_due(m, M, j + 1, N, (j + 1) * h, h, d0, period):
            for k in range(K):
                xr[k] = er[k] * sr[k] - ei[k] * si[k]
                xi[k] = er[k] * si[k] + ei[k] * sr[k]
                ar = evr[k] + c_j * er[k]
                ai = evi[k] + c_j * ei[k]
                qr[k] = h * (ar + odr[k] * sr[k] - odi[k] * si[k] + 0.5 * fo * xr[k])
                qi[k] = h * (ai + odr[k] * si[k] + odi[k] * sr[k] + 0.5 * fo * xi[k])
            m = _in_contact(
                m, j + 1, N, h, d0, period, forces, slopes, offset_forces, offset_slopes,
                pr, pi, cr, ci, ur, ui, vr, vi, xr, xi, qr, qi, gr, gi, tr, ti, resp,
            )  # fmt: skip
        last = j + 2 >= N
        for k in range(K):
            evr[k] += c_j * er[k]
            evi[k] += c_j * ei[k]
            odr[k] += c_o * er[k]
            odi[k] += c_o * ei[k]
        if not last:
            for k in range(K):
                nr = er[k] * s2r[k] - ei[k] * s2i[k]
                ei[k] = er[k] * s2i[k] + ei[k] * s2r[k]
                er[k] = nr
        else:
            # N even: E at the last (odd) point, for the settled weight below
            for k in range(K):
                nr = er[k] * sr[k] - ei[k] * si[k]
                ei[k] = er[k] * si[k] + ei[k] * sr[k]
                er[k] = nr
    extrapolate = order > 0.0 and N % 2 == 1 and N >= 5
    c = 2.0**order
    inv_c1 = 1.0 / (c - 1.0) if extrapolate else 0.0
    for k in range(K):
        zr = h * (evr[k] + odr[k] * sr[k] - odi[k] * si[k])
        zi = h * (evi[k] + odr[k] * si[k] + odi[k] * sr[k])
        # where the step-2h rule resolves the mode's oscillation (omega h <= 1/2: at
        # least 6 points a period); above it the expansion in h does not hold and the
        # plain rule is the better one
        if extrapolate and abs(pi[k]) * h <= RICHARDSON_MAX_PHASE:
            zr = (c * zr - 2.0 * h * evr[k]) * inv_c1
            zi = (c * zi - 2.0 * h * evi[k]) * inv_c1
        if weight != 0.0:
            # the weight left on the plate: + m g e^(-p tau) / p (e^(-p tau) = E at the
            # last point)
            den = pr[k] * pr[k] + pi[k] * pi[k]
            zr += weight * (er[k] * pr[k] + ei[k] * pi[k]) / den
            zi += weight * (ei[k] * pr[k] - er[k] * pi[k]) / den
        # times c, times e^(p (d0 + M period)) (g, advanced past the last sample)
        yr = zr * cr[k] - zi * ci[k]
        yi = zr * ci[k] + zi * cr[k]
        amps[k] = complex(yr * gr[k] - yi * gi[k], yr * gi[k] + yi * gr[k])
    return _magnitude_sum(amps)


#: Rows of the transforms' workspace (K-vectors of :func:`_impact`).
WORK_ROWS = 20
#: Largest ``sigma_max tau`` (the most damped mode's decay over one contact, in nepers)
#: for :func:`_impact`, whose ``e^(-p u)`` factors reach ``e^(sigma tau)`` and
#: ``|e^(p d)|^2`` reaches ``e^(-2 sigma tau)``: both stay inside float64 (about
#: ``e^(+-708)``) with a margin. Longer contacts (a heavy ball resting on a damped
#: plate) go to :func:`_impact_long`.
LONG_CONTACT_NEPERS = 300.0


@numba.njit(cache=True, fastmath=_FAST)
def _impact_long(
    pr,
    pi,
    cr,
    ci,
    ur,
    ui,
    period,
    h,
    forces,
    slopes,
    d0,
    offset_forces,
    offset_slopes,
    weight,
    tau,
    order,
    amps,
    resp,
    work,
):
    """:func:`_impact` (same arguments, same result) for contacts so long that the
    factors ``e^(-p u)`` over the contact leave float64.

    The transforms are carried in the frame of the current time instead: the state
    ``S(u) = Int_0^u F(v) e^(p (u - v)) dv`` (trapezoid rule, ``S <- S e^(p h) + h/2
    (F_(j-1) e^(p h) + F_j)``) only ever decays, and a sample at ``d`` inside the
    contact hears ``Re[c S(d)]``; the end corrections and the Richardson step are those
    of :func:`_impact`, each term multiplied by the same ``e^(p u)``.
    """
    K = pr.size
    N = forces.size
    M = offset_forces.size
    # e^(p h), e^(2 p h); the K-vectors are rows of the workspace
    sr, si, s2r, s2i = work[0], work[1], work[2], work[3]
    for k in range(K):
        mag = math.exp(pr[k] * h)
        sr[k] = mag * math.cos(pi[k] * h)
        si[k] = mag * math.sin(pi[k] * h)
        mag = math.exp(2.0 * pr[k] * h)
        s2r[k] = mag * math.cos(2.0 * pi[k] * h)
        s2i[k] = mag * math.sin(2.0 * pi[k] * h)
    ar, ai, br, bi = work[4], work[5], work[6], work[7]
    work[4:8] = 0.0
    m = 0
    half = 0.5 * h
    f_prev = forces[0]
    for j in range(N):
        fj = forces[j]
        if j > 0:
            for k in range(K):
                nr = ar[k] * sr[k] - ai[k] * si[k] + half * f_prev * sr[k] + half * fj
                ni = ar[k] * si[k] + ai[k] * sr[k] + half * f_prev * si[k]
                ar[k] = nr
                ai[k] = ni
        if order > 0.0 and j % 2 == 0:
            w2 = fj * (h if (j == 0 or j == N - 1) else 2.0 * h)
            for k in range(K):
                if j > 0:
                    nr = br[k] * s2r[k] - bi[k] * s2i[k]
                    bi[k] = br[k] * s2i[k] + bi[k] * s2r[k]
                    br[k] = nr
                br[k] += w2
        uj = j * h
        while m < M and (j == N - 1 or d0 + m * period < uj + h):
            dd = d0 + m * period - uj
            if dd < 0.0:
                dd = 0.0
            fd = offset_forces[m]
            sd = offset_slopes[m]
            sj = slopes[j]
            wj = (dd * dd - h * h) / 12.0
            wd = dd * dd / 12.0
            acc = 0.0
            for k in range(K):
                mag = math.exp(pr[k] * dd)
                er = mag * math.cos(pi[k] * dd)  # e^(p dd)
                ei = mag * math.sin(pi[k] * dd)
                a1 = sj - pr[k] * fj
                b1 = -pi[k] * fj
                a2 = sd - pr[k] * fd
                b2 = -pi[k] * fd
                # (S + dd/2 F_j + wj g'(u_j)) e^(p dd) + dd/2 F_d - wd g'(d), g' in the frame
                zr = ar[k] + 0.5 * dd * fj + wj * a1
                zi = ai[k] + wj * b1
                xr = zr * er - zi * ei + 0.5 * dd * fd - wd * a2
                xi = zr * ei + zi * er - wd * b2
                acc += cr[k] * xr - ci[k] * xi
            resp[m] = acc
            m += 1
        f_prev = fj
    if order > 0.0 and N % 2 == 1 and N >= 5:
        c = 2.0**order
        for k in range(K):
            if abs(pi[k]) * h <= RICHARDSON_MAX_PHASE:
                ar[k] = (c * ar[k] - br[k]) / (c - 1.0)
                ai[k] = (c * ai[k] - bi[k]) / (c - 1.0)
    # the injection sample lies d_inj - tau >= 0 after the end of the contact
    rest = d0 + M * period - tau
    for k in range(K):
        zr = ar[k]
        zi = ai[k]
        if weight != 0.0:
            # the weight left on the plate: + m g / p in this frame
            den = pr[k] * pr[k] + pi[k] * pi[k]
            zr += weight * pr[k] / den
            zi -= weight * pi[k] / den
        mag = math.exp(pr[k] * rest)
        gr = mag * math.cos(pi[k] * rest)
        gi = mag * math.sin(pi[k] * rest)
        xr = zr * cr[k] - zi * ci[k]
        xi = zr * ci[k] + zi * cr[k]
        amps[k] = complex(xr * gr - xi * gi, xr * gi + xi * gr)
    return _magnitude_sum(amps)


@numba.njit(cache=True, fastmath=_FAST, nogil=True, inline="always")
def power_table(poles, fs):
    """``r^j = e^(p_k j / fs)``, ``j = 0..SUB``, of every mode: (K, 2, SUB + 1) real and
    imaginary parts, by recurrence from ``r = e^(p / fs)`` re-anchored on an exact
    exponential every 8 steps (rounding within a few ulp). poles (K,) complex, rad/s;
    fs: Hz."""
    K = poles.shape[0]
    table = np.empty((K, 2, SUB + 1))
    for k in range(K):
        r = np.exp(poles[k] / fs)
        z = 1.0 + 0.0j
        for j in range(SUB + 1):
            if j % 8 == 0 and j > 0:
                z = np.exp(poles[k] * (j / fs))
            elif j > 0:
                z = z * r
            table[k, 0, j] = z.real
            table[k, 1, j] = z.imag
    return table


@numba.njit(cache=True, fastmath=_FAST, nogil=True, inline="always")
def inject_amplitudes(zr, zi, active, debt, debt_at, thresholds, poles, fs, amps, a):
    """Add one impact's complex amplitudes ``amps`` (K,) to the modes' states ``zr + i zi``
    at sample ``a`` (the bank's state, see :func:`ring_modes`); a mode whose state plus what
    it has already left out (decayed to ``a``) is within its threshold stops (its ``|z|``
    joins its debt), any other one rings."""
    K = zr.shape[0]
    for k in range(K):
        zr[k] += amps[k].real
        zi[k] += amps[k].imag
        mag = math.sqrt(zr[k] * zr[k] + zi[k] * zi[k])
        d = debt[k]
        if d > 0.0:
            d *= math.exp(poles[k].real * ((a - debt_at[k]) / fs))
        if mag + d <= thresholds[k]:
            debt[k] = d + mag
            debt_at[k] = a
            zr[k] = 0.0
            zi[k] = 0.0
            active[k] = False
        else:
            active[k] = True


@numba.njit(cache=True, fastmath=_FAST, nogil=True, inline="always")
def ring_modes(
    out, offset, a, b, table, zr, zi, active, debt, debt_at, thresholds, thr2, poles, fs
):
    """Advance every ringing mode from sample ``a`` to ``b`` (no injection in between),
    adding ``Re[z_k r_k^j]`` into ``out[s - offset]`` for ``s`` in ``[a, b)``.

    The bank's state, per mode ``k``: ``zr, zi`` its complex amplitude at the current
    sample, ``active`` whether it rings, ``debt`` a bound of what it has left out so far as
    of sample ``debt_at``, ``thresholds`` its share of the omission budget (``thr2`` its
    square). table: :func:`power_table`; poles (K,) complex, rad/s; fs: Hz.

    A mode writes from the table ``SUB`` samples at a time, then advances its state by
    ``r^SUB`` (one complex product; the inner loop, two multiply-adds a sample,
    vectorises); there its state is checked against its share: it stops if ``|z| + debt
    <= threshold``. Returns (mode-samples computed, end of the last sample written,
    absolute).
    """
    K = zr.shape[0]
    work = 0
    last = 0
    for k in range(K):
        if not active[k]:
            continue
        pr = table[k, 0]
        pi = table[k, 1]
        cr = zr[k]
        ci = zi[k]
        s = a
        while s < b:
            n = min(SUB, b - s)
            o = out[s - offset : s - offset + n]  # a view: unsigned indexing, the loop vectorises
            for j in range(n):
                o[j] += cr * pr[j] - ci * pi[j]
            er = pr[n]
            ei = pi[n]
            cr, ci = cr * er - ci * ei, cr * ei + ci * er
            s += n
            m2 = cr * cr + ci * ci
            if m2 < thr2[k]:
                d = debt[k]
                if d > 0.0:
                    d *= math.exp(poles[k].real * ((s - debt_at[k]) / fs))
                mag = math.sqrt(m2)
                if mag + d <= thresholds[k]:
                    debt[k] = d + mag
                    debt_at[k] = s
                    active[k] = False
                    cr = 0.0
                    ci = 0.0
                    break
        work += s - a
        if s > last:
            last = s
        zr[k] = cr
        zi[k] = ci
    return work, last


@numba.njit(cache=True, fastmath=_FAST, nogil=True, inline="always")
def remainder(zr, zi, active, debt, debt_at, poles, fs, at):
    """Bound of what the bank's modes leave out at sample ``at``: ``|z|`` of the modes still
    ringing plus every mode's debt decayed to ``at``."""
    left = 0.0
    for k in range(zr.shape[0]):
        d = debt[k]
        if d > 0.0:
            d *= math.exp(poles[k].real * ((at - debt_at[k]) / fs))
        left += d
        if active[k]:
            left += math.sqrt(zr[k] * zr[k] + zi[k] * zi[k])
    return left


@numba.njit(cache=True, fastmath=_FAST)
def _bank(out, fs, poles, amps, inject, thresholds):
    """The modal bank: every mode's ringing after every injection, added into ``out``.

    out (S,) float64 accumulates; fs: Hz; poles (K,) complex, rad/s; amps (I, K) complex
    amplitudes of the impacts' ringing, already referred to the injection samples
    inject (I,) int64 (ascending): the mode's state at sample inject[i] gains amps[i, k].
    thresholds (K,): each mode's share of the omission budget (see the module docstring).

    Omission with a budget: each mode keeps ``debt``, a bound on what it has left out so
    far as it stands now (it decays with the mode). At an injection, or when the mode's
    state ``z`` (checked every ``SUB`` samples) has fallen below its share, the mode
    stops if ``|z| + debt <= threshold``: ``|z|`` joins the debt and the mode is silent
    until the next injection. So at every sample what a mode leaves out is at most its
    threshold.

    Layout: the output is taken in tiles of ``TILE`` samples (they stay in the L1/L2
    cache while every mode adds to them); every segment between injections and tile
    ends is one :func:`ring_modes` (the block-wise step the live engine takes too), so
    the state's rounding error grows by about one ulp per ``SUB`` samples.

    Returns (mode-samples computed, end of the last sample written (the samples after it
    are exactly zero), the sum over the modes of what is left at the end of ``out``:
    ``|z|`` of the modes still ringing plus every mode's debt).
    """
    S = out.shape[0]
    K = poles.shape[0]
    I = inject.shape[0]
    table = power_table(poles, fs)
    zr = np.zeros(K)
    zi = np.zeros(K)
    active = np.zeros(K, dtype=np.bool_)
    debt = np.zeros(K)  # bound of the omitted part, as of sample debt_at
    debt_at = np.zeros(K, dtype=np.int64)
    thr2 = thresholds * thresholds
    work = 0
    last = 0
    nxt = 0
    a = 0
    while a < S:
        # inject the impacts that start at sample a
        while nxt < I and inject[nxt] <= a:
            if inject[nxt] == a:
                inject_amplitudes(
                    zr, zi, active, debt, debt_at, thresholds, poles, fs, amps[nxt], a
                )
            nxt += 1
        # this segment ends at the tile's end or at the next injection
        b = min(S, (a // TILE + 1) * TILE)
        if nxt < I and inject[nxt] < b:
            b = inject[nxt]
        w, e = ring_modes(
            out, 0, a, b, table, zr, zi, active, debt, debt_at, thresholds, thr2, poles, fs
        )
        work += w
        if e > last:
            last = e
        a = b
    return work, last, remainder(zr, zi, active, debt, debt_at, poles, fs, S)


def _grid_size(tau, omega_max, min_points=PULSE_POINTS):
    """Points of the uniform pulse grid over a contact of ``tau`` s: an odd number (for
    the extrapolation), at least ``min_points``, with a step ``h`` such that
    ``omega_max h <= pi / 4`` (8 points a period of the highest mode)."""
    n = max(min_points, int(math.ceil(4.0 * omega_max * tau / math.pi)) + 1)
    return n + 1 - n % 2


def pulse_grid(result, omega_max, min_points=PULSE_POINTS):
    """Uniform grid of a pulse fine enough for the transform: ``(h, forces)``.

    ``omega_max`` (rad/s) is the highest mode's angular frequency; the grid has at least
    ``min_points`` points and a step ``h`` (s) with ``omega_max h <= pi / 4``; ``forces``
    in N.
    """
    tau = result.contact_time
    n = _grid_size(tau, omega_max, min_points)
    h = tau / (n - 1)
    u = np.arange(n) * h
    f = result.force_at(u)
    return h, np.ascontiguousarray(f)


def pulse_transforms(result, poles, omega_max=None):
    """Laplace transforms ``L_k = Int_0^tau F(u) exp(-p_k u) du`` of an impact's force
    pulse at the poles ``p_k`` (rad/s), N s, by the rule the renderer uses (trapezoid
    rule on :func:`pulse_grid`'s grid for ``omega_max``, rad/s; default the highest
    ``|Im p_k|``). A settled contact's remaining weight is not included."""
    poles = np.ascontiguousarray(poles, dtype=complex)
    if omega_max is None:
        omega_max = float(np.max(np.abs(poles.imag))) if poles.size else 0.0
    h, f = pulse_grid(result, omega_max)
    out = np.empty(poles.size, dtype=complex)
    one = np.ones(poles.size)
    zero = np.zeros(poles.size)
    _impact(
        np.ascontiguousarray(poles.real),
        np.ascontiguousarray(poles.imag),
        one,
        zero,
        one,
        zero,
        1.0,
        h,
        f,
        np.zeros(f.size),
        0.0,
        np.zeros(0),
        np.zeros(0),
        0.0,
        result.contact_time,
        result.exponent + 1.0,
        out,
        np.zeros(0),
        transform_workspace(poles.size),
    )
    return out


@dataclass(frozen=True, eq=False)
class BankCoefficients:
    """What every impact on one plate, heard by one listener, shares (see :func:`synthesize`):
    the poles ``p_k`` (rad/s), the listener response per unit pulse transform
    ``-i b_k output_k / omega_dk`` and the ringing over one sample ``e^(p_k / fs)``, as
    contiguous real and imaginary parts; ``samplerate`` in Hz; ``omega_max`` and
    ``sigma_max`` the largest ``|Im p_k|`` and ``-Re p_k`` (rad/s, 1/s)."""

    poles: np.ndarray
    samplerate: float
    omega_max: float
    sigma_max: float
    pole_re: np.ndarray
    pole_im: np.ndarray
    coef_re: np.ndarray
    coef_im: np.ndarray
    step_re: np.ndarray
    step_im: np.ndarray


def bank_coefficients(poles, excitation, output, samplerate) -> BankCoefficients:
    """:class:`BankCoefficients` of modes with ``poles`` (rad/s, below Nyquist), excited
    with ``excitation`` ``b_k`` (1/kg) and heard with ``output`` (see :func:`synthesize`),
    at ``samplerate`` Hz."""
    fs = float(samplerate)
    poles = np.ascontiguousarray(poles, dtype=complex)
    omega_max = float(np.max(np.abs(poles.imag))) if poles.size else 0.0
    sigma_max = float(np.max(-poles.real)) if poles.size else 0.0
    coef = -1j * excitation / poles.imag * output  # response per unit transform
    step = np.exp(poles * (1.0 / fs))  # one sample's ringing
    return BankCoefficients(
        poles,
        fs,
        omega_max,
        sigma_max,
        np.ascontiguousarray(poles.real),
        np.ascontiguousarray(poles.imag),
        np.ascontiguousarray(coef.real),
        np.ascontiguousarray(coef.imag),
        np.ascontiguousarray(step.real),
        np.ascontiguousarray(step.imag),
    )


@dataclass(frozen=True, eq=False)
class ImpactExcitation:
    """One impact as the modal bank takes it.

    Attributes
    ----------
    amplitudes : complex ndarray (K,)
        The modes' ringing, referred to sample ``inject`` (listener units).
    inject : int
        The first sample after the contact, where the amplitudes join the bank's state.
    first : int
        The first sample inside the contact.
    response : ndarray (M,)
        The exact listener response at the in-contact samples ``first .. first + M - 1``.
    forces : ndarray (M,)
        The contact force there, N (for an accelerometer's direct term).
    magnitude : float
        ``sum_k |amplitudes_k|`` (listener units): a bound of the tick's peak.
    """

    amplitudes: np.ndarray
    inject: int
    first: int
    response: np.ndarray
    forces: np.ndarray
    magnitude: float


@numba.njit(cache=True)
def transform_pulse(
    pr,
    pi,
    cr,
    ci,
    ur,
    ui,
    sigma_max,
    period,
    h,
    forces,
    slopes,
    d0,
    offset_forces,
    offset_slopes,
    weight,
    tau,
    order,
    amps,
    resp,
    work,
):
    """One impact's mode amplitudes and in-contact response: :func:`_impact` (its
    arguments, its result), or :func:`_impact_long` when the contact of ``tau`` s lasts
    more than ``LONG_CONTACT_NEPERS`` time constants of the fastest-decaying mode
    (``sigma_max``, 1/s). Compiled, so that the live engine's audio thread calls it too."""
    if sigma_max * tau > LONG_CONTACT_NEPERS:
        return _impact_long(
            pr, pi, cr, ci, ur, ui, period, h, forces, slopes, d0,
            offset_forces, offset_slopes, weight, tau, order, amps, resp, work,
        )  # fmt: skip
    return _impact(
        pr, pi, cr, ci, ur, ui, period, h, forces, slopes, d0,
        offset_forces, offset_slopes, weight, tau, order, amps, resp, work,
    )  # fmt: skip


def transform_workspace(modes: int) -> np.ndarray:
    """The workspace of :func:`transform_pulse` for ``modes`` modes."""
    return np.empty((WORK_ROWS, modes))


@dataclass(slots=True)
class PulseLayout:
    """Where one contact's pulse is sampled for its transforms (see :func:`_impact`):
    ``points`` grid points ``j step`` (s) from first touch, and the ``samples`` audio
    samples inside the contact, ``first .. first + samples - 1``, the first of them
    ``offset`` s (in ``[0, 1 / samplerate)``) after first touch."""

    points: int
    step: float
    first: int
    samples: int
    offset: float

    @property
    def inject(self) -> int:
        """The first sample after the contact, where the mode amplitudes join the bank."""
        return self.first + self.samples


def pulse_layout(
    contact_time: float, onset: float, omega_max: float, samplerate: float, pulse_points: int
) -> PulseLayout:
    """The :class:`PulseLayout` of a contact of ``contact_time`` s whose first touch is at
    ``onset`` s from sample 0, for modes up to ``omega_max`` rad/s at ``samplerate`` Hz,
    with at least ``pulse_points`` grid points (the kernel guards the rounding of a sample
    that falls on the touch)."""
    fs = samplerate
    n = _grid_size(contact_time, omega_max, pulse_points)
    first = int(math.ceil(onset * fs - 1e-9))
    samples = max(0, int(math.ceil((onset + contact_time) * fs - 1e-9)) - first)
    return PulseLayout(n, contact_time / (n - 1), first, samples, first * (1.0 / fs) - onset)


def impact_excitation(
    coefficients: BankCoefficients,
    result,
    onset: float,
    *,
    weight=0.0,
    pulse_points=PULSE_POINTS,
    amplitudes=None,
    response=None,
    work=None,
) -> ImpactExcitation:
    """The excitation of the modes by the contact ``result`` (an ImpactResult) whose first
    touch is at ``onset`` s from sample 0 (sub-sample exact): its amplitudes at the first
    sample after the contact and its exact response inside it (see ``_impact``).

    weight: ``m g`` (N) left on the plate after a settled contact, else 0; pulse_points:
    fewest points of the pulse grid; amplitudes: an optional (K,) complex array to write
    the amplitudes into; response: an optional float array to write the in-contact
    response into (at least :func:`samples_in_contact` long); work: an optional
    :func:`transform_workspace` of the K modes.
    """
    c = coefficients
    fs = c.samplerate
    tau = result.contact_time
    lay = pulse_layout(tau, onset, c.omega_max, fs, pulse_points)
    n, M = lay.points, lay.samples
    forces, slopes = result.pulse_samples(lay.step, n, lay.offset, 1.0 / fs, M)
    if response is None:
        resp = np.empty(M)
    elif response.size < M:
        raise ParameterError(
            f"response has {response.size} samples; the contact of {tau!r} s at "
            f"samplerate={fs!r} Hz needs {M}"
        )
    else:
        resp = response[:M]
    amps = np.zeros(c.poles.size, dtype=complex) if amplitudes is None else amplitudes
    magnitude = transform_pulse(
        c.pole_re,
        c.pole_im,
        c.coef_re,
        c.coef_im,
        c.step_re,
        c.step_im,
        c.sigma_max,
        1.0 / fs,
        lay.step,
        forces[:n],
        slopes[:n],
        lay.offset,
        forces[n:],
        slopes[n:],
        float(weight),
        tau,
        result.exponent + 1.0,
        amps,
        resp,
        transform_workspace(c.poles.size) if work is None else work,
    )
    return ImpactExcitation(amps, lay.inject, lay.first, resp, forces[n:], magnitude)


def samples_in_contact(contact_time: float, samplerate: float) -> int:
    """Most audio samples (at ``samplerate`` Hz) that a contact of ``contact_time`` s
    can span, wherever it starts (see :func:`impact_excitation`)."""
    return int(math.ceil(contact_time * samplerate)) + 1


def synthesize(
    impacts,
    onsets,
    poles,
    excitation,
    output,
    samplerate,
    *,
    floor,
    settled_weight=None,
    direct=None,
    max_samples=None,
    pulse_points=PULSE_POINTS,
):
    """Mix the ringing of every mode after every impact.

    Parameters
    ----------
    impacts : sequence of ImpactResult
        The contacts, in time order.
    onsets : ndarray (I,)
        Each contact's start on the audio timeline, s (float, sub-sample).
    poles : complex ndarray (K,)
        ``p_k = -sigma_k + i omega_dk``, rad/s (all below Nyquist).
    excitation : ndarray (K,)
        ``b_k = phi_k(x0) / M_k``, 1/kg.
    output : complex ndarray (K,)
        Listener gain per unit modal displacement ``q_k`` at the pole: ``phi_k(xp) p_k^2``
        for acceleration, ``G_k p_k`` for a microphone.
    samplerate : float
        Hz.
    floor : float
        Omission floor, a fraction of the reference amplitude (see module docstring).
    settled_weight : sequence of float or None
        For a settled impact, the weight ``m g`` (N) that stays on the plate after its
        contact time (its step adds ``m g exp(-p tau) / p`` to the transform); else None.
    direct : ndarray (K,) or None
        For acceleration, ``phi_k(xp) b_k`` of the direct term ``b_k F(t)`` inside contacts.
    max_samples : int
        Length cap of the output.
    pulse_points : int >= 5
        Fewest points of each pulse's grid for the transforms (an odd number is used).

    Returns
    -------
    (audio float64 (S,), info dict: n_modes_rendered, mode_samples, reference, length)
    """
    fs = float(samplerate)
    onsets = np.asarray(onsets, dtype=float)
    if onsets.size and not np.min(onsets) >= 0.0:
        raise ParameterError(
            f"onsets: {float(np.min(onsets))!r} s; every onset must be >= 0 s "
            f"(from the first sample of the audio)"
        )
    coefficients = bank_coefficients(poles, excitation, output, fs)
    poles = coefficients.poles
    K = poles.size
    I = len(impacts)
    amps = np.zeros((I, K), dtype=complex)
    inject = np.zeros(I, dtype=np.int64)
    contact_samples = []  # per impact: in-contact sample indices, responses there, forces there
    work = transform_workspace(K)
    for i, (res, t0) in enumerate(zip(impacts, onsets)):
        weight = float(settled_weight[i]) if settled_weight is not None else 0.0
        ex = impact_excitation(
            coefficients,
            res,
            float(t0),
            weight=weight,
            pulse_points=pulse_points,
            amplitudes=amps[i],
            work=work,
        )
        inject[i] = ex.inject
        contact_samples.append(
            (ex.first + np.arange(ex.response.size, dtype=np.int64), ex.response, ex.forces)
        )
    reference = float(np.max(np.sum(np.abs(amps), axis=1))) if I else 0.0
    thr = floor * reference / max(K, 1)
    # a mode whose amplitudes add up to at most its share is left out whole
    total = np.sum(np.abs(amps), axis=0) if I else np.zeros(K)
    keep = total > thr
    # buffer: until every kept mode's state is below half its share (the sum of its
    # amplitudes bounds its state after the last impact), so that with what it has left
    # out before it can stop; trimmed below to what was written
    if I and keep.any():
        sig = -poles.real[keep]
        t_tail = np.log(np.maximum(2.0 * total[keep] / max(thr, 1e-300), 1.0)) / np.maximum(
            sig, 1e-12
        )
        length = int(inject[-1] + math.ceil(float(np.max(t_tail)) * fs) + TILE)
    else:
        length = int(inject[-1] + 1) if I else 1
    if max_samples is not None:
        length = min(length, int(max_samples))
    out = np.zeros(length)
    t_bank = time.perf_counter()
    work, last, left = (
        _bank(
            out,
            fs,
            poles[keep],
            np.ascontiguousarray(amps[:, keep]),
            inject,
            np.full(int(keep.sum()), thr),
        )
        if keep.any()
        else (0, 0, 0.0)
    )
    t_bank = time.perf_counter() - t_bank
    mass_line = float(np.sum(direct.real)) if direct is not None else 0.0
    for idx, resp, off_f in contact_samples:
        ok = idx < length
        if not ok.any():
            continue
        out[idx[ok]] += resp[ok]
        if direct is not None:
            out[idx[ok]] += off_f[ok] * mass_line
        last = max(last, int(idx[ok][-1]) + 1)
    length = max(1, min(length, last))
    out = out[:length]
    # what is left out at the end of the audio: the kept modes' remainder there, and the
    # modes left out whole (each at most its share)
    left += float(np.sum(total[~keep]))
    info = dict(
        n_modes=K,
        n_modes_rendered=int(keep.sum()),
        mode_samples=int(work),
        reference=reference,
        threshold=thr,
        length=length,
        bank_seconds=t_bank,
        left_at_end=left,
    )
    return out, info
