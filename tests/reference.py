"""References the tests compare the engine with: slower or diagnostic forms of what the
package computes another way (adaptive quadrature, a bare Ritz solve, the transform on
the renderer's grid), kept here because nothing in the package calls them.
"""

from __future__ import annotations

import math

import numpy as np

from synth import checks
from synth.compilation import compiled
from synth.constants import PULSE_POINTS
from synth.errors import ParameterError
from synth.physics.modal_contact.point import (
    PLATE_THEORIES,
    RESIDUAL_BINS,
    RESIDUAL_RATIO,
    _band_edge_loss,
    _coupling_density,
    _lumped_residual,
    _mode_frequency,
    _wavenumber_at,
)
from synth.physics.modes.ritz import (
    _C0,
    _C1,
    _CLASSES,
    RitzProblem,
    index_set,
    ratios,
    solve_class,
)
from synth.physics.scene import Plate
from synth.sound.modal_bank.pulse import grid_size, transform_workspace
from synth.sound.modal_bank.transform_kernels import impact_transform
from synth.sound.radiation.bessel_j0 import HANKEL_FROM, j0_cephes, j0_hankel


def pulse_grid(result, omega_max, min_points=PULSE_POINTS):
    """Uniform grid of a pulse fine enough for the transform: ``(h, forces)``.

    ``omega_max`` (rad/s) is the highest mode's angular frequency; the grid has at least
    ``min_points`` points and a step ``h`` (s) with ``omega_max h <= pi / 4``; ``forces``
    in N.
    """
    tau = result.separation_time
    n = grid_size(tau, omega_max, min_points)
    h = tau / (n - 1)
    u = np.arange(n) * h
    f = result.force_at(u)
    return h, np.ascontiguousarray(f)


def pulse_transforms(result, poles, omega_max=None):
    """Laplace transforms ``L_k = Int_0^tau F(u) exp(-p_k u) du`` of an impact's force
    pulse at the poles ``p_k`` (rad/s), N s, by the rule the renderer uses (trapezoid
    rule on :func:`pulse_grid`'s grid for ``omega_max``, rad/s; default the highest
    ``|Im p_k|``). A settled contact's remaining weight is not included."""
    poles = np.ascontiguousarray(poles, dtype=complex)
    if omega_max is None:
        omega_max = float(np.max(np.abs(poles.imag))) if poles.size else 0.0
    h, f = pulse_grid(result, omega_max)
    out = np.empty(poles.size, dtype=complex)
    one = np.ones(poles.size)
    zero = np.zeros(poles.size)
    impact_transform(
        np.ascontiguousarray(poles.real),
        np.ascontiguousarray(poles.imag),
        one,
        zero,
        one,
        zero,
        1.0,
        h,
        f,
        np.zeros(f.size),
        0.0,
        np.zeros(0),
        np.zeros(0),
        0.0,
        result.separation_time,
        result.pulse_order,
        out,
        np.zeros(0),
        transform_workspace(poles.size),
    )
    return out


def ritz_frequencies(
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
    rx, ry = ratios(aspect)
    k_l = math.sqrt(omega_basis)
    sets = [index_set(px, py, 0.5 * k_l / rx, 0.5 * k_l / ry, c0, c1) for px, py in _CLASSES]
    problem = RitzProblem.over(boundary, aspect, nu, sets)
    out = []
    for c, (I, J) in enumerate(sets):
        lam, _ = solve_class(problem, I, J, omega_cut**2, False)
        if boundary == "free" and c != 3:
            lam = lam[1:]
        out.append(np.sqrt(np.maximum(lam, 0.0)))
    return np.sort(np.concatenate(out))


def residual_admittance_exact(
    plate: Plate, max_frequency: float, frequency, *, theory: str = "kirchhoff"
) -> np.ndarray:
    """The residual's admittance (m/(N s), complex, ``e^(i omega t)``) at ``frequency`` (Hz,
    below ``max_frequency``) from the wavenumber integral it lumps: ``i omega Int dmu /
    (w(s)^2 - omega^2 + 2 i sigma(w) omega)`` over the bins' span ``[Omega, W]`` (module
    docstring; ``sigma`` the plate's damping law) by adaptive quadrature, plus the tail
    above ``W``. The reference of :meth:`ModalPoint.residual`."""
    from scipy.integrate import quad

    fmax = checks.positive("max_frequency", max_frequency, "Hz")
    if theory not in PLATE_THEORIES:
        raise ParameterError(f"theory={theory!r} must be one of {PLATE_THEORIES}")
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if not np.all((f > 0.0) & (f < fmax)):
        raise ParameterError(f"frequency={frequency!r} must be in (0, max_frequency) (Hz)")
    omega_band = 2.0 * math.pi * fmax
    top = omega_band * RESIDUAL_RATIO**RESIDUAL_BINS
    lo, hi = _wavenumber_at(plate, omega_band, theory), _wavenumber_at(plate, top, theory)
    tail = _lumped_residual(plate, omega_band, theory)
    loss = _band_edge_loss(plate, omega_band, fmax)

    def term(x, w):
        wk = float(_mode_frequency(plate, x, theory))
        sigma = loss * wk
        return complex(_coupling_density(plate, x, theory)) / (wk * wk - w * w + 2j * sigma * w)

    out = []
    for w in 2.0 * math.pi * f:
        re = quad(lambda x, w=w: term(x, w).real, lo, hi, limit=200)[0]
        im = quad(lambda x, w=w: term(x, w).imag, lo, hi, limit=200)[0]
        s = 1j * w
        out.append(s * complex(re, im) + tail.tail_admittance * s / (s + tail.tail_rate))
    y = np.array(out)
    return y.reshape(np.shape(frequency)) if np.ndim(frequency) else y[0]


@compiled()
def bessel_j0(x):
    """J_0 of every entry of the 1-D array ``x`` (each ``>= 0``), as
    :func:`synth.sound.radiation.polar._add_circle_sums` evaluates it."""
    out = np.empty(x.size)
    for k in range(x.size):
        if x[k] >= HANKEL_FROM:
            out[k] = j0_hankel(1.0 / x[k], math.sqrt(1.0 / x[k]), x[k])
        else:
            out[k] = j0_cephes(x[k])
    return out
