"""The path of a ball released with a horizontal velocity (docs/rolling.md, "The ball's path"):
bounces gripping at each impact, then rolling until it stops, leaves the plate or time ends."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from synth.errors import ParameterError, SynthError
from synth.physics import rolling as rolling_contact
from synth.physics import rolling_kernels as _k
from synth.physics import surface
from synth.physics.bounces import DEFAULT_MAX_IMPACTS, BounceSequence, Impact
from synth.physics.contact import ContactSolver
from synth.physics.scene import Scene

#: Length of the rolling's blocks, s: the speed is updated from the roughness' work after each.
BLOCK_SECONDS = 0.01
#: Moment of inertia of a solid sphere over ``m R^2``.
SPHERE_INERTIA = 0.4
#: The rolling sphere's kinetic energy over ``m v^2``: ``(1 + I / (m R^2)) / 2``.
ROLLING_ENERGY = 0.5 * (1.0 + SPHERE_INERTIA)
#: How a path ends; the first three by the rolling kernel's codes.
ENDS = ("max-duration", "stopped", "left-plate", "max-impacts")
#: Blocks of the rolling solved in one call of its kernel.
CHUNK_BLOCKS = 256


@dataclass(frozen=True, eq=False)
class RollingPart:
    """The rolling on the grid of ``samplerate`` (Hz) from ``start`` (s): per period ``force``
    (N), ``contact_coordinate`` (m) and ``speed`` (m/s); ``final_force`` (N); ``flights``."""

    samplerate: int
    start: float
    force: np.ndarray
    contact_coordinate: np.ndarray
    speed: np.ndarray
    final_force: float
    energy: RollingEnergy
    flights: int

    @property
    def duration(self) -> float:
        """How long the ball rolled, s."""
        return self.force.size / self.samplerate


@dataclass(frozen=True)
class RollingEnergy:
    """Where the rolling's energy went (J): ``initial - final`` = loss + plate + resistance."""

    initial: float
    final: float
    contact_loss: float
    plate_energy: float
    resistance_work: float
    roughness_work: float

    @property
    def residual(self) -> float:
        """``|initial - final - losses|`` relative to ``initial``."""
        lost = self.contact_loss + self.plate_energy + self.resistance_work
        return abs(self.initial - self.final - lost) / max(abs(self.initial), 1e-300)


@dataclass(frozen=True, eq=False)
class BallPath:
    """A ball's path: ``impacts`` at ``impact_points`` (I, 2; m) along ``origin + s direction``
    (m); ``rolling_speed`` (m/s); ``rolling`` (None if the ball left or ran out of time); the
    ``end`` (:data:`ENDS`), ``end_time`` (s) and ``end_point`` (m)."""

    impacts: BounceSequence
    impact_points: np.ndarray
    origin: tuple[float, float]
    direction: tuple[float, float]
    rolling_speed: float
    rolling: RollingPart | None
    end: str
    end_time: float
    end_point: tuple[float, float]


def grip(speed: float, spin: float, radius: float) -> float:
    """Horizontal speed (m/s) after a gripping impact, ``(5 v + 2 R w) / 7``: ``radius`` R (m),
    ``speed`` v (m/s), ``spin`` w (rad/s)."""
    return (speed + SPHERE_INERTIA * radius * spin) / (1.0 + SPHERE_INERTIA)


def edge_distance(plate, origin, direction) -> float:
    """Distance (m) from ``origin`` (on the plate) along the unit ``direction`` to its edge."""
    out = math.inf
    for p, u, size in (
        (origin[0], direction[0], plate.length),
        (origin[1], direction[1], plate.width),
    ):
        if u > 0.0:
            out = min(out, (size - p) / u)
        elif u < 0.0:
            out = min(out, -p / u)
    return out


@dataclass(frozen=True, eq=False)
class PathBounces:
    """The bounces up to the rolling: ``impacts`` at ``points`` (m), line ``origin`` (m) and
    unit ``direction``, ``speed`` after the grip (m/s), ``edge`` distance (m), the last
    contact's end (s, m) and ``rebound_speed`` (m/s; None: no separation)."""

    impacts: BounceSequence
    points: np.ndarray
    origin: tuple[float, float]
    direction: tuple[float, float]
    speed: float
    edge: float
    separation_time: float
    separation_position: float
    rebound_speed: float | None

    @property
    def rolls(self) -> bool:
        """Whether the ball rolls after these bounces (it is still on the plate)."""
        return self.impacts.stop_reason in ("settled", "flight-shorter-than-contact")

    def point(self, s: float) -> tuple[float, float]:
        """The point ``s`` m along the line, m from the plate's corner."""
        return _along(self.origin, self.direction, s)


def _along(origin, direction, s: float) -> tuple[float, float]:
    """The point ``s`` m from ``origin`` (m) along the unit ``direction``."""
    return (origin[0] + direction[0] * s, origin[1] + direction[1] * s)


def path_bounces(scene: Scene, *, max_duration: float = 30.0) -> PathBounces:
    """The bounces of ``scene`` until it rolls, leaves the plate or passes ``max_duration`` (s)."""
    if not isinstance(scene, Scene) or not scene.moving:
        raise ParameterError(f"scene={scene!r} must be a Scene with a non-zero velocity")
    ball, plate, g, c = scene.ball, scene.plate, scene.gravity, scene.contact
    speed = math.hypot(*scene.velocity)
    u = (scene.velocity[0] / speed, scene.velocity[1] / speed)
    origin = scene.position
    s_edge = edge_distance(plate, origin, u)
    solver = ContactSolver.for_pair(
        ball, plate, gravity=g, law=c.law, rtol=c.rtol, n_points=128, **c.options()
    )

    def ended(reason, time, position, rebound):
        sequence = BounceSequence(tuple(impacts), reason, scene.drop_height, g)
        return PathBounces(
            sequence, np.array(points), origin, u, speed, s_edge, time, position, rebound
        )

    t = math.sqrt(2.0 * scene.drop_height / g)
    v = math.sqrt(2.0 * g * scene.drop_height)
    s = speed * t
    spin = 0.0
    t_sep, s_sep = t, s  # the last contact's end (before the first: the first touch)
    impacts, points = [], []
    if s > s_edge:
        raise ParameterError(
            f"drop.velocity={scene.velocity!r} from drop.position={origin!r}: the ball lands "
            f"{s:.4g} m along its path, off the plate (its edge is {s_edge:.4g} m away)"
        )
    while True:
        if len(impacts) >= DEFAULT_MAX_IMPACTS:
            return ended("max-impacts", t_sep, s_sep, v)
        res = solver.solve(v, position=_along(origin, u, s))
        if not res.success:
            raise SynthError(
                f"impact {len(impacts) + 1} (at {v:.4g} m/s) could not be solved: {res.message}"
            )
        impacts.append(Impact(len(impacts) + 1, t, v, res))
        points.append(_along(origin, u, s))
        speed = grip(speed, spin, ball.radius)
        spin = speed / ball.radius
        t_sep = t + res.separation_time
        s_sep = s + speed * res.separation_time
        if res.settled:
            return ended("settled", t_sep, s_sep, None)
        v_out = res.rebound_speed
        flight = 2.0 * v_out / g
        if flight < res.separation_time:
            return ended("flight-shorter-than-contact", t_sep, s_sep, v_out)
        if t_sep + flight > max_duration:
            return ended("max-duration", t_sep, s_sep, v_out)
        if s_sep + speed * flight > s_edge:
            return ended("left-plate", t_sep, s_sep, v_out)
        t, s, v = t_sep + flight, s_sep + speed * flight, v_out


def simulate_path(
    scene: Scene, *, samplerate: int, time_origin: float = 0.0, max_duration: float = 30.0
) -> BallPath:
    """The :class:`BallPath` of ``scene``, the rolling on the grid of ``samplerate`` (Hz)
    through ``time_origin`` (s), followed to ``max_duration`` (s from the release)."""
    b = path_bounces(scene, max_duration=max_duration)
    part, end, end_time, end_point = None, b.impacts.stop_reason, b.separation_time, None
    if b.rolls:
        part, end, end_time, end_s = _roll(scene, b, int(samplerate), time_origin, max_duration)
        end_point = b.point(end_s)
    end_point = tuple(b.points[-1]) if end_point is None else end_point
    return BallPath(b.impacts, b.points, b.origin, b.direction, b.speed, part, end, end_time,
                    end_point)  # fmt: skip


def _profile(rolling, length):
    """The plate's profile along ``length`` m of path (:class:`synth.physics.scene.Rolling`)."""
    spectrum = rolling.spectrum()
    if spectrum is None:
        n = int(math.ceil(length / rolling.spacing)) + 1
        return surface.Profile(np.zeros(max(n, 4)), rolling.spacing, "smooth")
    try:
        return surface.rough_profile(
            spectrum, length=length, spacing=rolling.spacing, seed=rolling.seed
        )
    except ParameterError as exc:  # the spectrum's keys are the [rolling] section's
        raise ParameterError(f"rolling.{exc}") from None


def _roll(scene, bounces: PathBounces, fs, time_origin, max_duration):
    """The rolling after ``bounces``: its part, end, time (s) and coordinate (m)."""
    ball, g, c, rolling = scene.ball, scene.gravity, scene.contact, scene.rolling
    s_edge, speed, v_out = bounces.edge, bounces.speed, bounces.rebound_speed
    t_sep, s_sep = bounces.separation_time, bounces.separation_position
    R, m = ball.radius, ball.mass
    # the first sample boundary at or after the separation
    j0 = math.ceil((t_sep - time_origin) * fs - 1e-9)
    start = time_origin + j0 / fs
    d = start - t_sep
    s0 = s_sep + speed * d
    envelope, behind, x_end = _envelope_ahead(rolling, R, s0, s_edge)
    path_origin = bounces.point(behind)
    x0 = s0 - behind
    if v_out is None:
        state = None
    else:
        # ballistic from the separation: at most a sample's fall into the surface
        state = rolling_contact.RollingState.at(
            envelope, path_position=x0, height=v_out * d - 0.5 * g * d * d,
            vertical_velocity=v_out - g * d,
        )  # fmt: skip
    roller = rolling_contact.Roller.over(
        ball, scene.plate, envelope, samplerate=fs, origin=path_origin,
        direction=bounces.direction, contact=c.law, gravity=g, **c.options(),
    )  # fmt: skip
    if x0 < x_end:
        # every block's centre stays in [x0, x_end] (block_speeds): checked once for all
        roller.check_reach(x0, x_end)
    decel = c_rr_deceleration(rolling.resistance, g)
    block = max(1, int(round(BLOCK_SECONDS * fs)))
    n_max = max(0, int(math.floor((max_duration - start) * fs + 1e-9)))
    # the first block's speeds: the first one starts a ball rolled there (without a state)
    first = np.empty(min(block, n_max))
    count, code = _k.block_speeds(speed, decel, first.size, float(fs), x0, x_end, first)
    if count == 0:
        return None, ENDS[code], t_sep, s_sep
    y, h = roller.integrator_start(float(first[0]), x0, state)
    m_kinetic = ROLLING_ENERGY * m
    e_initial = (
        roller.mechanical_energy(rolling_contact.RollingState(y, h)) + m_kinetic * speed * speed
    )
    drive = _k.Drive(decel, block, x_end, m_kinetic, rolling.resistance * m * g)
    chunks, tallies, scratch = [], np.zeros(4), np.empty(block)
    v, n_done, flights, end = speed, 0, 0, "max-duration"
    while n_done < n_max:
        # the blocks in chunks of whole blocks: each chunk's arrays are written in place
        chunk = np.empty((3, min(n_max - n_done, block * CHUNK_BLOCKS)))
        status, code, count, h, v, lost = _k.roll_blocks(
            y, h, envelope.coefficients, envelope.spacing, roller.constants, drive, v,
            chunk.shape[1], chunk, scratch, tallies,
        )  # fmt: skip
        chunks.append(chunk[:, :count])
        n_done += count
        flights += int(lost)
        if status != _k.OK:
            raise SynthError(
                f"the rolling from {start + n_done / fs:.4g} s: "
                f"{rolling_contact.status_message(status)}"
            )
        end = ENDS[code]
        if code != _k.RUNNING:
            break
    v = 0.0 if end == "stopped" else v
    e_final = roller.mechanical_energy(rolling_contact.RollingState(y, h)) + m_kinetic * v * v
    energy = RollingEnergy(e_initial, e_final, *(float(t) for t in tallies))
    forces, centres, speeds = np.concatenate(chunks, axis=1)
    # the touching points of every period at once (as roll gives them)
    coordinate = roller.contact_coordinates(centres) + behind
    final_force = 0.0 if end == "left-plate" else m * g
    part = RollingPart(fs, start, forces, coordinate, speeds, final_force, energy, flights)
    return part, end, start + n_done / fs, float(coordinate[-1])


#: Most profile samples of the envelopes kept for the next paths (48 bytes a sample).
ENVELOPE_CACHE_SAMPLES = 2_000_000
#: The envelopes kept, most recent last: ``(key, envelope)``, ``key`` what makes them.
_ENVELOPES: list = []
_ENVELOPES_LOCK = threading.Lock()


def _envelope(rolling, length, radius):
    """:func:`make_envelope`, cached (a seeded profile is a pure function of its arguments)."""
    key = (rolling.rms_height, rolling.correlation_length, rolling.hurst, rolling.seed,
           rolling.spacing, float(length), float(radius))  # fmt: skip
    with _ENVELOPES_LOCK:
        for i, (k, envelope) in enumerate(_ENVELOPES):
            if k == key:
                _ENVELOPES.append(_ENVELOPES.pop(i))
                return envelope
    envelope = make_envelope(rolling, length, radius)
    with _ENVELOPES_LOCK:
        _ENVELOPES.append((key, envelope))
        while sum(e.heights.size for _, e in _ENVELOPES) > ENVELOPE_CACHE_SAMPLES:
            _ENVELOPES.pop(0)
    return envelope


def make_envelope(rolling, length, radius):
    """The contact envelope of a ball of ``radius`` (m) along ``length`` m, made afresh."""
    return surface.contact_envelope(_profile(rolling, length), radius)


def _envelope_ahead(rolling, radius, s0, s_edge):
    """The envelope from a ``radius`` (m) behind ``s0`` to beyond the edge at ``s_edge`` (m),
    its first sample's coordinate (m) and the last centre coordinate on the plate (m)."""
    behind = s0 - radius
    length = s_edge - behind + radius
    if rolling.spacing * 4 > length:
        raise ParameterError(
            f"rolling.spacing={rolling.spacing!r} m: the path left to roll, {length:.4g} m, "
            f"needs at least 4 samples"
        )
    if length / rolling.spacing > surface.MAX_PROFILE_SAMPLES:
        raise ParameterError(
            f"rolling.spacing={rolling.spacing!r} m: the path left to roll, {length:.4g} m, "
            f"needs more than {surface.MAX_PROFILE_SAMPLES} samples; use a larger spacing"
        )
    envelope = _envelope(rolling, length, radius)
    reach = float(np.max(np.abs(envelope.contact_offsets)))
    return envelope, behind, (s_edge - behind) - reach - rolling.spacing


def c_rr_deceleration(resistance: float, gravity: float) -> float:
    """Deceleration (m/s^2) of a rolling solid sphere by ``C_rr m g``: ``-(5/7) C_rr g``."""
    return resistance * gravity / (2.0 * ROLLING_ENERGY)
