"""The finite plate in the contact: the ball against the plate's modes (docs/physics.md,
"Plate impedance" and "Plate modes").

The plate's displacement under the ball is ``w = sum_k q_k + q_rigid + sum_j q_j - x_res``:
its bending modes seen at the contact point (coupling ``c_k = phi_k(x0)^2 / M_k``, 1/kg),
a free plate's rigid-body motion, and the residual above the band limit (the infinite
plate's continuum less the band's, as :data:`RESIDUAL_BINS` lumped modes and a one-pole
tail). The onset of every contact sees the infinite plate's admittance and the modes add the
finite plate's reflections and ringing. Ball: ``m u'' = F - m g``, ``F = K delta^n`` with
``delta = w - u``, or with Hunt & Crossley's or the viscoelastic loss (J. Appl. Mech. 42
(1975) 440-445; Brilliantov et al. 1996; docs/physics.md, "Contact losses").

Numerics: fixed steps with a first-order hold on the force; every linear part is advanced
exactly by exponential integrators (Hochbruck & Ostermann, Acta Numerica 19 (2010)
209-286), the force at the step's end the root of one monotone scalar equation, so the
scheme is implicit in the contact, unconditionally stable and second order in ``h``. The
modes are an eigen-solution of exactly the band (:func:`band_modes`), so results do not
depend on the caches. Energy is book-kept and its balance reported as ``energy_residual``.

Modules: :mod:`~.kernels` (numba kernels), :mod:`~.point` (the plate seen from one point,
its cache and residual), :mod:`~.contact` (the impact, the plate's state, the next landing).
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
