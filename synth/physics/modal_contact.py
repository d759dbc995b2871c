"""The finite plate in the contact: the ball against the plate's modes (docs/physics.md,
"Plate impedance" and "Plate modes").

The impedance model (:mod:`synth.physics.contact`) gives the plate surface under the ball the
velocity ``v_free - beta F`` of an infinite plate. Here the plate is the finite plate itself:
its displacement under the ball is

    w(t) = sum_k q_k(t) + q_rigid(t) + sum_j q_j(t) - x_res(t)

* ``q_k`` bending mode k (:func:`synth.sound.modes.modes`, frequencies ``omega_k``, decay rates
  ``sigma_k``), seen at the contact point ``x0``: ``q_k'' + 2 sigma_k q_k' + omega_k^2 q_k =
  -c_k F`` with the coupling ``c_k = phi_k(x0)^2 / M_k`` (1/kg);
* ``q_rigid`` the rigid-body motion of a free plate (translation and two rotations,
  ``q_rigid'' = -c_rigid F``, ``c_rigid = (1 + 3 xi^2 + 3 eta^2) / M`` with ``xi, eta`` the
  point's coordinates scaled to [-1, 1]); none for supported or clamped edges;
* the residual: the modes above the band limit ``Omega``, taken as the infinite plate's
  continuum of modes (wavenumber ``s = k^2``, ``S / (4 pi)`` modes per unit ``s`` on a plate
  of area ``S``, each of coupling ``1 / (rho h S m_f(s))``, ``m_f`` Mindlin's modal mass
  factor, 1 for Kirchhoff). Their admittance is ``Y_res(s) = s Int dmu(w) / (w^2 + s^2)``
  over ``w > Omega`` with ``dmu = ds / (4 pi rho h m_f)``: the infinite plate's admittance
  minus the band's modes (:func:`residual_admittance_exact`). Below the band it is reactive
  (but for the modes' damping) and varies with frequency (for Kirchhoff
  ``i (beta_inf / pi) ln((Omega + omega) / (Omega - omega))``, nearly a spring; for a
  Mindlin plate of soft shear not). It is
  realised by :data:`RESIDUAL_BINS` lumped modes, one per geometric bin of
  :data:`RESIDUAL_RATIO` in frequency above ``Omega``, each with its bin's coupling
  ``c_j = Int dmu`` and its bin's compliance ``c_j / w_j^2 = Int dmu / w^2`` and the plate's
  loss ``sigma / omega`` at the band limit (they are the plate's own modes above the band,
  lumped; the damping law is not extrapolated beyond the band); and above the
  last bin, ``W``, the one-pole tail ``beta_W s / (s + a)``, ``beta_W`` the infinite plate's
  ``Re Y`` at ``W`` and ``a = pi W / 2`` (a dashpot ``1 / beta_W`` in parallel with a spring
  ``a / beta_W``: the continuum of constant density above ``W``): ``x_res' = beta_W F -
  a x_res``. For Kirchhoff this is exact above ``W`` and the bins hold the residual to
  2e-3 of ``beta_inf`` below ``Omega / 2`` (0.04 at ``0.9 Omega``, the logarithm at the
  band edge); for Mindlin the wavenumber integral of a point force diverges
  logarithmically (the local shear deflection), and the tail's constant density above
  ``W`` bounds it there: what lies above is the local deformation that the contact law
  carries.

So the onset of every contact sees the infinite plate's admittance, the modes add what the
finite plate does within the band (reflections from edges and corners, the ringing left by an
earlier impact), and as ``Omega`` grows the model tends to the finite thin plate. Far from the
edges, before any reflection returns, it equals the impedance model.

Ball (mass ``m``, height ``u`` of its lowest point, gravity ``g``): ``m u'' = F - m g``;
contact law ``F = K delta^n`` with ``delta = w - u`` (:func:`synth.physics.contact.contact_law`),
or with Hunt & Crossley's loss ``F = K delta^n (1 + mu delta')``, ``F >= 0`` (Hunt & Crossley,
J. Appl. Mech. 42 (1975) 440-445).

Numerics. Fixed steps ``h``; over each step the force is taken linear in time (first-order
hold), and every linear part (modes, rigid body, residual, the ball's free flight) is advanced
exactly for that force: with ``z = p h`` for a pole ``p``, the responses to the force at the
start and at the end of the step are ``h (phi_1(z) - phi_2(z))`` and ``h phi_2(z)``,
``phi_1(z) = (e^z - 1) / z``, ``phi_2(z) = (e^z - 1 - z) / z^2`` (exponential integrators,
Hochbruck & Ostermann, Acta Numerica 19 (2010) 209-286). The force at the end of the step is
then the root of one scalar equation, ``delta + B F(delta) = A`` (monotone: one root; with the
loss, ``delta'`` at the end of the step is itself linear in that force), so the
scheme is implicit in the contact and unconditionally stable for every mode; its error is
second order in ``h``. The end of contact is the root of ``delta(h') = 0`` within the last step.
The modes are those of an eigen-solution of exactly the band (:func:`band_modes`): a cached
wider band's modes differ in their last digits, which a series of bounces amplifies to audible
differences, so the result does not depend on what the process or the disk cache solved before.
Energy is book-kept (ball, modes, modal damping, rigid body, residual spring and dashpot, the
contact's loss ``Int (F - K delta^n) delta' dt`` by the trapezoid rule) and its
balance reported as ``energy_residual``.
"""

from __future__ import annotations

import cmath
import json
import math
from dataclasses import dataclass, field

import numba
import numpy as np

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.io.cache import MemoryCache, cache_path, load_npz, savez_atomic
from synth.physics import impedance
from synth.physics.contact import ImpactResult, contact_law, solve_contact
from synth.physics.scene import Ball, Plate

__all__ = [
    "BAND_FACTOR",
    "PLATE_THEORIES",
    "RESIDUAL_BINS",
    "RESIDUAL_RATIO",
    "STEPS_PER_CONTACT",
    "ModalPoint",
    "ModalContact",
    "ModalImpactResult",
    "PlateRinging",
    "band_modes",
    "clear_memory_cache",
    "modal_point",
    "next_touch",
    "residual_admittance_exact",
]

#: Band limit of the modes in the contact, in units of ``1 / tau`` (``tau`` the impedance
#: model's contact time): the force pulse's spectrum is below -60 dB of its peak beyond
#: about ``3 / tau``; the residual stands for the modes above.
BAND_FACTOR = 4.0
#: The residual's lumped modes above the band limit: this many geometric bins, each this
#: ratio wide in frequency (three per octave, four octaves: the tail starts at 16 Omega).
RESIDUAL_BINS = 12
RESIDUAL_RATIO = 2.0 ** (1.0 / 3.0)
#: Fixed steps over one contact of the impedance model's duration.
STEPS_PER_CONTACT = 512
#: A contact still going after this many impedance-model contact times is reported as
#: settled (the ball rests on the plate).
SETTLE_FACTOR = 40.0

# Result columns of the kernel.
_R_STATUS, _R_TIME, _R_V, _R_U, _R_DMAX, _R_FMAX, _R_IMPULSE = 0, 1, 2, 3, 4, 5, 6
_R_STEPS, _R_DAMPING_LOSS, _R_DASHPOT_LOSS, _R_RIGID_Q, _R_RIGID_V = 7, 8, 9, 10, 11
_R_CONTACT_LOSS = 12
_R_COLS = 13
_SEPARATED, _SETTLED = 0, 1


# --------------------------------------------------------------------------------------
# Kernel
# --------------------------------------------------------------------------------------


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _mode_coefficients(omega, sigma, h, P, G):  # pragma: no cover
    """Exact step ``h`` (s) of ``q'' + 2 sigma q' + omega^2 q = f`` (underdamped) with ``f``
    linear over the step: ``[q, v](h) = P [q, v](0) + G[:, 0:2] f(0) + G[:, 2:4] f(h)``;
    ``P`` rows (P11, P12, P21, P22), ``G`` rows (f0 -> q, f1 -> q, f0 -> v, f1 -> v)."""
    for k in range(omega.size):
        s = sigma[k]
        w0 = omega[k]
        wd = math.sqrt(w0 * w0 - s * s)
        e = math.exp(-s * h)
        c = math.cos(wd * h)
        sn = math.sin(wd * h)
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


@numba.njit(cache=True)
def _real_coefficients(a, h):  # pragma: no cover
    """Step ``h`` of ``x' = -a x + f`` with ``f`` linear: ``x(h) = E x(0) + g0 f(0) + g1 f(h)``."""
    p1, p2 = _phi12(complex(-a * h, 0.0))
    return math.exp(-a * h), h * (p1.real - p2.real), h * p2.real


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _lossy_force(d, K, n, mu, Av, Bv):  # pragma: no cover
    """Hunt-Crossley force ``K d^n (1 + mu d')`` (N, at least 0) at the end of a step whose
    penetration rate is ``d' = Av - Bv F`` (the step's linear response to the force ``F``
    at its end), solved for ``F``, and its derivative with respect to ``d`` (N/m)."""
    s = K * d**n
    num = 1.0 + mu * Av
    if num <= 0.0 or d <= 0.0:
        return 0.0, 0.0
    den = 1.0 + mu * Bv * s
    return s * num / den, n * s / d * num / (den * den)


@numba.njit(cache=True)
def _solve_lossy_delta(A, B, K, n, mu, Av, Bv):  # pragma: no cover
    """The root ``delta >= 0`` of ``delta + B F(delta) = A`` (A > 0) with the Hunt-Crossley
    force of :func:`_lossy_force` (increasing in ``delta``: one root in ``[0, A]``): Newton's
    method kept inside a bracket, bisection where a step leaves it."""
    lo = 0.0
    hi = A
    d = _solve_delta(A, B, K, n)  # start from the elastic root
    for _ in range(200):
        F, dF = _lossy_force(d, K, n, mu, Av, Bv)
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


@numba.njit(cache=True)
def _plate_free(q, v, P, G, c, F0, qr, vr, rc, x, Er, r0, beta, h):  # pragma: no cover
    """Plate displacement under the ball after a step ``h`` with the force at its end left out:
    modes, rigid body and residual from their states and the force ``F0`` at the start."""
    w = 0.0
    for k in range(q.size):
        w += P[k, 0] * q[k] + P[k, 1] * v[k] - c[k] * G[k, 0] * F0
    w += qr + vr * h - rc * h * h * F0 / 3.0
    w -= Er * x + beta * r0 * F0
    return w


@numba.njit(cache=True)
def _rate_free(q, v, P, G, c, F0, vr, rc, x, Er, r0, beta, a, vs, m, g, h):  # pragma: no cover
    """Penetration rate ``delta'`` (m/s) after a step ``h`` with the force at its end left out
    (the part of the rate that does not depend on it): plate surface velocity (modes, rigid
    body, residual) minus the ball's velocity."""
    w = vr - 0.5 * rc * h * F0 + a * (Er * x + beta * r0 * F0)
    for k in range(q.size):
        w += P[k, 2] * q[k] + P[k, 3] * v[k] - c[k] * G[k, 2] * F0
    return w - (vs - g * h + 0.5 * h * F0 / m)


@numba.njit(cache=True)
def _end_gap(q, v, c, omega, sigma, F0, qr, vr, rc, x, a, beta, u, vs, m, g, h):  # pragma: no cover
    """``delta`` after a step ``h`` over which the force falls linearly from ``F0`` to 0."""
    P = np.empty((q.size, 4))
    G = np.empty((q.size, 4))
    _mode_coefficients(omega, sigma, h, P, G)
    Er, r0, _ = _real_coefficients(a, h)
    w = _plate_free(q, v, P, G, c, F0, qr, vr, rc, x, Er, r0, beta, h)
    ub = u + vs * h - 0.5 * g * h * h + h * h * F0 / (3.0 * m)
    return w - ub


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _surface_velocity(v, vr, xdot):  # pragma: no cover
    """Velocity of the plate surface under the ball (m/s, upward): bending modes, rigid body
    and residual (whose displacement ``x_res`` is downward)."""
    w = vr - xdot
    for k in range(v.size):
        w += v[k]
    return w


@numba.njit(cache=True)
def _contact(
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
    the contact law ``F = K delta^n (1 + mu delta')`` (``mu = 0``: elastic).

    ``q``, ``v`` (modal displacements and velocities under the ball) and ``x_res`` (array of
    one: the residual's displacement) are the plate's state at first touch and are advanced
    in place to the end of contact. ``forces``/``times`` receive the force at every step,
    ``gaps``/``rates`` the penetration ``delta`` (m) and its rate (m/s)."""
    r = np.zeros(_R_COLS)
    N = q.size
    P = np.empty((N, 4))
    G = np.empty((N, 4))
    _mode_coefficients(omega, sigma, h, P, G)
    Er, r0, r1 = _real_coefficients(a, h)
    B = h * h / (6.0 * m) + rc * h * h / 6.0 + beta * r1
    for k in range(N):
        B += c[k] * G[k, 1]
    # the penetration rate at the end of a step is Av - Bv F1 (Hunt-Crossley only)
    Bv = h / (2.0 * m) + 0.5 * rc * h + beta * (1.0 - a * r1)
    for k in range(N):
        Bv += c[k] * G[k, 3]
    contact_loss = 0.0
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
    status = _SETTLED
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
            t += hh
            forces[i + 1] = 0.0
            times[i + 1] = t
            gaps[i + 1] = 0.0
            rates[i + 1] = _surface_velocity(v, vr, xdot1) - vs
            status = _SEPARATED
            steps = i + 1
            break
        if mu == 0.0:
            d1 = _solve_delta(A, B, K, n)
            F1 = K * d1**n
        else:
            Av = _rate_free(q, v, P, G, c, F0, vr, rc, x, Er, r0, beta, a, vs, m, g, h)
            d1 = _solve_lossy_delta(A, B, K, n, mu, Av, Bv)
            F1 = _lossy_force(d1, K, n, mu, Av, Bv)[0]
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
        if mu != 0.0:
            Fd1 = F1 - K * d1**n
            contact_loss += 0.5 * h * (Fd0 * rates[i] + Fd1 * rates[i + 1])
            Fd0 = Fd1
        if d1 > dmax:
            dmax = d1
        if F1 > fmax:
            fmax = F1
        steps = i + 1
    x_res[0] = x
    r[_R_STATUS] = status
    r[_R_TIME] = t
    r[_R_V] = vs
    r[_R_U] = u
    r[_R_DMAX] = dmax
    r[_R_FMAX] = fmax
    r[_R_IMPULSE] = impulse
    r[_R_STEPS] = steps
    r[_R_DAMPING_LOSS] = damping_loss
    r[_R_DASHPOT_LOSS] = dashpot_loss
    r[_R_RIGID_Q] = qr
    r[_R_RIGID_V] = vr
    r[_R_CONTACT_LOSS] = contact_loss
    return r


@numba.njit(cache=True)
def _ring(omega, sigma, q, v, duration):  # pragma: no cover
    """Free ringing of the modes over ``duration`` (s), in place (the homogeneous part of
    :func:`_mode_coefficients`)."""
    for k in range(q.size):
        s = sigma[k]
        w0 = omega[k]
        wd = math.sqrt(w0 * w0 - s * s)
        e = math.exp(-s * duration)
        c = math.cos(wd * duration)
        sn = math.sin(wd * duration)
        q0 = q[k]
        v0 = v[k]
        q[k] = e * ((c + s / wd * sn) * q0 + sn / wd * v0)
        v[k] = e * (-w0 * w0 / wd * sn * q0 + (c - s / wd * sn) * v0)


# --------------------------------------------------------------------------------------
# The plate seen from one point
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ModalPoint:
    """The finite plate as the contact sees it at one point (see the module docstring).

    Attributes
    ----------
    plate : Plate
    position : (float, float)
        The point, metres from a plate corner.
    max_frequency : float
        Band limit of the modes, Hz (``Omega = 2 pi max_frequency``).
    omega : ndarray
        Natural angular frequencies of the bending modes in the band, rad/s.
    sigma : ndarray
        Their amplitude decay rates, 1/s.
    coupling : ndarray
        ``c_k = phi_k(x0)^2 / M_k``, 1/kg.
    rigid_coupling : float
        ``c_rigid`` of the free plate's rigid-body motion at the point, 1/kg (0 for
        supported and clamped plates).
    residual_admittance : float
        The residual's tail ``beta_W``: the infinite plate's ``Re Y`` at the top ``W`` of
        the lumped modes, m/(N s).
    residual_rate : float
        The tail's ``a = pi W / 2``, 1/s.
    theory : str
        The plate theory of the modes and residual: "kirchhoff" (thin plate) or "mindlin"
        (shear deformation and rotary inertia, :func:`modal_point`).
    residual_omega, residual_sigma, residual_coupling : ndarray
        The residual's lumped modes above the band: angular frequencies (rad/s), decay
        rates (1/s) and couplings (1/kg) (empty: the tail alone).
    """

    plate: Plate
    position: tuple[float, float]
    max_frequency: float
    omega: np.ndarray = field(repr=False)
    sigma: np.ndarray = field(repr=False)
    coupling: np.ndarray = field(repr=False)
    rigid_coupling: float
    residual_admittance: float
    residual_rate: float
    theory: str = "kirchhoff"
    residual_omega: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    residual_sigma: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    residual_coupling: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def contact_modes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angular frequencies (rad/s), decay rates (1/s) and couplings (1/kg) of every
        oscillator the contact drives: the band's modes, then the residual's lumped ones."""
        return (
            np.concatenate((self.omega, self.residual_omega)),
            np.concatenate((self.sigma, self.residual_sigma)),
            np.concatenate((self.coupling, self.residual_coupling)),
        )

    def residual(self, frequency) -> np.ndarray:
        """The residual's admittance (m/(N s), complex, as :meth:`admittance`) at
        ``frequency`` (Hz, > 0): the lumped modes above the band and the tail."""
        s = 2j * np.pi * np.asarray(frequency, dtype=float)[..., None]
        w, sg, c = self.residual_omega, self.residual_sigma, self.residual_coupling
        lumped = (s * c / (s * s + 2.0 * sg * s + w**2)).sum(axis=-1)
        s1 = s[..., 0]
        return lumped + self.residual_admittance * s1 / (s1 + self.residual_rate)

    def admittance(self, frequency) -> np.ndarray:
        """Driving-point admittance ``Y = v / F`` (m/(N s), complex, ``e^(i omega t)``
        convention, force and velocity both positive downward) at ``frequency`` (Hz, > 0)."""
        f = np.atleast_1d(np.asarray(frequency, dtype=float))
        if not np.all(np.isfinite(f) & (f > 0.0)):
            raise ParameterError(f"frequency={frequency!r} must be finite and > 0 (Hz)")
        s = 2j * np.pi * f[:, None]
        modal = (s * self.coupling / (s * s + 2.0 * self.sigma * s + self.omega**2)).sum(axis=1)
        y = modal + self.rigid_coupling / s[:, 0] + self.residual(f)
        return y.reshape(np.shape(frequency)) if np.ndim(frequency) else y[0]

    def band_impedance(self, low: float, high: float) -> float:
        """Driving-point impedance ``1 / <Re Y>`` (N s/m), with ``Re Y`` averaged over the band
        ``[low, high]`` (Hz): the quantity an impact hammer's band-averaged measurement
        gives, and for the infinite plate ``Z_inf`` (each mode adds ``pi c_k / 2`` to the
        integral of ``Re Y`` over angular frequency; the average is taken of the modes in
        the band, plus the residual's share)."""
        lo = checks.nonnegative("low", low, "Hz")
        hi = checks.positive("high", high, "Hz")
        if not hi > lo:
            raise ParameterError(f"high={high!r} must be > low={low!r} (Hz)")
        if hi > self.max_frequency:
            raise ParameterError(
                f"high={high!r} must be <= the band limit {self.max_frequency!r} (Hz)"
            )
        w_lo, w_hi = 2.0 * np.pi * lo, 2.0 * np.pi * hi
        inside = (self.omega >= w_lo) & (self.omega < w_hi)
        modal = 0.5 * np.pi * float(self.coupling[inside].sum())
        # residual's tail: Int Re[beta s / (s + a)] d omega = beta (w - a atan(w / a))
        b, a = self.residual_admittance, self.residual_rate
        residual = b * ((w_hi - a * math.atan(w_hi / a)) - (w_lo - a * math.atan(w_lo / a)))
        residual += _lumped_real_integral(
            self.residual_omega, self.residual_sigma, self.residual_coupling, w_lo, w_hi
        )
        return (w_hi - w_lo) / (modal + residual)


def _lumped_real_integral(omega, sigma, coupling, w_lo: float, w_hi: float) -> float:
    """``Int Re Y d omega`` (m/(N s) rad/s) over ``[w_lo, w_hi]`` (rad/s) of the damped
    oscillators ``Y = c s / (s^2 + 2 sigma s + omega^2)`` (``sigma > 0``): by partial
    fractions ``Y = r / (s - p) + conj(r) / (s - conj(p))``, ``r = c p / (p - conj(p))``,
    and ``Int r / (i w - p) d w = -i r log(i w - p)`` (``Re(i w - p) = sigma > 0``: no
    branch cut is crossed)."""
    total = 0.0
    for w0, sg, c in zip(omega, sigma, coupling, strict=True):
        p = complex(-sg, math.sqrt(w0 * w0 - sg * sg))
        r = c * p / (p - p.conjugate())
        for pole, res in ((p, r), (p.conjugate(), r.conjugate())):
            step = cmath.log(1j * w_hi - pole) - cmath.log(1j * w_lo - pole)
            total += (-1j * res * step).real
    return total


#: Plate theories of the modal contact (:func:`modal_point`).
PLATE_THEORIES = ("kirchhoff", "mindlin")


def modal_point(
    plate: Plate,
    position: tuple[float, float],
    *,
    max_frequency: float,
    theory: str = "kirchhoff",
) -> ModalPoint:
    """The plate at ``position`` (m from a corner) with its bending modes up to
    ``max_frequency`` (Hz) and the residual above (see the module docstring).

    ``theory``: "kirchhoff", the thin plate; or "mindlin", with shear deformation and
    rotary inertia (docs/physics.md, "Thick plates"): each thin-plate mode keeps its shape
    and its wavenumber ``k^2 = omega_K sqrt(rho h / D)`` and takes Mindlin's frequency at
    that wavenumber (:func:`synth.physics.impedance.mindlin_angular_frequency`, exact for
    the simply supported plate) and Mindlin's modal mass
    (:func:`synth.physics.impedance.mindlin_mass_factor`); the band then needs the thin
    modes up to the wavenumber of Mindlin's ``max_frequency``. The residual's admittance is
    the infinite Mindlin plate's at the band limit
    (:func:`synth.physics.impedance.mindlin_point_admittance`). With these couplings the
    modes' band-averaged ``Re Y`` is the infinite Mindlin plate's (modal density times
    ``pi c_k / 2``).

    The modes are those of an eigen-solution for exactly this band
    (:func:`band_modes`), never a wider band's held in the mode cache: a Ritz solution's
    modes depend on its basis in their last digits, and a series of bounces on the modal
    plate amplifies such differences, so the result must not depend on what was solved
    before. Each point's modes are kept on disk (a later process then needs no solve)."""
    if not isinstance(plate, Plate):
        raise ParameterError(f"plate={plate!r} must be a Plate")
    x, y = plate.check_position(position, "position")
    fmax = checks.positive("max_frequency", max_frequency, "Hz")
    if theory not in PLATE_THEORIES:
        raise ParameterError(f"theory={theory!r} must be one of {PLATE_THEORIES}")
    omega_band = 2.0 * math.pi * fmax
    if theory == "mindlin":
        thin_band = _thin_frequency(plate, impedance.mindlin_wavenumbers(plate, omega_band)[0])
        omega, coupling = _point_modes(plate, (x, y), thin_band / (2.0 * math.pi))
        s = omega * math.sqrt(plate.surface_density / plate.flexural_rigidity)
        omega = impedance.mindlin_angular_frequency(plate, s)
        coupling = coupling / impedance.mindlin_mass_factor(plate, s, omega)
        inside = omega <= omega_band
        omega, coupling = omega[inside], coupling[inside]
    else:
        omega, coupling = _point_modes(plate, (x, y), fmax)
    lumped = _lumped_residual(plate, omega_band, theory)
    sigma = _decay_rates(plate, omega, fmax)
    lumped_sigma = lumped.omega * _band_edge_loss(plate, omega_band, fmax)
    # modes with a node at the point take no part in the contact
    keep = coupling > 1e-12 * coupling.max(initial=0.0)
    omega, sigma, coupling = omega[keep], sigma[keep], coupling[keep]
    if plate.boundary == "free":
        xi = 2.0 * x / plate.length - 1.0
        eta = 2.0 * y / plate.width - 1.0
        rigid = (1.0 + 3.0 * xi * xi + 3.0 * eta * eta) / plate.mass
    else:
        rigid = 0.0
    return ModalPoint(
        plate=plate,
        position=(x, y),
        max_frequency=fmax,
        omega=omega,
        sigma=sigma,
        coupling=coupling,
        rigid_coupling=rigid,
        residual_admittance=lumped.tail_admittance,
        residual_rate=lumped.tail_rate,
        theory=theory,
        residual_omega=lumped.omega,
        residual_sigma=lumped_sigma,
        residual_coupling=lumped.coupling,
    )


def _band_edge_loss(plate: Plate, omega_band: float, fmax: float) -> float:
    """``sigma / omega`` (dimensionless) of the plate's damping law at the band limit
    ``omega_band`` (rad/s): the residual's lumped modes keep it above the band (a damping
    law fitted in the audio band is not extrapolated to the residual's frequencies)."""
    return float(_decay_rates(plate, np.array([omega_band]), fmax)[0]) / omega_band


def _decay_rates(plate: Plate, omega: np.ndarray, fmax: float) -> np.ndarray:
    """The plate's damping law's decay rates (1/s) at ``omega`` (rad/s), checked
    underdamped (the modal contact's oscillators must be)."""
    sigma = np.broadcast_to(
        np.asarray(plate.damping_law().decay_rate(omega), dtype=float), omega.shape
    ).copy()
    if np.any(sigma >= omega):
        k = int(np.argmax(sigma >= omega))
        raise ParameterError(
            f"plate.material.damping gives the mode at {omega[k] / (2 * np.pi):.6g} Hz a decay "
            f"rate {sigma[k]:.6g} 1/s at or above its angular frequency: the modal contact "
            f"needs underdamped modes up to max_frequency={fmax!r} Hz"
        )
    return sigma


# --------------------------------------------------------------------------------------
# The residual: the infinite plate's modes above the band
# --------------------------------------------------------------------------------------


def _mode_frequency(plate: Plate, s, theory: str):
    """Angular frequency (rad/s) of the plate's bending wave of ``k^2 = s`` (rad^2/m^2)."""
    if theory == "mindlin":
        return impedance.mindlin_angular_frequency(plate, s)
    return np.asarray(s, dtype=float) * math.sqrt(plate.flexural_rigidity / plate.surface_density)


def _coupling_density(plate: Plate, s, theory: str):
    """``dmu / ds`` (1/kg per rad^2/m^2): the couplings of the infinite plate's modes per
    unit ``s = k^2``, ``1 / (4 pi rho h m_f(s))`` (``S / (4 pi)`` modes per unit ``s``, each
    of coupling ``1 / (rho h S m_f)``, ``m_f`` :func:`impedance.mindlin_mass_factor`)."""
    base = 1.0 / (4.0 * math.pi * plate.surface_density)
    if theory != "mindlin":
        return base * np.ones_like(np.asarray(s, dtype=float))
    return base / impedance.mindlin_mass_factor(plate, s, _mode_frequency(plate, s, theory))


def _wavenumber_at(plate: Plate, omega: float, theory: str) -> float:
    """``s = k^2`` (rad^2/m^2) of the propagating bending wave at ``omega`` (rad/s)."""
    if theory == "mindlin":
        return float(impedance.mindlin_wavenumbers(plate, omega)[0])
    return omega * math.sqrt(plate.surface_density / plate.flexural_rigidity)


@dataclass(frozen=True)
class _LumpedResidual:
    """The residual's lumped modes (rad/s, 1/kg) and its tail (m/(N s), 1/s)."""

    omega: np.ndarray
    coupling: np.ndarray
    tail_admittance: float
    tail_rate: float


def _lumped_residual(plate: Plate, omega_band: float, theory: str) -> _LumpedResidual:
    """The residual above ``omega_band`` (rad/s) as :data:`RESIDUAL_BINS` lumped modes and a
    tail (module docstring): bin ``j`` spans ``[Omega r^j, Omega r^(j+1)]``; its coupling
    ``c_j = Int dmu`` and frequency ``w_j`` with ``c_j / w_j^2 = Int dmu / w^2`` keep the
    bin's stiffness (its response below the band) and its mass (above it)."""
    from scipy.integrate import quad

    edges = omega_band * RESIDUAL_RATIO ** np.arange(RESIDUAL_BINS + 1)
    s = [_wavenumber_at(plate, float(w), theory) for w in edges]
    omega, coupling = [], []
    for lo, hi in zip(s[:-1], s[1:], strict=True):
        c = quad(lambda x: float(_coupling_density(plate, x, theory)), lo, hi)[0]
        k = quad(
            lambda x: float(
                _coupling_density(plate, x, theory) / _mode_frequency(plate, x, theory) ** 2
            ),
            lo,
            hi,
        )[0]
        omega.append(math.sqrt(c / k))
        coupling.append(c)
    top = float(edges[-1])
    if theory == "mindlin":
        tail = float(impedance.mindlin_point_admittance(plate, top / (2.0 * math.pi)))
    else:
        tail = 1.0 / impedance.infinite_plate_impedance(plate)
    return _LumpedResidual(np.array(omega), np.array(coupling), tail, 0.5 * math.pi * top)


def residual_admittance_exact(
    plate: Plate, max_frequency: float, frequency, *, theory: str = "kirchhoff"
) -> np.ndarray:
    """The residual's admittance (m/(N s), complex, ``e^(i omega t)``) at ``frequency`` (Hz,
    below ``max_frequency``) from the wavenumber integral it lumps: ``i omega Int dmu /
    (w(s)^2 - omega^2 + 2 i sigma(w) omega)`` over the bins' span ``[Omega, W]`` (module
    docstring; ``sigma`` the plate's damping law) by adaptive quadrature, plus the tail
    above ``W``. The reference of :meth:`ModalPoint.residual`."""
    from scipy.integrate import quad

    fmax = checks.positive("max_frequency", max_frequency, "Hz")
    if theory not in PLATE_THEORIES:
        raise ParameterError(f"theory={theory!r} must be one of {PLATE_THEORIES}")
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if not np.all((f > 0.0) & (f < fmax)):
        raise ParameterError(f"frequency={frequency!r} must be in (0, max_frequency) (Hz)")
    omega_band = 2.0 * math.pi * fmax
    top = omega_band * RESIDUAL_RATIO**RESIDUAL_BINS
    lo, hi = _wavenumber_at(plate, omega_band, theory), _wavenumber_at(plate, top, theory)
    tail = _lumped_residual(plate, omega_band, theory)
    loss = _band_edge_loss(plate, omega_band, fmax)

    def term(x, w):
        wk = float(_mode_frequency(plate, x, theory))
        sigma = loss * wk
        return complex(_coupling_density(plate, x, theory)) / (wk * wk - w * w + 2j * sigma * w)

    out = []
    for w in 2.0 * math.pi * f:
        re = quad(lambda x, w=w: term(x, w).real, lo, hi, limit=200)[0]
        im = quad(lambda x, w=w: term(x, w).imag, lo, hi, limit=200)[0]
        s = 1j * w
        out.append(s * complex(re, im) + tail.tail_admittance * s / (s + tail.tail_rate))
    y = np.array(out)
    return y.reshape(np.shape(frequency)) if np.ndim(frequency) else y[0]


def _thin_frequency(plate: Plate, wavenumber_squared: float) -> float:
    """Kirchhoff's angular frequency (rad/s) of a wave of ``k^2`` (rad^2/m^2)."""
    return wavenumber_squared * math.sqrt(plate.flexural_rigidity / plate.surface_density)


# Eigen-solutions of exactly the contact's bands, held in memory (a few plates), and each
# point's modes on disk. The disk key holds everything the modes depend on; its version
# changes with the mode solver's algorithm.
_BAND_MODES = MemoryCache("solves", max_entries=8)
_POINT_VERSION = 1


def clear_memory_cache() -> None:
    """Forget the eigen-solutions held by :func:`band_modes` (the disk cache is untouched)."""
    _BAND_MODES.clear()


def _plate_key(plate: Plate, max_frequency: float) -> dict:
    """What the bending modes of ``plate`` to ``max_frequency`` (Hz) depend on."""
    m = plate.material
    return {
        "boundary": plate.boundary,
        "young": float(m.young).hex(),
        "density": float(m.density).hex(),
        "poisson": float(m.poisson).hex(),
        "thickness": float(plate.thickness).hex(),
        "length": float(plate.length).hex(),
        "width": float(plate.width).hex(),
        "max_frequency": float(max_frequency).hex(),
    }


def band_modes(plate: Plate, max_frequency: float):
    """The bending modes of ``plate`` up to ``max_frequency`` (Hz) from an eigen-solution of
    exactly that band: the mode cache's if it holds that band, else a solve of the band
    alone (:func:`synth.sound.modes.modes` with ``cache=False``) where the cache would serve
    a wider band's. Held in memory for the next contact on the plate."""
    from synth.sound.modes import modes as plate_modes

    key = json.dumps(_plate_key(plate, max_frequency), sort_keys=True)
    held = _BAND_MODES.get(key)
    if held is None:
        held = plate_modes(plate, max_frequency=max_frequency)
        if not held.solved_for_band:
            held = plate_modes(plate, max_frequency=max_frequency, cache=False)
        _BAND_MODES.put(key, held, source="computed")
    return held


def _point_modes(plate: Plate, position, max_frequency: float) -> tuple[np.ndarray, np.ndarray]:
    """Angular frequencies (rad/s) and couplings ``phi_k(x0)^2 / M_k`` (1/kg) of the modes of
    :func:`band_modes` at ``position``: from the disk cache, or computed and stored."""
    from synth.sound.modes import TOLERANCE

    key = json.dumps(
        dict(
            _plate_key(plate, max_frequency),
            x=float(position[0]).hex(),
            y=float(position[1]).hex(),
            version=_POINT_VERSION,
            tolerance=TOLERANCE,
        ),
        sort_keys=True,
    )
    try:
        path = cache_path("contact-point-modes", key)
    except RuntimeError:  # no home directory: no disk cache
        path = None
    stored = _load_point(path, key)
    if stored is not None:
        return stored
    m = band_modes(plate, max_frequency)
    phi = m.shapes(np.array([position], dtype=float))[0]
    omega = np.array(m.angular_frequencies, dtype=float)
    coupling = phi * phi / np.asarray(m.modal_masses, dtype=float)
    if path is not None:
        savez_atomic(path, {"key": np.array(key), "omega": omega, "coupling": coupling})
    return omega, coupling


def _load_point(path, key: str):
    """The stored ``(omega, coupling)`` of ``key`` at ``path``, or None if absent or not
    consistent (then recomputed)."""
    if path is None or not path.is_file():
        return None
    try:
        with load_npz(path) as z:
            if str(z["key"][()]) != key:
                return None
            omega, coupling = z["omega"], z["coupling"]
    except (OSError, ValueError, KeyError):
        return None
    ok = (
        omega.ndim == 1
        and coupling.shape == omega.shape
        and bool(np.all(np.isfinite(omega)) and np.all(np.isfinite(coupling)))
        and bool(np.all(omega > 0.0) and np.all(coupling >= 0.0))
    )
    return (omega, coupling) if ok else None


# --------------------------------------------------------------------------------------
# Impacts
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PlateRinging:
    """The plate's state under the ball: bending-mode displacements ``q`` (m) and velocities
    ``v`` (m/s) at the contact point (one per mode of the :class:`ModalPoint`), the
    residual's tail displacement ``x_res`` (m, downward), and its lumped modes'
    displacements ``q_res`` (m) and velocities ``v_res`` (m/s) (one per lumped mode). A
    plate at rest is all zeros."""

    q: np.ndarray
    v: np.ndarray
    x_res: float = 0.0
    q_res: np.ndarray = field(default_factory=lambda: np.zeros(0))
    v_res: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def displacement(self) -> float:
        """Displacement of the surface under the ball, m, positive upward."""
        return float(self.q.sum()) + float(self.q_res.sum()) - self.x_res

    @property
    def velocity(self) -> float:
        """Bending velocity of the surface under the ball (the band's and the residual's
        lumped modes), m/s, positive upward."""
        return float(self.v.sum()) + float(self.v_res.sum())


class _Pulse:
    """The solver's samples at its steps (trimmed to the contact): times (s), forces (N),
    penetrations ``delta`` (m) and their rates (m/s)."""

    def __init__(self, times, forces, gaps, rates, steps):
        self.times = times[: steps + 1].copy()
        self.forces = forces[: steps + 1].copy()
        self.gaps = gaps[: steps + 1].copy()
        self.rates = rates[: steps + 1].copy()


@dataclass(frozen=True, eq=False)
class ModalImpactResult(ImpactResult):
    """An :class:`~synth.physics.contact.ImpactResult` of the modal contact. The pulse between
    the solver's steps (``step_times``, s) is ``F = K delta^n (1 + mu delta')`` with ``delta``
    the cubic Hermite interpolant of the penetrations ``step_gaps`` (m) and their rates
    ``step_rates`` (m/s): smooth, and rising like ``t^n`` after first touch as the contact law
    does. ``contact_loss`` is the energy the Hunt-Crossley loss took, J.
    ``ringing`` is the plate's state at separation; ``restitution`` is the ball's upward speed
    at separation over its impact speed (what bounce times measure)."""

    step_times: np.ndarray | None = field(default=None, repr=False)
    step_forces: np.ndarray | None = field(default=None, repr=False)
    step_gaps: np.ndarray | None = field(default=None, repr=False)
    step_rates: np.ndarray | None = field(default=None, repr=False)
    law_stiffness: float = 0.0
    law_exponent: float = 1.5
    law_dissipation: float = 0.0
    contact_loss: float = 0.0
    ringing: PlateRinging | None = field(default=None, repr=False)
    plate_modal_energy: float = 0.0
    n_points: int = 128

    @property
    def exponent(self) -> float:
        return self.law_exponent

    def _sample_pulse(self):
        times = np.linspace(0.0, self.contact_time, self.n_points)
        forces = self.force_and_slope_at(times)[0]
        self.__dict__.update(time=times, force=forces)
        return times, forces

    def force_at(self, t):
        """Contact force (N) at times ``t`` (s from first touch); 0 outside the contact."""
        out = self.force_and_slope_at(np.atleast_1d(np.asarray(t, dtype=float)))[0]
        return out.reshape(np.shape(t)) if np.ndim(t) else float(out[0])

    def force_and_slope_at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Contact force (N) and its rate of change (N/s) at times ``t`` (s from first touch,
        a 1-D array); both 0 outside the contact."""
        tt = np.asarray(t, dtype=float).ravel()
        ts = self.step_times
        i = np.clip(np.searchsorted(ts, tt, side="right") - 1, 0, ts.size - 2)
        h = ts[i + 1] - ts[i]
        u = (tt - ts[i]) / h
        d0, d1 = self.step_gaps[i], self.step_gaps[i + 1]
        r0, r1 = self.step_rates[i] * h, self.step_rates[i + 1] * h
        u2, u3 = u * u, u * u * u
        delta = ((2 * u3 - 3 * u2 + 1) * d0 + (u3 - 2 * u2 + u) * r0 + (-2 * u3 + 3 * u2) * d1) + (
            u3 - u2
        ) * r1
        rate = ((6 * u2 - 6 * u) * d0 + (3 * u2 - 4 * u + 1) * r0 + (6 * u - 6 * u2) * d1) / h
        rate += (3 * u2 - 2 * u) * r1 / h
        inside = (tt >= 0.0) & (tt <= self.contact_time) & (delta > 0.0)
        dpos = np.where(inside, delta, 1.0)
        n, K, mu = self.law_exponent, self.law_stiffness, self.law_dissipation
        elastic = K * dpos**n
        elastic_slope = n * K * dpos ** (n - 1.0) * rate
        if mu == 0.0:
            return np.where(inside, elastic, 0.0), np.where(inside, elastic_slope, 0.0)
        # Hunt-Crossley: F = K delta^n (1 + mu delta'), F >= 0
        accel = ((12 * u - 6) * d0 + (6 * u - 4) * r0 + (6 - 12 * u) * d1 + (6 * u - 2) * r1) / (
            h * h
        )
        lossy = inside & (1.0 + mu * rate > 0.0)
        force = np.where(lossy, elastic * (1.0 + mu * rate), 0.0)
        slope = np.where(lossy, elastic_slope * (1.0 + mu * rate) + elastic * mu * accel, 0.0)
        return force, slope

    def pulse_samples(
        self, step: float, points: int, offset: float, period: float, samples: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and its rate (N/s) at ``j step`` (``j < points``) and then at ``offset +
        m period`` (``m < samples``), times in s from first touch."""
        t = np.concatenate((np.arange(points) * step, offset + np.arange(samples) * period))
        return self.force_and_slope_at(t)


@dataclass(frozen=True, eq=False)
class ModalContact:
    """Impacts of one ball on a finite plate at one point, the plate modelled by its modes
    (:class:`ModalPoint`) in the contact.

    Build with :meth:`for_pair`; :meth:`solve` gives one impact (from a plate at rest or
    ringing), :meth:`ring` the plate's free ringing between impacts.

    Attributes
    ----------
    point : ModalPoint
    mass, stiffness, exponent : float
        Ball mass ``m`` (kg), contact law ``F = K delta^n`` (``K`` in N/m^n, ``n``).
    gravity : float
        m/s^2.
    steps_per_contact : int
        Fixed steps over one impedance-model contact time.
    dissipation : float
        Hunt-Crossley loss ``mu`` of ``F = K delta^n (1 + mu delta')``, ``F >= 0``, s/m
        (0: elastic contact).
    """

    point: ModalPoint
    mass: float
    stiffness: float
    exponent: float
    gravity: float = GRAVITY
    steps_per_contact: int = STEPS_PER_CONTACT
    dissipation: float = 0.0

    def __post_init__(self):
        if not isinstance(self.point, ModalPoint):
            raise ParameterError(f"point={self.point!r} must be a ModalPoint")
        checked = dict(
            mass=checks.positive("mass", self.mass, "kg"),
            stiffness=checks.positive("stiffness", self.stiffness, "N/m^n"),
            exponent=checks.in_range(
                "exponent", self.exponent, 1.0, 4.0, "dimensionless", hi_open=False
            ),
            gravity=checks.nonnegative("gravity", self.gravity, "m/s^2"),
            dissipation=checks.nonnegative("dissipation", self.dissipation, "s/m"),
        )
        steps = self.steps_per_contact
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 16:
            raise ParameterError(
                f"steps_per_contact={steps!r} must be an integer >= 16 (steps per contact time)"
            )
        for key, value in checked.items():
            object.__setattr__(self, key, value)

    @classmethod
    def for_pair(
        cls,
        ball: Ball,
        plate: Plate,
        position: tuple[float, float] | None = None,
        *,
        gravity: float = GRAVITY,
        law: str = "hertz",
        max_frequency: float | None = None,
        steps_per_contact: int = STEPS_PER_CONTACT,
        speed: float | None = None,
        theory: str = "kirchhoff",
        **contact_options,
    ) -> ModalContact:
        """The modal contact of ``ball`` on ``plate`` at ``position`` (m; None: the centre)
        under the contact ``law`` and its options (:func:`synth.physics.contact.contact_law`).
        ``max_frequency`` (Hz) defaults to :data:`BAND_FACTOR` over the impedance model's
        contact time at ``speed`` (m/s; default 1 m/s); ``theory`` is the plate theory of
        :func:`modal_point`."""
        if not isinstance(ball, Ball):
            raise ParameterError(f"ball={ball!r} must be a Ball")
        if not isinstance(plate, Plate):
            raise ParameterError(f"plate={plate!r} must be a Plate")
        K, n, mu = contact_law(ball, plate, law, **contact_options)
        pos = plate.centre if position is None else position
        if max_frequency is None:
            v = 1.0 if speed is None else checks.positive("speed", speed, "m/s")
            tau = _impedance_contact(ball.mass, K, n, plate, v, mu).contact_time
            max_frequency = BAND_FACTOR / tau
        point = modal_point(plate, pos, max_frequency=max_frequency, theory=theory)
        return cls(point, ball.mass, K, n, gravity, steps_per_contact, mu)

    def at_rest(self) -> PlateRinging:
        """The plate at rest."""
        z = np.zeros(self.point.omega.size)
        zr = np.zeros(self.point.residual_omega.size)
        return PlateRinging(z, z.copy(), 0.0, zr, zr.copy())

    def ring(self, state: PlateRinging, duration: float) -> PlateRinging:
        """The plate's state after ringing freely for ``duration`` (s)."""
        d = checks.nonnegative("duration", duration, "s")
        p = self.point
        q, v = _joined(state.q, state.q_res), _joined(state.v, state.v_res)
        if d > 0.0:
            omega, sigma, _ = p.contact_modes
            _ring(omega, sigma, q, v, d)
        x = state.x_res * math.exp(-p.residual_rate * d)
        n = p.omega.size
        return PlateRinging(q[:n], v[:n], x, q[n:], v[n:])

    def energy(self, state: PlateRinging) -> float:
        """Energy of the bending modes and the residual's lumped modes in ``state`` (J):
        ``(v_k^2 + omega_k^2 q_k^2) / (2 c_k)`` summed, plus the residual's tail spring's
        ``a x_res^2 / (2 beta_W)``."""
        p = self.point
        omega, _, coupling = p.contact_modes
        q, v = _joined(state.q, state.q_res), _joined(state.v, state.v_res)
        modal = 0.5 * float(((v**2 + omega**2 * q**2) / coupling).sum())
        return modal + 0.5 * p.residual_rate / p.residual_admittance * state.x_res**2

    def solve(
        self, speed: float, state: PlateRinging | None = None, *, n_points: int = 128
    ) -> ModalImpactResult:
        """The impact at ``speed`` (m/s, the ball's downward speed at first touch) on the plate
        in ``state`` at that moment (None: at rest); ``n_points`` uniform samples of the
        pulse in ``time`` and ``force``."""
        v_in = checks.positive("speed", speed, "m/s")
        if isinstance(n_points, bool) or not isinstance(n_points, int) or n_points < 64:
            raise ParameterError(f"n_points={n_points!r} must be an integer >= 64")
        p = self.point
        state = self.at_rest() if state is None else state
        shapes = (state.q.shape, state.v.shape, state.q_res.shape, state.v_res.shape)
        if shapes != (p.omega.shape,) * 2 + (p.residual_omega.shape,) * 2:
            raise ParameterError(
                f"state has {state.q.size} modes and {state.q_res.size} lumped residual modes; "
                f"this contact has {p.omega.size} and {p.residual_omega.size} (one per mode)"
            )
        v_approach = v_in + state.velocity
        if not v_approach > 0.0:
            raise ParameterError(
                f"speed={speed!r}: the plate surface moves down faster ({-state.velocity!r} m/s) "
                f"than the ball; the ball cannot hit it"
            )
        ref = _impedance_contact(
            self.mass, self.stiffness, self.exponent, p.plate, v_approach, self.dissipation
        )
        h = ref.contact_time / self.steps_per_contact
        max_steps = int(SETTLE_FACTOR * self.steps_per_contact)
        q, v = _joined(state.q, state.q_res), _joined(state.v, state.v_res)
        x = np.array([state.x_res])
        omega, sigma, coupling = p.contact_modes
        forces = np.zeros(max_steps + 1)
        times = np.zeros(max_steps + 1)
        gaps = np.zeros(max_steps + 1)
        rates = np.zeros(max_steps + 1)
        e0 = self.energy(state)
        w0 = state.displacement
        r = _contact(
            omega,
            sigma,
            coupling,
            p.rigid_coupling,
            p.residual_admittance,
            p.residual_rate,
            q,
            v,
            x,
            self.mass,
            self.stiffness,
            self.exponent,
            self.dissipation,
            self.gravity,
            v_in,
            h,
            max_steps,
            forces,
            times,
            gaps,
            rates,
        )
        pulse = _Pulse(times, forces, gaps, rates, int(r[_R_STEPS]))
        return self._result(r, q, v, float(x[0]), v_in, e0, w0, pulse, ref, n_points)

    def _result(self, r, q, v, x, v_in, e0, w0, pulse, ref, n_points) -> ModalImpactResult:
        p = self.point
        m = self.mass
        steps = int(r[_R_STEPS])
        separated = int(r[_R_STATUS]) == _SEPARATED
        n = p.omega.size
        ringing = PlateRinging(q[:n], v[:n], x, q[n:], v[n:])
        e_plate = self.energy(ringing)
        rigid = 0.5 * r[_R_RIGID_V] ** 2 / p.rigid_coupling if p.rigid_coupling > 0.0 else 0.0
        v_out = float(r[_R_V])
        # ball energy in = ball energy out + plate energy gained + losses (gravity's work on
        # the ball from first touch included: m g times the height it lost)
        ball_in = 0.5 * m * v_in**2
        ball_out = 0.5 * m * v_out**2 + m * self.gravity * (float(r[_R_U]) - w0)
        plate = e_plate - e0 + rigid + r[_R_DAMPING_LOSS] + r[_R_DASHPOT_LOSS]
        plate += r[_R_CONTACT_LOSS]
        scale = max(ball_in, e0, abs(plate), 1e-300)
        residual = abs(ball_in - ball_out - plate) / scale
        e = v_out / v_in if separated and v_out > 0.0 else 0.0
        obj = ModalImpactResult(
            restitution=e,
            contact_time=float(r[_R_TIME]),
            max_penetration=float(r[_R_DMAX]),
            peak_force=float(r[_R_FMAX]),
            impulse=float(r[_R_IMPULSE]),
            inelasticity=ref.inelasticity,
            settled=not separated,
            rebound_speed=max(v_out, 0.0) if separated else 0.0,
            plate_energy=float(plate),
            energy_residual=float(residual),
            success=True,
            status=0 if separated else 1,
            message=(
                "The ball separated from the plate."
                if separated
                else (
                    f"The ball did not separate within {SETTLE_FACTOR:g} contact times of the "
                    f"impedance model: it rests on the plate."
                )
            ),
            n_steps=steps,
            method="modal",
            step_times=pulse.times,
            step_forces=pulse.forces,
            step_gaps=pulse.gaps,
            step_rates=pulse.rates,
            law_stiffness=self.stiffness,
            law_exponent=self.exponent,
            law_dissipation=self.dissipation,
            contact_loss=float(r[_R_CONTACT_LOSS]),
            ringing=ringing,
            plate_modal_energy=e_plate,
            n_points=n_points,
        )
        return obj


def next_touch(
    contact: ModalContact, state: PlateRinging, height: float, speed: float
) -> tuple[float, PlateRinging]:
    """The ball's next landing on the ringing plate: the first time ``s`` (s, from now) at
    which the ball, now at ``height`` (m, above the plate's rest position) moving up at
    ``speed`` (m/s), meets the plate surface (which rings from ``state``), and the plate's
    state then.

    The surface moves by at most ``W = |x_res| + sum_k sqrt(q_k^2 + (v_k / omega_k)^2)`` (the
    band's and the residual's lumped modes): the
    search runs over the part of the flight where the ball is within ``W`` of the rest
    position, in steps of an eighth of the shortest mode period, and bisects the first sign
    change of the gap to the time resolution of double precision."""
    p = contact.point
    g = contact.gravity
    if not g > 0.0:
        raise ParameterError("the ball lands again only with gravity > 0")
    omega = p.contact_modes[0]
    qs, vs = _joined(state.q, state.q_res), _joined(state.v, state.v_res)
    W = abs(state.x_res) + float(np.sqrt(qs**2 + (vs / omega) ** 2).sum())
    v = speed

    def ball(s):
        return height + v * s - 0.5 * g * s * s

    def gap(s):
        return ball(s) - contact.ring(state, s).displacement

    def when(level):  # the later time at which the ball passes ``level`` going down
        disc = v * v + 2.0 * g * (height - level)
        return (v + math.sqrt(max(disc, 0.0))) / g

    dt = 1.0 / (8.0 * p.max_frequency)
    s0 = when(W) if height + v * v / (2.0 * g) > W else dt
    hi = when(-W)
    while gap(s0) > 0.0 and s0 < hi:
        s1 = min(s0 + dt, hi)
        if gap(s1) <= 0.0:
            a, b = s0, s1
            for _ in range(200):
                mid = 0.5 * (a + b)
                if gap(mid) > 0.0:
                    a = mid
                else:
                    b = mid
                if b - a <= 4e-16 * b:
                    break
            return b, contact.ring(state, b)
        s0 = s1
    return s0, contact.ring(state, s0)


def _joined(band: np.ndarray, lumped: np.ndarray) -> np.ndarray:
    """A fresh float array of the band's modes' values followed by the lumped modes'."""
    return np.concatenate((np.asarray(band, dtype=float), np.asarray(lumped, dtype=float)))


def _impedance_contact(m, K, n, plate, v, mu) -> ImpactResult:
    """The impedance model's impact (the infinite plate; Hunt-Crossley loss ``mu``, s/m), for
    the time scale of the modal one."""
    return solve_contact(
        mass=float(m),
        stiffness=float(K),
        admittance=1.0 / impedance.infinite_plate_impedance(plate),
        speed=float(v),
        gravity=0.0,
        exponent=float(n),
        dissipation=float(mu),
        rtol=1e-6,
    )


def impedance_contact_time(
    ball: Ball, plate: Plate, speed: float, *, law: str = "hertz", **contact_options
) -> float:
    """The impedance model's contact time (s) of ``ball`` on ``plate`` at ``speed`` (m/s),
    without gravity, under the contact ``law`` and its options: the time scale from which
    :meth:`ModalContact.for_pair` sets its band (``BAND_FACTOR / tau``)."""
    K, n, mu = contact_law(ball, plate, law, **contact_options)
    v = checks.positive("speed", speed, "m/s")
    return _impedance_contact(ball.mass, K, n, plate, v, mu).contact_time
