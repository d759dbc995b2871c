"""The polar rules of the Rayleigh integral (docs/physics.md, "Radiation"): for separable shapes
``X_i(x) Y_j(y)`` (:func:`separable_gains`) and sums of them (:func:`summed_gains`), integrated
over arcs about the microphone's projection (grids: :mod:`~.angular`)."""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from synth.compilation import compiled
from synth.errors import ParameterError
from synth.physics.modes import single_thread_product
from synth.sound.radiation.angular import (
    POLAR_PANEL_TOL,
    angular_rule,
    arc_panels,
    panels_points,
    radial_nodes,
    radial_rule,
    radial_segments,
    shorter_arcs,
)
from synth.sound.radiation.bessel_j0 import HANKEL_FROM, j0_cephes, j0_hankel
from synth.sound.radiation.common import (
    CHUNK_BYTES,
    REFINE,
    Poles,
    RadiationResult,
    Settings,
    add_sums,
    check_finite,
    check_listener,
    check_poles,
    check_settings,
    exp_halvings,
    gains_of,
    refine,
)
from synth.sound.radiation.rectangle import apply_rule, in_phase_grid

#: Revision of the polar rules' algorithm (part of the gain cache's key).
POLAR_REVISION = 2


@compiled(nogil=True)
def _add_circle_sums(radii, signs, wavenumbers, amplitudes, out):  # pragma: no cover
    """``out[i, k] += signs[i] amplitudes[k] J_0(wavenumbers[k] radii[i])`` for the rows with
    ``signs[i] != 0`` (radii > 0 m, wavenumbers >= 0 rad/m): the Hankel expansion, vectorised
    over the modes, then Cephes for the modes with ``k r < 25``."""
    m = wavenumbers.size
    order = np.argsort(wavenumbers)
    inv_k = np.empty(m)
    sqrt_inv_k = np.empty(m)
    for k in range(m):
        inv_k[k] = 1.0 / max(wavenumbers[k], 1e-300)
        sqrt_inv_k[k] = math.sqrt(inv_k[k])
    row = np.empty(m)
    cap = 1.0 / HANKEL_FROM
    sqrt_cap = math.sqrt(cap)
    for i in range(radii.size):
        if signs[i] == 0.0:
            continue
        r = radii[i]
        inv_r = 1.0 / r
        sqrt_inv_r = math.sqrt(inv_r)
        for k in range(m):
            x = wavenumbers[k] * r
            big = x >= HANKEL_FROM
            row[k] = j0_hankel(
                inv_k[k] * inv_r if big else cap,
                sqrt_inv_k[k] * sqrt_inv_r if big else sqrt_cap,
                x if big else HANKEL_FROM,
            )
        for j in range(m):
            k = order[j]
            x = wavenumbers[k] * r
            if x >= HANKEL_FROM:
                break
            row[k] = j0_cephes(x)
        s = signs[i]
        dest = out[i]
        for k in range(m):
            dest[k] += s * amplitudes[k] * row[k]


# Modes times this below the factor pairs of a separable rule: angular sums mode by mode
# (gathered factors, about this many times slower per multiply-add than a matrix product).
_DIRECT_RATIO = 10


def _factor_subset(rows, in_use):
    """``rows`` (sorted factor indices) for ``x_values`` / ``y_values``; None (the whole
    table, no copy) when they are all of ``0 .. max(in_use)``."""
    return None if rows.size == int(in_use.max()) + 1 else rows


@dataclass(frozen=True)
class _Circles:
    """Angular points of the separable rule at each of a block's radii: at radius ``i`` the
    points ``ends[i] : ends[i + 1]`` of ``x``, ``y`` (m) and ``w`` lie on the arcs on the
    plate (``whole[i] = 0``; clipped to it, rounding) or, when those off the plate are
    shorter, on the arcs off it (``whole[i] = 1``: the whole circle in closed form minus
    these, their weights negative)."""

    whole: np.ndarray
    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    ends: np.ndarray


def _circle_points(radii, size, listener, kb, tol, refine) -> _Circles:
    """The :class:`_Circles` of ``radii`` (m)."""
    a, b = size
    xl, yl, _ = listener
    whole = np.zeros(radii.size)
    panels, counts = [], np.zeros(radii.size, dtype=np.int64)
    for i, r in enumerate(radii):
        off, arcs = shorter_arcs(float(r), a, b, xl, yl)
        whole[i] = float(off)
        these = arc_panels(float(r), kb, tol, refine, arcs)
        counts[i] = sum(n * p for _, _, n, p in these)
        panels += these
    theta, w = panels_points(panels)
    on = np.repeat(whole == 0.0, counts)
    r_point = np.repeat(radii, counts)
    x = xl + r_point * np.cos(theta)
    y = yl + r_point * np.sin(theta)
    x[on] = np.clip(x[on], 0.0, a)
    y[on] = np.clip(y[on], 0.0, b)
    w[~on] *= -1.0
    return _Circles(whole, x, y, w, np.concatenate(([0], np.cumsum(counts))))


def _apply_separable_rule(sep, setup, radii, wr, refine, active):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` of the separable shapes ``k``
    in ``active`` (indices), and the number of points, by the polar rule of ``setup``
    refined by ``refine`` (``radii``, m, with weights ``wr``; :class:`_Circles`); only the
    factors those modes use enter the angular products."""
    xl, yl, zl = setup.listener
    m = active.size
    rows_x, xi = np.unique(sep.x_index[active], return_inverse=True)
    rows_y, yi = np.unique(sep.y_index[active], return_inverse=True)
    take_x = _factor_subset(rows_x, sep.x_index)
    take_y = _factor_subset(rows_y, sep.y_index)
    wavenumbers = np.ascontiguousarray(sep.mode_wavenumbers()[active])
    # 2 pi phi_k(xl, yl): the whole circle's integral over J_0(k r)
    centre = 2.0 * math.pi * (sep.x_values(np.array([xl]), take_x)[0, xi]
                              * sep.y_values(np.array([yl]), take_y)[0, yi])  # fmt: skip
    poles = Poles.of(setup.q[active], setup.halvings)
    # blocks of radii (one block of shape values at most CHUNK_BYTES), at least two per
    # worker; worker w takes blocks w, w + workers, ... into its own accumulators, so that
    # the result does not depend on the timing
    workers = max(1, numba.get_num_threads())
    rows = max(1, min(int(CHUNK_BYTES // (8 * m)), -(-radii.size // (2 * workers))))
    blocks = list(range(0, radii.size, rows))
    workers = min(workers, len(blocks))
    acc = np.zeros((workers, 3, m))  # per worker: real, imaginary, unused
    # few modes (a refinement of the failing ones): each mode's own angular sum costs
    # less than the product of every pair of their factors
    direct = _DIRECT_RATIO * m < rows_x.size * rows_y.size

    def block_sums(start, sums, acc_w):
        """Add the radii ``start : start + rows`` to ``acc_w``; their points."""
        rr = radii[start : start + rows]
        phi = np.zeros((rr.size, m))
        c = _circle_points(rr, setup.size, setup.listener, setup.settings.kb, setup.tol_panel,
                           refine)  # fmt: skip
        x, y, w, ends = c.x, c.y, c.w, c.ends
        for i in np.flatnonzero(ends[1:] > ends[:-1]):
            pts = slice(ends[i], ends[i + 1])
            fx = sep.x_values(x[pts], take_x)
            fy = np.ascontiguousarray(sep.y_values(y[pts], take_y))
            if direct:
                phi[i] = w[pts] @ (fx[:, xi] * fy[:, yi])
            else:
                single_thread_product(np.ascontiguousarray((fx * w[pts, None]).T), fy, sums)
                phi[i] = sums[xi, yi]
        _add_circle_sums(rr, c.whole, wavenumbers, centre, phi)
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        add_sums(0, rr.size, big_r - setup.r_mid, weight, phi, poles, acc_w)
        return w.size

    def worker(w):
        sums = np.empty((rows_x.size, rows_y.size))
        return sum(block_sums(start, sums, acc[w]) for start in blocks[w::workers])

    if workers == 1:
        n_points = worker(0)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            n_points = sum(pool.map(worker, range(workers)))
    acc_re, acc_im, _ = acc.sum(axis=0)
    total = acc_re + 1j * acc_im
    check_finite(total, "separable shapes gave NaN or infinite values", active)
    return total, n_points


def _separable_in_phase(sep, setup):
    """``Int |phi_k| / R dA`` of separable shapes on :func:`~.rectangle.in_phase_grid`: one
    matrix product ``|X|^T W |Y|`` for every mode, ``W`` the grid's weights over ``R``."""
    xl, yl, zl = setup.listener
    xs, wx, ys, wy = in_phase_grid(setup.size, setup.listener, setup.settings.kb, setup.tol_panel)
    weights = (wx[:, None] * wy[None, :]) / np.sqrt(
        (xs[:, None] - xl) ** 2 + (ys[None, :] - yl) ** 2 + zl * zl
    )
    abs_x = np.abs(sep.x_values(xs))
    abs_y = np.abs(sep.y_values(ys))
    inner = np.empty((xs.size, abs_y.shape[1]))
    single_thread_product(weights, abs_y, inner)
    sums = np.empty((abs_x.shape[1], abs_y.shape[1]))
    single_thread_product(np.ascontiguousarray(abs_x.T), inner, sums)
    mag = sums[sep.x_index, sep.y_index]
    check_finite(mag, "separable shapes gave NaN or infinite values")
    return mag


def _apply_summed_rule(shapes, setup, radii, wr, refine, active):
    """As :func:`_apply_separable_rule` for summed shapes: the angular sums ``A`` serve
    every mode; only the modes ``active`` are combined from them and take exponentials."""
    listener, kb, tol = setup.listener, setup.settings.kb, setup.tol_panel
    a, b = setup.size
    xl, yl, zl = listener
    m = active.size
    every = m == shapes.n_modes
    acc = np.zeros((3, m))  # real, imaginary, unused
    poles = Poles.of(setup.q[active], setup.halvings)
    rows = max(1, int(CHUNK_BYTES // (8 * max(m, shapes.n_x * shapes.n_y))))
    n_points = 0
    for start in range(0, radii.size, rows):
        rr = radii[start : start + rows]
        sums = np.zeros((rr.size, shapes.n_x, shapes.n_y))
        for i, r in enumerate(rr):
            theta, w = angular_rule(float(r), a, b, listener, kb, tol, refine)
            n_points += theta.size
            if theta.size:
                fx = shapes.x_values(np.clip(xl + r * np.cos(theta), 0.0, a))
                fy = shapes.y_values(np.clip(yl + r * np.sin(theta), 0.0, b))
                single_thread_product(np.ascontiguousarray((fx * w[:, None]).T), fy, sums[i])
        phi = shapes.combine(sums, None if every else active)
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        add_sums(0, rr.size, big_r - setup.r_mid, weight, phi, poles, acc)
    return acc[0] + 1j * acc[1], n_points


def _summed_in_phase(shapes, setup):
    """``Int |phi_k| / R dA`` of summed shapes on :func:`~.rectangle.in_phase_grid`."""
    m = shapes.n_modes
    grid = in_phase_grid(setup.size, setup.listener, setup.settings.kb, setup.tol_panel)
    chunk = max(1, int(CHUNK_BYTES // (8 * max(m, 1))))
    zero = Poles.of(np.zeros(m, complex), 0)
    return apply_rule(shapes.values, grid, setup.listener, setup.r_mid, zero, chunk)[1]


@dataclass(frozen=True)
class _PolarSetup:
    """A polar rule's checked arguments: ``size``, ``listener`` (m), poles ``q_s`` (rad/s) and
    ``q = s / c`` (1/m), ``settings``, radial panels and orders, ``r_mid`` (m), halvings."""

    size: tuple
    listener: tuple
    q_s: np.ndarray
    settings: Settings
    q: np.ndarray
    tol_panel: float
    panels: list
    orders: np.ndarray | None
    r_mid: float
    halvings: int


def _polar_setup(size, n_modes, listener_position, s, settings: dict) -> _PolarSetup:
    """The :class:`_PolarSetup` (a ParameterError names a bad field; no panels without
    modes)."""
    listener = check_listener(listener_position)
    q_s = check_poles(s, n_modes)
    checked = check_settings(**settings)
    q = q_s / checked.c
    tol_panel = POLAR_PANEL_TOL * checked.tol
    if q.size == 0:
        return _PolarSetup(size, listener, q_s, checked, q, tol_panel, [], None, 0.0, 0)
    panels, orders = radial_rule(size, listener, checked.kb, float(np.max(np.abs(q))), tol_panel)
    (a, b), (xl, yl, zl) = size, listener
    r_min, r_max, _, _ = radial_segments(a, b, xl, yl)
    big_min, big_max = math.hypot(r_min, zl), math.hypot(r_max, zl)
    r_mid, halvings = 0.5 * (big_min + big_max), exp_halvings(q, 0.5 * (big_max - big_min))
    return _PolarSetup(size, listener, q_s, checked, q, tol_panel, panels, orders, r_mid, halvings)


def _polar_gains(caller, shapes, listener_position, s, settings):
    """The :class:`RadiationResult` of ``caller`` (:func:`separable_gains` or
    :func:`summed_gains`) and the checked tolerance, each mode refined alone."""
    from synth.physics.modes import SeparableShapes, SummedShapes

    kind = SeparableShapes if caller == "separable_gains" else SummedShapes
    if not isinstance(shapes, kind):
        raise ParameterError(f"shapes={shapes!r} must be a synth.physics.modes.{kind.__name__}")
    if kind is SeparableShapes:
        n_modes, in_phase, apply = shapes.x_index.size, _separable_in_phase, _apply_separable_rule
    else:
        n_modes, in_phase, apply = shapes.n_modes, _summed_in_phase, _apply_summed_rule
    setup = _polar_setup((shapes.length, shapes.width), n_modes, listener_position, s, settings)
    checked = setup.settings
    if setup.q.size == 0:
        return RadiationResult.no_modes(), checked.tol
    mag = in_phase(shapes, setup)
    counts = {}

    def rule(level, active):
        f = REFINE**level
        radii, wr = radial_nodes(setup.panels, np.ceil(setup.orders * f).astype(np.int64))
        total, n = apply(shapes, setup, radii, wr, f, active)
        counts.setdefault(level, n)
        return total, mag[active]

    def npoints(level):
        if level in counts:
            return counts[level]
        known = max(counts)  # not yet applied: points grow as 1.25^2 per level
        return int(counts[known] * REFINE ** (2 * (level - known)))

    factor, scale = checked.factors(setup.q_s, setup.r_mid)
    panels = (len(setup.panels), 0)
    result = refine(rule, npoints, factor, scale, checked.tol, checked.max_points, panels, True)
    return dataclasses.replace(result, rule="polar"), checked.tol


def separable_gains(shapes, listener_position, s, *, full_output=False, **settings):
    """:func:`rayleigh_gains` of shapes ``X_i(x) Y_j(y)`` (``shapes``, a
    :class:`synth.physics.modes.SeparableShapes` with the plate's size), in polar coordinates
    about the microphone: the same integral, keywords (``max_wavenumber`` bounding every
    shape's, rad/m; ``max_points`` the points of one rule), tolerance, convergence test and
    result (``rule`` "polar", ``panels``: the radial panels and 0)."""
    result, tol = _polar_gains("separable_gains", shapes, listener_position, s, settings)
    return gains_of(result, "separable_gains", tol, full_output)


def summed_gains(shapes, listener_position, s, *, full_output=False, **settings):
    """:func:`separable_gains` of shapes ``sum_ij C_kij X_i(x) Y_j(y)`` (``shapes``, a
    :class:`synth.physics.modes.SummedShapes` with the plate's size): about ``N_theta n_x n_y
    + N_r n_basis n_modes / 4`` multiply-adds and ``N_r n_modes`` exponentials per rule."""
    result, tol = _polar_gains("summed_gains", shapes, listener_position, s, settings)
    return gains_of(result, "summed_gains", tol, full_output)
