"""The bounce sequence: impacts strung together by free flight (docs/physics.md, "Bounces"),
``t_(n+1) = t_n + tau_n + 2 v_out,n / g`` (air drag negligible, thesis appendix A.2), each
impact solved at its own speed, until "settled", "flight-shorter-than-contact", "floor",
"max-duration" or "max-impacts"."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

from synth import checks
from synth.constants import DEFAULT_FLOOR_DB, DEFAULT_MAX_IMPACTS, GRAVITY
from synth.errors import ParameterError
from synth.physics.contact import ContactSolver, ImpactResult
from synth.physics.contact_kernels import BOUNCE_ENDS, NO_END, bounce_end
from synth.physics.scene import Ball, Plate, Scene, check_type

STOP_REASONS = tuple(end for end in BOUNCE_ENDS if end != "handed-over")


@dataclass(frozen=True)
class Impact:
    """One impact: ``index`` (from 1), ``time`` (s from release), ``speed`` (m/s), ``result``;
    ``restitution`` that set the next flight (a rebound rule's if given); ``plate_state`` the
    modal plate's ringing at first touch (None: at rest)."""

    index: int
    time: float
    speed: float
    result: ImpactResult
    restitution: float | None = None
    plate_state: object | None = None

    @property
    def plate_velocity(self) -> float:
        """Velocity of the plate's surface under the ball at first touch, m/s, upward."""
        return 0.0 if self.plate_state is None else self.plate_state.velocity

    def __post_init__(self):
        if self.restitution is None:
            object.__setattr__(self, "restitution", self.result.restitution)


@dataclass(frozen=True)
class BounceSequence:
    """A drop's ``impacts`` in order, ``stop_reason``, ``drop_height`` (m), ``gravity`` (m/s^2)."""

    impacts: tuple[Impact, ...]
    stop_reason: str
    drop_height: float
    gravity: float

    def __len__(self):
        return len(self.impacts)

    def __iter__(self):
        return iter(self.impacts)

    def __getitem__(self, i):
        return self.impacts[i]

    @property
    def duration(self) -> float:
        """End of the last contact (its separation), s from release."""
        if not self.impacts:
            return 0.0
        last = self.impacts[-1]
        return last.time + last.result.separation_time

    def table(self) -> list[dict]:
        """One row per impact: n, time (s), speed (m/s), restitution, contact_time (s), peak_force
        (N), max_penetration (m), inelasticity, settled."""
        return [
            dict(n=i.index, time=i.time, speed=i.speed, restitution=i.restitution,
                 contact_time=i.result.contact_time, peak_force=i.result.peak_force,
                 max_penetration=i.result.max_penetration,
                 inelasticity=i.result.inelasticity, settled=i.result.settled)
            for i in self.impacts
        ]  # fmt: skip


#: A rebound rule: the restitution ``e'`` (dimensionless) that sets the flight after an
#: impact, from its solution and speed (m/s); ``e' <= 0`` ends the sequence.
ReboundRule = Callable[[ImpactResult, float], float]


@dataclass(frozen=True)
class BounceOptions:
    """How :func:`simulate_bounces` solves each impact and ends: ``rtol``; ``n_points`` >= 64;
    ``max_frequency`` of the modal band, Hz; ``floor_db`` < 0; ``max_duration`` > 0 (latest
    impact start, s); ``max_impacts`` >= 1; ``rebound``, a :data:`ReboundRule` replacing each
    flight's restitution while every impact is solved at its own speed."""

    rtol: float = 1e-6
    n_points: int = 128
    max_frequency: float | None = None
    floor_db: float = DEFAULT_FLOOR_DB
    max_duration: float = 60.0
    max_impacts: int = DEFAULT_MAX_IMPACTS
    rebound: ReboundRule | None = None

    def __post_init__(self):
        floor = checks.in_range("floor_db", self.floor_db, -math.inf, 0.0, "dB re the first tick")
        object.__setattr__(self, "floor_db", floor)
        object.__setattr__(
            self, "max_duration", checks.positive("max_duration", self.max_duration, "s")
        )
        checks.integer_at_least("max_impacts", self.max_impacts, 1)
        if self.rebound is not None and not callable(self.rebound):
            raise ParameterError(
                f"rebound={self.rebound!r} must be a callable (ImpactResult, speed) -> "
                f"restitution, or None"
            )

    @classmethod
    def split(cls, options: dict) -> tuple[dict, dict]:
        """``options`` parted into a ``BounceOptions``' fields and the rest (the contact law's)."""
        names = {f.name for f in dataclasses.fields(cls)}
        mine = {k: v for k, v in options.items() if k in names}
        return mine, {k: v for k, v in options.items() if k not in names}

    @property
    def energy_floor(self) -> float:
        """The lowest ratio of an impact's kinetic energy to the first's (``floor_db``)."""
        return 10.0 ** (self.floor_db / 10.0)


#: The plate models of the contact (see :func:`simulate_bounces`).
PLATE_MODELS = ("impedance", "modal")


def simulate_bounces(
    ball: Ball,
    plate: Plate,
    *,
    drop_height: float,
    position: tuple[float, float] | None = None,
    gravity: float = GRAVITY,
    contact_law: str | None = None,
    plate_model: str = "impedance",
    options: BounceOptions | None = None,
    **overrides,
) -> BounceSequence:
    """Drop ``ball`` on ``plate`` from ``drop_height`` (m, its lowest point) until the sequence
    ends. ``position``: m from a corner (None: far from the edges); ``gravity``: m/s^2;
    ``contact_law`` (None: the ball's own) with its parameters in ``overrides``;
    ``plate_model``: "impedance" (blended towards measured values near free edges) or "modal"
    (the finite plate's ringing modes); ``options``: :class:`BounceOptions`."""
    check_type("ball", ball, Ball)
    check_type("plate", plate, Plate)
    h0 = checks.positive("drop_height", drop_height, "metres")
    g = checks.positive("gravity", gravity, "m/s^2")
    given, contact_options = BounceOptions.split(overrides)
    o = dataclasses.replace(options or BounceOptions(), **given)
    pos = None if position is None else plate.check_position(position, "position")
    checks.choice("plate_model", plate_model, PLATE_MODELS)
    t, v = math.sqrt(2.0 * h0 / g), math.sqrt(2.0 * g * h0)
    if plate_model == "modal":
        series = _ModalSeries(ball, plate, pos, v, g, o, contact_law, contact_options)
    else:
        if o.max_frequency is not None:
            raise ParameterError(
                f"max_frequency={o.max_frequency!r} applies to plate_model='modal' only (Hz)"
            )
        solver = ContactSolver.for_pair(
            ball, plate, gravity=g, law=contact_law, rtol=o.rtol, n_points=o.n_points,
            **contact_options,
        )  # fmt: skip
        series = _Series(solver, pos, v, g, o)
        if o.rebound is None:
            # the elastic rest in one compiled call, as far as it serves (ContactSolver.solve_drop)
            t, v = series.compiled(t, v)
    if series.reason is None:
        series.run(t, v)
    return BounceSequence(tuple(series.impacts), series.reason or "max-impacts", h0, g)


class _Series:
    """The impacts of one drop; :meth:`run` is the one bounce loop."""

    def __init__(self, solver, position, v1: float, gravity: float, o: BounceOptions):
        self.solver, self.position, self.v1, self.gravity, self.o = solver, position, v1, gravity, o
        self.impacts: list[Impact] = []
        self.reason: str | None = None

    def run(self, t: float, v: float) -> None:
        """Impacts from the one at ``v`` (m/s) ``t`` s after release while the ball lands."""
        o, rule = self.o, self.o.rebound
        while v > 0.0:
            if len(self.impacts) >= o.max_impacts:
                self.reason = "max-impacts"
                return
            res, plate_state = self.impact(v)
            e = float(res.restitution if rule is None else rule(res, v))
            flight_e = max(e, 0.0) if not res.settled else 0.0
            self.impacts.append(Impact(len(self.impacts) + 1, t, v, res, flight_e, plate_state))
            v_out = res.rebound_speed if rule is None else e * v
            self.reason, t, v = self.flight(t, res, e, float(v_out))

    def impact(self, v: float):
        """The impact at ``v`` (m/s) and the plate's state at first touch (None: at rest)."""
        return self.solver.solve(v, position=self.position), None

    def flight(self, t: float, res: ImpactResult, e: float, v_out: float):
        """``(reason, t, v)`` after impact ``res`` at ``t`` (s), restitution ``e``, take-off
        ``v_out`` (m/s): why the series ends (None: on), the next start (s) and speed (m/s)."""
        o = self.o
        end, t_next = bounce_end(
            float(t), self.v1, float(self.gravity), res.success, res.settled, e, v_out,
            res.separation_time, o.energy_floor, float(o.max_duration),
        )  # fmt: skip
        return (None, t_next, v_out) if end == NO_END else (BOUNCE_ENDS[end], t, 0.0)

    def compiled(self, t: float, v: float):
        """Physical impacts from ``v`` (m/s) at ``t`` (s), one call; the ``(t, v)`` handed over."""
        o = self.o
        if len(self.impacts) >= o.max_impacts:
            self.reason = "max-impacts"
            return t, v
        drop = self.solver.solve_drop(
            v, t, position=self.position, energy_floor=o.energy_floor * (self.v1 / v) ** 2,
            max_duration=o.max_duration, max_impacts=o.max_impacts - len(self.impacts),
        )  # fmt: skip
        for time_, speed, res in zip(drop.times, drop.speeds, drop.results):
            flight_e = max(res.restitution, 0.0) if not res.settled else 0.0
            self.impacts.append(Impact(len(self.impacts) + 1, time_, speed, res, flight_e))
        if drop.end != "handed-over":
            self.reason = drop.end
        return drop.next_time, drop.next_speed


class _ModalSeries(_Series):
    """The series with the finite plate's modes ringing between impacts (rigid body: supports)."""

    def __init__(self, ball, plate, pos, v1, g, o, law, contact_options):
        from synth.physics import modal_contact

        contact = modal_contact.ModalContact.for_pair(
            ball, plate, pos, gravity=g, law=law, max_frequency=o.max_frequency, speed=v1,
            **contact_options,
        )  # fmt: skip
        super().__init__(contact, pos, v1, g, o)
        self.state = contact.at_rest()

    def impact(self, v: float):
        return self.solver.solve(v, self.state, n_points=self.o.n_points), self.state

    def flight(self, t: float, res, e: float, v_out: float):
        """Landing on the ringing plate: "settled" if it meets the ball rising."""
        from synth.physics.modal_contact import next_touch

        o = self.o
        e_end = 1.0 if o.rebound is None else e  # a physical flight ends by the rules below
        end, _ = bounce_end(
            0.0, self.v1, float(self.gravity), True, res.settled, e_end, v_out,
            res.separation_time, o.energy_floor, math.inf,
        )  # fmt: skip
        if end != NO_END:
            return BOUNCE_ENDS[end], t, 0.0
        flight, self.state = next_touch(self.solver, res.ringing, res.ringing.displacement, v_out)
        v_next = self.gravity * flight - v_out
        if not v_next > 0.0:
            return "settled", t, 0.0
        t_next = t + res.separation_time + flight
        if t_next > o.max_duration:
            return "max-duration", t, 0.0
        return None, t_next, v_next


def simulate_scene(scene: Scene, **options) -> BounceSequence:
    """:func:`simulate_bounces` for a :class:`~synth.physics.scene.Scene`; with a horizontal
    velocity its bounces until it rolls (only option: ``max_duration``)."""
    check_type("scene", scene, Scene)
    from synth.physics.plate_choice import scene_plate

    if scene.moving:
        return _moving_scene_bounces(scene, options)
    c = scene.contact
    plate = scene_plate(scene).plate  # contact.plate, or the choice of "auto"
    return simulate_bounces(
        scene.ball, scene.plate, drop_height=scene.drop_height, position=scene.position,
        gravity=scene.gravity, contact_law=c.law, rtol=c.rtol,
        **({"plate_model": plate} if plate != "impedance" else {}),
        **({"theory": c.theory} if c.theory != "kirchhoff" and plate == "modal" else {}),
        **c.options(), **options,
    )  # fmt: skip


def _moving_scene_bounces(scene: Scene, options: dict) -> BounceSequence:
    """:func:`simulate_scene` of a scene with a horizontal velocity."""
    from synth.physics.path import path_bounces

    other = sorted(set(options) - {"max_duration"})
    if other:
        raise ParameterError(
            f"{other[0]}={options[other[0]]!r}: a scene with drop.velocity takes only "
            f"max_duration (s) here; its bounces follow its path (synth.physics.path)"
        )
    return path_bounces(scene, **options).impacts
