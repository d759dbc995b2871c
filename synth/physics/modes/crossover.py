"""Large free and clamped plates: a band whose Ritz problem exceeds :data:`CROSSOVER_UNKNOWNS`
per class takes the Ritz modes of a low band and the edge effect modes above (linear cost;
within 0.5 % of Ritz, docs/physics.md, "Large free and clamped plates")."""

from __future__ import annotations

import json

import numpy as np

from synth.physics.modes.cache import cached_ritz
from synth.physics.modes.ritz import RitzSolution, TooLarge, ritz_unknowns

#: Relative accuracy of the edge effect frequencies above a crossed-over plate's Ritz low band,
#: against the Ritz solver (tests/test_asymptotic_modes.py).
EDGE_EFFECT_TOLERANCE = 0.005
# Ritz unknowns per class beyond which a band crosses over (the Ritz solve grows cubically);
# just above every preset's band at 48 kHz.
CROSSOVER_UNKNOWNS = 1850
# Ritz size of a crossed-over low band: its lowest modes (the edge effect's least accurate)
# exact in a fraction of a second.
LOW_BAND_UNKNOWNS = 300
# Most modes any band may hold (arrays of a few hundred MB per listener beyond).
_MAX_MODES = 2_000_000


def band_of_unknowns(aspect: float, unknowns: float, omega_hi: float) -> float:
    """The band (dimensionless, <= ``omega_hi``) with about ``unknowns`` Ritz unknowns per class."""
    lo, hi = 0.0, omega_hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if ritz_unknowns(aspect, mid) > unknowns:
            hi = mid
        else:
            lo = mid
    return lo


def crosses(aspect: float, omega_req: float) -> bool:
    """True when the band ``omega_req`` (dimensionless) of aspect ``a/b`` crosses over: its
    Ritz problem would exceed :data:`CROSSOVER_UNKNOWNS` per class."""
    return ritz_unknowns(aspect, omega_req) > CROSSOVER_UNKNOWNS


def low_band(aspect: float, omega_req: float) -> float:
    """The Ritz band (dimensionless) of a crossed-over band ``omega_req``: the one place that
    sets it, for the solve and for the cache keys that name it."""
    return band_of_unknowns(aspect, LOW_BAND_UNKNOWNS, omega_req)


def _seam(omega: np.ndarray, omega_low: float) -> float:
    """Where the Ritz modes hand over: the middle of the widest relative gap in the top third of
    ``omega <= omega_low`` (an edge mode's error does not move it across)."""
    band = omega[(omega >= omega_low * 2.0 / 3.0) & (omega <= omega_low)]
    if band.size < 2:
        return omega_low
    gaps = np.diff(band) / band[1:]
    i = int(np.argmax(gaps))
    return float(0.5 * (band[i] + band[i + 1]))


class HybridSolution:
    """Ritz modes to ``omega_low``, edge effect modes above to ``omega_max`` (dimensionless)."""

    def __init__(self, ritz: RitzSolution, omega_low: float, edge, omega_max: float):
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
        """Shapes of modes ``index``: Ritz ones from the first modes' columns, edge ones alone."""
        n_r = int(np.searchsorted(index, self.n_low))
        out = np.empty((xi.size, index.size))
        if n_r:
            out[:, :n_r] = self.ritz.shapes(xi, eta, int(index[n_r - 1]) + 1)[:, index[:n_r]]
        if index.size > n_r:
            edge = self.first + index[n_r:] - self.n_low
            self.edge.shapes(xi, eta, 0, out=out, column=n_r, index=edge)
        return out


def crossed(boundary, nu, aspect, omega_req, cache):
    """Hybrid solution of a band beyond the crossover (see ``CROSSOVER_UNKNOWNS``)."""
    from synth.physics import asymptotic_modes

    count = asymptotic_modes.mode_count_estimate(aspect, omega_req)
    if count > _MAX_MODES:
        raise TooLarge(int(count), "modes", _MAX_MODES)
    omega_low = low_band(aspect, omega_req)
    ritz = cached_ritz(boundary, nu, aspect, omega_low, cache)
    edge = asymptotic_modes.solve(boundary, nu, aspect, omega_req)
    return HybridSolution(ritz, omega_low, edge, omega_req)
