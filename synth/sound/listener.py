"""How a listener hears a plate's modes (:class:`ModalModel`, built once per plate and
listener): an accelerometer the acceleration at a point (m/s^2), a microphone the Rayleigh
radiation of the baffled plate (Pa)."""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from dataclasses import dataclass

import numpy as np

from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.physics import modes as plate_modes
from synth.physics.scene import Accelerometer, Microphone


def _microphone_gains(modes, plate, microphone, poles, k_max, max_points=None):
    """Pressure per unit modal velocity (Pa s/m) of every mode at the microphone, for the
    ringing ``exp(p_k t)`` from the first arrival ``R0 / c`` on: the least-squares fit of the
    causal pressure, the Rayleigh gain at the mirror pole ``G_k = H_k(s'_k) p_k / s'_k``,
    ``s'_k = -conj(p_k)`` (docs/physics.md, "Radiation"), which weights every element by
    ``exp(-sigma_k (R - R0) / c) <= 1`` instead of the exact pole gain's anti-causal growth."""
    from synth.sound.radiation import plate_gains

    mirror = -np.conj(poles)
    gains = functools.partial(
        plate_gains,
        modes,
        microphone.position,
        mirror,
        max_wavenumber=k_max,
        air_density=AIR_DENSITY,
        sound_speed=SOUND_SPEED,
        reference_distance=nearest_distance(plate, microphone),
    )
    if max_points is None:
        h = gains()
    else:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            h = gains(max_points=max_points)
        for w in caught:
            message = _budget_named(w.message, max_points)
            warnings.warn_explicit(message, w.category, w.filename, w.lineno)
    return np.asarray(h) * poles / mirror


def _budget_named(message, max_points):
    """A warning of the sums stopped at ``max_points`` (the budget's cut) reworded to name
    ``SYNTH_MAX_RADIATION_WORK``; any other as it is."""
    internal = f"the next rule would exceed max_points={max_points}"
    if internal not in str(message):
        return message
    budget = (
        "the next rule would exceed the radiation budget SYNTH_MAX_RADIATION_WORK (raise it "
        "for converged gains; synth info --cost prints the work)"
    )
    return type(message)(str(message).replace(internal, budget))


def nearest_distance(plate, microphone) -> float:
    """Distance (m) from the microphone to the nearest point of the plate."""
    from synth.sound.radiation.common import distance_range

    return distance_range((plate.length, plate.width), microphone.position)[0]


@dataclass(frozen=True, eq=False)
class ListenerOutput:
    """How a listener hears the plate's modes: ``output`` (K,) complex, the gain per unit
    modal displacement at the pole (``phi_k(xp) p_k^2``, m/s^2 per m, for an accelerometer;
    ``G_k p_k``, Pa per m, for a microphone); ``shape``, ``phi_k(xp)`` for the
    accelerometer's direct term (else None); ``delay``, the travel time from the plate's
    nearest point, s; ``units`` "m/s^2" or "Pa"."""

    output: np.ndarray
    shape: np.ndarray | None
    delay: float
    units: str


def _listener_output(modes, listener, poles, ok, max_points=None) -> ListenerOutput:
    """The :class:`ListenerOutput` of ``listener`` hearing the modes ``ok`` of ``modes``
    (``poles``, rad/s; ``max_points``: the most points of one radiation rule)."""
    if isinstance(listener, Accelerometer):
        phip = modes.shapes(np.array([listener.position]))[0][ok]
        return ListenerOutput(phip * poles**2, phip, 0.0, LISTENER_UNITS[Accelerometer])
    s, k_max = _sum_poles(modes, ok)
    all_gains = _microphone_gains(modes, modes.plate, listener, s, k_max, max_points)
    return _pressure_output(all_gains, poles, ok, modes.plate, listener)


def _sum_poles(modes, ok) -> tuple[np.ndarray, float]:
    """The poles ``s_k`` (rad/s) the radiation sums take for every mode, a mode left out
    (``ok`` False) ``-omega_k`` (its gain unused; its own ``-sigma_k`` can be of any size, and
    the sums' panels follow the largest ``|s|``); and the largest bending wavenumber (rad/m)
    of the modes ``ok``, ``(omega^2 rho h / D)^(1/4)`` (1 for none)."""
    sigma, omega, wd = _mode_rates(modes)
    plate, w = modes.plate, omega[ok]
    k4 = float(np.max(w)) ** 2 * plate.surface_density / plate.flexural_rigidity if w.size else 1.0
    return np.where(ok, -sigma + 1j * wd, -omega + 0j), k4**0.25


def _pressure_output(all_gains, poles, ok, plate, microphone) -> ListenerOutput:
    """A microphone's :class:`ListenerOutput` from the gains ``G_k`` of every mode."""
    return ListenerOutput(
        np.asarray(all_gains)[ok] * poles,
        None,
        nearest_distance(plate, microphone) / SOUND_SPEED,
        LISTENER_UNITS[Microphone],
    )


#: The units each kind of listener hears in.
LISTENER_UNITS = {Accelerometer: "m/s^2", Microphone: "Pa"}


@dataclass(frozen=True, eq=False)
class ModalModel:
    """A plate's modes as one listener hears them, built once per plate and listener:
    ``modes`` (:class:`synth.physics.modes.Modes`) below ``max_frequency``; ``poles`` (K,),
    ``p_k = -sigma_k + i omega_dk`` (rad/s) of the ringing modes below Nyquist, which of
    ``modes`` they are (``rendered``); the ``listener``'s :class:`ListenerOutput`;
    ``n_overdamped`` modes left out (``sigma >= omega``); ``samplerate``, Hz."""

    modes: object
    poles: np.ndarray
    rendered: np.ndarray
    listener: ListenerOutput
    n_overdamped: int
    samplerate: int

    @property
    def output(self) -> np.ndarray:
        return self.listener.output

    @property
    def delay(self) -> float:
        return self.listener.delay

    @property
    def units(self) -> str:
        return self.listener.units

    def excitation(self, position) -> np.ndarray:
        """``b_k = phi_k(x0) / M_k`` (1/kg) of a force at ``position`` ((x, y), m)."""
        phi = _shapes_at(self.modes, position)[self.rendered]
        return phi / np.asarray(self.modes.modal_masses, dtype=float)[self.rendered]

    def excitations(self, points) -> np.ndarray:
        """``b_k`` (1/kg) of a force at each of ``points`` ((P, 2), m): (P, K)."""
        phi = self.modes.shapes(np.asarray(points, dtype=float))[:, self.rendered]
        return phi / np.asarray(self.modes.modal_masses, dtype=float)[self.rendered]

    def heard_by(self, listener, grid=None) -> ModalModel:
        """The same modes heard by another ``listener`` of the same plate, as :func:`modal_model`
        computes them; with ``grid`` (:func:`listener_grid`) a microphone it serves takes its
        gains from the grid's sums (:mod:`synth.sound.radiation.fixed`)."""
        plate, ok = self.modes.plate, self.rendered
        microphone = isinstance(listener, Microphone)
        if microphone and grid is not None and grid.serves(listener.position):
            s = _sum_poles(self.modes, ok)[0]
            h = grid.gains(listener.position, nearest_distance(plate, listener))
            output = _pressure_output(h * s / -np.conj(s), self.poles, ok, plate, listener)
        else:
            output = _listener_output(self.modes, listener, self.poles, ok)
        return dataclasses.replace(self, listener=output)

    def direct(self, excitation) -> np.ndarray | None:
        """``phi_k(xp) b_k`` of an accelerometer's direct term ``b_k F(t)`` (None for a
        microphone)."""
        return None if self.listener.shape is None else self.listener.shape * excitation


#: The modes' shapes at single points, by ``(Modes.shape_key, x, y)`` (a drop's excitation).
_POINT_SHAPES: dict = {}
POINT_SHAPES_KEPT = 64


def _shapes_at(modes, position) -> np.ndarray:
    """``phi_k`` (dimensionless, read only) of every mode at ``position`` ((x, y), m), kept
    by the shapes' key (equal keys, equal shapes), the oldest point forgotten first."""
    try:
        x, y = (float(v) for v in position)
    except (TypeError, ValueError):  # not a point: Modes.shapes names what is wrong
        return modes.shapes(np.array([position]))[0]
    key = (modes.shape_key, x, y)
    phi = _POINT_SHAPES.get(key)
    if phi is None:
        phi = modes.shapes(np.array([[x, y]]))[0]
        phi.setflags(write=False)
        if len(_POINT_SHAPES) >= POINT_SHAPES_KEPT:
            _POINT_SHAPES.pop(next(iter(_POINT_SHAPES)), None)
        _POINT_SHAPES[key] = phi
    return phi


def modal_model(
    plate,
    listener,
    *,
    samplerate: int,
    max_frequency: float | None = None,
    radiation_max_points: int | None = None,
) -> ModalModel:
    """The :class:`ModalModel` of ``plate`` heard by ``listener`` at ``samplerate`` Hz, modes
    up to ``max_frequency`` Hz (default Nyquist); ``radiation_max_points``: the budget's cut
    of a microphone's sums (None: their default)."""
    fs = samplerate
    f_max = 0.5 * fs if max_frequency is None else max_frequency
    modes = plate_modes.modes(plate, max_frequency=f_max * (1.0 - 1e-9))
    sigma, omega, wd = _mode_rates(modes)
    under = sigma < omega
    ok = under & (wd < math.pi * fs)
    poles = (-sigma + 1j * wd)[ok]
    gains = _listener_output(modes, listener, poles, ok, radiation_max_points)
    return ModalModel(modes, poles, ok, gains, int(np.sum(~under)), int(fs))


def _mode_rates(modes):
    """``(sigma, omega, omega_d)`` of every mode, rad/s: decay rate, undamped and damped
    angular frequency (0 for an overdamped mode)."""
    sigma = np.asarray(modes.decay_rates, dtype=float)
    omega = np.asarray(modes.angular_frequencies, dtype=float)
    under = sigma < omega
    wd = np.zeros_like(omega)  # an overdamped mode's sigma can be of any size: not squared
    wd[under] = np.sqrt(omega[under] ** 2 - sigma[under] ** 2)
    return sigma, omega, wd


def listener_grid(model: ModalModel, max_bytes: int | None = None):
    """The :class:`~synth.sound.radiation.fixed.ListenerGrid` of ``model``'s plate: microphone
    gains at any point at least ``NEAR_FIELD_HEIGHT`` above the plate at the cost of the sums
    alone (:class:`~synth.sound.radiation.fixed.GridTooLarge` beyond ``max_bytes``)."""
    from synth.sound.radiation.fixed import ListenerGrid

    s, k_max = _sum_poles(model.modes, model.rendered)
    return ListenerGrid(
        model.modes,
        -np.conj(s),
        max_wavenumber=k_max,
        air_density=AIR_DENSITY,
        sound_speed=SOUND_SPEED,
        max_bytes=max_bytes,
    )
