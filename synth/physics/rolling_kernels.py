"""numba kernel of the rolling contact (private to :mod:`synth.physics.rolling`).

The equations (docs/rolling.md, "Rolling contact"): the ball's centre moves along the
path at the horizontal speed ``v`` (constant over each sample period), ``s' = v``; its
lowest point is at height ``y`` and the plate's surface under it at ``u`` (the impedance's
displacement, 0 for a rigid plate); ``z = y - u``. With the envelope ``e(s)``
(:func:`synth.physics.surface.contact_envelope`):

    delta = e(s) - z                     penetration, m
    w     = e'(s) v - v_y                approach rate with the plate held still, m/s
    F     = K force(delta, w, beta K, n, mu, (3/2) A)     contact force, N
    z'    = v_y + beta F
    v_y'  = F / m - g
    u'    = -beta F

``force`` is the impact solver's contact law (``contact_kernels.equations.force``, the
Hertz / Hunt-Crossley / viscoelastic law solved for the force with the plate's yield
``delta' = w - beta F``), called in SI units: with ``x = delta``, ``lam = beta K`` and the
losses ``c = mu``, ``b = (3/2) A`` it returns ``F / K`` and the elastic part ``delta^n``.
Quadratures carried with the state: the impulse of the current sample, the contact's loss
``Int (F - K delta^n) delta' dt``, the energy into the plate ``Int beta F^2 dt``, the work
of the horizontal drive ``Int F e'(s) v dt`` and its gross value ``Int |F e'(s) v| dt``.

Integrator: Dormand & Prince's embedded Runge-Kutta 5(4) pair (Dormand & Prince 1980,
J. Comput. Appl. Math. 6, 19; Hairer, Norsett & Wanner, "Solving ODEs I", II.5) with local
error control on ``delta`` and ``v_y`` (absolute ``rtol * delta_ref`` and ``rtol *
sqrt(g delta_ref)`` plus ``rtol`` times the values), steps ending on every sample boundary
(where the speed changes, the first stage is evaluated afresh with the new speed).

numba's cache (``cache=True``) keys these kernels on this file only: after editing
``contact_kernels/equations.py`` (the law) or ``surface.py`` (the envelope's spline),
clear ``synth/physics/__pycache__`` so that they compile again with the change.
"""

from __future__ import annotations

import math

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels import equations
from synth.physics.surface import envelope_at

#: The impact solver's contact law, the same compiled function as the impacts'.
force = equations.force

# Status codes.
OK = 0
MAX_STEPS = -1
STEP_TOO_SMALL = -2

# Components of the state.
Z, VY, U, IMPULSE, LOSS, PLATE, DRIVE, GROSS, S = range(9)
N_STATE = 9
#: The components :func:`rhs` reads: the intermediate stages compute only these (the
#: others are the plate's displacement and quadratures, which no derivative depends on).
STAGE_COMPONENTS = (Z, VY, S)

# Dormand-Prince 5(4) tableau.
C2, C3, C4, C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0,
    -355.0 / 33.0,
    46732.0 / 5247.0,
    49.0 / 176.0,
    -5103.0 / 18656.0,
)
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
)


@compiled(inline="always")
def rhs(y, out, env, dx, v, m, K, n, mu, b, beta, g):  # pragma: no cover - compiled
    """The right-hand side of the module docstring at the state ``y`` into ``out``; returns
    the penetration ``delta`` (m). Inlined into :func:`roll` (numba's ``inline="always"``:
    the same operations, so the same bits), where a call per stage cost as much as the
    equations."""
    e, ep, _ = envelope_at(env, dx, y[S])
    delta = e - y[Z]
    w = ep * v - y[VY]
    f, a = force(delta, w, beta * K, n, mu, b)
    F = K * f
    drive = F * ep * v
    out[Z] = y[VY] + beta * F
    out[VY] = F / m - g
    out[U] = -beta * F
    out[IMPULSE] = F
    out[LOSS] = K * (f - a) * (w - beta * F)
    out[PLATE] = beta * F * F
    out[DRIVE] = drive
    out[GROSS] = abs(drive)
    out[S] = v
    return delta


@compiled()
def penetration(y, env, dx):  # pragma: no cover - compiled
    """``delta = e(s) - z``, m."""
    e, _, _ = envelope_at(env, dx, y[S])
    return e - y[Z]


#: Rows of :func:`roll_into`'s workspace (the stages, the stage argument, the 5th-order end).
WORK_ROWS = 9


@compiled()
def roll(
    y,
    h,
    env,
    dx,
    speeds,
    m,
    K,
    n,
    mu,
    b,
    beta,
    g,
    samplerate,
    rtol,
    delta_ref,
    h_max,
    max_steps,
    force_out,
    min_penetration,
    path_out,
):  # pragma: no cover - compiled
    """Integrate from the state ``y`` (updated in place) with the first step ``h`` (s), steps
    of at most ``h_max`` (s), over
    ``speeds.size`` sample periods of ``1 / samplerate`` s, the horizontal speed ``speeds[j]``
    (m/s) in period ``j``; write each period's mean contact force (N), the smallest
    penetration at its steps' ends (m) and the path coordinate at its start (m).

    Every period is integrated from its own time 0 (the state and the step size carry
    over), so a rolling cut into consecutive calls at sample boundaries gives the bits of
    one call. Returns ``(status, steps, rejected, flights, h)``: ``flights`` counts the
    losses of contact seen at steps' ends; ``h`` is the next step size. The work of
    :func:`roll_into` in a workspace of its own."""
    work = np.empty((WORK_ROWS, N_STATE))
    return roll_into(
        y, h, env, dx, speeds, m, K, n, mu, b, beta, g, samplerate, rtol, delta_ref, h_max,
        max_steps, force_out, min_penetration, path_out, work,
    )  # fmt: skip


@compiled()
def roll_into(
    y,
    h,
    env,
    dx,
    speeds,
    m,
    K,
    n,
    mu,
    b,
    beta,
    g,
    samplerate,
    rtol,
    delta_ref,
    h_max,
    max_steps,
    force_out,
    min_penetration,
    path_out,
    work,
):  # pragma: no cover - compiled
    """:func:`roll` in the caller's workspace ``work`` (float64, ``(WORK_ROWS, N_STATE)``):
    it allocates nothing, so the live engine's audio thread runs it (the same code, so the
    same bits as :func:`roll`)."""
    n_samples = force_out.shape[0]
    period = 1.0 / samplerate
    atol_z = rtol * delta_ref
    atol_v = rtol * math.sqrt(g * delta_ref)
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    k5 = work[4]
    k6 = work[5]
    k7 = work[6]
    tmp = work[7]
    y5 = work[8]
    steps = 0
    rejected = 0
    flights = 0
    d_prev = penetration(y, env, dx)
    v = 0.0
    for j in range(n_samples):
        # the first stage: that of the last step's end (the same bits) unless the speed changed
        if j == 0 or speeds[j] != v:
            v = speeds[j]
            rhs(y, k1, env, dx, v, m, K, n, mu, b, beta, g)
        path_out[j] = y[S]
        y[IMPULSE] = 0.0
        d_min = d_prev
        t = 0.0
        while t < period:
            remaining = period - t
            if h > h_max:
                h = h_max
            last = h >= remaining
            hh = remaining if last else h
            if hh <= 1e-12 * period:
                return STEP_TOO_SMALL, steps, rejected, flights, h
            for i in STAGE_COMPONENTS:
                tmp[i] = y[i] + hh * A21 * k1[i]
            rhs(tmp, k2, env, dx, v, m, K, n, mu, b, beta, g)
            for i in STAGE_COMPONENTS:
                tmp[i] = y[i] + hh * (A31 * k1[i] + A32 * k2[i])
            rhs(tmp, k3, env, dx, v, m, K, n, mu, b, beta, g)
            for i in STAGE_COMPONENTS:
                tmp[i] = y[i] + hh * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i])
            rhs(tmp, k4, env, dx, v, m, K, n, mu, b, beta, g)
            for i in STAGE_COMPONENTS:
                tmp[i] = y[i] + hh * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
            rhs(tmp, k5, env, dx, v, m, K, n, mu, b, beta, g)
            for i in STAGE_COMPONENTS:
                tmp[i] = y[i] + hh * (
                    A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]
                )
            rhs(tmp, k6, env, dx, v, m, K, n, mu, b, beta, g)
            for i in range(N_STATE):
                y5[i] = y[i] + hh * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i])
            d_new = rhs(y5, k7, env, dx, v, m, K, n, mu, b, beta, g)
            err_z = hh * (
                E1 * k1[Z] + E3 * k3[Z] + E4 * k4[Z] + E5 * k5[Z] + E6 * k6[Z] + E7 * k7[Z]
            )
            err_v = hh * (
                E1 * k1[VY] + E3 * k3[VY] + E4 * k4[VY] + E5 * k5[VY] + E6 * k6[VY] + E7 * k7[VY]
            )
            sc_z = atol_z + rtol * max(abs(d_prev), abs(d_new))
            sc_v = atol_v + rtol * max(abs(y[VY]), abs(y5[VY]))
            err = max(abs(err_z) / sc_z, abs(err_v) / sc_v)
            steps += 1
            if steps > max_steps:
                return MAX_STEPS, steps, rejected, flights, h
            if err <= 1.0:
                t = period if last else t + hh
                for i in range(N_STATE):
                    y[i] = y5[i]
                    k1[i] = k7[i]
                if d_new <= 0.0 < d_prev:
                    flights += 1
                d_prev = d_new
                if d_new < d_min:
                    d_min = d_new
                factor = 5.0 if err == 0.0 else min(5.0, 0.9 * err**-0.2)
                proposed = hh * factor
                # a step cut short by the sample boundary does not shrink the next one
                h = max(proposed, h) if last else proposed
            else:
                rejected += 1
                h = hh * max(0.2, 0.9 * err**-0.2)
        force_out[j] = y[IMPULSE] * samplerate
        min_penetration[j] = d_min
    return OK, steps, rejected, flights, h
