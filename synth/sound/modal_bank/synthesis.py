"""The modal bank over a bounce sequence: :func:`synthesize` (see
:mod:`synth.sound.modal_bank`)."""

from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np

from synth.compilation import announce
from synth.errors import ParameterError
from synth.sound.modal_bank.bank_kernels import TILE, ring_bank
from synth.sound.modal_bank.pulse import (
    PULSE_POINTS,
    bank_coefficients,
    impact_excitation,
    transform_workspace,
)


class Bank(NamedTuple):
    """The modes a bank rings: ``poles`` (K,) ``p_k = -sigma_k + i omega_dk`` (rad/s, below
    Nyquist), ``excitation`` ``b_k = phi_k(x0) / M_k`` (1/kg; (K,) or one row per impact),
    listener gains ``output`` (K,) (``phi_k(xp) p_k^2`` for acceleration, ``G_k p_k`` for a
    microphone), at ``samplerate`` Hz."""

    poles: np.ndarray
    excitation: np.ndarray
    output: np.ndarray
    samplerate: float


def synthesize(
    impacts,
    onsets,
    bank: Bank,
    *,
    floor,
    settled_weight=None,
    direct=None,
    max_samples=None,
    pulse_points=PULSE_POINTS,
):
    """Mix the ringing of every mode of ``bank`` (:class:`Bank`) after every impact: the
    contacts ``impacts`` (time order) starting at ``onsets`` (I,) (s on the audio timeline,
    sub-sample); ``floor`` the omission floor (a fraction of the reference
    amplitude); ``settled_weight`` the weight ``m g`` (N) a settled impact leaves on the
    plate; ``direct`` an accelerometer's ``phi_k(xp) b_k`` of the direct term inside
    contacts; ``max_samples`` the output's length cap; ``pulse_points`` (>= 5) the fewest
    points of each pulse's grid. Returns the audio (float64) and a dict of figures (times
    in s)."""
    poles, excitation, output, fs = bank
    fs = float(fs)
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
        ex = impact_excitation(coefficients, res, float(t0), weight=weight, work=work,
                               pulse_points=pulse_points, amplitudes=amps[i])  # fmt: skip
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
    work, last, left = 0, 0, 0.0
    if keep.any():
        kept = np.ascontiguousarray(amps[:, keep])
        thresholds = np.full(kept.shape[1], thr)
        work, last, left = ring_bank(out, fs, poles[keep], kept, inject, thresholds)
    t_bank = time.perf_counter() - t_bank
    last = _add_contacts(out, contact_samples, direct, last)
    length = max(1, min(length, last))
    out = out[:length]
    # what is left out at the end of the audio: the kept modes' remainder there, and the
    # modes left out whole (each at most its share)
    left += float(np.sum(total[~keep]))
    info = dict(n_modes=K, n_modes_rendered=int(keep.sum()), mode_samples=int(work),
                reference=reference, threshold=thr, length=length, bank_seconds=t_bank,
                transform_seconds=t_transform, left_at_end=left)  # fmt: skip
    return out, info


def _add_contacts(out, contact_samples, direct, last: int) -> int:
    """Add each impact's response inside its contact (and an accelerometer's ``direct``
    term) to ``out``; the end of what is written, ``last`` or later."""
    line = 0.0 if direct is None else np.sum(np.asarray(direct).real, axis=-1)
    mass_lines = np.broadcast_to(line, (len(contact_samples),))
    for (idx, resp, off_f), mass_line in zip(contact_samples, mass_lines):
        ok = idx < out.size
        if not ok.any():
            continue
        out[idx[ok]] += resp[ok]
        if direct is not None:
            out[idx[ok]] += off_f[ok] * mass_line
        last = max(last, int(idx[ok][-1]) + 1)
    return last


def kept_modes(bounds, reference, floor) -> tuple[np.ndarray, float]:
    """The mask (K,) of the modes worth rendering under the omission budget ``floor *
    reference``, and each mode's share ``floor * reference / K``: a mode whose contribution
    to any sample is bounded by ``bounds[k]`` (the signal's units) within its share is left
    out, so those left out add up to at most ``floor * reference`` at every sample."""
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
