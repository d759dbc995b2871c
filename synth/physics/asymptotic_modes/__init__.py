"""Free and clamped plate modes by Bolotin's dynamic edge effect method (docs/physics.md, "Large
free and clamped plates"); a Rayleigh-Ritz step splits near-degenerate pairs."""

from __future__ import annotations

import json
import math

import numpy as np

from synth.physics.asymptotic_modes.factors import factor_edge_constants, factor_table, gather_modes
from synth.physics.asymptotic_modes.ritz import near_pairs, rayleigh_ritz
from synth.physics.asymptotic_modes.roots import solve_pairs, starting_s
from synth.physics.modes.common import ratios

__all__ = ["EdgeEffectSolution", "solve", "solution_key", "mode_count_estimate"]


#: Two modes of one symmetry class whose edge effect frequencies differ by less than this
#: (relative) are a near-degenerate pair, solved together by the Rayleigh-Ritz step.
_PAIR_GAP = 0.01


_VERSION = 3


def mode_count_estimate(aspect: float, omega: float) -> float:
    """Modes below the dimensionless ``omega``: the modal density ``N ~ omega a b / (4 pi)``
    (Cremer, Heckl & Petersson, Structure-Borne Sound, 3rd ed., eq. 5.118) in units of ``L``."""
    rx, ry = ratios(aspect)
    return omega / (4.0 * math.pi * rx * ry)


def _trial_indices(hx: float, hy: float, free: bool, omega_trials: float):
    """Indices ``(nx, ny)`` of the trials up to ``omega_trials`` on half sides ``hx``, ``hy``
    (units of ``L``), without rigid-body motions."""
    first = 0 if free else 2
    kmax = math.sqrt(omega_trials)
    ix = np.arange(first, int(kmax * 2.0 * hx / math.pi) + 3)
    iy = np.arange(first, int(kmax * 2.0 * hy / math.pi) + 3)
    kx_lo = np.maximum(ix - 1, 0) * math.pi / (2.0 * hx)
    ky_lo = np.maximum(iy - 1, 0) * math.pi / (2.0 * hy)
    keep = kx_lo[:, None] ** 2 + ky_lo[None, :] ** 2 <= omega_trials * (1.0 + 1e-9)
    gi, gj = np.nonzero(keep)
    nx, ny = ix[gi].astype(np.int64), iy[gj].astype(np.int64)
    if free:
        rigid = ((nx == 0) & (ny == 0)) | ((nx == 1) & (ny == 0)) | ((nx == 0) & (ny == 1))
        nx, ny = nx[~rigid], ny[~rigid]
    return nx, ny


class EdgeEffectSolution:
    """Modes of a free or clamped plate up to the dimensionless ``omega_max`` (lengths in units of
    ``L = max(a, b)``): mode ``k`` is ``own[k] trial[k] + other[k] trial[partner[k]]``
    (``partner`` -1: alone), of mean square 1."""

    def __init__(self, boundary: str, nu: float, aspect: float, omega_max: float):
        self.boundary = boundary
        self.nu = nu
        self.aspect = aspect
        self.omega_max = omega_max
        rx, ry = ratios(aspect)
        self.half = (0.5 / rx, 0.5 / ry)
        free = boundary == "free"
        hx, hy = self.half
        # trials above the band: the Ritz step moves a pair by at most about its gap
        omega_trials = omega_max * (1.0 + 2.0 * _PAIR_GAP)
        nx, ny = _trial_indices(hx, hy, free, omega_trials)
        sx = starting_s(nx, hx, free).copy()
        sy = starting_s(ny, hy, free).copy()
        solve_pairs(nx, ny, hx, hy, free, float(nu), sx, sy)
        om = sx + sy
        ok = np.isfinite(om) & (om > 0.0) & (om <= omega_trials)
        order = np.lexsort((ny[ok], nx[ok], om[ok]))
        trial_omega, self.nx, self.ny, self.sx, self.sy = (
            np.ascontiguousarray(a[ok][order]) for a in (om, nx, ny, sx, sy)
        )
        self.constants = (
            factor_edge_constants(self.sx, self.sy, self.nx, hx, free, float(nu)),
            factor_edge_constants(self.sy, self.sx, self.ny, hy, free, float(nu)),
        )  # edge coefficient and normalising factor of every trial's two factors
        (cx, gx), (cy, gy) = self.constants
        partner = near_pairs(trial_omega, self.nx % 2 * 2 + self.ny % 2, _PAIR_GAP)
        omega, own, other = rayleigh_ritz(
            self.sx, self.sy, self.nx, self.ny, hx, hy, free, float(nu), cx, gx, cy, gy,
            trial_omega, partner,
        )  # fmt: skip
        by_omega = np.argsort(omega, kind="stable")
        n = int(np.searchsorted(omega[by_omega], omega_max, side="right"))
        modes = by_omega[:n]
        self.trial = np.ascontiguousarray(modes)
        self.omega, self.partner, self.own, self.other = (
            np.ascontiguousarray(a[modes]) for a in (omega, partner, own, other)
        )
        self.n_paired = int(np.sum(self.partner >= 0))
        arrays = (self.omega, self.nx, self.ny, self.sx, self.sy, self.trial, self.partner)
        arrays += (self.own, self.other)
        for arr in arrays:
            arr.setflags(write=False)
        self.nbytes = sum(a.nbytes for a in arrays)
        self._tables = ({}, {})  # factor tables along x and along y (see _table)
        self.key = solution_key(boundary, nu, aspect, omega_max)

    def factors(self, xi: np.ndarray, eta: np.ndarray, n_trials: int):
        """Factors ``X_t(xi)``, ``Y_t(eta)`` (mean square 1) of the first ``n_trials`` trials at
        ``xi``, ``eta`` in [-1, 1]: ``(len(xi), n_trials)`` and ``(len(eta), n_trials)``."""
        m = slice(0, n_trials)
        return tuple(self._factor_table(a, np.ascontiguousarray(u, dtype=float), m)
                     for a, u in enumerate((xi, eta)))  # fmt: skip

    def _factor_table(self, axis, u, m):
        """Factors along ``axis`` (0: x, 1: y) of the trials ``m`` at ``u`` in [-1, 1]."""
        h, (c, g) = self.half[axis], self.constants[axis]
        s, so, n = (self.sx, self.sy, self.nx) if axis == 0 else (self.sy, self.sx, self.ny)
        return factor_table(u * h, s[m], so[m], n[m], h, c[m], g[m])

    def _table(self, axis, u, trials):
        """:meth:`_factor_table` at the distinct ``u``, the last two tables per axis kept."""
        tables = self._tables[axis]
        key = (trials.size, u.size, hash(u.tobytes()), hash(trials.tobytes()))
        held = tables.get(key)
        if held is not None and np.array_equal(held[0], u) and np.array_equal(held[1], trials):
            return held[2]
        table = self._factor_table(axis, u, trials)
        if len(tables) >= 2:
            tables.clear()
        tables[key] = (u.copy(), trials.copy(), table)
        return table

    def _used_tables(self, pick, u, v):
        """Modes ``pick``'s trials and partners (-1: none), the trials they use and those
        trials' factor tables at ``u`` (along x) and ``v`` (along y)."""
        trial, partner = self.trial[pick], self.partner[pick]
        used = np.unique(np.concatenate((trial, partner[partner >= 0])))
        return trial, partner, used, self._table(0, u, used), self._table(1, v, used)

    def shapes(self, xi, eta, n_modes, first=0, out=None, column=0, index=None):
        """Shapes of modes ``first <= k < n_modes`` (or ``index``) at ``(xi, eta)``, or into
        ``out[:, column:column + n]``."""
        ux, inv_x = np.unique(xi, return_inverse=True)
        uy, inv_y = np.unique(eta, return_inverse=True)
        pick = slice(first, n_modes) if index is None else np.asarray(index, dtype=np.int64)
        trial, partner, used, fx, fy = self._used_tables(pick, ux, uy)
        if out is None:
            out, column = np.empty((xi.size, trial.size)), 0
        gather_modes(
            fx, fy, inv_x.ravel(), inv_y.ravel(), np.searchsorted(used, trial),
            np.where(partner >= 0, np.searchsorted(used, partner), -1), self.own[pick],
            self.other[pick], out, column,
        )  # fmt: skip
        return out

    def product_factors(self, xi, eta, index):
        """Modes ``index`` as factor tables (as ``EdgeEffectPart.product_factors``)."""
        index = np.asarray(index, dtype=np.int64)
        xi, eta = np.asarray(xi, dtype=float), np.asarray(eta, dtype=float)
        trial, partner, used, fx, fy = self._used_tables(index, xi, eta)
        paired = partner >= 0
        own = np.searchsorted(used, trial)
        other = np.searchsorted(used, np.where(paired, partner, trial))
        x_own = self.own[index] * fx[:, own]
        x_other = np.where(paired, self.other[index] * fx[:, other], 0.0)
        y_other = np.where(paired, fy[:, other], 0.0)
        return x_own, np.ascontiguousarray(fy[:, own]), x_other, y_other


def solution_key(boundary: str, nu: float, aspect: float, omega_max: float) -> str:
    """Everything that sets :func:`solve`'s solution, as canonical JSON known before the solve."""
    return json.dumps(
        {"method": "edge-effect", "version": _VERSION, "boundary": boundary,
         "nu": float(nu).hex(), "aspect": float(aspect).hex(),
         "omega_max": float(omega_max).hex(), "pair_gap": float(_PAIR_GAP).hex()},
        sort_keys=True,
    )  # fmt: skip


def solve(boundary: str, nu: float, aspect: float, omega_max: float) -> EdgeEffectSolution:
    """Modes up to the dimensionless ``omega_max`` (see :class:`EdgeEffectSolution`)."""
    return EdgeEffectSolution(boundary, nu, aspect, omega_max)
