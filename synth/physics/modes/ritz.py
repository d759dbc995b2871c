"""Free and clamped plates: the Rayleigh-Ritz solution (docs/physics.md, "Plate modes"). The
four symmetry classes (:mod:`~.basis`) are solved again with a larger nested basis: Ritz
values fall monotonically to the exact ones, so the two bound each mode's error, and every
mode returned agrees to :data:`TOLERANCE` (else the basis grows)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from synth.compilation import compiled
from synth.errors import SynthError
from synth.physics.modes.basis import (
    SHIFT,
    RitzProblem,
    basis_1d,
    basis_alpha,
    index_set,
    solve_class,
)
from synth.physics.modes.common import CHUNK_ELEMENTS, VERSION, ratios, single_thread_product

#: Relative accuracy of every returned mode's frequency (Ritz estimate, see above).
TOLERANCE = 1e-4

# Basis-size rule g(kappa) = kappa + C1 kappa^(1/3) + C0 (degrees) and the check basis' extra
# degrees, from the Legendre convergence of free and clamped plates (tests/test_plate.py).
_C0 = 2.0
_C1 = 3.0
_D0 = 2.0
_D1 = 1.0
# Largest symmetry-class matrix (unknowns) the dense solver accepts: 12000^2
# doubles are 1.2 GB. Above it, max_frequency is refused.
_MAX_UNKNOWNS = 12000
# Parity classes (x, y): 0 = even, 1 = odd.
_CLASSES = ((0, 0), (0, 1), (1, 0), (1, 1))
#: Symmetry classes with more unknowns than this (in the first basis) are solved on one BLAS
#: thread. Every size is: BLAS's threads split its sums, so the modes' last bits would depend
#: on the process's thread count. ``math.inf``: never on one thread.
ONE_THREAD_UNKNOWNS = 0


@compiled()
def _take_columns(a, index):  # pragma: no cover
    """Reorder the columns of ``a`` in place: ``a[p, k] = a_old[p, index[k]]``."""
    n, m = a.shape
    row = np.empty(m)
    for p in range(n):
        for k in range(m):
            row[k] = a[p, index[k]]
        for k in range(m):
            a[p, k] = row[k]


@dataclass(eq=False, repr=False)
class RitzSolution:
    """Free or clamped modes of aspect ``a/b`` and Poisson ``nu`` up to ``omega_max``
    (dimensionless ``omega L^2 sqrt(rho h / D)``, ``L = max(a, b)``): ``omega`` ascending, mode
    ``k`` column ``col[k]`` of ``coef[cls[k]]`` on ``psi_I(xi) psi_J(eta)``, ``I, J =
    index[cls[k]]`` (shape ``2 sum c_ij psi_i psi_j``); ``info`` how it was obtained."""

    boundary: str
    nu: float
    aspect: float
    omega_max: float
    omega: np.ndarray
    cls: np.ndarray
    col: np.ndarray
    index: list
    coef: list
    info: dict
    nbytes: int = field(init=False)
    key: str = field(init=False)
    # dense coefficient tensors, the latest few kept (grids are evaluated chunk by chunk)
    _dense: dict = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self):
        arrays = (self.omega, self.cls, self.col, *[a for ij in self.index for a in ij], *self.coef)
        for arr in arrays:
            arr.setflags(write=False)
        self.nbytes = sum(arr.nbytes for arr in arrays)
        solution = solution_key(self.boundary, self.nu, self.aspect)
        omega_max = float(self.omega_max).hex()
        self.key = json.dumps({"solution": solution, "omega_max": omega_max}, sort_keys=True)

    def _dense_coefficients(self, c, m, axis):
        """Class ``c``'s first ``m`` modes' coefficients as a dense ``(n_s, n_t * m)`` matrix
        along ``axis``, zero where the basis has no pair. Read-only, cached."""
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
        """Shapes ``(len(xi), n_modes)`` of the first modes at ``(xi, eta)`` by matrix products per
        class; shared coordinates share partial sums; temporaries below ``CHUNK_ELEMENTS``."""
        out = np.empty((xi.size, n_modes))
        if n_modes == 0 or xi.size == 0:
            return out
        alpha = basis_alpha(self.boundary)
        cls = self.cls[:n_modes]
        counts = np.bincount(cls, minlength=4)
        start = np.concatenate(([0], np.cumsum(counts)))
        parts = [(c, slice(int(start[c]), int(start[c + 1])), self.coef[c][:, : counts[c]],
                  *self.index[c]) for c in range(4) if counts[c]]  # fmt: skip
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
            chunk = max(1, CHUNK_ELEMENTS // max(nb, n_modes, nx, ny))
            for first in range(0, xi.size, chunk):
                rows = slice(first, first + chunk)
                px = basis_1d(alpha, nx, xi[rows])[0]
                py = basis_1d(alpha, ny, eta[rows])[0]
                for _, cols, coef, I, J in parts:
                    single_thread_product(2.0 * (px[:, I] * py[:, J]), coef, out[rows, cols])
        index = np.empty(n_modes, dtype=np.int64)
        for c in range(4):
            index[cls == c] = np.arange(start[c], start[c + 1])
        _take_columns(out, index)
        return out

    def summed(self, n_modes, length, width, wavenumber):
        """First ``n_modes`` shapes as :class:`SummedShapes` (``length``, ``width`` m; rad/m)."""
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
        alpha = basis_alpha(self.boundary)
        return SummedShapes(length, width, wavenumber, n_x, n_y, n_modes, alpha, tuple(parts), self)

    def _grouped(self, out, parts, axis, u, inv, v, inv_v, alpha):
        """Shapes at points sharing ``axis`` coordinates into ``out``: the grouped sum once per
        distinct ``u``, then each point's sum over the other."""
        deg = [(I, J) if axis == 0 else (J, I) for *_, I, J in parts]
        ps = 2.0 * basis_1d(alpha, max(int(S.max()) for S, _ in deg) + 1, u)[0]
        pv = basis_1d(alpha, max(int(T.max()) for _, T in deg) + 1, v)[0]
        order = np.argsort(inv, kind="stable")
        bounds = np.searchsorted(inv[order], np.arange(u.size + 1))
        for (c, cols, coef, *_), (S, T) in zip(parts, deg):
            m = coef.shape[1]
            dense = self._dense_coefficients(c, m, axis)
            ni, nj = dense.shape[0], dense.shape[1] // m
            ps_c = ps[:, int(S[0]) % 2 :: 2][:, :ni]
            pv_c = pv[:, int(T[0]) % 2 :: 2][:, :nj]
            batch = max(1, CHUNK_ELEMENTS // (nj * m))
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


def _wavenumbers(aspect: float, omega: float, grow: float = 1.0) -> tuple[float, float]:
    """The band's wavenumbers per unit of xi and eta, times ``grow``: ``k L = sqrt(Omega)``."""
    rx, ry = ratios(aspect)
    k_l = math.sqrt(omega) * grow
    return 0.5 * k_l / rx, 0.5 * k_l / ry


def _index_sets(kx: float, ky: float, check: bool = False) -> list:
    """The main (or the larger check) basis ``(I, J)`` of each symmetry class."""
    c0, c1 = (_C0 + _D0, _C1 + _D1) if check else (_C0, _C1)
    return [index_set(px, py, kx, ky, c0, c1) for px, py in _CLASSES]


def _check_unknowns(kx: float, ky: float) -> float:
    """Estimated unknowns of the check basis' largest class (pi/4 of the degree rectangle / 4)."""
    nx_max = kx + (_C1 + _D1) * kx ** (1.0 / 3.0) + _C0 + _D0
    ny_max = ky + (_C1 + _D1) * ky ** (1.0 / 3.0) + _C0 + _D0
    return math.pi / 16.0 * nx_max * ny_max


def ritz_unknowns(aspect: float, omega: float) -> float:
    """Estimated unknowns of the largest class of the check basis for the band ``omega``."""
    return _check_unknowns(*_wavenumbers(aspect, omega))


def first_basis(aspect: float, omega: float):
    """The first main basis for ``omega`` without any matrix (for :mod:`synth.cost`): degrees
    along an axis, the factors ``(n_x, n_y)`` and each class's unknowns."""
    kx, ky = _wavenumbers(aspect, omega)
    sets = _index_sets(kx, ky)
    degrees = int(max([1] + [np.unique(a).size for ij in sets for a in ij]))
    n_x = max([1] + [int(i.max()) + 1 for i, _ in sets if i.size])
    n_y = max([1] + [int(j.max()) + 1 for i, j in sets if i.size])
    sizes = [i.size for i, _ in sets], [i.size for i, _ in _index_sets(kx, ky, True)]
    return degrees, (n_x, n_y), sizes


def _solve_classes(problem: RitzProblem, main, check, lam_cut, one_thread):
    """``(lam, vec, lam_check)`` of each class; ``one_thread``: one BLAS thread (a multithreaded
    LAPACK call stalls on busy cores)."""

    def solve(c):
        lam, vec = solve_class(problem, *main[c], lam_cut, True)
        lam2, _ = solve_class(problem, *check[c], lam_cut, False)
        return lam, vec, lam2

    if not one_thread:
        return [solve(c) for c in range(4)]
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):
        return [solve(c) for c in range(4)]


def _bases(aspect: float, omega_req: float, grow: float):
    """Main and check bases for ``omega_req``; ``TooLarge`` past the dense solver."""
    kx, ky = _wavenumbers(aspect, omega_req, grow)
    if _check_unknowns(kx, ky) > _MAX_UNKNOWNS:
        raise TooLarge(int(_check_unknowns(kx, ky)))
    main, check = _index_sets(kx, ky), _index_sets(kx, ky, check=True)
    largest = max(ij[0].size for ij in check)
    if largest > _MAX_UNKNOWNS:
        raise TooLarge(largest)
    return main, check


def _elastic(boundary: str, c: int, lam, vec, lam2):
    """The class's eigenpairs without the free plate's rigid-body modes (zero eigenvalues)."""
    if boundary != "free" or c == 3:
        return lam, vec, lam2
    if not (lam.size and lam2.size and abs(lam[0]) < 1e-6 * SHIFT and abs(lam2[0]) < 1e-6 * SHIFT):
        raise SynthError("free plate: rigid-body modes not found")  # pragma: no cover
    return lam[1:], vec[:, 1:], lam2[1:]


def _worst_change(om, om2, omega_req: float) -> float:
    """Largest relative change of a mode up to ``omega_req`` from the main basis (``om``) to the
    check basis (``om2``); ``inf`` when a check mode has no main partner."""
    need = int(np.searchsorted(om2, omega_req, side="right"))
    if need > om.size:
        return math.inf
    if not need:
        return 0.0
    return float(np.max(np.abs((om[:need] - om2[:need]) / om[:need])))


def solve_ritz(boundary: str, nu: float, aspect: float, omega_req: float) -> RitzSolution:
    """All converged modes with dimensionless frequency <= ``omega_req``."""
    lam_cut = (omega_req * (1.0 + 10.0 * TOLERANCE)) ** 2
    grow = 1.0
    attempts = []
    one_thread = None
    for _ in range(6):
        main, check = _bases(aspect, omega_req, grow)
        problem = RitzProblem.over(boundary, aspect, nu, check)
        if one_thread is None:  # decided on the first basis, kept for the larger ones
            one_thread = max(ij[0].size for ij in main) > ONE_THREAD_UNKNOWNS
        lams, vecs, worst = [], [], 0.0
        for c, solved in enumerate(_solve_classes(problem, main, check, lam_cut, one_thread)):
            lam, vec, lam2 = _elastic(boundary, c, *solved)
            om = np.sqrt(np.maximum(lam, 0.0))
            # Every check mode at or below omega_req needs a converged main partner.
            worst = max(worst, _worst_change(om, np.sqrt(np.maximum(lam2, 0.0)), omega_req))
            keep = int(np.searchsorted(om, omega_req, side="right"))
            lams.append(om[:keep])
            vecs.append(np.ascontiguousarray(vec[:, :keep]))
        unknowns = [ij[0].size for ij in main], [ij[0].size for ij in check]
        attempts.append(dict(grow=grow, unknowns=unknowns[0], check_unknowns=unknowns[1],
                             worst_relative_change=worst))  # fmt: skip
        if worst <= TOLERANCE:
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
    return RitzSolution(
        boundary, nu, aspect, omega_req, omega[order], cls[order], col[order], main, vecs,
        {"attempts": attempts},
    )  # fmt: skip


def solution_key(boundary: str, nu: float, aspect: float) -> str:
    """Everything that determines a stored solution, as canonical JSON."""
    return json.dumps(
        {"version": VERSION, "boundary": boundary, "nu": float(nu).hex(),
         "aspect": float(aspect).hex(), "c0": _C0, "c1": _C1, "d0": _D0, "d1": _D1,
         "shift": SHIFT, "tolerance": TOLERANCE},
        sort_keys=True,
    )  # fmt: skip


class TooLarge(Exception):
    def __init__(self, n, what="unknowns per symmetry class", limit=_MAX_UNKNOWNS):
        self.n = n
        self.what = what
        self.limit = limit


@dataclass(frozen=True, eq=False)
class SummedShapes:
    """Shapes ``phi_k = sum_ij C_kij X_i(x) Y_j(y)``: a weighted sum over points is ``sum_ij
    C_kij A_ij`` with one ``A = X^T diag(w) Y`` for every mode. ``length``, ``width``,
    ``wavenumber``: m, rad/m."""

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
        """``phi_k`` at ``points`` ((n, 2), metres, on the plate): ``(n, n_modes)``."""
        pts = np.asarray(points, dtype=float)
        xi = np.clip(2.0 * pts[:, 0] / self.length - 1.0, -1.0, 1.0)
        eta = np.clip(2.0 * pts[:, 1] / self.width - 1.0, -1.0, 1.0)
        return self._solution.shapes(xi, eta, self.n_modes)

    def x_values(self, x: np.ndarray) -> np.ndarray:
        """``X_i(x)`` for ``i < n_x``: ``(len(x), n_x)``, ``x`` in metres."""
        xi = np.clip(2.0 * np.asarray(x, dtype=float) / self.length - 1.0, -1.0, 1.0)
        return basis_1d(self._alpha, self.n_x, xi)[0]

    def y_values(self, y: np.ndarray) -> np.ndarray:
        """``Y_j(y)`` for ``j < n_y``: ``(len(y), n_y)``, ``y`` in metres."""
        eta = np.clip(2.0 * np.asarray(y, dtype=float) / self.width - 1.0, -1.0, 1.0)
        return basis_1d(self._alpha, self.n_y, eta)[0]

    def combine(self, sums: np.ndarray, modes: np.ndarray | None = None) -> np.ndarray:
        """``out[r, k] = sum_ij C_kij sums[r, i, j]``, one matrix product per class."""
        flat = np.ascontiguousarray(sums, dtype=float).reshape(sums.shape[0], -1)
        width = self.n_modes if modes is None else len(modes)
        out = np.empty((flat.shape[0], width))
        for cols, pairs, coef in self._parts:
            if modes is not None:
                taken = np.isin(cols, modes)
                if not taken.any():
                    continue
                coef = np.ascontiguousarray(coef[:, taken])
                cols = np.searchsorted(modes, cols[taken])
            part = np.empty((flat.shape[0], cols.size))
            single_thread_product(np.ascontiguousarray(flat[:, pairs]), coef, part)
            out[:, cols] = part
        return out
