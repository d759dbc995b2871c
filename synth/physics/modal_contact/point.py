"""The plate as the modal contact sees it at one point: the band's modes and couplings
(cached on disk per point), the free plate's rigid-body coupling, and the residual (the
infinite plate's modes above the band, lumped)."""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, field

import numpy as np

from synth import checks
from synth.errors import ParameterError
from synth.physics import impedance
from synth.physics.modal_contact.kernels import Oscillators
from synth.physics.scene import Plate, check_type
from synth.store.cache import MemoryCache, cache_path, load_npz, savez_atomic

#: The residual's lumped modes above the band limit: this many geometric bins, each this
#: ratio wide in frequency (three per octave, four octaves: the tail starts at 16 Omega).
RESIDUAL_BINS = 12
RESIDUAL_RATIO = 2.0 ** (1.0 / 3.0)


@dataclass(frozen=True, eq=False)
class ModalPoint:
    """The finite plate at ``position`` (m) to ``max_frequency`` (Hz) in ``theory``: modes'
    ``omega`` (rad/s), ``sigma`` (1/s), couplings ``phi_k(x0)^2 / M_k`` (1/kg); ``rigid_coupling``
    (1/kg); the residual's lumped modes and tail, ``residual_admittance`` (``Re Y`` of the infinite
    plate at the top ``W``, m/(N s)), ``residual_rate`` ``pi W / 2`` (1/s)."""

    plate: Plate
    position: tuple[float, float]
    max_frequency: float
    omega: np.ndarray = field(repr=False)
    sigma: np.ndarray = field(repr=False)
    coupling: np.ndarray = field(repr=False)
    rigid_coupling: float
    residual_admittance: float
    residual_rate: float
    theory: str = "kirchhoff"
    residual_omega: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    residual_sigma: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    residual_coupling: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def contact_modes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``omega`` (rad/s), ``sigma`` (1/s), couplings (1/kg): the band's, then the residual's."""
        return (
            np.concatenate((self.omega, self.residual_omega)),
            np.concatenate((self.sigma, self.residual_sigma)),
            np.concatenate((self.coupling, self.residual_coupling)),
        )

    @functools.cached_property
    def oscillators(self) -> Oscillators:
        """:attr:`contact_modes`, rigid body and residual tail as the kernels take them."""
        return Oscillators(
            *self.contact_modes, float(self.rigid_coupling), float(self.residual_admittance),
            float(self.residual_rate),
        )  # fmt: skip

    def residual(self, frequency) -> np.ndarray:
        """The residual's admittance (m/(N s), as :meth:`admittance`) at ``frequency`` (Hz)."""
        s = 2j * np.pi * np.asarray(frequency, dtype=float)[..., None]
        w, sg, c = self.residual_omega, self.residual_sigma, self.residual_coupling
        lumped = (s * c / (s * s + 2.0 * sg * s + w**2)).sum(axis=-1)
        s1 = s[..., 0]
        return lumped + self.residual_admittance * s1 / (s1 + self.residual_rate)

    def admittance(self, frequency) -> np.ndarray:
        """Driving-point admittance ``Y = v / F`` (m/(N s), ``e^(i omega t)``, force and velocity
        downward) at ``frequency`` (Hz, > 0)."""
        f = np.atleast_1d(np.asarray(frequency, dtype=float))
        if not np.all(np.isfinite(f) & (f > 0.0)):
            raise ParameterError(f"frequency={frequency!r} must be finite and > 0 (Hz)")
        s = 2j * np.pi * f[:, None]
        modal = (s * self.coupling / (s * s + 2.0 * self.sigma * s + self.omega**2)).sum(axis=1)
        y = modal + self.rigid_coupling / s[:, 0] + self.residual(f)
        return y.reshape(np.shape(frequency)) if np.ndim(frequency) else y[0]


#: Plate theories of the modal contact (:func:`modal_point`).
PLATE_THEORIES = ("kirchhoff", "mindlin")


def modal_point(
    plate: Plate,
    position: tuple[float, float],
    *,
    max_frequency: float,
    theory: str = "kirchhoff",
) -> ModalPoint:
    """The plate at ``position`` (m) with its modes up to ``max_frequency`` (Hz) and the
    residual. "mindlin" (docs/physics.md, "Thick plates"): each thin-plate mode keeps shape and
    wavenumber and takes Mindlin's frequency and modal mass. The modes solve exactly this band
    (a bounce series amplifies their last digits)."""
    check_type("plate", plate, Plate)
    x, y = plate.check_position(position, "position")
    fmax = checks.positive("max_frequency", max_frequency, "Hz")
    checks.choice("theory", theory, PLATE_THEORIES)
    omega_band = 2.0 * math.pi * fmax
    if theory == "mindlin":
        s_band = impedance.mindlin_wavenumbers(plate, omega_band)[0]
        thin_band = _mode_frequency(plate, s_band, "kirchhoff")[()]
        omega, coupling = _point_modes(plate, (x, y), thin_band / (2.0 * math.pi))
        s = omega * math.sqrt(plate.surface_density / plate.flexural_rigidity)
        omega = impedance.mindlin_angular_frequency(plate, s)
        coupling = coupling / impedance.mindlin_mass_factor(plate, s, omega)
        inside = omega <= omega_band
        omega, coupling = omega[inside], coupling[inside]
    else:
        omega, coupling = _point_modes(plate, (x, y), fmax)
    lumped = _lumped_residual(plate, omega_band, theory)
    sigma = _decay_rates(plate, omega, fmax)
    edge_loss = _band_edge_loss(plate, omega_band, fmax)
    # modes with a node at the point take no part in the contact
    keep = coupling > 1e-12 * coupling.max(initial=0.0)
    omega, sigma, coupling = omega[keep], sigma[keep], coupling[keep]
    xi, eta = 2.0 * x / plate.length - 1.0, 2.0 * y / plate.width - 1.0
    free = plate.boundary == "free"
    rigid = (1.0 + 3.0 * xi * xi + 3.0 * eta * eta) / plate.mass if free else 0.0
    return ModalPoint(
        plate, (x, y), fmax, omega, sigma, coupling, rigid, lumped.tail_admittance,
        lumped.tail_rate, theory, lumped.omega, lumped.omega * edge_loss, lumped.coupling,
    )  # fmt: skip


def _band_edge_loss(plate: Plate, omega_band: float, fmax: float) -> float:
    """``sigma / omega`` of the damping law at ``omega_band`` (rad/s), kept by the residual's
    lumped modes (a damping law of the audio band is not extrapolated above it)."""
    return float(_decay_rates(plate, np.array([omega_band]), fmax)[0]) / omega_band


def _decay_rates(plate: Plate, omega: np.ndarray, fmax: float) -> np.ndarray:
    """The damping law's decay rates (1/s) at ``omega`` (rad/s), checked underdamped."""
    sigma = np.broadcast_to(
        np.asarray(plate.damping_law().decay_rate(omega), dtype=float), omega.shape
    ).copy()
    if np.any(sigma >= omega):
        k = int(np.argmax(sigma >= omega))
        raise ParameterError(
            f"plate.material.damping gives the mode at {omega[k] / (2 * np.pi):.6g} Hz a decay "
            f"rate {sigma[k]:.6g} 1/s at or above its angular frequency: the modal contact "
            f"needs underdamped modes up to max_frequency={fmax!r} Hz"
        )
    return sigma


def _mode_frequency(plate: Plate, s, theory: str):
    """Angular frequency (rad/s) of the bending wave of ``k^2 = s`` (rad^2/m^2)."""
    if theory == "mindlin":
        return impedance.mindlin_angular_frequency(plate, s)
    return np.asarray(s, dtype=float) * math.sqrt(plate.flexural_rigidity / plate.surface_density)


def _coupling_density(plate: Plate, s, theory: str):
    """``dmu / ds`` (1/kg per rad^2/m^2): the infinite plate's couplings per unit ``s = k^2``,
    ``1 / (4 pi rho h m_f(s))`` (:func:`impedance.mindlin_mass_factor`, 1 for Kirchhoff)."""
    base = 1.0 / (4.0 * math.pi * plate.surface_density)
    if theory != "mindlin":
        return base * np.ones_like(np.asarray(s, dtype=float))
    return base / impedance.mindlin_mass_factor(plate, s, _mode_frequency(plate, s, theory))


def _wavenumber_at(plate: Plate, omega: float, theory: str) -> float:
    """``s = k^2`` (rad^2/m^2) of the propagating bending wave at ``omega`` (rad/s)."""
    if theory == "mindlin":
        return float(impedance.mindlin_wavenumbers(plate, omega)[0])
    return omega * math.sqrt(plate.surface_density / plate.flexural_rigidity)


@dataclass(frozen=True)
class _LumpedResidual:
    """The residual's lumped modes (rad/s, 1/kg) and its tail (m/(N s), 1/s)."""

    omega: np.ndarray
    coupling: np.ndarray
    tail_admittance: float
    tail_rate: float


def _lumped_residual(plate: Plate, omega_band: float, theory: str) -> _LumpedResidual:
    """The residual above ``omega_band`` (rad/s): lumped modes per geometric bin with ``c_j =
    Int dmu`` and ``c_j / w_j^2 = Int dmu / w^2`` (stiffness below, mass above), and a tail."""
    from scipy.integrate import quad

    edges = omega_band * RESIDUAL_RATIO ** np.arange(RESIDUAL_BINS + 1)
    s = [_wavenumber_at(plate, float(w), theory) for w in edges]
    omega, coupling = [], []

    def density(x):  # dmu / ds
        return float(_coupling_density(plate, x, theory))

    def compliance(x):  # dmu / ds / omega^2
        return density(x) / float(_mode_frequency(plate, x, theory)) ** 2

    for lo, hi in zip(s[:-1], s[1:], strict=True):
        c, k = quad(density, lo, hi)[0], quad(compliance, lo, hi)[0]
        omega.append(math.sqrt(c / k))
        coupling.append(c)
    top = float(edges[-1])
    if theory == "mindlin":
        tail = float(impedance.mindlin_point_admittance(plate, top / (2.0 * math.pi)))
    else:
        tail = 1.0 / impedance.infinite_plate_impedance(plate)
    return _LumpedResidual(np.array(omega), np.array(coupling), tail, 0.5 * math.pi * top)


# Eigen-solutions of the contact's bands in memory, each point's modes on disk, keyed by plate,
# band, point and solver; _POINT_VERSION changes with anything else that moves their bits.
_BAND_MODES = MemoryCache("solves", max_entries=8)
_POINT_VERSION = 2


def clear_memory_cache() -> None:
    """Forget the eigen-solutions held by :func:`band_modes` (not the disk cache)."""
    _BAND_MODES.clear()


def _plate_key(plate: Plate, max_frequency: float) -> dict:
    """What the bending modes of ``plate`` to ``max_frequency`` (Hz) depend on."""
    m = plate.material
    values = dict(young=m.young, density=m.density, poisson=m.poisson, thickness=plate.thickness,
                  length=plate.length, width=plate.width, max_frequency=max_frequency)  # fmt: skip
    return {"boundary": plate.boundary, **{k: float(v).hex() for k, v in values.items()}}


def band_modes(plate: Plate, max_frequency: float):
    """Modes of ``plate`` to ``max_frequency`` (Hz), of exactly that band, held in memory."""
    from synth.physics.modes import modes as plate_modes

    def solved():
        held = plate_modes(plate, max_frequency=max_frequency)
        return held if held.solved_for_band else plate_modes(plate, max_frequency=max_frequency,
                                                              cache=False)  # fmt: skip

    return _BAND_MODES.fetch(json.dumps(_plate_key(plate, max_frequency), sort_keys=True), solved)


def _point_modes(plate: Plate, position, max_frequency: float) -> tuple[np.ndarray, np.ndarray]:
    """``omega`` (rad/s), couplings (1/kg) at ``position``: from the disk cache, or computed."""
    key = _point_key(plate, position, max_frequency)
    try:
        path = cache_path("contact-point-modes", key)
    except RuntimeError:  # no home directory: no disk cache
        path = None
    stored = _load_point(path, key)
    if stored is not None:
        return stored
    m = band_modes(plate, max_frequency)
    phi = m.shapes(np.array([position], dtype=float))[0]
    omega = np.array(m.angular_frequencies, dtype=float)
    coupling = phi * phi / np.asarray(m.modal_masses, dtype=float)
    if path is not None:
        savez_atomic(path, {"key": np.array(key), "omega": omega, "coupling": coupling})
    return omega, coupling


def _point_key(plate: Plate, position, max_frequency: float) -> str:
    """The disk key of the modes at ``position`` (m): every input, the solver's identity and
    the digest of this module's sources and all they import."""
    from synth.jitcache import source_digest
    from synth.physics.modes import solver_key

    x, y = (float(v).hex() for v in position)
    solver = solver_key(plate, max_frequency)
    key = dict(_plate_key(plate, max_frequency), x=x, y=y, version=_POINT_VERSION, solver=solver,
               code=source_digest(__file__))  # fmt: skip
    return json.dumps(key, sort_keys=True)


def _load_point(path, key: str):
    """The stored ``(omega, coupling)`` of ``key`` at ``path``; None if absent or inconsistent."""
    if path is None or not path.is_file():
        return None
    try:
        with load_npz(path) as z:
            if str(z["key"][()]) != key:
                return None
            omega, coupling = z["omega"], z["coupling"]
    except (OSError, ValueError, KeyError):
        return None
    ok = omega.ndim == 1 and coupling.shape == omega.shape
    ok = ok and bool(np.all(np.isfinite(omega) & (omega > 0.0) & (coupling >= 0.0)))
    return (omega, coupling) if ok and bool(np.all(np.isfinite(coupling))) else None
