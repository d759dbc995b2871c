"""The finite plate in the contact: the ball against the plate's modes (docs/physics.md,
"Plate impedance" and "Plate modes").

The plate under the ball is its modes at the contact point (``c_k = phi_k(x0)^2 / M_k``,
1/kg), a free plate's rigid-body motion, and the residual above the band (lumped modes and a
one-pole tail), so every contact starts on the infinite plate's admittance and the modes add
reflections and ringing. Losses: Hunt & Crossley, J. Appl. Mech. 42 (1975) 440-445;
viscoelastic, Brilliantov et al. 1996.

Numerics: fixed steps, first-order hold on the force, linear parts advanced exactly by
exponential integrators (Hochbruck & Ostermann, Acta Numerica 19 (2010) 209-286), the force at
a step's end the root of one monotone scalar equation: unconditionally stable, second order.
The modes solve exactly the band, so results do not depend on the caches."""

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
    "BAND_FACTOR", "PLATE_THEORIES", "RESIDUAL_BINS", "RESIDUAL_RATIO", "SETTLE_FACTOR",
    "STEPS_PER_CONTACT", "ModalPoint", "ModalContact", "ModalImpactResult", "PlateRinging",
    "band_modes", "clear_memory_cache", "impedance_contact_time", "modal_point", "next_touch"
]  # fmt: skip
