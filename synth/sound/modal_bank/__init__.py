"""Exact pulse-to-mode synthesis (docs/physics.md, "Modal synthesis"): every impact is one complex
amplitude per mode injected into one pass of the bank, so tails add exactly and onsets keep
sub-sample times; a mode stops when all it could add stays within its share of the floor."""

from synth.sound.modal_bank.bank_kernels import (
    SUB,
    TILE,
    inject_amplitudes,
    power_table,
    remainder,
    ring_bank,
    ring_modes,
)
from synth.sound.modal_bank.pulse import (
    LONG_CONTACT_NEPERS,
    PULSE_POINTS,
    BankCoefficients,
    ImpactExcitation,
    PulseLayout,
    bank_coefficients,
    impact_excitation,
    pulse_layout,
    samples_in_contact,
    transform_pulse,
    transform_workspace,
)
from synth.sound.modal_bank.synthesis import Bank, kept_modes, synthesize
from synth.sound.modal_bank.transform_kernels import (
    RICHARDSON_MAX_PHASE,
    WORK_ROWS,
    impact_transform,
    long_impact_transform,
)

__all__ = [
    "LONG_CONTACT_NEPERS", "PULSE_POINTS", "RICHARDSON_MAX_PHASE", "SUB", "TILE", "WORK_ROWS",
    "Bank", "BankCoefficients", "ImpactExcitation", "PulseLayout", "bank_coefficients",
    "impact_excitation", "impact_transform", "inject_amplitudes", "kept_modes",
    "long_impact_transform", "power_table", "pulse_layout", "remainder", "ring_bank", "ring_modes",
    "samples_in_contact", "synthesize", "transform_pulse", "transform_workspace",
]  # fmt: skip
