"""numba kernels of the rolling contact (docs/rolling.md, "Rolling contact"): Dormand & Prince's
RK5(4) with steps ending on every sample boundary; a flight is a parabola in closed form."""

from __future__ import annotations

import math
from typing import NamedTuple

from synth.compilation import compiled
from synth.physics.contact_kernels import equations
from synth.physics.contact_kernels.shell import DP5_A, DP5_E
from synth.physics.surface import envelope_at, spline_piece

#: The impact solver's contact law, the same compiled function as the impacts'.
force = equations.force


class Constants(NamedTuple):
    """A rolling's constants: mass ``m`` (kg), the law's ``K``, ``n``, ``mu`` and ``b = (3/2)
    A`` (s), admittance ``beta`` (m/(N s)), ``g`` (m/s^2), ``samplerate`` (Hz), ``rtol``, the
    static penetration ``delta_ref`` (m) and the largest step ``h_max`` (s)."""

    m: float
    K: float
    n: float
    mu: float
    b: float
    beta: float
    g: float
    samplerate: float
    rtol: float
    delta_ref: float
    h_max: float


class Drive(NamedTuple):
    """A path's rolling: ``decel`` (m/s^2), periods per ``block``, ``x_end`` (m),
    ``kinetic_mass`` (kg: kinetic energy over ``v^2``), rolling resistance (N)."""

    decel: float
    block: int
    x_end: float
    kinetic_mass: float
    resistance_force: float


#: Most integration steps per sample period before the offline solver gives up.
MAX_STEPS_PER_SAMPLE = 2000

# Status codes.
OK = 0
MAX_STEPS = -1
STEP_TOO_SMALL = -2

# Components of the state.
Z, VY, U, IMPULSE, LOSS, PLATE, DRIVE, GROSS, S = range(9)
N_STATE = 9

# Dormand-Prince 5(4) tableau, the shell contact's (the equations are autonomous: no stage times).
A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62, A63, A64, A65 = (
    float(DP5_A[i, j]) for i in range(1, 6) for j in range(i)
)
B1, _, B3, B4, B5, B6 = (float(b) for b in DP5_A[6])
E1, _, E3, E4, E5, E6, E7 = (float(e) for e in DP5_E)
#: Error over tolerance below which the step grows by the largest factor, 5 (``(0.9/5)^5``).
TINY_ERROR = 1e-4


@compiled(inline="always")
def rates(z, vy, s, env, dx, v, c):  # pragma: no cover - compiled
    """Right-hand side at height ``z`` (m), speed ``vy`` (m/s), path coordinate ``s`` (m):
    ``(z', vy', u', impulse', loss', plate', drive', gross', delta)``, delta in m."""
    e, ep, _ = envelope_at(env, dx, s)
    delta = e - z
    w = ep * v - vy
    K, beta = c.K, c.beta
    # no yield: an infinite yield penetration, as the impacts' kernels take it (one compile)
    f, a = force(delta, w, beta * K, c.n, c.mu, c.b, math.inf, 0.0)
    F = K * f
    drive = F * ep * v
    return (
        vy + beta * F,
        F / c.m - c.g,
        -beta * F,
        F,
        K * (f - a) * (w - beta * F),
        beta * F * F,
        drive,
        abs(drive),
        delta,
    )


@compiled(inline="always")
def step5(y, h, k1, k3, k4, k5, k6):  # pragma: no cover - compiled
    """A component's fifth-order solution ``y + h sum_i B_i k_i``."""
    return y + h * (B1 * k1 + B3 * k3 + B4 * k4 + B5 * k5 + B6 * k6)


@compiled(inline="always")
def error4(h, k1, k3, k4, k5, k6, k7):  # pragma: no cover - compiled
    """One component's error estimate, the fifth- less the fourth-order solution."""
    return h * (E1 * k1 + E3 * k3 + E4 * k4 + E5 * k5 + E6 * k6 + E7 * k7)


@compiled(inline="always")
def control(hh, err_z, err_v, sc_z, sc_v, grow, h_max):  # pragma: no cover - compiled
    """Step error over tolerance and the next step (s) after ``hh`` (Hairer, Norsett & Wanner
    II.4); 0 when the largest step ``min(5 hh, h_max)`` applies."""
    r = hh * grow
    reach = max(r * r * r * r * r, TINY_ERROR)
    if abs(err_z) <= reach * sc_z and abs(err_v) <= reach * sc_v:
        return 0.0, min(5.0 * hh, h_max)
    err = max(abs(err_z) / sc_z, abs(err_v) / sc_v)
    if err > 1.0:
        return err, hh * max(0.2, 0.9 * err**-0.2)
    return err, hh * (5.0 if err == 0.0 else min(5.0, 0.9 * err**-0.2))


@compiled()
def first_contact(p0, p1, p2, p3, a, b, tol):  # pragma: no cover - compiled
    """First time in ``(a, b]`` (s) where the cubic penetration ``P(t)`` (m) reaches 0, given
    ``P(a) < 0``, within ``tol`` (s) before it; -1.0 if none."""
    # the critical points: roots of 3 p3 t^2 + 2 p2 t + p1
    c1 = c2 = b
    qa, qb = 3.0 * p3, 2.0 * p2
    if qa != 0.0:
        disc = qb * qb - 4.0 * qa * p1
        if disc > 0.0:
            r = math.sqrt(disc)
            t1, t2 = (-qb - r) / (2.0 * qa), (-qb + r) / (2.0 * qa)
            if t1 > t2:
                t1, t2 = t2, t1
            if a < t1 < b:
                c1 = t1
            if a < t2 < b:
                c2 = t2
    elif qb != 0.0:
        t1 = -p1 / qb
        if a < t1 < b:
            c1 = t1
    lo = a
    for hi in (c1, c2, b):
        if ((p3 * hi + p2) * hi + p1) * hi + p0 >= 0.0:
            while hi - lo > tol:
                mid = 0.5 * (lo + hi)
                if ((p3 * mid + p2) * mid + p1) * mid + p0 >= 0.0:
                    hi = mid
                else:
                    lo = mid
            return lo
        lo = hi
    return -1.0


@compiled()
def flight(env, dx, s, z, vy, v, g, span, tol):  # pragma: no cover - compiled
    """The parabolic flight from ``s`` (m), ``z`` (m), ``vy`` (m/s) at ``v`` (m/s) under ``g``
    (m/s^2): its duration (s), to the first contact or ``span`` (s), and whether it lands. A
    piece is skipped when below its chord's larger end plus ``max |P''| L^2 / 8``."""
    n = env.shape[0]
    i = spline_piece(n, dx, s)
    a = 0.0
    while True:
        b = span
        if v > 0.0 and i < n - 1:
            b = min(span, ((i + 1) * dx - s) / v)
        if b > a:
            # the penetration over this piece as a cubic in t (about t = 0)
            c0, c1, c2, c3 = env[i, 0], env[i, 1], env[i, 2], env[i, 3]
            o = s - i * dx  # the piece's local coordinate at t = 0
            p0 = ((c0 * o + c1) * o + c2) * o + c3 - z
            p1 = ((3.0 * c0 * o + 2.0 * c1) * o + c2) * v - vy
            p2 = (3.0 * c0 * o + c1) * v * v + 0.5 * g
            p3 = c0 * v * v * v
            pa = ((p3 * a + p2) * a + p1) * a + p0
            pb = ((p3 * b + p2) * b + p1) * b + p0
            curve = max(abs(2.0 * p2 + 6.0 * p3 * a), abs(2.0 * p2 + 6.0 * p3 * b))
            if max(pa, pb) + 0.125 * curve * (b - a) * (b - a) >= 0.0:
                t = first_contact(p0, p1, p2, p3, a, b, tol)
                if t >= 0.0:
                    # no step shorter than the root's tolerance to the period's end
                    return (span if span - t <= tol else t), True
        if b >= span:
            return span, False
        a = b
        i += 1


@compiled(inline="always")
def _store(y, z, vy, u, imp, loss, plate, drive, gross, s):  # pragma: no cover - compiled
    """The integrator's scalars back into the state ``y``."""
    y[Z], y[VY], y[U], y[IMPULSE], y[S] = z, vy, u, imp, s
    y[LOSS], y[PLATE], y[DRIVE], y[GROSS] = loss, plate, drive, gross


@compiled()
def roll(
    y, h, env, dx, speeds, c, max_steps, force_out, min_penetration, path_out
):  # pragma: no cover - compiled
    """Integrate from ``y`` (in place) with first step ``h`` (s) over periods of ``1 / samplerate``
    s at ``speeds`` (m/s), writing each period's mean force (N), least penetration (m) and start
    coordinate (m). Each period starts at its own time 0, so a rolling cut at sample boundaries
    gives the bits of one call. Returns ``(status, steps, rejected, flights, h)``."""
    g, samplerate, rtol, delta_ref, h_max = c.g, c.samplerate, c.rtol, c.delta_ref, c.h_max
    n_samples = force_out.shape[0]
    period = 1.0 / samplerate
    atol_z = rtol * delta_ref
    atol_v = rtol * math.sqrt(g * delta_ref)
    z, vy, u, imp = y[Z], y[VY], y[U], y[IMPULSE]
    loss, plate, drive, gross, s = y[LOSS], y[PLATE], y[DRIVE], y[GROSS], y[S]
    steps = 0
    rejected = 0
    flights = 0
    e0, _, _ = envelope_at(env, dx, s)
    d_prev = e0 - z
    v = 0.0
    # a flight ends this close before its landing (s)
    root_tol = 1e-6 * period
    grow = 0.9 / h_max
    # the first stage (k1), carried from a step's last stage (k7) to the next step
    z1 = v1 = u1 = i1 = l1 = p1 = d1 = g1 = 0.0
    for j in range(n_samples):
        # the first stage: that of the last step's end (the same bits) unless the speed changed
        if j == 0 or speeds[j] != v:
            v = speeds[j]
            z1, v1, u1, i1, l1, p1, d1, g1, _ = rates(z, vy, s, env, dx, v, c)
        path_out[j] = s
        imp = 0.0
        d_min = d_prev
        t = 0.0
        landing = False
        while t < period:
            remaining = period - t
            if d_prev < 0.0 and not landing:
                # a flight: in closed form to the landing or the period's end
                tau, landing = flight(env, dx, s, z, vy, v, g, remaining, root_tol)
                z, vy, s = z + (vy - 0.5 * g * tau) * tau, vy - g * tau, s + v * tau
                t = t + tau if tau < remaining else period
                z1, v1, u1, i1, l1, p1, d1, g1, d_prev = rates(z, vy, s, env, dx, v, c)
                if d_prev < d_min:
                    d_min = d_prev
                continue
            if h > h_max:
                h = h_max
            last = h >= remaining
            hh = remaining if last else h
            if hh <= 1e-12 * period:
                _store(y, z, vy, u, imp, loss, plate, drive, gross, s)
                return STEP_TOO_SMALL, steps, rejected, flights, h
            # the stages (s' = v: its increments are those of the other components' form)
            z2, v2, u2, i2, l2, p2, d2, g2, _ = rates(
                z + hh * A21 * z1, vy + hh * A21 * v1, s + hh * A21 * v, env, dx, v, c
            )
            z3, v3, u3, i3, l3, p3, d3, g3, _ = rates(
                z + hh * (A31 * z1 + A32 * z2),
                vy + hh * (A31 * v1 + A32 * v2),
                s + hh * (A31 * v + A32 * v), env, dx, v, c,
            )  # fmt: skip
            z4, v4, u4, i4, l4, p4, d4, g4, _ = rates(
                z + hh * (A41 * z1 + A42 * z2 + A43 * z3),
                vy + hh * (A41 * v1 + A42 * v2 + A43 * v3),
                s + hh * (A41 * v + A42 * v + A43 * v), env, dx, v, c,
            )  # fmt: skip
            z5, v5, u5, i5, l5, p5, d5, g5, _ = rates(
                z + hh * (A51 * z1 + A52 * z2 + A53 * z3 + A54 * z4),
                vy + hh * (A51 * v1 + A52 * v2 + A53 * v3 + A54 * v4),
                s + hh * (A51 * v + A52 * v + A53 * v + A54 * v), env, dx, v, c,
            )  # fmt: skip
            z6, v6, u6, i6, l6, p6, d6, g6, _ = rates(
                z + hh * (A61 * z1 + A62 * z2 + A63 * z3 + A64 * z4 + A65 * z5),
                vy + hh * (A61 * v1 + A62 * v2 + A63 * v3 + A64 * v4 + A65 * v5),
                s + hh * (A61 * v + A62 * v + A63 * v + A64 * v + A65 * v), env, dx, v, c,
            )  # fmt: skip
            z_new = step5(z, hh, z1, z3, z4, z5, z6)
            vy_new = step5(vy, hh, v1, v3, v4, v5, v6)
            s_new = step5(s, hh, v, v, v, v, v)
            z7, v7, u7, i7, l7, p7, d7, g7, d_new = rates(z_new, vy_new, s_new, env, dx, v, c)
            err_z = error4(hh, z1, z3, z4, z5, z6, z7)
            err_v = error4(hh, v1, v3, v4, v5, v6, v7)
            sc_z = atol_z + rtol * max(abs(d_prev), abs(d_new))
            sc_v = atol_v + rtol * max(abs(vy), abs(vy_new))
            err, proposed = control(hh, err_z, err_v, sc_z, sc_v, grow, h_max)
            steps += 1
            if steps > max_steps:
                _store(y, z, vy, u, imp, loss, plate, drive, gross, s)
                return MAX_STEPS, steps, rejected, flights, h
            if err <= 1.0:
                t = period if last else t + hh
                z, vy, s = z_new, vy_new, s_new
                u = step5(u, hh, u1, u3, u4, u5, u6)
                imp = step5(imp, hh, i1, i3, i4, i5, i6)
                loss = step5(loss, hh, l1, l3, l4, l5, l6)
                plate = step5(plate, hh, p1, p3, p4, p5, p6)
                drive = step5(drive, hh, d1, d3, d4, d5, d6)
                gross = step5(gross, hh, g1, g3, g4, g5, g6)
                z1, v1, u1, i1, l1, p1, d1, g1 = z7, v7, u7, i7, l7, p7, d7, g7
                landing = False
                if d_new <= 0.0 < d_prev:
                    flights += 1
                d_prev = d_new
                if d_new < d_min:
                    d_min = d_new
                # a step cut short by the sample boundary does not shrink the next one
                h = max(proposed, h) if last else proposed
            else:
                rejected += 1
                h = proposed
        force_out[j] = imp * samplerate
        min_penetration[j] = d_min
    _store(y, z, vy, u, imp, loss, plate, drive, gross, s)
    return OK, steps, rejected, flights, h


# How a path's rolling blocks end (synth.physics.path.ENDS: "max-duration" while running).
RUNNING = 0
STOPPED = 1
LEFT_PLATE = 2


@compiled()
def reach_bound(planned, count, samplerate, x):  # pragma: no cover - compiled
    """An upper bound (m) of the travel of ``count`` periods at the monotone speeds ``planned``
    (m/s) from ``x`` (m), with a margin for rounding."""
    travel = count * max(planned[0], planned[count - 1]) / samplerate
    return travel + 1e-9 * (travel + abs(x))


@compiled()
def block_speeds(v, decel, count, samplerate, x, x_end, out):  # pragma: no cover - compiled
    """The next block's speeds (m/s) into ``out`` from ``v`` (m/s) under ``decel`` (m/s^2), the
    centre at ``x`` (m): how many and how it ends (:data:`STOPPED`, :data:`LEFT_PLATE` past
    ``x_end``, else :data:`RUNNING`)."""
    end = RUNNING
    for k in range(count):
        out[k] = v - decel * (k + 0.5) / samplerate
    if count and out[count - 1] <= 0.0:
        end = STOPPED
        for k in range(count):
            if out[k] <= 0.0:
                count = k
                break
    if count == 0 or x + reach_bound(out, count, samplerate, x) <= x_end:
        return count, end
    travelled = 0.0
    for k in range(count):
        travelled += out[k]
        if x + travelled / samplerate > x_end:
            return k, LEFT_PLATE
    return count, end


@compiled()
def roll_blocks(
    y, h, env, dx, c, d, v, n_max, out, min_penetration, tallies
):  # pragma: no cover - compiled
    """A path's rolling from ``y`` (in place) and step ``h`` (s) at ``v`` (m/s), in blocks of
    ``d.block`` periods, at most ``n_max``, the kinetic energy losing the roughness' work.
    Writes force (N), centre (m), speed (m/s) into ``out`` (3, n_max); adds loss, plate
    energy, resistance and roughness work (J) to ``tallies[0:4]``. Returns ``(status, end,
    periods, h, v, flights)``."""
    samplerate = c.samplerate
    force_out, centre_out, speed_out = out[0], out[1], out[2]
    done = 0
    end = RUNNING
    flights = 0
    while done < n_max:
        speeds = speed_out[done : done + min(d.block, n_max - done)]
        count, end = block_speeds(v, d.decel, speeds.size, samplerate, y[S], d.x_end, speeds)
        if count == 0:
            break
        speeds = speeds[:count]
        loss, plate, drive = y[LOSS], y[PLATE], y[DRIVE]
        centres = centre_out[done : done + count]
        status, _, _, lost, h = roll(
            y, h, env, dx, speeds, c, MAX_STEPS_PER_SAMPLE * count,
            force_out[done : done + count], min_penetration[:count], centres,
        )  # fmt: skip
        if status != OK:
            return status, end, done, h, v, flights
        travel = 0.0
        for k in range(count):
            centres[k] += 0.5 * speeds[k] / samplerate  # the middle of each period
            travel += speeds[k]
        work = y[DRIVE] - drive
        tallies[0] += y[LOSS] - loss
        tallies[1] += y[PLATE] - plate
        tallies[2] += d.resistance_force * (travel / samplerate)
        tallies[3] += work
        flights += lost
        done += count
        v_end = v - d.decel * count / samplerate
        kinetic = d.kinetic_mass * v_end * abs(v_end) - work
        v = math.sqrt(max(kinetic, 0.0) / d.kinetic_mass)
        if end != RUNNING:
            break
        if kinetic <= 0.0:
            end = STOPPED
            break
    return OK, end, done, h, v, flights


@compiled()
def touching_points(centres, offsets, spacing, out):  # pragma: no cover - compiled
    """Touching points' path coordinates (m) of ``centres`` into ``out`` (as numpy's ``interp``)."""
    last = offsets.shape[0] - 1
    for k in range(centres.shape[0]):
        c = centres[k]
        if c < 0.0:
            offset = offsets[0]
        elif c >= last * spacing:
            offset = offsets[last]
        else:
            i = min(max(int(math.floor(c / spacing)), 0), last - 1)
            while i > 0 and i * spacing > c:
                i -= 1
            while i < last - 1 and (i + 1) * spacing <= c:
                i += 1
            x = i * spacing
            if x == c:
                offset = offsets[i]
            else:
                slope = (offsets[i + 1] - offsets[i]) / ((i + 1) * spacing - x)
                offset = slope * (c - x) + offsets[i]
        out[k] = c + offset


@compiled()
def node_reach(offsets, spacing, first, last):  # pragma: no cover - compiled
    """The least and largest touching point ``i spacing + offsets[i]`` (m), ``first <= i <= last``
    (``inf, -inf`` if none)."""
    lo, hi = math.inf, -math.inf
    for i in range(max(first, 0), min(last, offsets.shape[0] - 1) + 1):
        x = i * spacing + offsets[i]
        lo = min(lo, x)
        hi = max(hi, x)
    return lo, hi
