"""The result array of one impact: its fields' order and :func:`impact_row`, which fills it
for both the power laws' and the thin shell's drivers (SI results and the energy balance of
docs/physics.md, "Hertz contact")."""

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


#: How a contact ended, dimensionless (``finish`` and the shell's driver): its ``status``;
#: ``s_contact`` the time to separation (or to the proof that the ball cannot separate),
#: ``s_force`` the force pulse's end; the state ``s_end, w_end, x_end`` of the energy balance,
#: its quadratures ``I2 = Int f^2`` (``i2``) and the loss' work ``loss``; the largest
#: penetration ``x_max`` and force ``f_max``; the accepted steps ``n_steps``.
End = namedtuple("End", "status s_contact s_force s_end w_end x_end i2 loss x_max f_max n_steps")
#: The scales of one impact: the mass ``m`` (kg), the impact and approach speeds ``v_in`` and
#: ``v0`` (m/s), the time ``theta`` (s) and force ``f_scale`` (N), Zener's ``lam`` and the
#: dimensionless gravity ``G``.
Scales = namedtuple("Scales", "m v_in v0 theta lam G f_scale")


@compiled(inline="always")
def impact_row(e, elastic_end, sc):
    """The result array (fields ``R_*``; the law's own ones left 0) of the contact that ended
    as ``e`` (:data:`End`; ``elastic_end`` the law's elastic energy at ``x_end``) at the
    scales ``sc`` (:data:`Scales`)."""
    w_end, x_end, G, lam, v0, theta = e.w_end, e.x_end, sc.G, sc.lam, sc.v0, sc.theta
    separated = e.status == SEPARATED
    tiny_rebound = separated and w_end > 0.0
    if tiny_rebound:
        # The contact ended with the ball still (barely) approaching: the rebound is
        # below the solver's absolute resolution (atol of v0).
        w_end = 0.0
    i1 = 1.0 - w_end + G * e.s_end  # from w' = G - f
    # energy balance, dimensionless (docs/physics.md, "Hertz contact", in the plate's frame)
    lhs = 0.5 * w_end * w_end + elastic_end - G * x_end - 0.5
    rhs = G * lam * i1 - lam * e.i2 - e.loss
    # relative to the energy exchanged: the arrival energy, or the work of gravity and the
    # energy carried away when they are larger (a slow, heavy ball sinking with the plate)
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
