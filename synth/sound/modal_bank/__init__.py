"""Exact pulse-to-mode synthesis (docs/physics.md, "Modal synthesis").

Each mode ``k`` (pole ``p_k = -sigma_k + i omega_dk``) rings after a pulse that starts at
``t_n`` as ``q_k(t) = Re[A_nk exp(p_k (t - t_n))]``, ``A_nk = -i b_k L_nk / omega_dk``, with
``L_nk`` the pulse's Laplace transform at the pole; samples inside a contact get the partial
transform (and an accelerometer the direct term ``b_k F(t)``). Every impact is one complex
amplitude per mode injected into one pass of the bank: tails add exactly, onsets keep their
sub-sample times, and no mode at or above Nyquist is rendered.

The transforms use the trapezoid rule on a uniform grid of the pulse (``omega_max h <=
pi/4``). The pulse vanishes like ``u^n`` at both ends, so the rule's leading error is
``C h^(n+1)`` (Navot 1961, the ``zeta(-n)`` term) and one Richardson step removes it where
``omega h <= 1/2`` (above, the step-2h rule no longer resolves the oscillation and the plain
rule is kept); the in-contact partial transforms get Euler-Maclaurin end corrections from
the force's slope (``impact_transform``).

Leaving out, with a budget: each of the ``K`` modes below Nyquist gets the share ``floor *
reference / K``; a mode is not rendered, or stops (checked every ``SUB`` samples) until the
next impact, when all it could add stays within its share, so what is left out adds up to
at most ``floor * reference`` at every sample, for any number of impacts.

The package in five modules, in the order a render takes them:
:mod:`~synth.sound.modal_bank.coefficients` (what every impact on one plate and listener
shares), :mod:`~synth.sound.modal_bank.pulse` (one contact's pulse on its grid, its
transforms and in-contact response), :mod:`~synth.sound.modal_bank.transform_kernels`
(the numba quadrature of those transforms), :mod:`~synth.sound.modal_bank.bank_kernels`
(the numba block ringing of the modes, with the omission budget) and
:mod:`~synth.sound.modal_bank.synthesis` (:func:`synthesize`: all of them for a bounce
sequence).
"""

from synth.sound.modal_bank.bank_kernels import (
    SUB,
    TILE,
    inject_amplitudes,
    power_table,
    remainder,
    ring_bank,
    ring_modes,
)
from synth.sound.modal_bank.coefficients import BankCoefficients, bank_coefficients
from synth.sound.modal_bank.pulse import (
    LONG_CONTACT_NEPERS,
    PULSE_POINTS,
    ImpactExcitation,
    PulseLayout,
    impact_excitation,
    pulse_layout,
    samples_in_contact,
    transform_pulse,
    transform_workspace,
)
from synth.sound.modal_bank.synthesis import kept_modes, synthesize
from synth.sound.modal_bank.transform_kernels import (
    RICHARDSON_MAX_PHASE,
    WORK_ROWS,
    impact_transform,
    long_impact_transform,
)

__all__ = [
    "LONG_CONTACT_NEPERS",
    "PULSE_POINTS",
    "RICHARDSON_MAX_PHASE",
    "SUB",
    "TILE",
    "WORK_ROWS",
    "BankCoefficients",
    "ImpactExcitation",
    "PulseLayout",
    "bank_coefficients",
    "impact_excitation",
    "impact_transform",
    "inject_amplitudes",
    "kept_modes",
    "long_impact_transform",
    "power_table",
    "pulse_layout",
    "remainder",
    "ring_bank",
    "ring_modes",
    "samples_in_contact",
    "synthesize",
    "transform_pulse",
    "transform_workspace",
]
