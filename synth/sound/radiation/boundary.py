"""Rayleigh gains of the dynamic edge effect modes as integrals over the plate's boundary
(docs/physics.md, "Radiation").

Each edge effect shape is a sum of products ``f(x) g(y)`` that solve the Helmholtz equation
``(lap + q^2) psi = 0`` (:mod:`synth.physics.asymptotic_modes`). With ``F`` a radial
solution about the microphone's projection of ``(lap + q^2) F = exp(-s R / c) / R``
(regular at the origin by variation of parameters, in exponentially scaled Bessel
functions), Green's second identity gives exactly
``Int_P psi G dA = Oint (psi dF/dn - F dpsi/dn) ds``. The radial and boundary integrals
share the polar rule's radial Gauss-Legendre panels; decaying factors are integrated
exactly by product weights (:func:`decay_weights`). The cost grows with the plate's
diameter times the wavenumber, not its area.

Here: the driver (:func:`boundary_rule`, :func:`boundary_integrals`) and the bounds of the
in-phase part; the grid in :mod:`~.boundary_grid`, the Bessel functions in
:mod:`~.boundary_bessel`, the tables and edge integrals in :mod:`~.boundary_tables`.
"""

from __future__ import annotations

import math

import numpy as np

from synth.sound.radiation.boundary_grid import (
    RATE_LADDER,
    RadialGrid,
    below_ladder,
    on_ladder,
    rate_steps,
)
from synth.sound.radiation.boundary_grid import decay_weights as decay_weights
from synth.sound.radiation.boundary_tables import entry_integrals
from synth.sound.radiation.common import (
    MAX_ORDER,
    REFINE,
    RadiationResult,
    half_phase,
)
from synth.sound.radiation.refinement import refine_selective


def _edge_rate(sol, trials, big) -> float:
    """Largest decay rate (1/m) along an edge of the trials' edge parts,
    ``sqrt(|s + 2 s_o|) / big`` of either factor."""
    sx, sy = sol.sx[trials], sol.sy[trials]
    return float(np.sqrt(np.maximum(np.abs(sx + 2.0 * sy), np.abs(sy + 2.0 * sx)).max()) / big)


def boundary_integrals(sol, modes_index, size, listener, q, r0, refine, tol_panel):
    """``Int phi_k exp(-q_k (R - r0)) / R dA`` of the edge effect modes ``modes_index``
    (indices into ``sol``'s modes), ``q = s / c`` per mode (1/m), on the plate ``size``
    (metres) with the microphone at ``listener``; and the number of radial nodes.

    The terms (one per mode and trial, two for a pair) are taken in groups of similar
    radial rate ``k + |q|`` (:func:`rate_steps`), each group on radial panels sized for
    the top of its step (or for its edge parts' decay along an edge if faster), with its
    substituted panels at most ``1 / (sqrt(3) k)`` long and the decaying parts' tail,
    each rate rounded to the ladder so that neighbouring groups share panels."""
    a, b = size
    big = max(a, b)
    trial = sol.trial[modes_index]
    partner = sol.partner[modes_index]
    own = sol.own[modes_index]
    other = sol.other[modes_index]
    paired = np.flatnonzero(partner >= 0)
    rows_mode = np.concatenate([np.arange(trial.size), paired])
    rows_trial = np.concatenate([trial, partner[paired]])
    rows_weight = np.concatenate([own, other[paired]])
    k_trial = np.sqrt(np.abs(sol.sx[rows_trial] + sol.sy[rows_trial])) / big
    rate = k_trial + np.abs(q[rows_mode])
    out = np.zeros(trial.size, dtype=complex)
    nodes = 0
    w_max = half_phase(MAX_ORDER, tol_panel)
    grids_made = {}
    step = rate_steps(rate)
    for level in np.unique(step):
        rows = np.flatnonzero(step == level)
        # the interior x interior part oscillates; the others decay at k and sqrt(3) k
        # (exactly on plain panels) and their edge parts at up to mu along the edges
        k_osc = max(RATE_LADDER ** float(level), float(rate[rows].max()))
        trials = rows_trial[rows]
        k_dec = max(k_osc, on_ladder(_edge_rate(sol, trials, big)))
        kappa_max = on_ladder(math.sqrt(3.0) * float(k_trial[rows].max()))
        kappa_min = below_ladder(float(k_trial[rows].min()))
        if kappa_min * 2.0 * w_max / k_dec <= 2.0:  # F's layer at the far corner resolved
            kappa_min = 0.0
        key = (k_dec, kappa_max, kappa_min)
        if key not in grids_made:
            grids_made[key] = RadialGrid(size, listener, *key, tol_panel, refine)
        grid = grids_made[key]
        nodes = max(nodes, grid.rho.size)
        vals = entry_integrals(
            grid, sol, rows_trial[rows], np.ascontiguousarray(q[rows_mode[rows]]), r0, size, big
        )
        np.add.at(out, rows_mode[rows], rows_weight[rows] * vals)
    return out, nodes


def _inverse_distance_integral(size, listener) -> float:
    """``Int_plate 1 / R dA`` (metres) in closed form: ``x ln(y + R) + y ln(x + R) -
    z atan(x y / (z R))`` is an antiderivative in ``x`` and ``y`` (from the projection)."""
    a, b = size
    xl, yl, z = listener

    def f(x, y):
        r = math.sqrt(x * x + y * y + z * z)
        return x * math.log(y + r) + y * math.log(x + r) - z * math.atan(x * y / (z * r))

    x0, x1, y0, y1 = -xl, a - xl, -yl, b - yl
    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)


#: Largest ``k h`` whose ``cosh`` and ``sinh`` :func:`_factor_bounds` takes directly
#: (``cosh(700) = 5e303``); beyond, its bound is taken in logarithms.
_DIRECT_GROWTH = 700.0


def _factor_bounds(s, so, n, h, ce, scale):
    """Upper bounds of ``|X|`` on ``[-h, h]`` for trial factors (interior part ``cos``,
    ``sin / k``, ``cosh``, ``sinh / k``; edge part at most 1, or ``1 / |cos|``,
    ``1 / |sin|`` of the edge value for an oscillating edge part), times ``|scale|``.

    Each interior bound is evaluated for its own trials only: a growing part's ``cosh(k
    h)`` overflows float64 beyond ``k h = 710`` although the normalised factor, ``scale``
    times it, stays of order ``sqrt(k h)``. Beyond :data:`_DIRECT_GROWTH` that product is
    ``exp(log|scale| + k h - log 2)`` (``/ k`` when odd): ``cosh(k h) = exp(k h) / 2``
    and ``sinh(k h) = exp(k h) / 2`` to a relative ``exp(-2 k h) < 1e-600``. Below it the
    arithmetic is the direct one."""
    odd = n % 2 == 1
    k = np.sqrt(np.abs(s))
    kh = k * h
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(odd, h, 1.0)  # s == 0: x or 1
        osc = s > 0.0
        u[osc] = np.where(odd[osc], np.minimum(h, 1.0 / k[osc]), 1.0)
        grow = s < 0.0
        direct = grow & (kh <= _DIRECT_GROWTH)
        u[direct] = np.where(odd[direct], np.sinh(kh[direct]) / k[direct], np.cosh(kh[direct]))
        m2 = s + 2.0 * so
        mu = np.sqrt(np.abs(m2))
        e_osc = 1.0 / np.abs(np.where(odd, np.sin(mu * h), np.cos(mu * h)))
        e = np.where(m2 < 0.0, e_osc, 1.0)
        bound = np.abs(scale) * (u + np.abs(ce) * e)
        far = grow & (kh > _DIRECT_GROWTH)
        if far.any():
            log_u = kh[far] - math.log(2.0) - np.where(odd[far], np.log(k[far]), 0.0)
            weight = np.abs(scale[far])
            bound[far] = np.exp(np.log(weight) + log_u) + weight * np.abs(ce[far]) * e[far]
    return bound


def in_phase_bounds(sol, modes_index, size, listener) -> np.ndarray:
    """``max|phi_k| Int 1 / R dA`` (metres) of edge effect modes: upper bounds of
    ``Int |phi_k| / R dA`` (``S_k`` of :mod:`synth.sound.radiation.refinement` over
    ``rho |s_k| / (2 pi)``), ``|phi_k| <= |own| |X_t| |Y_t| + |other| |X_u| |Y_u|``."""
    (cx, gx), (cy, gy) = sol.factor_constants()
    hx, hy = sol.half
    bx = _factor_bounds(sol.sx, sol.sy, sol.nx, hx, cx, gx)
    by = _factor_bounds(sol.sy, sol.sx, sol.ny, hy, cy, gy)
    trial = sol.trial[modes_index]
    partner = sol.partner[modes_index]
    peak = np.abs(sol.own[modes_index]) * bx[trial] * by[trial]
    paired = partner >= 0
    peak[paired] += np.abs(sol.other[modes_index][paired]) * (
        bx[partner[paired]] * by[partner[paired]]
    )
    return peak * _inverse_distance_integral(size, listener)


def nearest_distance(size, listener) -> float:
    """Distance (m) from the microphone to the nearest point of the plate."""
    a, b = size
    xl, yl, z = listener
    dx = max(0.0, -xl, xl - a)
    dy = max(0.0, -yl, yl - b)
    return math.sqrt(dx * dx + dy * dy + z * z)


def boundary_rule(
    part,
    n_modes,
    size,
    listener,
    s,
    *,
    air_density,
    sound_speed,
    reference_distance,
    tol,
    max_points,
) -> RadiationResult:
    """Gains ``H_k(s_k)`` (times ``exp(s_k R0 / c)`` if ``reference_distance`` ``R0`` is
    given) of the edge effect modes ``part.first_mode <= k < n_modes`` by the boundary
    rule (module notes), with the tolerance, error estimate and convergence test of
    :mod:`synth.sound.radiation.refinement` (successive rules with 1.25 times the radial
    points, a passing mode keeping its gain). ``S_k`` is the bound of
    :func:`in_phase_bounds`. ``s`` one pole per edge effect mode (rad/s)."""
    sol = part.solution
    index = part.offset + np.arange(n_modes - part.first_mode)
    rho, c = air_density, sound_speed
    q = s / c
    r_ref = nearest_distance(size, listener)
    shift = r_ref - (0.0 if reference_distance is None else reference_distance)
    factor = rho * s / (2.0 * math.pi) * np.exp(-q * shift)
    scale = rho * np.abs(s) / (2.0 * math.pi)
    bounds = in_phase_bounds(sol, index, size, listener)
    tol_panel = 0.1 * tol
    nodes = {}

    def rule(level, active):
        integrals, n = boundary_integrals(
            sol, index[active], size, listener, q[active], r_ref, REFINE**level, tol_panel
        )
        nodes[level] = n
        return integrals, bounds[active]

    def npoints(level):
        # a rule not yet applied: its orders, hence its nodes, grow as REFINE per level
        if level in nodes:
            return nodes[level]
        known = max(nodes)
        return int(nodes[known] * REFINE ** (level - known))

    return refine_selective(rule, npoints, factor, scale, tol, max_points, (0, 0))
