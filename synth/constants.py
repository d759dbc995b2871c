"""Physical constants (SI units) and defaults shared by the physics, the sound and the render
options. Air is dry, at 20 degC and 101.325 kPa (ISO 9613-1's reference atmosphere)."""

from __future__ import annotations

#: Speed of sound in dry air at 20 degC, m/s (ISO 9613-1 reference atmosphere:
#: c = 331.3 sqrt(1 + T / 273.15) = 343.2 m/s, rounded as in most acoustics texts).
SOUND_SPEED = 343.0

#: Density of dry air at 20 degC and 101.325 kPa, kg/m^3 (ideal gas,
#: rho = p M / (R T) = 101325 * 0.0289652 / (8.31446 * 293.15) = 1.204).
AIR_DENSITY = 1.204

#: Gravitational acceleration used by default, m/s^2 (9.81: the value of the thesis'
#: computations; the standard gravity of CGPM 1901 is 9.80665).
GRAVITY = 9.81

#: The bounce series' ``"floor"`` rule by default: it ends when an impact's kinetic energy
#: would be this far below the first's, dB.
DEFAULT_FLOOR_DB = -60.0
#: Most impacts a series computes by default (``max_impacts``: a guard for a ball that
#: keeps bouncing).
DEFAULT_MAX_IMPACTS = 10_000
#: Fewest points of the uniform grid on which a force pulse's transforms are taken.
PULSE_POINTS = 65
