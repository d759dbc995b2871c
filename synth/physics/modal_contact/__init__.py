"""The finite plate in the contact: the ball against the plate's modes, rigid-body motion and the
residual above the band (docs/physics.md, "Plate impedance", "Plate modes"), integrated by
exponential integrators with fixed steps (unconditionally stable, second order)."""

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
