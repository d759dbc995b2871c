"""The rectangle rule of the Rayleigh integral (:func:`rayleigh_gains`): tensor Gauss-Legendre
panels for any shapes, graded towards the microphone's projection (docs/physics.md, "Radiation")."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from synth.compilation import announce, compiled
from synth.errors import ParameterError
from synth.sound.radiation.common import (
    CHUNK_BYTES,
    GRADING,
    REFINE,
    Poles,
    RadiationResult,
    accumulate,
    add_sums,
    check_finite,
    check_listener,
    check_poles,
    check_settings,
    check_size,
    distance_range,
    exp_halvings,
    fewest_points,
    gains_of,
    gauss,
    min_order,
    panel_length,
    refine,
)

#: Shortest panel over the plate's side: shorter ones are rounding (dropped), and the grading
#: never steps by less, so a microphone 1e-300 m above the plate still gets finite panels.
PANEL_RESOLUTION = 1e-12


def _breakpoints(length: float, centre: float, height: float, h: float) -> np.ndarray:
    """Panel ends on ``[0, length]`` (m): at most ``h`` long, and at most ``2 max(height,
    d)`` long, ``d`` the distance from ``centre`` (the microphone's projection) to the
    panel's near end, never shorter than ``PANEL_RESOLUTION * length``."""
    c = min(max(centre, 0.0), length)
    shortest = PANEL_RESOLUTION * length

    def side(stop, sign):
        out, t = [], c
        while (t - stop) * sign < 0.0:
            t += sign * min(h, GRADING * max(height, abs(t - centre), shortest))
            t = min(t, stop) if sign > 0.0 else max(t, stop)
            out.append(t)
        return out

    ends = np.array(side(0.0, -1.0)[::-1] + [c] + side(length, 1.0))
    ends = ends[np.concatenate(([True], np.diff(ends) > shortest))]
    ends[0], ends[-1] = 0.0, length
    return ends


def panel_orders(ends: np.ndarray, kappa, tol: float) -> np.ndarray:
    """Fewest points per panel (first rule) integrating ``exp(i kappa x)`` to ``tol``
    (``kappa`` rad/m, one for every panel or one per panel)."""
    lengths = np.diff(ends)
    kappas = np.broadcast_to(np.asarray(kappa, dtype=float), lengths.shape)
    p_min = min_order(tol)
    return np.array(
        [fewest_points(0.5 * k * n, tol, p_min) for k, n in zip(kappas, lengths)],
        dtype=np.int64,
    )


class Grid(NamedTuple):
    """A tensor grid: nodes ``xs`` and ``ys`` (m) and their weights ``wx``, ``wy`` (m)."""

    xs: np.ndarray
    wx: np.ndarray
    ys: np.ndarray
    wy: np.ndarray


def panel_grid(ex, ey, ox, oy) -> Grid:
    """The :class:`Grid` of the panels ``ex`` x ``ey`` with ``ox`` and ``oy`` points."""
    return Grid(*panel_nodes(ex, ox), *panel_nodes(ey, oy))


def panel_nodes(ends: np.ndarray, orders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes (m) and weights of the panels ``ends`` with ``orders`` points."""
    xs, ws = [], []
    for lo, hi, p in zip(ends[:-1], ends[1:], orders):
        t, w = gauss(int(p))
        half = 0.5 * (hi - lo)
        xs.append(0.5 * (lo + hi) + half * t)
        ws.append(half * w)
    return np.concatenate(xs), np.concatenate(ws)


def in_phase_grid(size, listener, kb: float, tol: float) -> Grid:
    """The :class:`Grid` of the polar rules' in-phase bounds: the rectangle rule at ``2 kb``
    (rad/m) refined once (shapes and the ``1 / R`` peak resolved, not the acoustic phase)."""
    ex, ey, px0, py0 = first_rule(size[0], size[1], listener, 2.0 * kb, tol)
    refined = (np.ceil(p * REFINE).astype(np.int64) for p in (px0, py0))
    return panel_grid(ex, ey, *refined)


def _workers() -> int:
    """Threads of the Rayleigh sums: one less than numba's (at least one)."""
    return max(1, numba.get_num_threads() - 1)


def apply_rule(shape_fn, grid: Grid, listener, r_mid, poles: Poles, chunk):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` and ``Int |phi_k| / R dA`` on
    ``grid``, ``chunk`` points at a time. While the worker threads (one less than numba's)
    add up one chunk without the GIL, this thread evaluates ``shape_fn`` on the next; each
    worker owns its accumulators and a fixed share of every chunk, so the result does not
    depend on the timing."""
    xl, yl, zl = listener
    xs, wx, ys, wy = grid
    m, ny = poles.qr.size, ys.size
    n_total = xs.size * ny
    workers = _workers()
    acc = np.zeros((workers, 3, m))  # per worker: real, imaginary, magnitude
    with ThreadPoolExecutor(max_workers=workers) as pool:
        running = []
        for start in range(0, n_total, chunk):
            ix, iy = np.divmod(np.arange(start, min(start + chunk, n_total)), ny)
            n = ix.size
            pts = np.column_stack((xs[ix], ys[iy]))
            phi = _real_table(shape_fn(pts), n, m, "shape_fn", "points")
            r = np.sqrt((pts[:, 0] - xl) ** 2 + (pts[:, 1] - yl) ** 2 + zl * zl)
            wr = wx[ix] * wy[iy] / r
            dist = r - r_mid
            for job in running:
                job.result()
            running = [
                pool.submit(add_sums, w * n // workers, (w + 1) * n // workers, dist, wr, phi,
                            poles, acc[w])
                for w in range(workers)
            ]  # fmt: skip
        for job in running:
            job.result()
    acc_re, acc_im, mag = acc.sum(axis=0)
    check_finite(mag, "shape_fn returned NaN or infinite (or overflowing) values")
    return acc_re + 1j * acc_im, mag


@dataclass(frozen=True)
class ProductFactors:
    """Mode shapes on a tensor grid as at most two products of one factor per axis:
    ``phi_k(x_a, y_b) = x_own[a, k] y_own[b, k] + x_other[a, k] y_other[b, k]``
    (dimensionless; the others None: the first product alone), as the dynamic edge effect
    modes are (:mod:`synth.physics.asymptotic_modes`)."""

    x_own: np.ndarray
    y_own: np.ndarray
    x_other: np.ndarray | None = None
    y_other: np.ndarray | None = None

    def columns(self, modes: np.ndarray) -> ProductFactors:
        """The factors of the modes ``modes`` (column indices) alone."""
        tables = (self.x_own, self.y_own, self.x_other, self.y_other)
        return ProductFactors(*(None if t is None else t[:, modes] for t in tables))


# Grid points whose shape values one call of the sums kernel holds (they stay in cache).
_PRODUCT_BLOCK = 64


@compiled(nogil=True)
def _product_sums(  # noqa: PLR0913
    i0, i1, xs, wx, ys, wy, listener, r_mid, fx, fy, gx, gy, paired, qr, qi, halvings, acc
):  # pragma: no cover
    """The sums of :func:`apply_rule` over the grid rows ``i0 <= i < i1`` (nodes ``xs[i]``
    times every ``ys``), the shapes ``fx[i] fy[j] (+ gx[i] gy[j] if paired)`` formed block
    by block of points and added by the shared kernel (:func:`accumulate`) into ``acc``
    (real, imaginary, magnitude)."""
    xl, yl, zl = listener[0], listener[1], listener[2]
    m = qr.size
    ny = ys.size
    phi = np.empty((_PRODUCT_BLOCK, m))
    dist = np.empty(_PRODUCT_BLOCK)
    wr = np.empty(_PRODUCT_BLOCK)
    for i in range(i0, i1):
        across = (xs[i] - xl) ** 2 + zl * zl
        ax, bx = fx[i], gx[i]
        for j0 in range(0, ny, _PRODUCT_BLOCK):
            n = min(_PRODUCT_BLOCK, ny - j0)
            for t in range(n):
                j = j0 + t
                r = math.sqrt(across + (ys[j] - yl) ** 2)
                dist[t] = r - r_mid
                wr[t] = wx[i] * wy[j] / r
                ay = fy[j]
                row = phi[t]
                if paired:
                    by = gy[j]
                    for k in range(m):
                        row[k] = ax[k] * ay[k] + bx[k] * by[k]
                else:
                    for k in range(m):
                        row[k] = ax[k] * ay[k]
            # the first row as an int64, not the literal 0: numba would compile a second
            # specialisation of the fused-multiply-add kernel, which rounds differently from
            # the one Python callers use, and which one runs would depend on the process
            accumulate(np.int64(0), n, dist, wr, phi, qr, qi, halvings, acc[0], acc[1], acc[2])


def apply_product_rule(factor_fn, grid: Grid, listener, r_mid, poles: Poles):
    """As :func:`apply_rule` for shapes given as factor tables (``factor_fn(xs, ys)`` ->
    :class:`ProductFactors`), formed in the sums kernel; one fixed share of rows per thread, so
    the result does not depend on the timing."""
    xs, wx, ys, wy = grid
    f = factor_fn(xs, ys)
    m = poles.qr.size
    paired = f.x_other is not None
    x_other, y_other = (f.x_other, f.y_other) if paired else (f.x_own, f.y_own)
    fx, gx = (_real_table(t, xs.size, m, "factor_fn", "nodes") for t in (f.x_own, x_other))
    fy, gy = (_real_table(t, ys.size, m, "factor_fn", "nodes") for t in (f.y_own, y_other))
    workers = max(1, min(numba.get_num_threads(), xs.size))
    acc = np.zeros((workers, 3, m))  # per worker: real, imaginary, magnitude
    args = (xs, wx, ys, wy, np.asarray(listener, dtype=float), r_mid, fx, fy, gx, gy, paired)
    bounds = [w * xs.size // workers for w in range(workers + 1)]
    announce("radiation")
    with ThreadPoolExecutor(max_workers=workers) as pool:
        jobs = [
            pool.submit(_product_sums, lo, hi, *args, *poles, acc[w])
            for w, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:]))
        ]
        for job in jobs:
            job.result()
    acc_re, acc_im, mag = acc.sum(axis=0)
    check_finite(mag, "factor_fn returned NaN or infinite values")
    return acc_re + 1j * acc_im, mag


def _real_table(values, n, m, fn, rows):
    """``values`` returned by ``fn`` as a C-ordered float array ``(n, m)`` (``rows``, modes),
    or a ParameterError naming its shape and dtype."""
    try:
        arr = np.asarray(values)
    except Exception:  # noqa: BLE001 - anything numpy cannot read is bad output
        raise ParameterError(f"{fn} must return an array of real values") from None
    number = np.issubdtype(arr.dtype, np.number) and arr.dtype != bool
    if arr.shape != (n, m) or not number or np.iscomplexobj(arr):
        raise ParameterError(
            f"{fn} returned shape {arr.shape} and dtype {arr.dtype}; expected real values of "
            f"shape ({n}, {m}) ({rows}, modes), one column per pole in s"
        )
    return np.ascontiguousarray(arr, dtype=np.float64)


def rayleigh_gains(shape_fn, size, listener_position, s, *, full_output=False, **settings):
    """Pressure per unit modal velocity at a microphone, for each mode (Rayleigh integral):
    ``H_k(s_k)``, Pa per (m/s) of modal velocity, (n_modes,) complex; with ``full_output`` a
    :class:`RadiationResult`, else the gains alone with a ``RuntimeWarning`` if the
    convergence test failed.

    ``shape_fn(points)``: the normal-velocity shapes ``phi_k`` (dimensionless, (n, n_modes))
    at plate positions ``points`` ((n, 2), m from the corner), called on chunks (the array
    returned must not be reused by the next call); ``size`` ``(a, b)`` > 0, m;
    ``listener_position`` ``(x, y, z)``, m, ``z > 0`` above the baffled plate; ``s`` each
    mode's complex frequency, rad/s. The keywords ``settings``
    (:func:`~.common.check_settings`): ``max_wavenumber`` >= 0 (required) the modes' largest
    bending wavenumber, rad/m; ``air_density`` > 0, kg/m^3; ``sound_speed`` > 0, m/s;
    ``reference_distance`` ``R0`` >= 0, m, or None: the gains times ``exp(s_k R0 / c)`` (the
    delay taken out, which keeps a damped pole's growth bounded); ``tol`` in [1e-9, 0.1]:
    ``|error| <= tol * max(|H_k|, 1e-4 S_k)`` (:func:`~.common.refine`); ``max_points`` > 0 the
    most points of one rule. A ParameterError names a field out of range, NaN or infinite
    shape values, or ``max_points`` too small for the first two rules."""
    if not callable(shape_fn):
        raise ParameterError(f"shape_fn={shape_fn!r} must be callable (points -> shape values)")

    def evaluate(grid, listener, r_mid, poles, active):
        chunk = max(1, int(CHUNK_BYTES // (8 * poles.qr.size)))
        return apply_rule(shape_fn, grid, listener, r_mid, poles, chunk)

    result = _rule_result(evaluate, size, listener_position, s, settings)
    return gains_of(result, "rayleigh_gains", check_settings(**settings).tol, full_output)


def product_gains(factor_fn, size, listener_position, s, **settings) -> RadiationResult:
    """:func:`rayleigh_gains` (``full_output``, the same keywords ``settings``) of shapes of
    at most two products of one factor per axis (the dynamic edge effect modes):
    ``factor_fn(x, y) -> ProductFactors`` at the grid's nodes (m), each panel's orders for its
    own bound of the acoustic phase's rate (:func:`first_rule`), each mode refined alone."""
    if not callable(factor_fn):
        raise ParameterError(f"factor_fn={factor_fn!r} must be callable (x, y -> factors)")

    def evaluate(grid, listener, r_mid, poles, active):
        def factors(x, y):
            return factor_fn(x, y).columns(active)

        return apply_product_rule(factors, grid, listener, r_mid, poles)

    return _rule_result(evaluate, size, listener_position, s, settings, local_phase=True)


def _rule_result(evaluate, size, listener_position, s, settings: dict, local_phase=False):
    """The :class:`RadiationResult` of the rectangle rule whose sums ``evaluate(grid, listener,
    r_mid, poles, active)`` computes as :func:`apply_rule` does; ``local_phase`` as for
    :func:`product_gains`."""
    a, b = check_size(size)
    listener = check_listener(listener_position)
    q_s = check_poles(s)
    settings = check_settings(**settings)
    kb, tol, max_points = settings.kb, settings.tol, settings.max_points
    if q_s.size == 0:
        return RadiationResult.no_modes()

    q = q_s / settings.c
    kappa = kb + float(np.max(np.abs(q)))
    zl = listener[2]
    tol_panel = 0.1 * tol
    h = panel_length(kappa, tol_panel)
    fewest = (a / h) * (b / h) * min_order(tol_panel) ** 2
    if fewest > max_points:  # before building the panels
        raise ParameterError(
            f"max_points={max_points!r} is too small: with max_wavenumber={kb!r} rad/m and "
            f"max|s|/c={kappa - kb:.6g} rad/m the plate needs more than {fewest:.3g} points"
        )
    ex, ey, px0, py0 = first_rule(
        a, b, listener, kappa, tol_panel, kappa - kb if local_phase else None
    )
    panels = (ex.size - 1, ey.size - 1)
    # the middle of the range of R over the plate is factored out of the exponentials
    r_min, r_max = distance_range((a, b), listener)
    r_mid = 0.5 * (r_max + r_min)
    halvings = exp_halvings(q, 0.5 * (r_max - r_min))

    def orders(level):
        f = REFINE**level
        return np.ceil(px0 * f).astype(np.int64), np.ceil(py0 * f).astype(np.int64)

    def npoints(level):
        ox, oy = orders(level)
        return int(ox.sum()) * int(oy.sum())

    if npoints(1) > max_points:
        raise ParameterError(
            f"max_points={max_points!r} is too small: with max_wavenumber={kb!r} rad/m, "
            f"max|s|/c={kappa - kb:.6g} rad/m and z={zl!r} m the plate needs "
            f"{panels[0]} x {panels[1]} panels and {npoints(1)} points for the "
            f"convergence check"
        )

    def rule(level, active):
        grid = panel_grid(ex, ey, *orders(level))
        return evaluate(grid, listener, r_mid, Poles.of(q[active], halvings), active)

    factor, scale = settings.factors(q_s, r_mid)
    return refine(rule, npoints, factor, scale, tol, max_points, panels, local_phase)


def first_rule(a, b, listener, kappa, tol_panel, acoustic=None):
    """Panel ends and first-rule orders along x and y of :func:`rayleigh_gains`. With ``acoustic``
    (the part ``max|s| / c`` of ``kappa``, rad/m) each panel's orders are for its own bound of the
    phase's rate, ``kappa - acoustic (1 - d / sqrt(d^2 + z^2))``, ``d`` the distance from the
    microphone's projection to the panel's far end (docs/physics.md, "Radiation")."""
    xl, yl, zl = listener
    h = panel_length(kappa, tol_panel)
    out = []
    for length, centre in ((a, xl), (b, yl)):
        ends = _breakpoints(length, centre, zl, h)
        rate = kappa
        if acoustic is not None:
            far = np.maximum(np.abs(ends[:-1] - centre), np.abs(ends[1:] - centre))
            rate = kappa - acoustic * (1.0 - far / np.sqrt(far * far + zl * zl))
        out.append((ends, panel_orders(ends, rate, tol_panel)))
    (ex, px), (ey, py) = out
    return ex, ey, px, py
