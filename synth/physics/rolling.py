"""A ball rolling at an imposed horizontal speed over a plate's rough surface (docs/rolling.md),
pressed by the contact law against the profile's envelope; its limits: docs/rolling.md."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import impedance
from synth.physics import rolling_kernels as _k
from synth.physics.contact_law import ContactLaw, contact_parameters
from synth.physics.scene import LAW_OPTIONS, MAX_GRAVITY, Ball, Plate, check_type
from synth.physics.surface import ContactEnvelope, envelope_at, read_only, samples

#: Most integration steps per sample period before the solver gives up.
MAX_STEPS_PER_SAMPLE = _k.MAX_STEPS_PER_SAMPLE
#: Longest rolling solved in one call, s.
MAX_DURATION = 3600.0
#: Most samples of one call (its arrays take about 50 bytes a sample: 1.5 GB).
MAX_SAMPLES = 30_000_000

_MESSAGES = {
    _k.OK: "The rolling was integrated to its end.",
    _k.MAX_STEPS: "The step limit was reached before the end.",
    _k.STEP_TOO_SMALL: "The step size fell below the resolution of the time axis.",
}


@dataclass(frozen=True)
class EnergyBalance:
    """Mechanical energy ``m v_y^2 / 2 + m g y + K delta^(n+1) / (n+1)`` at start and end (J) and
    where the difference went (J): contact loss, plate, the drive's work and its gross.
    ``residual``: the balance's error over the largest of those terms and ``m g delta_static``."""

    initial: float
    final: float
    loss_work: float
    plate_energy: float
    drive_work: float
    gross_drive_work: float
    residual: float


@dataclass(frozen=True, eq=False)
class RollingState:
    """Where a rolling ended, to continue from, or a ball above the surface: ``vector`` the
    integrator's read-only state (SI), ``step`` its next step, s (None: chosen)."""

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
        """The ball over ``path_position`` (m), its lowest point ``height`` (m) above the envelope,
        moving up at ``vertical_velocity`` (m/s), the plate at rest."""
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
    """A rolling ball's contact per sample period at ``samplerate`` (Hz): mean ``force`` (N),
    ``path_position`` (m), ``contact_coordinate`` (m), ``contact_point`` (N, 2; m), least
    ``min_penetration`` (m; <= 0: off the plate), ``speed`` (m/s); ``flights``; ``admittance``
    (m/(N s)); ``static_penetration`` ``(m g / K)^(1/n)`` (m); ``status``, ``message``,
    ``final_state``."""

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
        """Mean horizontal force opposing the motion, N (NaN if the ball did not move)."""
        distance = float(np.sum(self.speed)) / self.samplerate
        return self.energy.drive_work / distance if distance > 0.0 else math.nan


def _direction(direction) -> tuple[float, float]:
    dx, dy = checks.point("direction", direction, 2, "dimensionless")
    norm = math.hypot(dx, dy)
    if not norm > 0.0:
        raise ParameterError(f"direction={direction!r} must be a nonzero (x, y) vector")
    return dx / norm, dy / norm


def roll(ball: Ball, plate: Plate, envelope: ContactEnvelope, *, speed, samplerate: int, origin,
         **options) -> RollingContact:  # fmt: skip
    """Roll ``ball`` over ``plate`` along ``envelope`` (made with ``ball.radius``). ``speed``:
    m/s (>= 0), one for ``duration`` (s, at most :data:`MAX_DURATION`) or one per sample period
    of ``samplerate`` (Hz). ``origin``: the path's 0 on the plate, m. ``start``: the centre's
    path coordinate at time 0, m (pressed with ``m (g + v^2 e''(s0))``, as a ball rolled there
    slowly); or ``state`` to continue (consecutive calls give the bits of one call). The other
    ``options``: :meth:`Roller.over`'s."""
    where = {k: options.pop(k) for k in ("duration", "start", "state") if k in options}
    roller = Roller.over(ball, plate, envelope, samplerate=samplerate, origin=origin, **options)
    return roller.roll(speed, **where)


#: :meth:`Roller.over`'s settings beside the contact law's options, and their defaults.
SETTINGS = {"admittance": None, "gravity": GRAVITY, "rtol": 1e-6, "landing_speed": 1.0}


@dataclass(frozen=True, eq=False)
class Roller:
    """:func:`roll`'s arguments checked once, for a rolling solved in many calls (SI)."""

    plate: Plate
    mass: float
    law: ContactLaw
    admittance: float
    gravity: float
    rtol: float
    samplerate: int
    envelope: ContactEnvelope
    origin: tuple[float, float]
    direction: tuple[float, float]
    landing_speed: float

    @classmethod
    def over(cls, ball: Ball, plate: Plate, envelope: ContactEnvelope, *, samplerate: int, origin,
             direction=(1.0, 0.0), contact: str = "hertz", **options) -> Roller:  # fmt: skip
        """The :class:`Roller` of :func:`roll`'s arguments; ``options``: the law's and the
        :data:`SETTINGS`: ``admittance`` m/(N s) (0: rigid; default ``1 / Z_inf``), ``gravity``
        m/s^2, ``rtol`` in [1e-12, 1e-2] on penetration and vertical speed, ``landing_speed``
        (m/s): the fastest landing a step cannot miss (a step at most half its elastic contact,
        ``2 delta_max / u``, and a sample period)."""
        check_type("ball", ball, Ball)
        check_type("plate", plate, Plate)
        check_type("envelope", envelope, ContactEnvelope)
        if envelope.radius != ball.radius:
            raise ParameterError(
                f"envelope.radius={envelope.radius!r} must be the ball's radius "
                f"{ball.radius!r} (metres): make it with contact_envelope(profile, ball.radius)"
            )
        known = (*SETTINGS, "surface", *LAW_OPTIONS)  # the rest go to contact_parameters
        unknown = sorted(set(options) - set(known))
        if unknown:
            raise ParameterError(
                f"{unknown[0]}={options[unknown[0]]!r} is no option of a rolling: give one of "
                f"{', '.join(known)}"
            )
        o = {k: options.pop(k, default) for k, default in SETTINGS.items()}
        beta = (
            1.0 / impedance.infinite_plate_impedance(plate)
            if o["admittance"] is None
            else checks.nonnegative("admittance", o["admittance"], "m/(N s)")
        )
        return cls(
            plate, ball.mass, contact_parameters(ball, plate, contact, **options), beta,
            checks.positive_at_most("gravity", o["gravity"], MAX_GRAVITY, "m/s^2"),
            checks.in_range("rtol", o["rtol"], 1e-12, 1e-2, "dimensionless", lo_open=False,
                            hi_open=False),
            checks.samplerate(samplerate), envelope, checks.point("origin", origin, 2),
            _direction(direction), checks.positive("landing_speed", o["landing_speed"], "m/s"),
        )  # fmt: skip

    def roll(
        self,
        speed,
        *,
        duration: float | None = None,
        start: float | None = None,
        state: RollingState | None = None,
    ) -> RollingContact:
        """:func:`roll` with this roller's ball, plate, envelope and options."""
        speeds = _speeds(speed, duration, self.samplerate)
        if state is not None:
            if start is not None:
                raise ParameterError("give start or state, not both")
            if not isinstance(state, RollingState):
                raise ParameterError(f"state={state!r} must be a RollingState (a final_state)")
            s0 = float(state.vector[_k.S])
        else:
            s0 = 0.0 if start is None else checks.nonnegative("start", start, "metres")
        last = float(s0 + np.cumsum(speeds)[-1] / self.samplerate)
        if not 0.0 <= last <= self.envelope.length:
            raise ParameterError(
                f"speed={speed!r} from the path coordinate {s0!r} m reaches {last!r} m, "
                f"beyond the envelope's length {self.envelope.length!r} m"
            )
        self.check_reach(s0, last)
        return self._solve(speeds, s0, state)

    @property
    def max_step(self) -> float:
        """The largest step, s (see :meth:`over`'s ``landing_speed``)."""
        K, n, u = self.law.stiffness, self.law.exponent, self.landing_speed
        delta_max = ((n + 1.0) * self.mass * u * u / (2.0 * K)) ** (1.0 / (n + 1.0))
        return min(delta_max / u, 1.0 / self.samplerate)

    @property
    def static_penetration(self) -> float:
        """``(m g / K)^(1/n)``, m: the error control's scale."""
        return (self.mass * self.gravity / self.law.stiffness) ** (1.0 / self.law.exponent)

    @functools.cached_property
    def constants(self) -> _k.Constants:
        """The kernels' :class:`synth.physics.rolling_kernels.Constants`."""
        law = self.law
        return _k.Constants(
            self.mass, law.stiffness, law.exponent, law.dissipation, 1.5 * law.viscous_time,
            self.admittance, self.gravity, float(self.samplerate), self.rtol,
            self.static_penetration, self.max_step,
        )  # fmt: skip

    def initial_state(self, speed: float, start: float) -> RollingState:
        """The state and first step :func:`roll` starts from at ``start`` (m), ``speed`` (m/s)."""
        y, h = self.integrator_start(speed, start, None)
        return RollingState(read_only(y), float(h))

    def integrator_start(self, speed: float, start: float, state: RollingState | None):
        """State vector and first step (s) from ``state`` or at ``start`` (m), ``speed`` (m/s):
        pressed with ``F0 = m (g + v^2 e''(s0))`` in steady penetration, touching if ``F0 <= 0``."""
        m, g, beta = self.mass, self.gravity, self.admittance
        first = min(0.1 * math.sqrt(self.static_penetration / g), 1.0 / self.samplerate)
        if state is not None:
            return np.array(state.vector), (state.step if state.step is not None else first)
        v = float(speed)
        e, ep, epp = envelope_at(self.envelope.coefficients, self.envelope.spacing, start)
        F0 = m * (g + v * v * epp)
        y = np.zeros(_k.N_STATE)
        y[_k.S] = start
        y[_k.Z], y[_k.VY] = e, ep * v
        if F0 > 0.0:
            y[_k.Z] = e - (F0 / self.law.stiffness) ** (1.0 / self.law.exponent)
            y[_k.VY] = ep * v - beta * F0
        return y, first

    def contact_coordinates(self, centres: np.ndarray) -> np.ndarray:
        """The touching points' path coordinates (m) of the centre at ``centres`` (m)."""
        env = self.envelope
        centres = np.ascontiguousarray(centres, dtype=float)
        out = np.empty_like(centres)
        _k.touching_points(centres, env.contact_offsets, float(env.spacing), out)
        return out

    def points(self, coordinates: np.ndarray) -> np.ndarray:
        """The plate's points (m from its corner) at the path ``coordinates`` (m)."""
        (ox, oy), (ux, uy) = self.origin, self.direction
        return np.column_stack((ox + ux * coordinates, oy + uy * coordinates))

    def check_reach(self, first: float, last: float) -> None:
        """``ParameterError`` unless the touching points between ``first <= last`` (m) all lie
        on the convex plate: piecewise linear, their extremes are at the ends or samples."""
        env = self.envelope
        i0 = int(math.ceil(first / env.spacing))
        i1 = int(math.floor(last / env.spacing))
        nodes = _k.node_reach(env.contact_offsets, float(env.spacing), i0, i1)
        reach = np.concatenate((self.contact_coordinates(np.array([first, last])), nodes))
        points = self.points(np.array([np.min(reach), np.max(reach)]))
        a, b = self.plate.length, self.plate.width
        x, y = points[:, 0], points[:, 1]
        off = (x < 0.0) | (x > a) | (y < 0.0) | (y > b)
        if np.any(off):
            i = int(np.argmax(off))
            raise ParameterError(
                f"origin={self.origin!r} with direction={self.direction!r}: the contact point "
                f"({x[i]:.6g}, {y[i]:.6g}) m leaves the plate (x in [0, {a!r}], "
                f"y in [0, {b!r}] metres)"
            )

    def mechanical_energy(self, state: RollingState) -> float:
        """Mechanical energy (J) of the ball and its contact in ``state``."""
        y, m, n = state.vector, self.mass, self.law.exponent
        e, _, _ = envelope_at(self.envelope.coefficients, self.envelope.spacing, y[_k.S])
        delta = e - y[_k.Z]
        elastic = self.law.stiffness * delta ** (n + 1.0) / (n + 1.0) if delta > 0.0 else 0.0
        return 0.5 * m * y[_k.VY] ** 2 + m * self.gravity * (y[_k.Z] + y[_k.U]) + elastic

    def _solve(self, speeds, s0, state) -> RollingContact:
        """:func:`roll`'s integration from ``s0`` (m) or ``state`` over ``speeds`` (m/s)."""
        fs, N = self.samplerate, speeds.size
        y, h = self.integrator_start(speeds[0], s0, state)
        y0 = y.copy()
        # NaN where a failed integration did not reach; the path coordinate at each period's start
        forces, min_pen, path = np.full(N, np.nan), np.full(N, np.nan), np.full(N, np.nan)
        status, steps, rejected, flights, h = _k.roll(
            y, h, self.envelope.coefficients, self.envelope.spacing, speeds, self.constants,
            _k.MAX_STEPS_PER_SAMPLE * N, forces, min_pen, path,
        )  # fmt: skip
        E0 = self.mechanical_energy(RollingState(y0, None))
        E1 = self.mechanical_energy(RollingState(y, None))
        loss, plate_e, drive, gross = (
            y[i] - y0[i] for i in (_k.LOSS, _k.PLATE, _k.DRIVE, _k.GROSS)
        )
        scale = max(
            gross, loss + plate_e, abs(E1 - E0), self.mass * self.gravity * self.constants.delta_ref
        )
        balance = EnergyBalance(
            E0, E1, loss, plate_e, drive, gross, abs(E1 - E0 + loss + plate_e - drive) / scale
        )
        path += 0.5 * speeds / fs  # the middle of each period
        # the integrated path is the planned one (checked on the plate) within rounding
        reached = np.isfinite(path)
        coordinate = np.full(N, np.nan)
        coordinate[reached] = self.contact_coordinates(path[reached])
        points = self.points(coordinate)
        final = RollingState(read_only(y.copy()), float(h))
        for a in (forces, path, coordinate, points, min_pen, speeds):
            a.setflags(write=False)
        return RollingContact(
            fs, forces, path, coordinate, points, min_pen, int(flights), balance, self.law,
            self.admittance, speeds, self.origin, self.direction, self.mass,
            self.constants.delta_ref, status == _k.OK, int(status), status_message(status),
            int(steps), int(rejected), final,
        )  # fmt: skip


def status_message(status: int) -> str:
    """What the integrator's ``status`` (:mod:`synth.physics.rolling_kernels`' codes) says."""
    return _MESSAGES.get(int(status), "Unknown status.")


def _speeds(speed, duration, fs) -> np.ndarray:
    """The speed of every sample period (m/s), from one speed and a duration (s) or an array."""
    if np.ndim(speed) == 0:
        v = checks.nonnegative("speed", speed, "m/s")
        if duration is None:
            raise ParameterError("a single speed needs duration (s)")
        T = checks.positive_at_most("duration", duration, MAX_DURATION, "s")
        n = int(round(T * fs))
        if not 1 <= n <= MAX_SAMPLES:
            raise ParameterError(
                f"duration={duration!r} at samplerate={fs!r} gives {n} samples; a rolling "
                f"call covers 1 to {MAX_SAMPLES} samples"
            )
        return np.full(n, v)
    if duration is not None:
        raise ParameterError("speeds per sample set the duration: give no duration")
    return samples("speed", speed, 1, MAX_SAMPLES, "m/s", nonnegative=True)


@dataclass(frozen=True)
class LossOfContactSpeed:
    """The speed (m/s) at which a rolling ball leaves the surface: the bracket's middle."""

    speed: float
    low: float
    high: float
    rolls: int
    success: bool
    message: str


def loss_of_contact_speed(
    roller: Roller, *, start: float, stop: float, low: float, high: float, tolerance: float = 1e-3
) -> LossOfContactSpeed:
    """The lowest speed (m/s) at which the ball rolling from ``start`` to ``stop`` (m) leaves the
    surface (the thesis, section 6.2), by bisection between ``low`` and ``high`` to the relative
    ``tolerance`` in (0, 0.1]. A random surface may change more than once; the bracket holds one."""
    check_type("roller", roller, Roller)
    v_lo = checks.positive("low", low, "m/s")
    v_hi = checks.positive("high", high, "m/s")
    if not v_hi > v_lo:
        raise ParameterError(f"high={high!r} must be > low={low!r} (m/s)")
    tol = checks.in_range("tolerance", tolerance, 0.0, 0.1, "dimensionless", hi_open=False)
    s0 = checks.nonnegative("start", start, "metres")
    s1 = checks.real("stop", stop, "metres")
    if not s1 > s0:
        raise ParameterError(f"stop={stop!r} must be > start={start!r} (metres)")
    rolls = 0

    def leaves(v):
        nonlocal rolls
        rolls += 1
        # the last sample ends at or before ``stop``
        fs = roller.samplerate
        r = roller.roll(v, duration=math.floor((s1 - s0) / v * fs) / fs, start=s0)
        if not r.success:
            raise _RollFailed(f"at speed {v!r} m/s: {r.message}")
        return bool(np.any(r.contact_lost))

    def result(success, message):
        return LossOfContactSpeed(0.5 * (v_lo + v_hi), v_lo, v_hi, rolls, success, message)

    try:
        if leaves(v_lo):
            return result(False, f"The ball already leaves the surface at low={low!r} m/s.")
        if not leaves(v_hi):
            return result(False, f"The ball stays on the surface at high={high!r} m/s.")
        while v_hi - v_lo > tol * v_hi:
            mid = 0.5 * (v_lo + v_hi)
            if leaves(mid):
                v_hi = mid
            else:
                v_lo = mid
    except _RollFailed as err:
        return result(False, f"A rolling failed {err}")
    return result(True, "Bracketed to the tolerance.")


class _RollFailed(Exception):
    """A rolling of the bisection did not reach its end (reported in the result)."""
