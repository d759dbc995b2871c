"""The modal bank over a bounce sequence: :func:`synthesize` (see
:mod:`synth.sound.modal_bank`)."""

from __future__ import annotations

import math
import time

import numpy as np

from synth.compilation import announce
from synth.errors import ParameterError
from synth.sound.modal_bank.bank_kernels import TILE, ring_bank
from synth.sound.modal_bank.coefficients import bank_coefficients
from synth.sound.modal_bank.pulse import PULSE_POINTS, impact_excitation, transform_workspace


def synthesize(
    impacts,
    onsets,
    poles,
    excitation,
    output,
    samplerate,
    *,
    floor,
    settled_weight=None,
    direct=None,
    max_samples=None,
    pulse_points=PULSE_POINTS,
):
    """Mix the ringing of every mode after every impact.

    Parameters
    ----------
    impacts : sequence of ImpactResult
        The contacts, in time order.
    onsets : ndarray (I,)
        Each contact's start on the audio timeline, s (sub-sample).
    poles : complex ndarray (K,)
        ``p_k = -sigma_k + i omega_dk``, rad/s (all below Nyquist).
    excitation : ndarray (K,) or (I, K)
        ``b_k = phi_k(x0) / M_k``, 1/kg: one row for all impacts, or one per impact.
    output : complex ndarray (K,)
        Listener gain per unit modal displacement at the pole: ``phi_k(xp) p_k^2``
        (acceleration) or ``G_k p_k`` (microphone).
    samplerate : float
        Hz.
    floor : float
        Omission floor, a fraction of the reference amplitude (:mod:`synth.sound.modal_bank`).
    settled_weight : sequence of float or None
        For a settled impact the weight ``m g`` (N) left on the plate after its contact.
    direct : ndarray (K,) or (I, K) or None
        For acceleration, ``phi_k(xp) b_k`` of the direct term ``b_k F(t)`` inside contacts.
    max_samples : int
        Length cap of the output.
    pulse_points : int >= 5
        Fewest points of each pulse's grid for the transforms (an odd number is used).

    Returns
    -------
    (audio float64 (S,), info dict: n_modes_rendered, mode_samples, reference, length,
    bank_seconds and transform_seconds, s)"""
    fs = float(samplerate)
    onsets = np.asarray(onsets, dtype=float)
    if onsets.size and not np.min(onsets) >= 0.0:
        raise ParameterError(
            f"onsets: {float(np.min(onsets))!r} s; every onset must be >= 0 s "
            f"(from the first sample of the audio)"
        )
    excitation = np.asarray(excitation)
    per_impact = excitation.ndim == 2
    if per_impact and excitation.shape[0] != len(impacts):
        raise ParameterError(
            f"excitation has {excitation.shape[0]} rows for {len(impacts)} impacts: give one "
            f"row (K,) or one per impact (I, K)"
        )
    coefficients = bank_coefficients(poles, excitation[0] if per_impact else excitation, output, fs)
    poles = coefficients.poles
    K = poles.size
    I = len(impacts)
    amps = np.zeros((I, K), dtype=complex)
    inject = np.zeros(I, dtype=np.int64)
    contact_samples = []  # per impact: in-contact sample indices, responses there, forces there
    work = transform_workspace(K)
    t_transform = time.perf_counter()
    for i, (res, t0) in enumerate(zip(impacts, onsets)):
        weight = float(settled_weight[i]) if settled_weight is not None else 0.0
        if per_impact and i:
            coefficients = bank_coefficients(poles, excitation[i], output, fs)
        ex = impact_excitation(
            coefficients,
            res,
            float(t0),
            weight=weight,
            pulse_points=pulse_points,
            amplitudes=amps[i],
            work=work,
        )
        inject[i] = ex.inject
        contact_samples.append(
            (ex.first + np.arange(ex.response.size, dtype=np.int64), ex.response, ex.forces)
        )
    t_transform = time.perf_counter() - t_transform
    reference = float(np.max(np.sum(np.abs(amps), axis=1))) if I else 0.0
    # a mode whose amplitudes add up to at most its share is left out whole
    total = np.sum(np.abs(amps), axis=0) if I else np.zeros(K)
    keep, thr = kept_modes(total, reference, floor)
    length = _buffer_length(poles, keep, total, thr, inject, fs, max_samples)
    out = np.zeros(length)
    announce("modal-bank")
    t_bank = time.perf_counter()
    work, last, left = (
        ring_bank(
            out,
            fs,
            poles[keep],
            np.ascontiguousarray(amps[:, keep]),
            inject,
            np.full(int(keep.sum()), thr),
        )
        if keep.any()
        else (0, 0, 0.0)
    )
    t_bank = time.perf_counter() - t_bank
    if direct is None:
        mass_lines = np.zeros(I)
    else:
        mass_lines = np.broadcast_to(np.sum(np.asarray(direct).real, axis=-1), (I,))
    for (idx, resp, off_f), mass_line in zip(contact_samples, mass_lines):
        ok = idx < length
        if not ok.any():
            continue
        out[idx[ok]] += resp[ok]
        if direct is not None:
            out[idx[ok]] += off_f[ok] * mass_line
        last = max(last, int(idx[ok][-1]) + 1)
    length = max(1, min(length, last))
    out = out[:length]
    # what is left out at the end of the audio: the kept modes' remainder there, and the
    # modes left out whole (each at most its share)
    left += float(np.sum(total[~keep]))
    info = dict(
        n_modes=K,
        n_modes_rendered=int(keep.sum()),
        mode_samples=int(work),
        reference=reference,
        threshold=thr,
        length=length,
        bank_seconds=t_bank,
        transform_seconds=t_transform,
        left_at_end=left,
    )
    return out, info


def kept_modes(bounds, reference, floor) -> tuple[np.ndarray, float]:
    """The modes worth rendering under the omission budget ``floor * reference`` (module
    docstring of :mod:`synth.sound.modal_bank`, "Leaving out"): each of the ``K`` modes
    gets the share ``floor * reference / K``, and a mode whose contribution to any sample
    is bounded by ``bounds[k]`` (the signal's units) within its share is left out, so the
    modes left out add up to at most ``floor * reference`` at every sample. Returns the
    mask of the modes kept (K,) and the share."""
    bounds = np.asarray(bounds, dtype=float)
    share = floor * reference / max(bounds.size, 1)
    return bounds > share, share


def _buffer_length(poles, keep, total, thr, inject, fs, max_samples) -> int:
    """Samples of the output buffer: until every kept mode's state is below half its share
    ``thr`` (the sum of its amplitudes ``total`` bounds its state after the last impact,
    injected at sample ``inject[-1]``), so that with what it has left out before it can
    stop; at most ``max_samples``. The caller trims it to what was written."""
    if inject.size and keep.any():
        sig = -poles.real[keep]
        t_tail = np.log(np.maximum(2.0 * total[keep] / max(thr, 1e-300), 1.0)) / np.maximum(
            sig, 1e-12
        )
        length = int(inject[-1] + math.ceil(float(np.max(t_tail)) * fs) + TILE)
    else:
        length = int(inject[-1] + 1) if inject.size else 1
    if max_samples is not None:
        length = min(length, int(max_samples))
    return length
