"""The finite rectangular plate's bending modes, Kirchhoff theory (docs/physics.md, "Plate
modes"); shapes have mean square 1 (``M_k = rho h a b``) and an arbitrary sign."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from synth import checks
from synth.errors import ParameterError
from synth.physics.modes.cache import band_key, cache_info, cached_ritz, clear_memory_cache
from synth.physics.modes.closed_form import SeparableShapes, SimplySupported
from synth.physics.modes.common import numerics_key, single_thread_product
from synth.physics.modes.crossover import (
    EDGE_EFFECT_TOLERANCE,
    HybridSolution,
    crossed,
    crosses,
    low_band,
)
from synth.physics.modes.ritz import (
    TOLERANCE,
    RitzSolution,
    SummedShapes,
    TooLarge,
    first_basis,
)
from synth.physics.scene import Plate, check_type
from synth.store.cache import cache_dir

__all__ = [
    "Modes", "EdgeEffectPart", "modes", "SeparableShapes", "SummedShapes", "TOLERANCE",
    "EDGE_EFFECT_TOLERANCE", "cache_info", "clear_memory_cache", "cache_dir",
    "single_thread_product"
]  # fmt: skip


@dataclass(frozen=True)
class EdgeEffectPart:
    """Modes ``first_mode, first_mode + 1, ...`` of a :class:`Modes` are modes ``offset, ...`` of
    the edge effect ``solution``; those before ``first_mode`` are Rayleigh-Ritz modes."""

    first_mode: int
    solution: object
    offset: int

    def product_factors(self, x, y, length: float, width: float, index):
        """Modes ``index`` (ascending) of a ``length`` x ``width`` (m) plate as factor tables at
        the distinct ``x``, ``y`` (m): mode ``index[k]`` at ``(x[a], y[b])`` is ``x_own[a, k]
        y_own[b, k] + x_other[a, k] y_other[b, k]``."""
        xi = np.clip(2.0 * np.asarray(x, dtype=float) / length - 1.0, -1.0, 1.0)
        eta = np.clip(2.0 * np.asarray(y, dtype=float) / width - 1.0, -1.0, 1.0)
        own = np.asarray(index, dtype=np.int64) - self.first_mode + self.offset
        return self.solution.product_factors(xi, eta, own)


@dataclass(frozen=True, eq=False)
class Modes:
    """The bending modes of ``plate`` up to ``max_frequency`` (Hz), read-only: ``frequencies``
    (Hz, ascending, no rigid-body motion), ``angular_frequencies`` (rad/s), ``decay_rates``
    (1/s), ``modal_masses`` (kg), ``tolerance`` (relative; 0 for the closed form)."""

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
        """Text identifying :meth:`shapes` exactly, for caches of results computed from them."""
        p = self.plate
        return json.dumps(
            {"solution": self._solution.key, "length": float(p.length).hex(),
             "width": float(p.width).hex(), "modes": len(self), "numerics": numerics_key()},
            sort_keys=True,
        )  # fmt: skip

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
        """True when solved for exactly ``max_frequency`` (results independent of the cache)."""
        sol = self._solution
        if isinstance(sol, SimplySupported):
            return True
        if isinstance(sol, RitzSolution):
            return sol.omega_max == dimensionless_band(self.plate, self.max_frequency)
        # a hybrid: its Ritz part solved for exactly the low band this band asks for
        return sol.ritz.omega_max == ritz_band(self.plate, self.max_frequency)

    def separable(self) -> SeparableShapes | None:
        """The shapes as products ``X_i(x) Y_j(y)`` (simply supported plates), else None."""
        sol = self._solution
        if not isinstance(sol, SimplySupported):
            return None
        n = len(self)
        p = self.plate
        m_idx = np.asarray(sol.m[:n], dtype=np.int64) - 1
        n_idx = np.asarray(sol.n[:n], dtype=np.int64) - 1
        k = math.pi * max((m_idx.max() + 1) / p.length, (n_idx.max() + 1) / p.width) if n else 0.0
        return SeparableShapes(p.length, p.width, m_idx, n_idx, k)

    def shapes(self, points, index=None) -> np.ndarray:
        """Shapes (mean square 1) at ``points`` (n, 2; m), a column per mode or per ``index``."""
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
            pts = np.empty(0)
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ParameterError(
                f"points={points!r} must be an (n, 2) array of (x, y) positions (metres)"
            )
        a, b = self.plate.length, self.plate.width
        bad = ~np.all(np.isfinite(pts), axis=1)
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
        if isinstance(self._solution, HybridSolution):
            return self._solution.shapes_of(xi, eta, index)
        return self._solution.shapes(xi, eta, int(index[-1]) + 1 if index.size else 0)[:, index]

    def edge_effect(self) -> EdgeEffectPart | None:
        """The modes of the dynamic edge effect method (beyond the Ritz crossover), or None."""
        sol = self._solution
        if not isinstance(sol, HybridSolution) or sol.n_low >= len(self):
            return None
        return EdgeEffectPart(sol.n_low, sol.edge, sol.first)

    def summed(self) -> SummedShapes | None:
        """The shapes as sums ``sum_ij C_kij X_i(x) Y_j(y)`` (free and clamped plates), or None."""
        sol = self._solution
        if not isinstance(sol, RitzSolution):
            return None
        p = self.plate
        omega = float(self.angular_frequencies[-1]) if len(self) else 0.0
        k = (omega * omega * p.surface_density / p.flexural_rigidity) ** 0.25
        return sol.summed(len(self), p.length, p.width, k)


def frequency_scale(plate: Plate) -> float:
    """``omega / Omega`` (rad/s), ``Omega = omega L^2 sqrt(rho h / D)``, ``L = max(a, b)``."""
    length = max(plate.length, plate.width)
    return math.sqrt(plate.flexural_rigidity / plate.surface_density) / length**2


def dimensionless_band(plate: Plate, max_frequency: float) -> float:
    """``max_frequency`` (Hz) as the dimensionless ``Omega`` of the solutions."""
    return 2.0 * math.pi * max_frequency / frequency_scale(plate)


def ritz_band(plate: Plate, max_frequency: float) -> float:
    """The dimensionless band of the Ritz problem up to ``max_frequency`` (Hz)."""
    aspect = plate.length / plate.width
    omega_req = dimensionless_band(plate, max_frequency)
    return low_band(aspect, omega_req) if crosses(aspect, omega_req) else omega_req


def solver_key(plate: Plate, max_frequency: float) -> str:
    """Text identifying the eigen-solution of ``plate`` to ``max_frequency`` (Hz): a cache key."""
    from synth.physics import asymptotic_modes

    if plate.boundary == "simply-supported":
        return json.dumps({"method": "closed-form", "numerics": numerics_key()}, sort_keys=True)
    nu = plate.material.poisson
    aspect = plate.length / plate.width
    omega_req = dimensionless_band(plate, max_frequency)
    key = {
        "ritz": band_key(plate.boundary, nu, aspect, ritz_band(plate, max_frequency)),
        "numerics": numerics_key(),
    }
    if crosses(aspect, omega_req):
        key["edge"] = asymptotic_modes.solution_key(plate.boundary, nu, aspect, omega_req)
    return json.dumps(key, sort_keys=True)


def shape_terms(plate: Plate, max_frequency: float) -> int:
    """Terms of a shape value per mode on a grid before any solve (for :mod:`synth.cost`)."""
    return 1 if plate.boundary == "simply-supported" else _first_basis(plate, max_frequency)[0]


def ritz_factors(plate: Plate, max_frequency: float) -> tuple[int, int]:
    """Factors ``(n_x, n_y)`` of the first Ritz basis up to ``max_frequency`` (Hz)."""
    return _first_basis(plate, max_frequency)[1]


def solver_sizes(plate: Plate, max_frequency: float) -> tuple[list[int], list[int]]:
    """Unknowns of each class's main and check Ritz bases up to ``max_frequency`` (Hz)."""
    if plate.boundary == "simply-supported":
        return [], []
    return _first_basis(plate, max_frequency)[2]


def _first_basis(plate: Plate, max_frequency: float):
    return first_basis(plate.length / plate.width, ritz_band(plate, max_frequency))


def modes(plate: Plate, *, max_frequency: float, cache: bool = True) -> Modes:
    """Every bending mode of ``plate`` up to ``max_frequency`` (Hz, > 0), each to
    :data:`TOLERANCE` relative (:data:`EDGE_EFFECT_TOLERANCE` beyond the crossover). ``cache``:
    reuse and store the eigen-solution. ``ParameterError`` beyond two million modes."""
    check_type("plate", plate, Plate)
    damping = plate.damping_law()
    fmax = checks.positive("max_frequency", max_frequency, "Hz")
    if not isinstance(cache, bool):
        raise ParameterError(f"cache={cache!r} must be True or False")
    aspect = plate.length / plate.width
    scale = frequency_scale(plate)
    omega_req = dimensionless_band(plate, fmax)
    if plate.boundary == "simply-supported":
        sol = SimplySupported(aspect, omega_req)
        tol = 0.0
    else:
        nu = plate.material.poisson
        try:
            if crosses(aspect, omega_req):
                sol = crossed(plate.boundary, nu, aspect, omega_req, cache)
            else:
                sol = cached_ritz(plate.boundary, nu, aspect, omega_req, cache)
        except TooLarge as exc:
            raise ParameterError(
                f"max_frequency={max_frequency!r} is too high for this plate (Hz): the "
                f"mode solver would need {exc.n} {exc.what}, more than {exc.limit}"
            ) from None
        tol = EDGE_EFFECT_TOLERANCE if isinstance(sol, HybridSolution) else TOLERANCE
    omega = sol.omega * scale
    freq = omega / (2.0 * math.pi)
    n = int(np.searchsorted(freq, fmax, side="right"))
    omega, freq = omega[:n].copy(), freq[:n].copy()
    sigma = np.broadcast_to(np.asarray(damping.decay_rate(omega), dtype=float), omega.shape).copy()
    mass = np.full(n, plate.mass)
    for arr in (omega, freq, sigma, mass):
        arr.setflags(write=False)
    return Modes(plate, fmax, freq, omega, sigma, mass, tol, sol)
