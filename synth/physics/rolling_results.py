"""What a rolling returns: its contact sampled at the audio rate, its energy balance, and
the state to continue from (the results of :func:`synth.physics.rolling.roll` and of
:meth:`synth.physics.rolling.Roller.advance`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.errors import ParameterError
from synth.physics import rolling_kernels as _k
from synth.physics.contact_law import ContactLaw
from synth.physics.surface import ContactEnvelope, envelope_at


@dataclass(frozen=True)
class EnergyBalance:
    """The energy of the ball and its contact at the start and the end (J), and where the
    difference went.

    ``final - initial + loss_work + plate_energy - drive_work`` is zero for the exact
    solution: the mechanical energy ``m v_y^2 / 2 + m g y + K delta^(n+1) / (n+1)`` changes
    by the work of the horizontal drive (the force's horizontal part ``-F e'(s)`` against the
    imposed speed) less what the contact's loss and the plate's impedance take.

    Attributes
    ----------
    initial, final : float
        Mechanical energy, J (potential energy from the plate's nominal plane).
    loss_work : float
        Work of the contact's loss, ``Int (F - K delta^n) d(delta)/dt dt``, J (>= 0).
    plate_energy : float
        Energy carried into the plate, ``Int beta F^2 dt``, J.
    drive_work : float
        Work of the horizontal drive, ``Int F e'(s) v dt``, J.
    gross_drive_work : float
        ``Int |F e'(s) v| dt``, J: the energy exchanged with the drive.
    residual : float
        ``|final - initial + loss_work + plate_energy - drive_work|`` relative to the
        largest of ``gross_drive_work``, ``loss_work + plate_energy``, ``|final -
        initial|`` and the resting contact's energy scale ``m g delta_static``.
    """

    initial: float
    final: float
    loss_work: float
    plate_energy: float
    drive_work: float
    gross_drive_work: float
    residual: float


@dataclass(frozen=True, eq=False)
class RollingState:
    """Where a rolling ended, to continue from (:func:`roll`'s ``state``); or, made by
    :meth:`at`, a ball above (or on) the surface to start from.

    Attributes
    ----------
    vector : ndarray
        The integrator's state (read-only): the ball's height relative to the plate's
        surface (m), its vertical speed (m/s), the plate surface's displacement (m), the
        quadratures of the energy balance (J) and the centre's path coordinate (m).
    step : float or None
        The integrator's next step size, s (None: :func:`roll` chooses the first one).
    """

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
        """The ball with its centre above ``path_position`` (m, on the envelope's path), its
        lowest point ``height`` (m) above the envelope there (negative: pressed into it by
        that much), moving up at ``vertical_velocity`` (m/s; negative: down), the plate at
        rest: a landing ball is ``height=0, vertical_velocity=-v_in``."""
        if not isinstance(envelope, ContactEnvelope):
            raise ParameterError(f"envelope={envelope!r} must be a ContactEnvelope")
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
    """A rolling ball's contact with the plate, sampled at the audio rate (SI units).

    Attributes
    ----------
    samplerate : int
        Hz; sample ``j`` covers ``[j, j + 1) / samplerate`` s from the start.
    force : ndarray (N,)
        Mean contact force on the plate over each sample period, N (downward on the plate).
    path_position : ndarray (N,)
        Position of the ball's centre along the path in the middle of each sample period,
        m (where the period's mean force acts).
    contact_coordinate : ndarray (N,)
        Position of the touching point along the path there, m (the
        centre's position plus the envelope's contact offset).
    contact_point : ndarray (N, 2)
        That point on the plate, ``(x, y)`` m from the plate's corner.
    min_penetration : ndarray (N,)
        Smallest penetration at the solver's steps' ends within each sample, m (<= 0:
        the ball was off the plate).
    flights : int
        Losses of contact seen at the steps' ends.
    energy : EnergyBalance
    law : ContactLaw
        The contact law's constants.
    admittance : float
        The plate's admittance ``beta``, m/(N s) (0: rigid).
    speed : ndarray (N,)
        Horizontal speed in each sample period, m/s.
    origin : (float, float)
        Where the path's coordinate 0 lies on the plate, m from its corner.
    direction : (float, float)
        The path's unit direction on the plate.
    mass : float
        Ball mass, kg.
    static_penetration : float
        ``(m g / K)^(1/n)``, m: the scale of the error control.
    success : bool
    status : int
        0 integrated to its end; negative: failure (see ``message``).
    message : str
    n_steps, n_rejected : int
        Integration steps taken and rejected.
    final_state : RollingState
        Where the rolling ended, for a call that continues it.
    """

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


@dataclass(frozen=True, eq=False)
class RollingBlock:
    """One :meth:`Roller.advance` (SI units).

    Attributes
    ----------
    force : ndarray (N,)
        Mean contact force over each sample period, N.
    centre : ndarray (N,)
        The ball's centre on the path in the middle of each period, m.
    flights : int
        Losses of contact seen at the steps' ends.
    loss_work, plate_energy, drive_work : float
        As :class:`EnergyBalance`'s, J.
    success : bool
    message : str
    initial_state, final_state : RollingState
        Where the block started and ended.
    """

    force: np.ndarray
    centre: np.ndarray
    flights: int
    loss_work: float
    plate_energy: float
    drive_work: float
    success: bool
    message: str
    initial_state: RollingState
    final_state: RollingState


def read_only(a: np.ndarray) -> np.ndarray:
    """``a``, made read-only (the arrays a result holds)."""
    a.setflags(write=False)
    return a
