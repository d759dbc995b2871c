"""The polar rule of the Rayleigh integral for sums of separable shapes
(:func:`summed_gains`): the free and clamped plates' Ritz shapes.

Such shapes are ``phi_k = sum_ij C_kij X_i(x) Y_j(y)`` (:class:`synth.physics.modes.SummedShapes`).
:func:`summed_gains` applies the polar rule of :mod:`synth.sound.radiation.polar`: at each
radius the angular sums ``A_ij = sum_theta w X_i Y_j`` are one small matrix product whatever
the number of modes, and ``Phi_k = sum_ij C_kij A_ij`` one product of a block of radii's
``A`` with the coefficients; the exponentials are again one per mode and radius. Each mode
is refined alone (:func:`~synth.sound.radiation.refinement.refine_selective`): a rule after
the first check combines and exponentiates only the modes still failing. The
in-phase bounds ``S_k`` (``|phi_k|`` is not a sum of products) come from a rectangle rule
that resolves the shapes but not the acoustic phase.
"""

from __future__ import annotations

import numpy as np

from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.physics.modes import single_thread_product
from synth.sound.radiation.angular import angular_rule
from synth.sound.radiation.common import CHUNK_BYTES, REFINE, add_sums
from synth.sound.radiation.polar import polar_rule_gains, polar_setup
from synth.sound.radiation.rectangle import apply_rule, first_rule, panel_nodes

# ----------------------------------------------------------------------------------------
# Sums of separable shapes (free and clamped plates): for phi_k = sum_ij C_kij X_i Y_j the
# angular integral at radius r is Phi_k(r) = sum_ij C_kij A_ij(r), A(r) = X^T diag(w) Y,
# one small matrix product per radius (SummedShapes.combine). The in-phase integrals
# Int |phi_k| / R dA are not sums of products: they are taken once on a rectangle rule
# sized for twice the shapes' wavenumber and the 1/R peak, not the acoustic phase.


def _apply_summed_rule(shapes, setup, radii, wr, refine, active):
    """Integrals ``Int phi_k exp(-q_k (R - r_mid)) / R dA`` of the summed shapes ``k`` in
    ``active`` (increasing indices) by the polar rule of ``setup``
    (:class:`~synth.sound.radiation.polar._PolarSetup`) refined by ``refine`` (radii
    ``radii`` with weights ``wr``), and the number of points. The angular sums ``A``
    serve every mode; only the modes ``active`` are combined from them and take
    exponentials."""
    listener, kb, tol = setup.listener, setup.kb, setup.tol_panel
    q, r_mid, halvings = setup.q, setup.r_mid, setup.halvings
    a, b = setup.size
    xl, yl, zl = listener
    m = active.size
    q = q[active]
    every = m == shapes.n_modes
    acc_re, acc_im, unused = np.zeros(m), np.zeros(m), np.zeros(m)
    qr = np.ascontiguousarray(q.real) * 2.0 ** -max(halvings, 0)
    qi = np.ascontiguousarray(q.imag)
    rows = max(1, int(CHUNK_BYTES // (8 * max(m, shapes.n_x * shapes.n_y))))
    n_points = 0
    for start in range(0, radii.size, rows):
        rr = radii[start : start + rows]
        sums = np.zeros((rr.size, shapes.n_x, shapes.n_y))
        for i, r in enumerate(rr):
            theta, w = angular_rule(float(r), a, b, listener, kb, tol, refine)
            n_points += theta.size
            if theta.size:
                fx = shapes.x_values(np.clip(xl + r * np.cos(theta), 0.0, a))
                fy = shapes.y_values(np.clip(yl + r * np.sin(theta), 0.0, b))
                single_thread_product(np.ascontiguousarray((fx * w[:, None]).T), fy, sums[i])
        phi = shapes.combine(sums, None if every else active)
        big_r = np.sqrt(rr * rr + zl * zl)
        weight = wr[start : start + rows] * rr / big_r
        add_sums(0, rr.size, big_r - r_mid, weight, phi, qr, qi, halvings, acc_re, acc_im, unused)
    return acc_re + 1j * acc_im, n_points


def _summed_in_phase(shapes, size, listener, kb, tol, r_mid):
    """``Int |phi_k| / R dA`` of summed shapes on the refined rectangle rule of
    wavenumber ``2 kb`` (panels and orders of :func:`rayleigh_gains` without the
    acoustic phase)."""
    a, b = size
    m = shapes.n_modes
    ex, ey, px0, py0 = first_rule(a, b, listener, 2.0 * kb, tol)
    xs, wx = panel_nodes(ex, np.ceil(px0 * REFINE).astype(np.int64))
    ys, wy = panel_nodes(ey, np.ceil(py0 * REFINE).astype(np.int64))
    chunk = max(1, int(CHUNK_BYTES // (8 * max(m, 1))))
    _, mag = apply_rule(
        shapes.values, xs, wx, ys, wy, listener, np.zeros(m, complex), r_mid, 0, chunk
    )
    return mag


def summed_gains(
    shapes,
    listener_position,
    s,
    *,
    max_wavenumber,
    air_density=AIR_DENSITY,
    sound_speed=SOUND_SPEED,
    reference_distance=None,
    tol=1e-6,
    max_points=4_000_000,
    full_output=False,
):
    """:func:`rayleigh_gains` of shapes ``sum_ij C_kij X_i(x) Y_j(y)`` (``shapes``, a
    :class:`synth.physics.modes.SummedShapes` with the plate's size), in polar coordinates: the
    arguments, rule and convergence test of :func:`separable_gains`; the angular sums combine
    each mode's Ritz coefficients (the comment above :func:`_apply_summed_rule`), about
    ``N_theta n_x n_y + N_r n_basis n_modes / 4`` multiply-adds and ``N_r n_modes``
    exponentials per rule. Returns the gains, Pa per (m/s) of modal velocity, or a
    :class:`RadiationResult` (``rule`` "polar", ``panels`` the radial panels and 0)."""
    from synth.physics.modes import SummedShapes

    if not isinstance(shapes, SummedShapes):
        raise ParameterError(f"shapes={shapes!r} must be a synth.physics.modes.SummedShapes")
    settings = dict(max_wavenumber=max_wavenumber, air_density=air_density,
                    sound_speed=sound_speed, reference_distance=reference_distance, tol=tol,
                    max_points=max_points)  # fmt: skip
    setup = polar_setup(
        (shapes.length, shapes.width), shapes.n_modes, listener_position, s, settings
    )

    def in_phase():
        return _summed_in_phase(
            shapes, setup.size, setup.listener, setup.kb, setup.tol_panel, setup.r_mid
        )

    return polar_rule_gains(
        setup, shapes, in_phase, _apply_summed_rule, "summed_gains", full_output
    )
