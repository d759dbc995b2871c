"""Driving-point impedance of a plate at the impact point (docs/physics.md, "Plate impedance").

* Infinite thin plate (the thesis, docs/physics.md, References, eqs. 2.34 / 4.30;
  Cremer, Heckl & Petersson,
  "Structure-Borne Sound", 3rd ed., section 5.3): real and frequency-independent,

      Z_inf = 8 sqrt(D rho h) = 4 h^2 sqrt(E rho / (3 (1 - nu^2)))        N s/m

* Infinite thick (Mindlin) plate, with shear deformation and rotary inertia
  (docs/physics.md, "Thick plates (Mindlin)"): ``Re Y`` in closed form from the wavenumber
  integral of a point force (:func:`mindlin_point_admittance`), frequency-dependent, equal to
  ``1 / Z_inf`` as ``k h -> 0``; its dispersion relation, frequencies and modal mass serve the
  modal contact's ``theory="mindlin"``.

* At a free straight edge of a semi-infinite plate, for ka < 1 (Eichler 1964,
  J. Acoust. Soc. Am. 36, 344; thesis Table 3.4, measured Z_middle/Z_edge =
  3.3 ... 3.7): ``Z_edge = 0.29 Z_inf`` (:data:`EDGE_RATIO`).

* At a free corner there is no closed form; the thesis measured
  Z_middle/Z_corner = 7.6 (18 mm MDF), 7.4 (12 mm) and 4.9 (6.15 mm). The thick
  boards, where ka < 1 holds over the pulse's band as it does for Eichler's edge
  value, agree: :data:`CORNER_RATIO` = 1/7.5, their mean. (The 6 mm board's
  lower ratio is outside that regime and is not used.)

* Position dependence: the boundary is felt only within a critical distance of
  the order of half the distance a flexural wave travels during the contact,
  ``d_c = c_g tau / 2`` with the group velocity ``c_g = 2 sqrt(omega)
  (D / (rho h))^(1/4)`` at the pulse's dominant angular frequency
  ``omega = pi / tau`` (docs/physics.md, "Plate impedance"). The admittance is blended
  between the middle, edge and corner values with the smooth weight
  ``s(d) = cos^2(pi d / (2 d_c))`` for ``d < d_c`` (0 beyond) of each distance
  ``d`` to the nearest edge along x and along y:

      beta / beta_inf = 1 + (r_e - 1)(s_x + s_y) + (r_c - 2 r_e + 1) s_x s_y

  with ``r_e = 1/EDGE_RATIO`` and ``r_c = 1/CORNER_RATIO``: the middle value far
  from edges, the edge value on an edge far from corners, the corner value at a
  corner. This blend is empirical (a bilinear interpolation of the three
  measured regimes with a C1 taper); its scale ``d_c`` and its end values are
  those of the thesis.
"""

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


def edge_impedance(plate: Plate) -> float:
    """Driving-point impedance at a free straight edge, ``0.29 Z_inf``, N s/m."""
    return EDGE_RATIO * infinite_plate_impedance(plate)


def corner_impedance(plate: Plate) -> float:
    """Driving-point impedance at a free corner, ``Z_inf / 7.5``, N s/m."""
    return CORNER_RATIO * infinite_plate_impedance(plate)


def group_velocity(plate: Plate, omega: float) -> float:
    """Flexural group velocity ``c_g = 2 sqrt(omega) (D / (rho h))^(1/4)``, m/s.

    ``omega`` is an angular frequency, rad/s.
    """
    omega = checks.positive("omega", omega, "rad/s")
    return 2.0 * math.sqrt(omega) * (plate.flexural_rigidity / plate.surface_density) ** 0.25


def critical_distance(plate: Plate, contact_time: float) -> float:
    """Distance from an edge within which the edge is felt, ``c_g tau / 2``, m.

    ``contact_time`` is the contact duration ``tau``, s; ``c_g`` is taken at
    ``omega = pi / tau``.
    """
    tau = (
        contact_time
        if type(contact_time) is float and 0.0 < contact_time < math.inf
        else checks.positive("contact_time", contact_time, "s")
    )
    return _critical_distance(plate, tau)


def _critical_distance(plate: Plate, tau: float) -> float:
    """``sqrt(pi tau) (D / rho h)^(1/4)`` (m) for a checked ``tau`` (s)."""
    return math.sqrt(math.pi * tau) * (plate.flexural_rigidity / plate.surface_density) ** 0.25


def edge_contact_time(plate: Plate, distance: float) -> float:
    """The contact time (s) from which an edge at ``distance`` (m) is felt: where
    :func:`critical_distance` reaches it, ``d^2 / (pi sqrt(D / rho h))``."""
    wave = math.sqrt(plate.flexural_rigidity / plate.surface_density)
    return distance * distance / (math.pi * wave)


def _taper(d, dc):
    if d >= dc:
        return 0.0
    c = math.cos(0.5 * math.pi * d / dc)
    return c * c


def point_admittance(plate: Plate, position: tuple[float, float], contact_time: float) -> float:
    """Admittance ``beta`` (m/(N s)) at ``position`` (metres from a corner) for a pulse of
    duration ``contact_time`` (s).

    Equals ``1 / Z_inf`` farther than the critical distance from every edge. Only
    free edges soften the plate this way; for simply supported and clamped plates
    the infinite-plate value is returned (the thesis measured free edges only;
    those boundaries are handled by the plate's modes).
    """
    x, y = plate.check_position(position, "position")
    tau = checks.positive("contact_time", contact_time, "s")
    return admittance_at(plate, x, y, tau, 1.0 / infinite_plate_impedance(plate))


def admittance_at(
    plate: Plate, x: float, y: float, contact_time: float, infinite_admittance: float
) -> float:
    """:func:`point_admittance` at ``(x, y)`` (m, inside the plate) for a contact of
    ``contact_time`` (s, > 0), given the plate's ``infinite_admittance = 1 / Z_inf``
    (m/(N s)): the contact solver's inner loop, which has checked these values."""
    tau, beta_inf = contact_time, infinite_admittance
    if plate.boundary != "free":
        return beta_inf
    dc = _critical_distance(plate, tau)
    sx = _taper(min(x, plate.length - x), dc)
    sy = _taper(min(y, plate.width - y), dc)
    if sx == 0.0 and sy == 0.0:
        return beta_inf
    re = 1.0 / EDGE_RATIO
    rc = 1.0 / CORNER_RATIO
    return beta_inf * (1.0 + (re - 1.0) * (sx + sy) + (rc - 2.0 * re + 1.0) * sx * sy)


# --------------------------------------------------------------------------------------
# Thick plates: Mindlin's shear deformation and rotary inertia
# --------------------------------------------------------------------------------------

#: Mindlin's shear coefficient ``kappa`` (Reissner's 5/6; Mindlin's own pi^2/12 = 0.822
#: differs by 1.3 %).
SHEAR_COEFFICIENT = 5.0 / 6.0


def _mindlin_constants(plate: Plate) -> tuple[float, float, float, float, float]:
    """``D`` (N m), ``rho h`` (kg/m^2), ``I = rho h^3 / 12`` (kg), ``rho / (kappa G)``
    (s^2/m^2) and ``kappa G h`` (N/m) of the plate, ``G`` its material's transverse shear
    modulus (:attr:`synth.physics.materials.Material.transverse_shear_modulus`; isotropic
    ``E / (2 (1 + nu))`` unless the material gives one)."""
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
    """The two roots ``s1 > s2`` (rad^2/m^2) in ``s = k^2`` of Mindlin's dispersion relation
    at angular frequency ``omega`` (rad/s, > 0):

        P(s) = (s - omega^2 rho / (kappa G)) (D s - I omega^2) - rho h omega^2 = 0

    (Mindlin, J. Appl. Mech. 18 (1951) 31-38; Graff, "Wave Motion in Elastic Solids" (1975),
    chapter 8). ``s1`` is the propagating flexural wave; ``s2 < 0`` is evanescent below
    the thickness-shear cut-off ``sqrt(kappa G h / I)``. As ``omega h / c -> 0`` they tend
    to Kirchhoff's ``+-omega sqrt(rho h / D)``."""
    w2 = np.asarray(omega, dtype=float) ** 2
    D, rh, inertia, slow, _ = _mindlin_constants(plate)
    b = w2 * (inertia + D * slow)
    c = w2 * (inertia * slow * w2 - rh)
    s1 = (b + np.sqrt(b * b - 4.0 * D * c)) / (2.0 * D)
    return s1, c / (D * s1)


def mindlin_point_admittance(plate: Plate, frequency):
    """Real part of the driving-point admittance of the infinite Mindlin plate under a point
    force, m/(N s), at ``frequency`` (Hz, > 0):

        Re Y = omega N(s1) / (4 D (s1 - s2)),   N(s) = 1 + (D s - I omega^2) / (kappa G h)

    the residue of the propagating pole in ``Y = i omega / (4 pi) Int_0^inf N(s) / P(s) ds``
    (the wavenumber integral of the point force; ``N / P`` the plate's transfer function,
    see :func:`mindlin_wavenumbers`). It tends to Kirchhoff's ``1 / (8 sqrt(D rho h))``
    at low frequency and rises with ``k h``: shear makes the plate softer. (The imaginary
    part diverges logarithmically under a true point force, the local shear deflection;
    the contact's finite area bounds it, and the contact law carries it.)"""
    f = np.asarray(frequency, dtype=float)
    if not np.all(np.isfinite(f) & (f > 0.0)):
        raise ParameterError(f"frequency={frequency!r} must be finite and > 0 (Hz)")
    w = 2.0 * math.pi * f
    D, _, inertia, _, shear_stiffness = _mindlin_constants(plate)
    s1, s2 = mindlin_wavenumbers(plate, w)
    n1 = 1.0 + (D * s1 - inertia * w * w) / shear_stiffness
    y = w * n1 / (4.0 * D * (s1 - s2))
    return float(y) if np.ndim(y) == 0 else y


def mindlin_band_impedance(plate: Plate, low: float, high: float) -> float:
    """``1 / <Re Y>`` (N s/m) of the infinite Mindlin plate, ``Re Y``
    (:func:`mindlin_point_admittance`) averaged over ``[low, high]`` (Hz) by adaptive
    quadrature: what an impact hammer's band-averaged measurement gives at the middle of a
    large plate (``ModalPoint.band_impedance`` of :mod:`synth.physics.modal_contact`)."""
    from scipy.integrate import quad

    lo = checks.nonnegative("low", low, "Hz")
    hi = checks.positive("high", high, "Hz")
    if not hi > lo:
        raise ParameterError(f"high={high!r} must be > low={low!r} (Hz)")
    # Re Y is continuous down to 0 Hz (Kirchhoff's constant); start just above it
    mean = quad(lambda f: mindlin_point_admittance(plate, f), max(lo, 1e-6 * hi), hi, limit=200)[0]
    return (hi - lo) / mean


def mindlin_angular_frequency(plate: Plate, wavenumber_squared):
    """The flexural (lower) Mindlin angular frequency, rad/s, of a wave of ``k^2`` =
    ``wavenumber_squared`` (rad^2/m^2): the lower root in ``omega^2`` of ``P = 0``
    (:func:`mindlin_wavenumbers`),

        A omega^4 - B omega^2 + D s^2 = 0,  A = I rho / (kappa G),
        B = D s rho / (kappa G) + I s + rho h.

    For the simply supported plate's mode (m, n), ``s = (m pi / a)^2 + (n pi / b)^2``, this
    is Mindlin's exact frequency (Mindlin, Schacknow & Deresiewicz, J. Appl. Mech. 23
    (1956) 430-436)."""
    s = np.asarray(wavenumber_squared, dtype=float)
    D, rh, inertia, slow, _ = _mindlin_constants(plate)
    a = inertia * slow
    b = D * s * slow + inertia * s + rh
    w2 = 2.0 * D * s * s / (b + np.sqrt(b * b - 4.0 * a * D * s * s))
    return np.sqrt(w2)


def mindlin_mass_factor(plate: Plate, wavenumber_squared, omega):
    """A Mindlin mode's modal mass over Kirchhoff's ``rho h S``-normalised one, for the
    mode of ``k^2 = wavenumber_squared`` (rad^2/m^2) at ``omega`` (rad/s): the rotations
    ``psi = i k w / N(s)`` (from the moment equation) add the rotary kinetic energy,
    ``1 + I s / (rho h N(s)^2)``."""
    s = np.asarray(wavenumber_squared, dtype=float)
    w = np.asarray(omega, dtype=float)
    D, rh, inertia, _, shear_stiffness = _mindlin_constants(plate)
    n = 1.0 + (D * s - inertia * w * w) / shear_stiffness
    return 1.0 + inertia * s / (rh * n * n)


@dataclass(frozen=True)
class WaveSpeeds:
    """Bending-wave speeds at one frequency, m/s: ``phase = omega / k`` and ``group =
    d omega / d k`` (the speed of a wave packet's energy)."""

    phase: float
    group: float


def kirchhoff_wave_speeds(plate: Plate, frequency: float) -> WaveSpeeds:
    """The thin plate's bending-wave speeds at ``frequency`` (Hz, > 0): ``c = sqrt(omega)
    (D / (rho h))^(1/4)`` and ``c_g = 2 c`` (Cremer, Heckl & Petersson, section 3.7)."""
    f = checks.positive("frequency", frequency, "Hz")
    c = math.sqrt(2.0 * math.pi * f) * (plate.flexural_rigidity / plate.surface_density) ** 0.25
    return WaveSpeeds(c, 2.0 * c)


def mindlin_wave_speeds(plate: Plate, frequency: float) -> WaveSpeeds:
    """The Mindlin plate's flexural-wave speeds at ``frequency`` (Hz, > 0), with the
    material's transverse shear modulus (:func:`mindlin_wavenumbers`): ``c = omega / k`` at
    the propagating root ``k^2 = s1``, and the group speed by implicit differentiation of
    ``P(k^2, omega^2) = 0``,

        c_g = -(k / omega) (dP/ds) / (dP/d omega^2),
        dP/ds = (D s - I omega^2) + D (s - omega^2 rho / (kappa G)),
        dP/d omega^2 = -(rho / (kappa G)) (D s - I omega^2) - I (s - omega^2 rho / (kappa G))
                       - rho h.

    Below the thin plate's at every frequency; as ``k h -> 0`` they tend to Kirchhoff's
    (:func:`kirchhoff_wave_speeds`), and at high frequency both tend to the slower of the
    shear speed ``sqrt(kappa G / rho)`` and the plate speed ``sqrt(D / I)``."""
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
