"""What a rolling returns: its contact sampled at the audio rate, its energy balance, and
the state to continue from (the results of :func:`synth.physics.rolling.roll`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.physics import rolling_kernels as _k
from synth.physics.contact_law import ContactLaw
from synth.physics.scene import check_type
from synth.physics.surface import ContactEnvelope, envelope_at, read_only


@dataclass(frozen=True)
class EnergyBalance:
    """The mechanical energy ``m v_y^2 / 2 + m g y + K delta^(n+1) / (n+1)`` of the ball and its
    contact at the start and the end, J (``initial``, ``final``; potential from the plate's
    plane), and where the difference went, J: ``loss_work`` the contact's loss ``Int (F - K
    delta^n) delta' dt``, ``plate_energy`` into the plate ``Int beta F^2 dt``, ``drive_work``
    of the horizontal drive ``Int F e'(s) v dt`` (the force's horizontal part against the imposed
    speed), ``gross_drive_work`` ``Int |F e'(s) v| dt``. ``residual`` is ``|final - initial +
    loss_work + plate_energy - drive_work|`` (zero for the exact solution) relative to the
    largest of ``gross_drive_work``, ``loss_work + plate_energy``, ``|final - initial|`` and
    ``m g delta_static``."""

    initial: float
    final: float
    loss_work: float
    plate_energy: float
    drive_work: float
    gross_drive_work: float
    residual: float


@dataclass(frozen=True, eq=False)
class RollingState:
    """Where a rolling ended, to continue from (:func:`roll`'s ``state``), or a ball above the
    surface to start from (:meth:`at`): ``vector`` the integrator's state (read-only: height
    relative to the surface, m; vertical speed, m/s; the plate's displacement, m; the energy
    quadratures, J; the centre's path coordinate, m), ``step`` its next step, s (None: chosen)."""

    vector: np.ndarray
    step: float | None

    @classmethod
    def at(
        cls,
        envelope: ContactEnvelope,
        *,
        path_position: float,
        height: float,
        vertical_velocity: float,
    ) -> RollingState:
        """The ball over ``path_position`` (m), its lowest point ``height`` (m) above the envelope
        (negative: pressed in), moving up at ``vertical_velocity`` (m/s), the plate at rest: a
        landing ball is ``height=0, vertical_velocity=-v_in``."""
        check_type("envelope", envelope, ContactEnvelope)
        s = checks.in_range(
            "path_position", path_position, 0.0, envelope.length, "metres",
            lo_open=False, hi_open=False,
        )  # fmt: skip
        y = np.zeros(_k.N_STATE)
        e, _, _ = envelope_at(envelope.coefficients, envelope.spacing, s)
        y[_k.Z] = e + checks.real("height", height, "metres")
        y[_k.VY] = checks.real("vertical_velocity", vertical_velocity, "m/s")
        y[_k.S] = s
        return cls(read_only(y), None)

    @property
    def path_position(self) -> float:
        """The ball's centre on the path, m."""
        return float(self.vector[_k.S])

    @property
    def vertical_velocity(self) -> float:
        """The ball's vertical velocity, m/s (upward)."""
        return float(self.vector[_k.VY])


@dataclass(frozen=True, eq=False)
class RollingContact:
    """A rolling ball's contact with the plate, sampled at ``samplerate`` (Hz; sample ``j`` covers
    ``[j, j + 1) / samplerate`` s). Arrays (N,) per sample period: ``force`` the mean force on the
    plate, N; ``path_position`` the centre on the path in the period's middle, m;
    ``contact_coordinate`` the touching point on the path, m; ``contact_point`` (N, 2) it on the
    plate, m from its corner; ``min_penetration`` the smallest at the steps' ends, m (<= 0: off
    the plate); ``speed`` the horizontal speed, m/s. ``flights`` counts the losses of contact;
    ``law`` the contact law's constants; ``admittance`` ``beta``, m/(N s) (0 rigid); ``origin``
    (m) and unit ``direction`` of the path; ``mass`` kg; ``static_penetration`` ``(m g /
    K)^(1/n)``, m, the error control's scale; ``status`` 0 integrated to its end, negative a
    failure (``message``); ``n_steps``, ``n_rejected`` steps taken and rejected;
    ``final_state`` to continue from."""

    samplerate: int
    force: np.ndarray
    path_position: np.ndarray
    contact_coordinate: np.ndarray
    contact_point: np.ndarray
    min_penetration: np.ndarray
    flights: int
    energy: EnergyBalance
    law: ContactLaw
    admittance: float
    speed: np.ndarray
    origin: tuple[float, float]
    direction: tuple[float, float]
    mass: float
    static_penetration: float
    success: bool
    status: int
    message: str
    n_steps: int
    n_rejected: int
    final_state: RollingState

    @property
    def contact_lost(self) -> np.ndarray:
        """Samples in which the ball was seen off the plate (bool, (N,))."""
        return self.min_penetration <= 0.0

    @property
    def mean_drag(self) -> float:
        """Mean horizontal force the contact opposes to the ball's motion, N: the drive's
        work per metre of path (NaN if the ball did not move)."""
        distance = float(np.sum(self.speed)) / self.samplerate
        return self.energy.drive_work / distance if distance > 0.0 else math.nan
