"""The finite plate in the contact: the ball against the plate's modes (docs/physics.md,
"Plate impedance" and "Plate modes").

The impedance model (:mod:`synth.physics.contact`) gives the plate surface under the ball the
velocity ``v_free - beta F`` of an infinite plate. Here the plate is the finite plate itself:
its displacement under the ball is

    w(t) = sum_k q_k(t) + q_rigid(t) + sum_j q_j(t) - x_res(t)

* ``q_k`` bending mode k (:func:`synth.physics.modes.modes`, frequencies ``omega_k``, decay rates
  ``sigma_k``), seen at the contact point ``x0``: ``q_k'' + 2 sigma_k q_k' + omega_k^2 q_k =
  -c_k F`` with the coupling ``c_k = phi_k(x0)^2 / M_k`` (1/kg);
* ``q_rigid`` the rigid-body motion of a free plate (translation and two rotations,
  ``q_rigid'' = -c_rigid F``, ``c_rigid = (1 + 3 xi^2 + 3 eta^2) / M`` with ``xi, eta`` the
  point's coordinates scaled to [-1, 1]); none for supported or clamped edges;
* the residual: the modes above the band limit ``Omega``, the infinite plate's continuum of
  modes less the band's (Kirchhoff's or Mindlin's modal mass factor), realised by
  :data:`RESIDUAL_BINS` lumped modes a :data:`RESIDUAL_RATIO` apart and a one-pole tail
  ``x_res' = beta_W F - a x_res`` above the last bin (docs/physics.md, "Plate impedance":
  the residual, its bins, its tail and their accuracy).

So the onset of every contact sees the infinite plate's admittance, the modes add what the
finite plate does within the band (reflections from edges and corners, the ringing left by an
earlier impact), and as ``Omega`` grows the model tends to the finite thin plate. Far from the
edges, before any reflection returns, it equals the impedance model.

Ball (mass ``m``, height ``u`` of its lowest point, gravity ``g``): ``m u'' = F - m g``;
contact law ``F = K delta^n`` with ``delta = w - u``
(:func:`synth.physics.contact_law.contact_law`),
or with a loss ``F = K delta^(n-1) (delta + (mu delta + b) delta')``, ``F >= 0``: Hunt &
Crossley's ``K delta^n (1 + mu delta')`` for ``b = 0`` (J. Appl. Mech. 42 (1975) 440-445) and
the viscoelastic Hertz contact ``K (delta^(3/2) + (3/2) A delta^(1/2) delta')`` for ``mu = 0``,
``b = (3/2) A`` (Kuwabara & Kono 1987; Brilliantov et al. 1996; docs/physics.md, "Contact
losses").

Numerics. Fixed steps ``h``; over each step the force is taken linear in time (first-order
hold), and every linear part (modes, rigid body, residual, the ball's free flight) is advanced
exactly for that force: with ``z = p h`` for a pole ``p``, the responses to the force at the
start and at the end of the step are ``h (phi_1(z) - phi_2(z))`` and ``h phi_2(z)``,
``phi_1(z) = (e^z - 1) / z``, ``phi_2(z) = (e^z - 1 - z) / z^2`` (exponential integrators,
Hochbruck & Ostermann, Acta Numerica 19 (2010) 209-286). The force at the end of the step is
then the root of one scalar equation, ``delta + B F(delta) = A`` (monotone: one root; with the
loss, ``delta'`` at the end of the step is itself linear in that force), so the
scheme is implicit in the contact and unconditionally stable for every mode; its error is
second order in ``h`` (of order 3/2 with the viscoelastic loss, whose force starts like
``t^(1/2)``). The end of contact is the root of ``delta(h') = 0`` within the last step.
The modes are those of an eigen-solution of exactly the band (:func:`band_modes`): a cached
wider band's modes differ in their last digits, which a series of bounces amplifies to audible
differences, so the result does not depend on what the process or the disk cache solved before.
Energy is book-kept (ball, modes, modal damping, rigid body, residual spring and dashpot, the
contact's loss ``Int (F - K delta^n) delta' dt`` by the trapezoid rule) and its
balance reported as ``energy_residual``.

The package's modules: :mod:`~synth.physics.modal_contact.kernels` (the numba kernels),
:mod:`~synth.physics.modal_contact.point` (the plate seen from one point, its modes' cache and
the residual) and :mod:`~synth.physics.modal_contact.contact` (the impact, the plate's state,
the next landing); every public name is importable from the package.
"""

from synth.physics.modal_contact.contact import (
    BAND_FACTOR,
    SETTLE_FACTOR,
    STEPS_PER_CONTACT,
    ModalContact,
    ModalImpactResult,
    PlateRinging,
    impedance_contact_time,
    next_touch,
)
from synth.physics.modal_contact.point import (
    PLATE_THEORIES,
    RESIDUAL_BINS,
    RESIDUAL_RATIO,
    ModalPoint,
    band_modes,
    clear_memory_cache,
    modal_point,
)

__all__ = [
    "BAND_FACTOR",
    "PLATE_THEORIES",
    "RESIDUAL_BINS",
    "RESIDUAL_RATIO",
    "SETTLE_FACTOR",
    "STEPS_PER_CONTACT",
    "ModalPoint",
    "ModalContact",
    "ModalImpactResult",
    "PlateRinging",
    "band_modes",
    "clear_memory_cache",
    "impedance_contact_time",
    "modal_point",
    "next_touch",
]
