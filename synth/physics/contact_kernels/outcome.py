"""The result array of one impact: its fields' order and :func:`impact_row`, which fills it
for both the power laws' and the thin shell's drivers (SI results and the energy balance of
docs/physics.md, "Hertz contact")."""

from __future__ import annotations

import numpy as np

from synth.compilation import compiled
from synth.physics.contact_kernels.equations import SEPARATED

# Fields of the result array: the one place that names their order.
R_STATUS = 0  # SEPARATED, SETTLED or a failure code
R_TINY_REBOUND = 1  # 1: separated with a rebound below the solver's resolution
R_STIFF = 2  # 1: integrated by Radau IIA, 0: by DOP853 (power laws)
R_RESTITUTION = 3  # v_out / v_in
R_CONTACT_TIME = 4  # s, the force pulse's length (force > 0)
R_MAX_PENETRATION = 5  # m
R_PEAK_FORCE = 6  # N
R_IMPULSE = 7  # N s
R_INELASTICITY = 8  # Zener's lam = beta m / theta
R_REBOUND_SPEED = 9  # m/s
R_PLATE_ENERGY = 10  # J
R_ENERGY_RESIDUAL = 11  # relative error of the energy balance
R_N_STEPS = 12  # accepted steps
R_G = 13  # dimensionless gravity g theta / v0 (dense output)
R_C = 14  # dimensionless Hunt-Crossley loss mu v0 (dense output; power laws)
R_S_CONTACT = 15  # dimensionless end of contact (dense output)
R_THETA = 16  # the time scale, s
R_F_SCALE = 17  # force scale m v0 / theta, N
R_B = 18  # dimensionless viscoelastic loss (3/2) A / theta (dense output; power laws)
R_SEPARATION_TIME = 19  # s, to the penetration's return to 0 (the dense output's end)
R_XT = 20  # dimensionless transition deflection delta_t / (theta v0) (shell law)
R_XY = 21  # dimensionless yield penetration delta_y / (theta v0) (power laws; inf: none)
N_RESULT = 22


@compiled(inline="always")
def impact_row(
    status, w_end, x_end, elastic_end, s_end, s_force, s_contact, i2, loss, max_penetration,
    f_max, n_steps, m, v_in, v0, theta, lam, G, f_scale,
):  # fmt: skip
    """The result array (fields ``R_*``; the law's own ones left 0) of a contact that ended
    with ``status`` at the dimensionless state ``w_end, x_end`` (the law's elastic energy
    ``elastic_end`` there) at ``s_end``, its force pulse lasting ``s_force`` and its contact
    ``s_contact``, the quadratures ``I2 = Int f^2`` (``i2``) and the loss' work ``loss``; the
    largest penetration (m), the largest dimensionless force ``f_max``, the accepted steps;
    the mass ``m`` (kg), the impact and approach speeds ``v_in`` and ``v0`` (m/s), the scales
    ``theta`` (s) and ``f_scale`` (N), Zener's ``lam`` and the dimensionless gravity ``G``."""
    separated = status == SEPARATED
    tiny_rebound = separated and w_end > 0.0
    if tiny_rebound:
        # The contact ended with the ball still (barely) approaching: the rebound is
        # below the solver's absolute resolution (atol of v0).
        w_end = 0.0
    i1 = 1.0 - w_end + G * s_end  # from w' = G - f
    # energy balance, dimensionless (docs/physics.md, "Hertz contact", in the plate's frame)
    lhs = 0.5 * w_end * w_end + elastic_end - G * x_end - 0.5
    rhs = G * lam * i1 - lam * i2 - loss
    # relative to the energy exchanged: the arrival energy, or the work of gravity and the
    # energy carried away when they are larger (a slow, heavy ball sinking with the plate)
    scale = max(0.5, abs(G * lam * i1), lam * i2, abs(loss), abs(G * x_end))
    v_out = -w_end * v0 if separated else 0.0
    r = np.zeros(N_RESULT)
    r[R_STATUS] = status
    r[R_TINY_REBOUND] = 1.0 if tiny_rebound else 0.0
    r[R_RESTITUTION] = v_out / v_in
    r[R_CONTACT_TIME] = s_force * theta
    r[R_SEPARATION_TIME] = s_contact * theta
    r[R_MAX_PENETRATION] = max_penetration
    r[R_PEAK_FORCE] = f_max * f_scale
    r[R_IMPULSE] = i1 * m * v0
    r[R_INELASTICITY] = lam
    r[R_REBOUND_SPEED] = v_out
    r[R_PLATE_ENERGY] = lam * i2 * m * v0 * v0
    r[R_ENERGY_RESIDUAL] = abs(lhs - rhs) / scale
    r[R_N_STEPS] = n_steps
    r[R_G] = G
    r[R_S_CONTACT] = s_contact
    r[R_THETA] = theta
    r[R_F_SCALE] = f_scale
    return r
