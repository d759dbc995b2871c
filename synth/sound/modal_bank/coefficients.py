"""What every impact on one plate, heard by one listener, shares: the modal bank's
coefficients (see :mod:`synth.sound.modal_bank`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class BankCoefficients:
    """What every impact on one plate, heard by one listener, shares: the poles ``p_k``
    (rad/s), the listener response per unit pulse transform
    ``-i b_k output_k / omega_dk`` and the ringing over one sample ``e^(p_k / fs)``, as
    contiguous real and imaginary parts; ``samplerate`` in Hz; ``omega_max`` and
    ``sigma_max`` the largest ``|Im p_k|`` and ``-Re p_k`` (rad/s, 1/s)."""

    poles: np.ndarray
    samplerate: float
    omega_max: float
    sigma_max: float
    pole_re: np.ndarray
    pole_im: np.ndarray
    coef_re: np.ndarray
    coef_im: np.ndarray
    step_re: np.ndarray
    step_im: np.ndarray


def highest_frequency(poles: np.ndarray) -> float:
    """The largest ``|Im p_k|`` of the ``poles`` (rad/s; 0 for none): the frequency the
    pulse grid must resolve."""
    return float(np.max(np.abs(poles.imag))) if poles.size else 0.0


def response_per_transform(poles, excitation, output) -> np.ndarray:
    """The listener's response per unit pulse transform of modes with ``poles`` (rad/s),
    excited with ``excitation`` ``b_k`` (1/kg) and heard with ``output``: ``-i b_k
    output_k / omega_dk`` (the ringing ``Re[A exp(p t)]`` of a mode struck by a pulse,
    :mod:`synth.sound.modal_bank`)."""
    return -1j * excitation / poles.imag * output


def bank_coefficients(poles, excitation, output, samplerate) -> BankCoefficients:
    """:class:`BankCoefficients` of modes with ``poles`` (rad/s, below Nyquist), excited
    with ``excitation`` ``b_k`` (1/kg) and heard with ``output`` (see
    :func:`~synth.sound.modal_bank.synthesize`), at ``samplerate`` Hz."""
    fs = float(samplerate)
    poles = np.ascontiguousarray(poles, dtype=complex)
    omega_max = highest_frequency(poles)
    sigma_max = float(np.max(-poles.real)) if poles.size else 0.0
    coef = response_per_transform(poles, excitation, output)
    step = np.exp(poles * (1.0 / fs))  # one sample's ringing
    parts = (np.ascontiguousarray(v) for z in (poles, coef, step) for v in (z.real, z.imag))
    return BankCoefficients(poles, fs, omega_max, sigma_max, *parts)
