"""Successive rules of the Rayleigh integral compared until the gains converge.

The first rule is checked by one with 1.25 times the points per axis, refined again (up to
six times) while any mode fails ``|H_fine - H_coarse| <= tol * max(|H_fine|, 1e-4 S_k)``,
``S_k = (rho |s_k| / (2 pi)) Int |phi_k| / R dA >= |H_k|`` the in-phase gain (the floor
keeps round-off from dominating modes that cancel below -80 dB). The finer rule's gains are
returned; :func:`refine_selective` evaluates only the modes still failing.
"""

from __future__ import annotations

import warnings

import numpy as np

from synth.sound.radiation.common import COHERENT_FLOOR, MAX_RULES, RadiationResult


def _next_rule_too_large(npoints, level: int, max_points: int) -> bool:
    """Whether a refinement after rule ``level`` exists and would exceed ``max_points``."""
    return level + 1 < MAX_RULES and npoints(level + 1) > max_points


def _too_large_message(n_points: int, max_points: int) -> str:
    return f"stopped at {n_points} points: the next rule would exceed max_points={max_points}"


def refine(rule, npoints, factor, scale, tol, max_points, panels) -> RadiationResult:
    """Successive rules ``rule(level)`` (-> integrals, in-phase integrals) compared
    until every mode passes the convergence test of the module docstring; the gains
    are ``factor`` times the integrals and the in-phase bounds ``scale`` times theirs."""
    coarse, _ = rule(0)
    status, message = 1, "stopped at the last refinement without meeting tol"
    for level in range(1, MAX_RULES):
        fine, mag = rule(level)
        h_fine = factor * fine
        error = np.abs(factor * (fine - coarse))
        coherent = scale * mag
        allowed = tol * np.maximum(np.abs(h_fine), COHERENT_FLOOR * coherent)
        n_points = npoints(level)
        if np.all(error <= allowed):
            status, message = 0, f"converged with {n_points} points (refinement {level})"
            break
        if _next_rule_too_large(npoints, level, max_points):
            status, message = 2, _too_large_message(n_points, max_points)
            break
        coarse = fine
    return RadiationResult(
        gains=h_fine,
        error=error,
        coherent=coherent,
        n_points=n_points,
        refinements=level,
        panels=panels,
        success=status == 0,
        status=status,
        message=message,
    )


def refine_selective(rule, npoints, factor, scale, tol, max_points, panels) -> RadiationResult:
    """As :func:`refine`, but a mode that passes the test keeps that rule's gain, error
    and bound, and only the modes still failing are evaluated on the next rule:
    ``rule(level, active)`` returns the integrals and in-phase integrals of the modes
    ``active`` (indices). Each mode's test is its own, so the accepted gains meet the
    same bound as with every mode refined together."""
    m = factor.size
    active = np.arange(m)
    coarse, _ = rule(0, active)
    gains = np.empty(m, complex)
    error = np.empty(m)
    coherent = np.empty(m)
    status, message = 1, "stopped at the last refinement without meeting tol"
    for level in range(1, MAX_RULES):
        fine, mag = rule(level, active)
        f = factor[active]
        gains[active] = f * fine
        error[active] = np.abs(f * (fine - coarse))
        coherent[active] = scale[active] * mag
        allowed = tol * np.maximum(np.abs(gains[active]), COHERENT_FLOOR * coherent[active])
        failing = error[active] > allowed
        n_points = npoints(level)
        if not failing.any():
            status, message = 0, f"converged with {n_points} points (refinement {level})"
            break
        if _next_rule_too_large(npoints, level, max_points):
            status, message = 2, _too_large_message(n_points, max_points)
            break
        active = active[failing]
        coarse = fine[failing]
    return RadiationResult(
        gains=gains,
        error=error,
        coherent=coherent,
        n_points=n_points,
        refinements=level,
        panels=panels,
        success=status == 0,
        status=status,
        message=message,
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
