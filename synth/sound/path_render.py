"""Render a ball released with a horizontal velocity: its bounces and its rolling mixed in one
signal through one modal bank and one listener (docs/rolling.md, "Rendering a path").

The plate is linear, so the signal is the sum of its responses (superposition) to the
bounces' pulses (:func:`synth.sound.modal_bank.synthesize`, each impact exciting the modes at
its own point), to the rolling's force (:func:`synth.sound.rolling.drive_modes` from the
plate at rest, on the modes that may exceed their share of the floor under the bounces'
peak) and, after the rolling, to the force it leaves (a ball at rest's weight) held at its
last point until every mode is below the floor (or ``max_tail``).
"""

from __future__ import annotations

import math

import numpy as np

from synth.physics.path import BallPath, simulate_path
from synth.sound.modal_bank import bank_coefficients, ring_bank, synthesize
from synth.sound.result import PathInfo
from synth.sound.rolling import ModeState, audible_modes, drive_modes, path_excitation


def render_path_audio(scene, model, o) -> tuple[np.ndarray, BallPath, dict]:
    """The physical signal (Pa or m/s^2, float64) of ``scene`` (with a velocity) heard
    through ``model`` (a :class:`synth.sound.listener.ModalModel`) with the render options
    ``o``, its path, and the figures of its :class:`~synth.sound.result.RenderInfo` (its
    :class:`~synth.sound.result.PathInfo` the ``path``)."""
    fs = o.samplerate
    floor = 10.0 ** (o.floor_db / 20.0)
    pre, delay = o.preroll, model.delay
    first_touch = math.sqrt(2.0 * scene.drop_height / scene.gravity)
    origin_time = first_touch - pre  # the emission time of the audio's first sample
    path = simulate_path(scene, samplerate=fs, time_origin=origin_time, max_duration=o.max_duration)
    bounces, bank = _bounces(path, model, fs, floor, origin_time, o)
    rolling = path.rolling
    info = dict(
        n_modes_rendered=bank["n_modes_rendered"],
        mode_samples=bank["mode_samples"],
        bank_seconds=bank["bank_seconds"],
        reference_amplitude=bank["reference"],
        tail_cut=False,
        left_at_end=bank["left_at_end"] / bank["reference"] if bank["reference"] else 0.0,
    )
    if rolling is None:
        audio = bounces
    else:
        audio, tail, driven = _with_rolling(
            bounces, rolling, path, model, fs, floor, origin_time, o
        )
        info.update(tail, n_modes_rendered=max(info["n_modes_rendered"], driven))
    path_info = PathInfo(
        path_end=path.end,
        path_end_time=path.end_time,
        path_end_point=tuple(path.end_point),
        rolling_speed=path.rolling_speed,
        rolling_start=None if rolling is None else rolling.start,
        rolling_seconds=0.0 if rolling is None else rolling.duration,
        rolling_flights=0 if rolling is None else rolling.flights,
        contact_plate="impedance",
        rolling_mode_samples=info.pop("rolling_mode_samples", None),
    )
    figures = dict(delay=delay, audio_start=first_touch + delay - pre, path=path_info, **info)
    return audio, path, figures


def _bounces(path, model, fs, floor, origin_time, o) -> tuple[np.ndarray, dict]:
    """The bounces' part of the signal from the audio's first sample, and the bank's figures."""
    impacts = path.impacts
    excitation = model.excitations(path.impact_points)
    direct = None if model.listener.shape is None else model.listener.shape * excitation
    onsets = np.array([i.time for i in impacts]) - origin_time
    max_samples = int(math.ceil((impacts.duration - origin_time + o.max_tail) * fs))
    return synthesize(
        [i.result for i in impacts], onsets, model.poles, excitation, model.output, fs,
        floor=floor, direct=direct, max_samples=max_samples, pulse_points=o.pulse_points,
    )  # fmt: skip


def _with_rolling(bounces, rolling, path, model, fs, floor, origin_time, o):
    """The bounces' signal with the rolling's and its tail added, and the figures of the
    rolling's part (``left_at_end`` relative to the reference amplitude)."""
    j0 = int(round((rolling.start - origin_time) * fs))
    c = rolling.contact_coordinate
    table = path_excitation(
        model, origin=path.origin, direction=path.direction,
        start=float(np.min(c)), stop=float(np.max(c)),
    )  # fmt: skip
    # the modes within their share of the floor under the bounces' peak are left out
    bounce_peak = float(np.max(np.abs(bounces))) if bounces.size else 0.0
    keep = audible_modes(
        rolling.force, table, model.poles, model.output, fs, floor=floor, reference=bounce_peak
    )
    kept = ModeState.at_rest(int(keep.sum()))
    drive = drive_modes(
        rolling.force, c, table.modes(keep), model.poles[keep], model.output[keep], fs,
        state=kept,
    )  # fmt: skip
    state = ModeState.at_rest(model.poles.size)
    state.zeta[keep], state.previous = kept.zeta, kept.previous
    reference = max(bounce_peak, float(np.max(np.abs(drive))))
    tail, cut, left = _tail(state, rolling, path, model, fs, floor * reference, o.max_tail)
    # the sum in one new array, each part added where it lies
    end = j0 + drive.size
    audio = np.empty(max(bounces.size, end + tail.size))
    audio[: bounces.size] = bounces
    audio[bounces.size :] = 0.0
    audio[j0:end] += drive
    audio[end : end + tail.size] += tail
    work = int(keep.sum()) * drive.size
    figures = dict(tail_cut=cut, left_at_end=left / reference, rolling_mode_samples=work)
    return audio, figures, int(keep.sum())


def _tail(state, rolling, path, model, fs, floor, max_tail) -> tuple[np.ndarray, bool, float]:
    """The listener's signal after the rolling, whether ``max_tail`` (s) cut it and the bound
    of what rings on after its end (the signal's units). The force the rolling leaves is
    held at its last point, so each mode rings towards its static deflection, ``zeta_k(t) =
    zs_k + (zeta_k - zs_k) e^(p_k t)``, ``zs_k = -b_k F / p_k``: the modal bank's ringing
    (each mode until within its share of ``floor``) plus the deflection's constant part."""
    p = model.poles
    end = float(rolling.contact_coordinate[-1])
    point = (path.origin[0] + path.direction[0] * end, path.origin[1] + path.direction[1] * end)
    b = model.excitation(point)
    F = rolling.final_force
    static = -b * F / p
    coefficients = bank_coefficients(p, np.ones(p.size), model.output, fs)
    gain = coefficients.coef_re + 1j * coefficients.coef_im
    constant = float(np.sum((gain * static).real))
    direct = model.direct(b)
    if direct is not None:
        constant += F * float(np.sum(direct.real))
    out = np.zeros(int(math.ceil(max_tail * fs)))
    amplitudes = (gain * (state.zeta - static))[None, :]
    thresholds = np.full(p.size, floor / max(p.size, 1))
    _, last, left = ring_bank(out, float(fs), p, amplitudes, np.zeros(1, np.int64), thresholds)
    last = max(int(last), 1)
    return out[:last] + constant, bool(last >= out.size and left > floor), float(left)
