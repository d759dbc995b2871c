"""The rectangle rule of the Rayleigh integral (:func:`rayleigh_gains`): tensor
Gauss-Legendre panels along x and y, for any shapes.

Panels are at most ``h = 2 w24 / kappa`` long, ``kappa = max_wavenumber + max|s| / c``
(rad/m) the integrand's fastest oscillation and ``w24`` the largest half-panel phase that
24-point Gauss-Legendre integrates to ``tol / 10``; towards the microphone's projection they
are graded (at most ``2 max(z, d)`` long) so that the near-singular ``1 / R`` peak is
resolved for any height ``z > 0`` (docs/physics.md, "Radiation"). Shapes are evaluated in
chunks of about 32 MB while worker threads sum the previous chunk without the GIL, each
worker on a fixed share, so the result does not depend on timing.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from synth.compilation import announce, compiled
from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.sound.radiation.common import (
    CHUNK_BYTES,
    GRADING,
    MAX_ORDER,
    REFINE,
    RadiationResult,
    accumulate,
    add_sums,
    check_listener,
    check_poles,
    check_settings,
    check_size,
    distance_range,
    exp_halvings,
    gauss,
    half_phase,
    min_order,
)
from synth.sound.radiation.refinement import refine, refine_selective, warn_unconverged

#: Shortest panel, relative to the plate's side: a shorter one is a rounding artefact of
#: the stepping (dropped), and the near-field grading never steps by less, so that a
#: microphone closer to the plate than this (1e-300 m) still gets a finite set of panels
#: (a step below the float spacing at ``t`` would leave ``t`` where it is, forever).
PANEL_RESOLUTION = 1e-12


def _breakpoints(length: float, centre: float, height: float, h: float) -> np.ndarray:
    """Panel ends on ``[0, length]``: at most ``h`` long, and at most ``2 max(height, d)``
    long where ``d`` is the distance from ``centre`` (the microphone's projection on this
    axis) to the panel's near end, but never shorter than ``PANEL_RESOLUTION * length``
    (the steps then grow geometrically from there: about 30 panels to reach ``length``)."""
    c = min(max(centre, 0.0), length)
    shortest = PANEL_RESOLUTION * length
    right = [c]
    t = c
    while t < length:
        d = abs(t - centre)
        t = min(t + min(h, GRADING * max(height, d, shortest)), length)
        right.append(t)
    left = []
    t = c
    while t > 0.0:
        d = abs(centre - t)
        t = max(t - min(h, GRADING * max(height, d, shortest)), 0.0)
        left.append(t)
    ends = np.array(left[::-1] + right)
    keep = np.concatenate(([True], np.diff(ends) > shortest))
    ends = ends[keep]
    ends[-1] = length
    ends[0] = 0.0
    return ends


def panel_orders(ends: np.ndarray, kappa, tol: float) -> np.ndarray:
    """Fewest points per panel (first rule) integrating ``exp(i kappa x)`` to ``tol``
    (``kappa`` rad/m, one for every panel or one per panel)."""
    lengths = np.diff(ends)
    kappas = np.broadcast_to(np.asarray(kappa, dtype=float), lengths.shape)
    p_min = min_order(tol)
    orders = np.full(lengths.size, p_min, dtype=np.int64)
    for i, length in enumerate(lengths):
        w = 0.5 * kappas[i] * length
        p = p_min
        while p < MAX_ORDER and half_phase(p, tol) < w:
            p += 1
        orders[i] = p
    return orders


def panel_nodes(ends: np.ndarray, orders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xs, ws = [], []
    for lo, hi, p in zip(ends[:-1], ends[1:], orders):
        t, w = gauss(int(p))
        half = 0.5 * (hi - lo)
        xs.append(0.5 * (lo + hi) + half * t)
        ws.append(half * w)
    return np.concatenate(xs), np.concatenate(ws)


# ----------------------------------------------------------------------------------------
# One rule


def _workers() -> int:
    """Threads that run the Rayleigh sums: one less than numba's thread count (at
    least one); the calling thread meanwhile evaluates the next chunk's shapes."""
    return max(1, numba.get_num_threads() - 1)


def apply_rule(shape_fn, xs, wx, ys, wy, listener, q, r_mid, halvings, chunk):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` and ``Int |phi_k| / R dA``.

    Pipelined: while the worker threads add up one chunk of points (GIL released),
    the calling thread evaluates ``shape_fn`` on the next. Each worker owns its
    accumulators and always takes the same share of every chunk, so the result does
    not depend on the timing.
    """
    xl, yl, zl = listener
    m = q.size
    ny = ys.size
    n_total = xs.size * ny
    workers = _workers()
    acc = np.zeros((workers, 3, m))  # per worker: real, imaginary, magnitude
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        running = []
        for start in range(0, n_total, chunk):
            idx = np.arange(start, min(start + chunk, n_total))
            ix, iy = np.divmod(idx, ny)
            pts = np.empty((idx.size, 2))
            pts[:, 0] = xs[ix]
            pts[:, 1] = ys[iy]
            phi = shape_fn(pts)
            phi = _check_shapes(phi, idx.size, m)
            r = np.sqrt((pts[:, 0] - xl) ** 2 + (pts[:, 1] - yl) ** 2 + zl * zl)
            wr = wx[ix] * wy[iy] / r
            dist = r - r_mid
            for job in running:
                job.result()
            n = idx.size
            running = [
                pool.submit(
                    add_sums,
                    w * n // workers,
                    (w + 1) * n // workers,
                    dist,
                    wr,
                    phi,
                    qr,
                    qi,
                    halvings,
                    *acc[w],
                )
                for w in range(workers)
            ]
        for job in running:
            job.result()
    acc_re, acc_im, mag = acc.sum(axis=0)
    if not np.isfinite(mag).all():  # NaN or inf anywhere in phi propagates here
        k = int(np.flatnonzero(~np.isfinite(mag))[0])
        raise ParameterError(
            f"shape_fn returned NaN or infinite (or overflowing) values for mode {k}"
        )
    return acc_re + 1j * acc_im, mag


@dataclass(frozen=True)
class ProductFactors:
    """Mode shapes on a tensor grid as at most two products of one factor per axis:
    ``phi_k(x_a, y_b) = x_own[a, k] y_own[b, k] + x_other[a, k] y_other[b, k]``
    (dimensionless; ``x_other`` and ``y_other`` None: the first product alone), as the
    dynamic edge effect modes are (:mod:`synth.physics.asymptotic_modes`)."""

    x_own: np.ndarray
    y_own: np.ndarray
    x_other: np.ndarray | None = None
    y_other: np.ndarray | None = None

    def columns(self, modes: np.ndarray) -> ProductFactors:
        """The factors of the modes ``modes`` (column indices) alone."""
        paired = self.x_other is not None
        return ProductFactors(
            self.x_own[:, modes],
            self.y_own[:, modes],
            self.x_other[:, modes] if paired else None,
            self.y_other[:, modes] if paired else None,
        )


# Grid points whose shape values one call of the sums kernel holds (a few hundred kB for
# a few hundred modes: they stay in the processor's cache between their evaluation and
# their use).
_PRODUCT_BLOCK = 64


@compiled(nogil=True)
def _product_sums(
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


def apply_product_rule(factor_fn, xs, wx, ys, wy, listener, q, r_mid, halvings):
    """As :func:`apply_rule` for shapes given as factor tables: ``factor_fn(xs, ys)`` returns
    the :class:`ProductFactors` of every mode on the grid, whose shape values are formed
    in the sums kernel a block of points at a time (never all at once). The grid's rows
    are split into one fixed share per numba thread, each with its own accumulators, so
    the result does not depend on the timing."""
    f = factor_fn(xs, ys)
    m = q.size
    fx = _factor_table(f.x_own, xs.size, m)
    fy = _factor_table(f.y_own, ys.size, m)
    paired = f.x_other is not None
    gx = _factor_table(f.x_other, xs.size, m) if paired else fx
    gy = _factor_table(f.y_other, ys.size, m) if paired else fy
    workers = max(1, min(numba.get_num_threads(), xs.size))
    acc = np.zeros((workers, 3, m))  # per worker: real, imaginary, magnitude
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    args = (xs, wx, ys, wy, np.asarray(listener, dtype=float), r_mid, fx, fy, gx, gy, paired)
    bounds = [w * xs.size // workers for w in range(workers + 1)]
    announce("radiation")
    with ThreadPoolExecutor(max_workers=workers) as pool:
        jobs = [
            pool.submit(_product_sums, lo, hi, *args, qr, qi, halvings, acc[w])
            for w, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:]))
        ]
        for job in jobs:
            job.result()
    acc_re, acc_im, mag = acc.sum(axis=0)
    if not np.isfinite(mag).all():
        k = int(np.flatnonzero(~np.isfinite(mag))[0])
        raise ParameterError(f"factor_fn returned NaN or infinite values for mode {k}")
    return acc_re + 1j * acc_im, mag


def _factor_table(table, n, m):
    """A factor table of :class:`ProductFactors` as a C-ordered float array ``(n, m)``."""
    arr = np.asarray(table)
    if arr.shape != (n, m) or np.iscomplexobj(arr):
        raise ParameterError(
            f"factor_fn returned a factor table of shape {arr.shape} and dtype {arr.dtype}; "
            f"expected real values of shape ({n}, {m}) (nodes, modes)"
        )
    return np.ascontiguousarray(arr, dtype=np.float64)


def _check_shapes(phi, n, m):
    try:
        arr = np.asarray(phi)
    except Exception:  # noqa: BLE001
        raise ParameterError("shape_fn must return an array of mode shape values") from None
    if arr.shape != (n, m):
        raise ParameterError(
            f"shape_fn returned shape {arr.shape} for {n} points; expected ({n}, {m}) "
            f"(points, modes), one column per pole in s"
        )
    if np.iscomplexobj(arr):
        raise ParameterError("shape_fn must return real mode shape values, got complex")
    if not (np.issubdtype(arr.dtype, np.number) and arr.dtype != bool):
        raise ParameterError(f"shape_fn must return real numbers, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def rayleigh_gains(
    shape_fn,
    size,
    listener_position,
    s,
    *,
    max_wavenumber,
    air_density=AIR_DENSITY,
    sound_speed=SOUND_SPEED,
    reference_distance=None,
    tol=1e-6,
    max_points=4_000_000,
    full_output=False,
):
    """Pressure per unit modal velocity at a microphone, for each mode (Rayleigh integral).

    Parameters
    ----------
    shape_fn : callable
        ``shape_fn(points) -> values``: ``points`` ``(n, 2)`` plate positions ``(x, y)``, m
        from the corner; ``values`` ``(n, n_modes)`` normal-velocity shapes ``phi_k``
        (dimensionless). Called on chunks; the returned array must not be reused by the next
        call.
    size : (float > 0, float > 0)
        ``(a, b)``: the plate's extent along x and y, m.
    listener_position : (float, float, float)
        ``(x, y, z)`` of the microphone, m; ``z > 0`` the height above the baffled plate.
    s : array of complex, shape (n_modes,)
        Each mode's complex frequency, rad/s (``i omega``, or a pole ``-sigma_k + i omega_dk``).
    max_wavenumber : float >= 0
        Largest bending wavenumber of the modes, rad/m (0 for a rigid piston).
    air_density : float > 0
        Density of air, kg/m^3.
    sound_speed : float > 0
        Speed of sound in air, m/s.
    reference_distance : float >= 0 or None
        ``R0``, m: if given the gains are ``H_k(s_k) exp(+s_k R0 / c)`` (the delay ``R0 / c``
        taken out; for a damped pole this keeps the growth ``exp(sigma R / c)`` bounded).
    tol : float in [1e-9, 0.1]
        Relative accuracy of each gain: ``|error| <= tol * max(|H_k|, 1e-4 S_k)``
        (:mod:`synth.sound.radiation.refinement`).
    max_points : int > 0
        Most quadrature points one rule may use; refinement stops there.
    full_output : bool
        True: return a :class:`RadiationResult`; False: the gains alone, with a
        ``RuntimeWarning`` if the convergence test failed.

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity; or a :class:`RadiationResult`.

    Raises
    ------
    ParameterError
        For an input outside the ranges above (naming the field), NaN or infinite shape
        values, or a plate needing more than ``max_points`` points for the first two rules."""
    if not callable(shape_fn):
        raise ParameterError(f"shape_fn={shape_fn!r} must be callable (points -> shape values)")

    def evaluate(xs, wx, ys, wy, listener, q, r_mid, halvings, active):
        chunk = max(1, int(CHUNK_BYTES // (8 * q.size)))
        return apply_rule(shape_fn, xs, wx, ys, wy, listener, q, r_mid, halvings, chunk)

    settings = dict(max_wavenumber=max_wavenumber, air_density=air_density,
                    sound_speed=sound_speed, reference_distance=reference_distance, tol=tol,
                    max_points=max_points)  # fmt: skip
    result = _rule_result(evaluate, size, listener_position, s, settings)
    if full_output:
        return result
    if not result.success:
        warn_unconverged("rayleigh_gains", result, tol)
    return result.gains


def product_gains(
    factor_fn,
    size,
    listener_position,
    s,
    *,
    max_wavenumber,
    air_density=AIR_DENSITY,
    sound_speed=SOUND_SPEED,
    reference_distance=None,
    tol=1e-6,
    max_points=4_000_000,
) -> RadiationResult:
    """:func:`rayleigh_gains` (``full_output``) of shapes that are at most two products of one
    factor per axis (the dynamic edge effect modes): the shape values formed from factor
    tables inside the sums (:func:`apply_product_rule`), each panel's orders for its own bound
    of the acoustic phase's rate (:func:`first_rule`), each mode refined alone
    (:func:`~synth.sound.radiation.refinement.refine_selective`). ``factor_fn(x, y) ->
    ProductFactors``: the factors at the grid's nodes (m); other arguments as for
    :func:`rayleigh_gains`."""
    if not callable(factor_fn):
        raise ParameterError(f"factor_fn={factor_fn!r} must be callable (x, y -> factors)")

    def evaluate(xs, wx, ys, wy, listener, q, r_mid, halvings, active):
        def factors(x, y):
            f = factor_fn(x, y)
            return f if active is None else f.columns(active)

        return apply_product_rule(factors, xs, wx, ys, wy, listener, q, r_mid, halvings)

    settings = dict(max_wavenumber=max_wavenumber, air_density=air_density,
                    sound_speed=sound_speed, reference_distance=reference_distance, tol=tol,
                    max_points=max_points)  # fmt: skip
    return _rule_result(evaluate, size, listener_position, s, settings, local_phase=True)


def _rule_result(evaluate, size, listener_position, s, settings: dict, local_phase=False):
    """The :class:`RadiationResult` of the rectangle rule of :func:`rayleigh_gains`
    (arguments checked here) whose sums ``evaluate(xs, wx, ys, wy, listener, q, r_mid,
    halvings)`` computes, as :func:`apply_rule` does, on the tensor grid of nodes ``xs`` x
    ``ys`` (weights ``wx``, ``wy``; ``active`` the modes to sum, increasing indices, or
    None for every mode). ``local_phase``: each panel's orders for its own bound of the
    acoustic phase's rate (:func:`first_rule`), and each mode refined alone
    (:func:`~synth.sound.radiation.refinement.refine_selective`); ``settings`` the
    keywords of :func:`~.common.check_settings`."""
    a, b = check_size(size)
    listener = check_listener(listener_position)
    q_s = check_poles(s)
    kb, rho, c, r0, tol = check_settings(**settings)
    max_points = settings["max_points"]
    m = q_s.size
    if m == 0:
        return RadiationResult.no_modes()

    q = q_s / c
    kappa = kb + float(np.max(np.abs(q)))
    xl, yl, zl = listener
    # Panels: oscillation (kappa) and the near-field peak under the microphone.
    tol_panel = 0.1 * tol
    w_half = half_phase(MAX_ORDER, tol_panel)
    h = 2.0 * w_half / kappa if kappa > 0 else math.inf
    p_min = min_order(tol_panel)
    if (a / h) * (b / h) * p_min * p_min > max_points:  # before building the panels
        raise ParameterError(
            f"max_points={max_points!r} is too small: with max_wavenumber={kb!r} rad/m and "
            f"max|s|/c={kappa - kb:.6g} rad/m the plate needs more than "
            f"{(a / h) * (b / h) * p_min * p_min:.3g} points"
        )
    ex, ey, px0, py0 = first_rule(
        a, b, listener, kappa, tol_panel, kappa - kb if local_phase else None
    )
    panels = (ex.size - 1, ey.size - 1)

    # Range of R over the plate: the middle is factored out of the exponentials.
    r_min, r_max = distance_range((a, b), listener)
    r_mid = 0.5 * (r_max + r_min)
    spread = 0.5 * (r_max - r_min)
    # exp(-Re(q) dR) with |Re(q) dR| <= u_max by Taylor on [-1, 1] and `halvings`
    # squarings; libm beyond 2^6 (or for phases beyond the Cody-Waite range).
    halvings = exp_halvings(q, spread)

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

    def rule(level, active=None):
        ox, oy = orders(level)
        xs, wx = panel_nodes(ex, ox)
        ys, wy = panel_nodes(ey, oy)
        q_active = q if active is None else q[active]
        return evaluate(xs, wx, ys, wy, listener, q_active, r_mid, halvings, active)

    # Per-mode factor rho s / (2 pi) exp(-s (Rm - R0) / c).
    shift = r_mid - (0.0 if r0 is None else r0)
    factor = rho * q_s / (2.0 * math.pi) * np.exp(-q * shift)
    scale = rho * np.abs(q_s) / (2.0 * math.pi)

    how = refine_selective if local_phase else refine
    return how(rule, npoints, factor, scale, tol, max_points, panels)


def first_rule(a, b, listener, kappa, tol_panel, acoustic=None):
    """Panel ends and first-rule orders along x and y of :func:`rayleigh_gains`.

    ``acoustic``: the part ``max|s| / c`` of ``kappa`` (rad/m), or None. If given, each
    panel's orders are for its own bound of the phase's rate along the axis,
    ``kappa - acoustic (1 - slope)``: along x the acoustic phase ``Im(s) R / c`` changes
    at ``|s| / c |dR/dx|``, and ``|dR/dx| = |x - xl| / R <= slope = d / sqrt(d^2 + z^2)``,
    ``d`` the distance from the microphone's projection to the panel's far end (the same
    along y). The panels themselves are those of ``kappa``."""
    xl, yl, zl = listener
    w_half = half_phase(MAX_ORDER, tol_panel)
    h = 2.0 * w_half / kappa if kappa > 0 else math.inf
    ex = _breakpoints(a, xl, zl, h)
    ey = _breakpoints(b, yl, zl, h)
    if acoustic is None:
        return ex, ey, panel_orders(ex, kappa, tol_panel), panel_orders(ey, kappa, tol_panel)
    return (
        ex,
        ey,
        panel_orders(ex, _local_kappa(ex, xl, zl, kappa, acoustic), tol_panel),
        panel_orders(ey, _local_kappa(ey, yl, zl, kappa, acoustic), tol_panel),
    )


def _local_kappa(ends, centre, height, kappa, acoustic):
    """Per panel of ``ends``: ``kappa`` with its acoustic part ``acoustic`` (rad/m) scaled by
    the largest ``|dR/dt| = d / sqrt(d^2 + height^2)`` on the panel (see :func:`first_rule`)."""
    far = np.maximum(np.abs(ends[:-1] - centre), np.abs(ends[1:] - centre))
    slope = far / np.sqrt(far * far + height * height)
    return kappa - acoustic * (1.0 - slope)
