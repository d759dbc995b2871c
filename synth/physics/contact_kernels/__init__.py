"""numba kernels and drivers of the contact solver (docs/physics.md, "Hertz contact"); DOP853
and Radau IIA after Hairer, Norsett & Wanner, "Solving ODEs I" II.10 and "II" IV.8.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from synth.compilation import announce, compiled
from synth.physics.contact_kernels import dense as _d
from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels.dop853 import integrate_dop853
from synth.physics.contact_kernels.radau import integrate_radau
from synth.physics.contact_kernels.series import new_series, series_coefficients, series_start

# Constants of the compiled ``impact``, not arguments (each argument costs dispatch time).
#: Zener's inelasticity above which Radau IIA integrates instead of DOP853 (stiffness ~ lam^(5/3)).
STIFF_LAMBDA = 20.0
#: Absolute tolerance of the order-one dimensionless state relative to ``rtol``: keeps the
#: control relative down to 1e-6 (small restitutions, long inelastic tails).
ABSOLUTE_FACTOR = 1e-6
#: Steps before DOP853 gives up and the implicit method takes over.
EXPLICIT_STEP_LIMIT = 20_000
#: Steps before the implicit method reports failure.
IMPLICIT_STEP_LIMIT = 200_000

#: Columns past the result array: an impact's start (s) and speed (m/s).
R_T1 = _eq.N_RESULT
R_V1 = _eq.N_RESULT + 1

# Integrator choice of ``impact``.
AUTO = 0
DOP853 = 1
RADAU = 2


#: Lumped parameters of an impact: mass ``m`` (kg), stiffness ``K`` (N/m^n), exponent ``n``,
#: admittance ``beta`` (m/(N s)), ``g`` (m/s^2), Hunt-Crossley ``mu`` (s/m), viscous time
#: ``A`` (s), yield penetration ``delta_y`` (m; inf: none), surface velocity ``v_free`` (m/s,
#: upward).
Lumped = namedtuple("Lumped", ("m", "K", "n", "beta", "g", "mu", "A", "delta_y", "v_free"))
#: Bounce rules: lowest kinetic energy relative to the first's, end ``t_max`` (s), most impacts;
#: hand-over at a contact time ``tau_edge`` (s) or an energy residual above ``residual_limit``.
Rules = namedtuple("Rules", ("energy_floor", "t_max", "max_impacts", "tau_edge", "residual_limit"))


@compiled(inline="always")
def solve(P, rtol, atol, max_steps, integrate, radau):
    """One contact of the law ``P`` by ``integrate`` (DOP853 or Radau IIA; a kernel compiles
    only the one it is passed), started from the series; its :func:`finish`."""
    S = new_series(P.b)
    # the series ends before the yield penetration xy (x <= (1 + G) s)
    s_max = P.xy / (1.0 + P.G)
    s1, x1, w1, i2, loss = series_start(P, rtol, S, s_max)
    # zeros, not empty: unused columns would otherwise differ between processes
    hist = np.zeros((32, _d.H_COLS))
    hist[0, _d.H_H] = s1
    hist[0, _d.H_W0] = 1.0
    out = integrate(P, rtol, atol, max_steps, hist, s1, x1, w1, i2, loss, s1)
    return finish(out, _d.Dense(out.hist, S, radau, P))


@compiled(inline="always")
def finish(out, D):
    """End of contact, peak penetration and force of the integration ``out`` (its
    :data:`~.equations.Integration`) with dense output ``D``; ``s_force`` is the force
    pulse's end (:func:`force_end`)."""
    status, s_end, x_end, w_end, nh = out.status, out.s, out.x, out.w, out.nh
    P = D.P
    s_contact = s_end
    if status == _eq.SEPARATED:
        # f = 0 for x <= 0, so I2 and the loss need no correction past the root.
        s_end = _d.event_root(D, nh - 1, _d.END_OF_CONTACT, 0.0)
        w_end = _d.dense_state(D, nh - 1, s_end)[1]
        x_end = 0.0
        s_contact = s_end
    elif status == _eq.SETTLED:
        s_contact = _d.event_root(D, nh - 1, _d.SETTLING, 0.5 * (P.lam * P.G) ** 2)
    s_force = s_contact
    if status == _eq.SEPARATED and (P.c != 0.0 or P.b != 0.0 or P.xy != math.inf):
        s_force = min(force_end(D, nh), s_contact)
    x_max = peak_penetration(D, nh)
    f_max = peak_force(D, nh, x_max, s_contact)
    end = _eq.End(
        status, s_contact, s_force, s_end, w_end, x_end, out.i2, out.loss, x_max, f_max, nh - 1
    )
    return end, out.hist[:nh]


@compiled()
def peak_penetration(D, nh):
    """Largest penetration of dense output ``D``, refined where ``x' = w - lam f`` changes sign."""
    hist = D.hist
    ibest = 0
    for k in range(nh):
        if hist[k, _d.H_X0] > hist[ibest, _d.H_X0]:
            ibest = k
    x_max = hist[ibest, _d.H_X0]
    for k in range(max(ibest - 1, 0), ibest + 1):
        xm = hist[k, _d.H_XM]
        xe, we = _d.dense_state(D, k, hist[k, _d.H_T0] + hist[k, _d.H_H])
        rising = _eq.penetration_rate(D.P, hist[k, _d.H_X0], hist[k, _d.H_W0], xm) > 0.0
        if rising and _eq.penetration_rate(D.P, xe, we, xm) <= 0.0:
            xr, _ = _d.dense_state(D, k, _d.event_root(D, k, _d.PEAK_PENETRATION, 0.0))
            x_max = max(x_max, xr)
    return x_max


@compiled()
def peak_force(D, nh, x_max, s_contact):
    """Largest force of ``D``: elastic at ``x_max`` without a loss, else golden-section search."""
    P = D.P
    if P.c == 0.0 and P.b == 0.0:
        return _eq.elastic_terms(x_max, P.n, 0.0, P.xy, 0.0)[0] if x_max > 0.0 else 0.0
    hist = D.hist
    ibest = 0
    vbest = -1.0
    for k in range(nh):
        fk, _ = _eq.law_force(P, hist[k, _d.H_X0], hist[k, _d.H_W0], hist[k, _d.H_XM])
        if fk > vbest:
            vbest = fk
            ibest = k
    lo = hist[max(ibest - 1, 0), _d.H_T0]
    j = min(ibest + 1, nh - 1)
    hi = min(hist[j, _d.H_T0] + hist[j, _d.H_H], s_contact)
    return max(_d.golden_max(D, nh, lo, hi, 1), vbest)


@compiled()
def force_end(D, nh):
    """End of a lossy contact's force pulse (dimensionless): the force reaches 0 before the
    penetration does. The step index is an int64 so that ``event_root`` compiles once."""
    hist = D.hist
    k = nh - 1
    while k > 0:
        if _eq.law_force(D.P, hist[k, _d.H_X0], hist[k, _d.H_W0], hist[k, _d.H_XM])[0] > 0.0:
            break
        k -= 1
    return _d.event_root(D, k, _d.FORCE_END, 0.0)


#: How a bounce series ends (:data:`synth.physics.bounces.STOP_REASONS`), plus
#: ``"handed-over"``: stopped before an impact the caller solves (Radau IIA, or an edge).
BOUNCE_ENDS = (
    "settled", "flight-shorter-than-contact", "floor", "max-duration", "max-impacts",
    "solver-failure", "handed-over",
)  # fmt: skip
#: :func:`bounce_end`'s code while the series goes on; the index of each end.
NO_END = -1
(
    END_SETTLED, END_FLIGHT, END_FLOOR, END_MAX_DURATION, END_MAX_IMPACTS, END_SOLVER_FAILURE,
    END_HANDED_OVER,
) = range(len(BOUNCE_ENDS))  # fmt: skip


@compiled()
def bounce_end(t, v1, g, success, settled, restitution, v_out, separation, energy_floor, t_max):
    """The bounce rules after an impact started at ``t`` (s): ``(end, t_next)``, an index of
    :data:`BOUNCE_ENDS` or :data:`NO_END` and the next start (s). Speeds ``v1``, ``v_out``
    m/s, ``g`` m/s^2, ``separation`` s, ``energy_floor`` relative to the first, ``t_max`` s."""
    if not success:
        return END_SOLVER_FAILURE, t
    if settled or restitution <= 0.0:
        return END_SETTLED, t
    # without gravity the ball does not come back: the next impact never starts
    flight = 2.0 * v_out / g if g > 0.0 else math.inf
    if flight < separation:
        return END_FLIGHT, t
    if (v_out / v1) ** 2 < energy_floor:
        return END_FLOOR, t
    t_next = t + separation + flight
    if t_next > t_max:
        return END_MAX_DURATION, t
    return NO_END, t_next


@compiled(inline="always")
def _copy_rows(source, start, stop, target, at):
    """Rows ``start:stop`` of ``source`` into ``target`` from row ``at`` on."""
    for i in range(stop - start):
        for j in range(source.shape[1]):
            target[at + i, j] = source[start + i, j]


@compiled(inline="always")
def _grown(results, rows, used, size):
    """Copies of the series' arrays for ``size`` impacts, the first ``used`` kept."""
    grown = np.empty((size, results.shape[1]))
    _copy_rows(results, 0, used, grown, 0)
    r = np.zeros(size + 1, dtype=np.int64)
    for i in range(used + 1):
        r[i] = rows[i]
    return grown, r


@compiled()
def impacts_explicit(L, rtol, auto, v1, t1, rules):
    """The impacts of a drop of ``L`` by DOP853 under ``rules``, in one compiled call; the
    first at ``v1`` (m/s) at ``t1`` (s). Hands over (``END_HANDED_OVER``) before an impact
    needing Radau IIA or reaching ``rules.tau_edge`` (s). Returns ``(count, end, t, v,
    results, hists, rows)``; impact ``i``'s dense output is ``hists[rows[i]:rows[i + 1]]``."""
    max_impacts = rules.max_impacts
    # grown by doubling: max_impacts rows would hold megabytes for a few impacts
    capacity = min(max_impacts, 64)
    results = np.empty((capacity, R_V1 + 1))
    rows = np.zeros(capacity + 1, dtype=np.int64)
    hists = np.empty((64, _d.H_COLS))
    count = 0
    end = END_MAX_IMPACTS
    t = t1
    v = v1
    while count < max_impacts:
        P, sc = scales(L, v)
        if auto and P.lam > STIFF_LAMBDA:
            end = END_HANDED_OVER
            break
        e, hist = solve(
            P, rtol, rtol * ABSOLUTE_FACTOR, EXPLICIT_STEP_LIMIT, integrate_dop853, _d.DOP853_STEPS
        )
        if auto and e.status == _eq.MAX_STEPS:
            end = END_HANDED_OVER
            break
        r = result(e, P, sc, _d.DOP853_STEPS)
        status = r[_eq.R_STATUS]
        success = status >= 0.0 and r[_eq.R_ENERGY_RESIDUAL] <= rules.residual_limit
        if success and r[_eq.R_CONTACT_TIME] >= rules.tau_edge:
            end = END_HANDED_OVER
            break
        if count == results.shape[0]:
            capacity = min(2 * capacity, max_impacts)
            results, rows = _grown(results, rows, count, capacity)
        # element by element: a slice assignment compiles numba's shape-error path (seconds)
        first = rows[count]
        top = first + hist.shape[0]
        if top > hists.shape[0]:
            grown = np.empty((2 * top, _d.H_COLS))
            _copy_rows(hists, 0, first, grown, 0)
            hists = grown
        _copy_rows(hist, 0, hist.shape[0], hists, first)
        rows[count + 1] = top
        for j in range(_eq.N_RESULT):
            results[count, j] = r[j]
        results[count, R_T1] = t
        results[count, R_V1] = v
        count += 1
        v_out = r[_eq.R_REBOUND_SPEED]
        code, t = bounce_end(
            t, v1, L.g, success, success and status == _eq.SETTLED, r[_eq.R_RESTITUTION], v_out,
            r[_eq.R_SEPARATION_TIME], rules.energy_floor, rules.t_max,
        )  # fmt: skip
        if code != NO_END:
            end = code
            break
        v = v_out
    return count, end, t, v, results[:count], hists[: rows[count]], rows


#: The rules of a single impact (:func:`impact`).
ONE_IMPACT = Rules(0.0, math.inf, 1, math.inf, math.inf)


def impact(L, v_in, rtol, method):
    """One impact of ``L`` at ``v_in`` (m/s), scaled by Zener's time ``theta`` and length
    ``theta v0`` (``v0 = v_in + v_free``), by DOP853 or Radau IIA (``method``; AUTO takes
    Radau above ``STIFF_LAMBDA`` or after ``EXPLICIT_STEP_LIMIT`` steps) to ``rtol``.
    Returns ``(result, hist)``."""
    if method != RADAU:
        announce("contact")
        count, _, _, _, results, hists, _ = impacts_explicit(
            L, rtol, method == AUTO, v_in, 0.0, ONE_IMPACT
        )
        if count:
            return results[0, : _eq.N_RESULT], hists
    announce("stiff-contact")
    return impact_implicit(L, v_in, rtol)


@compiled(inline="always")
def scales(L, v_in):
    """The law and scales of an impact of ``L`` at ``v_in`` (m/s)."""
    v0 = v_in + L.v_free
    theta = (L.m / (L.K * v0 ** (L.n - 1.0))) ** (1.0 / (L.n + 1.0))
    lam = L.beta * L.m / theta
    G = L.g * theta / v0
    xy = scaled_yield(L.delta_y, L, v0, theta)
    P = _eq.Law(lam, G, L.n, L.mu * v0, 1.5 * L.A / theta, xy)
    return P, _eq.Scales(L.m, v_in, v0, theta, lam, G, L.m * v0 / theta)


@compiled()
def scaled_yield(delta_y, L, v0, theta):
    """Yield penetration over ``theta v0``, inf without a yield or where it is out of reach:
    a float either way, so that the kernels compile once (the yield's tests cost little)."""
    if delta_y == math.inf or not yield_reachable(delta_y, L.K, L.m, L.g, L.beta, v0):
        return math.inf
    return delta_y / (theta * v0)


@compiled()
def yield_reachable(delta_y, K, m, g, beta, v0):
    """Whether a Hertz contact (``K`` N/m^1.5, ``m`` kg, ``g`` m/s^2, ``beta`` m/(N s)) at
    ``v0`` (m/s) can reach ``delta_y`` (m): the settling function never increases, so
    ``(2/5) K delta^(5/2) - m g delta <= m (v0 - beta m g)^2 / 2``."""
    if not delta_y > (m * g / K) ** (2.0 / 3.0):
        return True
    left = 0.4 * K * delta_y * delta_y * math.sqrt(delta_y) - m * g * delta_y
    return left <= 0.5 * m * (v0 - beta * m * g) ** 2


@compiled()
def impact_implicit(L, v_in, rtol):
    """``impact`` by Radau IIA."""
    P, sc = scales(L, v_in)
    atol = rtol * ABSOLUTE_FACTOR
    e, hist = solve(P, rtol, atol, IMPLICIT_STEP_LIMIT, integrate_radau, _d.RADAU_STEPS)
    return result(e, P, sc, _d.RADAU_STEPS), hist


@compiled(inline="always")
def result(e, P, sc, stiff):
    """The result array of ``impact`` from :func:`finish`'s end ``e`` (yield: unloading energy)."""
    xy = P.xy
    r = _eq.impact_row(e, _eq.potential(e.x_end, P.n, xy, e.x_max if e.x_max > xy else 0.0), sc)
    r[_eq.R_STIFF] = 1.0 if stiff else 0.0
    r[_eq.R_C] = P.c
    r[_eq.R_B] = P.b
    r[_eq.R_XY] = xy
    return r


@compiled()
def pulse_force_slope(d, step, points, offset, period, samples, out):
    """Force (N) and rate (N/s) into ``out`` at times ``j step`` (s, ``j < points``), then
    ``offset + m period`` (s, ``m < samples``), in one call (a pulse per impact)."""
    total = points + samples
    s = np.empty(total)
    for j in range(points):
        s[j] = j * step / d.theta
    for m in range(samples):
        s[points + m] = (offset + m * period) / d.theta
    forces = out[0, :total]
    slopes = out[1, :total]
    force_slope_at(d, s, forces, slopes)
    rate = d.f_scale / d.theta
    for i in range(total):
        forces[i] *= d.f_scale
        slopes[i] *= rate


@compiled()
def force_slope_at(d, s, out, slope):
    """Dimensionless force at times ``s`` from dense output ``d``, 0 outside ``(0,
    s_contact]``, into ``out``; its rate ``f_x x' + f_w w'`` into ``slope``."""
    P = d.law
    S = new_series(P.b)
    series_coefficients(P, S)
    D = _d.Dense(d.hist, S, d.radau, P)
    nh = d.hist.shape[0]
    for i in range(s.shape[0]):
        si = s[i]
        if si <= 0.0 or si > d.s_contact:
            out[i] = 0.0
            slope[i] = 0.0
            continue
        k = _d.find_step(d.hist, nh, si)
        x, w = _d.dense_state(D, k, si)
        xm = d.hist[k, _d.H_XM]
        f = _eq.law_force(P, x, w, xm)[0]
        out[i] = f
        if x <= 0.0 or f <= 0.0:
            slope[i] = 0.0
            continue
        _, _, fx, fw = _eq.jacobian(P, x, w, xm)  # -f_x, -f_w
        slope[i] = -(fx * (w - P.lam * f) + fw * (P.G - f))
