"""The finite rectangular plate's bending modes (docs/physics.md, "Plate modes").

:func:`modes` returns every bending mode of a :class:`~synth.physics.scene.Plate` up to a
frequency: natural frequencies, modal damping, modal masses and the mode shapes
``phi_k(x, y)``, which the synthesis combines as

    v(xp, t) = sum_k phi_k(x0) phi_k(xp) / M_k * (h_k * F)(t).

Thin-plate (Kirchhoff) theory: transverse displacement ``w(x, y)``, kinetic
energy ``1/2 rho h omega^2 Int w^2 dA`` and strain energy

    U = D/2 Int [ w_xx^2 + w_yy^2 + 2 nu w_xx w_yy + 2 (1 - nu) w_xy^2 ] dA,

``D = E h^3 / (12 (1 - nu^2))``. Kirchhoff theory ignores shear deformation and
rotary inertia: against Mindlin's theory it overestimates a mode's frequency by
about ``(k h)^2 / 5`` (``k`` the bending wavenumber, nu = 0.3), 1 % when the
bending wavelength is 25 thicknesses; more when the wavelength nears a few
thicknesses (an 18 mm board at 24 kHz).

Simply supported edges
    Closed form (Leissa 1969, chapter 4): ``omega_mn = pi^2 sqrt(D / (rho h))
    ((m/a)^2 + (n/b)^2)``, ``phi_mn = 2 sin(m pi x / a) sin(n pi y / b)``.

Free and clamped edges
    Rayleigh-Ritz in the coordinates ``xi = 2x/a - 1``, ``eta = 2y/b - 1``, with a
    tensor basis ``psi_i(xi) psi_j(eta)`` that is orthonormal on ``[-1, 1]``:

    * free: orthonormal Legendre polynomials ``psi_n = p_n`` (the natural
      boundary conditions need not be imposed);
    * clamped: ``psi_n = (1 - xi^2)^2 p_n^(4,4)(xi)`` with ``p_n^(4,4)`` the Jacobi
      polynomials orthonormal for the weight ``(1 - xi^2)^4``; every ``psi_n``
      has ``w = dw/dn = 0`` at the edges and the ``psi_n`` are orthonormal in
      plain ``L2`` (no Gram-Schmidt, no ill-conditioned Gram matrix).

    The mass matrix is therefore the identity; the stiffness matrix is assembled
    from exact one-dimensional integrals of products of ``psi``, ``psi'`` and
    ``psi''`` (Gauss-Legendre quadrature, exact for these polynomials). A basis
    function is even or odd in ``xi`` with its degree, so the problem splits into
    the plate's four symmetry classes (even/odd in x times even/odd in y), solved
    apart.

    Eigen-solution. The stiffness matrix spans many decades (its largest Ritz
    values grow as the eighth power of the degree, ~1e14 times the lowest at
    degree 160) and a plain symmetric eigen-solver loses the low modes (errors of
    ``eps * ||K||``: 3e-4 relative on the 2nd mode of a square plate at degree
    160). The solver therefore factors ``K + s I = R^T R`` (Cholesky, whose
    errors stay relative to each entry of this graded matrix), forms
    ``(K + s I)^-1`` (LAPACK ``potri``) and takes its largest eigenvalues
    ``mu = 1 / (lambda + s)``: their absolute error ``eps / s`` gives the wanted
    eigenvalues to a relative error ``eps * lambda / s`` (measured: at degree 120
    the low modes agree with a degree-24 solve to 1e-8).

    Basis size. A mode of bending wavenumber ``k`` (``omega^2 rho h = D k^4``)
    varies along x at most like ``sin(k x)``, i.e. like ``sin(kappa xi)`` with
    ``kappa = k a / 2``; a polynomial basis resolves that once its degree exceeds
    ``g(kappa) = kappa + c1 kappa^(1/3) + c0`` (the Airy-type transition of
    spectral convergence). The basis keeps the degree pairs ``(i, j)`` needed by
    some wavenumber ``(k_x, k_y)`` with ``k_x^2 + k_y^2 <= k_max^2``:
    ``(g^-1(i) / K_x)^2 + (g^-1(j) / K_y)^2 <= 1``, ``K_x = k_max a / 2``,
    ``K_y = k_max b / 2`` (a quarter ellipse instead of the full rectangle: a
    fifth fewer unknowns). With ``c0 = 2``, ``c1 = 3`` every mode up to ``k_max``
    is measured converged to about 1e-7 in frequency (free) and 1e-9 (clamped),
    from 1D beam tests (``N - kappa ~ 3.5 kappa^(1/3)`` degrees for 1e-6) and 2D
    comparisons with bases 20 degrees larger.

    Convergence check. Each class is solved again (eigenvalues only) with a
    larger nested basis (``c1 + d1``, ``c0 + d0``). Ritz values of nested spaces
    decrease monotonically towards the exact eigenvalues, so the k-th values of
    the two solves bound the k-th mode's error from below and, with spectral
    convergence, estimate it. Every returned mode agrees to :data:`TOLERANCE`
    (relative, frequency) with the larger basis; if one below ``max_frequency``
    does not, the basis is enlarged and the solve repeated. Nothing above
    ``max_frequency`` is returned.

Large free and clamped bands. A band whose Ritz problem would exceed
``_CROSSOVER_UNKNOWNS`` per symmetry class takes the Ritz modes of a low band and, above
it, the dynamic edge effect modes of :mod:`synth.sound.asymptotic_modes` (cost linear in
the number of modes; frequencies within 0.5 % of the Ritz solver above that band, see
docs/physics.md, "Large free and clamped plates").

Separable shapes. The simply supported shapes are products ``X_m(x) Y_n(y)``;
:meth:`Modes.separable` returns them as such (:class:`SeparableShapes`), so that sums
over many points can be shared between modes (the polar rule of
:func:`synth.sound.radiation.separable_gains`). The free and clamped shapes are sums of
such products, ``2 sum c_ij psi_i(xi) psi_j(eta)``; :meth:`Modes.summed` returns them as
such (:class:`SummedShapes`, used by :func:`synth.sound.radiation.summed_gains`).

Normalisation. Every mode shape satisfies ``Int phi_k^2 dA = a b`` (mean square
1), so every modal mass is ``M_k = rho h a b`` (the plate's mass). Shapes are
orthogonal: ``Int phi_k phi_l dA = 0`` for ``k != l``. A shape's sign is arbitrary
(only products ``phi_k(x0) phi_k(xp)`` matter); within a degenerate pair (square
plates) the two shapes are one orthonormal basis of the pair's plane.

Caching. The eigen-solution depends only on the boundary, ``nu``, the aspect ratio
``a / b`` and the dimensionless band ``omega L^2 sqrt(rho h / D)``,
``L = max(a, b)``; E, rho, h and the size only scale its frequencies, and the
damping law is applied afterwards. Free and clamped solutions are kept in memory
and on disk (``.npz`` in ``$SYNTH_CACHE_DIR`` if set, else the platform's user
cache directory + ``synth``), keyed by those numbers and the basis settings. A
request for a lower band reuses a stored higher one. The simply supported closed
form needs no cache.

References
----------
A. W. Leissa, *Vibration of Plates*, NASA SP-160 (1969), chapter 4.
A. W. Leissa, "The free vibration of rectangular plates", J. Sound Vib. 31 (1973) 257-293.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
import scipy.linalg
from scipy.linalg import lapack
from scipy.special import gammaln, roots_legendre

from synth import checks
from synth.errors import ParameterError, SynthError
from synth.io.cache import MemoryCache, cache_dir, cache_path, load_npz, savez_atomic
from synth.physics.scene import Plate

__all__ = [
    "Modes",
    "modes",
    "SeparableShapes",
    "SummedShapes",
    "TOLERANCE",
    "EDGE_EFFECT_TOLERANCE",
    "cache_info",
    "clear_memory_cache",
    "cache_dir",
    "single_thread_product",
]

#: Relative accuracy of every returned mode's frequency (Ritz estimate, see above).
TOLERANCE = 1e-4
#: Relative accuracy of the dynamic edge effect frequencies (with their Rayleigh-Ritz
#: step) above the Ritz low band of a crossed-over plate, against the Ritz solver
#: (tests/test_asymptotic_modes.py: measured 0.015 % clamped, 0.43 % free rectangles,
#: 0.28 % free squares).
EDGE_EFFECT_TOLERANCE = 0.005

# Basis-size rule g(kappa) = kappa + C1 kappa^(1/3) + C0 (degrees), and the extra
# degrees of the check basis. Chosen from the measured Legendre convergence of
# free and clamped plates (tests/test_plate.py checks the result against a much
# larger basis).
_C0 = 2.0
_C1 = 3.0
_D0 = 2.0
_D1 = 1.0
# Shift s of K + s I (dimensionless units of omega^2 L^4 rho h / D). The lowest
# elastic mode of any free or clamped rectangle lies above 13 (square free plate);
# s = 100 puts the shifted spectrum's floor near it.
_SHIFT = 100.0
# Largest symmetry-class matrix (unknowns) the dense solver accepts: 12000^2
# doubles are 1.2 GB. Above it, max_frequency is refused.
_MAX_UNKNOWNS = 12000
# Crossover to the dynamic edge effect method (synth.sound.asymptotic_modes): a free or
# clamped band whose Ritz problem would exceed this many unknowns per symmetry class
# (the estimate of _ritz_unknowns) takes the Ritz modes of a low band only (up to
# _LOW_BAND_UNKNOWNS) and the edge effect modes above it. Every crossed-over plate has
# edge effect modes above the same low band, so the crossover sets the cost alone, not
# the accuracy: it lies just above every preset's band at 48 kHz (at most 1831 unknowns,
# ping-pong table, steel sheet: their recorded renders keep the Ritz path). A Ritz
# class costs about 3 s cold at 1400 unknowns and 12 s at 2400 (synth bench scale), the
# cubic growth beyond is what the crossover avoids.
_CROSSOVER_UNKNOWNS = 1850
# Ritz size of the low band of a crossed-over plate: its lowest modes (the edge effect
# method's least accurate: corner and beam-like modes; the tests measure its accuracy
# above a band of 200) exact, in a fraction of a second.
_LOW_BAND_UNKNOWNS = 300
# Most modes any band may hold (arrays of a few hundred MB per listener beyond).
_MAX_MODES = 2_000_000
# Temporary-array budget of shapes(): elements (8 bytes each).
_CHUNK_ELEMENTS = 1 << 22
# Largest matrix product shapes() hands to BLAS in one call, multiply-adds. OpenBLAS
# runs products up to 4 * 65536 multiply-adds on one thread (its default
# GEMM_MULTITHREAD_THRESHOLD). Shapes are evaluated beside other busy threads (the
# Rayleigh sums of synth.sound.radiation); a multithreaded product whose helper thread
# waits for a busy core stalls (measured: 5 to 10 times slower than on one thread).
_PIECE = 1 << 18
# Parity classes (x, y): 0 = even, 1 = odd.
_CLASSES = ((0, 0), (0, 1), (1, 0), (1, 1))
#: Symmetry classes with more unknowns than this (in the first basis tried) are solved on
#: one BLAS thread (see _solve_classes); smaller ones, every preset's among them (at most
#: 1732 unknowns at 48 kHz), with BLAS's own threads, whose partial sums, and so the last
#: bits of the modes, depend on their number. ``math.inf``: never on one thread.
ONE_THREAD_UNKNOWNS = 2500
# Version of the stored solution layout and algorithm; part of the cache key.
_VERSION = 1


# --------------------------------------------------------------------------------------
# One-dimensional basis
# --------------------------------------------------------------------------------------


def _alpha(boundary: str) -> int:
    """Jacobi weight exponent of the basis: 0 (free, Legendre), 4 (clamped)."""
    return 0 if boundary == "free" else 4


@numba.njit(cache=True)
def _recurrence(x, a, p0, out):  # pragma: no cover
    """Orthonormal symmetric Jacobi polynomials and derivatives by their recurrence.

    ``out[d, i, m]`` becomes ``d^d p_m / dxi^d`` at ``x[i]`` for ``d < out.shape[0]``:
    ``p_0 = p0``, ``p_(m+1) = (xi p_m - a_m p_(m-1)) / a_(m+1)`` and, differentiated,
    ``p_(m+1)^(d) = (d p_m^(d-1) + xi p_m^(d) - a_m p_(m-1)^(d)) / a_(m+1)``
    (``a`` as in :func:`_basis_1d`, ``a[0] = 0``). The operations are those of the
    recurrence written term by term, in the same order.
    """
    nd, nx, n = out.shape
    if n == 0:
        return
    for i in range(nx):
        xi = x[i]
        out[0, i, 0] = p0
        for d in range(1, nd):
            out[d, i, 0] = 0.0
        for m in range(n - 1):
            prev = out[0, i, m - 1] if m > 0 else 0.0
            out[0, i, m + 1] = (xi * out[0, i, m] - a[m] * prev) / a[m + 1]
            for d in range(1, nd):
                prev = out[d, i, m - 1] if m > 0 else 0.0
                out[d, i, m + 1] = (d * out[d - 1, i, m] + xi * out[d, i, m] - a[m] * prev) / a[
                    m + 1
                ]


def _basis_1d(alpha: int, n: int, x: np.ndarray, derivatives: int = 0) -> np.ndarray:
    """Basis functions ``psi_0 .. psi_(n-1)`` and derivatives at ``x`` in [-1, 1].

    Returns an array ``(derivatives + 1, len(x), n)``. The orthonormal symmetric
    Jacobi polynomials come from the three-term recurrence
    ``xi p_m = a_(m+1) p_(m+1) + a_m p_(m-1)``, ``a_m^2 = m (m + 2 alpha) /
    ((2m + 2 alpha + 1)(2m + 2 alpha - 1))``, differentiated term by term
    (:func:`_recurrence`); for ``alpha = 4`` the polynomials are multiplied by
    ``u = (1 - xi^2)^2``.
    """
    x = np.ascontiguousarray(x, dtype=float).ravel()
    p = np.empty((derivatives + 1, x.size, n))
    mu0 = math.exp(
        (2 * alpha + 1) * math.log(2.0) + 2 * gammaln(alpha + 1) - gammaln(2 * alpha + 2)
    )
    m = np.arange(n + 1, dtype=float)
    a = np.sqrt(m * (m + 2 * alpha) / ((2 * m + 2 * alpha + 1) * (2 * m + 2 * alpha - 1)))
    a[0] = 0.0
    _recurrence(x, a, 1.0 / math.sqrt(mu0), p)
    if alpha == 0:
        return p
    x2 = (x * x)[:, None]
    u = (1.0 - x2) ** 2
    if derivatives == 0:
        return u[None] * p
    out = np.empty_like(p)
    u1 = -4.0 * x[:, None] * (1.0 - x2)
    u2 = 12.0 * x2 - 4.0
    out[0] = u * p[0]
    out[1] = u1 * p[0] + u * p[1]
    if derivatives >= 2:
        out[2] = u2 * p[0] + 2.0 * u1 * p[1] + u * p[2]
    return out


def _matrices_1d(alpha: int, n: int):
    """Exact integrals over [-1, 1] of products of the first ``n`` basis functions.

    Returns ``(A11, A22, A20)``: ``A11[i, k] = Int psi_i' psi_k'``,
    ``A22 = Int psi_i'' psi_k''``, ``A20 = Int psi_i'' psi_k``. (``Int psi_i psi_k``
    is the identity.) Gauss-Legendre with ``n + 6`` nodes integrates these
    polynomials of degree at most ``2n + 6`` exactly.
    """
    xq, wq = roots_legendre(n + 6)
    b = _basis_1d(alpha, n, xq, derivatives=2)
    bw = b * wq[None, :, None]
    a11 = bw[1].T @ b[1]
    a22 = bw[2].T @ b[2]
    a20 = bw[2].T @ b[0]
    return a11, a22, a20


# --------------------------------------------------------------------------------------
# Basis size
# --------------------------------------------------------------------------------------


def _degree_wavenumber(i: np.ndarray, c0: float, c1: float) -> np.ndarray:
    """Inverse of ``g(kappa) = kappa + c1 kappa^(1/3) + c0``: the largest wavenumber
    (per unit of xi) that needs a degree ``i``; 0 for ``i <= c0``.

    With ``t = kappa^(1/3)``: ``t^3 + c1 t - (i - c0) = 0``, one real root (Cardano).
    """
    q = -(np.asarray(i, dtype=float) - c0)
    r = np.sqrt(q * q / 4.0 + c1**3 / 27.0)
    t = np.cbrt(-q / 2.0 + r) + np.cbrt(-q / 2.0 - r)
    return np.where(q < 0.0, t**3, 0.0)


def _index_set(px: int, py: int, kx: float, ky: float, c0: float, c1: float):
    """Degree pairs ``(i, j)`` of parity ``(px, py)`` kept for wavenumbers up to
    ``(kx, ky)`` (per unit of xi, eta): ``(g^-1(i)/kx)^2 + (g^-1(j)/ky)^2 <= 1``."""
    nx = int(math.floor(kx + c1 * kx ** (1.0 / 3.0) + c0)) + 1
    ny = int(math.floor(ky + c1 * ky ** (1.0 / 3.0) + c0)) + 1
    i = np.arange(px, nx + 1, 2)
    j = np.arange(py, ny + 1, 2)
    ki = _degree_wavenumber(i, c0, c1) / kx
    kj = _degree_wavenumber(j, c0, c1) / ky
    keep = ki[:, None] ** 2 + kj[None, :] ** 2 <= 1.0
    ii, jj = np.nonzero(keep)
    return i[ii], j[jj]


# --------------------------------------------------------------------------------------
# Ritz solution of one symmetry class
# --------------------------------------------------------------------------------------


@numba.njit(cache=True, nogil=True)
def _assemble(I, J, a11, a22, a20, b11, b22, b20, rx, ry, nu, shift):  # pragma: no cover
    """Shifted stiffness ``K + shift 1`` of the basis ``psi_I(xi) psi_J(eta)`` (upper triangle).

    ``K[p, q] = 16 [rx^4 A22[i,k] d_jl + ry^4 d_ik B22[j,l]
    + nu rx^2 ry^2 (A20[i,k] B20[l,j] + A20[k,i] B20[j,l]) + 2 (1-nu) rx^2 ry^2 A11[i,k] B11[j,l]]``
    for ``p = (i, j)``, ``q = (k, l)``; see :func:`_stiffness`.
    """
    n = I.size
    k = np.zeros((n, n))
    cx = 16.0 * rx**4
    cy = 16.0 * ry**4
    cn = 16.0 * nu * rx * rx * ry * ry
    ct = 32.0 * (1.0 - nu) * rx * rx * ry * ry
    for q in range(n):
        kk = I[q]
        ll = J[q]
        for p in range(q + 1):
            i = I[p]
            j = J[p]
            v = (
                cn * (a20[i, kk] * b20[ll, j] + a20[kk, i] * b20[j, ll])
                + ct * a11[i, kk] * b11[j, ll]
            )
            if j == ll:
                v += cx * a22[i, kk]
            if i == kk:
                v += cy * b22[j, ll]
            k[p, q] = v
        k[q, q] += shift
    return k


def _stiffness(mx, my, I, J, rx, ry, nu, shift=0.0):
    """Dimensionless stiffness matrix (upper triangle) of the basis ``psi_I(xi) psi_J(eta)``.

    With ``L = max(a, b)``, ``rx = L/a``, ``ry = L/b`` and eigenvalue
    ``lambda = omega^2 L^4 rho h / D``, the Kirchhoff energy becomes
    ``16 Int [rx^4 w_xixi^2 + ry^4 w_etaeta^2 + 2 nu rx^2 ry^2 w_xixi w_etaeta
    + 2 (1 - nu) rx^2 ry^2 w_xieta^2] dxi deta`` and the mass matrix is the identity.
    ``shift`` is added to the diagonal.
    """
    return _assemble(
        np.ascontiguousarray(I, dtype=np.int64),
        np.ascontiguousarray(J, dtype=np.int64),
        *mx,
        *my,
        float(rx),
        float(ry),
        float(nu),
        float(shift),
    )


def _solve_class(mx, my, I, J, rx, ry, nu, lam_max: float, vectors: bool):
    """Eigenpairs with eigenvalue <= ``lam_max`` of one class, through ``(K + s I)^-1``.

    Returns ``(lam, vec)`` ascending (``vec`` is None if not wanted). The largest
    eigenvalues ``mu = 1 / (lambda + s)`` of the inverse carry a relative error of
    about ``eps * lambda / s``, whatever the norm of ``K``.
    """
    k = _stiffness(mx, my, I, J, rx, ry, nu, _SHIFT)
    c, info = lapack.dpotrf(k, lower=0, clean=1, overwrite_a=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"Cholesky failed (info={info})")  # pragma: no cover
    x, info = lapack.dpotri(c, lower=0, overwrite_c=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"inverse failed (info={info})")  # pragma: no cover
    mu_lo = 1.0 / (lam_max + _SHIFT)
    # Divide and conquer (evd) on the whole spectrum is faster here than a subset
    # (evr or evx) with vectors.
    if vectors:
        mu, vec = scipy.linalg.eigh(
            x, lower=False, driver="evd", overwrite_a=True, check_finite=False
        )
    else:
        mu = scipy.linalg.eigh(
            x, lower=False, driver="evd", eigvals_only=True, overwrite_a=True, check_finite=False
        )
        vec = None
    first = int(np.searchsorted(mu, mu_lo, side="left"))
    lam = 1.0 / mu[first:][::-1] - _SHIFT
    if vec is not None:
        vec = np.ascontiguousarray(vec[:, first:][:, ::-1])
    return lam, vec


# --------------------------------------------------------------------------------------
# Dimensionless solutions (cached)
# --------------------------------------------------------------------------------------


def single_thread_product(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out[...] = a @ b`` (2-D float arrays) by products of at most ``_PIECE``
    multiply-adds each, which OpenBLAS runs on the calling thread: square-ish blocks
    of ``out`` (so that BLAS copies each operand into its packed layout a few times
    only), every entry one whole dot product. On a machine whose cores are busy, a
    multithreaded product waits for them (see ``_PIECE``)."""
    n, k = a.shape
    m = b.shape[1]
    rows = min(n, max(8, math.isqrt(_PIECE // max(1, k))))
    cols = min(m, max(8, _PIECE // max(1, k * rows)))
    for r0 in range(0, n, rows):
        for c0 in range(0, m, cols):
            np.matmul(
                a[r0 : r0 + rows], b[:, c0 : c0 + cols], out=out[r0 : r0 + rows, c0 : c0 + cols]
            )


@numba.njit(cache=True)
def _take_columns(a, index):  # pragma: no cover
    """Reorder the columns of ``a`` in place, row by row: ``a[p, k] = a_old[p, index[k]]``
    (``index`` a permutation of ``range(a.shape[1])``)."""
    n, m = a.shape
    row = np.empty(m)
    for p in range(n):
        for k in range(m):
            row[k] = a[p, index[k]]
        for k in range(m):
            a[p, k] = row[k]


class _RitzSolution:
    """Free or clamped modes of a plate of aspect ``a/b``, Poisson ``nu``, up to
    ``omega_max`` (dimensionless ``omega L^2 sqrt(rho h / D)``, ``L = max(a, b)``).

    ``omega`` ascending; mode ``k`` is column ``col[k]`` of ``coef[cls[k]]``, the
    coefficients on ``psi_I(xi) psi_J(eta)`` with ``I, J = index[cls[k]]`` (unit
    norm: the shape is ``2 sum c_ij psi_i(xi) psi_j(eta)``).
    """

    def __init__(self, boundary, nu, aspect, omega_max, omega, cls, col, index, coef, info):
        self.boundary = boundary
        self.nu = nu
        self.aspect = aspect
        self.omega_max = omega_max
        self.omega = omega
        self.cls = cls
        self.col = col
        self.index = index
        self.coef = coef
        self.info = info
        arrays = (omega, cls, col, *[a for ij in index for a in ij], *coef)
        for arr in arrays:
            arr.setflags(write=False)
        self.nbytes = sum(arr.nbytes for arr in arrays)
        self.key = json.dumps(
            {"solution": _key(boundary, nu, aspect), "omega_max": float(omega_max).hex()},
            sort_keys=True,
        )
        # Dense coefficient tensors of _grouped, by (class, modes, grouped axis): the
        # latest few are kept (a grid is usually evaluated chunk by chunk).
        self._dense = {}

    def _dense_coefficients(self, c, m, axis):
        """Coefficients of class ``c``'s first ``m`` modes as a dense
        ``(n_s, n_t * m)`` matrix, ``s`` the degrees along ``axis`` (0: xi, 1: eta)
        and ``t`` along the other, one parity each (degree ``d`` at ``d // 2``);
        zero where the basis has no such degree pair. Read-only, cached."""
        key = (c, m, axis)
        dense = self._dense.get(key)
        if dense is None:
            S, T = self.index[c] if axis == 0 else self.index[c][::-1]
            dense = np.zeros((int(S.max()) // 2 + 1, int(T.max()) // 2 + 1, m))
            dense[S // 2, T // 2] = self.coef[c][:, :m]
            dense = dense.reshape(dense.shape[0], -1)
            dense.setflags(write=False)
            if len(self._dense) >= 8:
                self._dense.clear()
            self._dense[key] = dense
        return dense

    def shapes(self, xi, eta, n_modes):
        """Mode shapes ``phi_k`` of the first ``n_modes`` modes at ``(xi, eta)``.

        Returns ``(len(xi), n_modes)``. Each symmetry class is evaluated as one
        block of columns by matrix products (its coefficients form one matrix);
        the columns are put in frequency order at the end (:func:`_take_columns`).
        Points sharing a coordinate (a grid) share the partial sum over that
        direction. Temporaries stay below ``_CHUNK_ELEMENTS`` doubles.
        """
        out = np.empty((xi.size, n_modes))
        if n_modes == 0 or xi.size == 0:
            return out
        alpha = _alpha(self.boundary)
        cls = self.cls[:n_modes]
        counts = np.bincount(cls, minlength=4)
        start = np.concatenate(([0], np.cumsum(counts)))
        # A class's modes come in the order of its columns (ascending frequency):
        # class c's j-th mode is column start[c] + j of the block layout.
        parts = [
            (
                c,
                slice(int(start[c]), int(start[c + 1])),
                self.coef[c][:, : counts[c]],
                *self.index[c],
            )
            for c in range(4)
            if counts[c]
        ]
        # Group on the coordinate with fewer distinct values, if it has few.
        ux, inv_x = np.unique(xi, return_inverse=True)
        uy, inv_y = np.unique(eta, return_inverse=True)
        if min(ux.size, uy.size) * 8 <= xi.size:
            if uy.size < ux.size:
                self._grouped(out, parts, 1, uy, inv_y, ux, inv_x, alpha)
            else:
                self._grouped(out, parts, 0, ux, inv_x, uy, inv_y, alpha)
        else:
            # Scattered points: phi[p, k] = 2 sum_b psi_I[b](xi_p) psi_J[b](eta_p) coef[b, k].
            nx = max(int(I.max()) for *_, I, _ in parts) + 1
            ny = max(int(J.max()) for *_, J in parts) + 1
            nb = max(I.size for *_, I, _ in parts)
            chunk = max(1, _CHUNK_ELEMENTS // max(nb, n_modes, nx, ny))
            for first in range(0, xi.size, chunk):
                rows = slice(first, first + chunk)
                px = _basis_1d(alpha, nx, xi[rows])[0]
                py = _basis_1d(alpha, ny, eta[rows])[0]
                for _, cols, coef, I, J in parts:
                    single_thread_product(2.0 * (px[:, I] * py[:, J]), coef, out[rows, cols])
        index = np.empty(n_modes, dtype=np.int64)
        for c in range(4):
            index[cls == c] = np.arange(start[c], start[c + 1])
        _take_columns(out, index)
        return out

    def summed(self, n_modes, length, width, wavenumber):
        """The first ``n_modes`` shapes as a :class:`SummedShapes` of a plate
        ``length`` x ``width`` (metres) whose largest bending wavenumber is
        ``wavenumber`` (rad/m)."""
        cls = self.cls[:n_modes]
        n_x = max(int(I.max()) for I, _ in self.index) + 1
        n_y = max(int(J.max()) for _, J in self.index) + 1
        parts = []
        for c in range(4):
            cols = np.flatnonzero(cls == c)
            if cols.size:
                I, J = self.index[c]
                coef = np.ascontiguousarray(2.0 * self.coef[c][:, : cols.size])
                parts.append((cols, I * n_y + J, coef))
        return SummedShapes(
            length, width, wavenumber, n_x, n_y, n_modes, _alpha(self.boundary), tuple(parts), self
        )

    def _grouped(self, out, parts, axis, u, inv, v, inv_v, alpha):
        """Shapes at points that share values of one coordinate, into column blocks.

        ``axis`` is the grouped coordinate (0: xi, 1: eta); point ``p`` lies at
        ``u[inv[p]]`` along it and at ``v[inv_v[p]]`` along the other. ``parts``
        holds, per class, ``(c, cols, coef, I, J)``: the class, its block of
        ``out``, its coefficients and degrees. The sum over the grouped
        coordinate's degrees is done once per distinct ``u`` (matrix products for
        a batch of them), then the points of each ``u`` take the sum over the
        other's (matrix products per ``u``; see :func:`_product`).
        """
        deg = [(I, J) if axis == 0 else (J, I) for *_, I, J in parts]
        ps = 2.0 * _basis_1d(alpha, max(int(S.max()) for S, _ in deg) + 1, u)[0]
        pv = _basis_1d(alpha, max(int(T.max()) for _, T in deg) + 1, v)[0]
        order = np.argsort(inv, kind="stable")
        bounds = np.searchsorted(inv[order], np.arange(u.size + 1))
        for (c, cols, coef, *_), (S, T) in zip(parts, deg):
            m = coef.shape[1]
            dense = self._dense_coefficients(c, m, axis)
            ni, nj = dense.shape[0], dense.shape[1] // m
            ps_c = ps[:, int(S[0]) % 2 :: 2][:, :ni]
            pv_c = pv[:, int(T[0]) % 2 :: 2][:, :nj]
            batch = max(1, _CHUNK_ELEMENTS // (nj * m))
            for g0 in range(0, u.size, batch):
                s_batch = ps_c[g0 : g0 + batch]
                part = np.empty((s_batch.shape[0], nj * m))
                single_thread_product(s_batch, dense, part)
                part = part.reshape(-1, nj, m)
                for g in range(part.shape[0]):
                    pts = order[bounds[g0 + g] : bounds[g0 + g + 1]]
                    if pts[-1] - pts[0] == pts.size - 1:  # consecutive rows
                        single_thread_product(
                            pv_c[inv_v[pts]], part[g], out[pts[0] : pts[-1] + 1, cols]
                        )
                    else:
                        block = np.empty((pts.size, m))
                        single_thread_product(pv_c[inv_v[pts]], part[g], block)
                        out[pts, cols] = block


class _SimplySupported:
    """Closed-form modes of a simply supported rectangle (dimensionless, as above)."""

    def __init__(self, aspect, omega_max):
        rx, ry = _ratios(aspect)
        m_max = int(math.sqrt(omega_max) / (math.pi * rx)) + 1
        n_max = int(math.sqrt(omega_max) / (math.pi * ry)) + 1
        m, n = np.meshgrid(np.arange(1, m_max + 1), np.arange(1, n_max + 1), indexing="ij")
        m, n = m.ravel(), n.ravel()
        om = math.pi**2 * ((m * rx) ** 2 + (n * ry) ** 2)
        keep = om <= omega_max
        m, n, om = m[keep], n[keep], om[keep]
        order = np.lexsort((n, m, om))
        self.omega = om[order]
        self.m = m[order]
        self.n = n[order]
        self.omega_max = omega_max
        self.key = json.dumps(
            {
                "version": _VERSION,
                "boundary": "simply-supported",
                "aspect": float(aspect).hex(),
                "omega_max": float(omega_max).hex(),
            },
            sort_keys=True,
        )

    def shapes(self, xi, eta, n_modes):
        out = np.empty((xi.size, n_modes))
        m = self.m[:n_modes]
        n = self.n[:n_modes]
        if n_modes == 0:
            return out
        mm = np.arange(1, int(m.max()) + 1)
        nn = np.arange(1, int(n.max()) + 1)
        chunk = max(1, _CHUNK_ELEMENTS // max(n_modes, mm.size, nn.size))
        for start in range(0, xi.size, chunk):
            sl = slice(start, start + chunk)
            # x / a = (xi + 1) / 2
            sx = np.sin(0.5 * math.pi * (xi[sl, None] + 1.0) * mm[None, :])
            sy = np.sin(0.5 * math.pi * (eta[sl, None] + 1.0) * nn[None, :])
            out[sl] = 2.0 * sx[:, m - 1] * sy[:, n - 1]
        return out


def _ratios(aspect: float):
    """``(L/a, L/b)`` for ``aspect = a/b`` and ``L = max(a, b)``."""
    return (1.0, aspect) if aspect >= 1.0 else (1.0 / aspect, 1.0)


def _ritz_unknowns(aspect: float, omega: float) -> float:
    """Estimated unknowns of the largest symmetry class of the Ritz check basis for the
    band ``omega`` (dimensionless): the kept degree pairs fill about pi/4 of the
    rectangle of the largest degrees, a quarter per class."""
    rx, ry = _ratios(aspect)
    k_l = math.sqrt(omega)
    kx, ky = 0.5 * k_l / rx, 0.5 * k_l / ry
    nx_max = kx + (_C1 + _D1) * kx ** (1.0 / 3.0) + _C0 + _D0
    ny_max = ky + (_C1 + _D1) * ky ** (1.0 / 3.0) + _C0 + _D0
    return math.pi / 16.0 * nx_max * ny_max


def _band_of_unknowns(aspect: float, unknowns: float, omega_hi: float) -> float:
    """The band (dimensionless) whose Ritz problem has about ``unknowns`` per class
    (bisection on the increasing :func:`_ritz_unknowns`), at most ``omega_hi``."""
    lo, hi = 0.0, omega_hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _ritz_unknowns(aspect, mid) > unknowns:
            hi = mid
        else:
            lo = mid
    return lo


def _seam(omega: np.ndarray, omega_low: float) -> float:
    """Where the Ritz modes ``omega`` (ascending) hand over to the edge effect ones: the
    middle of the widest relative gap between Ritz modes in the top third of the band
    ``omega <= omega_low``, so that an edge effect mode's error (below the gap's
    half-width) does not move it across the seam (no mode counted twice or lost)."""
    band = omega[(omega >= omega_low * 2.0 / 3.0) & (omega <= omega_low)]
    if band.size < 2:
        return omega_low
    gaps = np.diff(band) / band[1:]
    i = int(np.argmax(gaps))
    return float(0.5 * (band[i] + band[i + 1]))


class _HybridSolution:
    """Ritz modes up to ``omega_low`` followed by the dynamic edge effect modes above
    it, up to ``omega_max`` (dimensionless, as :class:`_RitzSolution`)."""

    def __init__(self, ritz: _RitzSolution, omega_low: float, edge, omega_max: float):
        omega_low = _seam(ritz.omega, omega_low)
        n_low = int(np.searchsorted(ritz.omega, omega_low, side="right"))
        first = int(np.searchsorted(edge.omega, omega_low, side="right"))
        self.ritz, self.edge = ritz, edge
        self.n_low, self.first = n_low, first
        self.omega = np.concatenate((ritz.omega[:n_low], edge.omega[first:]))
        self.omega.setflags(write=False)
        self.omega_max = omega_max
        self.nbytes = ritz.nbytes + edge.nbytes
        self.key = json.dumps(
            {"ritz": ritz.key, "omega_low": float(omega_low).hex(), "edge": edge.key},
            sort_keys=True,
        )

    def shapes(self, xi, eta, n_modes):
        """Shapes of the first ``n_modes`` modes: Ritz columns, then edge effect ones."""
        n_r = min(n_modes, self.n_low)
        out = np.empty((xi.size, n_modes))
        if n_r:
            out[:, :n_r] = self.ritz.shapes(xi, eta, n_r)
        if n_modes > n_r:
            n_e = self.first + n_modes - n_r
            self.edge.shapes(xi, eta, n_e, first=self.first, out=out, column=n_r)
        return out

    def shapes_of(self, xi, eta, index):
        """Shapes of the modes ``index`` (ascending): the Ritz ones as columns of the
        first modes' shapes, the edge effect ones alone."""
        n_r = int(np.searchsorted(index, self.n_low))
        out = np.empty((xi.size, index.size))
        if n_r:
            out[:, :n_r] = self.ritz.shapes(xi, eta, int(index[n_r - 1]) + 1)[:, index[:n_r]]
        if index.size > n_r:
            edge = self.first + index[n_r:] - self.n_low
            self.edge.shapes(xi, eta, 0, out=out, column=n_r, index=edge)
        return out


def _crossed(boundary, nu, aspect, omega_req, cache):
    """Hybrid solution of a band beyond the crossover (see ``_CROSSOVER_UNKNOWNS``)."""
    from synth.sound import asymptotic_modes

    count = asymptotic_modes.mode_count_estimate(aspect, omega_req)
    if count > _MAX_MODES:
        raise _TooLarge(int(count), "modes", _MAX_MODES)
    omega_low = _band_of_unknowns(aspect, _LOW_BAND_UNKNOWNS, omega_req)
    ritz = _ritz(boundary, nu, aspect, omega_low, cache)
    edge = asymptotic_modes.solve(boundary, nu, aspect, omega_req)
    return _HybridSolution(ritz, omega_low, edge, omega_req)


def _solve_classes(mx, my, main, check, rx, ry, nu, lam_cut, one_thread):
    """``(lam, vec, lam_check)`` of each symmetry class: eigenpairs of the basis
    ``main[c]`` and eigenvalues of the larger ``check[c]`` (see :func:`_solve_class`).

    ``one_thread``: LAPACK runs on one BLAS thread. A multithreaded LAPACK call whose
    helper threads wait for cores that other work keeps busy stalls: measured with
    dense eigen-solutions of 1400 unknowns on two shared cores, 16 times slower than
    on one thread (see ``_PIECE``).
    """

    def solve(c):
        lam, vec = _solve_class(mx, my, *main[c], rx, ry, nu, lam_cut, True)
        lam2, _ = _solve_class(mx, my, *check[c], rx, ry, nu, lam_cut, False)
        return lam, vec, lam2

    if not one_thread:
        return [solve(c) for c in range(4)]
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):
        return [solve(c) for c in range(4)]


def _solve_ritz(boundary: str, nu: float, aspect: float, omega_req: float) -> _RitzSolution:
    """All converged modes with dimensionless frequency <= ``omega_req``."""
    alpha = _alpha(boundary)
    rx, ry = _ratios(aspect)
    lam_cut = (omega_req * (1.0 + 10.0 * TOLERANCE)) ** 2
    grow = 1.0
    attempts = []
    one_thread = None
    for _ in range(6):
        # Wavenumbers per unit of xi, eta: k L = sqrt(Omega), a = L / rx.
        k_l = math.sqrt(omega_req) * grow
        kx, ky = 0.5 * k_l / rx, 0.5 * k_l / ry
        # The kept degree pairs fill more than pi/4 of the rectangle of the largest
        # degrees: refuse hopeless sizes before building any index set.
        nx_max = kx + (_C1 + _D1) * kx ** (1.0 / 3.0) + _C0 + _D0
        ny_max = ky + (_C1 + _D1) * ky ** (1.0 / 3.0) + _C0 + _D0
        if math.pi / 16.0 * nx_max * ny_max > _MAX_UNKNOWNS:
            raise _TooLarge(int(math.pi / 16.0 * nx_max * ny_max))
        main = [_index_set(px, py, kx, ky, _C0, _C1) for px, py in _CLASSES]
        check = [_index_set(px, py, kx, ky, _C0 + _D0, _C1 + _D1) for px, py in _CLASSES]
        sizes = [ij[0].size for ij in check]
        if max(sizes) > _MAX_UNKNOWNS:
            raise _TooLarge(max(sizes))
        nx = max(int(ij[0].max()) for ij in check) + 1
        ny = max(int(ij[1].max()) for ij in check) + 1
        mx = _matrices_1d(alpha, nx)
        my = _matrices_1d(alpha, ny)
        if one_thread is None:  # decided on the first basis, kept for the larger ones
            one_thread = max(ij[0].size for ij in main) > ONE_THREAD_UNKNOWNS
        solved = _solve_classes(mx, my, main, check, rx, ry, nu, lam_cut, one_thread)
        lams, vecs, ok = [], [], True
        worst = 0.0
        for c, (lam, vec, lam2) in enumerate(solved):
            if boundary == "free" and c != 3:
                # The rigid-body motions (1, xi, eta) lie in classes 0, 1, 2: one zero
                # eigenvalue each (numerically |lambda| ~ eps * s).
                if not (
                    lam.size
                    and lam2.size
                    and abs(lam[0]) < 1e-6 * _SHIFT
                    and abs(lam2[0]) < 1e-6 * _SHIFT
                ):
                    raise SynthError("free plate: rigid-body modes not found")  # pragma: no cover
                lam, vec, lam2 = lam[1:], vec[:, 1:], lam2[1:]
            om = np.sqrt(np.maximum(lam, 0.0))
            om2 = np.sqrt(np.maximum(lam2, 0.0))
            # Every check mode at or below omega_req needs a converged main partner.
            need = int(np.searchsorted(om2, omega_req, side="right"))
            if need > om.size:
                ok = False
                worst = math.inf
            else:
                err = (om[:need] - om2[:need]) / om[:need] if need else np.zeros(0)
                if err.size:
                    worst = max(worst, float(np.max(np.abs(err))))
                    if np.any(np.abs(err) > TOLERANCE):
                        ok = False
            keep = int(np.searchsorted(om, omega_req, side="right"))
            lams.append(om[:keep])
            vecs.append(np.ascontiguousarray(vec[:, :keep]))
        attempts.append(
            {
                "grow": grow,
                "unknowns": [ij[0].size for ij in main],
                "check_unknowns": sizes,
                "worst_relative_change": worst,
            }
        )
        if ok:
            break
        grow *= 1.15
    else:
        raise SynthError(  # pragma: no cover
            f"plate modes did not converge to {TOLERANCE:g} after {len(attempts)} bases: {attempts}"
        )
    omega = np.concatenate(lams)
    cls = np.concatenate([np.full(v.size, c, dtype=np.int64) for c, v in enumerate(lams)])
    col = np.concatenate([np.arange(v.size, dtype=np.int64) for v in lams])
    order = np.lexsort((cls, omega))
    return _RitzSolution(
        boundary,
        nu,
        aspect,
        omega_req,
        omega[order],
        cls[order],
        col[order],
        main,
        vecs,
        {"attempts": attempts},
    )


def _ritz_frequencies(
    boundary: str,
    nu: float,
    aspect: float,
    omega_basis: float,
    omega_cut: float,
    c0: float = _C0,
    c1: float = _C1,
) -> np.ndarray:
    """Ritz frequencies (dimensionless, ascending, rigid-body motions removed) up to
    ``omega_cut`` with the basis the rule ``(c0, c1)`` builds for ``omega_basis``.

    A diagnostic of the basis-size rule: bases grow (nested) with ``omega_basis``,
    ``c0`` and ``c1``, so each Ritz value can only decrease as they grow.
    """
    alpha = _alpha(boundary)
    rx, ry = _ratios(aspect)
    k_l = math.sqrt(omega_basis)
    sets = [_index_set(px, py, 0.5 * k_l / rx, 0.5 * k_l / ry, c0, c1) for px, py in _CLASSES]
    mx = _matrices_1d(alpha, max(int(ij[0].max()) for ij in sets) + 1)
    my = _matrices_1d(alpha, max(int(ij[1].max()) for ij in sets) + 1)
    out = []
    for c, (I, J) in enumerate(sets):
        lam, _ = _solve_class(mx, my, I, J, rx, ry, nu, omega_cut**2, False)
        if boundary == "free" and c != 3:
            lam = lam[1:]
        out.append(np.sqrt(np.maximum(lam, 0.0)))
    return np.sort(np.concatenate(out))


class _TooLarge(Exception):
    def __init__(self, n, what="unknowns per symmetry class", limit=_MAX_UNKNOWNS):
        self.n = n
        self.what = what
        self.limit = limit


# --------------------------------------------------------------------------------------
# Cache (memory and disk)
# --------------------------------------------------------------------------------------

# Solutions held in memory: least recently used ones are dropped beyond 1 GiB (the
# newest is always kept).
_CACHE = MemoryCache("solves", max_bytes=1 << 30)


def cache_info() -> dict:
    """Counters of the mode cache since start-up (or :func:`clear_memory_cache`).

    Returns
    -------
    dict
        ``solves`` (eigen-solutions computed), ``memory_hits``, ``disk_hits``
        (solutions read from disk), ``disk_writes``, and ``entries`` (solutions
        held in memory).
    """
    return _CACHE.info()


def clear_memory_cache() -> None:
    """Forget the solutions held in memory and reset the counters (disk untouched)."""
    _CACHE.clear()


def _key(boundary: str, nu: float, aspect: float) -> str:
    """Everything that determines a stored solution, as a canonical JSON string."""
    return json.dumps(
        {
            "version": _VERSION,
            "boundary": boundary,
            "nu": float(nu).hex(),
            "aspect": float(aspect).hex(),
            "c0": _C0,
            "c1": _C1,
            "d0": _D0,
            "d1": _D1,
            "shift": _SHIFT,
            "tolerance": TOLERANCE,
        },
        sort_keys=True,
    )


def _path(key: str, boundary: str) -> Path:
    return cache_path(f"plate-modes-{boundary}", key)


def _save(sol: _RitzSolution, key: str) -> None:
    """Write ``sol`` to the disk cache (atomically); skipped if impossible."""
    arrays = {
        "key": np.array(key),
        "omega_max": np.array(sol.omega_max),
        "omega": sol.omega,
        "cls": sol.cls,
        "col": sol.col,
    }
    for c in range(4):
        arrays[f"I{c}"], arrays[f"J{c}"] = sol.index[c]
        arrays[f"coef{c}"] = sol.coef[c]
    try:
        path = _path(key, sol.boundary)
    except RuntimeError:  # no home directory
        return
    if savez_atomic(path, arrays):
        _CACHE.count("disk_writes")


def _load(key: str, boundary: str, nu: float, aspect: float):
    """The stored solution for ``key``, or None if absent, unreadable or inconsistent."""
    try:
        path = _path(key, boundary)
        if not path.is_file():
            return None
        with load_npz(path) as z:
            if str(z["key"][()]) != key:
                return None
            omega_max = float(z["omega_max"][()])
            omega, cls, col = z["omega"], z["cls"], z["col"]
            index = [(z[f"I{c}"], z[f"J{c}"]) for c in range(4)]
            coef = [z[f"coef{c}"] for c in range(4)]
        n = omega.size
        ok = (
            omega.ndim == 1
            and cls.shape == (n,)
            and col.shape == (n,)
            and np.all(np.isfinite(omega))
            and np.all(np.diff(omega) >= 0.0)
            and math.isfinite(omega_max)
            and omega_max > 0.0
            and (n == 0 or (omega[-1] <= omega_max and cls.min() >= 0 and cls.max() <= 3))
        )
        for c in range(4):
            I, J = index[c]
            counts = int(np.sum(cls == c))
            ok = ok and (
                I.ndim == 1
                and I.shape == J.shape
                and coef[c].ndim == 2
                and coef[c].shape == (I.size, counts)
                and np.all(np.isfinite(coef[c]))
                and np.array_equal(col[cls == c], np.arange(counts))
            )
        if not ok:
            return None
        return _RitzSolution(
            boundary,
            nu,
            aspect,
            omega_max,
            omega,
            cls.astype(np.int64),
            col.astype(np.int64),
            [(I.astype(np.int64), J.astype(np.int64)) for I, J in index],
            [np.ascontiguousarray(cf, dtype=float) for cf in coef],
            {"source": str(path)},
        )
    except Exception:  # noqa: BLE001 - any unreadable cache file is recomputed and rewritten
        return None


def _ritz(boundary: str, nu: float, aspect: float, omega_req: float, cache: bool):
    """A converged solution covering ``omega_req``: from memory, disk, or solved."""
    if not cache:
        sol = _solve_ritz(boundary, nu, aspect, omega_req)
        _CACHE.count("computed")
        return sol
    key = _key(boundary, nu, aspect)

    def covers(held):
        return held.omega_max >= omega_req

    sol = _CACHE.get(key, covers)
    if sol is not None:
        return sol
    sol = _load(key, boundary, nu, aspect)
    if sol is not None and covers(sol):
        _CACHE.put(key, sol, source="disk")
        return sol
    sol = _solve_ritz(boundary, nu, aspect, omega_req)
    _CACHE.put(
        key, sol, source="computed", better=lambda held, new: held.omega_max >= new.omega_max
    )
    _save(sol, key)
    return sol


# --------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SeparableShapes:
    """Mode shapes that are products of one function of x and one of y.

    ``phi_k(x, y) = X_(i_k)(x) Y_(j_k)(y)``: :meth:`x_values` and :meth:`y_values`
    give the factors of every index at once, so that sums over points of a grid
    or a curve can be shared between the modes (matrix products). Used by
    :func:`synth.sound.radiation.plate_gains` for the simply supported plate,
    ``X_m(x) = sqrt(2) sin(m pi x / a)``, ``Y_n(y) = sqrt(2) sin(n pi y / b)``.

    Attributes
    ----------
    length, width : float
        ``a`` and ``b``, metres.
    x_index, y_index : ndarray of int, shape (n_modes,)
        ``i_k`` and ``j_k``: mode ``k`` takes column ``x_index[k]`` of
        :meth:`x_values` and column ``y_index[k]`` of :meth:`y_values`.
    wavenumber : float
        Largest rate of oscillation of any factor along its axis, rad/m.
    """

    length: float
    width: float
    x_index: np.ndarray = field(repr=False)
    y_index: np.ndarray = field(repr=False)
    wavenumber: float

    def x_values(self, x: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """``X_i(x)`` for every index ``i`` in use: shape ``(len(x), max(x_index) + 1)``
        (``x`` in metres); or for the indices ``index`` alone, ``(len(x), len(index))``."""
        return _sine_factors(x, math.pi / self.length, self.x_index, index)

    def y_values(self, y: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """``Y_j(y)`` for every index ``j`` in use: shape ``(len(y), max(y_index) + 1)``
        (``y`` in metres); or for the indices ``index`` alone, ``(len(y), len(index))``."""
        return _sine_factors(y, math.pi / self.width, self.y_index, index)


def _sine_factors(u, rate, in_use, index):
    """``sqrt(2) sin((i + 1) rate u)`` for ``i <= max(in_use)`` (the table of
    :func:`_sine_table`), or for ``i`` in ``index``: from the table, or (a few indices
    of a long table) by libm's sine directly."""
    t = np.ascontiguousarray(u, dtype=float) * rate
    n = int(in_use.max()) + 1 if in_use.size else 0
    if index is None:
        return _sine_table(t, n)
    index = np.asarray(index, dtype=np.int64)
    if 4 * index.size < n:
        return math.sqrt(2.0) * np.sin(t[:, None] * (index + 1.0)[None, :])
    return _sine_table(t, n)[:, index]


@dataclass(frozen=True, eq=False)
class SummedShapes:
    """Mode shapes that are sums of products of one function of x and one of y.

    ``phi_k(x, y) = sum_ij C_kij X_i(x) Y_j(y)`` (the free and clamped plates' Ritz
    shapes, ``X_i(x) = psi_i(2 x / a - 1)``, ``Y_j(y) = psi_j(2 y / b - 1)``): a sum over
    points of ``w phi_k`` is ``sum_ij C_kij A_ij`` with ``A = X^T diag(w) Y`` one matrix
    for every mode (:meth:`combine`). Used by
    :func:`synth.sound.radiation.summed_gains` (the polar rule of these shapes).

    Attributes
    ----------
    length, width : float
        ``a`` and ``b``, metres.
    wavenumber : float
        Largest bending wavenumber of the modes, rad/m.
    n_x, n_y : int
        Number of factors ``X_i`` (columns of :meth:`x_values`) and ``Y_j``.
    n_modes : int
        Number of modes (columns of :meth:`combine` and :meth:`values`).
    """

    length: float
    width: float
    wavenumber: float
    n_x: int
    n_y: int
    n_modes: int
    _alpha: int = field(repr=False)
    # per symmetry class: (mode columns, flat factor index i * n_y + j, coefficients 2 C)
    _parts: tuple = field(repr=False)
    _solution: object = field(repr=False)

    def values(self, points: np.ndarray) -> np.ndarray:
        """``phi_k`` at ``points`` (``(n, 2)`` array of ``(x, y)``, metres, on the plate):
        shape ``(n, n_modes)``, as :meth:`Modes.shapes`."""
        pts = np.asarray(points, dtype=float)
        xi = np.clip(2.0 * pts[:, 0] / self.length - 1.0, -1.0, 1.0)
        eta = np.clip(2.0 * pts[:, 1] / self.width - 1.0, -1.0, 1.0)
        return self._solution.shapes(xi, eta, self.n_modes)

    def x_values(self, x: np.ndarray) -> np.ndarray:
        """``X_i(x)`` for ``i < n_x``: shape ``(len(x), n_x)`` (``x`` in metres, on the plate)."""
        xi = np.clip(2.0 * np.asarray(x, dtype=float) / self.length - 1.0, -1.0, 1.0)
        return _basis_1d(self._alpha, self.n_x, xi)[0]

    def y_values(self, y: np.ndarray) -> np.ndarray:
        """``Y_j(y)`` for ``j < n_y``: shape ``(len(y), n_y)`` (``y`` in metres, on the plate)."""
        eta = np.clip(2.0 * np.asarray(y, dtype=float) / self.width - 1.0, -1.0, 1.0)
        return _basis_1d(self._alpha, self.n_y, eta)[0]

    def combine(self, sums: np.ndarray) -> np.ndarray:
        """``out[r, k] = sum_ij C_kij sums[r, i, j]`` for every mode ``k``.

        ``sums`` has shape ``(n, n_x, n_y)`` (for instance ``X^T diag(w) Y`` of ``n``
        sets of points); returns ``(n, n_modes)`` in the order of the frequencies:
        one matrix product per symmetry class.
        """
        flat = np.ascontiguousarray(sums, dtype=float).reshape(sums.shape[0], -1)
        out = np.empty((flat.shape[0], self.n_modes))
        for cols, pairs, coef in self._parts:
            part = np.empty((flat.shape[0], cols.size))
            single_thread_product(np.ascontiguousarray(flat[:, pairs]), coef, part)
            out[:, cols] = part
        return out


@numba.njit(cache=True)
def _sine_table(t, n):  # pragma: no cover
    """``out[j, m] = sqrt(2) sin((m + 1) t_j)`` for ``m < n``: by rotation
    ``exp(i (m + 1) t) = exp(i m t) exp(i t)``, restarted from libm's sin and cos every
    32 orders (rounding grows by about one ulp per order: a few 1e-15)."""
    out = np.empty((t.size, n))
    root2 = math.sqrt(2.0)
    for j in range(t.size):
        c1 = math.cos(t[j])
        s1 = math.sin(t[j])
        c = 1.0
        s = 0.0
        for m in range(n):
            if m % 32 == 31:
                c = math.cos((m + 1) * t[j])
                s = math.sin((m + 1) * t[j])
            else:
                c, s = c * c1 - s * s1, s * c1 + c * s1
            out[j, m] = root2 * s
    return out


@dataclass(frozen=True)
class EdgeEffectPart:
    """Modes ``first_mode, first_mode + 1, ...`` of a :class:`Modes` are modes
    ``offset, offset + 1, ...`` of ``solution``
    (:class:`synth.sound.asymptotic_modes.EdgeEffectSolution`; lengths in units of the
    plate's longer side); the modes before ``first_mode`` are Rayleigh-Ritz modes."""

    first_mode: int
    solution: object
    offset: int


@dataclass(frozen=True, eq=False)
class Modes:
    """The bending modes of a plate up to a frequency (see :func:`modes`).

    Attributes
    ----------
    plate : Plate
        The plate.
    max_frequency : float > 0
        The band asked for, Hz: every mode at or below it, none above.
    frequencies : ndarray, shape (n,)
        Natural frequencies ``f_k``, Hz, ascending (a free plate's three
        rigid-body motions excluded).
    angular_frequencies : ndarray, shape (n,)
        ``omega_k = 2 pi f_k``, rad/s.
    decay_rates : ndarray, shape (n,)
        Amplitude decay rates ``sigma_k`` (amplitude ``~ exp(-sigma_k t)``), 1/s,
        from ``plate.material.damping.decay_rate(omega_k)``.
    modal_masses : ndarray, shape (n,)
        ``M_k = rho h Int phi_k^2 dA = rho h a b`` (the plate's mass), kg.
    tolerance : float
        Relative accuracy of every frequency (Rayleigh-Ritz convergence check;
        the simply supported closed form is exact; :data:`EDGE_EFFECT_TOLERANCE`
        beyond the crossover).

    Normalisation: ``Int phi_k^2 dA = a b`` over the plate (mean square 1), so
    ``v(xp, t) = sum_k phi_k(x0) phi_k(xp) / M_k (h_k * F)(t)`` with these
    :meth:`shapes` and :attr:`modal_masses`. Arrays are read-only.
    """

    plate: Plate
    max_frequency: float
    frequencies: np.ndarray = field(repr=False)
    angular_frequencies: np.ndarray = field(repr=False)
    decay_rates: np.ndarray = field(repr=False)
    modal_masses: np.ndarray = field(repr=False)
    tolerance: float
    _solution: object = field(repr=False)

    def __len__(self) -> int:
        return int(self.frequencies.size)

    @property
    def shape_key(self) -> str:
        """Text that identifies :meth:`shapes` exactly, for caches of results
        computed from them (such as radiation gains).

        Two :class:`Modes` with equal keys return equal shape values at every
        point. The key holds the plate's length and width, the number of modes
        and the eigen-solution the shapes come from (boundary, Poisson ratio,
        aspect ratio, the band it was solved for, the solver settings): not the
        material's stiffness, density or damping, which do not change the shapes.
        """
        p = self.plate
        return json.dumps(
            {
                "solution": self._solution.key,
                "length": float(p.length).hex(),
                "width": float(p.width).hex(),
                "modes": len(self),
            },
            sort_keys=True,
        )

    def __repr__(self) -> str:
        p = self.plate
        band = f"{self.frequencies[0]:.6g}..{self.frequencies[-1]:.6g} Hz" if len(self) else "none"
        return (
            f"Modes({len(self)} modes, {band}, max_frequency={self.max_frequency:g} Hz; "
            f"{p.boundary} {p.material.name} plate {p.length:g} x {p.width:g} x "
            f"{p.thickness:g} m)"
        )

    @property
    def solved_for_band(self) -> bool:
        """True when the eigen-solution was solved for exactly ``max_frequency`` (the
        simply supported closed form always is). A cached wider band's solution serves a
        narrower request with modes equal within :data:`TOLERANCE` but not to the last bit;
        a caller whose result must not depend on the cache's history (the modal contact,
        whose bounces amplify such differences) checks this."""
        sol = self._solution
        if isinstance(sol, _SimplySupported):
            return True
        if isinstance(sol, _RitzSolution):
            return sol.omega_max == _dimensionless_band(self.plate, self.max_frequency)
        return False  # a hybrid's low Ritz band may itself be a wider band's

    def separable(self) -> SeparableShapes | None:
        """The shapes as products ``X_i(x) Y_j(y)`` (:class:`SeparableShapes`), or None
        when they are not (free and clamped plates: sums of such products)."""
        sol = self._solution
        if not isinstance(sol, _SimplySupported):
            return None
        n = len(self)
        p = self.plate
        m_idx = np.asarray(sol.m[:n], dtype=np.int64) - 1
        n_idx = np.asarray(sol.n[:n], dtype=np.int64) - 1
        k = math.pi * max(
            (int(m_idx.max()) + 1) / p.length if n else 0.0,
            (int(n_idx.max()) + 1) / p.width if n else 0.0,
        )
        return SeparableShapes(p.length, p.width, m_idx, n_idx, k)

    def shapes(self, points, index=None) -> np.ndarray:
        """Mode shapes ``phi_k`` at points on the plate.

        Parameters
        ----------
        points : array_like, shape (n, 2)
            ``(x, y)`` positions, metres from the plate's corner: ``0 <= x <= a``
            (length), ``0 <= y <= b`` (width).
        index : array of int, optional
            Modes to evaluate (ascending, distinct); every mode if None. Edge effect
            modes are evaluated alone; others as columns of the first modes' shapes.

        Returns
        -------
        ndarray, shape (n, n_modes)
            ``phi_k`` (dimensionless, mean square 1 over the plate), one column per
            mode in the order of :attr:`frequencies` (of ``index`` if given).

        Notes
        -----
        Cost ``~ n * (basis size) * n_modes / 4`` for scattered points; points on a
        grid (few distinct x or y) share the sum over one direction and cost far
        less. Temporaries are bounded (about 32 MB) whatever ``n``; the result
        itself takes ``8 n n_modes`` bytes, so evaluate very many points in chunks.

        Raises
        ------
        ParameterError
            If ``points`` is not an ``(n, 2)`` array of finite numbers, a point is
            off the plate, or ``index`` is not ascending distinct mode numbers.
        """
        if index is not None:
            index = np.asarray(index)
            if (
                index.ndim != 1
                or not np.issubdtype(index.dtype, np.integer)
                or (index.size and (index[0] < 0 or index[-1] >= len(self)))
                or np.any(np.diff(index) <= 0)
            ):
                raise ParameterError(
                    f"index={index!r} must be ascending distinct mode numbers in [0, {len(self)})"
                )
        try:
            pts = np.asarray(points, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(
                f"points={points!r} must be an (n, 2) array of (x, y) positions (metres)"
            ) from None
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ParameterError(
                f"points with shape {pts.shape} must be an (n, 2) array of (x, y) "
                f"positions (metres)"
            )
        bad = ~np.all(np.isfinite(pts), axis=1)
        p = self.plate
        a, b = p.length, p.width
        bad |= (pts[:, 0] < 0.0) | (pts[:, 0] > a) | (pts[:, 1] < 0.0) | (pts[:, 1] > b)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ParameterError(
                f"points[{i}]=({pts[i, 0]!r}, {pts[i, 1]!r}) is off the plate: x must be in "
                f"[0, {a!r}] and y in [0, {b!r}] (metres from a corner)"
            )
        xi = np.clip(2.0 * pts[:, 0] / a - 1.0, -1.0, 1.0)
        eta = np.clip(2.0 * pts[:, 1] / b - 1.0, -1.0, 1.0)
        if index is None:
            return self._solution.shapes(xi, eta, len(self))
        if isinstance(self._solution, _HybridSolution):
            return self._solution.shapes_of(xi, eta, index)
        return self._solution.shapes(xi, eta, int(index[-1]) + 1 if index.size else 0)[:, index]

    def edge_effect(self) -> EdgeEffectPart | None:
        """The modes that come from the dynamic edge effect method (a free or clamped
        plate beyond the Ritz crossover, see :func:`modes`), or None if there are none."""
        sol = self._solution
        if not isinstance(sol, _HybridSolution) or sol.n_low >= len(self):
            return None
        return EdgeEffectPart(sol.n_low, sol.edge, sol.first)

    def summed(self) -> SummedShapes | None:
        """The shapes as sums of products ``sum_ij C_kij X_i(x) Y_j(y)``
        (:class:`SummedShapes`: free and clamped plates), or None (simply supported
        plates: see :meth:`separable`)."""
        sol = self._solution
        if not isinstance(sol, _RitzSolution):
            return None
        p = self.plate
        omega = float(self.angular_frequencies[-1]) if len(self) else 0.0
        k = (omega * omega * p.surface_density / p.flexural_rigidity) ** 0.25
        return sol.summed(len(self), p.length, p.width, k)


def _frequency_scale(plate: Plate) -> float:
    """``omega / Omega`` (rad/s): ``Omega = omega L^2 sqrt(rho h / D)`` is dimensionless,
    ``L = max(a, b)``."""
    length = max(plate.length, plate.width)
    return math.sqrt(plate.flexural_rigidity / plate.surface_density) / length**2


def _dimensionless_band(plate: Plate, max_frequency: float) -> float:
    """The band ``max_frequency`` (Hz) as the dimensionless ``Omega`` of the solutions."""
    return 2.0 * math.pi * max_frequency / _frequency_scale(plate)


def modes(plate: Plate, *, max_frequency: float, cache: bool = True) -> Modes:
    """Every bending mode of ``plate`` with frequency at or below ``max_frequency``.

    Parameters
    ----------
    plate : Plate
        The plate (material, thickness, length ``a`` along x, width ``b`` along y,
        boundary "free", "simply-supported" or "clamped").
    max_frequency : float > 0
        Upper end of the band, Hz.
    cache : bool
        Reuse and store the eigen-solution (memory and disk, see the module
        notes). ``False`` computes afresh and stores nothing.

    Returns
    -------
    Modes
        Frequencies (Hz, ascending), angular frequencies (rad/s), decay rates
        (1/s), modal masses (kg) and shapes; every frequency accurate to
        :data:`TOLERANCE` relative.

    Raises
    ------
    ParameterError
        If ``plate`` is not a Plate, ``max_frequency`` is not a finite number
        > 0, or the band holds more than two million modes.

    Notes
    -----
    The Ritz cost grows as the cube of the number of modes (a free 0.5 mm steel
    sheet 0.5 m x 0.4 m to 20 kHz, about 2600 modes, takes seconds once, then
    milliseconds from the cache); beyond the crossover (module notes) a Ritz low
    band and the dynamic edge effect modes above it, whose cost is linear in the
    number of modes, are returned with ``tolerance`` :data:`EDGE_EFFECT_TOLERANCE`.
    """
    if not isinstance(plate, Plate):
        raise ParameterError(f"plate={plate!r} must be a Plate")
    damping = plate.damping_law()
    fmax = checks.positive("max_frequency", max_frequency, "Hz")
    if not isinstance(cache, bool):
        raise ParameterError(f"cache={cache!r} must be True or False")
    aspect = plate.length / plate.width
    scale = _frequency_scale(plate)
    omega_req = _dimensionless_band(plate, fmax)
    if plate.boundary == "simply-supported":
        sol = _SimplySupported(aspect, omega_req)
        tol = 0.0
    else:
        nu = plate.material.poisson
        try:
            if _ritz_unknowns(aspect, omega_req) > _CROSSOVER_UNKNOWNS:
                sol = _crossed(plate.boundary, nu, aspect, omega_req, cache)
            else:
                sol = _ritz(plate.boundary, nu, aspect, omega_req, cache)
        except _TooLarge as exc:
            raise ParameterError(
                f"max_frequency={max_frequency!r} is too high for this plate (Hz): the "
                f"mode solver would need {exc.n} {exc.what}, more than {exc.limit}"
            ) from None
        tol = EDGE_EFFECT_TOLERANCE if isinstance(sol, _HybridSolution) else TOLERANCE
    omega = sol.omega * scale
    freq = omega / (2.0 * math.pi)
    n = int(np.searchsorted(freq, fmax, side="right"))
    omega, freq = omega[:n].copy(), freq[:n].copy()
    sigma = np.asarray(damping.decay_rate(omega), dtype=float)
    sigma = np.broadcast_to(sigma, omega.shape).copy()
    mass = np.full(n, plate.mass)
    for arr in (omega, freq, sigma, mass):
        arr.setflags(write=False)
    return Modes(
        plate=plate,
        max_frequency=fmax,
        frequencies=freq,
        angular_frequencies=omega,
        decay_rates=sigma,
        modal_masses=mass,
        tolerance=tol,
        _solution=sol,
    )
