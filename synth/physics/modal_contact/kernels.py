"""Numba kernels of the modal contact (:mod:`synth.physics.modal_contact`): one contact
integrated in fixed steps (exponential integrators for every linear part, the contact force
implicit) and the free ringing of damped modes. The numerics are described in the package's
docstring."""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels.equations import yield_law, yield_potential

# Result columns of the kernel.
R_STATUS, R_TIME, R_V, R_U, R_DMAX, R_FMAX, R_IMPULSE = 0, 1, 2, 3, 4, 5, 6
R_STEPS, R_DAMPING_LOSS, R_DASHPOT_LOSS, R_RIGID_Q, R_RIGID_V = 7, 8, 9, 10, 11
R_CONTACT_LOSS = 12
R_COLS = 13
SEPARATED, SETTLED = 0, 1


# --------------------------------------------------------------------------------------
# Kernel
# --------------------------------------------------------------------------------------


@compiled()
def _phi12(z):  # pragma: no cover
    """``phi_1(z) = (e^z - 1) / z`` and ``phi_2(z) = (e^z - 1 - z) / z^2`` (complex z), by
    their Taylor series near 0 (no cancellation) and the closed forms elsewhere."""
    if abs(z) < 0.1:
        p1 = 0j
        p2 = 0j
        term = 1.0 + 0j  # z^k / k!
        for k in range(11):
            p1 += term / (k + 1)
            p2 += term / ((k + 1) * (k + 2))
            term *= z / (k + 1)
        return p1, p2
    ez = np.exp(z)
    return (ez - 1.0) / z, (ez - 1.0 - z) / (z * z)


@compiled()
def _transition(omega, sigma, h):  # pragma: no cover
    """The free oscillation of ``q'' + 2 sigma q' + omega^2 q = 0`` (underdamped) over a step
    ``h`` (s): the damped frequency ``omega_d = sqrt(omega^2 - sigma^2)`` (rad/s), the decay
    ``e^(-sigma h)`` and ``cos``, ``sin(omega_d h)``, from which the transition matrix is
    ``e^(-sigma h) [[c + sigma/omega_d s, s/omega_d], [-omega^2/omega_d s,
    c - sigma/omega_d s]]``."""
    wd = math.sqrt(omega * omega - sigma * sigma)
    return wd, math.exp(-sigma * h), math.cos(wd * h), math.sin(wd * h)


@compiled()
def _mode_coefficients(omega, sigma, h, P, G):  # pragma: no cover
    """Exact step ``h`` (s) of ``q'' + 2 sigma q' + omega^2 q = f`` (underdamped) with ``f``
    linear over the step: ``[q, v](h) = P [q, v](0) + G[:, 0:2] f(0) + G[:, 2:4] f(h)``;
    ``P`` rows (P11, P12, P21, P22) the transition matrix of :func:`_transition`, ``G`` rows
    (f0 -> q, f1 -> q, f0 -> v, f1 -> v)."""
    for k in range(omega.size):
        s = sigma[k]
        w0 = omega[k]
        wd, e, c, sn = _transition(w0, s, h)
        P[k, 0] = e * (c + s / wd * sn)
        P[k, 1] = e * sn / wd
        P[k, 2] = -e * w0 * w0 / wd * sn
        P[k, 3] = e * (c - s / wd * sn)
        p = complex(-s, wd)
        p1, p2 = _phi12(p * h)
        j0 = h * (p1 - p2)
        j1 = h * p2
        G[k, 0] = j0.imag / wd
        G[k, 1] = j1.imag / wd
        G[k, 2] = (p * j0).imag / wd
        G[k, 3] = (p * j1).imag / wd


@compiled()
def _real_coefficients(a, h):  # pragma: no cover
    """Step ``h`` of ``x' = -a x + f`` with ``f`` linear: ``x(h) = E x(0) + g0 f(0) + g1 f(h)``."""
    p1, p2 = _phi12(complex(-a * h, 0.0))
    return math.exp(-a * h), h * (p1.real - p2.real), h * p2.real


@compiled()
def _solve_delta(A, B, K, n):  # pragma: no cover
    """The root ``delta >= 0`` of ``delta + B K delta^n = A`` (A > 0): Newton from above
    (the left side is convex and increasing)."""
    d = A
    # start from the smaller of the two one-term solutions: both bound the root from above
    d2 = (A / (B * K)) ** (1.0 / n) if B > 0.0 else A
    if d2 < d:
        d = d2
    for _ in range(100):
        f = d + B * K * d**n - A
        df = 1.0 + n * B * K * d ** (n - 1.0)
        step = f / df
        d_new = d - step
        if d_new <= 0.0:
            d_new = 0.5 * d
        if abs(d_new - d) <= 1e-14 * d:
            return d_new
        d = d_new
    return d


@compiled()
def _yield_force(d, K, mu, b, Av, Bv, dy, dm):  # pragma: no cover
    """:func:`_lossy_force` of the Hertz law with Thornton's yield (``dy``, m, the yield
    penetration; ``dm``, m, the largest penetration before the step): ``F = K (a + c
    d')``, ``c = mu a + b r``, with the elastic-plastic force ``K a`` and the contact radius
    factor ``r`` of :func:`~synth.physics.contact_kernels.equations.yield_law` (in metres:
    the law is homogeneous), solved for ``F`` at ``d' = Av - Bv F``; and ``dF / d delta``."""
    if d <= 0.0:
        return 0.0, 0.0
    a, r, da, dr = yield_law(d, dy, dm)
    c = mu * a + b * r
    dc = mu * da + b * dr
    num = a + c * Av
    if num <= 0.0:
        return 0.0, 0.0
    den = 1.0 + c * Bv * K
    F = K * num / den
    return F, K * (da + dc * Av) / den - F * dc * Bv * K / den


@compiled()
def _lossy_force(d, K, n, mu, b, Av, Bv, dy, dm):  # pragma: no cover
    """The lossy contact force ``F = K d^(n-1) (d + c(d) d')``, ``c(d) = mu d + b`` (N, at
    least 0): Hunt-Crossley ``K d^n (1 + mu d')`` for ``b = 0``, the viscoelastic Hertz
    contact ``K (d^(3/2) + b d^(1/2) d')`` (``b = 3/2 A``) for ``mu = 0``; at the end of a
    step whose penetration rate is ``d' = Av - Bv F`` (the step's linear response to the
    force ``F`` at its end), solved for ``F``:
    ``F = K d^(n-1) (d + c Av) / (1 + c Bv K d^(n-1))``; and its derivative with respect to
    ``d`` (N/m). With a yield penetration ``dy`` (m; None: no yield; ``dm`` the largest
    penetration before the step): :func:`_yield_force`."""
    if dy is not None:
        return _yield_force(d, K, mu, b, Av, Bv, dy, dm)
    if d <= 0.0:
        return 0.0, 0.0
    if b == 0.0:
        s = K * d**n
        num = 1.0 + mu * Av
        if num <= 0.0:
            return 0.0, 0.0
        den = 1.0 + mu * Bv * s
        return s * num / den, n * s / d * num / (den * den)
    r = K * d ** (n - 1.0)
    c = mu * d + b
    num = d + c * Av
    if num <= 0.0:
        return 0.0, 0.0
    den = 1.0 + c * Bv * r
    dr = (n - 1.0) * r / d
    dden = Bv * (mu * r + c * dr)
    F = r * num / den
    return F, (dr * num + r * (1.0 + mu * Av)) / den - F * dden / den


@compiled()
def _solve_lossy_delta(A, B, K, n, mu, b, Av, Bv, dy, dm):  # pragma: no cover
    """The root ``delta >= 0`` of ``delta + B F(delta) = A`` (A > 0) with the lossy force of
    :func:`_lossy_force` (increasing in ``delta`` where positive: one root in ``[0, A]``):
    Newton's method kept inside a bracket, bisection where a step leaves it."""
    lo = 0.0
    hi = A
    d = _solve_delta(A, B, K, n)  # start from the elastic root
    for _ in range(200):
        F, dF = _lossy_force(d, K, n, mu, b, Av, Bv, dy, dm)
        f = d + B * F - A
        if f > 0.0:
            hi = d
        else:
            lo = d
        d_new = d - f / (1.0 + B * dF)
        if not (lo < d_new < hi):
            d_new = 0.5 * (lo + hi)
        if abs(d_new - d) <= 1e-14 * d or hi - lo <= 1e-15 * A:
            return d_new
        d = d_new
    return d


@compiled()
def _plate_free(q, v, P, G, c, F0, qr, vr, rc, x, Er, r0, beta, h):  # pragma: no cover
    """Plate displacement under the ball after a step ``h`` with the force at its end left out:
    modes, rigid body and residual from their states and the force ``F0`` at the start."""
    w = 0.0
    for k in range(q.size):
        w += P[k, 0] * q[k] + P[k, 1] * v[k] - c[k] * G[k, 0] * F0
    w += qr + vr * h - rc * h * h * F0 / 3.0
    w -= Er * x + beta * r0 * F0
    return w


@compiled()
def _rate_free(q, v, P, G, c, F0, vr, rc, x, Er, r0, beta, a, vs, m, g, h):  # pragma: no cover
    """Penetration rate ``delta'`` (m/s) after a step ``h`` with the force at its end left out
    (the part of the rate that does not depend on it): plate surface velocity (modes, rigid
    body, residual) minus the ball's velocity."""
    w = vr - 0.5 * rc * h * F0 + a * (Er * x + beta * r0 * F0)
    for k in range(q.size):
        w += P[k, 2] * q[k] + P[k, 3] * v[k] - c[k] * G[k, 2] * F0
    return w - (vs - g * h + 0.5 * h * F0 / m)


@compiled()
def _end_gap(q, v, c, omega, sigma, F0, qr, vr, rc, x, a, beta, u, vs, m, g, h):  # pragma: no cover
    """``delta`` after a step ``h`` over which the force falls linearly from ``F0`` to 0."""
    P = np.empty((q.size, 4))
    G = np.empty((q.size, 4))
    _mode_coefficients(omega, sigma, h, P, G)
    Er, r0, _ = _real_coefficients(a, h)
    w = _plate_free(q, v, P, G, c, F0, qr, vr, rc, x, Er, r0, beta, h)
    ub = u + vs * h - 0.5 * g * h * h + h * h * F0 / (3.0 * m)
    return w - ub


@compiled()
def _advance(q, v, P, G, c, sigma, F0, F1, h):  # pragma: no cover
    """Advance the modes over one step with the force going linearly from F0 to F1; returns
    the modal damping loss over the step (trapezoid rule), J."""
    loss = 0.0
    for k in range(q.size):
        q0 = q[k]
        v0 = v[k]
        q[k] = P[k, 0] * q0 + P[k, 1] * v0 - c[k] * (G[k, 0] * F0 + G[k, 1] * F1)
        v[k] = P[k, 2] * q0 + P[k, 3] * v0 - c[k] * (G[k, 2] * F0 + G[k, 3] * F1)
        loss += sigma[k] / c[k] * (v0 * v0 + v[k] * v[k]) * h
    return loss


@compiled()
def _surface_velocity(v, vr, xdot):  # pragma: no cover
    """Velocity of the plate surface under the ball (m/s, upward): bending modes, rigid body
    and residual (whose displacement ``x_res`` is downward)."""
    w = vr - xdot
    for k in range(v.size):
        w += v[k]
    return w


@compiled()
def contact_kernel(
    omega,
    sigma,
    c,
    rc,
    beta,
    a,
    q,
    v,
    x_res,
    m,
    K,
    n,
    mu,
    b,
    dy,
    g,
    v_in,
    h,
    max_steps,
    forces,
    times,
    gaps,
    rates,
):  # pragma: no cover
    """One contact from first touch (ball height = plate surface, ball velocity ``-v_in``),
    the contact law ``F = K delta^(n-1) (delta + (mu delta + b) delta')``, ``F >= 0``
    (:func:`_lossy_force`; ``mu = b = 0``: elastic), with Thornton's yield past the
    penetration ``dy`` (m; None: none, the kernel then compiled without the yield's code),
    the largest penetration of the steps so far its state.

    ``q``, ``v`` (modal displacements and velocities under the ball) and ``x_res`` (array of
    one: the residual's displacement) are the plate's state at first touch and are advanced
    in place to the end of contact. ``forces``/``times`` receive the force at every step,
    ``gaps``/``rates`` the penetration ``delta`` (m) and its rate (m/s)."""
    r = np.zeros(R_COLS)
    N = q.size
    P = np.empty((N, 4))
    G = np.empty((N, 4))
    _mode_coefficients(omega, sigma, h, P, G)
    Er, r0, r1 = _real_coefficients(a, h)
    B = h * h / (6.0 * m) + rc * h * h / 6.0 + beta * r1
    for k in range(N):
        B += c[k] * G[k, 1]
    # the penetration rate at the end of a step is Av - Bv F1 (the lossy laws only)
    Bv = h / (2.0 * m) + 0.5 * rc * h + beta * (1.0 - a * r1)
    for k in range(N):
        Bv += c[k] * G[k, 3]
    lossy = mu != 0.0 or b != 0.0
    plain = not lossy  # the elastic law: its own root
    if dy is not None:
        plain = False
    contact_loss = 0.0
    work = 0.0  # the elastic-plastic force's work on the penetration (trapezoid rule), J
    Fd0 = 0.0  # the viscous part F - K delta^n of the force at the start of the step
    w = -x_res[0]
    for k in range(N):
        w += q[k]
    u = w
    vs = -v_in
    qr = 0.0
    vr = 0.0
    x = x_res[0]
    F0 = 0.0
    t = 0.0
    damping_loss = 0.0
    dashpot_loss = 0.0
    impulse = 0.0
    dmax = 0.0
    fmax = 0.0
    forces[0] = 0.0
    times[0] = 0.0
    gaps[0] = 0.0
    rates[0] = v_in
    for k in range(N):
        rates[0] += v[k]
    status = SETTLED
    steps = 0
    for i in range(max_steps):
        wf = _plate_free(q, v, P, G, c, F0, qr, vr, rc, x, Er, r0, beta, h)
        A = wf - (u + vs * h - 0.5 * g * h * h + h * h * F0 / (3.0 * m))
        if A <= 0.0:
            # the gap opens within this step: find h' with delta(h') = 0, force falling to 0
            # Illinois' false position on [0, h]: gap(0) = delta > 0 >= gap(h) = A
            lo = 0.0
            hi = h
            g_lo = (F0 / K) ** (1.0 / n)  # delta at the start of the step
            if dy is not None:
                g_lo = gaps[i]
            g_hi = A
            side = 0
            for _ in range(100):
                if g_lo - g_hi > 0.0:
                    mid = lo + (hi - lo) * g_lo / (g_lo - g_hi)
                else:
                    mid = 0.5 * (lo + hi)
                if not (lo < mid < hi):
                    mid = 0.5 * (lo + hi)
                gap = _end_gap(q, v, c, omega, sigma, F0, qr, vr, rc, x, a, beta, u, vs, m, g, mid)
                if gap > 0.0:
                    lo, g_lo = mid, gap
                    if side == 1:
                        g_hi *= 0.5
                    side = 1
                else:
                    hi, g_hi = mid, gap
                    if side == -1:
                        g_lo *= 0.5
                    side = -1
                if hi - lo <= 1e-13 * h or gap == 0.0:
                    break
            hh = hi
            Pe = np.empty((N, 4))
            Ge = np.empty((N, 4))
            _mode_coefficients(omega, sigma, hh, Pe, Ge)
            Ee, e0, _ = _real_coefficients(a, hh)
            damping_loss += _advance(q, v, Pe, Ge, c, sigma, F0, 0.0, hh)
            xdot0 = beta * F0 - a * x
            x = Ee * x + beta * e0 * F0
            xdot1 = -a * x
            dashpot_loss += 0.5 * hh * (xdot0 * xdot0 + xdot1 * xdot1) / beta
            qr += vr * hh - rc * hh * hh * F0 / 3.0
            vr -= rc * hh * 0.5 * F0
            u += vs * hh - 0.5 * g * hh * hh + hh * hh * F0 / (3.0 * m)
            vs += -g * hh + hh * 0.5 * F0 / m
            impulse += 0.5 * hh * F0
            contact_loss += 0.5 * hh * Fd0 * rates[i]
            if dy is not None:
                work -= 0.5 * K * yield_law(gaps[i], dy, dmax)[0] * gaps[i]
            t += hh
            forces[i + 1] = 0.0
            times[i + 1] = t
            gaps[i + 1] = 0.0
            rates[i + 1] = _surface_velocity(v, vr, xdot1) - vs
            status = SEPARATED
            steps = i + 1
            break
        if plain:
            d1 = _solve_delta(A, B, K, n)
            F1 = K * d1**n
        else:
            Av = _rate_free(q, v, P, G, c, F0, vr, rc, x, Er, r0, beta, a, vs, m, g, h)
            d1 = _solve_lossy_delta(A, B, K, n, mu, b, Av, Bv, dy, dmax)
            F1 = _lossy_force(d1, K, n, mu, b, Av, Bv, dy, dmax)[0]
        Fe1 = 0.0
        if dy is not None:
            Fe1 = K * yield_law(d1, dy, dmax)[0] if d1 > 0.0 else 0.0
            Fe0 = K * yield_law(gaps[i], dy, dmax)[0] if gaps[i] > 0.0 else 0.0
            work += 0.5 * (Fe0 + Fe1) * (d1 - gaps[i])
        damping_loss += _advance(q, v, P, G, c, sigma, F0, F1, h)
        xdot0 = beta * F0 - a * x
        x = Er * x + beta * (r0 * F0 + r1 * F1)
        xdot1 = beta * F1 - a * x
        dashpot_loss += 0.5 * h * (xdot0 * xdot0 + xdot1 * xdot1) / beta
        qr += vr * h - rc * h * h * (F0 / 3.0 + F1 / 6.0)
        vr -= rc * h * 0.5 * (F0 + F1)
        u += vs * h - 0.5 * g * h * h + h * h * (F0 / 3.0 + F1 / 6.0) / m
        vs += -g * h + h * 0.5 * (F0 + F1) / m
        impulse += 0.5 * h * (F0 + F1)
        t += h
        F0 = F1
        forces[i + 1] = F1
        times[i + 1] = t
        gaps[i + 1] = d1
        rates[i + 1] = _surface_velocity(v, vr, xdot1) - vs
        if lossy:
            Fd1 = F1 - K * d1**n
            if dy is not None:
                Fd1 = F1 - Fe1
            contact_loss += 0.5 * h * (Fd0 * rates[i] + Fd1 * rates[i + 1])
            Fd0 = Fd1
        if d1 > dmax:
            dmax = d1
        if F1 > fmax:
            fmax = F1
        steps = i + 1
    x_res[0] = x
    if dy is not None:
        # the plastic work: the elastic-plastic force's work less the energy it still holds
        end = gaps[steps]
        contact_loss += work - (K * yield_potential(end, dy, dmax) if end > 0.0 else 0.0)
    r[R_STATUS] = status
    r[R_TIME] = t
    r[R_V] = vs
    r[R_U] = u
    r[R_DMAX] = dmax
    r[R_FMAX] = fmax
    r[R_IMPULSE] = impulse
    r[R_STEPS] = steps
    r[R_DAMPING_LOSS] = damping_loss
    r[R_DASHPOT_LOSS] = dashpot_loss
    r[R_RIGID_Q] = qr
    r[R_RIGID_V] = vr
    r[R_CONTACT_LOSS] = contact_loss
    return r


@compiled()
def ring_free(omega, sigma, q, v, duration):  # pragma: no cover
    """Free ringing of the modes over ``duration`` (s), in place: the transition matrix of
    :func:`_transition` (the homogeneous part of :func:`_mode_coefficients`) applied to each
    mode's state."""
    for k in range(q.size):
        s = sigma[k]
        w0 = omega[k]
        wd, e, c, sn = _transition(w0, s, duration)
        q0 = q[k]
        v0 = v[k]
        q[k] = e * ((c + s / wd * sn) * q0 + sn / wd * v0)
        v[k] = e * (-w0 * w0 / wd * sn * q0 + (c - s / wd * sn) * v0)


@compiled()
def _surface(omega, sigma, q0, v0, x_res, rate, s, q, v):  # pragma: no cover
    """Displacement (m, upward) of the surface under the ball ``s`` seconds after the state
    ``q0``, ``v0`` (m, m/s; the band's modes then the residual's lumped ones, as ``omega``
    and ``sigma``) and ``x_res`` (m, the residual's tail, decaying at ``rate``, 1/s), as
    :meth:`ModalContact.ring` gives it; ``q``, ``v`` are work arrays."""
    for k in range(q0.size):
        q[k] = q0[k]
        v[k] = v0[k]
    if s > 0.0:
        ring_free(omega, sigma, q, v, s)
    total = 0.0
    for k in range(q.size):
        total += q[k]
    return total - x_res * math.exp(-rate * s)


@compiled()
def first_touch(  # pragma: no cover
    omega, sigma, q0, v0, x_res, rate, height, speed, gravity, dt, s0, end
):
    """The first time in ``[s0, end]`` (s) at which a ball at ``height`` (m) rising at
    ``speed`` (m/s) under ``gravity`` (m/s^2) meets the surface ringing from the state
    (as :func:`_surface`), or ``end`` if it does not.

    The gap is sampled in steps of ``dt`` (s), the modes carried from step to step by their
    transition matrices over ``dt`` (exact for free ringing, to rounding); the first sign
    change is then closed on the surface evaluated afresh at each trial time, by Illinois'
    false position kept inside the bracket (a bisection where it would leave it), to the
    time resolution of double precision. The time returned is the bracket's end where the
    gap is <= 0."""
    n = q0.size
    q = np.empty(n)
    v = np.empty(n)
    if not end > s0:
        return s0
    # the state at s0, then the transition over one step
    surface = _surface(omega, sigma, q0, v0, x_res, rate, s0, q, v)
    P = np.empty((n, 4))
    for k in range(n):
        wd, e, c, sn = _transition(omega[k], sigma[k], dt)
        P[k, 0] = e * (c + sigma[k] / wd * sn)
        P[k, 1] = e * sn / wd
        P[k, 2] = -e * omega[k] * omega[k] / wd * sn
        P[k, 3] = e * (c - sigma[k] / wd * sn)
    tail = x_res * math.exp(-rate * s0)
    tail_step = math.exp(-rate * dt)
    gap0 = height + speed * s0 - 0.5 * gravity * s0 * s0 - surface
    if not gap0 > 0.0:
        return s0
    while s0 < end:
        s1 = s0 + dt
        if s0 < s1 < end:
            total = 0.0
            for k in range(n):
                qk = P[k, 0] * q[k] + P[k, 1] * v[k]
                v[k] = P[k, 2] * q[k] + P[k, 3] * v[k]
                q[k] = qk
                total += qk
            tail *= tail_step
            surface = total - tail
        else:
            s1 = end
            surface = _surface(omega, sigma, q0, v0, x_res, rate, s1, q, v)
        gap1 = height + speed * s1 - 0.5 * gravity * s1 * s1 - surface
        if gap1 <= 0.0:
            return _close_touch(omega, sigma, q0, v0, x_res, rate, height, speed, gravity,
                                s0, gap0, s1, gap1, q, v)  # fmt: skip
        s0 = s1
        gap0 = gap1
    return end


@compiled()
def _close_touch(  # pragma: no cover
    omega, sigma, q0, v0, x_res, rate, height, speed, gravity, a, gap_a, b, gap_b, q, v
):
    """The touch inside ``[a, b]`` (s), ``gap_a > 0 >= gap_b`` (m): Illinois' false
    position on the gap, a bisection where its step leaves the bracket, until the bracket is
    within the spacing of doubles at ``b``; returns ``b``."""
    side = 0
    for _ in range(200):
        if b - a <= 4e-16 * b:
            break
        t = (a * gap_b - b * gap_a) / (gap_b - gap_a)
        if not a < t < b:
            t = 0.5 * (a + b)
        gap = height + speed * t - 0.5 * gravity * t * t
        gap -= _surface(omega, sigma, q0, v0, x_res, rate, t, q, v)
        if gap > 0.0:
            a, gap_a = t, gap
            if side == 1:
                gap_b *= 0.5
            side = 1
        else:
            b, gap_b = t, gap
            if side == -1:
                gap_a *= 0.5
            side = -1
    return b
