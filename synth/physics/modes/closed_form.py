"""Simply supported plates: the closed form (Leissa 1969, ch. 4), ``omega_mn = pi^2 sqrt(D /
(rho h)) ((m/a)^2 + (n/b)^2)``, ``phi_mn = 2 sin(m pi x / a) sin(n pi y / b)``."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from synth.compilation import compiled
from synth.physics.modes.common import CHUNK_ELEMENTS, VERSION, ratios


class SimplySupported:
    """Closed-form modes of a simply supported rectangle (``omega L^2 sqrt(rho h / D)``)."""

    def __init__(self, aspect, omega_max):
        rx, ry = ratios(aspect)
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
            {"version": VERSION, "boundary": "simply-supported", "aspect": float(aspect).hex(),
             "omega_max": float(omega_max).hex()},
            sort_keys=True,
        )  # fmt: skip

    def shapes(self, xi, eta, n_modes):
        out = np.empty((xi.size, n_modes))
        m = self.m[:n_modes]
        n = self.n[:n_modes]
        if n_modes == 0:
            return out
        mm = np.arange(1, int(m.max()) + 1)
        nn = np.arange(1, int(n.max()) + 1)
        chunk = max(1, CHUNK_ELEMENTS // max(n_modes, mm.size, nn.size))
        for start in range(0, xi.size, chunk):
            sl = slice(start, start + chunk)
            # x / a = (xi + 1) / 2
            sx = np.sin(0.5 * math.pi * (xi[sl, None] + 1.0) * mm[None, :])
            sy = np.sin(0.5 * math.pi * (eta[sl, None] + 1.0) * nn[None, :])
            out[sl] = 2.0 * sx[:, m - 1] * sy[:, n - 1]
        return out


@dataclass(frozen=True)
class SeparableShapes:
    """Shapes that are products ``X_i(x) Y_j(y)``, ``X_m(x) = sqrt(2) sin(m pi x / a)``, whose
    sums over points are shared between modes. ``length``, ``width``: m; ``wavenumber``: the
    largest factor's, rad/m."""

    length: float
    width: float
    x_index: np.ndarray = field(repr=False)
    y_index: np.ndarray = field(repr=False)
    wavenumber: float

    def x_values(self, x: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """``X_i(x)`` (``x`` in m) for every ``i`` in use, or for ``index`` alone."""
        return _sine_factors(x, math.pi / self.length, self.x_index, index)

    def y_values(self, y: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """``Y_j(y)`` (``y`` in m) for every ``j`` in use, or for ``index`` alone."""
        return _sine_factors(y, math.pi / self.width, self.y_index, index)

    def mode_wavenumbers(self) -> np.ndarray:
        """Wavenumbers (rad/m): each product of sines solves ``(lap + k^2) phi = 0`` everywhere."""
        kx = math.pi * (self.x_index + 1.0) / self.length
        ky = math.pi * (self.y_index + 1.0) / self.width
        return np.sqrt(kx * kx + ky * ky)


def _sine_factors(u, rate, in_use, index):
    """``sqrt(2) sin((i + 1) rate u)`` for every ``i`` in use, or for ``index`` (libm)."""
    t = np.ascontiguousarray(u, dtype=float) * rate
    n = int(in_use.max()) + 1 if in_use.size else 0
    if index is None:
        return _sine_table(t, n)
    index = np.asarray(index, dtype=np.int64)
    if 4 * index.size < n:
        return math.sqrt(2.0) * np.sin(t[:, None] * (index + 1.0)[None, :])
    return _sine_table(t, n)[:, index]


@compiled(nogil=True)
def _sine_table(t, n):  # pragma: no cover
    """``out[j, m] = sqrt(2) sin((m + 1) t_j)``, ``m < n``, by rotation, restarted from libm every
    32 orders (rounding grows by about one ulp per order)."""
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
