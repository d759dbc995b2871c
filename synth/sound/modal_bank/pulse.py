"""One contact's pulse as the modal bank takes it (:mod:`synth.sound.modal_bank`): its grid,
its transforms at the poles (compiled: the live engine's audio thread calls them too) and the
modes' excitation."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.compilation import announce, compiled
from synth.constants import PULSE_POINTS
from synth.errors import ParameterError
from synth.sound.modal_bank.transform_kernels import (
    WORK_ROWS,
    impact_transform,
    long_impact_transform,
)


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


def response_per_transform(poles, excitation, output) -> np.ndarray:
    """The listener's response ``-i b_k output_k / omega_dk`` per unit pulse transform of modes
    with ``poles`` (rad/s) and ``excitation`` ``b_k`` (1/kg)."""
    return -1j * excitation / poles.imag * output


def bank_coefficients(poles, excitation, output, samplerate) -> BankCoefficients:
    """:class:`BankCoefficients` of modes with ``poles`` (rad/s, below Nyquist), excited
    with ``excitation`` ``b_k`` (1/kg) and heard with ``output`` (see
    :func:`~synth.sound.modal_bank.synthesize`), at ``samplerate`` Hz."""
    fs = float(samplerate)
    poles = np.ascontiguousarray(poles, dtype=complex)
    omega_max = float(np.max(np.abs(poles.imag))) if poles.size else 0.0
    sigma_max = float(np.max(-poles.real)) if poles.size else 0.0
    coef = response_per_transform(poles, excitation, output)
    step = np.exp(poles * (1.0 / fs))  # one sample's ringing
    parts = (np.ascontiguousarray(v) for z in (poles, coef, step) for v in (z.real, z.imag))
    return BankCoefficients(poles, fs, omega_max, sigma_max, *parts)


#: Largest ``sigma_max tau`` (nepers) for :func:`impact_transform`, whose factors reach
#: ``e^(+-2 sigma tau)``: inside float64 (``e^(+-708)``) with a margin; longer contacts go
#: to :func:`long_impact_transform`.
LONG_CONTACT_NEPERS = 300.0


def grid_size(tau, omega_max, min_points=PULSE_POINTS):
    """Points of the uniform pulse grid over a contact of ``tau`` s: an odd number (for
    the extrapolation), at least ``min_points``, with a step ``h`` such that
    ``omega_max h <= pi / 4`` (8 points a period of the highest mode)."""
    n = max(min_points, int(math.ceil(4.0 * omega_max * tau / math.pi)) + 1)
    return n + 1 - n % 2


@dataclass(frozen=True, eq=False)
class ImpactExcitation:
    """One impact as the modal bank takes it: ``amplitudes`` (K,) complex, the modes' ringing
    referred to sample ``inject`` (the first after the contact; listener units); ``first``,
    the first sample inside the contact; ``response`` (M,), the exact listener response at
    samples ``first .. first + M - 1`` and ``forces`` (M,), the contact force there, N (for an
    accelerometer's direct term); ``magnitude``, ``sum_k |amplitudes_k|``, a bound of the
    tick's peak."""

    amplitudes: np.ndarray
    inject: int
    first: int
    response: np.ndarray
    forces: np.ndarray
    magnitude: float


@compiled()
def long_contact(sigma_max, tau):
    """True if the contact of ``tau`` s lasts more than ``LONG_CONTACT_NEPERS`` time
    constants of the fastest-decaying mode (``sigma_max``, 1/s): the transforms of
    :func:`long_impact_transform` rather than :func:`impact_transform`."""
    return sigma_max * tau > LONG_CONTACT_NEPERS


@compiled(inline="always")
def transform_pulse(
    pr, pi, cr, ci, ur, ui, sigma_max, period, h, forces, slopes, d0, offset_forces,
    offset_slopes, weight, tau, order, amps, resp, work,
):  # fmt: skip
    """:func:`impact_transform`, or :func:`long_impact_transform` for a :func:`long_contact`
    (compiled: the live engine's audio thread calls it too)."""
    if long_contact(sigma_max, tau):
        return long_impact_transform(
            pr, pi, cr, ci, ur, ui, period, h, forces, slopes, d0,
            offset_forces, offset_slopes, weight, tau, order, amps, resp, work,
        )  # fmt: skip
    return impact_transform(
        pr, pi, cr, ci, ur, ui, period, h, forces, slopes, d0,
        offset_forces, offset_slopes, weight, tau, order, amps, resp, work,
    )  # fmt: skip


def transform_workspace(modes: int) -> np.ndarray:
    """The workspace of :func:`transform_pulse` for ``modes`` modes."""
    return np.empty((WORK_ROWS, modes))


@dataclass(slots=True)
class PulseLayout:
    """Where one contact's pulse is sampled for its transforms (see :func:`impact_transform`):
    ``points`` grid points ``j step`` (s) from first touch, and the ``samples`` audio
    samples inside the contact, ``first .. first + samples - 1``, the first of them
    ``offset`` s (in ``[0, 1 / samplerate)``) after first touch."""

    points: int
    step: float
    first: int
    samples: int
    offset: float

    @property
    def inject(self) -> int:
        """The first sample after the contact, where the mode amplitudes join the bank."""
        return self.first + self.samples


def pulse_layout(
    contact_time: float, onset: float, omega_max: float, samplerate: float, pulse_points: int
) -> PulseLayout:
    """The :class:`PulseLayout` of a contact of ``contact_time`` s whose first touch is at
    ``onset`` s from sample 0, for modes up to ``omega_max`` rad/s at ``samplerate`` Hz,
    with at least ``pulse_points`` grid points (the kernel guards the rounding of a sample
    that falls on the touch)."""
    fs = samplerate
    n = grid_size(contact_time, omega_max, pulse_points)
    first = int(math.ceil(onset * fs - 1e-9))
    samples = max(0, int(math.ceil((onset + contact_time) * fs - 1e-9)) - first)
    return PulseLayout(n, contact_time / (n - 1), first, samples, first * (1.0 / fs) - onset)


def impact_excitation(
    coefficients: BankCoefficients,
    result,
    onset: float,
    *,
    weight=0.0,
    pulse_points=PULSE_POINTS,
    amplitudes=None,
    response=None,
    work=None,
) -> ImpactExcitation:
    """The excitation of the modes by the contact ``result`` (an ImpactResult) whose first
    touch is at ``onset`` s from sample 0 (sub-sample exact): its amplitudes at the first
    sample after the contact and its exact response inside it. ``weight``: ``m g`` (N) left
    on a settled contact's plate; ``amplitudes``, ``response`` (at least
    :func:`samples_in_contact` long) and ``work`` (:func:`transform_workspace`): optional
    arrays to write into."""
    c = coefficients
    fs = c.samplerate
    tau = result.separation_time
    lay = pulse_layout(tau, onset, c.omega_max, fs, pulse_points)
    n, M = lay.points, lay.samples
    forces, slopes = result.pulse_samples(lay.step, n, lay.offset, 1.0 / fs, M)
    if response is None:
        resp = np.empty(M)
    elif response.size < M:
        raise ParameterError(
            f"response has {response.size} samples; the contact of {tau!r} s at "
            f"samplerate={fs!r} Hz needs {M}"
        )
    else:
        resp = response[:M]
    amps = np.zeros(c.poles.size, dtype=complex) if amplitudes is None else amplitudes
    announce("modal-bank")
    # transform_pulse's choice, made here: a render compiles only the transform it uses
    transform = long_impact_transform if long_contact(c.sigma_max, tau) else impact_transform
    magnitude = transform(
        c.pole_re, c.pole_im, c.coef_re, c.coef_im, c.step_re, c.step_im, 1.0 / fs, lay.step,
        forces[:n], slopes[:n], lay.offset, forces[n:], slopes[n:], float(weight), tau,
        result.pulse_order, amps, resp,
        transform_workspace(c.poles.size) if work is None else work,
    )  # fmt: skip
    return ImpactExcitation(amps, lay.inject, lay.first, resp, forces[n:], magnitude)


def samples_in_contact(contact_time: float, samplerate: float) -> int:
    """Most audio samples (at ``samplerate`` Hz) that a contact of ``contact_time`` s
    can span, wherever it starts (see :func:`impact_excitation`)."""
    return int(math.ceil(contact_time * samplerate)) + 1
