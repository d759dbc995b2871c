"""Where the finite plate's modes enter the contact: ``contact.plate = "auto"`` (docs/physics.md,
"Plate impedance" and "Plate modes").

Until a wave reflected by an edge returns, the finite plate moves as the infinite one and the
modal contact costs time for nothing. A flexural wave of ``omega`` travels at ``c_g = 2
sqrt(omega) kappa``, ``kappa = (D / (rho h))^(1/4)`` (Cremer, Heckl & Petersson, section
3.7), and is back from an edge at ``d`` within the contact time ``tau`` above
``omega_d = (d / (kappa tau))^2``. The share ``s(d)`` of the first impact's force spectrum
``|F(omega)|^2`` above it bounds the change of the plate's energy, blended as in
:func:`synth.physics.impedance.admittance_at`:

    Delta(e^2) <= eps [(r_e - 1)(s_x + s_y) + (r_c - 2 r_e + 1) s_x s_y]

(``eps`` the share of kinetic energy the plate took, ``r_e = 1 / EDGE_RATIO``, ``r_c = 1 /
CORNER_RATIO``), and ``Delta e <= Delta(e^2) / (2 e)``; above :data:`TOLERANCE` the modes
enter the contact. Left out: the ringing of earlier bounces, the modal plate's alone.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth.errors import ParameterError
from synth.physics import impedance

#: The change of the first impact's e (and relative change of its tau) below which the modal
#: contact is not used: the modal contact's own accuracy at its default band and steps against
#: the impedance model at the middle of a large plate (tests/test_fidelity_losses.py,
#: tests/test_modal_contact.py: within 1e-3).
TOLERANCE = 1e-3
#: Samples of the force pulse for its energy spectrum, and the length (a power of two) of the
#: zero-padded transform: bins of ``1 / (8 tau)`` and pulses resolved to 1/2048 of ``tau``.
PULSE_SAMPLES = 4096
TRANSFORM_LENGTH = 1 << 15


@dataclass(frozen=True)
class PlateChoice:
    """The plate in the contact for one scene: ``plate`` ("impedance" or "modal"), the bound
    on the change of e by the edges' reflections within the first contact (``bound``,
    dimensionless), the distances to the nearest edge along x and y (``distances``, m) and
    the lowest frequency whose reflection from each is back within the contact
    (``frequencies``, Hz)."""

    plate: str
    bound: float
    distances: tuple[float, float]
    frequencies: tuple[float, float]


def energy_share_above(result, omega: float) -> float:
    """The share of the force pulse's energy ``Int |F(omega)|^2`` above the angular frequency
    ``omega`` (rad/s) for an :class:`~synth.physics.contact.ImpactResult` (dimensionless,
    in [0, 1]): the pulse sampled on :data:`PULSE_SAMPLES` points over its contact, its
    spectrum by a zero-padded FFT."""
    return energy_shares_above(result, (omega,))[0]


def energy_shares_above(result, omegas) -> list[float]:
    """:func:`energy_share_above` at each of ``omegas`` (rad/s), from one spectrum of the
    pulse."""
    tau = result.separation_time
    t = np.linspace(0.0, tau, PULSE_SAMPLES)
    f = np.asarray(result.force_at(t), dtype=float)
    dt = t[1] - t[0]
    spectrum = np.abs(np.fft.rfft(f, TRANSFORM_LENGTH)) ** 2
    frequencies = 2.0 * math.pi * np.fft.rfftfreq(TRANSFORM_LENGTH, dt)
    total = float(spectrum.sum())
    if not total > 0.0:
        return [0.0 for _ in omegas]
    return [float(spectrum[frequencies >= omega].sum()) / total for omega in omegas]


def return_frequency(plate, distance: float, contact_time: float) -> float:
    """The lowest angular frequency (rad/s) whose flexural wave, reflected by an edge at
    ``distance`` (m), is back at the impact point within ``contact_time`` (s):
    ``(d / (kappa tau))^2``, ``kappa = (D / (rho h))^(1/4)``."""
    kappa = (plate.flexural_rigidity / plate.surface_density) ** 0.25
    return (distance / (kappa * contact_time)) ** 2


def choose_plate(result, plate, position, ball_mass: float, speed: float) -> PlateChoice:
    """The :class:`PlateChoice` for the first impact ``result`` (the impedance plate's, at
    ``speed`` m/s, of a ball of ``ball_mass`` kg) at ``position`` (m from a corner) on
    ``plate`` (module docstring; for a ball that settles, the bound is on the plate's share
    of the energy itself)."""
    x, y = plate.check_position(position, "position")
    dx = min(x, plate.length - x)
    dy = min(y, plate.width - y)
    tau = result.separation_time
    omegas = (return_frequency(plate, dx, tau), return_frequency(plate, dy, tau))
    shares = energy_shares_above(result, omegas)
    r_e = 1.0 / impedance.EDGE_RATIO
    r_c = 1.0 / impedance.CORNER_RATIO
    contrast = (r_e - 1.0) * (shares[0] + shares[1]) + (r_c - 2.0 * r_e + 1.0) * shares[0] * shares[
        1
    ]
    taken = result.plate_energy / (0.5 * ball_mass * speed * speed)
    e = result.restitution
    # a ball that settles has no e to change: the bound is then on the plate's share itself
    bound = taken * contrast / (2.0 * e) if e > 0.0 and not result.settled else taken * contrast
    return PlateChoice(
        "modal" if bound > TOLERANCE else "impedance",
        bound,
        (dx, dy),
        (omegas[0] / (2.0 * math.pi), omegas[1] / (2.0 * math.pi)),
    )


def scene_plate(scene) -> PlateChoice:
    """The plate in the contact of a :class:`~synth.physics.scene.Scene`: its
    ``contact.plate`` where that names one ("impedance" or "modal", bound 0 or inf), else
    (``"auto"``) :func:`choose_plate` on its first impact solved on the impedance plate; the
    impedance plate for the thin-shell law of a hollow ball, which the modal contact does not
    integrate."""
    from synth.physics.scene import Scene

    if not isinstance(scene, Scene):
        raise ParameterError(f"scene={scene!r} must be a Scene")
    c = scene.contact
    if c.law == "shell":
        # the modal contact integrates the power laws only: a hollow ball's contact is on the
        # impedance plate (with its admittance near the edges, synth.physics.impedance)
        return PlateChoice("impedance", 0.0, (0.0, 0.0), (0.0, 0.0))
    if c.plate != "auto":
        return PlateChoice(
            c.plate, 0.0 if c.plate == "impedance" else math.inf, (0.0, 0.0), (0.0, 0.0)
        )
    try:
        hash(scene)
    except TypeError:  # a field given as a list: not kept
        return _automatic_choice.__wrapped__(scene)
    return _automatic_choice(scene)


@functools.lru_cache(maxsize=64)
def _automatic_choice(scene) -> PlateChoice:
    """:func:`choose_plate` on the first impact of ``scene`` (a Scene, hashable: its fields
    are frozen values) solved on the impedance plate; kept for the scene, which a render
    asks for once per render and a bank or the benchmarks for many renders of one scene."""
    from synth.physics.contact import solve_impact

    c = scene.contact
    speed = math.sqrt(2.0 * scene.gravity * scene.drop_height)
    first = solve_impact(
        scene.ball, scene.plate, speed, position=scene.position, gravity=scene.gravity,
        contact=c.law, rtol=c.rtol, **c.options(),
    )  # fmt: skip
    return choose_plate(first, scene.plate, scene.position, scene.ball.mass, speed)
