"""Sound radiated by plate modes to a microphone: the Rayleigh integral.

The plate ``[0, a] x [0, b]`` lies in the plane ``z = 0`` of an infinite rigid
baffle, air on the side ``z > 0``. When its normal surface velocity is one mode,
``v(xs, t) = phi_k(xs) u(t)`` with ``u(t) = exp(s t)``, the pressure at the
listener ``xL = (x, y, z)`` is ``p(xL, t) = H_k(s) exp(s t)`` with the exact
transfer function of the Rayleigh integral (docs/physics.md, "Radiation")::

    H_k(s) = (rho s / (2 pi)) Int_plate phi_k(xs) exp(-s R / c) / R dA,   R = |xL - xs|

(``rho s u`` is the surface acceleration; the integral is linear and
time-invariant, so an exponential input returns the same exponential times
``H_k(s)``, the propagation delay included). ``s`` may be any complex number: a
damped mode ringing as ``exp(p_k t)``, ``p_k = -sigma_k + i omega_dk``, takes
``s = p_k`` (the analytic continuation of the same formula). Units: ``H`` is in
pascals per metre-per-second of the modal velocity ``u`` (Pa s/m).

For synthesis with one pure delay per listener, the gain can be returned with a
reference delay factored out, ``H_k(s) exp(+s R0 / c)``, where ``R0`` is the
distance from the listener to a reference point (for instance the impact point,
:func:`distance`); the pressure is then that gain applied ``R0 / c`` seconds
(:func:`delay`) later.

Quadrature
----------
Tensor Gauss-Legendre panels. The integrand oscillates along the plate at most at
``kappa = max_wavenumber + max|s| / c`` rad/m (the mode's bending wavenumber plus
the acoustic one: the phase of ``exp(-s R / c)`` changes along the plate at most
at ``|s| / c``). Along each axis the panels are at most ``h = 2 w24 / kappa``
long, ``w24`` the largest half-panel phase that 24-point Gauss-Legendre
integrates (``exp(i w t)`` on ``[-1, 1]``) to ``tol / 10``; each panel then gets
the fewest points that do so for its own length. Towards the microphone's
projection ``(x, y)`` the panels are graded: a panel whose near end is a
distance ``d`` (along the axis) from the projection is at most ``2 max(z, d)``
long, so that the near-singular ``1 / R`` peak (its complex singularities lie at
a distance ``>= sqrt(d^2 + z^2)``) is resolved for any height ``z > 0``; such a
panel gets at least ``ln(1/tol) / (2 ln 2.89)`` points (its Bernstein-ellipse
parameter is ``>= 2.89``).

Convergence is checked by a second rule on the same panels with 1.25 times the
points per axis (about 1.5 times in all); while any mode fails the test below
the rule is refined again by 1.25 per axis (up to six times), each rule compared
with the previous one. The estimated error of mode ``k`` is the change
``|H_fine - H_coarse|`` and the rule is accepted when for every mode::

    |H_fine - H_coarse| <= tol * max(|H_fine|, 1e-4 * S_k),
    S_k = (rho |s_k| / (2 pi)) Int |phi_k| / R dA  >= |H_k|

``S_k`` is the gain the mode would have if the whole plate radiated in phase;
for a mode whose radiation cancels to below ``1e-4`` of it (-80 dB), the
tolerance is taken relative to ``1e-4 S_k`` instead of ``|H_k|`` (round-off,
about ``1e-16 S_k`` times the square root of the number of points, would
otherwise dominate). The finer rule's gains are returned.

Shapes are evaluated in chunks of points so that one chunk of mode values takes
at most about 32 MB (``n_modes * chunk * 8`` bytes) whatever the number of
modes and points. The sums over a chunk run in worker threads without the GIL
while the calling thread evaluates the next chunk's shapes (two chunks are held
at a time); each worker always takes the same share of every chunk, so the
result does not depend on the timing.

Polar rule (separable shapes)
-----------------------------
The rectangle rule costs one exponential per mode and point, about ``n_modes (k a)(k b)``
(``k`` the largest of the bending and acoustic wavenumbers): hours for tens of
thousands of modes on a 2 m plate. For shapes ``X_i(x) Y_j(y)`` (the simply supported
plate) :func:`separable_gains` integrates in polar coordinates ``(r, theta)`` about the
microphone's projection, where ``R = sqrt(r^2 + z^2)`` does not depend on ``theta``::

    Int phi_k exp(-s R / c) / R dA = Int (r / R) exp(-s R / c) Phi_k(r) dr,
    Phi_k(r) = Int_arcs phi_k(xl + r cos theta, yl + r sin theta) dtheta.

``Phi_k`` does not depend on ``s``: at each radius the angular sums of every mode are
one matrix product of the ``X`` and ``Y`` values at the arc's points, and the radial
sums take one exponential per mode and radius. Angular points: Gauss-Legendre panels
for a trigonometric polynomial of the degree beyond which ``|J_n(k_b r)| <= tol`` (a
plane wave on a circle, Jacobi-Anger). Radial panels: as along x and y above, with
breakpoints where the set of arcs changes (a circle touching an edge's line, where
``Phi_k`` behaves as ``sqrt(r - d)``, removed by ``r = d + L u^2``; a corner, a kink),
and sized for the phase of ``exp(-s R / c)`` plus that of the arcs' ends travelling
along the edges. The tolerance, the error estimate (successive rules with 1.25 times
the points per axis) and the convergence test are those above, except that a mode
passing the test keeps that rule's gain and only the modes still failing are evaluated
on the next rule (with the factors they use alone): each mode's test is its own. The
in-phase bounds ``S_k`` (``|phi_k| = |X_i| |Y_j|``) come from one matrix product on a
rectangle rule that resolves the shapes but not the acoustic phase (as for the sums of
separable shapes below). Tests compare the two rules on plates where both run
(agreement within ``2 tol``, in-phase bounds within 5 %). :func:`plate_gains` takes
the polar rule for separable shapes when the rectangle rule's work (modes times
points) exceeds ``5e7``.

Polar rule (sums of separable shapes)
-------------------------------------
The free and clamped plates' Ritz shapes are sums of such products,
``phi_k = sum_ij C_kij X_i(x) Y_j(y)`` (:class:`synth.sound.modes.SummedShapes`).
:func:`summed_gains` applies the same polar rule: at each radius the angular sums
``A_ij = sum_theta w X_i Y_j`` are one small matrix product whatever the number of
modes, and ``Phi_k = sum_ij C_kij A_ij`` one product of a block of radii's ``A`` with
the coefficients; the exponentials are again one per mode and radius. The in-phase
bounds ``S_k`` (``|phi_k|`` is not a sum of products) come from a rectangle rule that
resolves the shapes but not the acoustic phase. :func:`plate_gains` takes this rule for
free and clamped plates when the rectangle rule's work exceeds
:data:`SUMMED_RULE_WORK` (``5e8``, above every preset's).

Cache
-----
:func:`plate_gains` computes the gains of a :class:`synth.sound.modes.Modes` and keeps
them in memory and on disk (``radiation-gains-*.npz`` beside the plate-mode cache,
``$SYNTH_CACHE_DIR`` if set), keyed by everything that determines them, so that a
scene rendered again (in this process or another) does not repeat the integral.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np
import scipy.special

from synth import checks
from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.io.cache import MemoryCache, cache_path, load_npz, savez_atomic
from synth.sound.modes import Modes, single_thread_product
from synth.vecmath import cis, exp_small

__all__ = [
    "RadiationResult",
    "rayleigh_gains",
    "separable_gains",
    "summed_gains",
    "plate_gains",
    "delay",
    "distance",
    "cache_info",
    "clear_memory_cache",
]


_MAX_ORDER = 24  # Gauss-Legendre points per axis of the longest panels, first rule
_REFINE = 1.25  # ratio of points per axis between successive rules (1.56 in 2-D)
_MAX_RULES = 7  # first rule and up to six refinements
_GRADING = 2.0  # near-field panel length / max(z, d)
_NEAR_RHO = 2.89  # Bernstein-ellipse parameter of the worst graded panel (see _min_order)
_COHERENT_FLOOR = 1e-4  # see the module docstring
_CHUNK_BYTES = 32e6  # one chunk of mode values, bytes
_TOL_RANGE = (1e-9, 0.1)


@dataclass(frozen=True)
class RadiationResult:
    """Gains of the Rayleigh integral and how they were obtained.

    Attributes
    ----------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)`` (times ``exp(s_k R0 / c)`` if a reference distance was
        given), Pa per (m/s) of modal velocity.
    error : ndarray of float, shape (n_modes,)
        Estimated absolute error of each gain, ``|H_fine - H_coarse|``, Pa s/m.
    coherent : ndarray of float, shape (n_modes,)
        ``S_k = (rho |s_k| / (2 pi)) Int |phi_k| / R dA``, an upper bound of
        ``|H_k|``, Pa s/m.
    n_points : int
        Number of quadrature points of the returned (finer) rule.
    refinements : int
        How many times the first rule was refined (by 1.25 in points per axis) to
        give the returned rule (1 when the first check passed).
    panels : (int, int)
        Number of panels along x and along y.
    success : bool
        Whether the convergence test passed for every mode.
    status : int
        0 converged; 1 stopped after the last refinement; 2 stopped at ``max_points``.
    message : str
        A sentence saying which.
    rule : str
        "rectangle" (:func:`rayleigh_gains`: panels along x and y) or "polar"
        (:func:`separable_gains`: radial panels about the microphone, and 0).
    """

    gains: np.ndarray
    error: np.ndarray
    coherent: np.ndarray
    n_points: int
    refinements: int
    panels: tuple[int, int]
    success: bool
    status: int
    message: str
    rule: str = "rectangle"


# ----------------------------------------------------------------------------------------
# Validation helpers


def _listener(listener_position) -> tuple[float, float, float]:
    x, y, z = checks.point("listener_position", listener_position, 3)
    if not z > 0.0:
        raise ParameterError(
            f"listener_position.z={z!r} must be > 0 (metres above the plate, on the air side)"
        )
    return x, y, z


def _size(size) -> tuple[float, float]:
    try:
        items = tuple(size)
    except TypeError:
        raise ParameterError(f"size={size!r} must be a pair (a, b) of lengths (metres)") from None
    if len(items) != 2:
        raise ParameterError(f"size={size!r} must be a pair (a, b) of lengths (metres)")
    return (
        checks.positive("size.a", items[0], "metres"),
        checks.positive("size.b", items[1], "metres"),
    )


def _poles(s) -> np.ndarray:
    try:
        arr = np.asarray(s)
    except Exception:  # noqa: BLE001 - anything numpy cannot read is bad input
        raise ParameterError(f"s={s!r} must be a 1-D array of complex poles (rad/s)") from None
    if arr.ndim != 1 or not (np.issubdtype(arr.dtype, np.number) and arr.dtype != bool):
        raise ParameterError(
            f"s (shape {arr.shape}, dtype {arr.dtype}) must be a 1-D numeric array "
            f"of complex poles (rad/s), one per mode"
        )
    arr = arr.astype(complex)
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ParameterError(f"s[{i}]={arr[i]!r} must be finite (rad/s)")
    return arr


# ----------------------------------------------------------------------------------------
# Gauss-Legendre rules and panels


@functools.cache
def _gauss(p: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(p)
    t.setflags(write=False)
    w.setflags(write=False)
    return t, w


@functools.lru_cache(maxsize=256)
def _half_phase(p: int, tol: float) -> float:
    """Largest ``w`` such that ``p``-point Gauss-Legendre integrates ``exp(i w' t)``
    on ``[-1, 1]`` with error ``<= tol`` times the interval length, for all ``w' <= w``."""
    t, wts = _gauss(p)
    omega = np.arange(1, 4000) * (0.005 * p)  # up to 20 p, beyond any useful panel
    quad = np.exp(1j * np.outer(omega, t)) @ wts
    err = np.abs(quad - 2.0 * np.sin(omega) / omega) / 2.0
    bad = np.flatnonzero(err > tol)
    return float(omega[bad[0] - 1]) if bad.size and bad[0] > 0 else float(omega[0])


def _breakpoints(length: float, centre: float, height: float, h: float) -> np.ndarray:
    """Panel ends on ``[0, length]``: at most ``h`` long, and at most ``2 max(height, d)``
    long where ``d`` is the distance from ``centre`` (the microphone's projection on this
    axis) to the panel's near end."""
    c = min(max(centre, 0.0), length)
    right = [c]
    t = c
    while t < length:
        d = abs(t - centre)
        t = min(t + min(h, _GRADING * max(height, d)), length)
        right.append(t)
    left = []
    t = c
    while t > 0.0:
        d = abs(centre - t)
        t = max(t - min(h, _GRADING * max(height, d)), 0.0)
        left.append(t)
    ends = np.array(left[::-1] + right)
    # a panel shorter than 1e-12 of the plate is a rounding artefact of the stepping
    keep = np.concatenate(([True], np.diff(ends) > 1e-12 * length))
    ends = ends[keep]
    ends[-1] = length
    ends[0] = 0.0
    return ends


def _min_order(tol: float) -> int:
    """Points per axis that resolve the 1/R peak on a graded panel to ``tol``.

    The worst graded panel, ``[0, 2 z]`` from the projection, has the complex
    singularity of ``1/R`` at ``-1 +- i`` in its own coordinate ``t in [-1, 1]``:
    the Bernstein ellipse through it has ``rho = 2.89``, and Gauss-Legendre's error
    decays as ``rho^(-2 p)``.
    """
    p = math.ceil(math.log(1.0 / tol) / (2.0 * math.log(_NEAR_RHO)))
    return min(max(p, 6), _MAX_ORDER)


def _panel_orders(ends: np.ndarray, kappa: float, tol: float) -> np.ndarray:
    """Fewest points per panel (first rule) integrating ``exp(i kappa x)`` to ``tol``."""
    lengths = np.diff(ends)
    p_min = _min_order(tol)
    orders = np.full(lengths.size, p_min, dtype=np.int64)
    for i, length in enumerate(lengths):
        w = 0.5 * kappa * length
        p = p_min
        while p < _MAX_ORDER and _half_phase(p, tol) < w:
            p += 1
        orders[i] = p
    return orders


def _nodes(ends: np.ndarray, orders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xs, ws = [], []
    for lo, hi, p in zip(ends[:-1], ends[1:], orders):
        t, w = _gauss(int(p))
        half = 0.5 * (hi - lo)
        xs.append(0.5 * (lo + hi) + half * t)
        ws.append(half * w)
    return np.concatenate(xs), np.concatenate(ws)


# ----------------------------------------------------------------------------------------
# Kernels
#
# Each accumulates, for a chunk of quadrature points j and every mode k,
#     acc_k += w_j phi_jk exp(-q_k (R_j - Rm)) / R_j,   q_k = s_k / c,
#     mag_k += w_j |phi_jk| / R_j,
# with Rm the middle of the range of R over the plate (the factor exp(-q_k Rm) is
# applied once per mode afterwards). exp(-q dR) = exp(-Re(q) dR) (cos - i sin)(Im(q) dR).
# The fast kernel uses the polynomial sin, cos and exp of synth.vecmath (the exp on
# |u| <= 1 squared up to 6 times: |Re(q) dR| <= 64), so that the loop over modes
# vectorises; the general kernel calls libm.


@numba.njit(cache=True, fastmath={"contract"}, inline="always")
def _exp_scaled(u, halvings):
    """exp(u 2^halvings) as exp(u)^(2^halvings) for |u| <= 1 and 0 <= halvings <= 6,
    the squarings as selects rather than a loop: a loop of variable length inside the
    loop over modes stops it from vectorising (the values are those of
    :func:`synth.vecmath.exp_squared`, bit for bit)."""
    e = exp_small(u)
    e = e * e if halvings >= 1 else e
    e = e * e if halvings >= 2 else e
    e = e * e if halvings >= 3 else e
    e = e * e if halvings >= 4 else e
    e = e * e if halvings >= 5 else e
    e = e * e if halvings >= 6 else e
    return e


@numba.njit(cache=True, fastmath={"contract"})
def _rows_fast(j0, j1, dist, wr, phi, qr, qi, halvings, acc_re, acc_im, mag):
    """Rayleigh sums over points ``j0 <= j < j1``.

    dist : (n,) R_j - Rm, metres; wr : (n,) w_j / R_j, metres; phi : (n, m) shapes;
    qr : (m,) Re(s_k / c) / 2^halvings, 1/m; qi : (m,) Im(s_k / c), 1/m; halvings : int
    in [0, 6]; acc_re, acc_im, mag : (m,) accumulators. Requires |qr_k dist_j| <= 1 and
    |qi_k dist_j| < 2^19 pi. exp(u) = exp(u / 2^J)^(2^J) (relative error <= 2^J ulp-ish).

    Points are taken four at a time (four independent evaluations per mode keep
    the vector units busy), their terms added to each accumulator in point order:
    the same sums, term by term, as one point at a time.
    """
    m = phi.shape[1]
    j = j0
    while j + 4 <= j1:
        d0, d1, d2, d3 = dist[j], dist[j + 1], dist[j + 2], dist[j + 3]
        w0, w1, w2, w3 = wr[j], wr[j + 1], wr[j + 2], wr[j + 3]
        r0, r1, r2, r3 = phi[j], phi[j + 1], phi[j + 2], phi[j + 3]
        for k in range(m):
            f0 = r0[k] * w0
            f1 = r1[k] * w1
            f2 = r2[k] * w2
            f3 = r3[k] * w3
            a0 = f0 * _exp_scaled(-qr[k] * d0, halvings)
            a1 = f1 * _exp_scaled(-qr[k] * d1, halvings)
            a2 = f2 * _exp_scaled(-qr[k] * d2, halvings)
            a3 = f3 * _exp_scaled(-qr[k] * d3, halvings)
            c0, s0 = cis(qi[k] * d0)
            c1, s1 = cis(qi[k] * d1)
            c2, s2 = cis(qi[k] * d2)
            c3, s3 = cis(qi[k] * d3)
            acc_re[k] = (((acc_re[k] + a0 * c0) + a1 * c1) + a2 * c2) + a3 * c3
            acc_im[k] = (((acc_im[k] - a0 * s0) - a1 * s1) - a2 * s2) - a3 * s3
            mag[k] = (((mag[k] + abs(f0)) + abs(f1)) + abs(f2)) + abs(f3)
        j += 4
    for j in range(j, j1):
        d = dist[j]
        w = wr[j]
        row = phi[j]
        for k in range(m):
            f = row[k] * w
            amp = f * _exp_scaled(-qr[k] * d, halvings)
            c, sn = cis(qi[k] * d)
            acc_re[k] += amp * c
            acc_im[k] -= amp * sn
            mag[k] += abs(f)


@numba.njit(cache=True)
def _rows_libm(j0, j1, dist, wr, phi, qr, qi, acc_re, acc_im, mag):
    """As :func:`_rows_fast` with ``halvings = 0``, with libm exp, cos and sin (any arguments)."""
    m = phi.shape[1]
    for j in range(j0, j1):
        d = dist[j]
        w = wr[j]
        row = phi[j]
        for k in range(m):
            f = row[k] * w
            amp = f * math.exp(-qr[k] * d)
            th = qi[k] * d
            acc_re[k] += amp * math.cos(th)
            acc_im[k] -= amp * math.sin(th)
            mag[k] += abs(f)


@numba.njit(cache=True, nogil=True)
def _accumulate(j0, j1, dist, wr, phi, qr, qi, halvings, acc_re, acc_im, mag):
    """Add the Rayleigh sums of points ``j0 <= j < j1`` to acc_re, acc_im, mag (see
    _rows_fast; ``halvings < 0``: the libm kernel). Runs without the GIL."""
    if halvings >= 0:
        _rows_fast(j0, j1, dist, wr, phi, qr, qi, halvings, acc_re, acc_im, mag)
    else:
        _rows_libm(j0, j1, dist, wr, phi, qr, qi, acc_re, acc_im, mag)


def _halvings(q: np.ndarray, spread: float) -> int:
    """Squarings of the fast kernel's exp for ``|Re(q) dR| <= |Re(q)| spread`` (Taylor on
    ``[-1, 1]``, then ``2^halvings``); -1 (the libm kernel) beyond 2^6 or for phases
    beyond the Cody-Waite range."""
    u_max = float(np.max(np.abs(q.real))) * spread
    halvings = max(0, math.ceil(math.log2(u_max))) if u_max > 0 else 0
    if halvings > 6 or float(np.max(np.abs(q.imag))) * spread >= 2.0**18:
        halvings = -1
    return halvings


# ----------------------------------------------------------------------------------------
# One rule


def _workers() -> int:
    """Threads that run the Rayleigh sums: one less than numba's thread count (at
    least one); the calling thread meanwhile evaluates the next chunk's shapes."""
    return max(1, numba.get_num_threads() - 1)


def _apply_rule(shape_fn, xs, wx, ys, wy, listener, q, r_mid, halvings, chunk):
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
                    _accumulate,
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


# ----------------------------------------------------------------------------------------
# Public API


def _check_settings(max_wavenumber, air_density, sound_speed, reference_distance, tol, max_points):
    """The settings shared by :func:`rayleigh_gains` and :func:`plate_gains`, checked:
    ``(kb rad/m, rho kg/m^3, c m/s, R0 m or None, tol)``; ``max_points`` must be a positive
    integer."""
    kb = checks.nonnegative("max_wavenumber", max_wavenumber, "rad/m")
    rho = checks.positive("air_density", air_density, "kg/m^3")
    c = checks.positive("sound_speed", sound_speed, "m/s")
    r0 = (
        None
        if reference_distance is None
        else checks.nonnegative("reference_distance", reference_distance, "metres")
    )
    tol = checks.in_range("tol", tol, _TOL_RANGE[0], _TOL_RANGE[1], lo_open=False, hi_open=False)
    if (
        isinstance(max_points, bool)
        or not isinstance(max_points, (int, np.integer))
        or max_points <= 0
    ):
        raise ParameterError(f"max_points={max_points!r} must be a positive integer")
    return kb, rho, c, r0, tol


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
        ``shape_fn(points) -> values``: ``points`` an ``(n, 2)`` float array of
        plate positions ``(x, y)``, metres from the corner; ``values`` an
        ``(n, n_modes)`` real array of the modes' normal-velocity shapes
        ``phi_k`` there (dimensionless: the surface velocity is ``phi_k u``).
        It is called on chunks of points (at most about 32 MB of values each);
        the returned array is read while the next chunk is evaluated, so it
        must not be reused for the next call's values.
    size : (float > 0, float > 0)
        ``(a, b)``: the plate's extent along x and y, metres.
    listener_position : (float, float, float)
        ``(x, y, z)`` of the microphone, metres; any ``x, y``; ``z > 0`` the
        height above the plate's plane (the air side of the baffle).
    s : array of complex, shape (n_modes,)
        The complex frequency of each mode, rad/s: ``i omega`` for a steady
        sinusoid, the pole ``-sigma_k + i omega_dk`` for a mode ringing freely.
    max_wavenumber : float >= 0
        Largest bending wavenumber of the modes, ``k_b = (omega^2 rho h / D)^(1/4)``,
        rad/m (0 for a rigid piston); sets the panel size with ``max|s| / c``.
    air_density : float > 0
        Density of air, kg/m^3.
    sound_speed : float > 0
        Speed of sound in air, m/s.
    reference_distance : float >= 0 or None
        ``R0``, metres. If given, the gains are ``H_k(s_k) exp(+s_k R0 / c)``: the
        transfer function with a pure delay ``R0 / c`` taken out (see :func:`distance`
        and :func:`delay`). None: ``H_k(s_k)`` itself.
    tol : float in [1e-9, 0.1]
        Relative accuracy of each gain (dimensionless), in the sense of the
        module docstring: ``|error| <= tol * max(|H_k|, 1e-4 S_k)``.
    max_points : int > 0
        Most quadrature points one rule may use; refinement stops there.
    full_output : bool
        If True return a :class:`RadiationResult` (gains, error estimates,
        success flag); if False return the gains alone, and warn
        (``RuntimeWarning``) if the convergence test failed.

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity ``u``; or a
        :class:`RadiationResult` if ``full_output``.

    Raises
    ------
    ParameterError
        For any input outside the ranges above (the message names the field),
        NaN or infinite shape values, or a plate needing more than ``max_points``
        points for the first two rules.

    Notes
    -----
    Cost: about ``1.6 N n_modes`` evaluations of ``phi exp(-s R / c) / R`` plus
    ``1.6 N`` points of ``shape_fn`` for the two rules, ``N`` the returned rule's
    points (``RadiationResult.n_points``; a few 10^4 for ``kappa ~ 800`` rad/m on
    a 0.5 x 0.4 m plate). A ``shape_fn`` returning a C-ordered (row per point)
    float64 array is used without a copy. For a damped pole the gain grows as
    ``exp(sigma R / c)``; with a distant microphone give ``reference_distance``
    so that only ``exp(sigma (R - R0) / c)`` remains.
    """
    if not callable(shape_fn):
        raise ParameterError(f"shape_fn={shape_fn!r} must be callable (points -> shape values)")
    a, b = _size(size)
    listener = _listener(listener_position)
    q_s = _poles(s)
    kb, rho, c, r0, tol = _check_settings(
        max_wavenumber, air_density, sound_speed, reference_distance, tol, max_points
    )
    m = q_s.size
    if m == 0:
        empty = np.zeros(0, complex)
        res = RadiationResult(empty, np.zeros(0), np.zeros(0), 0, 0, (0, 0), True, 0, "no modes")
        return res if full_output else empty

    q = q_s / c
    kappa = kb + float(np.max(np.abs(q)))
    xl, yl, zl = listener
    # Panels: oscillation (kappa) and the near-field peak under the microphone.
    tol_panel = 0.1 * tol
    w_half = _half_phase(_MAX_ORDER, tol_panel)
    h = 2.0 * w_half / kappa if kappa > 0 else math.inf
    p_min = _min_order(tol_panel)
    if (a / h) * (b / h) * p_min * p_min > max_points:  # before building the panels
        raise ParameterError(
            f"max_points={max_points!r} is too small: with max_wavenumber={kb!r} rad/m and "
            f"max|s|/c={kappa - kb:.6g} rad/m the plate needs more than "
            f"{(a / h) * (b / h) * p_min * p_min:.3g} points"
        )
    ex, ey, px0, py0 = _first_rule(a, b, listener, kappa, tol_panel)
    panels = (ex.size - 1, ey.size - 1)

    # Range of R over the plate: the middle is factored out of the exponentials.
    dx = (max(abs(xl), abs(xl - a)), max(0.0, -xl, xl - a))
    dy = (max(abs(yl), abs(yl - b)), max(0.0, -yl, yl - b))
    r_max = math.sqrt(dx[0] ** 2 + dy[0] ** 2 + zl * zl)
    r_min = math.sqrt(dx[1] ** 2 + dy[1] ** 2 + zl * zl)
    r_mid = 0.5 * (r_max + r_min)
    spread = 0.5 * (r_max - r_min)
    # exp(-Re(q) dR) with |Re(q) dR| <= u_max by Taylor on [-1, 1] and `halvings`
    # squarings; libm beyond 2^6 (or for phases beyond the Cody-Waite range).
    halvings = _halvings(q, spread)
    chunk = max(1, int(_CHUNK_BYTES // (8 * m)))

    def orders(level):
        f = _REFINE**level
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

    def rule(level):
        ox, oy = orders(level)
        xs, wx = _nodes(ex, ox)
        ys, wy = _nodes(ey, oy)
        return _apply_rule(shape_fn, xs, wx, ys, wy, listener, q, r_mid, halvings, chunk)

    # Per-mode factor rho s / (2 pi) exp(-s (Rm - R0) / c).
    shift = r_mid - (0.0 if r0 is None else r0)
    factor = rho * q_s / (2.0 * math.pi) * np.exp(-q * shift)
    scale = rho * np.abs(q_s) / (2.0 * math.pi)

    result = _refine(rule, npoints, factor, scale, tol, max_points, panels)
    if full_output:
        return result
    if not result.success:
        _warn_unconverged("rayleigh_gains", result, tol)
    return result.gains


def _first_rule(a, b, listener, kappa, tol_panel):
    """Panel ends and first-rule orders along x and y of :func:`rayleigh_gains`."""
    xl, yl, zl = listener
    w_half = _half_phase(_MAX_ORDER, tol_panel)
    h = 2.0 * w_half / kappa if kappa > 0 else math.inf
    ex = _breakpoints(a, xl, zl, h)
    ey = _breakpoints(b, yl, zl, h)
    return ex, ey, _panel_orders(ex, kappa, tol_panel), _panel_orders(ey, kappa, tol_panel)


def _next_rule_too_large(npoints, level: int, max_points: int) -> bool:
    """Whether a refinement after rule ``level`` exists and would exceed ``max_points``."""
    return level + 1 < _MAX_RULES and npoints(level + 1) > max_points


def _too_large_message(n_points: int, max_points: int) -> str:
    return f"stopped at {n_points} points: the next rule would exceed max_points={max_points}"


def _refine(rule, npoints, factor, scale, tol, max_points, panels) -> RadiationResult:
    """Successive rules ``rule(level)`` (-> integrals, in-phase integrals) compared
    until every mode passes the convergence test of the module docstring; the gains
    are ``factor`` times the integrals and the in-phase bounds ``scale`` times theirs."""
    coarse, _ = rule(0)
    status, message = 1, "stopped at the last refinement without meeting tol"
    for level in range(1, _MAX_RULES):
        fine, mag = rule(level)
        h_fine = factor * fine
        error = np.abs(factor * (fine - coarse))
        coherent = scale * mag
        allowed = tol * np.maximum(np.abs(h_fine), _COHERENT_FLOOR * coherent)
        n_points = npoints(level)
        if np.all(error <= allowed):
            status, message = 0, f"converged with {n_points} points (refinement {level})"
            break
        if _next_rule_too_large(npoints, level, max_points):
            status, message = 2, _too_large_message(n_points, max_points)
            break
        coarse = fine
    return RadiationResult(
        gains=h_fine,
        error=error,
        coherent=coherent,
        n_points=n_points,
        refinements=level,
        panels=panels,
        success=status == 0,
        status=status,
        message=message,
    )


def _refine_selective(rule, npoints, factor, scale, tol, max_points, panels) -> RadiationResult:
    """As :func:`_refine`, but a mode that passes the test keeps that rule's gain, error
    and bound, and only the modes still failing are evaluated on the next rule:
    ``rule(level, active)`` returns the integrals and in-phase integrals of the modes
    ``active`` (indices). Each mode's test is its own, so the accepted gains meet the
    same bound as with every mode refined together."""
    m = factor.size
    active = np.arange(m)
    coarse, _ = rule(0, active)
    gains = np.empty(m, complex)
    error = np.empty(m)
    coherent = np.empty(m)
    status, message = 1, "stopped at the last refinement without meeting tol"
    for level in range(1, _MAX_RULES):
        fine, mag = rule(level, active)
        f = factor[active]
        gains[active] = f * fine
        error[active] = np.abs(f * (fine - coarse))
        coherent[active] = scale[active] * mag
        allowed = tol * np.maximum(np.abs(gains[active]), _COHERENT_FLOOR * coherent[active])
        failing = error[active] > allowed
        n_points = npoints(level)
        if not failing.any():
            status, message = 0, f"converged with {n_points} points (refinement {level})"
            break
        if _next_rule_too_large(npoints, level, max_points):
            status, message = 2, _too_large_message(n_points, max_points)
            break
        active = active[failing]
        coarse = fine[failing]
    return RadiationResult(
        gains=gains,
        error=error,
        coherent=coherent,
        n_points=n_points,
        refinements=level,
        panels=panels,
        success=status == 0,
        status=status,
        message=message,
    )


def _warn_unconverged(caller: str, result: RadiationResult, tol: float) -> None:
    """RuntimeWarning naming the mode furthest from the convergence test."""
    allowed = tol * np.maximum(np.abs(result.gains), _COHERENT_FLOOR * result.coherent)
    worst = int(np.argmax(result.error / np.maximum(allowed, 1e-300)))
    warnings.warn(
        f"{caller}: {result.message} (mode {worst}: estimated error "
        f"{result.error[worst]:.3g} Pa s/m, allowed {allowed[worst]:.3g})",
        RuntimeWarning,
        stacklevel=3,
    )


# ----------------------------------------------------------------------------------------
# Separable shapes: the integral in polar coordinates about the microphone
#
# With r, theta polar coordinates in the plate's plane about the microphone's projection
# (xl, yl), R = sqrt(r^2 + z^2) depends on r alone, so
#     Int phi_k exp(-q R) / R dA = Int (r / R) exp(-q R) Phi_k(r) dr,
#     Phi_k(r) = Int phi_k(xl + r cos theta, yl + r sin theta) dtheta  (arcs inside the plate).
# Phi_k does not depend on q: for shapes X_i(x) Y_j(y) the angular sums of every mode at
# one radius are one matrix product, Phi = (X^T diag(w)) Y, and the radial sums take
# each mode's own exp(-q_k R) (the kernel above). The angular integrand oscillates at
# most at k_b r rad/rad (a shape's wavenumber is at most k_b), the radial one at most
# at k_b + |q|; the 1/R peak under the microphone is resolved by graded radial panels.
# Phi_k(r) is analytic in r between the radii where the set of arcs changes: at a
# radius where the circle touches an edge's line Phi_k behaves as sqrt(r - d) (the arc
# grows as sqrt), removed by r = d + L u^2 on the adjacent panel; at a corner's distance
# it has a kink, a panel end.


def _radial_segments(a: float, b: float, xl: float, yl: float):
    """``(r_min, r_max, singular, kinks)``: the range of distances from ``(xl, yl)`` to
    the plate, the radii (inside the range) where a circle touches an edge's line, and
    the corners' distances."""
    dx = max(0.0, -xl, xl - a)
    dy = max(0.0, -yl, yl - b)
    r_min = math.hypot(dx, dy)
    corners = [math.hypot(xl - cx, yl - cy) for cx in (0.0, a) for cy in (0.0, b)]
    r_max = max(corners)
    singular = sorted(
        {t for t in (abs(xl), abs(xl - a), abs(yl), abs(yl - b)) if t > 0.0 and r_min <= t < r_max}
    )
    kinks = sorted({t for t in corners if r_min < t < r_max})
    return r_min, r_max, singular, kinks


def _radial_panels(a, b, listener, h):
    """Radial panels ``(lo, hi, kind)``: ``kind`` 0 plain, +1 (-1) with the
    ``sqrt`` behaviour at ``lo`` (``hi``) removed by a quadratic substitution.
    At most ``h`` long and, from the microphone's projection, at most
    ``2 max(z, r)`` long (see :func:`_breakpoints`)."""
    xl, yl, zl = listener
    r_min, r_max, singular, kinks = _radial_segments(a, b, xl, yl)
    # breakpoints closer than 1e-12 r_max are one (rounding of equal distances)
    points = sorted(
        [(r_min, False), (r_max, False)]
        + [(t, True) for t in singular]
        + [(t, False) for t in kinks]
    )
    ends, sing = [], []
    for t, s in points:
        if ends and t - ends[-1] <= 1e-12 * r_max:
            sing[-1] = sing[-1] or s
        else:
            ends.append(t)
            sing.append(s)
    ends[-1] = r_max
    panels = []
    for t0, t1, lo_s, hi_s in zip(ends[:-1], ends[1:], sing[:-1], sing[1:]):
        pieces = [(t0, t1, lo_s, hi_s)]
        if lo_s and hi_s:
            mid = 0.5 * (t0 + t1)
            pieces = [(t0, mid, True, False), (mid, t1, False, True)]
        for p0, p1, s0, s1 in pieces:
            cuts = [p0]
            t = p0
            while t < p1:
                t = min(t + min(h, _GRADING * max(zl, t)), p1)
                cuts.append(t)
            # a substituted panel doubles the phase per unit of its variable: h / 2 long
            if s0 and cuts[1] - p0 > 0.5 * h:
                cuts.insert(1, p0 + 0.5 * h)
            if s1 and p1 - cuts[-2] > 0.5 * h:
                cuts.insert(len(cuts) - 1, p1 - 0.5 * h)
            cuts = np.array(cuts)
            keep = np.concatenate(([True], np.diff(cuts) > 1e-12 * r_max))
            cuts = cuts[keep]
            cuts[-1] = p1
            n = cuts.size - 1
            for i in range(n):
                kind = 1 if (s0 and i == 0) else (-1 if (s1 and i == n - 1) else 0)
                panels.append((float(cuts[i]), float(cuts[i + 1]), kind))
    return panels


def _panel_phase(lo, hi, kind, tangents, kb, qa, z):
    """Largest phase change (rad) over a radial panel of the polar integrand's terms.

    ``exp(-q R)`` turns by at most ``|q| (R(hi) - R(lo))``; a shape's plane waves by
    at most ``k_b`` per metre of radius inside the arcs, and by ``k_b`` per metre that
    an arc's end travels along an edge's line at distance ``d``
    (``sqrt(r^2 - d^2)``, much faster than ``r`` just beyond ``d``). A substituted
    panel (``kind != 0``) is taken as twice as long in radius (``dr/du <= 2 L``).
    """
    stretch = 1.0 if kind == 0 else 2.0
    travel = max(
        (
            math.sqrt(max(hi * hi - d * d, 0.0)) - math.sqrt(max(lo * lo - d * d, 0.0))
            for d in tangents
        ),
        default=0.0,
    )
    big = math.hypot(hi, z) - math.hypot(lo, z)
    return stretch * qa * big + kb * max(stretch * (hi - lo), travel)


def _radial_orders(panels, size, listener, kb, qa, tol):
    """Panels split until each one's phase (:func:`_panel_phase`) is integrated to
    ``tol`` by at most ``_MAX_ORDER`` points, and their first-rule orders."""
    a, b = size
    xl, yl, _ = listener
    tangents = (abs(xl), abs(xl - a), abs(yl), abs(yl - b))
    w_max = _half_phase(_MAX_ORDER, tol)
    p_min = _min_order(tol)
    todo = list(reversed(panels))
    out, orders = [], []
    while todo:
        lo, hi, kind = todo.pop()
        half = 0.5 * _panel_phase(lo, hi, kind, tangents, kb, qa, listener[2])
        if half > w_max and hi - lo > 1e-9 * hi:
            mid = 0.5 * (lo + hi)
            todo.append((mid, hi, -1 if kind < 0 else 0))
            todo.append((lo, mid, 1 if kind > 0 else 0))
            continue
        out.append((lo, hi, kind))
        orders.append(_fewest_points(half, tol, p_min))
    return out, np.array(orders, dtype=np.int64)


def _fewest_points(phase: float, tol: float, p_min: int) -> int:
    """Fewest Gauss-Legendre points (at least ``p_min``, at most ``_MAX_ORDER``) that
    integrate ``exp(i w t)``, ``|w| <= phase``, on ``[-1, 1]`` to ``tol``."""
    p = p_min
    while p < _MAX_ORDER and _half_phase(p, tol) < phase:
        p += 1
    return p


def _radial_nodes(panels, orders):
    """Radii (m) and weights of ``Int f(r) dr`` on the panels (substitutions applied)."""
    rs, ws = [], []
    for (lo, hi, kind), p in zip(panels, orders):
        t, w = _gauss(int(p))
        u = 0.5 * (t + 1.0)
        length = hi - lo
        if kind == 0:
            rs.append(lo + length * u)
            ws.append(0.5 * length * w)
        elif kind > 0:
            rs.append(lo + length * u * u)
            ws.append(length * u * w)  # dr = 2 L u du, du = dt / 2
        else:
            rs.append(hi - length * (1.0 - u) ** 2)
            ws.append(length * (1.0 - u) * w)
    return np.concatenate(rs), np.concatenate(ws)


def _arcs(r: float, a: float, b: float, xl: float, yl: float) -> list:
    """Angular intervals ``(theta0, theta1)`` of the circle of radius ``r`` about
    ``(xl, yl)`` that lie on the plate ``[0, a] x [0, b]``."""
    two_pi = 2.0 * math.pi
    cuts = [0.0, two_pi]
    for c in (-xl, a - xl):
        cos_t = c / r
        if -1.0 < cos_t < 1.0:
            t = math.acos(cos_t)
            cuts += [t, two_pi - t]
    for d in (-yl, b - yl):
        sin_t = d / r
        if -1.0 < sin_t < 1.0:
            t = math.asin(sin_t)
            cuts += [t % two_pi, (math.pi - t) % two_pi]
    cuts.sort()
    arcs = []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        if hi - lo <= 1e-15:
            continue
        mid = 0.5 * (lo + hi)
        x, y = xl + r * math.cos(mid), yl + r * math.sin(mid)
        if 0.0 <= x <= a and 0.0 <= y <= b:
            if arcs and arcs[-1][1] == lo:
                arcs[-1] = (arcs[-1][0], hi)
            else:
                arcs.append((lo, hi))
    return arcs


_ANGLE_MIN_ORDER = 4  # Gauss-Legendre points of the shortest angular panels
# Panel accuracy of the polar rule, relative to tol (as the rectangle rule's).
_POLAR_PANEL_TOL = 0.1


@functools.lru_cache(maxsize=4096)
def _angular_band(x: float, tol: float) -> int:
    """Fewest Fourier orders ``N >= x`` beyond which ``|J_n(x)| <= tol`` (``n >= N``).

    A plane wave of wavenumber ``k <= k_b`` on a circle of radius ``r`` is
    ``exp(i k r cos(theta - theta_k)) = sum_n i^n J_n(k r) exp(i n (theta - theta_k))``,
    and ``|J_n(k r)| <= |J_n(k_b r)|`` decreases in ``n`` past ``k_b r``: a shape made
    of such waves is, to ``tol``, a trigonometric polynomial of degree ``N``.
    """
    n = np.arange(math.floor(x), math.floor(x) + 64 + int(8 * x ** (1.0 / 3.0)))
    small = np.flatnonzero(np.abs(scipy.special.jv(n, x)) <= tol)
    return int(n[small[0]]) if small.size else int(n[-1])


def _angular_rule(r, a, b, listener, kb, tol, refine):
    """Angles (rad) and weights of ``Int f(theta) dtheta`` over the arcs of radius ``r``
    on the plate, for shapes made of plane waves of wavenumbers at most ``kb``
    (:func:`_angular_band`); orders times ``refine``."""
    xl, yl, _ = listener
    arcs = _arcs(r, a, b, xl, yl)
    # kb r rounded up to an integer so that neighbouring radii share the computation
    rate = float(_angular_band(float(math.ceil(kb * r)), tol))
    w24 = _half_phase(_MAX_ORDER, tol)
    h = 2.0 * w24 / rate if rate > 0 else math.inf
    ts, ws = [], []
    for lo, hi in arcs:
        n = max(1, math.ceil((hi - lo) / h))
        ends = np.linspace(lo, hi, n + 1)
        p = math.ceil(_fewest_points(0.5 * rate * (hi - lo) / n, tol, _ANGLE_MIN_ORDER) * refine)
        t, w = _gauss(p)
        half = 0.5 * (ends[1:] - ends[:-1])
        mid = 0.5 * (ends[1:] + ends[:-1])
        ts.append((mid[:, None] + half[:, None] * t[None, :]).ravel())
        ws.append((half[:, None] * w[None, :]).ravel())
    if not ts:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(ts), np.concatenate(ws)


# Modes times this below the factor pairs of a separable rule: angular sums mode by mode
# (gathered factors, about this many times slower per multiply-add than a matrix product).
_DIRECT_RATIO = 10


def _apply_separable_rule(
    sep, size, listener, radii, wr, kb, tol, refine, q, r_mid, halvings, active
):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` of the separable shapes ``k``
    in ``active`` (indices), and the number of points, by the polar rule (radii
    ``radii`` with weights ``wr``). Only the factors those modes use enter the angular
    products."""
    a, b = size
    xl, yl, zl = listener
    m = active.size
    rows_x, xi = np.unique(sep.x_index[active], return_inverse=True)
    rows_y, yi = np.unique(sep.y_index[active], return_inverse=True)
    q = q[active]
    acc_re, acc_im, unused = np.zeros(m), np.zeros(m), np.zeros(m)
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    rows = max(1, int(_CHUNK_BYTES // (8 * m)))
    n_points = 0
    sums = np.empty((rows_x.size, rows_y.size))
    # few modes (a refinement of the failing ones): each mode's own angular sum costs
    # less than the product of every pair of their factors
    direct = _DIRECT_RATIO * m < rows_x.size * rows_y.size
    for start in range(0, radii.size, rows):
        rr = radii[start : start + rows]
        phi = np.empty((rr.size, m))
        for i, r in enumerate(rr):
            theta, w = _angular_rule(float(r), a, b, listener, kb, tol, refine)
            n_points += theta.size
            if theta.size == 0:
                phi[i] = 0.0
                continue
            x = np.clip(xl + r * np.cos(theta), 0.0, a)
            y = np.clip(yl + r * np.sin(theta), 0.0, b)
            fx = sep.x_values(x, rows_x)
            fy = np.ascontiguousarray(sep.y_values(y, rows_y))
            if direct:
                phi[i] = w @ (fx[:, xi] * fy[:, yi])
            else:
                single_thread_product(np.ascontiguousarray((fx * w[:, None]).T), fy, sums)
                phi[i] = sums[xi, yi]
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        dist = big_r - r_mid
        _accumulate(0, rr.size, dist, weight, phi, qr, qi, halvings, acc_re, acc_im, unused)
    total = acc_re + 1j * acc_im
    if not np.isfinite(total).all():
        k = int(active[np.flatnonzero(~np.isfinite(total))[0]])
        raise ParameterError(f"separable shapes gave NaN or infinite values for mode {k}")
    return total, n_points


def _separable_in_phase(sep, size, listener, kb, tol):
    """``Int |phi_k| / R dA`` of separable shapes on the refined rectangle rule of
    wavenumber ``2 kb`` (as :func:`_summed_in_phase`): with ``|phi_k| = |X_i| |Y_j|``
    one matrix product for every mode, ``|X|^T W |Y|``, ``W`` the grid's weights over
    ``R``."""
    a, b = size
    xl, yl, zl = listener
    ex, ey, px0, py0 = _first_rule(a, b, listener, 2.0 * kb, tol)
    xs, wx = _nodes(ex, np.ceil(px0 * _REFINE).astype(np.int64))
    ys, wy = _nodes(ey, np.ceil(py0 * _REFINE).astype(np.int64))
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
    if not np.isfinite(mag).all():
        k = int(np.flatnonzero(~np.isfinite(mag))[0])
        raise ParameterError(f"separable shapes gave NaN or infinite values for mode {k}")
    return mag


@dataclass(frozen=True)
class _PolarSetup:
    """What a polar rule about the microphone needs (see :func:`separable_gains`): the
    plate's size (m), the listener (m), the settings as :func:`_check_settings` returns
    them, ``q = s / c`` (1/m), the panel tolerance, the radial panels and their first
    orders, the middle distance ``r_mid`` (m) and the exponentials' halvings."""

    size: tuple
    listener: tuple
    q_s: np.ndarray
    kb: float
    rho: float
    c: float
    r0: float | None
    tol: float
    max_points: int
    q: np.ndarray
    tol_panel: float
    panels: list
    orders: np.ndarray
    r_mid: float
    halvings: int


def _polar_setup(
    size,
    n_modes,
    listener_position,
    s,
    max_wavenumber,
    air_density,
    sound_speed,
    reference_distance,
    tol,
    max_points,
) -> _PolarSetup:
    """The arguments of a polar rule checked (a ParameterError names the field), and its
    radial panels about the listener (none without modes)."""
    a, b = size
    listener = _listener(listener_position)
    q_s = _poles(s)
    if q_s.size != n_modes:
        raise ParameterError(
            f"s has {q_s.size} poles for {n_modes} modes: one complex "
            f"frequency (rad/s) per mode is needed"
        )
    kb, rho, c, r0, tol = _check_settings(
        max_wavenumber, air_density, sound_speed, reference_distance, tol, max_points
    )
    q = q_s / c
    tol_panel = _POLAR_PANEL_TOL * tol
    if q.size == 0:
        return _PolarSetup(
            size, listener, q_s, kb, rho, c, r0, tol, max_points, q, tol_panel, [], None, 0.0, 0
        )
    kappa = kb + float(np.max(np.abs(q)))
    h = 2.0 * _half_phase(_MAX_ORDER, tol_panel) / kappa if kappa > 0 else math.inf
    xl, yl, zl = listener
    panels, orders0 = _radial_orders(
        _radial_panels(a, b, listener, h), (a, b), listener, kb, kappa - kb, tol_panel
    )
    r_min, r_max, _, _ = _radial_segments(a, b, xl, yl)
    big_min, big_max = math.hypot(r_min, zl), math.hypot(r_max, zl)
    r_mid = 0.5 * (big_min + big_max)
    halvings = _halvings(q, 0.5 * (big_max - big_min))
    return _PolarSetup(
        size,
        listener,
        q_s,
        kb,
        rho,
        c,
        r0,
        tol,
        max_points,
        q,
        tol_panel,
        panels,
        orders0,
        r_mid,
        halvings,
    )


def _polar_gains(setup: _PolarSetup, rule, caller: str, full_output: bool, selective=False):
    """The gains of a polar rule, refined until converged (:func:`_refine`). ``rule(level)``
    applies the rule refined ``level`` times and returns its integrals, their in-phase
    bounds and its number of points; with ``selective``, ``rule(level, active)`` does so
    for the modes ``active`` alone (:func:`_refine_selective`)."""
    if setup.q.size == 0:
        empty = np.zeros(0, complex)
        res = RadiationResult(empty, np.zeros(0), np.zeros(0), 0, 0, (0, 0), True, 0, "no modes")
        return res if full_output else empty
    counts = {}

    def counted(level, *active):
        total, mag, points = rule(level, *active)
        counts.setdefault(level, points)
        return total, mag

    def npoints(level):
        if level in counts:
            return counts[level]
        known = max(counts)  # not yet applied: points grow as 1.25^2 per level
        return int(counts[known] * _REFINE ** (2 * (level - known)))

    q_s, q, rho = setup.q_s, setup.q, setup.rho
    shift = setup.r_mid - (0.0 if setup.r0 is None else setup.r0)
    factor = rho * q_s / (2.0 * math.pi) * np.exp(-q * shift)
    scale = rho * np.abs(q_s) / (2.0 * math.pi)
    result = dataclasses.replace(
        (_refine_selective if selective else _refine)(
            counted,
            npoints,
            factor,
            scale,
            setup.tol,
            setup.max_points,
            (len(setup.panels), 0),
        ),
        rule="polar",
    )
    if full_output:
        return result
    if not result.success:
        _warn_unconverged(caller, result, setup.tol)
    return result.gains


def separable_gains(
    shapes,
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
    """:func:`rayleigh_gains` of shapes ``X_i(x) Y_j(y)``, in polar coordinates.

    Parameters
    ----------
    shapes : synth.sound.modes.SeparableShapes
        The modes' shapes (see :meth:`synth.sound.modes.Modes.separable`) and the
        plate's size.
    listener_position, s, max_wavenumber, air_density, sound_speed
        As for :func:`rayleigh_gains` (``max_wavenumber`` bounds every shape's
        wavenumber, rad/m).
    reference_distance, tol, max_points, full_output
        As for :func:`rayleigh_gains` (``max_points`` counts the points of one rule).

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity; or a :class:`RadiationResult`
        (``panels`` holds the radial panels and 0).

    Notes
    -----
    The same integral, tolerance and convergence test (successive rules with 1.25
    times the points per axis, the error estimate their difference) as
    :func:`rayleigh_gains`; only the rule differs: polar coordinates about the
    microphone (see the comment above :func:`_radial_segments`). The angular sums
    of all modes at one radius are one matrix product of ``X`` and ``Y`` values,
    and the radial sums cost one exponential per mode and radius: about
    ``N_theta I J + N_r n_modes`` operations per rule (``N_theta`` the points,
    ``N_r`` the radii, ``I, J`` the numbers of factors) instead of
    ``N n_modes`` exponentials. Measured on a simply supported 1.86 m square
    plate to 22 kHz (34 161 modes): see ``synth bench scale``.
    """
    from synth.sound.modes import SeparableShapes

    if not isinstance(shapes, SeparableShapes):
        raise ParameterError(f"shapes={shapes!r} must be a synth.sound.modes.SeparableShapes")
    setup = _polar_setup(
        (shapes.length, shapes.width),
        shapes.x_index.size,
        listener_position,
        s,
        max_wavenumber,
        air_density,
        sound_speed,
        reference_distance,
        tol,
        max_points,
    )

    if setup.q.size == 0:
        return _polar_gains(setup, None, "separable_gains", full_output)
    in_phase = _separable_in_phase(shapes, setup.size, setup.listener, setup.kb, setup.tol_panel)

    def rule(level, active):
        f = _REFINE**level
        radii, wr = _radial_nodes(setup.panels, np.ceil(setup.orders * f).astype(np.int64))
        total, n = _apply_separable_rule(
            shapes,
            setup.size,
            setup.listener,
            radii,
            wr,
            setup.kb,
            setup.tol_panel,
            f,
            setup.q,
            setup.r_mid,
            setup.halvings,
            active,
        )
        return total, in_phase[active], n

    return _polar_gains(setup, rule, "separable_gains", full_output, selective=True)


# ----------------------------------------------------------------------------------------
# Sums of separable shapes (free and clamped plates): the polar rule, one matrix of
# angular sums per radius for every mode
#
# For phi_k = sum_ij C_kij X_i(x) Y_j(y) the angular integral at radius r is
#     Phi_k(r) = sum_ij C_kij A_ij(r),   A(r) = X^T diag(w) Y  (the arc's points),
# one small matrix product per radius whatever the number of modes, then one product
# of the radii's A (flattened) with the coefficients for a block of radii
# (SummedShapes.combine). The in-phase integrals Int |phi_k| / R dA are not sums of
# products; they only set the tolerance floor and the bound S_k, and are taken once on
# a rectangle rule sized for twice the shapes' wavenumber k_b (and the 1/R peak) but not
# for the acoustic phase, which |phi_k| / R does not carry: |phi_k| has kinks on the
# nodal lines, which such a rule integrates to about 2 % (measured against rules 4 and
# 8 times finer; tests compare it with the full rectangle rule).


def _apply_summed_rule(shapes, size, listener, radii, wr, kb, tol, refine, q, r_mid, halvings):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` of summed shapes by the polar
    rule (radii ``radii`` with weights ``wr``), and the number of points."""
    a, b = size
    xl, yl, zl = listener
    m = q.size
    acc_re, acc_im, unused = np.zeros(m), np.zeros(m), np.zeros(m)
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    rows = max(1, int(_CHUNK_BYTES // (8 * max(m, shapes.n_x * shapes.n_y))))
    n_points = 0
    for start in range(0, radii.size, rows):
        rr = radii[start : start + rows]
        sums = np.zeros((rr.size, shapes.n_x, shapes.n_y))
        for i, r in enumerate(rr):
            theta, w = _angular_rule(float(r), a, b, listener, kb, tol, refine)
            n_points += theta.size
            if theta.size:
                fx = shapes.x_values(np.clip(xl + r * np.cos(theta), 0.0, a))
                fy = shapes.y_values(np.clip(yl + r * np.sin(theta), 0.0, b))
                single_thread_product(np.ascontiguousarray((fx * w[:, None]).T), fy, sums[i])
        phi = shapes.combine(sums)
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        _accumulate(
            0, rr.size, big_r - r_mid, weight, phi, qr, qi, halvings, acc_re, acc_im, unused
        )
    return acc_re + 1j * acc_im, n_points


def _summed_in_phase(shapes, size, listener, kb, tol, r_mid):
    """``Int |phi_k| / R dA`` of summed shapes on the refined rectangle rule of
    wavenumber ``2 kb`` (panels and orders of :func:`rayleigh_gains` without the
    acoustic phase)."""
    a, b = size
    m = shapes.n_modes
    ex, ey, px0, py0 = _first_rule(a, b, listener, 2.0 * kb, tol)
    xs, wx = _nodes(ex, np.ceil(px0 * _REFINE).astype(np.int64))
    ys, wy = _nodes(ey, np.ceil(py0 * _REFINE).astype(np.int64))
    chunk = max(1, int(_CHUNK_BYTES // (8 * max(m, 1))))
    _, mag = _apply_rule(
        shapes.values, xs, wx, ys, wy, listener, np.zeros(m, complex), r_mid, 0, chunk
    )
    return mag


def summed_gains(
    shapes,
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
    """:func:`rayleigh_gains` of shapes ``sum_ij C_kij X_i(x) Y_j(y)``, in polar coordinates.

    Parameters
    ----------
    shapes : synth.sound.modes.SummedShapes
        The modes' shapes (see :meth:`synth.sound.modes.Modes.summed`) and the
        plate's size.
    listener_position, s, max_wavenumber, air_density, sound_speed
        As for :func:`rayleigh_gains` (``max_wavenumber`` bounds every shape's
        wavenumber, rad/m).
    reference_distance, tol, max_points, full_output
        As for :func:`rayleigh_gains` (``max_points`` counts the points of one rule).

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity; or a :class:`RadiationResult`
        (``rule`` "polar", ``panels`` the radial panels and 0).

    Notes
    -----
    The rule, tolerance and convergence test of :func:`separable_gains`; only the
    angular sums differ (see the comment above :func:`_apply_summed_rule`): about
    ``N_theta n_x n_y + N_r n_basis n_modes / 4`` multiply-adds per rule (matrix
    products; ``N_r`` radii, ``N_theta`` points, ``n_basis`` the Ritz unknowns)
    and ``N_r n_modes`` exponentials, against ``N n_modes`` exponentials and shape
    values for the rectangle rule's ``N`` points. The in-phase bounds ``S_k``
    (``RadiationResult.coherent``) come from a rectangle rule that resolves the
    shapes alone, to about 2 %. Measured at 384 kHz: see ``synth bench render``.
    """
    from synth.sound.modes import SummedShapes

    if not isinstance(shapes, SummedShapes):
        raise ParameterError(f"shapes={shapes!r} must be a synth.sound.modes.SummedShapes")
    setup = _polar_setup(
        (shapes.length, shapes.width),
        shapes.n_modes,
        listener_position,
        s,
        max_wavenumber,
        air_density,
        sound_speed,
        reference_distance,
        tol,
        max_points,
    )
    if setup.q.size == 0:
        return _polar_gains(setup, None, "summed_gains", full_output)
    in_phase = _summed_in_phase(
        shapes, setup.size, setup.listener, setup.kb, setup.tol_panel, setup.r_mid
    )

    def rule(level):
        f = _REFINE**level
        radii, wr = _radial_nodes(setup.panels, np.ceil(setup.orders * f).astype(np.int64))
        total, n = _apply_summed_rule(
            shapes,
            setup.size,
            setup.listener,
            radii,
            wr,
            setup.kb,
            setup.tol_panel,
            f,
            setup.q,
            setup.r_mid,
            setup.halvings,
        )
        return total, in_phase, n

    return _polar_gains(setup, rule, "summed_gains", full_output)


# ----------------------------------------------------------------------------------------
# Gains of a plate's modes, cached in memory and on disk


_CACHE_VERSION = 1  # layout of the stored gains and the algorithm; part of the key
_CACHE = MemoryCache("computations", max_entries=32)  # least recently used dropped


def cache_info() -> dict:
    """Counters of the gain cache of :func:`plate_gains` since start-up (or
    :func:`clear_memory_cache`).

    Returns
    -------
    dict
        ``computations`` (Rayleigh integrals evaluated), ``memory_hits``,
        ``disk_hits`` (results read from disk), ``disk_writes``, and ``entries``
        (results held in memory).
    """
    return _CACHE.info()


def clear_memory_cache() -> None:
    """Forget the gains held in memory and reset the counters (disk untouched)."""
    _CACHE.clear()


def _gains_key(modes, listener, s, kb, rho, c, r0, tol, max_points, polar=False) -> str:
    """Everything that determines the gains of :func:`plate_gains`, as canonical JSON
    (``polar``: computed by :func:`separable_gains`)."""
    extra = {"rule": "polar"} if polar else {}
    return json.dumps(
        {
            **extra,
            "version": _CACHE_VERSION,
            "shapes": modes.shape_key,
            "listener": [float(v).hex() for v in listener],
            "poles": hashlib.sha256(
                np.ascontiguousarray(s, dtype=np.complex128).tobytes()
            ).hexdigest(),
            "n_poles": int(s.size),
            "max_wavenumber": float(kb).hex(),
            "air_density": float(rho).hex(),
            "sound_speed": float(c).hex(),
            "reference_distance": None if r0 is None else float(r0).hex(),
            "tol": float(tol).hex(),
            "max_points": int(max_points),
            "quadrature": [_MAX_ORDER, _REFINE, _MAX_RULES, _GRADING, _NEAR_RHO, _COHERENT_FLOOR],
        },
        sort_keys=True,
    )


def _gains_path(key: str) -> Path:
    return cache_path("radiation-gains", key)


def _save_gains(result: RadiationResult, key: str) -> None:
    """Write ``result`` to the disk cache (atomically); skipped if impossible."""
    arrays = {
        "key": np.array(key),
        "gains": result.gains,
        "error": result.error,
        "coherent": result.coherent,
        "n_points": np.array(result.n_points),
        "refinements": np.array(result.refinements),
        "panels": np.array(result.panels),
        "status": np.array(result.status),
        "message": np.array(result.message),
        "rule": np.array(result.rule),
    }
    try:
        path = _gains_path(key)
    except RuntimeError:  # no home directory
        return
    if savez_atomic(path, arrays):
        _CACHE.count("disk_writes")


def _load_gains(key: str, m: int):
    """The stored result for ``key`` (``m`` modes), or None if absent, unreadable or
    inconsistent."""
    try:
        path = _gains_path(key)
        if not path.is_file():
            return None
        with load_npz(path) as z:
            if str(z["key"][()]) != key:
                return None
            gains, error, coherent = z["gains"], z["error"], z["coherent"]
            n_points, refinements = int(z["n_points"][()]), int(z["refinements"][()])
            panels, status, message = z["panels"], int(z["status"][()]), str(z["message"][()])
            rule = str(z["rule"][()]) if "rule" in z.files else "rectangle"
        ok = (
            gains.dtype == np.complex128
            and gains.shape == (m,)
            and error.shape == (m,)
            and coherent.shape == (m,)
            and panels.shape == (2,)
            and np.all(np.isfinite(gains))
            and np.all(np.isfinite(error))
            and np.all(np.isfinite(coherent))
            and status in (0, 1, 2)
            and n_points >= 0
            and refinements >= 0
            and rule in ("rectangle", "polar")
        )
        if not ok:
            return None
        return _frozen(
            RadiationResult(
                gains,
                error.astype(float),
                coherent.astype(float),
                n_points,
                refinements,
                (int(panels[0]), int(panels[1])),
                status == 0,
                status,
                message,
                rule,
            )
        )
    except Exception:  # noqa: BLE001 - any unreadable cache file is recomputed and rewritten
        return None


def _frozen(result: RadiationResult) -> RadiationResult:
    """``result`` with read-only arrays (it is shared between callers)."""
    for arr in (result.gains, result.error, result.coherent):
        arr.setflags(write=False)
    return result


# Work of the rectangle rule (modes times points of its first rule, estimated from its
# longest panels) above which a plate
# with separable shapes takes the polar rule of separable_gains. Below it the rectangle
# rule takes at most a few seconds and is kept: its gains (the polar rule's agree to
# tol, not to the last bit) are those the presets' recorded renders were made with
# (the largest simply supported preset, 550 modes at 48 kHz, is 3.6e7).
_POLAR_WORK = 5e7


def _use_separable(modes, size, listener, q_s, kb, c, tol):
    """The modes' :class:`~synth.sound.modes.SeparableShapes` if :func:`plate_gains`
    should use :func:`separable_gains`, else None."""
    shapes = modes.separable()
    if shapes is None or q_s.size == 0:
        return None
    return shapes if _rectangle_work(size, q_s, kb, c, tol) > _POLAR_WORK else None


#: Rectangle-rule work (modes times points, as for ``_POLAR_WORK``) above which a free or
#: clamped plate takes the polar rule of :func:`summed_gains`. Above every preset's (at
#: most 3.4e8, a free wooden table at 48 kHz: their recorded renders were made with the
#: rectangle rule), below the default board's at 192 kHz (7e8). ``math.inf``: never.
SUMMED_RULE_WORK = 5e8


def _rectangle_work(size, q_s, kb, c, tol) -> float:
    """Modes times points of the rectangle rule's first rule, estimated from its
    longest panels (24 points each, ``2 w24 / kappa`` long)."""
    kappa = kb + float(np.max(np.abs(q_s))) / c
    per_metre = _MAX_ORDER * kappa / (2.0 * _half_phase(_MAX_ORDER, 0.1 * tol))
    return float(q_s.size) * (size[0] * per_metre + 1.0) * (size[1] * per_metre + 1.0)


def _use_summed(modes, size, q_s, kb, c, tol):
    """The modes' :class:`~synth.sound.modes.SummedShapes` if :func:`plate_gains`
    should use :func:`summed_gains`, else None."""
    if q_s.size == 0 or _rectangle_work(size, q_s, kb, c, tol) <= SUMMED_RULE_WORK:
        return None
    return modes.summed()


def plate_gains(
    modes,
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
    cache=True,
):
    """:func:`rayleigh_gains` of a plate's modes, cached in memory and on disk.

    Parameters
    ----------
    modes : synth.sound.modes.Modes
        The plate's modes; their :meth:`~synth.sound.modes.Modes.shapes` are the
        normal-velocity shapes and the plate's length and width the size.
    listener_position, s, max_wavenumber, air_density, sound_speed, reference_distance, tol,
    max_points, full_output
        As for :func:`rayleigh_gains` (``s`` one complex frequency per mode, rad/s).
    cache : bool
        Reuse and store the result (memory and disk). ``False`` computes afresh
        and stores nothing.

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity (read-only); or a
        :class:`RadiationResult` if ``full_output``.

    Raises
    ------
    ParameterError
        If ``modes`` is not a :class:`~synth.sound.modes.Modes`, ``s`` does not have one
        entry per mode, ``cache`` is not a bool, or as :func:`rayleigh_gains`.

    Notes
    -----
    The result is stored under a key made of everything that determines it:
    :attr:`~synth.sound.modes.Modes.shape_key` (the plate's size and eigen-solution),
    the listener position, the poles ``s`` (exact bytes), the maximum wavenumber,
    the air constants, the reference distance, ``tol``, ``max_points`` and the
    quadrature's settings. Files ``radiation-gains-*.npz`` sit beside the mode
    cache (:func:`synth.sound.modes.cache_dir`, ``$SYNTH_CACHE_DIR``) and are written
    atomically; an unreadable or inconsistent file is ignored and rewritten. A
    result loaded from disk equals the computed one exactly (the
    convergence warning, if any, is repeated).
    """
    if not isinstance(modes, Modes):
        raise ParameterError(f"modes={modes!r} must be a synth.sound.modes.Modes")
    if not isinstance(cache, bool):
        raise ParameterError(f"cache={cache!r} must be True or False")
    listener = _listener(listener_position)
    q_s = _poles(s)
    if q_s.size != len(modes):
        raise ParameterError(
            f"s has {q_s.size} poles for {len(modes)} modes: one complex frequency (rad/s) "
            f"per mode is needed"
        )
    kb, rho, c, r0, tol = _check_settings(
        max_wavenumber, air_density, sound_speed, reference_distance, tol, max_points
    )

    size = (modes.plate.length, modes.plate.width)
    separable = _use_separable(modes, size, listener, q_s, kb, c, tol)
    summed = None if separable is not None else _use_summed(modes, size, q_s, kb, c, tol)

    def compute():
        if summed is not None:
            result = summed_gains(
                summed,
                listener,
                q_s,
                max_wavenumber=kb,
                air_density=rho,
                sound_speed=c,
                reference_distance=r0,
                tol=tol,
                max_points=max_points,
                full_output=True,
            )
        elif separable is not None:
            result = separable_gains(
                separable,
                listener,
                q_s,
                max_wavenumber=kb,
                air_density=rho,
                sound_speed=c,
                reference_distance=r0,
                tol=tol,
                max_points=max_points,
                full_output=True,
            )
        else:
            result = rayleigh_gains(
                modes.shapes,
                size,
                listener,
                q_s,
                max_wavenumber=kb,
                air_density=rho,
                sound_speed=c,
                reference_distance=r0,
                tol=tol,
                max_points=max_points,
                full_output=True,
            )
        return _frozen(result)

    if not cache:
        result = compute()
        _CACHE.count("computed")
    else:
        key = _gains_key(
            modes,
            listener,
            q_s,
            kb,
            rho,
            c,
            r0,
            tol,
            max_points,
            separable is not None or summed is not None,
        )
        result = _CACHE.get(key)
        if result is None:
            result = _load_gains(key, q_s.size)
            if result is not None:
                _CACHE.put(key, result, source="disk")
            else:
                result = compute()
                _CACHE.put(key, result, source="computed")
                _save_gains(result, key)
    if full_output:
        return result
    if not result.success:
        _warn_unconverged("plate_gains", result, tol)
    return result.gains


def distance(listener_position, reference_point) -> float:
    """Distance from the microphone to a point of the plate, metres.

    Parameters
    ----------
    listener_position : (float, float, float)
        ``(x, y, z)`` of the microphone, metres, ``z > 0``.
    reference_point : (float, float)
        ``(x, y)`` of a point in the plate's plane (``z = 0``), metres.

    Returns
    -------
    float
        ``|xL - xr|``, metres (the ``reference_distance`` of :func:`rayleigh_gains`).
    """
    xl, yl, zl = _listener(listener_position)
    xr, yr = checks.point("reference_point", reference_point, 2)
    return math.sqrt((xl - xr) ** 2 + (yl - yr) ** 2 + zl * zl)


def delay(listener_position, reference_point, sound_speed=SOUND_SPEED) -> float:
    """Propagation delay from a point of the plate to the microphone, seconds.

    Parameters
    ----------
    listener_position : (float, float, float)
        ``(x, y, z)`` of the microphone, metres, ``z > 0``.
    reference_point : (float, float)
        ``(x, y)`` of a point in the plate's plane (``z = 0``), metres.
    sound_speed : float > 0
        Speed of sound in air, m/s.

    Returns
    -------
    float
        ``|xL - xr| / c``, seconds: the delay to apply to gains computed with
        ``reference_distance = distance(listener_position, reference_point)``.
    """
    c = checks.positive("sound_speed", sound_speed, "m/s")
    return distance(listener_position, reference_point) / c
