"""The plate's modes below a frequency, counted from the lattice of its wavenumbers before
any is solved, and the cold mode solver's size and floating-point operations.
"""

from __future__ import annotations

import math

import numpy as np

from synth.cost.records import CHECK_SQUARES, SOLVER_SQUARES, SolverCost


def bending_wavenumber(plate, f_max: float) -> float:
    """The bending wavenumber at ``f_max`` (Hz), rad/m."""
    omega = 2.0 * math.pi * f_max
    return math.sqrt(omega * math.sqrt(plate.surface_density / plate.flexural_rigidity))


def modal_count(plate, max_frequency: float) -> int:
    """Modes of ``plate`` below ``max_frequency`` (Hz): the wavenumber lattice of the
    rectangle, ``(m pi / a)^2 + (n pi / b)^2 <= k^2`` with ``k^4 = omega^2 rho h / D``,
    counted exactly (``m, n >= 1`` for simply supported edges, where it is the exact count).
    Its area term is the asymptotic modal density ``S omega / (4 pi) sqrt(rho h / D)``
    (Cremer, Heckl & Petersson, eq. 5.118); the lattice adds the edges' share, which
    dominates for a strip (a beam's ``k a / pi`` modes where the area term counts few).
    Clamped edges are counted as simply supported (their wavenumbers lie half a step
    higher). Free edges: :func:`_free_modal_count`."""
    k = bending_wavenumber(plate, max_frequency)
    if plate.boundary == "free":
        return _free_modal_count(plate, k)
    kx, ky = k * plate.length / math.pi, k * plate.width / math.pi  # lattice radii
    n = np.arange(1, int(math.floor(ky)) + 1, dtype=float)
    rows = np.floor(kx * np.sqrt(np.maximum(1.0 - (n / ky) ** 2, 0.0)))
    return int(np.sum(np.maximum(rows, 0.0)))


def _free_modal_count(plate, k: float) -> int:
    """Modes of a free ``plate`` whose bending wavenumber ``k`` (rad/m) is the band's top: the
    free beam's functions along each side (Warburton, Proc. Inst. Mech. Eng. 168, 371 (1954);
    Blevins' single-span beams) counted on the lattice ``q_x^2 + q_y^2 <= k^2``, plus the
    twisting modes up to ``q_T^2 = (sqrt(g^2 + 4 k^4) - g) / 2``, ``g = 24 (1 - nu) / b^2``
    (the derivation: docs/cli.md, "The cost of a render, and its budget"), ``w = x y`` once."""
    a, b = plate.length, plate.width
    nu = plate.material.poisson
    qx, qy = _free_beam_wavenumbers(k, a), _free_beam_wavenumbers(k, b)
    reach = np.sqrt(np.maximum(k * k - qy * qy, 0.0))
    bending = int(np.sum(np.searchsorted(qx, reach, side="right")))
    twist_x = _twisting_count(k, a, 24.0 * (1.0 - nu) / (b * b))
    twist_y = _twisting_count(k, b, 24.0 * (1.0 - nu) / (a * a))
    return bending + twist_x + twist_y - (1 if twist_x >= 2 and twist_y >= 2 else 0)


def _free_beam_wavenumbers(k: float, length: float) -> np.ndarray:
    """The free beam's wavenumbers up to ``k`` (rad/m) on ``length`` m, rigid rotation
    left out (:func:`_free_modal_count`): 0, then ``(j - 1/2) pi / length``, ``j >= 2``."""
    j = np.arange(2, int(k * length / math.pi + 0.5) + 1, dtype=float)
    return np.concatenate(([0.0], (j - 0.5) * math.pi / length))


def _twisting_count(k: float, length: float, g: float) -> int:
    """Twisting modes ``q = m pi / length <= q_T`` (``m >= 0``) of :func:`_free_modal_count`,
    ``g`` (1/m^2) the torsional term of their dispersion."""
    q_t = math.sqrt(0.5 * (math.sqrt(g * g + 4.0 * k**4) - g))
    return int(math.floor(q_t * length / math.pi)) + 1


def solver_cost(plate, f_max: float, modes: int) -> SolverCost:
    """The :class:`SolverCost` of ``plate``'s ``modes`` modes up to ``f_max`` (Hz)."""
    from synth.physics import modes as plate_modes

    main, check = plate_modes.solver_sizes(plate, f_max)
    flops = sum(n**3 / 3 + 2 * n**3 / 3 + 9 * n**3 for n in main)
    flops += sum(n**3 / 3 + 2 * n**3 / 3 + 4 * n**3 / 3 for n in check)
    return SolverCost(
        unknowns=max(main + check, default=0),
        flops=float(flops),
        solver_bytes=8 * max(SOLVER_SQUARES * max(main, default=0) ** 2,
                             CHECK_SQUARES * max(check, default=0) ** 2),
        shapes_bytes=8 * max(main, default=0) * modes,
    )  # fmt: skip
