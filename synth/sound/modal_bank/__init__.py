"""Exact pulse-to-mode synthesis (docs/physics.md, "Modal synthesis").

A force ``F(t)`` at ``x0`` drives each mode ``k`` of the plate (pole
``p_k = -sigma_k + i omega_dk``, shape ``phi_k``, modal mass ``M_k``)::

    q_k'' + 2 sigma_k q_k' + omega_k^2 q_k = b_k F(t),       b_k = phi_k(x0) / M_k

After a pulse that starts at ``t_n`` the mode rings exactly as

    q_k(t) = Re[A_nk exp(p_k (t - t_n))],    A_nk = -i b_k L_nk / omega_dk,
    L_nk = Int_0^tau F(u) exp(-p_k u) du         (the pulse's Laplace transform at the pole)

and a listener hears ``Re[G_k p_k A_nk exp(...)]`` (velocity times the
microphone's Rayleigh gain ``G_k``, Pa per m/s) or ``Re[phi_k(xp) p_k^2 A_nk
exp(...)]`` (an accelerometer, m/s^2). Samples inside a contact get the exact
partial transform ``Int_0^(t - t_n)`` instead, plus, for acceleration, the
direct term ``b_k F(t)``. Every impact is a complex amplitude injected into one
pass of the modal bank, so overlapping tails add exactly and every onset sits at
its true (sub-sample) time: nothing is rounded to the sample grid. A mode at or
above the Nyquist frequency is never rendered, so nothing aliases.

The transform is computed on a uniform grid of the pulse (from the contact
solver's dense output, an odd number of points, at least ``PULSE_POINTS``, fine
enough that ``omega_max h <= pi/4`` so the exponential is resolved at every
mode's frequency). The pulse vanishes like ``u^n`` at both ends (``n`` the
contact law's exponent, 3/2 for Hertz), so the trapezoid rule's leading error is
``C h^(n+1)`` (Navot's endpoint expansion, the ``zeta(-n)`` term; 1.5e-5 of the
impulse for the thesis pulse on 65 points, measured) and no ``h^2`` term arises.
One Richardson step on the grid and on every other point removes it for every
mode with ``omega h <= 1/2`` (above that the step-2h rule no longer resolves the
oscillation and the plain rule is kept); what is left is of order ``|p|
h^(n+2)``: below 1e-7 of the impulse under 3 kHz and 2e-6 at 23 kHz for the
thesis pulse on 65 points (``tests/test_render.py`` checks this against adaptive
quadrature of the dense output). The in-contact samples' partial transforms
``Int_0^d`` end inside the pulse, where it is smooth: the trapezoid rule there has
an ``h^2`` term, removed by the Euler-Maclaurin end corrections with the force's
slope from the dense output (see ``impact_transform``).

Leaving out, with a budget. ``reference`` is the largest, over the impacts, of
the sum of the amplitudes ``|C_nk|`` of one impact (it bounds the peak of a
tick); each of the ``K`` modes below Nyquist gets the share ``floor * reference
/ K`` of the budget ``floor * reference``:

* a mode whose amplitudes add up, over all impacts, to at most its share is not
  rendered (it could never add more than that at any sample);
* a rendered mode stops, at an injection or when its state has fallen below its
  share (checked every ``SUB`` samples), if its state plus what it has already
  left out (decayed to now) is within its share; it restarts at the next impact;
* the audio ends when every mode has stopped (or at the caller's length cap,
  reported as ``left_at_end``).

So at every sample the omitted modes and tails add up to at most ``floor *
reference``, for any number of impacts.

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
