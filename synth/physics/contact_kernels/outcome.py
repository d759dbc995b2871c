"""The result array of one impact: field order and :func:`impact_row` (SI, energy balance)."""

from __future__ import annotations

from collections import namedtuple

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


#: How a contact ended (dimensionless): ``status``; ``s_contact`` (separation, or proof it
#: cannot), ``s_force`` (force pulse's end); ``s_end, w_end, x_end``; ``i2 = Int f^2``,
#: ``loss``; ``x_max``, ``f_max``; ``n_steps``.
End = namedtuple("End", "status s_contact s_force s_end w_end x_end i2 loss x_max f_max n_steps")
#: Scales of one impact: ``m`` (kg), ``v_in``, ``v0`` (m/s), ``theta`` (s), ``f_scale`` (N),
#: Zener's ``lam``, dimensionless gravity ``G``.
Scales = namedtuple("Scales", "m v_in v0 theta lam G f_scale")


@compiled(inline="always")
def impact_row(e, elastic_end, sc):
    """The result array of the contact that ended as ``e`` at the scales ``sc``."""
    w_end, x_end, G, lam, v0, theta = e.w_end, e.x_end, sc.G, sc.lam, sc.v0, sc.theta
    separated = e.status == SEPARATED
    tiny_rebound = separated and w_end > 0.0
    if tiny_rebound:
        # still (barely) approaching: the rebound is below the absolute resolution
        w_end = 0.0
    i1 = 1.0 - w_end + G * e.s_end  # from w' = G - f
    # energy balance, dimensionless (docs/physics.md, "Hertz contact", in the plate's frame)
    lhs = 0.5 * w_end * w_end + elastic_end - G * x_end - 0.5
    rhs = G * lam * i1 - lam * e.i2 - e.loss
    # relative to the energy exchanged: arrival energy, or gravity's work and the energy
    # carried away when larger (a slow heavy ball sinking with the plate)
    scale = max(0.5, abs(G * lam * i1), lam * e.i2, abs(e.loss), abs(G * x_end))
    v_out = -w_end * v0 if separated else 0.0
    r = np.zeros(N_RESULT)
    r[R_STATUS] = e.status
    r[R_TINY_REBOUND] = 1.0 if tiny_rebound else 0.0
    r[R_RESTITUTION] = v_out / sc.v_in
    r[R_CONTACT_TIME] = e.s_force * theta
    r[R_SEPARATION_TIME] = e.s_contact * theta
    r[R_MAX_PENETRATION] = e.x_max * theta * v0
    r[R_PEAK_FORCE] = e.f_max * sc.f_scale
    r[R_IMPULSE] = i1 * sc.m * v0
    r[R_INELASTICITY] = lam
    r[R_REBOUND_SPEED] = v_out
    r[R_PLATE_ENERGY] = lam * e.i2 * sc.m * v0 * v0
    r[R_ENERGY_RESIDUAL] = abs(lhs - rhs) / scale
    r[R_N_STEPS] = e.n_steps
    r[R_G] = G
    r[R_S_CONTACT] = e.s_contact
    r[R_THETA] = theta
    r[R_F_SCALE] = sc.f_scale
    return r
