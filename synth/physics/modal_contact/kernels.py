"""numba kernels of the modal contact: one contact in fixed steps, free ringing of damped modes."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels.equations import yield_law, yield_potential


class Oscillators(NamedTuple):
    """The plate under the ball as the kernels drive it: modes' ``omega`` (rad/s), ``sigma``
    (1/s), couplings ``c`` (1/kg); rigid-body coupling ``rc`` (1/kg); the residual's tail
    admittance ``beta`` (m/(N s)) and rate ``a`` (1/s)."""

    omega: np.ndarray
    sigma: np.ndarray
    c: np.ndarray
    rc: float
    beta: float
    a: float


class BallLaw(NamedTuple):
    """Ball mass ``m`` (kg), gravity ``g`` (m/s^2) and the law ``F = K delta^(n-1) (delta +
    (mu delta + b) delta')`` (``K`` N/m^n, ``mu`` s/m, ``b`` s)."""

    m: float
    K: float
    n: float
    mu: float
    b: float
    g: float


class Outcome(NamedTuple):
    """One contact: separated, time to separation (s), the ball's velocity (m/s, up) and height
    (m), peak penetration (m) and force (N), impulse (N s), steps, damping, dashpot and contact
    losses (J), rigid-body velocity (m/s)."""

    separated: bool
    time: float
    v: float
    u: float
    dmax: float
    fmax: float
    impulse: float
    steps: int
    damping_loss: float
    dashpot_loss: float
    contact_loss: float
    rigid_v: float


@compiled(inline="always")
def illinois(f, args, lo, hi, f_lo, f_hi, atol, rtol):  # pragma: no cover
    """Root in ``[lo, hi]`` with ``f(lo) > 0 >= f(hi)`` by Illinois' false position (Dowell &
    Jarratt, BIT 11 (1971) 168-174), bisecting outside the bracket; returns ``hi``."""
    side = 0
    for _ in range(200):
        if hi - lo <= atol + rtol * hi:
            break
        x = lo + (hi - lo) * f_lo / (f_lo - f_hi) if f_lo > f_hi else 0.5 * (lo + hi)
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
        fx = f(x, *args)
        if fx > 0.0:
            lo, f_lo = x, fx
            if side == 1:
                f_hi *= 0.5
            side = 1
        else:
            hi, f_hi = x, fx
            if side == -1:
                f_lo *= 0.5
            side = -1
            if fx == 0.0:
                break
    return hi


@compiled()
def _phi12(z):  # pragma: no cover
    """``phi_1(z)``, ``phi_2(z)`` (complex), by Taylor series near 0 (no cancellation)."""
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
    """``omega_d`` (rad/s), ``e^(-sigma h)``, ``cos``, ``sin(omega_d h)`` over ``h`` (s)."""
    wd = math.sqrt(omega * omega - sigma * sigma)
    return wd, math.exp(-sigma * h), math.cos(wd * h), math.sin(wd * h)


@compiled()
def _transition_matrix(omega, sigma, h, P):  # pragma: no cover
    """Rows (P11, P12, P21, P22) of each mode's :func:`_transition` matrix over ``h``."""
    for k in range(omega.size):
        s = sigma[k]
        w0 = omega[k]
        wd, e, c, sn = _transition(w0, s, h)
        P[k, 0] = e * (c + s / wd * sn)
        P[k, 1] = e * sn / wd
        P[k, 2] = -e * w0 * w0 / wd * sn
        P[k, 3] = e * (c - s / wd * sn)


@compiled()
def _mode_coefficients(omega, sigma, h, P, G):  # pragma: no cover
    """Exact step ``h`` (s) of ``q'' + 2 sigma q' + omega^2 q = f``, ``f`` linear over it."""
    _transition_matrix(omega, sigma, h, P)
    for k in range(omega.size):
        wd = math.sqrt(omega[k] * omega[k] - sigma[k] * sigma[k])
        p = complex(-sigma[k], wd)
        p1, p2 = _phi12(p * h)
        j0 = h * (p1 - p2)
        j1 = h * p2
        G[k, 0] = j0.imag / wd
        G[k, 1] = j1.imag / wd
        G[k, 2] = (p * j0).imag / wd
        G[k, 3] = (p * j1).imag / wd


@compiled()
def _real_coefficients(a, h):  # pragma: no cover
    """Step ``h`` of ``x' = -a x + f``, ``f`` linear: ``x(h) = E x(0) + g0 f(0) + g1 f(h)``."""
    p1, p2 = _phi12(complex(-a * h, 0.0))
    return math.exp(-a * h), h * (p1.real - p2.real), h * p2.real


@compiled()
def _solve_delta(A, B, K, n):  # pragma: no cover
    """Root ``delta >= 0`` of ``delta + B K delta^n = A`` (A > 0): Newton from above (convex)."""
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
def _lossy_force(d, K, n, mu, b, Av, Bv, dy, dm):  # pragma: no cover
    """Force ``F = K (a + c d')`` (N, >= 0), ``c = mu a + b r``, at the end of a step whose rate
    is ``d' = Av - Bv F``, and ``dF / dd`` (N/m); past a yield ``dy`` (m) Thornton's ``a``,
    ``r`` from the largest penetration ``dm`` (m)."""
    if d <= 0.0:
        return 0.0, 0.0
    if dy != math.inf:
        a, r, da, dr = yield_law(d, dy, dm)
    else:
        r = d ** (n - 1.0)
        a, da, dr = r * d, n * r, (n - 1.0) * r / d
    c = mu * a + b * r
    dc = mu * da + b * dr
    num = a + c * Av
    if num <= 0.0:
        return 0.0, 0.0
    den = 1.0 + c * Bv * K
    F = K * num / den
    return F, K * (da + dc * Av) / den - F * dc * Bv * K / den


@compiled()
def _solve_lossy_delta(A, B, K, n, mu, b, Av, Bv, dy, dm):  # pragma: no cover
    """Root of ``delta + B F(delta) = A``: bracketed Newton."""
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
def _free_gap(q, v, p, P, G, Er, r0, F0, qr, vr, x, u, vs, h, law):  # pragma: no cover
    """Penetration ``delta`` (m) after a step ``h`` with the force at its end left out."""
    w = 0.0
    for k in range(q.size):
        w += P[k, 0] * q[k] + P[k, 1] * v[k] - p.c[k] * G[k, 0] * F0
    w += qr + vr * h - p.rc * h * h * F0 / 3.0
    w -= Er * x + p.beta * r0 * F0
    return w - (u + vs * h - 0.5 * law.g * h * h + h * h * F0 / (3.0 * law.m))


@compiled()
def _rate_free(q, v, p, P, G, Er, r0, F0, vr, x, vs, h, law):  # pragma: no cover
    """Penetration rate ``delta'`` (m/s) after a step ``h`` with the force at its end left out."""
    w = vr - 0.5 * p.rc * h * F0 + p.a * (Er * x + p.beta * r0 * F0)
    for k in range(q.size):
        w += P[k, 2] * q[k] + P[k, 3] * v[k] - p.c[k] * G[k, 2] * F0
    return w - (vs - law.g * h + 0.5 * h * F0 / law.m)


@compiled()
def _end_gap(h, q, v, p, F0, qr, vr, x, u, vs, law):  # pragma: no cover
    """``delta`` after a step ``h`` over which the force falls linearly from ``F0`` to 0."""
    P = np.empty((q.size, 4))
    G = np.empty((q.size, 4))
    _mode_coefficients(p.omega, p.sigma, h, P, G)
    Er, r0, _ = _real_coefficients(p.a, h)
    return _free_gap(q, v, p, P, G, Er, r0, F0, qr, vr, x, u, vs, h, law)


@compiled()
def _advance(q, v, P, G, c, sigma, F0, F1, h):  # pragma: no cover
    """Advance the modes one step, force linear from F0 to F1; the damping loss, J (trapezoid)."""
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
    """Velocity of the surface under the ball (m/s, up): modes, rigid body, residual."""
    w = vr - xdot
    for k in range(v.size):
        w += v[k]
    return w


@compiled()
def _step(q, v, p, P, G, E, r0, r1, x, qr, vr, u, vs, F0, F1, h, law):  # pragma: no cover
    """One step ``h`` (s), force linear from ``F0`` to ``F1`` (N): modes in place, residual
    tail, rigid body and ball; returns those, the tail's velocity (m/s) and losses (J)."""
    damping = _advance(q, v, P, G, p.c, p.sigma, F0, F1, h)
    xdot0 = p.beta * F0 - p.a * x
    x = E * x + p.beta * (r0 * F0 + r1 * F1)
    xdot1 = p.beta * F1 - p.a * x
    dashpot = 0.5 * h * (xdot0 * xdot0 + xdot1 * xdot1) / p.beta
    qr += vr * h - p.rc * h * h * (F0 / 3.0 + F1 / 6.0)
    vr -= p.rc * h * 0.5 * (F0 + F1)
    u += vs * h - 0.5 * law.g * h * h + h * h * (F0 / 3.0 + F1 / 6.0) / law.m
    vs += -law.g * h + h * 0.5 * (F0 + F1) / law.m
    return x, qr, vr, u, vs, xdot1, damping, dashpot


@compiled()
def contact_kernel(p, q, v, x_res, law, dy, v_in, h, max_steps, pulse):  # pragma: no cover
    """One contact from first touch at ``v_in`` (m/s) on plate ``p`` under ``law``, yield past
    ``dy`` (m; inf: none, a float either way so that the kernel compiles once); fixed steps
    ``h`` (s), the last cut at separation. The plate's state is advanced in place; ``pulse``
    takes time (s), force (N), penetration (m) and rate (m/s) per step."""
    times, forces, gaps, rates = pulse[0], pulse[1], pulse[2], pulse[3]
    m, K, n, mu, b = law.m, law.K, law.n, law.mu, law.b
    N = q.size
    P = np.empty((N, 4))
    G = np.empty((N, 4))
    _mode_coefficients(p.omega, p.sigma, h, P, G)
    Er, r0, r1 = _real_coefficients(p.a, h)
    B = h * h / (6.0 * m) + p.rc * h * h / 6.0 + p.beta * r1
    for k in range(N):
        B += p.c[k] * G[k, 1]
    # the penetration rate at the end of a step is Av - Bv F1 (the lossy laws only)
    Bv = h / (2.0 * m) + 0.5 * p.rc * h + p.beta * (1.0 - p.a * r1)
    for k in range(N):
        Bv += p.c[k] * G[k, 3]
    lossy = mu != 0.0 or b != 0.0
    plain = not lossy  # the elastic law: its own root
    if dy != math.inf:
        plain = False
    contact_loss = 0.0
    work = 0.0  # the elastic-plastic force's work on the penetration (trapezoid rule), J
    Fd0 = 0.0  # the viscous part F - K delta^n of the force at the start of the step
    x = x_res[0]
    u = -x
    for k in range(N):
        u += q[k]
    vs = -v_in
    qr = vr = F0 = t = damping_loss = dashpot_loss = impulse = dmax = fmax = 0.0
    times[0] = forces[0] = gaps[0] = 0.0
    rates[0] = v_in
    for k in range(N):
        rates[0] += v[k]
    separated = False
    steps = 0
    for i in range(max_steps):
        A = _free_gap(q, v, p, P, G, Er, r0, F0, qr, vr, x, u, vs, h, law)
        hs, Ps, Gs, Es, s0, s1 = h, P, G, Er, r0, r1
        separated = A <= 0.0
        if separated:
            # the gap opens within this step: the step hs to delta(hs) = 0, force falling to 0
            g_lo = gaps[i] if dy != math.inf else (F0 / K) ** (1.0 / n)  # delta at the start
            gap_args = (q, v, p, F0, qr, vr, x, u, vs, law)
            hs = illinois(_end_gap, gap_args, 0.0, h, g_lo, A, 1e-13 * h, 0.0)
            Ps = np.empty((N, 4))
            Gs = np.empty((N, 4))
            _mode_coefficients(p.omega, p.sigma, hs, Ps, Gs)
            Es, s0, s1 = _real_coefficients(p.a, hs)
            d1 = F1 = 0.0
        elif plain:
            d1 = _solve_delta(A, B, K, n)
            F1 = K * d1**n
        else:
            Av = _rate_free(q, v, p, P, G, Er, r0, F0, vr, x, vs, h, law)
            d1 = _solve_lossy_delta(A, B, K, n, mu, b, Av, Bv, dy, dmax)
            F1 = _lossy_force(d1, K, n, mu, b, Av, Bv, dy, dmax)[0]
        Fe1 = 0.0
        if dy != math.inf:
            Fe1 = K * yield_law(d1, dy, dmax)[0] if d1 > 0.0 else 0.0
            Fe0 = K * yield_law(gaps[i], dy, dmax)[0] if gaps[i] > 0.0 else 0.0
            work += 0.5 * (Fe0 + Fe1) * (d1 - gaps[i])
        x, qr, vr, u, vs, xdot1, lost, dashpot = _step(
            q, v, p, Ps, Gs, Es, s0, s1, x, qr, vr, u, vs, F0, F1, hs, law
        )
        damping_loss += lost
        dashpot_loss += dashpot
        impulse += 0.5 * hs * (F0 + F1)
        t += hs
        F0 = F1
        forces[i + 1] = F1
        times[i + 1] = t
        gaps[i + 1] = d1
        rates[i + 1] = _surface_velocity(v, vr, xdot1) - vs
        if lossy:
            Fd1 = F1 - K * d1**n
            if dy != math.inf:
                Fd1 = F1 - Fe1
            contact_loss += 0.5 * hs * (Fd0 * rates[i] + Fd1 * rates[i + 1])
            Fd0 = Fd1
        dmax = max(dmax, d1)
        fmax = max(fmax, F1)
        steps = i + 1
        if separated:
            break
    x_res[0] = x
    if dy != math.inf:
        # the plastic work: the elastic-plastic force's work less the energy it still holds
        end = gaps[steps]
        contact_loss += work - (K * yield_potential(end, dy, dmax) if end > 0.0 else 0.0)
    return Outcome(
        separated, t, vs, u, dmax, fmax, impulse, steps, damping_loss, dashpot_loss,
        contact_loss, vr,
    )  # fmt: skip


@compiled()
def ring_free(omega, sigma, q, v, duration):  # pragma: no cover
    """Free ringing of the modes over ``duration`` (s), in place (:func:`_transition`)."""
    for k in range(q.size):
        s = sigma[k]
        w0 = omega[k]
        wd, e, c, sn = _transition(w0, s, duration)
        q0 = q[k]
        v0 = v[k]
        q[k] = e * ((c + s / wd * sn) * q0 + sn / wd * v0)
        v[k] = e * (-w0 * w0 / wd * sn * q0 + (c - s / wd * sn) * v0)


@compiled()
def _surface(p, q0, v0, x_res, s, q, v):  # pragma: no cover
    """Displacement (m, upward) of the surface under the ball ``s`` (s) after the state ``q0``,
    ``v0``, ``x_res`` (as :meth:`ModalContact.ring`); ``q``, ``v`` are work arrays."""
    for k in range(q0.size):
        q[k] = q0[k]
        v[k] = v0[k]
    if s > 0.0:
        ring_free(p.omega, p.sigma, q, v, s)
    total = 0.0
    for k in range(q.size):
        total += q[k]
    return total - x_res * math.exp(-p.a * s)


@compiled()
def _touch_gap(t, p, q0, v0, x_res, height, speed, gravity, q, v):  # pragma: no cover
    """The ball's height (m) over the ringing surface of :func:`_surface` at ``t`` (s)."""
    gap = height + speed * t - 0.5 * gravity * t * t
    return gap - _surface(p, q0, v0, x_res, t, q, v)


@compiled()
def first_touch(p, q0, v0, x_res, height, speed, gravity, dt, s0, end):  # pragma: no cover
    """First time in ``[s0, end]`` (s) a ball at ``height`` (m) rising at ``speed`` (m/s) under
    ``gravity`` (m/s^2) meets the ringing surface, else ``end``: sampled every ``dt`` (s)."""
    n = q0.size
    q = np.empty(n)
    v = np.empty(n)
    if not end > s0:
        return s0
    # the state at s0, then the transition over one step
    surface = _surface(p, q0, v0, x_res, s0, q, v)
    P = np.empty((n, 4))
    _transition_matrix(p.omega, p.sigma, dt, P)
    tail = x_res * math.exp(-p.a * s0)
    tail_step = math.exp(-p.a * dt)
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
            surface = _surface(p, q0, v0, x_res, s1, q, v)
        gap1 = height + speed * s1 - 0.5 * gravity * s1 * s1 - surface
        if gap1 <= 0.0:
            args = (p, q0, v0, x_res, height, speed, gravity, q, v)
            return illinois(_touch_gap, args, s0, s1, gap0, gap1, 0.0, 4e-16)
        s0 = s1
        gap0 = gap1
    return end


@compiled()
def hermite(u, h, gaps, rates, i):  # pragma: no cover
    """Cubic Hermite interpolant of ``gaps`` (m) and ``rates`` (m/s) at the fraction ``u`` of
    steps ``i`` of length ``h`` (s): penetration (m), rate (m/s) and acceleration (m/s^2)."""
    d0, d1 = gaps[i], gaps[i + 1]
    r0, r1 = rates[i] * h, rates[i + 1] * h
    u2, u3 = u * u, u * u * u
    delta = ((2 * u3 - 3 * u2 + 1) * d0 + (u3 - 2 * u2 + u) * r0 + (-2 * u3 + 3 * u2) * d1) + (
        u3 - u2
    ) * r1
    rate = ((6 * u2 - 6 * u) * d0 + (3 * u2 - 4 * u + 1) * r0 + (6 * u - 6 * u2) * d1) / h
    rate += (3 * u2 - 2 * u) * r1 / h
    accel = ((12 * u - 6) * d0 + (6 * u - 4) * r0 + (6 - 12 * u) * d1 + (6 * u - 2) * r1) / (h * h)
    return delta, rate, accel


@compiled()
def _force_sign(u, h, gaps, rates, i, mu, b, dy, dm):  # pragma: no cover
    """Sign of the unclipped lossy force (``dy``, ``dm`` in m) at fraction ``u`` of step ``i``."""
    d, rate, _ = hermite(u, h, gaps, rates, i)
    if d <= 0.0:
        return d
    if dy != math.inf:
        a, r, _, _ = yield_law(d, dy, dm)
        return -1.0 if a <= 0.0 else a + (mu * a + b * r) * rate
    return 1.0 + mu * rate if b == 0.0 else d + (mu * d + b) * rate


@compiled()
def force_end(times, forces, gaps, rates, mu, b, dy):  # pragma: no cover
    """End (s) of a lossy contact's force pulse: the last zero of :func:`_force_sign`."""
    last = times.size - 1
    i = last
    while i >= 0 and not forces[i] > 0.0:
        i -= 1
    if i < 0 or i == last:
        return times[last]
    t0, t1 = times[i], times[i + 1]
    h = t1 - t0
    args = (h, gaps, rates, i, mu, b, dy, np.max(gaps[: i + 1]))
    f_lo, f_hi = _force_sign(0.0, *args), _force_sign(1.0, *args)
    if not (f_lo > 0.0 and f_hi <= 0.0):
        return t1
    return t0 + illinois(_force_sign, args, 0.0, 1.0, f_lo, f_hi, 4e-16 * t1 / h, 0.0) * h
