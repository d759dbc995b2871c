"""Successive rules of the Rayleigh integral compared until the gains converge.

The first rule is checked by one with 1.25 times the points per axis, refined again (up to
six times) while any mode fails ``|H_fine - H_coarse| <= tol * max(|H_fine|, 1e-4 S_k)``,
``S_k = (rho |s_k| / (2 pi)) Int |phi_k| / R dA >= |H_k|`` the in-phase gain (the floor
keeps round-off from dominating modes that cancel below -80 dB). The finer rule's gains are
returned.
"""

from __future__ import annotations

import warnings

import numpy as np

from synth.sound.radiation.common import COHERENT_FLOOR, MAX_RULES, RadiationResult


def refine(rule, npoints, factor, scale, tol, max_points, panels, selective=False):
    """Rules ``rule(level, active)`` (-> integrals and in-phase integrals of the modes
    ``active``, indices) compared until every mode passes the test of the module docstring;
    the gains are ``factor`` times the integrals, the bounds ``scale`` times theirs.
    ``selective``: a mode that passes keeps that rule's gain and only the modes still
    failing go on (each mode's test is its own: the same bound)."""
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


def warn_unconverged(caller: str, result: RadiationResult, tol: float) -> None:
    """RuntimeWarning naming the mode furthest from the convergence test."""
    allowed = tol * np.maximum(np.abs(result.gains), COHERENT_FLOOR * result.coherent)
    worst = int(np.argmax(result.error / np.maximum(allowed, 1e-300)))
    warnings.warn(
        f"{caller}: {result.message} (mode {worst}: estimated error "
        f"{result.error[worst]:.3g} Pa s/m, allowed {allowed[worst]:.3g})",
        RuntimeWarning,
        stacklevel=3,
    )
