"""Driving-point impedance of a plate at the impact point (docs/physics.md, "Plate impedance"),
N s/m: infinite thin and Mindlin plates, and measured ratios near free edges and corners."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from synth import checks
from synth.errors import ParameterError

if TYPE_CHECKING:
    from synth.physics.scene import Plate

#: Z_edge / Z_inf at a free straight edge (Eichler; thesis Table 3.4).
EDGE_RATIO = 0.29
#: Z_corner / Z_inf at a free right-angled corner (thesis Table 3.4, 18 and 12 mm boards).
CORNER_RATIO = 1.0 / 7.5


def infinite_plate_impedance(plate: Plate) -> float:
    """``Z_inf = 8 sqrt(D rho h)``, N s/m (thesis eq. 2.34)."""
    return 8.0 * math.sqrt(plate.flexural_rigidity * plate.surface_density)


def critical_distance(plate: Plate, contact_time: float) -> float:
    """Distance (m) within which an edge is felt, ``c_g tau / 2`` at ``omega = pi / tau`` (s):
    ``sqrt(pi tau) (D / rho h)^(1/4)``."""
    tau = contact_time
    if not (type(tau) is float and 0.0 < tau < math.inf):
        tau = checks.positive("contact_time", contact_time, "s")
    return math.sqrt(math.pi * tau) * (plate.flexural_rigidity / plate.surface_density) ** 0.25


def edge_contact_time(plate: Plate, distance: float) -> float:
    """The contact time (s) from which an edge at ``distance`` (m) is felt."""
    wave = math.sqrt(plate.flexural_rigidity / plate.surface_density)
    return distance * distance / (math.pi * wave)


def _taper(d, dc):
    if d >= dc:
        return 0.0
    c = math.cos(0.5 * math.pi * d / dc)
    return c * c


def point_admittance(plate: Plate, position: tuple[float, float], contact_time: float) -> float:
    """Admittance (m/(N s)) at ``position`` (m) for a pulse of ``contact_time`` (s): ``1 /
    Z_inf`` beyond the critical distance, and everywhere on simply supported and clamped plates
    (the thesis measured free edges only)."""
    x, y = plate.check_position(position, "position")
    tau = checks.positive("contact_time", contact_time, "s")
    return admittance_at(plate, x, y, tau, 1.0 / infinite_plate_impedance(plate))


def admittance_at(
    plate: Plate, x: float, y: float, contact_time: float, infinite_admittance: float
) -> float:
    """:func:`point_admittance` on checked values (m, s, m/(N s)): the solver's inner loop."""
    tau, beta_inf = contact_time, infinite_admittance
    if plate.boundary != "free":
        return beta_inf
    dc = critical_distance(plate, tau)
    sx = _taper(min(x, plate.length - x), dc)
    sy = _taper(min(y, plate.width - y), dc)
    if sx == 0.0 and sy == 0.0:
        return beta_inf
    return beta_inf * edge_blend(sx, sy)


def edge_blend(sx: float, sy: float) -> float:
    """``Z_inf / Z`` where the edges along x and y are felt by the shares ``sx``, ``sy`` in [0,
    1]: bilinear between the middle's 1, an edge's and a corner's (Table 3.4)."""
    re = 1.0 / EDGE_RATIO
    rc = 1.0 / CORNER_RATIO
    return 1.0 + (re - 1.0) * (sx + sy) + (rc - 2.0 * re + 1.0) * sx * sy


#: Mindlin's shear coefficient ``kappa`` (Reissner's 5/6; Mindlin's pi^2/12 differs by 1.3 %).
SHEAR_COEFFICIENT = 5.0 / 6.0


def _mindlin_constants(plate: Plate) -> tuple[float, float, float, float, float]:
    """``D`` (N m), ``rho h`` (kg/m^2), ``I = rho h^3 / 12`` (kg), ``rho / (kappa G)`` (s^2/m^2)
    and ``kappa G h`` (N/m), ``G`` the material's transverse shear modulus."""
    m = plate.material
    shear = m.transverse_shear_modulus
    h = plate.thickness
    return (
        plate.flexural_rigidity,
        plate.surface_density,
        m.density * h**3 / 12.0,
        m.density / (SHEAR_COEFFICIENT * shear),
        SHEAR_COEFFICIENT * shear * h,
    )


def mindlin_wavenumbers(plate: Plate, omega):
    """Roots ``s1 > s2`` (rad^2/m^2) in ``s = k^2`` of Mindlin's dispersion relation at
    ``omega`` (rad/s) (Mindlin, J. Appl. Mech. 18 (1951) 31-38; Graff 1975, ch. 8): ``s1``
    propagating, ``s2 < 0`` evanescent below the thickness-shear cut-off."""
    w2 = np.asarray(omega, dtype=float) ** 2
    D, rh, inertia, slow, _ = _mindlin_constants(plate)
    b = w2 * (inertia + D * slow)
    c = w2 * (inertia * slow * w2 - rh)
    s1 = (b + np.sqrt(b * b - 4.0 * D * c)) / (2.0 * D)
    return s1, c / (D * s1)


def mindlin_point_admittance(plate: Plate, frequency):
    """``Re Y`` (m/(N s)) of the infinite Mindlin plate under a point force at ``frequency``
    (Hz): the residue of the propagating pole, Kirchhoff's ``1 / (8 sqrt(D rho h))`` at low
    frequency. (``Im Y`` diverges under a true point force; the contact law carries it.)"""
    f = np.asarray(frequency, dtype=float)
    if not np.all(np.isfinite(f) & (f > 0.0)):
        raise ParameterError(f"frequency={frequency!r} must be finite and > 0 (Hz)")
    w = 2.0 * math.pi * f
    D, _, inertia, _, shear_stiffness = _mindlin_constants(plate)
    s1, s2 = mindlin_wavenumbers(plate, w)
    n1 = 1.0 + (D * s1 - inertia * w * w) / shear_stiffness
    y = w * n1 / (4.0 * D * (s1 - s2))
    return float(y) if np.ndim(y) == 0 else y


def mindlin_angular_frequency(plate: Plate, wavenumber_squared):
    """Flexural Mindlin angular frequency (rad/s) at ``k^2`` (rad^2/m^2): exact for a simply
    supported mode (Mindlin, Schacknow & Deresiewicz, J. Appl. Mech. 23 (1956) 430-436)."""
    s = np.asarray(wavenumber_squared, dtype=float)
    D, rh, inertia, slow, _ = _mindlin_constants(plate)
    a = inertia * slow
    b = D * s * slow + inertia * s + rh
    w2 = 2.0 * D * s * s / (b + np.sqrt(b * b - 4.0 * a * D * s * s))
    return np.sqrt(w2)


def mindlin_mass_factor(plate: Plate, wavenumber_squared, omega):
    """A Mindlin mode's modal mass over Kirchhoff's at ``k^2`` (rad^2/m^2), ``omega`` (rad/s):
    the rotations add ``1 + I s / (rho h N(s)^2)``."""
    s = np.asarray(wavenumber_squared, dtype=float)
    w = np.asarray(omega, dtype=float)
    D, rh, inertia, _, shear_stiffness = _mindlin_constants(plate)
    n = 1.0 + (D * s - inertia * w * w) / shear_stiffness
    return 1.0 + inertia * s / (rh * n * n)


@dataclass(frozen=True)
class WaveSpeeds:
    """Bending-wave phase and group speeds at one frequency, m/s."""

    phase: float
    group: float


def mindlin_wave_speeds(plate: Plate, frequency: float) -> WaveSpeeds:
    """The Mindlin plate's flexural-wave phase and group speeds (m/s) at ``frequency`` (Hz)."""
    f = checks.positive("frequency", frequency, "Hz")
    w = 2.0 * math.pi * f
    w2 = w * w
    D, rh, inertia, slow, _ = _mindlin_constants(plate)
    s = float(mindlin_wavenumbers(plate, w)[0])
    k = math.sqrt(s)
    bend = D * s - inertia * w2
    shear = s - w2 * slow
    dp_ds = bend + D * shear
    dp_dw2 = -slow * bend - inertia * shear - rh
    return WaveSpeeds(w / k, -(k / w) * dp_ds / dp_dw2)
