"""The Rayleigh-Ritz basis of free and clamped plates (docs/physics.md, "Plate modes"): tensor
products of functions orthonormal on ``[-1, 1]``, so the mass matrix is the identity."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.compilation import compiled
from synth.physics.modes.common import ratios

# Shift s of K + s I (units of omega^2 L^4 rho h / D): the lowest elastic mode of any free or
# clamped rectangle lies above 13, and s = 100 puts the shifted floor near it.
SHIFT = 100.0


def basis_alpha(boundary: str) -> int:
    """Jacobi weight exponent of the basis: 0 (free, Legendre), 4 (clamped)."""
    return 0 if boundary == "free" else 4


@compiled()
def _recurrence(x, a, p0, out):  # pragma: no cover
    """``out[d, i, m] = d^d p_m / dxi^d`` at ``x[i]``, orthonormal symmetric Jacobi polynomials."""
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


def _log_factorial(k: int) -> float:
    """``ln k!`` by the exact product, without importing scipy.special for a render."""
    return math.log(math.factorial(k))


def basis_1d(alpha: int, n: int, x: np.ndarray, derivatives: int = 0) -> np.ndarray:
    """``psi_0 .. psi_(n-1)`` and derivatives at ``x`` in [-1, 1], (derivatives + 1, len(x), n):
    orthonormal Jacobi polynomials, times ``(1 - xi^2)^2`` for ``alpha = 4``."""
    x = np.ascontiguousarray(x, dtype=float).ravel()
    p = np.empty((derivatives + 1, x.size, n))
    mu0 = math.exp(
        (2 * alpha + 1) * math.log(2.0) + 2 * _log_factorial(alpha) - _log_factorial(2 * alpha + 1)
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


def matrices_1d(alpha: int, n: int):
    """``(A11, A22, A20)``: ``Int psi_i' psi_k'``, ``Int psi_i'' psi_k''``, ``Int psi_i'' psi_k``
    over [-1, 1], exact by Gauss-Legendre with ``n + 6`` nodes."""
    from scipy.special import roots_legendre

    xq, wq = roots_legendre(n + 6)
    b = basis_1d(alpha, n, xq, derivatives=2)
    bw = b * wq[None, :, None]
    a11 = bw[1].T @ b[1]
    a22 = bw[2].T @ b[2]
    a20 = bw[2].T @ b[0]
    return a11, a22, a20


def _degree_wavenumber(i: np.ndarray, c0: float, c1: float) -> np.ndarray:
    """Inverse of ``g(kappa) = kappa + c1 kappa^(1/3) + c0`` (Cardano, ``t = kappa^(1/3)``): the
    largest wavenumber per unit of xi needing degree ``i``; 0 for ``i <= c0``."""
    q = -(np.asarray(i, dtype=float) - c0)
    r = np.sqrt(q * q / 4.0 + c1**3 / 27.0)
    t = np.cbrt(-q / 2.0 + r) + np.cbrt(-q / 2.0 - r)
    return np.where(q < 0.0, t**3, 0.0)


def index_set(px: int, py: int, kx: float, ky: float, c0: float, c1: float):
    """Degree pairs ``(i, j)`` of parity ``(px, py)`` for wavenumbers up to ``(kx, ky)``:
    ``(g^-1(i)/kx)^2 + (g^-1(j)/ky)^2 <= 1``."""
    nx = int(math.floor(kx + c1 * kx ** (1.0 / 3.0) + c0)) + 1
    ny = int(math.floor(ky + c1 * ky ** (1.0 / 3.0) + c0)) + 1
    i = np.arange(px, nx + 1, 2)
    j = np.arange(py, ny + 1, 2)
    ki = _degree_wavenumber(i, c0, c1) / kx
    kj = _degree_wavenumber(j, c0, c1) / ky
    keep = ki[:, None] ** 2 + kj[None, :] ** 2 <= 1.0
    ii, jj = np.nonzero(keep)
    return i[ii], j[jj]


@compiled(nogil=True)
def _assemble(I, J, a11, a22, a20, b11, b22, b20, rx, ry, nu, shift):  # noqa: PLR0913  # pragma: no cover
    """Shifted stiffness ``K + shift 1`` of the basis (upper triangle) from the 1-D integrals."""
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


@dataclass(frozen=True)
class RitzProblem:
    """One plate's Rayleigh-Ritz problem: :func:`matrices_1d` along ``xi`` and ``eta``, ``rx =
    L/a``, ``ry = L/b``, ``L = max(a, b)``, Poisson's ``nu``."""

    mx: tuple
    my: tuple
    rx: float
    ry: float
    nu: float

    @classmethod
    def over(cls, boundary: str, aspect: float, nu: float, sets) -> RitzProblem:
        """The problem of aspect ``a/b`` whose matrices reach the largest degrees of ``sets``."""
        alpha = basis_alpha(boundary)
        rx, ry = ratios(aspect)
        return cls(
            matrices_1d(alpha, max(int(ij[0].max()) for ij in sets) + 1),
            matrices_1d(alpha, max(int(ij[1].max()) for ij in sets) + 1),
            rx,
            ry,
            nu,
        )


def _stiffness(problem: RitzProblem, I, J, shift=0.0):
    """Stiffness (upper triangle) plus ``shift``, in ``lambda = omega^2 L^4 rho h / D``."""
    I, J = (np.ascontiguousarray(a, dtype=np.int64) for a in (I, J))
    p = problem
    return _assemble(I, J, *p.mx, *p.my, float(p.rx), float(p.ry), float(p.nu), float(shift))


def solve_class(problem: RitzProblem, I, J, lam_max: float, vectors: bool):
    """Eigenpairs ascending with ``lam <= lam_max`` of the class through ``(K + s I)^-1``
    (Cholesky, LAPACK ``potri``): the largest carry a relative error of about ``eps lambda /
    s`` whatever the norm of ``K``."""
    import scipy.linalg  # imported on use: a render from cached modes solves nothing
    from scipy.linalg import lapack

    k = _stiffness(problem, I, J, SHIFT)
    c, info = lapack.dpotrf(k, lower=0, clean=1, overwrite_a=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"Cholesky failed (info={info})")  # pragma: no cover
    x, info = lapack.dpotri(c, lower=0, overwrite_c=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"inverse failed (info={info})")  # pragma: no cover
    mu_lo = 1.0 / (lam_max + SHIFT)
    # divide and conquer (evd) on the whole spectrum is faster here than a subset with vectors
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
    lam = 1.0 / mu[first:][::-1] - SHIFT
    if vec is not None:
        vec = np.ascontiguousarray(vec[:, first:][:, ::-1])
    return lam, vec
