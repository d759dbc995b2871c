"""The numba quadrature of one contact's pulse transforms ``Int_0^tau F(u) e^(-p_k u) du``
(:mod:`synth.sound.modal_bank`). Every loop over the modes vectorises."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.vecmath import cis, exp_small, halvings_for

#: Largest phase step ``omega h`` (rad) of the pulse grid at which a mode's transform is
#: extrapolated (see :func:`impact_transform`); the grid keeps ``omega_max h <= pi / 4``.
RICHARDSON_MAX_PHASE = 0.5
#: Rows of the transforms' workspace (K-vectors of :func:`impact_transform`).
WORK_ROWS = 20


@compiled(sums=True)
def _magnitude_sum(amps):
    """``sum_k |amps_k|`` of complex amplitudes (bounds the peak of what they ring)."""
    total = 0.0
    for k in range(amps.shape[0]):
        total += math.sqrt(amps[k].real * amps[k].real + amps[k].imag * amps[k].imag)
    return total


@compiled()
def _sample_due(m, M, j, N, uj, h, d0, period):
    """Whether in-contact sample ``m`` (of ``M``) falls in ``[u_j, u_j + h)`` (or at or
    after ``u_j``, the last of ``N`` points)."""
    return m < M and (j == N - 1 or d0 + m * period < uj + h)


@compiled(sums=True)
def _in_contact(
    m, j, N, h, d0, period, forces, slopes, offset_forces, offset_slopes,
    pr, pi, cr, ci, ur, ui, vr, vi, er, ei, qr, qi, gr, gi, tr, ti, resp,
):  # fmt: skip
    """The responses ``resp[m], ...`` of the in-contact samples that fall in ``[u_j,
    u_j + h)`` (see :func:`impact_transform`): from ``E = e^(-p u_j)`` (er, ei) and the rule to
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


@compiled(sums=True)
def impact_transform(
    pr, pi, cr, ci, ur, ui, period, h, forces, slopes, d0, offset_forces, offset_slopes,
    weight, tau, order, amps, resp, work,
):  # fmt: skip
    """One impact's contribution, vectorised over the K modes (docs/physics.md, "Modal
    synthesis"): poles ``pr + i pi`` (rad/s), listener response per unit transform ``cr + i
    ci``, ``ur + i ui = e^(p_k period)`` (``period = 1 / fs``, s); the pulse on the grid ``u_j
    = j h`` (``forces`` N, ``slopes`` N/s); ``d0`` (s) from first touch to the first audio
    sample, ``offset_forces`` and ``offset_slopes`` (M,) at the audio samples inside the
    contact; ``weight`` ``m g`` (N) left after a settled contact; ``tau`` the contact time,
    s; ``order`` the trapezoid rule's error exponent for one Richardson step (0: none);
    ``work`` a (``WORK_ROWS``, K) workspace (the audio thread allocates nothing). Writes
    ``amps`` (K,), the ringing injected at the first sample after the contact, and ``resp``
    (M,), the exact response inside it (Euler-Maclaurin end corrections, exact for cubics);
    returns ``sum_k |amps_k|``. Two complex exponentials per mode, the rest by products."""
    K = pr.shape[0]
    N = forces.shape[0]
    M = offset_forces.shape[0]
    # arguments of the real exponentials, scaled into [-1, 1] (see synth.vecmath.halvings_for)
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
    m = np.int64(0)  # not the literal 0: numba would compile _in_contact for it too
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


@compiled(sums=True)
def long_impact_transform(
    pr, pi, cr, ci, ur, ui, period, h, forces, slopes, d0, offset_forces, offset_slopes,
    weight, tau, order, amps, resp, work,
):  # fmt: skip
    """:func:`impact_transform` (same arguments, same result) for contacts so long that the
    factors ``e^(-p u)`` over the contact leave float64. In the frame of the current time the
    state ``S(u) = Int_0^u F(v) e^(p (u - v)) dv`` (trapezoid rule, ``S <- S e^(p h) + h/2
    (F_(j-1) e^(p h) + F_j)``) only ever decays; a sample at ``d`` inside the contact hears
    ``Re[c S(d)]``, the end corrections and Richardson step each multiplied by ``e^(p u)``."""
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
    m = np.int64(0)  # not the literal 0: numba would compile _in_contact for it too
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
