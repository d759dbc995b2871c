"""Where the finite plate's modes enter the contact, ``contact.plate = "auto"`` (docs/physics.md,
"Plate impedance"): when the pulse's energy whose reflections return within the contact time
exceeds :data:`TOLERANCE`."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth.physics import impedance

#: Change of the first impact's e (and relative tau) below which the modal contact is not used:
#: its own accuracy against the impedance model (within 1e-3).
TOLERANCE = 1e-3
#: Pulse samples and zero-padded transform length: bins of ``1 / (8 tau)``.
PULSE_SAMPLES = 4096
TRANSFORM_LENGTH = 1 << 15


@dataclass(frozen=True)
class PlateChoice:
    """The plate in one scene's contact: ``plate``, the ``bound`` on the change of e, the nearest
    edges' ``distances`` (m) and the lowest returning ``frequencies`` (Hz)."""

    plate: str
    bound: float
    distances: tuple[float, float]
    frequencies: tuple[float, float]


def energy_shares_above(result, omegas) -> list[float]:
    """Shares of the pulse energy above each of ``omegas`` (rad/s), from one zero-padded FFT."""
    t = np.linspace(0.0, result.separation_time, PULSE_SAMPLES)
    f = np.asarray(result.force_at(t), dtype=float)
    dt = t[1] - t[0]
    spectrum = np.abs(np.fft.rfft(f, TRANSFORM_LENGTH)) ** 2
    frequencies = 2.0 * math.pi * np.fft.rfftfreq(TRANSFORM_LENGTH, dt)
    total = float(spectrum.sum())
    if not total > 0.0:
        return [0.0 for _ in omegas]
    return [float(spectrum[frequencies >= omega].sum()) / total for omega in omegas]


def return_frequency(plate, distance: float, contact_time: float) -> float:
    """Lowest angular frequency (rad/s) whose flexural wave reflected at ``distance`` (m) is
    back within ``contact_time`` (s): ``(d / (kappa tau))^2``, ``kappa = (D / (rho h))^(1/4)``."""
    kappa = (plate.flexural_rigidity / plate.surface_density) ** 0.25
    return (distance / (kappa * contact_time)) ** 2


def choose_plate(result, plate, position, ball_mass: float, speed: float) -> PlateChoice:
    """The :class:`PlateChoice` for the first impact ``result`` at ``speed`` (m/s), ``ball_mass``
    (kg), ``position`` (m); for a settling ball the bound is on the plate's energy share."""
    x, y = plate.check_position(position, "position")
    dx = min(x, plate.length - x)
    dy = min(y, plate.width - y)
    tau = result.separation_time
    omegas = (return_frequency(plate, dx, tau), return_frequency(plate, dy, tau))
    shares = energy_shares_above(result, omegas)
    contrast = impedance.edge_blend(*shares) - 1.0
    taken = result.plate_energy / (0.5 * ball_mass * speed * speed)
    e = result.restitution
    bound = taken * contrast / (2.0 * e) if e > 0.0 and not result.settled else taken * contrast
    frequencies = (omegas[0] / (2.0 * math.pi), omegas[1] / (2.0 * math.pi))
    return PlateChoice("modal" if bound > TOLERANCE else "impedance", bound, (dx, dy), frequencies)


def scene_plate(scene) -> PlateChoice:
    """The plate in a scene's contact: as named, impedance for the shell law, else chosen."""
    from synth.physics.scene import Scene, check_type

    check_type("scene", scene, Scene)
    c = scene.contact
    if c.law == "shell":
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
    """:func:`choose_plate` on the hashable ``scene``'s first impact, kept for the scene."""
    from synth.physics.contact import solve_impact

    c = scene.contact
    speed = math.sqrt(2.0 * scene.gravity * scene.drop_height)
    first = solve_impact(
        scene.ball, scene.plate, speed, position=scene.position, gravity=scene.gravity,
        contact=c.law, rtol=c.rtol, **c.options(),
    )  # fmt: skip
    return choose_plate(first, scene.plate, scene.position, scene.ball.mass, speed)
