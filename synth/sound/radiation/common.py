"""What the rules of the Rayleigh integral share: their result, argument checks, Gauss-Legendre
rules, the numba kernel of the sums (no GIL) and the convergence test (:func:`refine`,
docs/physics.md, "Radiation")."""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from synth import checks
from synth.compilation import announce, compiled
from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.vecmath import cis, exp_small

MAX_ORDER = 24  # Gauss-Legendre points per axis of the longest panels, first rule
REFINE = 1.25  # ratio of points per axis between successive rules (1.56 in 2-D)
MAX_RULES = 7  # first rule and up to six refinements
GRADING = 2.0  # near-field panel length / max(z, d)
NEAR_RHO = 2.89  # Bernstein-ellipse parameter of the worst graded panel (see min_order)
COHERENT_FLOOR = 1e-4  # see refine()
CHUNK_BYTES = 32e6  # one chunk of mode values, bytes
_TOL_RANGE = (1e-9, 0.1)


@dataclass(frozen=True)
class RadiationResult:
    """Gains ``H_k(s_k)`` (n_modes,) of the Rayleigh integral (times ``exp(s_k R0 / c)`` with a
    reference distance), Pa per (m/s) of modal velocity, with their estimated error
    ``|H_fine - H_coarse|`` and in-phase bound ``S_k``, Pa s/m, and how the convergence test
    ended (``status`` 0 converged, 1 out of refinements, 2 at ``max_points``)."""

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

    @classmethod
    def no_modes(cls) -> RadiationResult:
        """The result of a rule given no modes: nothing to sum, converged."""
        empty = np.zeros(0)
        return cls(empty.astype(complex), empty, empty, 0, 0, (0, 0), True, 0, "no modes")


@dataclass(frozen=True)
class Settings:
    """The checked settings every rule takes: ``kb`` the largest bending wavenumber (rad/m),
    air density ``rho`` (kg/m^3) and sound speed ``c`` (m/s), reference distance ``r0`` (m or
    None), ``tol`` and ``max_points``."""

    kb: float
    rho: float
    c: float
    r0: float | None
    tol: float
    max_points: int

    def keywords(self) -> dict:
        """These settings as the keywords of :func:`~.rectangle.rayleigh_gains`."""
        names = ("max_wavenumber", "air_density", "sound_speed", "reference_distance")
        values = (self.kb, self.rho, self.c, self.r0)
        return dict(zip(names, values), tol=self.tol, max_points=self.max_points)

    def factors(self, q_s, r_mid):
        """Per mode of poles ``q_s`` (rad/s): :func:`pole_factor` about ``r_mid`` (m), and
        the in-phase bound's ``rho |s| / (2 pi)``."""
        factor = pole_factor(q_s, self.rho, self.c, r_mid, self.r0)
        return factor, self.rho * np.abs(q_s) / (2.0 * math.pi)


def pole_factor(s, rho, c, r_mid, r0=None):
    """The gains' factor ``rho s / (2 pi) exp(-s (r_mid - R0) / c)`` of sums taken about
    ``r_mid`` (m), for poles ``s`` (rad/s), air density ``rho`` (kg/m^3), sound speed ``c``
    (m/s) and reference distance ``R0`` (m, None: 0)."""
    shift = r_mid - (0.0 if r0 is None else r0)
    return rho * s / (2.0 * math.pi) * np.exp(-(s / c) * shift)


def check_settings(
    max_wavenumber,
    air_density=AIR_DENSITY,
    sound_speed=SOUND_SPEED,
    reference_distance=None,
    tol=1e-6,
    max_points=4_000_000,
) -> Settings:
    """The keywords of :func:`~.rectangle.rayleigh_gains` shared by every rule, checked."""
    r0 = reference_distance
    return Settings(
        kb=checks.nonnegative("max_wavenumber", max_wavenumber, "rad/m"),
        rho=checks.positive("air_density", air_density, "kg/m^3"),
        c=checks.positive("sound_speed", sound_speed, "m/s"),
        r0=None if r0 is None else checks.nonnegative("reference_distance", r0, "metres"),
        tol=checks.in_range("tol", tol, *_TOL_RANGE, lo_open=False, hi_open=False),
        max_points=checks.integer_at_least("max_points", max_points, 1, "points of one rule"),
    )


def check_listener(listener_position) -> tuple[float, float, float]:
    x, y, z = checks.point("listener_position", listener_position, 3)
    if not z > 0.0:
        raise ParameterError(
            f"listener_position.z={z!r} must be > 0 (metres above the plate, on the air side)"
        )
    return x, y, z


def check_size(size) -> tuple[float, float]:
    """The plate's ``size`` (a, b), m, both > 0."""
    a, b = checks.point("size", size, 2)
    return checks.positive("size.x", a, "metres"), checks.positive("size.y", b, "metres")


def distance_range(size, listener) -> tuple[float, float]:
    """``(r_min, r_max)``, m: the distances from the listener ``(x, y, z)`` to the nearest
    and the farthest point of the plate ``[0, a] x [0, b]`` (``size``)."""
    a, b = size
    xl, yl, zl = listener
    dx = (max(abs(xl), abs(xl - a)), max(0.0, -xl, xl - a))
    dy = (max(abs(yl), abs(yl - b)), max(0.0, -yl, yl - b))
    r_max = math.sqrt(dx[0] ** 2 + dy[0] ** 2 + zl * zl)
    r_min = math.sqrt(dx[1] ** 2 + dy[1] ** 2 + zl * zl)
    return r_min, r_max


def check_finite(values, what: str, modes=None) -> None:
    """A ParameterError ``what`` naming the first mode (index in ``modes``) whose sum is not
    finite."""
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0] if modes is None else modes[bad[0]])
        raise ParameterError(f"{what} for mode {k}")


def check_poles(s, n_modes: int | None = None) -> np.ndarray:
    """``s`` as a 1-D complex array of finite poles (rad/s), one per mode where
    ``n_modes`` is given."""
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
    if n_modes is not None and arr.size != n_modes:
        raise ParameterError(
            f"s has {arr.size} poles for {n_modes} modes: one complex frequency (rad/s) "
            f"per mode is needed"
        )
    return arr


@functools.cache
def gauss(p: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(p)
    t.setflags(write=False)
    w.setflags(write=False)
    return t, w


@functools.lru_cache(maxsize=256)
def half_phase(p: int, tol: float) -> float:
    """Largest ``w`` such that ``p``-point Gauss-Legendre integrates ``exp(i w' t)``
    on ``[-1, 1]`` with error ``<= tol`` times the interval length, for all ``w' <= w``."""
    t, wts = gauss(p)
    omega = np.arange(1, 4000) * (0.005 * p)  # up to 20 p, beyond any useful panel
    # in blocks, up to the first failing w (about 0.5 p to 1.5 p for tol 1e-11 to 1e-2)
    for start in range(0, omega.size, 256):
        block = omega[start : start + 256]
        quad = np.exp(1j * np.outer(block, t)) @ wts
        err = np.abs(quad - 2.0 * np.sin(block) / block) / 2.0
        bad = np.flatnonzero(err > tol)
        if bad.size:
            first = start + int(bad[0])
            return float(omega[first - 1]) if first > 0 else float(omega[0])
    return float(omega[0])


def panel_length(kappa: float, tol: float) -> float:
    """Longest panel (m) whose ``MAX_ORDER`` points integrate ``exp(i kappa x)`` (``kappa``
    rad/m) to ``tol``: ``2 w24 / kappa`` (infinite for ``kappa = 0``)."""
    return 2.0 * half_phase(MAX_ORDER, tol) / kappa if kappa > 0 else math.inf


def fewest_points(phase: float, tol: float, p_min: int) -> int:
    """Fewest Gauss-Legendre points (at least ``p_min``, at most ``MAX_ORDER``) that
    integrate ``exp(i w t)``, ``|w| <= phase``, on ``[-1, 1]`` to ``tol``."""
    p = p_min
    while p < MAX_ORDER and half_phase(p, tol) < phase:
        p += 1
    return p


def min_order(tol: float) -> int:
    """Points per axis that resolve the 1/R peak on a graded panel to ``tol``: the worst
    graded panel, ``[0, 2 z]`` from the projection, has the singularity of ``1/R`` at
    ``-1 +- i`` in its coordinate ``t in [-1, 1]``, on the Bernstein ellipse ``rho = 2.89``;
    Gauss-Legendre's error decays as ``rho^(-2 p)``."""
    p = math.ceil(math.log(1.0 / tol) / (2.0 * math.log(NEAR_RHO)))
    return min(max(p, 6), MAX_ORDER)


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


@compiled(inline="always")
def _exp_scaled(u, halvings):
    """exp(u 2^halvings) as exp(u)^(2^halvings) for |u| <= 1 and 0 <= halvings <= 6, the
    squarings as selects: a loop of variable length would stop the loop over modes from
    vectorising."""
    e = exp_small(u)
    e = e * e if halvings >= 1 else e
    e = e * e if halvings >= 2 else e
    e = e * e if halvings >= 3 else e
    e = e * e if halvings >= 4 else e
    e = e * e if halvings >= 5 else e
    e = e * e if halvings >= 6 else e
    return e


@compiled(nogil=True)
def _rows_fast(j0, j1, dist, wr, phi, qr, qi, halvings, acc_re, acc_im, mag):  # noqa: PLR0913
    """Rayleigh sums over points ``j0 <= j < j1``: ``dist`` (n,) ``R_j - Rm`` and ``wr``
    (n,) ``w_j / R_j``, m; ``phi`` (n, m) shapes; ``qr``, ``qi`` as :class:`Poles` (1/m,
    ``|qr_k dist_j| <= 1``, ``|qi_k dist_j| < 2^19 pi``); into ``acc_re``, ``acc_im``, ``mag``
    (m,). Four points at a time (the vector units busy), added in point order."""
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
    for rest in range(j, j1):
        d = dist[rest]
        w = wr[rest]
        row = phi[rest]
        for k in range(m):
            f = row[k] * w
            amp = f * _exp_scaled(-qr[k] * d, halvings)
            c, sn = cis(qi[k] * d)
            acc_re[k] += amp * c
            acc_im[k] -= amp * sn
            mag[k] += abs(f)


@compiled(nogil=True)
def _rows_libm(j0, j1, dist, wr, phi, qr, qi, acc_re, acc_im, mag):  # noqa: PLR0913
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


@compiled(nogil=True)
def accumulate(j0, j1, dist, wr, phi, qr, qi, halvings, acc_re, acc_im, mag):  # noqa: PLR0913
    """:func:`_rows_fast`, or for ``halvings < 0`` :func:`_rows_libm`, without the GIL."""
    if halvings >= 0:
        _rows_fast(j0, j1, dist, wr, phi, qr, qi, halvings, acc_re, acc_im, mag)
    else:
        _rows_libm(j0, j1, dist, wr, phi, qr, qi, acc_re, acc_im, mag)


class Poles(NamedTuple):
    """The poles as the sums kernels take them: ``qr = Re(s / c) / 2^halvings`` and ``qi =
    Im(s / c)`` (1/m, contiguous), and ``halvings`` (:func:`exp_halvings`)."""

    qr: np.ndarray
    qi: np.ndarray
    halvings: int

    @classmethod
    def of(cls, q: np.ndarray, halvings: int) -> Poles:
        """The kernels' poles of ``q = s / c`` (1/m) with ``halvings``."""
        qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
        return cls(qr, np.ascontiguousarray(q.imag), halvings)


def add_sums(j0, j1, dist, wr, phi, poles: Poles, acc) -> None:
    """:func:`accumulate` into ``acc`` (3, m: real, imaginary, magnitude) for callers in
    Python, choosing the kernel here so that only the one the sums need compiles (its first
    compile noted on stderr)."""
    qr, qi, halvings = poles
    if halvings >= 0:
        announce("radiation")
        _rows_fast(j0, j1, dist, wr, phi, qr, qi, halvings, acc[0], acc[1], acc[2])
    else:
        _rows_libm(j0, j1, dist, wr, phi, qr, qi, acc[0], acc[1], acc[2])


def exp_halvings(q: np.ndarray, spread: float) -> int:
    """Squarings of the fast kernel's exp for ``|Re(q) dR| <= |Re(q)| spread`` (Taylor on
    ``[-1, 1]``, then ``2^halvings``); -1 (the libm kernel) beyond 2^6 or for phases
    beyond the Cody-Waite range."""
    u_max = float(np.max(np.abs(q.real))) * spread
    halvings = max(0, math.ceil(math.log2(u_max))) if u_max > 0 else 0
    if halvings > 6 or float(np.max(np.abs(q.imag))) * spread >= 2.0**18:
        halvings = -1
    return halvings


def refine(rule, npoints, factor, scale, tol, max_points, panels, selective=False):
    """Rules ``rule(level, active)`` (-> integrals and in-phase integrals of the modes ``active``,
    indices) compared until every mode passes the test of docs/physics.md, "The quadrature of
    the rules"; the gains are ``factor`` times the integrals, the bounds ``scale`` times theirs.
    ``selective``: a mode that passes keeps that rule's gain and only the modes still failing go
    on (each mode's test is its own: the same bound)."""
    m = factor.size
    active = np.arange(m)
    coarse, _ = rule(0, active)
    gains, error, coherent = np.empty(m, complex), np.empty(m), np.empty(m)
    status, message = 1, "stopped at the last refinement without meeting tol"
    for level in range(1, MAX_RULES):
        fine, mag = rule(level, active)
        f = factor[active]
        gains[active] = f * fine
        error[active] = np.abs(f * (fine - coarse))
        coherent[active] = scale[active] * mag
        allowed = tol * np.maximum(np.abs(gains[active]), COHERENT_FLOOR * coherent[active])
        failing = ~(error[active] <= allowed)  # a NaN error fails
        n_points = npoints(level)
        if not failing.any():
            status, message = 0, f"converged with {n_points} points (refinement {level})"
            break
        if level + 1 < MAX_RULES and npoints(level + 1) > max_points:
            message = f"the next rule would exceed max_points={max_points}"
            status, message = 2, f"stopped at {n_points} points: {message}"
            break
        if selective:
            active, coarse = active[failing], fine[failing]
        else:
            coarse = fine
    return RadiationResult(
        gains, error, coherent, n_points, level, panels, status == 0, status, message
    )


def gains_of(result: RadiationResult, caller: str, tol: float, full_output: bool):
    """``result`` if ``full_output``, else its gains, with a RuntimeWarning (at the caller of
    ``caller``) naming the mode furthest from convergence if the test failed."""
    if full_output:
        return result
    if not result.success:
        allowed = tol * np.maximum(np.abs(result.gains), COHERENT_FLOOR * result.coherent)
        worst = int(np.argmax(result.error / np.maximum(allowed, 1e-300)))
        warnings.warn(
            f"{caller}: {result.message} (mode {worst}: estimated error "
            f"{result.error[worst]:.3g} Pa s/m, allowed {allowed[worst]:.3g})",
            RuntimeWarning,
            stacklevel=3,
        )
    return result.gains
