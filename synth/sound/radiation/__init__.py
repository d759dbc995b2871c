"""Sound radiated by plate modes to a microphone by the Rayleigh integral, plate in a rigid baffle
(docs/physics.md, "Radiation"); gains ``H_k(s)`` in Pa per m/s."""

from __future__ import annotations

import math

import numpy as np

from synth import checks
from synth.constants import SOUND_SPEED
from synth.errors import ParameterError
from synth.physics.modes import Modes
from synth.sound.radiation.cache import (
    CACHE,
    cache_info,
    clear_memory_cache,
    frozen,
    gains_key,
    load_gains,
    save_gains,
)
from synth.sound.radiation.common import (
    MAX_ORDER,
    RadiationResult,
    check_listener,
    check_poles,
    check_settings,
    gains_of,
    half_phase,
)
from synth.sound.radiation.polar import separable_gains, summed_gains
from synth.sound.radiation.rectangle import rayleigh_gains
from synth.sound.radiation.rules import RULES, choose_rule, edge_split, plate_problem

__all__ = [
    "RadiationResult", "rayleigh_gains", "separable_gains", "summed_gains", "plate_gains", "delay",
    "distance", "cache_info", "clear_memory_cache",
]  # fmt: skip

DEFAULT_MAX_POINTS = 4_000_000  # most points of one rule of plate_gains by default


def rectangle_points(size, kappa: float, tol: float = 1e-6) -> float:
    """Points of the rectangle rule's first rule on a plate of ``size`` (a, b), m, for the
    wavenumber ``kappa`` (rad/m) and ``tol``, from its longest panels (24 points each)."""
    per_metre = MAX_ORDER * kappa / (2.0 * half_phase(MAX_ORDER, 0.1 * tol))
    return (size[0] * per_metre + 1.0) * (size[1] * per_metre + 1.0)


def _problem(modes, listener, q_s, checked):
    """The :class:`~synth.sound.radiation.rules.Problem` of ``modes`` heard at ``listener``
    for the poles ``q_s`` (rad/s) with the checked settings ``checked``."""
    kb, c = checked.kb, checked.c
    frequencies = np.asarray(modes.angular_frequencies) / (2.0 * math.pi)
    f_max = float(frequencies[-1]) if frequencies.size else 0.0
    edge, split = modes.edge_effect(), None
    if edge is not None:
        n_low = edge.first_mode
        f_low = float(frequencies[n_low - 1]) if n_low else 0.999 * float(frequencies[0])
        count = lambda f: np.searchsorted(frequencies, f, side="right")  # noqa: E731
        split = edge_split(kb, f_low, f_max, n_low, count, c)
        shapes = "edge"
    elif modes.separable() is not None:
        shapes = "separable"
    else:
        shapes = "summed" if modes.summed() is not None else "any"
    qa = float(np.max(np.abs(q_s))) / c if q_s.size else 0.0
    return plate_problem(modes.plate, f_max, listener=listener, modes=len(modes), kb=kb, qa=qa,
                         tol=checked.tol, max_points=checked.max_points, edge=split,
                         shapes=shapes)  # fmt: skip


def plate_gains(modes, listener_position, s, *, full_output=False, cache=True, **settings):
    """:func:`rayleigh_gains` (its keywords ``settings`` and result, read-only; ``s`` one
    complex frequency per mode, rad/s) of a :class:`~synth.physics.modes.Modes` by the chosen
    rule (``max_points`` default :data:`DEFAULT_MAX_POINTS`), kept in memory and on disk
    (``cache`` False: computed afresh, nothing stored). The key holds everything that
    determines the result; files ``radiation-gains-*.npz`` beside the mode cache are written
    atomically, and an unreadable one is rewritten."""
    if not isinstance(modes, Modes):
        raise ParameterError(f"modes={modes!r} must be a synth.physics.modes.Modes")
    if not isinstance(cache, bool):
        raise ParameterError(f"cache={cache!r} must be True or False")
    listener = check_listener(listener_position)
    q_s = check_poles(s, len(modes))
    settings.setdefault("max_points", DEFAULT_MAX_POINTS)
    checked = check_settings(**settings)
    rule = RULES[0]  # the rectangle rule: no modes, nothing to sum
    if q_s.size:
        problem = _problem(modes, listener, q_s, checked)
        rule = choose_rule(problem).rule

    result = CACHE.fetch(
        gains_key(modes, listener, q_s, checked, type(rule).__name__) if cache else None,
        lambda: frozen(rule.gains(modes, listener, q_s, checked.keywords())),
        load=lambda key: load_gains(key, q_s.size), save=save_gains,
    )  # fmt: skip
    return gains_of(result, "plate_gains", checked.tol, full_output)


def distance(listener_position, reference_point) -> float:
    """Distance (m) from the microphone ``listener_position`` ((x, y, z), m, ``z > 0``) to
    ``reference_point`` ((x, y), m) of the plate's plane."""
    xl, yl, zl = check_listener(listener_position)
    xr, yr = checks.point("reference_point", reference_point, 2)
    return math.sqrt((xl - xr) ** 2 + (yl - yr) ** 2 + zl * zl)


def delay(listener_position, reference_point, sound_speed=SOUND_SPEED) -> float:
    """Propagation delay (s) from ``reference_point`` to the microphone at ``sound_speed``
    (m/s): the delay taken out of gains computed with that ``reference_distance``."""
    c = checks.positive("sound_speed", sound_speed, "m/s")
    return distance(listener_position, reference_point) / c
